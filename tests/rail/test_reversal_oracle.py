"""The oracle bound on reversal detection (benchmarks.bench_rail_calibration.reversal_oracle, docs/rail.md)."""

from __future__ import annotations

import numpy as np
from benchmarks.bench_rail_calibration import pooled_np_detection, reversal_log_lr, reversal_oracle_site
from scipy.stats import multivariate_normal


def test_reversal_log_lr_is_the_gaussian_likelihood_ratio():
    rng = np.random.default_rng(0)
    K = 7
    A = rng.normal(size=(K, K))
    S = A @ A.T + 0.5 * np.eye(K)
    a, m = rng.normal(size=K), rng.normal(size=K)
    llr, info = reversal_log_lr(a, S, m)
    ref = multivariate_normal(-a, S).logpdf(m) - multivariate_normal(a, S).logpdf(m)
    assert np.isclose(llr, ref, rtol=1e-10, atol=1e-10)
    assert np.isclose(info, a @ np.linalg.solve(S, a))
    # a healthy reading of its own mean gives -2 I, a reversed one +2 I
    assert np.isclose(reversal_log_lr(a, S, a)[0], -2 * info) and np.isclose(reversal_log_lr(a, S, -a)[0], 2 * info)


def test_oracle_statistic_is_standard_normal_on_healthy_sensors_and_large_on_reversals():
    """On four faults sites (seeds 200-203) the healthy sensors' standardised statistic has mean ~0 and std ~1 (the
    analytic drift + day-noise covariance fits the tool's daily changes: a wrong unit or a missing drift term would
    put the std far from 1), and each reversed sensor's lies 2 sqrt(I) away (measured: healthy mean 0.32, std 1.00
    over 79 sensors; the reversed ones z 30.6 / 102.7 / 6.2 / 48.0, I 243 / 2609 / 13.6 / 550)."""
    rows = [r for seed in range(200, 204) for r in reversal_oracle_site(seed)]
    healthy = np.array([r["z_tool"] for r in rows if r["kind"] == "healthy" and np.isfinite(r["z_tool"])])
    assert healthy.size >= 60
    assert abs(healthy.mean()) < 0.6 and 0.75 < healthy.std() < 1.3
    rev = [r for r in rows if r["kind"] == "reversed"]
    assert len(rev) == 4
    for r in rev:
        assert r["I_ideal"] > 10 and abs(r["z_tool"] - 2 * np.sqrt(r["I_tool"])) < 4


def test_pooled_threshold_is_the_per_sensor_test_when_every_sensor_has_the_same_information():
    from scipy.special import ndtr, ndtri

    for info, alpha in ((2.0, 0.0046), (9.0, 0.01)):
        lam, p = pooled_np_detection(np.full(50, info), np.full(3, info), alpha)
        z = ndtri(1 - alpha)
        assert np.isclose(lam, 2 * np.sqrt(info) * z - 2 * info, atol=1e-8)
        assert np.allclose(p, ndtr(2 * np.sqrt(info) - z))
    # healthy sensors that see nothing (I ~ 0) spend no false alarms: the threshold drops, the reversals gain
    lam0, p0 = pooled_np_detection(np.full(50, 2.0), [2.0], 0.01)
    lam1, p1 = pooled_np_detection(np.r_[np.full(25, 2.0), np.full(25, 1e-6)], [2.0], 0.01)
    assert lam1 < lam0 and p1[0] > p0[0]
