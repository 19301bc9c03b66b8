"""Per-day statistics of daily_angles (the cache of the monitoring service): carried over a new day, a late
reading or a revision, they give the daily angles of a full recomputation (docs/rail-service.md)."""

import dataclasses

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.rail import (
    daily_angles,
    daily_angles_from_statistics,
    day_statistics,
    estimate_settlement,
    estimate_settlement_from_daily,
    simulate_site,
    statistics_window,
    validate_site,
)
from longprofile.rail._thermal import MEDIAN_LINES, MEDIAN_UPDATE_TOLERANCE_DEG, NOISE_STD_TOLERANCE


@pytest.fixture(scope="module")
def site():
    syn = simulate_site("mittersheim-like", seed=2, sampling_minutes=30, n_days=10)
    return validate_site(syn.sensors, syn.readings, syn.survey)


def _incremental(readings, ids, previous, changed, **kw):
    """What the service does: recompute from the window of the change, rebuild stale sensors from all readings."""
    first, ctx = statistics_window(previous, changed)
    win = readings[readings["timestamp"] >= ctx]
    stats = day_statistics(win, ids, first_day=first, previous=previous, **kw)
    if stats.stale_sensors:
        stale = [s for s in ids if s in stats.stale_sensors]
        stats = stats.replace_sensors(day_statistics(readings[readings["sensor_id"].isin(stale)], stale, **kw))
    return stats


def _assert_close(inc, full):
    a, b = daily_angles_from_statistics(inc), daily_angles_from_statistics(full)
    assert np.array_equal(a.days, b.days)
    np.testing.assert_array_equal(a.n_readings, b.n_readings)
    np.testing.assert_array_equal(a.n_outliers, b.n_outliers)
    np.testing.assert_array_equal(np.isnan(a.angle_deg), np.isnan(b.angle_deg))
    assert np.nanmax(np.abs(a.angle_deg - b.angle_deg)) <= MEDIAN_UPDATE_TOLERANCE_DEG + 1e-12
    np.testing.assert_allclose(a.thermal_coef, b.thermal_coef, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.raw_day_spread_deg, b.raw_day_spread_deg, rtol=0, atol=1e-15)
    np.testing.assert_allclose(a.temperature_mean_c, b.temperature_mean_c, rtol=1e-12)
    # approximation of the incremental path (assumption in docs/rail-service.md): the kept noise std of a cached
    # sensor is within NOISE_STD_TOLERANCE of the one of all its readings (decided exactly from per-day counts)
    np.testing.assert_allclose(a.noise_deg, b.noise_deg, rtol=NOISE_STD_TOLERANCE * (1 + 1e-9))
    assert not inc.exact and full.exact


