"""All days at once (issue 13, step 10): day-correlated sensor errors and a work-day settlement prior."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.rail import estimate_settlement, validate_site
from longprofile.rail._joint import day_modes, day_noise_covariance, joint_posterior
from longprofile.rail._rigidity import FIRST_SLOPE_PRIOR_STD, rigidity_cost_matrix
from longprofile.rail._scenarios import simulate_scenario
from longprofile.rail._settle import increment_rigidity
from tests._fingerprint import assert_same_fingerprint, fingerprint

SMALL = dict(n_sensors=(16, 18), n_days=(14, 16), sampling_minutes=60.0)


def _dense_joint(x, M, R, S, r, f, sigma_z=1e-5):
    """The joint Gaussian posterior of all days, written out densely: vec(X) ~ N(0, S ⊗ Pi^-1) with Pi the
    paper's per-day prior precision (cost matrix + end anchors + the state-space form's first-slope prior), the
    slope observations with noise covariance R ⊗ diag(f^2) (days-major)."""
    N = x.size
    K = S.shape[0]
    Pi = rigidity_cost_matrix(x, rigidity=r)
    Pi[0, 0] += 1.0 / sigma_z**2
    Pi[N - 1, N - 1] += 1.0 / sigma_z**2
    Pi[N, N] += 1.0 / FIRST_SLOPE_PRIOR_STD**2
    H = np.kron(np.eye(K), np.hstack([np.zeros((N, N)), np.eye(N)]))
    W = np.linalg.inv(np.kron(R, np.diag(f**2)))
    prec = np.kron(np.linalg.inv(S), Pi) + H.T @ W @ H
    cov = np.linalg.inv(prec)
    mean = cov @ (H.T @ W @ M.ravel())
    z = mean.reshape(K, 2 * N)[:, :N]
    zs = np.sqrt(np.diag(cov)).reshape(K, 2 * N)[:, :N]
    Dz = np.kron(np.eye(K) - np.eye(K, k=-1), np.hstack([np.eye(N), np.zeros((N, N))]))
    rate_std = np.sqrt(np.diag(Dz @ cov @ Dz.T)).reshape(K, N)
    return z, zs, rate_std


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(5, 9), k=st.integers(2, 6))
def test_the_modes_give_the_dense_joint_posterior(seed, n, k):
    """Mode by mode through the engine's smoother == the dense Gaussian posterior of all days and stations."""
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.uniform(1.0, 5.0, n))
    A = rng.normal(0.0, 3e-5, (k, k))
    R = A @ A.T + np.diag(rng.uniform(0.5e-10, 4e-10, k))  # any positive-definite day covariance
    rd = np.exp(rng.uniform(np.log(1e-12), np.log(1e-9), k))
    f = np.exp(rng.uniform(-0.7, 0.7, n))
    M = np.vstack([np.zeros(n), rng.normal(0.0, 1e-4, (k, n))])
    modes = day_modes(R, rd)
    # the generalised eigenbasis diagonalises both day covariances
    L = np.tril(np.ones((k, k)))
    S = (L * (rd / rd.max())) @ L.T
    V = modes.to_modes.T
    np.testing.assert_allclose(V.T @ S @ V, np.eye(k), atol=1e-9)
    np.testing.assert_allclose(V.T @ R @ V, np.diag(modes.noise**2), atol=1e-9 * np.max(modes.noise**2))
    jp = joint_posterior(x, M, modes, penalty_order=2, sensor_factors=f, level_step=0.0)
    z, zs, rs = _dense_joint(x, M[1:], R, S, modes.rigidity, f)
    scale = np.max(np.abs(z))
    np.testing.assert_allclose(jp.z_mean[1:], z, atol=1e-7 * scale)
    np.testing.assert_allclose(jp.z_std[1:], zs, rtol=1e-4)
    np.testing.assert_allclose(jp.rate_std[1:], rs, rtol=1e-4)
    assert np.all(jp.z_mean[0] == 0) and np.all(jp.z_std[0] == 0)
    assert np.all(jp.z_std >= jp.noise_std * (1 - 1e-9))


