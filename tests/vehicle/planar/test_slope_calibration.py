"""Calibration of the printed stds of estimate_slope (issue 13): NIS inflation, parameter terms, 10 % flag."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.vehicle import default_vehicle, drive_scenario, estimate_slope, simulate_drive
from longprofile.vehicle.planar._estimate import MAX_PLAUSIBLE_GRADE, SlopeUncertainty, nis_inflation

Z90 = 1.6448536269514722


@pytest.fixture(scope="module")
def paper():
    sim = simulate_drive(drive_scenario("paper", duration=12.0), seed=3)
    return sim, estimate_slope(sim.log, default_vehicle())


@pytest.fixture(scope="module")
def heavy_hill():
    """The hill drive with a car 15 % heavier than the estimator's (first 20 s: acceleration and climb)."""
    car = default_vehicle()
    sim = simulate_drive(drive_scenario("hill", duration=20.0), car.with_changes(mass=1.15 * car.mass), seed=5)
    return sim, car


def _coverage(sim, est, key="slope"):
    keep = sim.log.time >= 2.0
    err = (getattr(est, key) - getattr(sim.truth, key))[keep]
    return float(np.mean(np.abs(err) <= Z90 * np.broadcast_to(getattr(est, f"{key}_std"), est.slope.shape)[keep]))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 31), st.integers(0, 60), st.floats(0.01, 100.0))
def test_nis_inflation_is_at_least_one_and_one_for_small_innovations(seed, window, scale):
    rng = np.random.default_rng(seed)
    T = 200
    s = rng.uniform(0.1, 10.0, (T, 2))
    cov = np.zeros((T, 2, 2))
    cov[:, 0, 0], cov[:, 1, 1] = s[:, 0], s[:, 1]
    nu = rng.normal(0.0, np.sqrt(scale * s))
    nu[rng.random((T, 2)) < 0.1] = np.nan  # missing components count as consistent
    kappa = nis_inflation(nu, cov, window)
    assert kappa.shape == (T, 2) and np.all(kappa >= 1.0)
    assert np.all(nis_inflation(0.5 * np.sqrt(s), cov, window) == 1.0)  # NIS 0.25 everywhere: nothing to inflate


def test_nis_inflation_recovers_the_variance_ratio():
    rng = np.random.default_rng(0)
    T, w = 100_000, 1000
    cov = np.full((T, 1, 1), 2.0)
    consistent = nis_inflation(rng.normal(0.0, np.sqrt(2.0), (T, 1)), cov, w)
    assert np.median(consistent) < 1.05 and consistent.max() < 1.0 + 5 * np.sqrt(2.0 / w)
    too_small = nis_inflation(rng.normal(0.0, np.sqrt(8.0), (T, 1)), cov, w)
    assert abs(np.median(too_small) - 4.0) < 0.2


def test_inflation_is_one_on_a_consistent_simulated_drive(paper):
    sim, est = paper
    f = est.filtered
    kappa = nis_inflation(f.innovation, f.innovation_cov, 1000)
    assert np.median(kappa[:, 0]) == pytest.approx(1.0, abs=0.05)
    assert np.median(kappa[:, 1]) == pytest.approx(1.0, abs=0.05)


def test_noise_only_is_the_stationary_lyapunov_std(paper):
    sim, est = paper
    old = estimate_slope(sim.log, default_vehicle(), uncertainty=SlopeUncertainty.noise_only())
    s_std = old.slope_std * np.cos(old.slope)
    assert np.ptp(s_std) < 1e-12 * s_std.max()  # one stationary value of sin(theta)'s std
    assert old.force_fit is None  # no parameter uncertainty: nothing to correct
    stated = estimate_slope(sim.log, default_vehicle(), force_correction=False, sensor_calibration=False)
    for e in (est, stated):
        assert np.all(e.slope_std > old.slope_std) and np.all(e.vx_std >= old.vx_std)
    np.testing.assert_array_equal(stated.slope, old.slope)  # without the force correction the estimate is the same


def test_mass_error_is_covered_after_and_was_not_before(heavy_hill):
    sim, car = heavy_hill
    for method in ("cascade", "joint"):
        before = _coverage(sim, estimate_slope(sim.log, car, method=method, uncertainty=SlopeUncertainty.noise_only()))
        after = _coverage(sim, estimate_slope(sim.log, car, method=method))
        assert 0.85 <= after <= 1.0, (method, after)
        if method == "cascade":
            assert before < 0.5, before


def test_larger_stated_mass_uncertainty_widens_the_slope_band(heavy_hill):
    sim, car = heavy_hill
    a = estimate_slope(sim.log, car, uncertainty=SlopeUncertainty(mass_rel_std=0.05), force_correction=False)
    b = estimate_slope(sim.log, car, uncertainty=SlopeUncertainty(mass_rel_std=0.2), force_correction=False)
    assert np.all(b.slope_std >= a.slope_std) and np.median(b.slope_std) > 1.5 * np.median(a.slope_std)


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf")])
def test_uncertainty_rejects_bad_values(bad):
    with pytest.raises(InputError):
        SlopeUncertainty(mass_rel_std=bad)


