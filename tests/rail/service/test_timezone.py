"""A site's loggers on local time: naive times read in the site's zone, the autumn hour shown twice kept twice.

Session 35's probe: a logger on naive local time sent the repeated hour at the end of daylight-saving time again,
and the service stored it as 348 revisions of the first hour (the first hour superseded, the settlement 0.45 mm
off). The oracle here is the zone database (``zoneinfo``), not the service: each scan gets a true UTC time, the
logger writes it as the local wall-clock time of the zone, and what the service stores must be the true UTC times.
"""

from __future__ import annotations

from datetime import datetime, timedelta, timezone
from zoneinfo import ZoneInfo

import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sqlalchemy import select

from longprofile.errors import InputError
from longprofile.rail.service import _core
from longprofile.rail.service._db import Reading

from .conftest import count_readings

NOW = 2_000_000_000
PARIS = ZoneInfo("Europe/Paris")
#: 2019-10-27: the clock in Paris goes back from 03:00 CEST to 02:00 CET at 01:00 UTC.
FALL_START = datetime(2019, 10, 26, 23, 0, tzinfo=timezone.utc)


def _local_scans(r, start, n, step_min=10, zone=PARIS):
    """The site's first ``n`` scans re-timed every ``step_min`` minutes from ``start`` (UTC), each as the logger
    writes it (naive local time in ``zone``), with the true UTC seconds."""
    scans = [g for _, g in r.groupby("timestamp", sort=True)][:n]
    out = []
    for k, g in enumerate(scans):
        t = start + timedelta(minutes=step_min * k)
        local = t.astimezone(zone).replace(tzinfo=None).isoformat()
        out.append(([{**x, "timestamp": local} for x in g.to_dict("records")], int(t.timestamp())))
    return out


def _stored_times(db) -> list[int]:
    with db.read() as s:
        return sorted(set(s.scalars(select(Reading.ts))))


def test_a_local_time_logger_posting_each_scan_across_the_autumn_change_loses_nothing(site):
    db, _, r = site
    _core.update_site(db, "t", "mitt", timezone="Europe/Paris")
    scans = _local_scans(r, FALL_START, 18)  # 23:00Z-01:50Z: local 01:00-02:50 CEST, then 02:00-02:50 CET again
    locals_ = [rows[0]["timestamp"] for rows, _ in scans]
    assert len(set(locals_)) < len(locals_)  # the logger's clock does show the hour twice
    results = [_core.ingest(db, "mitt", rows, now=NOW) for rows, _ in scans]
    assert all(res.counts["accepted"] == len(rows) for res, (rows, _) in zip(results, scans))
    assert sum(res.counts["revised"] for res in results) == 0
    assert _stored_times(db) == [ts for _, ts in scans]
    second = [res for res, (_, ts) in zip(results, scans) if ts >= int(FALL_START.timestamp()) + 7200]
    assert second and all("read as the second" in res.rows[0]["note"] for res in second)
    again = [_core.ingest(db, "mitt", rows, now=NOW) for rows, _ in scans]  # the whole night sent again
    assert all(res.counts["duplicate"] == len(rows) for res, (rows, _) in zip(again, scans))
    assert count_readings(db) == sum(len(rows) for rows, _ in scans)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cuts=st.lists(st.integers(1, 17), max_size=4, unique=True))
def test_any_split_of_the_night_into_batches_in_order_stores_the_true_times(site, cuts):
    db, _, r = site
    name = f"tz{abs(hash(tuple(cuts))) % 10**9}"
    _core.create_site(db, "t", name, clock="data", timezone="Europe/Paris")
    _core.put_sensors(db, "t", name, [{k: x[k] for k in ("sensor_id", "x_m", "z_m")} for x in _sensors(db)])
    scans = _local_scans(r, FALL_START, 18)
    edges = [0, *sorted(cuts), len(scans)]
    for a, b in zip(edges[:-1], edges[1:]):
        rows = [x for rows, _ in scans[a:b] for x in rows]
        res = _core.ingest(db, name, rows, now=NOW)
        assert res.counts["accepted"] == len(rows), res.rows[:3]
    with db.read() as s:
        site_id = _core._site(s, name).id
        stored = sorted(set(s.scalars(select(Reading.ts).where(Reading.site_id == site_id))))
    assert stored == [ts for _, ts in scans]


def _sensors(db):
    return _core.get_site(db, "mitt")["sensors"]


def test_a_time_the_clock_skips_in_spring_is_rejected_and_utc_sites_are_unchanged(site):
    db, _, r = site
    rows = [{**x, "timestamp": "2019-03-31T02:30:00"} for x in r.iloc[:5].to_dict("records")]
    assert _core.ingest(db, "mitt", rows, now=NOW).counts["accepted"] == 5  # UTC site: naive = UTC, as before
    _core.update_site(db, "t", "mitt", timezone="Europe/Paris")
    res = _core.ingest(db, "mitt", [{**x, "timestamp": "2019-03-31T02:40:00"} for x in rows], now=NOW)
    assert res.counts["rejected"] == 5 and "does not exist in Europe/Paris" in res.rows[0]["reason"]
    summer = _core.ingest(db, "mitt", [{**x, "timestamp": "2019-07-01T12:00:00"} for x in rows], now=NOW)
    assert summer.counts["accepted"] == 5
    offset = _core.ingest(db, "mitt", [{**x, "timestamp": "2019-07-02T12:00:00+02:00"} for x in rows], now=NOW)
    assert offset.counts["accepted"] == 5  # a time with its offset is that instant, whatever the site's zone
    times = _stored_times(db)
    assert int(pd.Timestamp("2019-07-01T10:00:00Z").timestamp()) in times  # 12:00 CEST = 10:00 UTC
    assert int(pd.Timestamp("2019-07-02T10:00:00Z").timestamp()) in times


def test_a_prompt_local_time_logger_in_summer_is_no_longer_in_the_future(site):
    db, _, r = site
    rows = [{**x, "timestamp": "2019-07-01T12:00:00"} for x in r.iloc[:5].to_dict("records")]
    now = int(pd.Timestamp("2019-07-01T10:05:00Z").timestamp())  # sent five minutes after 12:00 CEST
    res = _core.ingest(db, "mitt", rows, now=now)
    assert res.counts["rejected"] == 5 and "in the future" in res.rows[0]["reason"]  # read as UTC
    _core.update_site(db, "t", "mitt", timezone="Europe/Paris")
    assert _core.ingest(db, "mitt", rows, now=now).counts["accepted"] == 5


def test_an_unknown_zone_is_refused(site):
    db, _, _ = site
    with pytest.raises(InputError, match="unknown time zone 'Europe/Pariss'"):
        _core.update_site(db, "t", "mitt", timezone="Europe/Pariss")
    assert _core.get_site(db, "mitt")["timezone"] == "UTC"
