"""A failed temperature channel: its angles take the nearest sensors' temperature (rail.fill_temperature)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.rail import estimate_settlement, fill_temperature, validate_site
from longprofile.rail._data import TEMPERATURE_OFFSET_DAYS
from longprofile.rail._scenarios import simulate_scenario


def _brute_median(readings, sensors, k, i, minute):
    """The median of the k nearest other sensors' temperatures in row i's minute (NaN without any)."""
    x = dict(zip(sensors["sensor_id"], sensors["x_m"]))
    order = {sid: n for n, sid in enumerate(sensors["sensor_id"])}
    sid = readings["sensor_id"][i]
    same = readings[(minute == minute[i]) & (readings["sensor_id"] != sid) & readings["temperature_c"].notna()]
    if same.empty:
        return np.nan
    by_sensor = same.groupby("sensor_id")["temperature_c"].first()  # one reading per sensor and minute here
    near = sorted(by_sensor.index, key=lambda s: (abs(x[s] - x[sid]), order[s]))[:k]
    return float(np.median(by_sensor[near].to_numpy()))


def _brute_fill(readings: pd.DataFrame, sensors: pd.DataFrame, k: int) -> np.ndarray:
    """The definition, row by row: the median of the k nearest other sensors' temperatures in the same minute, plus
    the sensor's median difference from that median over its readings of the TEMPERATURE_OFFSET_DAYS days that end on
    its last day before the row's with a temperature read with an angle (no stuck days here: too few readings)."""
    minute = readings["timestamp"].dt.floor("min")
    day = readings["timestamp"].dt.floor("D")
    has = readings["temperature_c"].notna() & readings["angle_deg"].notna()
    out = readings["temperature_c"].to_numpy(float).copy()
    for i, row in readings.iterrows():
        if not (np.isnan(row["temperature_c"]) and np.isfinite(row["angle_deg"])):
            continue
        out[i] = _brute_median(readings, sensors, k, i, minute)
        mine = readings["sensor_id"] == row["sensor_id"]
        before = day[mine & has & (day < day[i])]
        if before.empty:
            continue
        end = before.max()
        window = mine & has & (day <= end) & (day > end - pd.Timedelta(days=TEMPERATURE_OFFSET_DAYS))
        diffs = [readings["temperature_c"][j] - _brute_median(readings, sensors, k, j, minute)
                 for j in np.flatnonzero(window)]
        diffs = [d for d in diffs if np.isfinite(d)]
        if diffs:
            out[i] += float(np.median(diffs))
    return out


@st.composite
def _sites(draw):
    n = draw(st.integers(3, 7))
    xs = np.cumsum(draw(st.lists(st.floats(0.5, 5.0), min_size=n, max_size=n)))
    sensors = pd.DataFrame({"sensor_id": [f"S{i}" for i in range(n)], "x_m": xs})
    n_t = draw(st.integers(1, 8))
    step = pd.Timedelta(minutes=draw(st.sampled_from([10, 1440, 2880, 4320])))  # days apart: the offset's window
    t0 = pd.Timestamp("2024-03-01 00:00:00")
    rows = []
    for k in range(n_t):
        for i in range(n):
            # loggers a few seconds apart within the minute
            rows.append((t0 + k * step + pd.Timedelta(seconds=draw(st.integers(0, 59))), f"S{i}",
                         draw(st.sampled_from([np.nan, 0.5, -0.3])),
                         draw(st.sampled_from([np.nan, np.nan, 1.0, 2.5, 7.0, -3.0]))))
    r = pd.DataFrame(rows, columns=["timestamp", "sensor_id", "angle_deg", "temperature_c"])
    r = r.sample(frac=1.0, random_state=draw(st.integers(0, 100))).reset_index(drop=True)
    return sensors, r, draw(st.integers(1, 5))


@settings(max_examples=80, deadline=None)
@given(_sites())
def test_fill_is_the_median_of_the_nearest_sensors_in_the_same_minute_plus_the_offset(case):
    sensors, r, k = case
    got, filled, stuck = fill_temperature(r, sensors, neighbours=k)
    assert stuck == {}  # fewer than STUCK_MIN_READINGS readings a day
    want = _brute_fill(r, sensors, k)
    np.testing.assert_allclose(got["temperature_c"].to_numpy(float), want, equal_nan=True)
    assert got.index.equals(r.index) and got["sensor_id"].equals(r["sensor_id"])  # rows and order kept
    had = r["temperature_c"].notna().to_numpy()
    np.testing.assert_array_equal(got["temperature_c"].to_numpy()[had], r["temperature_c"].to_numpy()[had])
    new = np.isnan(r["temperature_c"].to_numpy()) & np.isfinite(want)
    assert sum(filled.values()) == int(new.sum())
    assert r["temperature_c"].isna().sum() == (~had).sum()  # the input is not modified