def test_ten_percent_flag_fires_on_steep_slope_not_on_flat_drive(paper):
    sim, est = paper  # the paper drive climbs 4 deg = 7 %
    frame = est.to_frame()
    assert frame["slope_plausible"].dtype == bool and frame["slope_plausible"].all()
    assert est.warnings() == []
    grade = 0.12  # 12 %: over the 10 % flag, under the former 0.2 rad warning
    steep = replace(est, slope=np.where(est.time >= 6.0, np.arctan(grade), est.slope))
    flag = steep.slope_plausible()
    np.testing.assert_array_equal(flag, est.time < 6.0)
    (w,) = steep.warnings()
    assert "slope leaves the plausible range" in w and "10 % grade" in w and "t = 6" in w
    assert steep.warnings(max_slope=0.2) == []  # the threshold stays a parameter
    assert MAX_PLAUSIBLE_GRADE == 0.10
    downhill = replace(est, slope=-np.abs(est.slope) - np.arctan(0.101))
    assert not downhill.slope_plausible().any()


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 31), st.integers(2, 60), st.floats(0.01, 1.0))
def test_nis_floor_bounds_the_factors_and_equals_inflation_above_one(seed, window, floor):
    rng = np.random.default_rng(seed)
    T = 200
    cov = np.broadcast_to(rng.uniform(0.1, 10.0, (T, 1, 1)), (T, 1, 1)).copy()
    nu = rng.normal(0.0, rng.uniform(0.05, 3.0) * np.sqrt(cov[:, :, 0]))
    scale = nis_inflation(nu, cov, window, floor=floor)
    assert np.all(scale >= floor) and np.all(scale <= np.maximum(nis_inflation(nu, cov, window), 1.0))
    np.testing.assert_array_equal(np.maximum(scale, 1.0), nis_inflation(nu, cov, window))


def test_nis_floor_recovers_a_variance_ratio_below_one_and_rejects_bad_floors():
    rng = np.random.default_rng(1)
    T, w = 100_000, 1000
    cov = np.full((T, 1, 1), 8.0)
    too_large = nis_inflation(rng.normal(0.0, np.sqrt(2.0), (T, 1)), cov, w, floor=0.1)  # the filter says 8, truth 2
    assert abs(np.median(too_large) - 0.25) < 0.02
    assert np.all(nis_inflation(rng.normal(0.0, 0.1, (T, 1)), cov, w, floor=0.1) == 0.1)  # NIS 1/800: the floor
    for bad in (0.0, -1.0, 1.5, float("nan")):
        with pytest.raises(InputError):
            nis_inflation(np.ones((10, 1)), np.ones((10, 1, 1)), 3, floor=bad)
        with pytest.raises(InputError):
            SlopeUncertainty(nis_floor=bad)


def test_yaw_rate_band_is_calibrated_when_the_tuning_overstates_the_gyro_noise():
    """The default tuning states a gyro noise of 3e-3 rad/s, the simulated gyro has 2e-3: with inflation only the
    yaw-rate band over-covered (99.7 % on the calibration benchmark); the NIS scaling brings it near 90 % (the
    estimator until 2026-12-07), and so does the band from the filter's gain and the measured gyro noise (since)."""
    car = default_vehicle()
    inside = {1.0: [], 0.1: [], "gain": []}
    for seed in range(3):
        sim = simulate_drive(drive_scenario("paper", duration=12.0), seed=seed)
        keep = sim.log.time >= 2.0
        for floor in inside:
            unc = SlopeUncertainty() if floor == "gain" else SlopeUncertainty(nis_floor=floor, yaw_rate_from_gain=False)
            est = estimate_slope(sim.log, car, uncertainty=unc)
            err = (est.yaw_rate - sim.truth.yaw_rate)[keep]
            inside[floor].append(np.abs(err) <= Z90 * est.yaw_rate_std[keep])
    before, after, gain = (float(np.mean(np.concatenate(inside[f]))) for f in (1.0, 0.1, "gain"))
    assert before > 0.98, before
    assert 0.85 <= after <= 0.95, after
    assert 0.85 <= gain <= 0.95, gain


def test_joint_slope_band_narrows_but_still_covers_a_heavy_car(heavy_hill):
    sim, car = heavy_hill
    a = estimate_slope(sim.log, car, method="joint", uncertainty=SlopeUncertainty(nis_floor=1.0, grade_nis_floor=None))
    b = estimate_slope(sim.log, car, method="joint")
    np.testing.assert_array_equal(a.slope, b.slope)  # the stds change, not the estimate
    assert np.all(b.slope_std <= a.slope_std) and np.median(b.slope_std) < 0.9 * np.median(a.slope_std)
    assert 0.85 <= _coverage(sim, b) <= 1.0
