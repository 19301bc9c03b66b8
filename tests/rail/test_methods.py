"""§2 integration, §3 / lagged thermal models, synthetic presets, temporal smoothing and alarms."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.stats import norm

from longprofile.errors import InputError
from longprofile.rail import (
    bar_angles_from_profile,
    daily_angles,
    first_order_response,
    integrate_angles,
    settlement_alarms,
    simulate_site,
    smooth_through_time,
    validate_site,
)


@settings(max_examples=30, deadline=None)
@given(z=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=12), method=st.sampled_from(
    ["forward", "backward", "average", "convex"]))
def test_integration_reconstructs_any_profile_from_its_bar_angles(z, method):
    z = np.array(z)
    x = np.arange(z.size) * 3.0
    got = integrate_angles(x, bar_angles_from_profile(x, z), method=method, z_first=z[0], z_last=z[-1])
    assert np.allclose(got, z, atol=1e-12)


def test_forward_misclosure_and_convex_keeps_both_ends():
    x = np.linspace(0, 30, 11)
    biased = np.full(10, 1e-3)  # a constant angle error of 1 mrad on a flat track
    fwd = integrate_angles(x, biased, method="forward")
    conv = integrate_angles(x, biased, method="convex")
    assert fwd[-1] == pytest.approx(30 * np.tan(1e-3))
    assert conv[0] == 0 and conv[-1] == pytest.approx(0, abs=1e-15)
    with pytest.raises(InputError, match="method must be one of"):
        integrate_angles(x, biased, method="spline")


def test_first_order_response_matches_scipy_ode_solver():
    # irregular sampling, temperature linear between samples: oracle = scipy's ODE solver at tight tolerance
    t = np.sort(np.r_[0.0, np.random.default_rng(0).uniform(0, 48, 300), 48.0])
    T = 10 + 8 * np.sin(2 * np.pi * t / 24)
    tau = 3.0
    ours = first_order_response(t, T, tau)
    sol = solve_ivp(lambda s, y: (np.interp(s, t, T) - y) / tau, (0, 48), [T[0]], t_eval=t, rtol=1e-10,
                    atol=1e-10, max_step=0.05)
    assert np.allclose(ours, sol.y[0], atol=1e-6)
    assert np.array_equal(first_order_response(t, T, 0.0), T)


@pytest.fixture(scope="module")
def fare_site():
    syn = simulate_site("farebersviller-like", seed=1, sampling_minutes=30, n_days=12)
    return syn, validate_site(syn.sensors, syn.readings, syn.survey, syn.controls)


def test_linear_debiasing_recovers_the_thermal_coefficients():
    syn = simulate_site("mittersheim-like", seed=2, sampling_minutes=30, n_days=8)
    site = validate_site(syn.sensors, syn.readings, syn.survey)
    da = daily_angles(site, thermal="linear")
    good = [i for i, s in enumerate(site.sensor_ids) if s not in syn.truth.bad_sensors]
    assert np.allclose(da.thermal_coef[good], syn.truth.thermal_coef[good], atol=2e-4)
    assert da.n_outliers.sum() > 0  # the preset has outliers and they are counted, not hidden
    quiet = daily_angles(site, thermal="linear", quiet_days=syn.truth.days[:5])
    assert np.allclose(quiet.thermal_coef[good], syn.truth.thermal_coef[good], atol=4e-4)
    with pytest.raises(InputError, match="quiet_days must be dates"):
        daily_angles(site, quiet_days=["not a date"])


def test_lagged_model_finds_the_lag_and_beats_linear_on_hysteresis(fare_site):
    syn, site = fare_site
    lin = daily_angles(site, thermal="linear")
    lag = daily_angles(site, thermal="lagged")
    true = np.rad2deg(syn.truth.slope_change)
    err_lin = np.sqrt(np.nanmean((lin.change_deg - true) ** 2))
    err_lag = np.sqrt(np.nanmean((lag.change_deg - true) ** 2))
    assert err_lag < 0.5 * err_lin
    assert np.median(np.abs(lag.thermal_lag_hours - syn.truth.thermal_lag_hours)) < 1.0
    with pytest.raises(InputError, match="thermal must be one of"):
        daily_angles(site, thermal="cubic")


def test_presets_match_the_issue():
    m = simulate_site("mittersheim-like", seed=0, sampling_minutes=120)
    assert len(m.sensors) == 58 and m.sensors["x_m"].iloc[-1] == pytest.approx(167.5)
    assert len(m.truth.days) == 28 and not m.truth.work_days[:7].any() and m.truth.work_days.any()
    assert -m.truth.settlement.min() == pytest.approx(0.02, rel=0.05)
    assert set(m.truth.bad_sensors.values()) == {"dead", "reversed"}
    assert m.readings["temperature_c"].min() == pytest.approx(-5, abs=1.5)
    assert m.readings["temperature_c"].max() == pytest.approx(15, abs=1.5)
    f = simulate_site("farebersviller-like", seed=0, sampling_minutes=240)
    assert len(f.sensors) == 75 and len(f.truth.days) >= 89
    assert f.truth.thermal_lag_hours.min() > 0
    assert f.controls["date"].nunique() == 3 and np.allclose(np.diff(np.unique(f.controls["x_m"])), 10)
    a = simulate_site("mittersheim-like", seed=5, sampling_minutes=120)
    b = simulate_site("mittersheim-like", seed=5, sampling_minutes=120)
    pd.testing.assert_frame_equal(a.readings, b.readings)
    with pytest.raises(InputError, match="unknown preset"):
        simulate_site("paris")


def test_temporal_smoothing_equals_dense_conditioning_with_the_shared_reference_error():
    # external oracle: one dense Gaussian conditioning of (s_1..s_{D-1}) on y_d = s_d - a_0 + n_d, d >= 1, with
    # s a random walk from s_0 = 0 (Cov(s_d, s_e) = q^2 min(d, e)), a_0 ~ N(0, v/2) shared, n_d ~ N(0, v/2)
    rng = np.random.default_rng(0)
    D, N, q, v = 15, 3, 1e-3, (5e-4) ** 2
    truth = np.vstack([np.zeros(N), np.cumsum(rng.normal(0, q, (D - 1, N)), axis=0)])
    a = rng.normal(0, np.sqrt(v / 2), (D, N))
    obs = truth + a - a[0]
    sd = np.full((D, N), np.sqrt(v))
    res = smooth_through_time(obs, sd, process_std=q)
    d = np.arange(1, D)
    S = q**2 * np.minimum.outer(d, d)
    C = S + v / 2 + np.eye(D - 1) * v / 2
    for j in range(N):
        mean = S @ np.linalg.solve(C, obs[1:, j])
        cov = S - S @ np.linalg.solve(C, S)
        assert np.allclose(res.mean[1:, j], mean, atol=1e-12)
        assert np.allclose(res.std[1:, j], np.sqrt(np.diag(cov)), rtol=1e-6)
        var_rate = np.diag(cov)[1:] + np.diag(cov)[:-1] - 2 * np.diag(cov, 1)
        assert np.allclose(res.rate_std[2:, j], np.sqrt(var_rate), rtol=1e-6)
    # the reference day's share cannot be averaged away: the smoothed std stays above sqrt(v / 2) / 2
    assert np.all(res.std[1:] > 0.5 * np.sqrt(v / 2))
    # reference_share=0: the daily errors are independent, a plain random walk + noise
    ind = smooth_through_time(obs, sd, process_std=q, reference_share=0.0)
    C0 = S + np.eye(D - 1) * v
    assert np.allclose(ind.mean[1:, 0], S @ np.linalg.solve(C0, obs[1:, 0]), atol=1e-12)
    est = smooth_through_time(obs, sd)
    assert est.process_std in (5e-4, 1e-3, 2e-3)
    with pytest.raises(InputError, match="reference_share"):
        smooth_through_time(obs, sd, reference_share=1.0)


def _per_station_smoothing(mu, sd, process_std=None, reference_share=0.5, noise_variance_by_day=None):
    """The through-time smoothing as it was written before the batched engine call: one StateSpaceModel and one
    shared_covariance_smoother run per station and candidate q (the oracle of the batched implementation)."""
    from longprofile.rail._temporal import PROCESS_STD_GRID
    from longprofile.statespace import StateSpaceModel, shared_covariance_smoother

    D, N = mu.shape
    var = np.maximum(sd, 1e-7) ** 2
    Y = mu.copy()
    Y[0] = np.nan
    if noise_variance_by_day is not None:
        ws = np.minimum(np.min(noise_variance_by_day[1:]) / noise_variance_by_day, 1.0)
        ws[0] = 1.0
        var_white, var_drift = var * ws[:, None], var * (1 - ws[:, None])
    else:
        var_white, var_drift = var, None

    def run(q, j):
        v = var_white[:, j]
        var_ref = reference_share * float(np.median(v[1:]))
        model = StateSpaceModel(np.eye(2), [[1.0, -1.0]], np.diag([q**2, 0.0]), ((1 - reference_share) * v)
                                .reshape(D, 1, 1), np.zeros(2), np.diag([1e-16, max(var_ref, 1e-20)]))
        return shared_covariance_smoother(model, Y[:, j:j + 1])

    q = process_std
    if q is None:
        ll = [sum(run(g, j).filtered.log_likelihood for j in range(N)) for g in PROCESS_STD_GRID]
        q = PROCESS_STD_GRID[int(np.argmax(ll))]
    mean, std, rate_std = np.empty((D, N)), np.empty((D, N)), np.full((D, N), np.nan)
    for j in range(N):
        sm = run(q, j)
        mean[:, j] = sm.mean[:, 0]
        P = sm.cov[:, 0, 0]
        Pr = P[1:] + P[:-1] - 2 * sm.cross_cov[:, 0, 0]
        if var_drift is not None:
            walk = np.maximum.accumulate(var_drift[:, j])
            P, Pr = P + walk, Pr + np.diff(walk)
        std[:, j] = np.sqrt(P)
        rate_std[1:, j] = np.sqrt(np.maximum(Pr, 0.0))
    return q, mean, std, rate_std


@settings(max_examples=15, deadline=None)
@given(D=st.integers(2, 40), N=st.integers(1, 6), seed=st.integers(0, 2**16), drift=st.booleans(),
       given_q=st.booleans(), missing=st.sampled_from([0.0, 0.1]), share=st.sampled_from([0.0, 0.5]))
def test_batched_through_time_smoothing_equals_one_smoother_per_station(D, N, seed, drift, given_q, missing, share):
    """The grid search over q and the smoother run as ONE batch of the engine's filter (per-series covariances);
    it must equal one model and one smoother per station and candidate q to round-off (and pick the same q)."""
    rng = np.random.default_rng(seed)
    q_true = rng.choice([1e-4, 1e-3])
    mu = np.vstack([np.zeros(N), np.cumsum(rng.normal(0, q_true, (D - 1, N)), axis=0)])
    sd = rng.uniform(2e-4, 1e-3, (D, N))
    mu = mu + sd * rng.standard_normal((D, N))
    mu[1:][rng.random((D - 1, N)) < missing] = np.nan
    nv = np.cumsum(rng.uniform(1e-10, 1e-9, D)) if drift else None
    q = 1e-3 if given_q else None
    got = smooth_through_time(mu, sd, process_std=q, reference_share=share, noise_variance_by_day=nv)
    q_ref, mean, std, rate_std = _per_station_smoothing(mu, sd, q, share, nv)
    assert got.process_std == q_ref
    np.testing.assert_allclose(got.mean, mean, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(got.std, std, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(got.rate_std, rate_std, rtol=1e-7, atol=1e-13)
    np.testing.assert_allclose(got.rate[1:], np.diff(mean, axis=0), rtol=1e-9, atol=1e-15)


def test_alarm_probabilities_are_gaussian_tail_probabilities():
    days = pd.date_range("2020-01-01", periods=2).to_numpy()
    mean = np.array([[0.0, -0.004], [0.0, -0.012]])
    std = np.full((2, 2), 0.002)
    al = settlement_alarms(days, ["A", "B"], np.array([0.0, 3.0]), mean, std, threshold_m=0.01,
                           min_probability=0.01)
    row = al[(al.date == "2020-01-02") & (al.sensor_id == "B")].iloc[0]
    assert row.probability == pytest.approx(norm.cdf((-0.01 + 0.012) / 0.002) + norm.sf((0.01 + 0.012) / 0.002))
    assert set(al.columns) == {"date", "sensor_id", "x_m", "kind", "value", "threshold", "probability"}
    none = settlement_alarms(days, ["A", "B"], np.zeros(2), mean, std, threshold_m=1.0)
    assert len(none) == 0
    # nothing exceeds: the same columns with the dtypes of a non-empty result (were object: np.allclose raised)
    assert none.dtypes.to_dict() == al.dtypes.to_dict()
    with pytest.raises(InputError, match="rate threshold needs"):
        settlement_alarms(days, ["A", "B"], np.zeros(2), mean, std, rate_threshold_m_per_day=0.001)