@pytest.mark.parametrize("seed", [0, 4, 9])
def test_day_noise_covariance_recovers_a_random_walk(seed):
    """Sensors drifting as random walks (diffusion q^2 f_i^2 per day) with white daily errors, each change measured
    against a reference day that has its own error: the walk's diffusion comes back within 20 % and each day's
    variance 2 s^2 + q^2 t_d within 15 % on average (20 seeds: walk 0.83-1.12, days 0.88-1.10 of the truth); the
    white and reference terms are less well told apart (the reference only enters the first increment)."""
    rng = np.random.default_rng(seed)
    N, D = 60, 30
    x = np.cumsum(rng.uniform(2.0, 4.0, N))
    f = np.exp(rng.uniform(-0.5, 0.5, N))
    q, s = 4e-5, 1.5e-5  # rad/sqrt(day), rad
    walk = np.cumsum(rng.normal(0.0, q, (D, N)), axis=0) * f
    walk -= walk[0]
    e = rng.normal(0.0, s, (D, N)) * f
    M = walk + e - e[0]
    cov = day_noise_covariance(x, M, sensor_factors=f)
    c = cov.coefficients
    assert c["walk"] == pytest.approx(q**2, rel=0.2)
    assert np.mean(np.diag(cov.cov) / (2 * s**2 + q**2 * np.arange(1, D))) == pytest.approx(1.0, abs=0.15)
    assert 0.4 * s**2 < c["white"] < 2.5 * s**2
    assert c["thermal"] == 0.0 and c["thermal_white"] == 0.0  # no temperature given
    assert np.all(np.linalg.eigvalsh(cov.cov) > 0)


def _short_memory_site(seed, N=60, D=30, s=1e-5, a=1e-5):
    """Drift-free slope changes: white (std s) + AR(1) errors of lag-1 correlation e^-1 (std a) per day, times each
    sensor's factor, each change against the reference day's own error. (x, M, f, variance of the last change)."""
    rng = np.random.default_rng(seed)
    rho = np.exp(-1.0)
    x = np.cumsum(rng.uniform(2.0, 4.0, N))
    f = np.exp(rng.uniform(-0.5, 0.5, N))
    ar = np.empty((D, N))
    ar[0] = rng.normal(0.0, a, N)
    for d in range(1, D):
        ar[d] = rho * ar[d - 1] + np.sqrt(1.0 - rho**2) * rng.normal(0.0, a, N)
    e = (rng.normal(0.0, s, (D, N)) + ar) * f
    return x, e - e[0], f, 2.0 * (s**2 + a**2) - 2.0 * a**2 * rho ** (D - 1)


def test_day_noise_covariance_does_not_read_a_short_memory_error_as_drift():
    """Drift-free sensors whose daily error persists for about a day (as the daily medians of a thermal residual do):
    over 8 seeds the median share of the last day's variance that the fitted random walk claims is below 1 and the
    median ratio of the fitted day variances to the truth's last-day value is 0.7-1.4 (measured: 0.02 and 0.84; single seeds up to
    1.44 and 1.39). Without the short-memory term (session 40) the fit read the lag-1 correlation as drift: medians
    3.5 and 2.4, the over-wide bands of the drift-free mittersheim-like preset (docs/rail.md)."""
    walk, ratio = [], []
    for seed in range(8):
        x, M, f, true_last = _short_memory_site(seed)
        cov = day_noise_covariance(x, M, sensor_factors=f)
        walk.append(cov.coefficients["walk"] * (M.shape[0] - 1) / true_last)
        ratio.append(np.mean(np.diag(cov.cov)) / true_last)
    assert np.median(walk) < 1.0
    assert 0.7 < np.median(ratio) < 1.4


