"""Recompute through estimate_settlement, versioned runs, three-level alarms on transitions, ack, clear, outbox."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from sqlalchemy import select

from longprofile.errors import InputError
from longprofile.rail import estimate_settlement, validate_site
from longprofile.rail.service import _core
from longprofile.rail.service._alarms import acknowledge, list_alarms
from longprofile.rail.service._db import Outbox, ResultRow, Run
from longprofile.rail.service._recompute import ALL_DAYS_MAX_SENSOR_DAYS, recompute, service_joint_days

from .conftest import synthetic

NOW = 2_000_000_000


def _ingest_days(db, r, upto_day):
    days = r["timestamp"].str[:10]
    part = r[days <= upto_day]
    for i in range(0, len(part), 2000):
        _core.ingest(db, "mitt", part.iloc[i:i + 2000].to_dict("records"), now=NOW)


def _two_runs(db, r, first_upto):
    """Ingest the readings up to ``first_upto`` and recompute, then the rest and recompute again (the per-day cache
    carried over); returns the second run's outcome, checked ok."""
    _ingest_days(db, r, first_upto)
    assert recompute(db, "mitt")["status"] == "ok"
    _ingest_days(db, r, sorted(r["timestamp"].str[:10].unique())[-1])
    out = recompute(db, "mitt")
    assert out["status"] == "ok", out["message"]
    return out


def _stored_against(db, run_id, ref) -> pd.DataFrame:
    """The run's stored (date, sensor) rows merged with ``ref.to_table()`` (columns ``_ref``): one per day and sensor."""
    with db.read() as s:
        rows = pd.DataFrame(s.execute(select(ResultRow.day, ResultRow.sensor_id, ResultRow.dz_m, ResultRow.dz_std_m)
                                      .where(ResultRow.run_id == run_id)).all(),
                            columns=["date", "sensor_id", "dz_m", "dz_std_m"])
    got = rows.merge(ref.to_table(), on=["date", "sensor_id"], suffixes=("", "_ref"))
    assert len(got) == ref.days.size * len(ref.sensor_ids)
    return got


def test_stored_results_are_those_of_estimate_settlement(site):
    db, _, r = site
    syn, _ = synthetic()
    _core.ingest(db, "mitt", r.to_dict("records"), now=NOW)
    out = recompute(db, "mitt")
    assert out["status"] == "ok", out["message"]
    n_days = pd.to_datetime(syn.readings["timestamp"]).dt.normalize().nunique()
    joint = service_joint_days({}, syn.sensors.shape[0], n_days)  # "auto": a small site gets the all-days model
    assert joint and syn.sensors.shape[0] * n_days <= ALL_DAYS_MAX_SENSOR_DAYS
    ref = estimate_settlement(validate_site(syn.sensors, syn.readings, syn.survey), n_monte_carlo=0,
                               joint_days=joint)  # the service's model, what `rail settle` runs by default
    assert ref.settings["joint_days"]
    with db.read() as s:
        assert s.get(Run, out["run_id"]).model == "all-days"
    with db.read() as s:
        rows = pd.DataFrame(s.execute(select(ResultRow.day, ResultRow.sensor_id, ResultRow.dz_m, ResultRow.dz_std_m,
                                             ResultRow.smoothed_dz_m, ResultRow.rate_m_per_day)
                                      .where(ResultRow.run_id == out["run_id"])).all(),
                            columns=["date", "sensor_id", "dz_m", "dz_std_m", "smoothed_dz_m", "rate_m_per_day"])
    tab = ref.to_table()
    got = rows.merge(tab, on=["date", "sensor_id"], suffixes=("", "_ref"))
    assert len(got) == len(tab) == ref.days.size * len(ref.sensor_ids)
    for c in ("dz_m", "dz_std_m", "smoothed_dz_m"):
        np.testing.assert_allclose(got[c], got[c + "_ref"], rtol=1e-9, atol=1e-12)
    assert out["data_complete_to"] == r["timestamp"].max()


