"""The all-days model's batched stages (docs/rail-service.md, "All days within the 2 s recompute"): each equals the
one-group-at-a-time computation it replaced (the rail functions of before, run group by group, are the oracle)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.rail import _health
from longprofile.rail._joint import _noise_groups, _posterior_by_level, day_differences
from longprofile.rail._rigidity import (
    measurement_std,
    rigidity_log_likelihood_function,
    rigidity_posterior,
    segment_process_energy,
)
from longprofile.rail._settle import _fit_rigidity, _fit_rigidity_each, segment_prior_weights


def _profiles(seed, D=12, N=15):
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.uniform(2.0, 4.0, N))
    bowl = np.exp(-0.5 * ((x - x.mean()) / 6.0) ** 2)
    M = 2e-4 * rng.standard_normal((D, 1)) * np.gradient(bowl, x) + 1e-5 * rng.standard_normal((D, N))
    return rng, x, M


@settings(max_examples=20, deadline=None)
@given(K=st.integers(1, 40), seed=st.integers(0, 2**31 - 1))
def test_day_differences_are_the_dense_product_bit_for_bit(K, seed):
    C = np.random.default_rng(seed).normal(size=(K, K))
    Delta = np.eye(K) - np.eye(K, k=-1)
    assert np.array_equal(day_differences(C), Delta @ C @ Delta.T)


@pytest.mark.parametrize("order", [2, 3])
@pytest.mark.parametrize("factors", [False, True])
def test_per_day_fits_in_lockstep_are_each_days_own_fit(order, factors):
    rng, x, M = _profiles(order)
    s = np.exp(rng.uniform(np.log(5e-6), np.log(2e-5), M.shape[0]))
    f = rng.uniform(0.5, 2.0, x.size) if factors else None
    got = _fit_rigidity_each(x, M, s, 1e-5, order, f)
    want = np.array([_fit_rigidity(x, M[d:d + 1], float(s[d]), 1e-5, order, f)[0] for d in range(M.shape[0])])
    # the same grid; the bracket refined by scipy's element-wise minimiser instead of one bounded Brent search per
    # day: each within the searches' tolerance (1e-3 in log r) of the optimum, so within 2e-3 of each other, and
    # as likely
    assert np.max(np.abs(np.log(got / want))) <= 2e-3
    for d in range(M.shape[0]):
        loglik = rigidity_log_likelihood_function(x, M[d], sigma=s[d] * (1.0 if f is None else f),
                                                  penalty_order=order)
        assert loglik(got[d]) == pytest.approx(loglik(want[d]), abs=1e-6)


@pytest.mark.parametrize("order", [2, 3])
def test_segment_weights_equal_the_group_by_group_em(order):
    rng, x, M = _profiles(10 + order, D=20)
    sig = np.exp(rng.uniform(np.log(5e-6), np.log(5e-5), M.shape[0]))
    f = rng.uniform(0.5, 2.0, x.size)
    M[:, 4] = np.nan  # an excluded sensor
    got = segment_prior_weights(x, M, sigma=sig, rigidity=1e-8 if order == 2 else 1e-11, penalty_order=order,
                                sensor_factors=f, n_iter=3)
    w = np.ones(x.size - 1)  # the loop of before: one smoother per noise-level group
    rows = M[np.nanmax(np.abs(np.nan_to_num(M)), axis=1) > 0]
    kernel = np.full(3, 1.0 / 3)
    for _ in range(3):
        energy = sum(segment_process_energy(x, rows[idx], sigma=s * f, rigidity=1e-8 if order == 2 else 1e-11,
                                            penalty_order=order, segment_weights=w).sum(axis=0)
                     for idx, s in _noise_groups(sig[np.nanmax(np.abs(np.nan_to_num(M)), axis=1) > 0]))
        wn = np.convolve(np.pad(energy / (order * rows.shape[0]), 1, mode="edge"), kernel, mode="valid")
        w = np.maximum(wn, 0.3 * wn.max())
    # the smoother's covariances by Cholesky in small loops instead of LAPACK's LU: equal to round-off, which the
    # order-3 model's conditioning (1 rad and 0.1 m^-1 initial priors against slopes of 1e-5) turns into ~1e-7
    np.testing.assert_allclose(got, w, rtol=1e-6)


def test_posterior_by_level_equals_each_levels_posterior():
    rng, x, M = _profiles(7, D=25)
    sig = np.exp(rng.uniform(np.log(5e-6), np.log(5e-5), M.shape[0]))
    f = rng.uniform(0.5, 2.0, x.size)
    w = rng.uniform(0.3, 1.0, x.size - 1)
    got = _posterior_by_level(x, M, sig, rigidity=1e-8, sigma_z=1e-5, penalty_order=2, factors=f, weights=w)
    for idx, s in _noise_groups(sig):
        post = rigidity_posterior(x, M[idx], sigma=s * f, rigidity=1e-8, segment_weights=w)
        for k in ("z_mean", "z_std", "slope_mean", "slope_std"):
            np.testing.assert_allclose(got[k][idx], getattr(post, k), rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(got["noise_std"][idx], measurement_std(x, M[idx], sigma=s * f, rigidity=1e-8,
                                                                          segment_weights=w), rtol=1e-9, atol=1e-15)


def test_step_evidence_in_blocks_of_factors_is_the_evidence_over_all_of_them(monkeypatch):
    rng = np.random.default_rng(3)
    K, N = 30, 12
    U = rng.normal(size=(K, K))
    r = rng.normal(size=(K, N))
    r[:, 5] = np.nan  # an excluded sensor
    preds = rng.uniform(0.1, 1.0, (K, N))
    own = rng.uniform(0.1, 2.0, (K, 1))
    g = np.geomspace(*_health.PROFILE_FACTOR_BOUNDS, _health.PROFILE_FACTOR_GRID)
    blocks = _health._step_maxima(U, r, preds, own, g)
    monkeypatch.setattr(_health, "_STEP_FACTOR_BLOCK", 10**6)
    whole = _health._step_maxima(U, r, preds, own, g)
    for k in whole:
        assert np.array_equal(blocks[k], whole[k], equal_nan=True), k