def test_work_days_get_the_prior_and_quiet_days_the_floor():
    """A bowl that deepens on two days only: those two increments carry the largest prior intensity."""
    rng = np.random.default_rng(2)
    N, D = 30, 16
    x = np.cumsum(rng.uniform(2.0, 4.0, N))
    u = (x - x.mean()) / 8.0
    slope_shape = u / 8.0 * np.exp(-0.5 * u**2)  # slope of a unit Gaussian bowl, 1/m
    depth = np.zeros(D)
    depth[6:] += 0.006
    depth[11:] += 0.008
    M = depth[:, None] * slope_shape[None, :]
    M += np.cumsum(rng.normal(0.0, 3e-5, (D, N)), axis=0) - rng.normal(0.0, 3e-5, N)
    M[0] = 0.0
    cov = day_noise_covariance(x, M)
    prior = increment_rigidity(x, M, noise_cov=cov.cov, floor=0.02)
    top = set(np.argsort(prior.rigidity_by_day)[-2:] + 1)
    assert top == {6, 11}
    assert np.min(prior.rigidity_by_day) == pytest.approx(0.02 * np.max(prior.rigidity_by_day))


def test_bad_inputs_are_refused():
    with pytest.raises(InputError, match="day-to-day"):
        day_noise_covariance(np.arange(10.0), np.zeros((4, 10)))
    with pytest.raises(InputError, match="rigidity_by_day"):
        day_modes(np.eye(3), [1.0, 0.0, 1.0])
    with pytest.raises(InputError, match="noise_cov"):
        day_modes(np.eye(2), [1.0, 1.0, 1.0])
    M = np.zeros((4, 6))
    M[2, 3] = np.nan
    with pytest.raises(InputError, match="miss some days"):
        joint_posterior(np.arange(6.0), M, day_modes(np.eye(3), [1.0, 1.0, 1.0]))


def _rms(sc, res):
    return float(np.sqrt(np.mean((res.dz[1:] - sc.truth.settlement[1:]) ** 2)))


@pytest.fixture(scope="module")
def drift_sites():
    out = []
    for seed in (300, 301, 302, 303, 304, 305):
        sc = simulate_scenario("drift", seed, **SMALL)
        site = validate_site(sc.sensors, sc.readings, sc.survey)
        out.append((sc, estimate_settlement(site, n_monte_carlo=0),
                    estimate_settlement(site, n_monte_carlo=0, joint_days=False)))
    return out


def test_random_walk_drift_is_subtracted_not_only_down_weighted(drift_sites):
    """Sites whose sensors drift as random walks (scenario family "drift", small sites, calibration seeds): the
    all-days estimate's settlement error is below the per-day one's on the whole (mean over six sites at least 10 %
    lower: measured 0.69 against 0.97 mm) and below 1 mm RMS at the median site (measured 0.63 mm)."""
    new = np.array([_rms(sc, a) for sc, a, _ in drift_sites])
    old = np.array([_rms(sc, b) for sc, _, b in drift_sites])
    assert new.mean() < 0.9 * old.mean()
    assert np.median(new) < 1e-3
    for sc, res, _ in drift_sites:
        assert res.settings["joint_days"] and res.increment_rigidity is not None
        assert res.noise_day_cov.shape == (res.days.size - 1,) * 2


def test_the_joint_bands_cover_the_truth(drift_sites):
    """Daily and rate 90 % bands of the all-days posterior on the same sites: pooled coverage 80-98 % (measured
    85.4 % and 94.8 %)."""
    z = np.concatenate([((res.dz - sc.truth.settlement)[1:] / res.dz_std[1:]).ravel() for sc, res, _ in drift_sites])
    assert 0.80 <= np.mean(np.abs(z) <= 1.6448536) <= 0.98
    zr = np.concatenate([((res.smoothed.rate - np.diff(sc.truth.settlement, axis=0, prepend=np.nan))[1:]
                          / res.smoothed.rate_std[1:]).ravel() for sc, res, _ in drift_sites])
    assert 0.80 <= np.mean(np.abs(zr) <= 1.6448536) <= 0.98


