"""Ingestion: idempotent on (sensor, timestamp), revisions kept, late data, per-row rejection reasons."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sqlalchemy import func, select

from longprofile.rail.service import _core
from longprofile.rail.service._db import Reading, ReadingRevision, Site

from .conftest import count_readings

NOW = 2_000_000_000  # 2033: every synthetic reading is in the past


def test_migrations_match_the_models(db):
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext

    from longprofile.rail.service._db import Base

    with db.engine.connect() as c:
        diffs = compare_metadata(MigrationContext.configure(c), Base.metadata)
    assert diffs == []
    db.migrate()  # idempotent at start-up


def test_sqlite_is_in_wal_mode(tmp_path):
    from longprofile.rail.service._db import Database

    d = Database(f"sqlite:///{tmp_path}/w.db")
    with d.engine.connect() as c:
        assert c.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
    d.dispose()


def test_resent_batch_creates_no_duplicate(site):
    db, _, r = site
    rows = r.iloc[:1000].to_dict("records")
    a = _core.ingest(db, "mitt", rows, now=NOW)
    assert a.counts == {"accepted": 1000, "duplicate": 0, "revised": 0, "rejected": 0}
    b = _core.ingest(db, "mitt", rows, now=NOW)
    assert b.counts == {"accepted": 0, "duplicate": 1000, "revised": 0, "rejected": 0}
    assert count_readings(db) == 1000


def test_changed_value_is_a_revision_not_an_overwrite(site):
    db, _, r = site
    rows = r.iloc[:10].to_dict("records")
    _core.ingest(db, "mitt", rows, now=NOW)
    changed = [dict(x) for x in rows[:3]]
    for x in changed:
        x["angle_deg"] += 0.01
    res = _core.ingest(db, "mitt", changed, now=NOW)
    assert res.counts["revised"] == 3 and all(o["outcome"] == "revised" for o in res.rows)
    assert res.rows[0]["previous"]["angle_deg"] == pytest.approx(rows[0]["angle_deg"])
    assert count_readings(db) == 10
    with db.read() as s:
        revs = s.execute(select(ReadingRevision.angle_deg, ReadingRevision.revision)).all()
        cur = s.execute(select(func.max(Reading.revision))).scalar()
    assert sorted(a for a, _ in revs) == pytest.approx(sorted(x["angle_deg"] for x in rows[:3]))
    assert cur == 1
    # the revised value sent again is a duplicate
    assert _core.ingest(db, "mitt", changed, now=NOW).counts["duplicate"] == 3


def test_out_of_order_and_late_data_are_stored_by_measurement_time(site):
    db, _, r = site
    from sqlalchemy import update

    with db.write() as s:  # as after a recompute: nothing pending
        s.execute(update(Site).values(dirty_from_ts=None))
    r = r.sort_values("timestamp", kind="stable")
    late = r.iloc[2000:2500].to_dict("records")
    early = r.iloc[:500].to_dict("records")
    _core.ingest(db, "mitt", late, now=NOW)
    with db.read() as s:
        first_dirty = s.scalar(select(Site.dirty_from_ts))
    rng = np.random.default_rng(0)
    shuffled = [early[i] for i in rng.permutation(len(early))]
    res = _core.ingest(db, "mitt", shuffled, now=NOW)
    assert res.counts["accepted"] == 500
    with db.read() as s:
        dirty = s.scalar(select(Site.dirty_from_ts))
        keys = s.execute(select(Reading.sensor_pk, Reading.ts)).all()
    ts = [k[1] for k in keys]
    assert dirty < first_dirty
    assert dirty == min(ts)
    assert len(keys) == 1000 == len(set(keys))


def test_bad_rows_are_rejected_with_reasons_and_nothing_else_is_lost(site):
    db, _, r = site
    good = r.iloc[:20].to_dict("records")
    bad = [
        {"timestamp": "yesterday", "sensor_id": "S1", "angle_deg": 0.1, "temperature_c": 5},
        {"timestamp": "2019-11-18T00:00:00Z", "sensor_id": "NOPE", "angle_deg": 0.1, "temperature_c": 5},
        {"timestamp": "2019-11-18T00:00:00Z", "sensor_id": "S1", "angle_deg": "abc", "temperature_c": 5},
        {"timestamp": "2019-11-18T00:00:00Z", "sensor_id": "S1", "angle_deg": float("nan"), "temperature_c": 5},
        {"timestamp": "2040-01-01T00:00:00Z", "sensor_id": "S1", "angle_deg": 0.1, "temperature_c": 5},
        {"timestamp": "2019-11-18T00:00:00Z", "sensor_id": "S1", "angle_rad": 0.001, "temperature_c": 5},
        {"timestamp": "2019-11-18T00:00:00Z", "sensor_id": "S1", "angle_deg": 120.0, "temperature_c": 5},
        {"timestamp": "2019-11-18T00:00:00.5Z", "sensor_id": "S1", "angle_deg": 0.1, "temperature_c": 5},
        "not an object",
        {**good[0], "angle_deg": good[0]["angle_deg"] + 1.0},  # conflicts with row 0 in the same batch
        dict(good[1]),  # exact repeat inside the batch
    ]
    res = _core.ingest(db, "mitt", good + bad, now=NOW)
    out = res.rows[20:]
    assert [o["outcome"] for o in out] == ["rejected"] * 10 + ["duplicate"]
    reasons = [o["reason"] for o in out]
    for needle, reason in zip(["ISO 8601", "unknown sensor", "not a number", "finite", "future", "angle_deg",
                               "plausible range", "sub-second", "object", "conflicts with row 0"], reasons):
        assert needle in reason, (needle, reason)
    assert res.counts["accepted"] == 20 and count_readings(db) == 20


def test_radians_are_rejected_unless_declared(site):
    db, _, r = site
    rows = r.iloc[:1000].to_dict("records")
    rad = [{**x, "angle_deg": float(np.deg2rad(x["angle_deg"]))} for x in rows]
    res = _core.ingest(db, "mitt", rad, now=NOW)
    assert res.counts["rejected"] == 1000 and "radians" in res.rows[0]["reason"]
    assert count_readings(db) == 0
    res = _core.ingest(db, "mitt", rad, angle_unit="rad", now=NOW)
    assert res.counts["accepted"] == 1000
    with db.read() as s:
        got = sorted(s.scalars(select(Reading.angle_deg)))
    assert got == pytest.approx(sorted(x["angle_deg"] for x in rows), rel=1e-12)


def test_degrees_sent_as_radians_or_millidegrees_are_rejected(site):
    """The batch check of `track_angle` (as validate_site on files): sleeper inclinometers read a few degrees from
    level; degrees declared as radians (x 57.3) or millidegrees under angle_deg read tens to thousands."""
    db, _, r = site
    rows = r.iloc[:1000].to_dict("records")
    res = _core.ingest(db, "mitt", rows, angle_unit="rad", now=NOW)
    assert res.counts["rejected"] == 1000 and "without ?angle_unit=rad" in res.rows[0]["reason"]
    mdeg = [{**x, "angle_deg": 1000.0 * x["angle_deg"]} for x in rows if abs(x["angle_deg"]) < 0.09]
    res = _core.ingest(db, "mitt", mdeg, now=NOW)  # each within the row range, the batch far from level
    assert res.counts["rejected"] == len(mdeg) > 0 and "another unit" in res.rows[0]["reason"]
    assert count_readings(db) == 0
    assert _core.ingest(db, "mitt", rows, now=NOW).counts["accepted"] == 1000


def test_csv_and_json_batches_parse_to_the_same_rows(site):
    db, _, r = site
    part = r.iloc[:50]
    a = _core.parse_batch(part.to_csv(index=False).encode(), "text/csv")
    b = _core.parse_batch(json.dumps({"readings": part.to_dict("records")}).encode(), "application/json")
    assert _core.ingest(db, "mitt", a, now=NOW).counts["accepted"] == 50
    assert _core.ingest(db, "mitt", b, now=NOW).counts["duplicate"] == 50
    for body, ctype in ((b"{", "application/json"), (b"a,b\n1,2\n", "text/csv"), (b"x", "image/png"),
                        (b'{"readings": 3}', "application/json")):
        with pytest.raises(_core.InputFormatError):
            _core.parse_batch(body, ctype)


def test_a_reading_without_a_temperature_is_stored_and_a_bad_one_refused(site):
    """A failed temperature channel: an empty (CSV) or null (JSON) temperature keeps the row, stored with a NULL
    temperature (each recompute fills it from the nearest sensors, docs/rail.md); a temperature that is there but
    wrong is still refused."""
    db, _, r = site
    part = r.iloc[:40].copy()
    part.loc[part.index[:10], "temperature_c"] = np.nan
    rows = _core.parse_batch(part.to_csv(index=False).encode(), "text/csv")
    res = _core.ingest(db, "mitt", rows, now=NOW)
    assert res.counts["accepted"] == 40, res.rows[:3]
    js = json.loads(json.dumps({"readings": part.iloc[:10].to_dict("records")}).replace("NaN", "null"))
    assert _core.ingest(db, "mitt", js["readings"], now=NOW).counts["duplicate"] == 10  # null = empty: same rows
    with db.read() as s:
        temps = s.execute(select(Reading.temperature_c)).scalars().all()
    assert sum(t is None for t in temps) == 10
    bad = [{**part.iloc[20].to_dict(), "temperature_c": v} for v in ("warm", float("inf"), 300.0)]
    out = _core.ingest(db, "mitt", bad, now=NOW)
    assert out.counts["rejected"] == 3 and "temperature_c" in out.rows[0]["reason"]
    # a logger's marker for a failed channel (Campbell Scientific: "NAN") is an empty temperature, as in `rail settle`
    marked = [{**part.iloc[k].to_dict(), "temperature_c": v} for k, v in zip(range(10), ("NAN", "n/a", "#N/A", "null",
                                                                                        " NaN ", "", None, "nan", "NA",
                                                                                        "None"))]
    assert _core.ingest(db, "mitt", marked, now=NOW).counts["duplicate"] == 10  # the same rows as the empty ones
    out = _core.ingest(db, "mitt", [{**part.iloc[21].to_dict(), "temperature_c": -9999}], now=NOW)
    assert out.counts["rejected"] == 1 and "plausible range" in out.rows[0]["reason"]


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_any_resending_pattern_stores_each_key_exactly_once(tmp_path_factory, data):
    from longprofile.rail.service._db import Database

    from .conftest import synthetic

    syn, r = synthetic()
    db = Database(f"sqlite:///{tmp_path_factory.mktemp('h')}/h.db")
    _core.create_site(db, "t", "mitt")
    _core.put_sensors(db, "t", "mitt", syn.sensors.to_dict("records"))
    pool = r.iloc[:300].to_dict("records")
    idx = data.draw(st.lists(st.integers(0, len(pool) - 1), min_size=1, max_size=600))
    cuts = sorted(data.draw(st.lists(st.integers(0, len(idx)), max_size=6)))
    sent = set()
    acked = 0
    for a, b in zip([0] + cuts, cuts + [len(idx)]):
        batch = [pool[i] for i in idx[a:b]]
        if batch:
            res = _core.ingest(db, "mitt", batch, now=NOW)
            acked += res.counts["accepted"]
            assert res.counts["rejected"] == 0 and res.counts["revised"] == 0
            sent.update(idx[a:b])
    assert count_readings(db) == len(sent) == acked
    db.dispose()


def test_a_two_reading_batch_in_degrees_is_not_taken_for_radians(site):
    """Hypothesis found it: two readings 1e-5 deg apart were refused as radians (one difference decided)."""
    db, _, r = site
    rows = r.iloc[:1].to_dict("records")
    second = {**rows[0], "timestamp": "2019-11-18T00:10:00Z", "angle_deg": rows[0]["angle_deg"] + 1e-5}
    res = _core.ingest(db, "mitt", rows + [second], now=NOW)
    assert res.counts["rejected"] == 0 and res.counts["accepted"] == 2, res.rows


def test_radians_sent_one_scan_at_a_time_are_caught_from_the_stored_readings(site):
    """A logger posting each scan (one reading per sensor: no noise of its own) in radians: every batch was accepted
    and the settlement came out 57 times too small (session 35, a probe). The stored readings of the batch's
    sensors within 6 hours give the test its differences: the second scan on is refused."""
    db, _, r = site
    scans = [g for _, g in r.groupby("timestamp", sort=True)][:4]
    outcomes = []
    for g in scans:
        rad = [{**x, "angle_deg": float(np.deg2rad(x["angle_deg"]))} for x in g.to_dict("records")]
        outcomes.append(_core.ingest(db, "mitt", rad, now=NOW))
    assert outcomes[0].counts["accepted"] == len(scans[0])  # nothing to compare the first scan with
    assert all(o.counts["rejected"] == o.counts["accepted"] + o.counts["rejected"] for o in outcomes[1:])
    assert "radians" in outcomes[1].rows[0]["reason"]
    degrees = [g.to_dict("records") for g in [x for _, x in r.groupby("timestamp", sort=True)][4:8]]
    assert all(_core.ingest(db, "mitt", rows, now=NOW).counts["accepted"] == len(rows) for rows in degrees)


def test_a_batch_mixing_times_with_and_without_an_offset_is_refused(site):
    db, _, r = site
    rows = r.iloc[:10].to_dict("records")
    assert str(rows[0]["timestamp"]).endswith("Z")
    rows[3] = {**rows[3], "timestamp": str(rows[3]["timestamp"])[:-1]}  # one time without its "Z"
    with pytest.raises(_core.InputFormatError, match="mixes times with a UTC offset"):
        _core.ingest(db, "mitt", rows, now=NOW)
    assert count_readings(db) == 0


@pytest.mark.parametrize(("body", "ctype", "match"), [
    ("timestamp,sensor_id,angle_deg,temperature_c\n2019-11-18 00:00:00," + "S" * 200_000 + ",0.1,3.0\n", "text/csv",
     "CSV batch, line"),
    ("timestamp,sensor_id,angle_deg,temperature_c\n2019-11-18 00:00:00,Capteur_\u00e9,0.1,3.0\n".encode("cp1252"),
     "text/csv", r"not utf-8 text: line 2 \('2019-11-18 00:00:00,Capteur_\u00e9"),
])
def test_odd_csv_batches_are_one_clear_refusal(body, ctype, match):
    with pytest.raises(_core.InputFormatError, match=match):
        _core.parse_batch(body.encode() if isinstance(body, str) else body, ctype)


def test_a_declared_charset_is_honoured_and_rows_with_extra_fields_or_dates_out_of_range_are_rejected(site):
    db, _, _ = site
    body = "timestamp,sensor_id,angle_deg,temperature_c\n2019-11-18T00:00:00Z,S01,0.1,3.0\n".encode("cp1252")
    assert _core.parse_batch(body, "text/csv; charset=windows-1252")[0]["sensor_id"] == "S01"
    rows = _core.parse_batch(b"timestamp,sensor_id,angle_deg,temperature_c,note\n"
                             b"2019-11-18T00:00:00Z,S01,0.1,3.0,a,EXTRA\n", "text/csv")
    rows += [{"timestamp": "0001-01-01T00:00:00+01:00", "sensor_id": "S01", "angle_deg": 0.1, "temperature_c": 3.0},
             {"timestamp": "2019-11-18T00:00:00Z", "sensor_id": "S01", "angle_deg": 0.1, "temperature_c": -9999}]
    res = _core.ingest(db, "mitt", rows, now=NOW)
    reasons = [o["reason"] for o in res.rows]
    assert res.counts["rejected"] == 3
    assert "6 fields, more than the header's 5" in reasons[0]
    assert "out of the range of dates" in reasons[1]
    assert "a logger's code for a missing value" in reasons[2]


def test_a_sensor_id_in_another_script_is_registered(site):
    db, _, _ = site
    # within the survey (0..167.5 m): a sensor outside it is refused since session 36
    assert _core.put_sensors(db, "tester", "mitt", [{"sensor_id": "Capteur_\u00e94", "x_m": 1.0}])
    with pytest.raises(_core.InputError, match="starting with a letter or digit"):
        _core.put_sensors(db, "tester", "mitt", [{"sensor_id": "_x", "x_m": 1.5}])