def test_the_full_statistics_are_daily_angles(site):
    full = day_statistics(site.readings, site.sensor_ids)
    a, b = daily_angles_from_statistics(full), daily_angles(site)
    for f in ("angle_deg", "change_deg", "n_readings", "n_outliers", "raw_std_deg", "noise_deg", "thermal_coef"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    with pytest.raises(InputError, match="lagged"):
        day_statistics(site.readings, site.sensor_ids, thermal="lagged")
    with pytest.raises(InputError, match="together"):
        day_statistics(site.readings, site.sensor_ids, first_day="2019-11-20")


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(split=st.integers(2, 9), revise=st.integers(0, 9), thermal=st.sampled_from(["linear", "none"]),
       quiet=st.booleans(), seed=st.integers(0, 2**31))
def test_a_new_day_a_late_reading_or_a_revision_gives_the_full_result(site, split, revise, thermal, quiet, seed):
    r = site.readings
    days = np.sort(r["timestamp"].dt.normalize().unique())
    kw = {"thermal": thermal, "quiet_days": list(days[:4]) if quiet else None}
    before = r[r["timestamp"] < days[split]]
    prev = day_statistics(before, site.sensor_ids, **kw)
    # the data grow by one day, and one stored reading of an earlier (or the same) day is revised
    after = r[r["timestamp"] < days[split] + np.timedelta64(1, "D")].copy()
    rng = np.random.default_rng(seed)
    day_of = after["timestamp"].dt.normalize().to_numpy()
    target = min(revise, split)
    rows = np.nonzero(day_of == days[target])[0]
    i = after.index[rng.choice(rows)]
    after.loc[i, "angle_deg"] += rng.normal(0, 0.01)
    after.loc[i, "temperature_c"] += rng.normal(0, 1.0)
    changed = min(days[split], days[target])
    inc = _incremental(after, site.sensor_ids, prev, changed, **kw)
    _assert_close(inc, day_statistics(after, site.sensor_ids, **kw))


def test_a_stale_cache_is_found_and_rebuilt(site):
    """A revision that moves the thermal coefficient far: the carried medians would be off, so the sensor is
    listed stale, and after its rebuild the result is the full one."""
    r = site.readings
    days = np.sort(r["timestamp"].dt.normalize().unique())
    prev = day_statistics(r[r["timestamp"] < days[-1]], site.sensor_ids)
    sid = site.sensor_ids[3]
    after = r.copy()
    on = (after["sensor_id"] == sid) & (after["timestamp"] >= days[-1])
    after.loc[on, "angle_deg"] += 0.05 * (after.loc[on, "temperature_c"] - 5.0)  # a day with another thermal slope
    first, ctx = statistics_window(prev, days[-1])
    inc = day_statistics(after[after["timestamp"] >= ctx], site.sensor_ids, first_day=first, previous=prev)
    assert sid in inc.stale_sensors
    with pytest.raises(InputError, match="stale"):
        daily_angles_from_statistics(inc)
    _assert_close(_incremental(after, site.sensor_ids, prev, days[-1]),
                  day_statistics(after, site.sensor_ids))


def test_statistics_window_reaches_three_readings_back(site):
    r = site.readings
    days = np.sort(r["timestamp"].dt.normalize().unique())
    prev = day_statistics(r, site.sensor_ids)
    first, ctx = statistics_window(prev, days[5])
    assert first == days[4] and ctx == days[3]  # 48 readings a day: one day back for each
    # a sensor with a single reading on day 4: its 3 readings before day 5 start on day 3
    sid = site.sensor_ids[0]
    keep = ~((r["sensor_id"] == sid) & (r["timestamp"].dt.normalize() == days[4])) | (
        r.index == r[(r["sensor_id"] == sid) & (r["timestamp"].dt.normalize() == days[4])].index[0])
    first, ctx = statistics_window(day_statistics(r[keep], site.sensor_ids), days[5])
    assert first == days[3] and ctx == days[2]


def test_settlement_from_the_statistics_equals_estimate_settlement(site):
    res = estimate_settlement(site, n_monte_carlo=0)
    again = estimate_settlement_from_daily(site, daily_angles_from_statistics(
        day_statistics(site.readings, site.sensor_ids)), n_monte_carlo=0)
    np.testing.assert_array_equal(res.dz, again.dz)
    np.testing.assert_array_equal(res.dz_std, again.dz_std)
    assert list(res.health.status) == list(again.health.status)
    with pytest.raises(InputError, match="thermal model"):
        estimate_settlement_from_daily(site, res.daily, thermal="none")
    assert isinstance(res.to_table(), pd.DataFrame)


def _exact_corrected_medians(readings, ids, days, k, tref):
    """(D, N) median of a - k_j (T - T_ref) per day and sensor over the readings (no outliers in them), by hand."""
    out = np.full((len(days), len(ids)), np.nan)
    day = readings["timestamp"].dt.normalize().to_numpy()
    for j, sid in enumerate(ids):
        for d, dd in enumerate(days):
            r = readings[(readings["sensor_id"] == sid).to_numpy() & (day == dd)]
            out[d, j] = np.median(r["angle_deg"] - k[j] * (r["temperature_c"] - tref))
    return out


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**16), delta=st.sampled_from([-2e-3, -1e-4, 3e-4, 1e-3]))
def test_cached_medians_follow_a_new_coefficient_by_their_first_order_update(seed, delta):
    """A cached day's median was computed with the coefficient k of its run (coef_deg_per_c); when the sensor's k
    moves to k' (a later day moved the median of the per-day slopes) the combine stage carries it by
    m(k') = m(k) - (k' - k)(T_m - T_ref), whose error is at most |k' - k| x the day's temperature range (the median
    is 1-Lipschitz; docs/rail-service.md). The temperatures (17-23 °C) are far from T_ref = 5 °C, so without the
    update the error |k' - k| |T_m - T_ref| is at least twice that bound: this test fails if the update is removed."""
    rng = np.random.default_rng(seed)
    ids = ["A", "B", "C"]
    t = pd.date_range("2024-03-01", periods=4 * 48, freq="30min")
    temp = 20 + 3 * np.sin(2 * np.pi * (t.hour.to_numpy() + t.minute.to_numpy() / 60) / 24)
    rows = pd.DataFrame({"timestamp": np.repeat(t.to_numpy(), 3), "sensor_id": np.tile(ids, t.size),
                         "temperature_c": np.repeat(temp, 3)})
    rows["angle_deg"] = (rng.uniform(-0.1, 0.1, 3)[np.tile(np.arange(3), t.size)]
                         + 2e-3 * rows["temperature_c"] + rng.uniform(-5e-3, 5e-3, len(rows)))
    # bounded noise: |deviation from the 7-sample running median| <= 1e-2 + 2.4e-3 deg (the thermal trend over 3
    # samples), below 8 robust noise stds (~3e-2 deg), so no reading is an outlier whatever the seed
    rows = rows.sort_values(["sensor_id", "timestamp"], kind="stable").reset_index(drop=True)
    stats = day_statistics(rows, ids, reference_temp_c=5.0)
    assert stats.n_outliers.sum() == 0  # the hand-made medians below use every reading
    moved = dataclasses.replace(stats, thermal_coef=stats.thermal_coef + delta)  # k' != the k of every cached day
    got = daily_angles_from_statistics(moved).angle_deg
    exact = _exact_corrected_medians(rows, ids, stats.days, moved.thermal_coef, 5.0)
    bound = abs(delta) * stats.temp_range_c
    without_update = abs(delta) * np.abs(stats.median_temp_c - 5.0)
    assert np.all(without_update > 2 * bound)  # the test can tell the update from its absence
    assert np.all(np.abs(got - exact) <= bound + 1e-12)
    # and with the coefficient the medians were computed with, the combine stage returns them as they are
    np.testing.assert_array_equal(daily_angles_from_statistics(stats).angle_deg, stats.median_deg)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**16), minutes=st.sampled_from([20, 30, 60]),
       u=st.floats(0.3, 0.99), sign=st.sampled_from([-1.0, 1.0]))