#: Fingerprints (tests/_fingerprint.py: shape, NaN mask, weighted sums) of the step-9 output computed by the code of
#: 91ba304 (before step 10) on two small sites, ``n_monte_carlo=50``: dz, dz_std, dz_noise_std, slope_change, smoothed
#: mean/std/rate_std, maximum settlement mean/lower/upper, factors, weights. Equal to 1e-9 of each array's scale: a
#: sha256 would fail on the last bits a compiling process (a fresh clone) moves. 91ba304 took the outlier test's noise
#: std from every deviation (zeros included; the non-zero ones since step 19, docs/rail.md): the test puts that rule
#: back, so that it compares the estimator on the same daily angles.
STEP9_FINGERPRINTS = {
    ("drift", 7): {
        "dz": ([15, 18], "eb142b0cae0baa72", [-0.5704823310922601, -0.4914616882311103, -0.5250572773243877],
                   0.6565800903686924),
        "dz_noise_std": ([15, 18], "eb142b0cae0baa72", [0.23720318905525842, 0.2372971837905788, 0.2382317595902606],
                   0.2369788810948965),
        "dz_std": ([15, 18], "eb142b0cae0baa72", [0.31642501533439016, 0.3172953065507552, 0.31791977729781035],
                   0.31687459893909864),
        "factors": ([18], "709e80c88487a241", [17.09648103458176, 17.406096527430837, 16.61787126256056],
                   17.50577362288986),
        "max_lower": ([15], "96a296d224f285c6", [0.07387494045270027, 0.06282872615175052, 0.07627413609219838],
                   0.07579036583254978),
        "max_mean": ([15], "96a296d224f285c6", [0.11920497465460037, 0.10023284597677615, 0.12569102847936767],
                   0.1206318246783333),
        "max_upper": ([15], "96a296d224f285c6", [0.17023173457548135, 0.14349216429199946, 0.1811132705015855],
                   0.17102562804242094),
        "rate_std": ([15, 18], "062054d304808e63", [0.13614803324647717, 0.1389443659699251, 0.13804575827794843],
                   0.1385245012207798),
        "slope_change": ([15, 18], "eb142b0cae0baa72", [0.000902699113613039, -0.0017242345173308301, -0.00479349852259448],
                   0.09124131984383005),
        "smoothed_mean": ([15, 18], "eb142b0cae0baa72", [-0.5906289524401711, -0.5147816720656543, -0.5468907091220135],
                   0.6518148914390713),
        "smoothed_std": ([15, 18], "eb142b0cae0baa72", [0.2914813163716242, 0.292532286159334, 0.2932227333614972],
                   0.2920784059693718),
        "weights": ([17], "709e80c88487a241", [22.253678001136613, 20.243893716151707, 21.898397955981146],
                   22.141326885343265),
    },
    ("faults", 3): {
        "dz": ([14, 18], "66687aadf862bd77", [0.020403331765675506, 0.008401349675299864, 0.015337905383640497],
                   0.164837251939639),
        "dz_noise_std": ([14, 18], "66687aadf862bd77", [0.0830510684829699, 0.08261012366017657, 0.08263915496495822],
                   0.08274382791314724),
        "dz_std": ([14, 18], "66687aadf862bd77", [0.15935836687219623, 0.16004482702905853, 0.16003659263284786],
                   0.16015458968071966),
        "factors": ([18], "709e80c88487a241", [19.286491794060513, 18.980941074438256, 17.811006229716316],
                   19.18995429162601),
        "max_lower": ([14], "96a296d224f285c6", [0.005243042471324338, 0.004549801228076432, 0.005531261570612021],
                   0.006073645950801291),
        "max_mean": ([14], "96a296d224f285c6", [0.0279892483399142, 0.02335460453317979, 0.03108908678692446],
                   0.02821659892649705),
        "max_upper": ([14], "96a296d224f285c6", [0.05833907240213893, 0.04957765845572864, 0.06492011279105532],
                   0.05800236305000786),
        "rate_std": ([14, 18], "627661c83a910f81", [0.04615337808317477, 0.04747543576659666, 0.047332368200725866],
                   0.047564143530578744),
        "slope_change": ([14, 18], "66687aadf862bd77", [-0.0027339302395365714, -0.00031545928504649805, -0.0025304324742304],
                   0.029850089764107902),
        "smoothed_mean": ([14, 18], "66687aadf862bd77", [0.010814293247509425, -0.0019706378136768368, 0.00586357788773992],
                   0.15402254663755421),
        "smoothed_std": ([14, 18], "66687aadf862bd77", [0.13893403147362696, 0.13958971946276882, 0.1393615230608587],
                   0.139590115969205),
        "weights": ([17], "709e80c88487a241", [47.6716558993882, 43.340821979348135, 43.04128980736515],
                   45.5367442587047),
    },
}