def test_nothing_to_fill_returns_the_same_table_and_bad_neighbours_are_refused():
    s = pd.DataFrame({"sensor_id": ["A", "B", "C"], "x_m": [0.0, 1.0, 2.0]})
    r = pd.DataFrame({"timestamp": pd.to_datetime(["2024-01-01"] * 3), "sensor_id": ["A", "B", "C"],
                      "angle_deg": [0.1, 0.2, np.nan], "temperature_c": [1.0, 2.0, np.nan]})
    got, filled, stuck = fill_temperature(r, s)
    assert got is r and filled == {} and stuck == {}  # C has no angle: nothing to fill
    with pytest.raises(InputError, match="neighbours"):
        fill_temperature(r, s, neighbours=0)


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_the_failures_family_is_drift_with_some_temperature_channels_lost(seed):
    """``drift-temperature-failures`` is ``drift`` except for the failing sensors (their own random stream): their
    temperature is empty ("empty") or one value ("stuck") from the failure's day on, and their own temperature
    (before it) is not the one ``drift`` drew for them."""
    full = simulate_scenario("drift", seed).readings
    sc = simulate_scenario("drift-temperature-failures", seed)
    ids = list(sc.sensors["sensor_id"])
    start = pd.Timestamp(sc.truth.days[0])
    day = ((full["timestamp"] - start) / pd.Timedelta(days=1)).to_numpy()
    failing = np.zeros(len(full), bool)
    lost = np.zeros(len(full), bool)
    held = np.zeros(len(full), bool)
    failures = sc.truth.params["temperature_failures"]
    assert len(failures) == 2
    for f in failures:  # a sensor in both groups: the later one decides its channel
        assert 2 <= f["n_sensors"] <= 8 and 0.6 <= f["swing"] <= 1.4 and 0 <= f["extra_lag_minutes"] <= 120
        j0 = ids.index(f["first_sensor"])
        mine = full["sensor_id"].isin(ids[j0:j0 + f["n_sensors"]]).to_numpy()
        failing |= mine
        lost[mine] = held[mine] = False
        (lost if f["kind"] == "empty" else held)[mine & (day >= f["first_day"])] = True
    pd.testing.assert_frame_equal(sc.readings[~failing], full[~failing])
    np.testing.assert_array_equal(sc.readings["temperature_c"].isna().to_numpy(), lost)
    for sid in sc.readings["sensor_id"][held].unique():
        assert sc.readings["temperature_c"][held & (sc.readings["sensor_id"] == sid).to_numpy()].nunique() == 1
    kept = failing & ~lost & ~held
    if kept.sum() > 100:  # their own temperature differs from what their neighbours' model drew
        assert not np.allclose(sc.readings["temperature_c"][kept], full["temperature_c"][kept])


def _failed_channel(sc, ids):
    r = sc.readings.copy()
    r.loc[r["sensor_id"].isin(ids), "temperature_c"] = np.nan
    return r


def test_a_failed_channel_keeps_its_sensor_and_matches_the_intact_site():
    """Two sensors of a drifting site lose their temperature channel: filled, they are kept (not dead), and the
    settlement differs from the intact site's by far less than its band; without the fill they are dead."""
    sc = simulate_scenario("drift", 7)
    ids = list(sc.sensors["sensor_id"].iloc[[5, 14]])
    intact = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=0)
    site = validate_site(sc.sensors, _failed_channel(sc, ids), sc.survey)
    assert any("no usable temperature" in w and ids[0] in w for w in site.warnings)
    res = estimate_settlement(site, n_monte_carlo=0)
    status = dict(zip(res.sensor_ids, res.health.status))
    assert all(status[i] == "ok" for i in ids)
    diff = np.abs(res.dz[1:] - intact.dz[1:]) / intact.dz_std[1:]
    assert np.nanmax(diff) < 0.5, np.nanmax(diff)
    off = estimate_settlement(validate_site(sc.sensors, _failed_channel(sc, ids), sc.survey, temperature_fill=False),
                              n_monte_carlo=0)
    status = dict(zip(off.sensor_ids, off.health.status))
    assert all(status[i] == "dead" for i in ids)