def test_cached_medians_are_exact_within_the_window_of_their_median_lines(seed, minutes, u, sign):
    """Each cached day keeps the MEDIAN_LINES kept readings nearest its median; for any coefficient k' within
    median_window_deg_per_c of the k it was computed with, the combine stage's median is the median of all the
    day's corrected angles a - k' (T - T_ref), to round-off (docs/rail-service.md, "Per-day cache"). The k' are
    taken up to the smallest window of each sensor's days, where the median reading changes: the first-order
    update alone is off there (checked below), so the test fails without the lines or with a window too wide."""
    rng = np.random.default_rng(seed)
    ids = ["A", "B", "C"]
    t = pd.date_range("2024-03-01", periods=4 * 1440 // minutes, freq=f"{minutes}min")
    temp = 20 + 3 * np.sin(2 * np.pi * (t.hour.to_numpy() + t.minute.to_numpy() / 60) / 24)
    rows = pd.DataFrame({"timestamp": np.repeat(t.to_numpy(), 3), "sensor_id": np.tile(ids, t.size),
                         "temperature_c": np.repeat(temp, 3) + rng.uniform(-0.5, 0.5, 3 * t.size)})
    rows["angle_deg"] = (rng.uniform(-0.1, 0.1, 3)[np.tile(np.arange(3), t.size)]
                         + 2e-3 * rows["temperature_c"] + rng.uniform(-5e-3, 5e-3, len(rows)))
    # the record ends 3.5 h into its last day: at most MEDIAN_LINES readings there, every one of them a line
    rows = rows[rows["timestamp"] < t[-1].normalize() + pd.Timedelta(hours=3.5)]
    rows = rows.sort_values(["sensor_id", "timestamp"], kind="stable").reset_index(drop=True)
    stats = day_statistics(rows, ids, reference_temp_c=5.0)
    assert stats.n_outliers.sum() == 0  # bounded noise (as above): the hand-made medians use every reading
    w = stats.median_window_deg_per_c
    assert np.all(w >= 0)
    many = stats.n_kept > MEDIAN_LINES
    assert many[:-1].all() and not many[-1].any()
    assert np.all(np.isfinite(w[many])) and np.all(np.isinf(w[~many]))  # few readings: all are lines
    finite = np.where(np.isfinite(w), w, np.nan)
    span = np.where(np.isfinite(np.nanmin(finite, axis=0)), np.nanmin(finite, axis=0), 1e-3)
    moved = dataclasses.replace(stats, thermal_coef=stats.thermal_coef + sign * u * span)
    got = daily_angles_from_statistics(moved).angle_deg
    exact = _exact_corrected_medians(rows, ids, stats.days, moved.thermal_coef, 5.0)
    np.testing.assert_allclose(got, exact, rtol=0, atol=1e-14)
    # the first-order update alone (the medians' slopes at k) is off wherever the median reading changed
    dk = moved.thermal_coef[None, :] - stats.coef_deg_per_c
    first_order = stats.median_deg - dk * (stats.median_temp_c - 5.0)
    if minutes <= 60 and u > 0.6:  # many readings a day and k' far in the window: the median reading changes
        assert np.nanmax(np.abs(first_order - exact)) > 1e-9