def _noise_std_with_zeros(dev) -> float:
    """The outlier test's noise std before step 19: 1.4826 x the median of every |deviation|, zeros included."""
    return 1.4826 * float(np.median(np.abs(dev))) if len(dev) else float("nan")


@pytest.mark.parametrize("family,seed", sorted(STEP9_FINGERPRINTS))
def test_joint_days_false_is_the_step9_estimate(family, seed, monkeypatch):
    from longprofile.rail import _thermal

    monkeypatch.setattr(_thermal, "_noise_std", _noise_std_with_zeros)
    sc = simulate_scenario(family, seed, **SMALL)
    site = validate_site(sc.sensors, sc.readings, sc.survey)
    # step 9 printed the simultaneous band's max-settlement interval (the "draws" interval since step 13)
    res = estimate_settlement(site, n_monte_carlo=50, joint_days=False, max_settlement_interval="band")
    arrs = dict(dz=res.dz, dz_std=res.dz_std, dz_noise_std=res.dz_noise_std, slope_change=res.slope_change,
                smoothed_mean=res.smoothed.mean, smoothed_std=res.smoothed.std, rate_std=res.smoothed.rate_std,
                max_mean=res.max_settlement_mean, max_lower=res.max_settlement_lower,
                max_upper=res.max_settlement_upper, factors=res.sensor_noise_factor, weights=res.prior_weights)
    assert_same_fingerprint(fingerprint(arrs), STEP9_FINGERPRINTS[(family, seed)])
    assert res.increment_rigidity is None and res.noise_day_cov is None and not res.settings["joint_days"]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_residual_factors_recover_the_drifters_better_than_the_neighbour_equations(seed):
    """Sensors drifting as random walks of diffusion spread over a decade, a settlement already removed (the fitted
    slope changes are the truth, 0): the factors from each sensor's own residual increments follow the true relative
    drift (log-slope 0.8-1.2, correlation > 0.9) better than the neighbour-equation factors (step 9). Measured on
    seeds 0-2: log-slope 0.87 / 0.86 / 0.89 against 0.69 / 0.48 / 0.70, correlation 0.96 / 0.96 / 0.96 against
    0.89 / 0.77 / 0.90."""
    from longprofile.rail._settle import residual_noise_factors, sensor_noise_factors

    rng = np.random.default_rng(seed)
    N, D = 40, 25
    x = np.cumsum(rng.uniform(2.0, 4.0, N))
    q = np.exp(rng.uniform(np.log(1.7e-5), np.log(1.7e-4), N))
    M = np.cumsum(rng.normal(0.0, 1.0, (D, N)) * q, axis=0) + rng.normal(0.0, 1e-5, (D, N))
    M -= M[0]
    f_nb = sensor_noise_factors(x, M)
    f_res = residual_noise_factors(M, np.zeros_like(M), np.ones(D - 1, bool), reference_factors=f_nb)
    lt = np.log(q / np.exp(np.mean(np.log(q))))
    slope, _ = np.polyfit(lt, np.log(f_res), 1)
    assert 0.8 < slope < 1.2
    c_res = np.corrcoef(lt, np.log(f_res))[0, 1]
    c_nb = np.corrcoef(lt, np.log(f_nb))[0, 1]
    assert c_res > 0.9 and c_res > c_nb
    # the scale of the reference factors is kept (the day covariance was fitted with it)
    assert np.mean(np.log(f_res)) == pytest.approx(np.mean(np.log(f_nb)), abs=0.05)