def test_the_cli_fills_and_can_be_told_not_to(tmp_path):
    from longprofile.cli.app import main

    sc = simulate_scenario("drift", 3, n_days=(8, 8))
    sc.sensors.to_csv(tmp_path / "s.csv", index=False)
    sc.survey.to_csv(tmp_path / "v.csv", index=False)
    _failed_channel(sc, ["S04"]).to_csv(tmp_path / "r.csv", index=False)
    args = ["rail", "settle", "--sensors", str(tmp_path / "s.csv"), "--readings", str(tmp_path / "r.csv"),
            "--survey", str(tmp_path / "v.csv"), "--monte-carlo", "0"]
    assert main(args + ["-o", str(tmp_path / "a.csv")]) == 0
    a = pd.read_csv(tmp_path / "a.csv")
    assert (a.loc[a["sensor_id"] == "S04", "status"] == "ok").all()
    assert main(args + ["-o", str(tmp_path / "b.csv"), "--no-temperature-fill"]) == 0
    b = pd.read_csv(tmp_path / "b.csv")
    assert (b.loc[b["sensor_id"] == "S04", "status"] == "dead").all()


def _stuck_site(seed=5, from_day=3, value=12.0):
    sc = simulate_scenario("drift", seed, n_days=(8, 8))
    r = sc.readings.copy()
    day = ((r["timestamp"] - pd.Timestamp(sc.truth.days[0])) / pd.Timedelta(days=1)).to_numpy()
    stuck = (r["sensor_id"] == "I005").to_numpy() & (day >= from_day)
    r.loc[stuck, "temperature_c"] = value
    return sc, r, stuck


def test_a_stuck_channel_is_a_missing_temperature_on_the_days_it_is_stuck():
    """I005 reads 12.0 degC from day 3 on (8 days at 30 min): 5 stuck days, their readings filled from the
    neighbours, nothing else touched; the settlement is the intact site's within 0.25 band std (0.04 measured),
    where the stuck values taken as read move it by 0.92 band std. (On seed 4 the fill without the sensor's own offset
    gave 0.64: its offset to its neighbours appeared as a step where the fill began; with it 0.05, docs/rail.md.)"""
    sc, r, stuck = _stuck_site()
    got, filled, days = fill_temperature(r, sc.sensors)
    assert days == {"I005": 5} and filled == {"I005": int(stuck.sum())}
    np.testing.assert_array_equal(got["temperature_c"].to_numpy()[~stuck], r["temperature_c"].to_numpy()[~stuck])
    assert np.abs(got["temperature_c"].to_numpy()[stuck] - 12.0).max() > 1.0  # the neighbours' day moves
    site = validate_site(sc.sensors, r, sc.survey)
    assert any("stuck temperature channel" in w and "I005 (5 day(s))" in w for w in site.warnings)
    intact = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=0)

    def moved(site_data):
        res = estimate_settlement(site_data, n_monte_carlo=0)
        return np.nanmax(np.abs(res.dz[1:] - intact.dz[1:]) / intact.dz_std[1:])

    assert moved(site) < 0.25
    assert moved(validate_site(sc.sensors, r, sc.survey, temperature_fill=False)) > 0.5


def test_a_constant_temperature_is_not_stuck_when_nothing_moves_or_on_a_short_day():
    """The same value all day is a stuck channel only when the other sensors' temperatures move (not in a tunnel),
    and only over at least STUCK_MIN_READINGS readings."""
    sc, r, _ = _stuck_site()
    tunnel = r.assign(temperature_c=12.0)
    assert fill_temperature(tunnel, sc.sensors)[2] == {}
    sparse = r[(r["sensor_id"] != "I005") | (r["timestamp"].dt.minute == 0) & (r["timestamp"].dt.hour % 3 == 0)]
    assert fill_temperature(sparse.reset_index(drop=True), sc.sensors)[2] == {}  # 8 readings a day


def test_without_the_fill_a_site_that_loses_most_sensors_is_refused_with_the_count():
    """``drift-temperature-failures`` seed 108, empty channels only: 16 of 20 sensors lose their temperature from day
    10-11 of 27. Left out (the behaviour before the fill) they are dead, and the refusal says how many sensors were
    left; filled, the site is estimated."""
    sc = simulate_scenario("drift-temperature-failures", 108, failure_kinds=("empty",))
    with pytest.raises(InputError, match=r"4 sensor\(s\) with a daily angle \(at least 5 needed\)"):
        estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey, temperature_fill=False), n_monte_carlo=0)
    res = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=0)
    assert (np.asarray(res.health.status) == "ok").sum() >= 18


