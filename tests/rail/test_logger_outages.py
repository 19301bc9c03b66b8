"""Logger outages (docs/rail.md, "Logger outages, and a prior that claimed no change"): the scenario family that has
them, and the per-day model's prior, which claimed "no change, no doubt" on a site whose bowl it could not tell from
the noise."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import longprofile.rail._settle as settle
from longprofile.rail import estimate_settlement, validate_site
from longprofile.rail._joint import joint_posterior
from longprofile.rail._rigidity import rigidity_log_likelihood
from longprofile.rail._scenarios import simulate_scenario
from longprofile.rail._settle import _LOG10_RIGIDITY_GRID, _changed_rows, fit_change_prior


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_an_outage_removes_whole_days_of_one_loggers_sensors_and_nothing_else(seed):
    """``drift-outages`` is ``drift`` with the readings of the outages taken out (their own random stream)."""
    full = simulate_scenario("drift", seed).readings
    sc = simulate_scenario("drift-outages", seed)
    ids = list(sc.sensors["sensor_id"])
    start = pd.Timestamp(sc.truth.days[0])
    gone = np.zeros(len(full), bool)
    outages = sc.truth.params["logger_outages"]
    assert len(outages) == 2
    for o in outages:
        j0 = ids.index(o["first_sensor"])
        assert 1 <= o["n_days"] <= 4 and 6 <= o["n_sensors"] <= 12 and o["first_day"] >= 1
        day = ((full["timestamp"] - start) / pd.Timedelta(days=1)).to_numpy()
        gone |= (full["sensor_id"].isin(ids[j0:j0 + o["n_sensors"]]).to_numpy()
                 & (day >= o["first_day"]) & (day < o["first_day"] + o["n_days"]))
    assert gone.any()
    pd.testing.assert_frame_equal(sc.readings, full[~gone].reset_index(drop=True))


def test_the_stiffest_likelihood_is_the_engines_at_the_grids_stiffest_rigidity():
    """``ChangePriorFit.stiffest_log_likelihood``: the rigidity model's Kalman-filter likelihood at the grid's stiffest
    r (the oracle: :func:`rigidity_log_likelihood`, the model built at that r, not the search's scaled one), never
    above the maximised one."""
    sc = simulate_scenario("drift", 3)
    rng = np.random.default_rng(0)
    x = sc.truth.x
    slopes = sc.truth.slope_change + rng.normal(0, 5e-5, sc.truth.slope_change.shape)
    fit = fit_change_prior(x, slopes, sigma=5e-5)
    rows = _changed_rows(slopes)
    for order in (2, 3):
        r0 = 10.0 ** _LOG10_RIGIDITY_GRID[order][0]
        oracle = rigidity_log_likelihood(x, rows, sigma=5e-5, rigidity=r0, sigma_z=1e-5, penalty_order=order)
        assert fit.stiffest_log_likelihood[order] == pytest.approx(float(np.sum(oracle)), rel=1e-9)
        assert fit.stiffest_log_likelihood[order] <= fit.log_likelihood[order] + 1e-9


@pytest.mark.parametrize("stiffest_lr, ok", [(settle.STIFFEST_LR, True), (0.0, False)])
def test_a_prior_that_cannot_tell_the_settlement_from_the_noise_is_not_kept(monkeypatch, stiffest_lr, ok):
    """``drift-outages`` seed 128, per-day model (the live service's above 40 000 sensor-days): with the per-day noise
    the likelihood is flat from r = 1e-15 to 1e-12.5 (within 0.05) and the bounded search stopped at 1.18e-13, off the
    grid's end: the old rule kept that prior and printed 0.02 +- 0.35 mm where the track had settled 8.8 mm (|z| 25).
    The likelihood-ratio rule refits the prior with the day-difference noise (|z| <= 2.1). ``STIFFEST_LR = 0`` is the
    old rule on this site (a fallback only where the maximum is the grid's end)."""
    monkeypatch.setattr(settle, "STIFFEST_LR", stiffest_lr)
    sc = simulate_scenario("drift-outages", 128)
    res = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=0, joint_days=False)
    z = np.abs((res.dz - sc.truth.settlement) / res.dz_std)[1:]
    assert (np.nanmax(z) < 3.0) == ok, np.nanmax(z)
    assert any("at its stiffest" in w for w in res.warnings) == ok


def _dense_oracle(x, modes, R, factors, observed, sigma_z):
    """The posterior given the observed sensor-days by textbook Gaussian conditioning: the complete-data posterior
    mean is H m (H from unit data, one ``joint_posterior`` per entry), so Sigma_theta = (I - H)^{-1} H Sigma_e and
    Sigma_m = Sigma_theta + Sigma_e; then theta | m_O ~ N(S_tO S_OO^{-1} m_O, S_tt - S_tO S_OO^{-1} S_Ot)."""
    from scipy.linalg import block_diag

    K, N = observed.shape[0] - 1, observed.shape[1]

    def mean(data):
        return joint_posterior(x, np.vstack([np.zeros((1, N)), data]), modes, penalty_order=2,
                               sensor_factors=factors, sigma_z=sigma_z).slope_mean[1:]

    H = np.empty((K * N, K * N))
    for e in range(K * N):
        unit = np.zeros(K * N)
        unit[e] = 1.0
        H[:, e] = mean(unit.reshape(K, N)).ravel()
    # vec index d * N + i; Sigma_e of sensor i is f_i^2 R over the days: permute a block-diagonal by sensor
    by_sensor = block_diag(*[f ** 2 * R for f in factors])
    order = np.arange(K * N).reshape(N, K).T.ravel()  # day-major index -> sensor-major position
    Se = by_sensor[np.ix_(order, order)]
    St = np.linalg.solve(np.eye(K * N) - H, H @ Se)
    St = 0.5 * (St + St.T)
    Sm = St + Se
    m = observed[1:].ravel()
    O = np.isfinite(m)
    mu = St[:, O] @ np.linalg.solve(Sm[np.ix_(O, O)], m[O])
    var = np.diag(St) - np.einsum("ij,ji->i", St[:, O], np.linalg.solve(Sm[np.ix_(O, O)], St[O, :]))
    return mu.reshape(K, N), np.sqrt(var).reshape(K, N)


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**31))
@example(seed=2231579)  # two modes within 2 % of each other: one shared level
def test_the_missing_days_posterior_is_gaussian_conditioning_on_the_observed_days(seed):
    """``_impute_missing`` against the dense conditioning of the same model (K = 6 days, N = 7 sensors, a random
    day covariance, prior rigidities and factors, two sensors with missing days): slope means and stds agree to 1e-6."""
    from longprofile.rail._joint import _noise_groups, day_modes
    from longprofile.rail._settle import _fill_missing_days, _impute_missing

    rng = np.random.default_rng(seed)
    K, N = 6, 7
    x = np.cumsum(rng.uniform(2.0, 4.0, N))
    A = rng.normal(size=(K, K))
    R = 1e-8 * (A @ A.T / K + np.eye(K))
    modes = day_modes(R, rng.uniform(1e-10, 1e-8, K))
    # modes whose noise stds agree within 2 % share one covariance pass at their median (joint_posterior's level_step):
    # the model both sides condition is then that of the shared levels, R = T^-1 diag(levels^2) T^-T (seed 2231579)
    levels = np.empty(K)
    for idx, level in _noise_groups(modes.noise):
        levels[idx] = level
    T_inv = np.linalg.inv(modes.to_modes)
    R = T_inv @ np.diag(levels**2) @ T_inv.T
    f = rng.uniform(0.7, 1.5, N)
    obs = np.vstack([np.zeros(N), rng.normal(0, 1e-4, (K, N))])
    obs[2:4, 2] = np.nan
    obs[rng.integers(1, K + 1), 5] = np.nan
    filled, n = _fill_missing_days(obs, np.arange(K + 1.0))
    assert n == 3
    jp = joint_posterior(x, filled, modes, penalty_order=2, sensor_factors=f, sigma_z=1e-5)
    post, _, records = _impute_missing(x, obs, filled, jp, R, 2, f, None, 1e-5, np.random.default_rng(0))
    mu, sd = _dense_oracle(x, modes, R, f, obs, 1e-5)
    scale = np.abs(mu).max()
    np.testing.assert_allclose(post["slope_mean"][1:], mu, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(post["slope_std"][1:], sd, rtol=1e-6)
    assert records.shape == (8, K, N)
    # missing days only widen the bands (the interpolated days were counted as measured)
    assert np.all(post["slope_std"] >= jp.slope_std - 1e-15)


def _outage_z(seeds, **overrides):
    """z-scores of the daily settlement on the outage sensor-days of ``drift-outages`` sites, and the last warnings."""
    zs, warned = [], []
    for seed in seeds:
        sc = simulate_scenario("drift-outages", seed, **overrides)
        res = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=0)
        z = (res.dz - sc.truth.settlement)[1:] / res.dz_std[1:]  # day 0: no change, std 0
        out = np.zeros(z.shape, bool)
        for o in sc.truth.params["logger_outages"]:
            j0 = res.sensor_ids.index(o["first_sensor"])
            out[o["first_day"] - 1:o["first_day"] - 1 + o["n_days"], j0:j0 + o["n_sensors"]] = True
        zs.append(z[out & np.isfinite(z)])
        warned = [w for w in res.warnings if "sensor-day(s) without a daily angle" in w]
    return np.concatenate(zs), warned


