"""statespace.grouped_covariance_smoother / grouped_log_likelihood / process_noise_energy: oracles are the dense
Gaussian density (scipy), the shared-covariance functions run group by group, and the EM moments."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, ShapeError
from longprofile.statespace import (
    StateSpaceModel,
    grouped_covariance_smoother,
    grouped_log_likelihood,
    process_noise_energy,
    process_noise_moments,
    process_scale_log_likelihood,
    shared_covariance_smoother,
    smoother_noise_covariance,
)

from .test_shared_cov_loglik import _dense_log_likelihood


def _model(rng, T, n, m, diagonal_r=False):
    F = rng.normal(scale=0.5, size=(T - 1, n, n)) + np.eye(n)
    A = rng.normal(size=(T - 1, n, n))
    Q = A @ A.transpose(0, 2, 1) * 0.1 + 0.01 * np.eye(n)
    H = rng.normal(size=(m, n))
    B0 = rng.normal(size=(n, n))
    if diagonal_r:
        R = np.zeros((T, m, m))
        R[:, np.arange(m), np.arange(m)] = rng.uniform(0.1, 1.0, (T, m))
    else:
        C = rng.normal(size=(m, m))
        R = C @ C.T * 0.2 + 0.05 * np.eye(m)
    return StateSpaceModel(F, H, Q, R, rng.normal(size=n), B0 @ B0.T + 0.1 * np.eye(n),
                           state_offset=rng.normal(scale=0.1, size=(T - 1, n)), obs_offset=rng.normal(size=m))


def _groups(rng, T, m, n_groups, n_series):
    """Series with one NaN pattern per group, every group used, per-group scales and diagonal R."""
    group = np.concatenate([np.arange(n_groups), rng.integers(0, n_groups, n_series - n_groups)])
    y = rng.normal(size=(n_series, T, m))
    pattern = rng.random((n_groups, T, m)) < 0.2
    y[pattern[group]] = np.nan
    scale = np.exp(rng.uniform(-2, 2, n_groups))
    R = np.zeros((n_groups, T, m, m))
    R[:, :, np.arange(m), np.arange(m)] = rng.uniform(0.1, 2.0, (n_groups, T, m))
    return group, y, scale, R


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), T=st.integers(2, 12), n=st.integers(1, 3), m=st.integers(1, 2),
       n_groups=st.integers(1, 4), extra=st.integers(0, 4))
def test_grouped_results_are_the_shared_covariance_results_of_each_group(seed, T, n, m, n_groups, extra):
    rng = np.random.default_rng(seed)
    model = _model(rng, T, n, m)
    group, y, scale, R = _groups(rng, T, m, n_groups, n_groups + extra)
    Rn = R * rng.uniform(0.0, 1.0)
    res = grouped_covariance_smoother(model, y, group, process_scale=scale, obs_cov=R, noise_cov=Rn)
    ll = grouped_log_likelihood(model, y, group, process_scale=scale, obs_cov=R)
    llu = grouped_log_likelihood(model, y, group, process_scale=scale, obs_cov=R, univariate=True)
    for g in range(n_groups):
        rows = group == g
        mg = model.replace(process_cov=scale[g] * model.process_cov, obs_cov=R[g])
        sm = shared_covariance_smoother(mg, y[rows])
        np.testing.assert_allclose(res.mean[rows], sm.mean, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(res.cov[g], sm.cov, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(res.cross_cov[g], sm.cross_cov, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(res.log_likelihood[rows], sm.filtered.log_likelihood, rtol=1e-12)
        # the default likelihood is the shared-covariance one bit for bit; univariate equal to round-off
        assert np.array_equal(ll[rows], process_scale_log_likelihood(model.replace(obs_cov=R[g]), y[rows])(scale[g]))
        np.testing.assert_allclose(llu[rows], ll[rows], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(res.noise_cov[g], smoother_noise_covariance(mg, y[rows][0], noise_cov=Rn[g]),
                                   rtol=1e-8, atol=1e-12)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), T=st.integers(2, 6), n=st.integers(1, 3))
def test_univariate_log_likelihood_is_the_dense_gaussian_density(seed, T, n):
    rng = np.random.default_rng(seed)
    model = _model(rng, T, n, 2, diagonal_r=True)
    y = rng.normal(size=(1, T, 2))
    y[0, rng.random((T, 2)) < 0.3] = np.nan
    got = grouped_log_likelihood(model, y, [0], univariate=True)[0]
    assert got == pytest.approx(_dense_log_likelihood(model, y[0]), rel=1e-9, abs=1e-9)


def test_grouped_inputs_are_checked():
    rng = np.random.default_rng(0)
    model = _model(rng, 5, 2, 2)
    y = rng.normal(size=(2, 5, 2))
    y[0, 1, 0] = np.nan
    with pytest.raises(ShapeError, match="same places"):
        grouped_covariance_smoother(model, y, [0, 0])
    grouped_covariance_smoother(model, y, [0, 1])  # own groups: fine
    with pytest.raises(InputError, match="diagonal"):
        grouped_log_likelihood(model, y, [0, 1], univariate=True)
    with pytest.raises(InputError, match="process_scale"):
        grouped_log_likelihood(model, y, [0, 1], process_scale=[1.0, -1.0])


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), T=st.integers(2, 10), n=st.integers(1, 3), n_groups=st.integers(1, 3))
def test_process_noise_energy_is_the_contracted_moments(seed, T, n, n_groups):
    rng = np.random.default_rng(seed)
    model = _model(rng, T, n, 1)
    group, y, scale, R = _groups(rng, T, 1, n_groups, n_groups + 3)
    res = grouped_covariance_smoother(model, y, group, process_scale=scale, obs_cov=R)
    A = rng.normal(size=(T - 1, n, n))
    W = A @ A.transpose(0, 2, 1) + np.eye(n)
    want = np.einsum("tij,btji->bt", W, process_noise_moments(model, res))
    np.testing.assert_allclose(process_noise_energy(model, res, W), want, rtol=1e-10, atol=1e-12)
    sm = shared_covariance_smoother(model, y[group == 0])  # shared covariances, batched means
    want = np.einsum("tij,btji->bt", W, process_noise_moments(model, sm))
    np.testing.assert_allclose(process_noise_energy(model, sm, W), want, rtol=1e-10, atol=1e-12)