@pytest.mark.parametrize("seed", [4, 7])
def test_a_channel_failing_mid_record_carries_the_sensors_offset(seed, monkeypatch):
    """Seeds where I005 reads 0.67 / 0.87 degC off its neighbours before its channel sticks (day 3 of 8): the fill
    carries that offset (its filled temperatures within 0.05 degC of the truth on average) and the settlement stays
    within 0.25 band std of the intact site; the neighbours' median alone (the fill of session 33) moved it by
    0.64 / 0.75."""
    from longprofile.rail import _data

    sc, r, stuck = _stuck_site(seed)
    got = fill_temperature(r, sc.sensors)[0]["temperature_c"].to_numpy()
    truth = sc.readings["temperature_c"].to_numpy()
    assert abs(np.mean(got[stuck] - truth[stuck])) < 0.05
    intact = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=0)

    def moved():
        res = estimate_settlement(validate_site(sc.sensors, r, sc.survey), n_monte_carlo=0)
        return np.nanmax(np.abs(res.dz[1:] - intact.dz[1:]) / intact.dz_std[1:])

    assert moved() < 0.25
    monkeypatch.setattr(_data, "_offsets", lambda diff, pair, need, *a: np.zeros(int(need.sum())))
    assert moved() > 0.5


def test_a_sensor_without_a_station_is_left_as_it_is():
    """``fill_temperature`` called directly with a reading of a sensor the sensors table does not list (validate_site
    refuses those): it has no neighbours, so its temperature stays empty; the others are filled."""
    s = pd.DataFrame({"sensor_id": ["A", "B", "C"], "x_m": [0.0, 1.0, 2.0]})
    r = pd.DataFrame({"timestamp": pd.to_datetime(["2024-01-01"] * 4), "sensor_id": ["A", "B", "C", "Z"],
                      "angle_deg": [0.1, 0.2, 0.3, 0.4], "temperature_c": [1.0, np.nan, 3.0, np.nan]})
    got, filled, _ = fill_temperature(r, s)
    assert filled == {"B": 1} and got["temperature_c"][1] == 2.0 and np.isnan(got["temperature_c"][3])


def test_the_offset_is_not_moved_by_a_few_glitches_of_the_failing_channel():
    """A channel about to fail often glitches first: five readings of I005 at -40 degC the day before it sticks leave
    its offset within 0.05 degC (a median; a mean of its 144 differences would move by ~1.5 degC)."""
    sc, r, stuck = _stuck_site(4)
    day = ((r["timestamp"] - pd.Timestamp(sc.truth.days[0])) / pd.Timedelta(days=1)).to_numpy()
    glitch = np.flatnonzero((r["sensor_id"] == "I005").to_numpy() & (day >= 2) & (day < 3))[::9][:5]
    r.loc[glitch, "temperature_c"] = -40.0
    got = fill_temperature(r, sc.sensors)[0]["temperature_c"].to_numpy()
    assert abs(np.mean(got[stuck] - sc.readings["temperature_c"].to_numpy()[stuck])) < 0.05


def test_a_record_without_any_temperature_is_refused_with_the_way_out():
    """Angles only (every temperature empty): nothing to fill from, every sensor would be dead. One refusal names the
    cause and the way out (it was "too few daily slope changes to estimate their noise; pass sigma"); a constant
    temperature with thermal='none' is estimated."""
    sc, r, _ = _stuck_site()
    site = validate_site(sc.sensors, r.assign(temperature_c=np.nan), sc.survey)
    with pytest.raises(InputError, match=r"no reading has both an angle and a temperature.*--thermal none"):
        estimate_settlement(site, n_monte_carlo=0)
    res = estimate_settlement(validate_site(sc.sensors, r.assign(temperature_c=0.0), sc.survey), n_monte_carlo=0,
                              thermal="none")
    assert np.isfinite(res.dz).all()


@pytest.mark.parametrize(("column", "day"), [("temperature_c", 4), ("angle_deg", 4), ("temperature_c", 0)])
def test_a_day_without_any_usable_reading_is_left_out_with_a_warning(column, day):
    """A day when the loggers sent angles but no sensor a temperature (a temperature bus down for the day, nothing to
    fill from), or no angle: that day is left out with a warning, and the estimate is that of the record without it
    (it ended in a traceback, "array of sample points is empty")."""
    sc = simulate_scenario("drift", 5, n_days=(8, 8))
    r = sc.readings.copy()
    d = ((r["timestamp"] - pd.Timestamp(sc.truth.days[0])) / pd.Timedelta(days=1)).to_numpy().astype(int)
    r.loc[d == day, column] = np.nan
    site = validate_site(sc.sensors, r, sc.survey)
    res = estimate_settlement(site, n_monte_carlo=0)
    assert any("1 day(s) without a usable daily angle on any sensor" in w for w in res.warnings)
    ref = estimate_settlement(validate_site(sc.sensors, sc.readings[d != day].reset_index(drop=True), sc.survey),
                              n_monte_carlo=0)
    assert res.days.size == ref.days.size == 7
    np.testing.assert_array_equal(res.days, ref.days)
    np.testing.assert_allclose(res.dz, ref.dz, rtol=0, atol=1e-12, equal_nan=True)
    np.testing.assert_allclose(res.dz_std, ref.dz_std, rtol=0, atol=1e-12, equal_nan=True)