def test_week_long_outages_widen_the_bands_where_the_days_are_missing(monkeypatch):
    """Outages of 5-10 days, seeds 100-109: on the missing sensor-days the 90 % band covers 77.1 % (RMS z 1.48)
    treated as missing, 67.0 % (1.76) interpolated and counted as measured (measured; pooled over seeds 100-139 85.3 %
    against 74.6 %, docs/rail.md). Above ``MISSING_DAY_MAX`` the old treatment is kept, and said."""
    z, warned = _outage_z(range(100, 110), outage_days=(5, 10))
    assert len(warned) == 1 and "treat them as missing" in warned[0]
    monkeypatch.setattr(settle, "MISSING_DAY_MAX", 0)
    z0, warned0 = _outage_z(range(100, 110), outage_days=(5, 10))
    assert len(warned0) == 1 and "counted as measured" in warned0[0]
    cover, cover0 = np.mean(np.abs(z) <= 1.6449), np.mean(np.abs(z0) <= 1.6449)
    assert cover >= cover0 + 0.05 and np.sqrt(np.mean(z**2)) <= np.sqrt(np.mean(z0**2)) - 0.15


@pytest.mark.parametrize("n_draws", [3, 9])
def test_fewer_maximum_settlement_draws_than_completed_records(n_draws):
    """The maximum settlement's draws are shared among MISSING_DAY_IMPUTATIONS (8) completed records: with fewer draws
    than records (``--monte-carlo 3``) the later records get none, instead of an empty draw request (found in the
    session 33 review: "n_samples must be a positive integer; got 0")."""
    sc = simulate_scenario("drift-outages", 100)
    res = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=n_draws)
    assert any("treat them as missing" in w for w in res.warnings)
    assert np.isfinite(res.max_settlement_mean[1:]).all()