def test_model_setting_chooses_the_settlement_model_and_the_run_records_it(site):
    db, _, r = site
    syn, _ = synthetic()
    _core.ingest(db, "mitt", r.to_dict("records"), now=NOW)
    _core.update_site(db, "tester", "mitt", settings={"model": "per-day"})
    out = recompute(db, "mitt")
    ref = estimate_settlement(validate_site(syn.sensors, syn.readings, syn.survey), n_monte_carlo=0, joint_days=False)
    with db.read() as s:
        assert s.get(Run, out["run_id"]).model == "per-day"
        dz = dict(s.execute(select(ResultRow.sensor_id, ResultRow.dz_m).where(
            ResultRow.run_id == out["run_id"], ResultRow.day == str(ref.days[-1])[:10])).all())
    tab = ref.to_table()
    last = tab[tab["date"] == tab["date"].max()]
    np.testing.assert_allclose([dz[k] for k in last["sensor_id"]], last["dz_m"], rtol=1e-9, atol=1e-12)
    with pytest.raises(InputError, match="model must be one of auto, all-days, per-day"):
        _core.update_site(db, "tester", "mitt", settings={"model": "joint"})


def test_auto_model_is_all_days_up_to_the_size_limit():
    assert service_joint_days({}, 100, 366)  # a year-long 100-sensor site: the all-days model within 2 s (2026-12-06)
    assert service_joint_days({}, 100, ALL_DAYS_MAX_SENSOR_DAYS // 100)
    assert not service_joint_days({}, 100, ALL_DAYS_MAX_SENSOR_DAYS // 100 + 1)
    assert service_joint_days({"model": "all-days"}, 100, 365) and not service_joint_days({"model": "per-day"}, 5, 10)


def test_runs_are_versioned_and_skip_when_nothing_changed(site):
    db, _, r = site
    _ingest_days(db, r, "2019-11-22")
    a = recompute(db, "mitt")
    assert a["status"] == "ok"
    assert recompute(db, "mitt")["status"] == "unchanged"
    # one late reading of an early day: a new run that records the earliest changed time
    late = r[r["timestamp"].str[:10] == "2019-11-23"].iloc[:1].to_dict("records")
    late[0]["timestamp"] = "2019-11-19T12:34:56Z"
    _core.ingest(db, "mitt", late, now=NOW)
    b = recompute(db, "mitt")
    assert b["status"] == "ok" and b["run_id"] > a["run_id"]
    with db.read() as s:
        runs = list(s.scalars(select(Run).order_by(Run.id)))
    assert runs[-1].changed_from_ts == int(pd.Timestamp("2019-11-19T12:34:56").value // 10**9)
    assert runs[-1].data_version > runs[0].data_version
    assert runs[-1].code_version and len(runs[-1].settings_hash) == 32
    # a settings change is a new settings hash
    _core.update_site(db, "t", "mitt", settings={"thermal": "none"})
    c = recompute(db, "mitt")
    with db.read() as s:
        assert s.get(Run, c["run_id"]).settings_hash != runs[-1].settings_hash


def test_too_little_data_is_a_waiting_run(site):
    db, _, r = site
    _ingest_days(db, r, "2019-11-18")
    out = recompute(db, "mitt")
    assert out["status"] == "waiting" and "2 days" in out["message"]


def test_alarm_levels_raise_on_transitions_ack_and_clear(site):
    db, _, r = site
    _core.add_channel(db, "t", "mitt", "webhook", "http://127.0.0.1:9/hook")
    _core.add_channel(db, "t", "mitt", "smtp", "track@example.org")
    _core.ingest(db, "mitt", r.to_dict("records"), now=NOW)
    out = recompute(db, "mitt")
    syn, _ = synthetic()
    worst = -syn.truth.settlement[-1].min()  # ~ 0.015 m on day 8 of the preset
    for lv, f in (("alert", 0.2), ("action", 0.4), ("alarm", 3.0)):
        _core.set_threshold(db, "t", "mitt", "settlement", lv, f * worst)
    out = recompute(db, "mitt")
    al = [a for a in list_alarms(db, "mitt") if a["quantity"] == "settlement"]
    assert [(a["level"], a["state"]) for a in al] == [("action", "raised")], al
    assert "at S" in al[0]["message"]
    # same level again: de-duplicated, no new alarm, no new notification
    with db.read() as s:
        n_out = len(list(s.scalars(select(Outbox))))
    recompute(db, "mitt", force=True)
    assert len([a for a in list_alarms(db, "mitt") if a["quantity"] == "settlement"]) == 1
    with db.read() as s:
        assert len(list(s.scalars(select(Outbox)))) == n_out
    acked = acknowledge(db, al[0]["id"], "eng1", "crew informed")
    assert (acked["state"], acked["ack_by"], acked["ack_comment"]) == ("acknowledged", "eng1", "crew informed")
    with pytest.raises(_core.InputError):
        acknowledge(db, al[0]["id"], "eng1", "twice")
    # thresholds raised above the value: the alarm clears (a transition, notified)
    _core.set_threshold(db, "t", "mitt", "settlement", "alarm", 10 * worst)
    _core.set_threshold(db, "t", "mitt", "settlement", "action", 9 * worst)
    _core.set_threshold(db, "t", "mitt", "settlement", "alert", 8 * worst)
    recompute(db, "mitt")
    al = [a for a in list_alarms(db, "mitt") if a["quantity"] == "settlement"]
    assert [a["state"] for a in al] == ["cleared"]
    with db.read() as s:
        ev = [(o.event, o.kind) for o in s.scalars(select(Outbox).order_by(Outbox.id))
              if '"settlement"' in o.payload_json]
    assert ev == [("raised", "webhook"), ("raised", "smtp"), ("cleared", "webhook"), ("cleared", "smtp")]
    # the reversed and the dead sensor of the preset are sensor-health alarms
    health = {a["subject"] for a in list_alarms(db, "mitt") if a["quantity"] == "health"}
    assert set(syn.truth.bad_sensors) <= health


def test_no_data_alarm_for_a_silent_sensor(site):
    db, _, r = site
    quiet = r[~((r["sensor_id"] == "S40") & (r["timestamp"] >= "2019-11-24"))]
    _core.update_site(db, "t", "mitt", no_data_hours=12)
    _core.ingest(db, "mitt", quiet.to_dict("records"), now=NOW)
    recompute(db, "mitt")
    nd = [a for a in list_alarms(db, "mitt") if a["quantity"] == "no_data"]
    assert [a["subject"] for a in nd] == ["S40"] and "no data from sensor S40" in nd[0]["message"]
    # the data arrive: the alarm clears
    _core.ingest(db, "mitt", r.to_dict("records"), now=NOW)
    recompute(db, "mitt")
    assert [a["state"] for a in list_alarms(db, "mitt") if a["quantity"] == "no_data"] == ["cleared"]


def test_stored_readings_load_as_the_table_sent(site):
    """load_site_data (chunked Core fetch) returns every stored reading with the sent values, bit for bit."""
    from longprofile.rail.service._db import Site
    from longprofile.rail.service._recompute import load_site_data

    db, _, r = site
    r = r.iloc[:3000].copy()
    _core.ingest(db, "mitt", r.to_dict("records"), now=NOW)
    with db.read() as s:
        st = s.scalar(select(Site).where(Site.name == "mitt"))
        _, got, _ = load_site_data(s, st, chunk=1000)  # several chunks
    sent = r.assign(timestamp=pd.to_datetime(r["timestamp"]).dt.tz_localize(None))
    key = ["sensor_id", "timestamp"]
    got = got.sort_values(key).reset_index(drop=True)
    sent = sent.sort_values(key).reset_index(drop=True)
    assert len(got) == len(sent) == 3000
    np.testing.assert_array_equal(got["sensor_id"].to_numpy(), sent["sensor_id"].to_numpy())
    np.testing.assert_array_equal(got["angle_deg"].to_numpy(), sent["angle_deg"].to_numpy(dtype=float))
    np.testing.assert_array_equal(got["temperature_c"].to_numpy(), sent["temperature_c"].to_numpy(dtype=float))


def test_the_thermal_model_chosen_by_the_data_runs_as_rail_settle_runs_it(site):
    """A site's ``thermal: auto`` setting (rail settle's default): the run reads every reading, as with the lagged
    model, and stores what ``estimate_settlement(thermal="auto")`` gives (on this site, without a thermal lag, the
    linear model's numbers); a thermal model the service does not know is refused with the list."""
    db, _, r = site
    syn, _ = synthetic()
    with pytest.raises(InputError, match="linear, lagged, none or auto"):
        _core.update_site(db, "tester", "mitt", settings={"thermal": "warm"})
    _core.update_site(db, "tester", "mitt", settings={"thermal": "auto"})
    _core.ingest(db, "mitt", r.to_dict("records"), now=NOW)
    out = recompute(db, "mitt")
    assert out["status"] == "ok", out["message"]
    n_days = pd.to_datetime(syn.readings["timestamp"]).dt.normalize().nunique()
    ref = estimate_settlement(validate_site(syn.sensors, syn.readings, syn.survey), n_monte_carlo=0, thermal="auto",
                              joint_days=service_joint_days({}, syn.sensors.shape[0], n_days))
    assert ref.settings["thermal"] == "linear"
    with db.read() as s:
        rows = pd.DataFrame(s.execute(select(ResultRow.day, ResultRow.sensor_id, ResultRow.dz_m)
                                      .where(ResultRow.run_id == out["run_id"])).all(),
                            columns=["date", "sensor_id", "dz_m"])
    got = rows.merge(ref.to_table(), on=["date", "sensor_id"], suffixes=("", "_ref"))
    assert len(got) == ref.days.size * len(ref.sensor_ids)
    np.testing.assert_allclose(got["dz_m"], got["dz_m_ref"], rtol=1e-9, atol=1e-12)


def test_a_logger_outage_is_treated_as_missing_as_rail_settle_does(site):
    """Ten sensors silent for two days (a logger outage; a run during it and one after, the per-day cache carried
    over): the stored results are ``estimate_settlement``'s on the same readings, whose all-days model treats the
    missing sensor-days as missing (docs/rail.md, "Logger outages")."""
    db, _, r = site
    syn, _ = synthetic()
    days = r["timestamp"].str[:10]
    ud = sorted(days.unique())
    gone = (r["sensor_id"].isin(list(syn.sensors["sensor_id"])[20:30]) & days.isin(ud[3:5])).to_numpy()
    _ingest_days(db, r[~gone], ud[4])
    assert recompute(db, "mitt")["status"] == "ok"
    _ingest_days(db, r[~gone], ud[-1])
    out = recompute(db, "mitt")
    assert out["status"] == "ok", out["message"]
    ref = estimate_settlement(validate_site(syn.sensors, syn.readings[~gone].reset_index(drop=True), syn.survey),
                              n_monte_carlo=0)
    assert ref.settings["joint_days"] and any("treat them as missing" in w for w in ref.warnings)
    got = _stored_against(db, out["run_id"], ref)
    for c in ("dz_m", "dz_std_m"):
        np.testing.assert_allclose(got[c], got[c + "_ref"], rtol=1e-9, atol=1e-12)


def test_a_failed_temperature_channel_is_filled_as_rail_settle_does(site):
    """Two sensors send angles without a temperature (a failed channel, from day 3 on) and one a stuck temperature
    (from day 2 on; a run before and one after, the per-day cache carried over): ingestion keeps the rows, and the stored results are ``estimate_settlement``'s
    on the same readings, whose temperatures ``validate_site`` fills from the nearest sensors (docs/rail.md, "A
    failed temperature channel")."""
    db, _, r = site
    syn, _ = synthetic()
    days = r["timestamp"].str[:10]
    ud = sorted(days.unique())
    ids = list(syn.sensors["sensor_id"])
    failed = (r["sensor_id"].isin([ids[11], ids[31]]) & (days >= ud[3])).to_numpy()
    stuck = ((r["sensor_id"] == ids[40]) & (days >= ud[2])).to_numpy()  # a channel stuck at one value
    r = r.copy()
    r.loc[failed, "temperature_c"] = np.nan
    r.loc[stuck, "temperature_c"] = 9.5
    out = _two_runs(db, r, ud[4])
    readings = syn.readings.copy()
    readings.loc[failed, "temperature_c"] = np.nan
    readings.loc[stuck, "temperature_c"] = 9.5
    site_data = validate_site(syn.sensors, readings, syn.survey)
    assert any("no usable temperature" in w for w in site_data.warnings)
    assert any("stuck temperature channel" in w and ids[40] in w for w in site_data.warnings)
    ref = estimate_settlement(site_data, n_monte_carlo=0)
    got = _stored_against(db, out["run_id"], ref)
    assert (got.loc[got["sensor_id"].isin([ids[11], ids[31]]), "status"] != "dead").all()  # they are kept
    with db.read() as s:  # the run says so, as `rail settle` does (for the readings of its recompute window)
        warned = s.get(Run, out["run_id"]).warnings_json
    assert "no usable temperature" in warned and "stuck temperature channel" in warned
    for c in ("dz_m", "dz_std_m"):
        np.testing.assert_allclose(got[c], got[c + "_ref"], rtol=1e-9, atol=1e-12)


def test_a_channel_failed_long_before_the_window_takes_its_offset_from_before_the_failure(db):
    """A sensor that reads 2 degC above its neighbours (shade, a probe's offset) loses its channel on day 2 of 14.
    The second run recomputes from day 12 only, ten days after the failure: its filled temperatures still take the
    sensor's offset from the week before the failure (the service reads those days again, ``_fill_history``), and
    the stored results are ``rail settle``'s on the same readings (docs/rail.md, "The sensor's offset")."""
    from longprofile.rail import fill_temperature

    syn, r = synthetic(n_days=14)
    _core.create_site(db, "tester", "mitt", clock="data")
    _core.put_sensors(db, "tester", "mitt", syn.sensors.to_dict("records"))
    _core.put_survey(db, "tester", "mitt", syn.survey.to_dict("records"))
    days = r["timestamp"].str[:10]
    ud = sorted(days.unique())
    sid = list(syn.sensors["sensor_id"])[20]
    mine = (r["sensor_id"] == sid).to_numpy()
    failed = mine & (days >= ud[2]).to_numpy()
    r = r.copy()
    r.loc[mine, "temperature_c"] += 2.0
    r.loc[failed, "temperature_c"] = np.nan
    out = _two_runs(db, r, ud[11])
    with db.read() as s:
        assert s.get(Run, out["run_id"]).changed_from_ts >= pd.Timestamp(ud[12]).value // 10**9  # incremental
    readings = syn.readings.copy()
    readings.loc[mine, "temperature_c"] += 2.0
    readings.loc[failed, "temperature_c"] = np.nan
    filled = fill_temperature(readings, syn.sensors)[0]["temperature_c"].to_numpy()
    plain = syn.readings["temperature_c"].to_numpy()
    assert abs(np.mean(filled[failed] - plain[failed]) - 2.0) < 0.2  # the offset is carried
    ref = estimate_settlement(validate_site(syn.sensors, readings, syn.survey), n_monte_carlo=0)
    got = _stored_against(db, out["run_id"], ref)
    for c in ("dz_m", "dz_std_m"):
        np.testing.assert_allclose(got[c], got[c + "_ref"], rtol=1e-9, atol=1e-12)
    from longprofile.rail.service._recompute import _active_sensors, _filled, _readings_frame

    full = fill_temperature(readings.assign(timestamp=pd.to_datetime(readings["timestamp"])), syn.sensors)[0]
    with db.read() as s:  # any window, whole days or not: the rows of the whole record's fill
        site_row = _core._site(s, "mitt")
        sens = _active_sensors(s, site_row)
        for start in (ud[5], ud[9] + " 13:00", ud[12], ud[13] + " 06:00"):
            t = pd.Timestamp(start).value // 10**9
            frame = _filled(s, site_row, _readings_frame(s, site_row, sens, from_ts=t), from_ts=t)
            want = full[full["timestamp"] >= pd.Timestamp(start)]
            got_t = frame.merge(want, on=["timestamp", "sensor_id"], suffixes=("", "_want"))
            assert len(got_t) == len(frame) == len(want)
            np.testing.assert_allclose(got_t["temperature_c"], got_t["temperature_c_want"], rtol=0, atol=1e-12)


def test_the_fill_of_any_window_is_the_whole_records(db):
    """The service fills a recompute window's readings (``_filled`` with ``from_ts``) as ``fill_temperature`` fills the
    whole record, for 20 random window starts (whole days or not): one channel empty from day 3, one stuck from day
    9, one intermittent (a third of its readings empty from day 5), each sensor with its own offset."""
    from longprofile.rail import fill_temperature
    from longprofile.rail.service._recompute import _active_sensors, _filled, _readings_frame

    syn, r = synthetic(n_days=14)
    _core.create_site(db, "tester", "mitt", clock="data")
    _core.put_sensors(db, "tester", "mitt", syn.sensors.to_dict("records"))
    days = r["timestamp"].str[:10]
    ud = sorted(days.unique())
    ids = list(syn.sensors["sensor_id"])
    rng = np.random.default_rng(3)
    r = r.copy()
    for k, sid in enumerate((ids[10], ids[30], ids[45])):
        r.loc[r["sensor_id"] == sid, "temperature_c"] += (1.5, -2.0, 0.8)[k]
    r.loc[(r["sensor_id"] == ids[10]) & (days >= ud[3]), "temperature_c"] = np.nan
    r.loc[(r["sensor_id"] == ids[30]) & (days >= ud[9]), "temperature_c"] = 4.25
    gaps = (r["sensor_id"] == ids[45]) & (days >= ud[5]) & (rng.random(len(r)) < 1 / 3)
    r.loc[gaps, "temperature_c"] = np.nan
    _ingest_days(db, r, ud[-1])
    full = fill_temperature(r.assign(timestamp=pd.to_datetime(r["timestamp"]).dt.tz_localize(None)), syn.sensors)[0]
    t0 = pd.Timestamp(ud[0]).value // 10**9
    with db.read() as s:
        site_row = _core._site(s, "mitt")
        sens = _active_sensors(s, site_row)
        for t in sorted(t0 + rng.integers(3600, 13 * 86400, 20) // 3600 * 3600):
            frame = _filled(s, site_row, _readings_frame(s, site_row, sens, from_ts=int(t)), from_ts=int(t))
            want = full[full["timestamp"] >= pd.Timestamp(int(t), unit="s")]
            got = frame.merge(want, on=["timestamp", "sensor_id"], suffixes=("", "_want"))
            assert len(got) == len(frame) == len(want)
            np.testing.assert_allclose(got["temperature_c"], got["temperature_c_want"], rtol=0, atol=1e-12,
                                       err_msg=f"window from {pd.Timestamp(int(t), unit='s')}")


def test_a_day_without_any_temperature_is_left_out_as_rail_settle_does(site):
    """A day when no sensor sent a temperature (nothing to fill from): the service's run leaves it out as
    ``rail settle`` does, with the same warning, and stores the same results (a full build, then an incremental run
    with the day in its window)."""
    db, _, r = site
    syn, _ = synthetic()
    days = r["timestamp"].str[:10]
    ud = sorted(days.unique())
    r = r.copy()
    r.loc[(days == ud[5]).to_numpy(), "temperature_c"] = np.nan
    out = _two_runs(db, r, ud[3])
    readings = syn.readings.copy()
    readings.loc[(days == ud[5]).to_numpy(), "temperature_c"] = np.nan
    ref = estimate_settlement(validate_site(syn.sensors, readings, syn.survey), n_monte_carlo=0)
    assert ref.days.size == len(ud) - 1
    got = _stored_against(db, out["run_id"], ref)
    with db.read() as s:
        assert "without a usable daily angle on any sensor" in s.get(Run, out["run_id"]).warnings_json
    for c in ("dz_m", "dz_std_m"):
        np.testing.assert_allclose(got[c], got[c + "_ref"], rtol=1e-9, atol=1e-12)
