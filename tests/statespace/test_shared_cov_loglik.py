"""statespace.shared_covariance_log_likelihood: the dense Gaussian density of the stacked observations (scipy) as
the oracle, and bit-identity with the smoother's filter log-likelihood that the rail rigidity fit used before."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import multivariate_normal

from longprofile.errors import InputError, ModelError, ShapeError
from longprofile.statespace import (
    StateSpaceModel,
    log_likelihood,
    process_scale_log_likelihood,
    shared_covariance_log_likelihood,
    shared_covariance_smoother,
)


def _random_model(rng, T, n, m):
    """Time-varying F, Q, R, offsets: nothing the shared pass could get right by accident."""
    F = rng.normal(scale=0.6, size=(T - 1, n, n)) + np.eye(n)
    A = rng.normal(size=(T - 1, n, n))
    Q = A @ A.transpose(0, 2, 1) * 0.1 + 0.01 * np.eye(n)
    H = rng.normal(size=(m, n))
    C = rng.normal(size=(T, m, m))
    R = C @ C.transpose(0, 2, 1) * 0.2 + 0.05 * np.eye(m)
    B0 = rng.normal(size=(n, n))
    return StateSpaceModel(F, H, Q, R, rng.normal(size=n), B0 @ B0.T + 0.1 * np.eye(n),
                           state_offset=rng.normal(scale=0.1, size=(T - 1, n)), obs_offset=rng.normal(size=m))


def _dense_log_likelihood(model, y):
    """log N(y_obs; mu, Sigma) of the observed components, from the model's stacked (dense) joint distribution."""
    T, m = y.shape
    n = model.n_states
    dim = n * T  # z = (x0 - m0, w_0, ..., w_{T-2})
    cov_z = np.zeros((dim, dim))
    cov_z[:n, :n] = model.initial_cov
    L = np.zeros((n, dim))
    L[:, :n] = np.eye(n)
    mean_x = np.array(model.initial_mean, float)
    mu, rows = [], []
    for k in range(T):
        mu.append(model.observation @ mean_x + model.obs_offset)
        rows.append(model.observation @ L)
        if k < T - 1:
            w = slice(n * (k + 1), n * (k + 2))
            cov_z[w, w] = model.process_cov[k]
            L = model.transition[k] @ L
            L[:, w] += np.eye(n)
            mean_x = model.transition[k] @ mean_x + model.state_offset[k]
    G = np.vstack(rows)
    Rb = np.zeros((T * m, T * m))
    for k in range(T):
        Rb[k * m:(k + 1) * m, k * m:(k + 1) * m] = model.obs_cov[k]
    cov_y = G @ cov_z @ G.T + Rb
    obs = ~np.isnan(y.ravel())
    if not obs.any():
        return 0.0  # the density of nothing observed
    return multivariate_normal(np.concatenate(mu)[obs], cov_y[np.ix_(obs, obs)]).logpdf(y.ravel()[obs])


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), T=st.integers(2, 9), n=st.integers(1, 3), m=st.integers(1, 3),
       B=st.integers(1, 4), p_missing=st.sampled_from([0.0, 0.3, 0.6]))
def test_equals_the_dense_gaussian_density_and_the_smoother(seed, T, n, m, B, p_missing):
    rng = np.random.default_rng(seed)
    model = _random_model(rng, T, n, m)
    y = rng.normal(size=(B, T, m)) * 2.0
    y[:, rng.random((T, m)) < p_missing] = np.nan  # one missing pattern for the batch
    got = shared_covariance_log_likelihood(model, y)
    assert got.shape == (B,)
    dense = np.array([_dense_log_likelihood(model, y[b]) for b in range(B)])
    np.testing.assert_allclose(got, dense, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(got, shared_covariance_smoother(model, y).filtered.log_likelihood)
    np.testing.assert_allclose(got, log_likelihood(model, y), rtol=1e-10, atol=1e-10)  # the per-series engine


def test_unbatched_series_gives_a_float():
    rng = np.random.default_rng(5)
    model = _random_model(rng, 6, 2, 1)
    y = rng.normal(size=(6, 1))
    got = shared_covariance_log_likelihood(model, y)
    assert isinstance(got, float)
    assert got == shared_covariance_smoother(model, y).filtered.log_likelihood
    assert got == pytest.approx(_dense_log_likelihood(model, y), rel=1e-10)


def test_rejects_mixed_missing_patterns_inputs_and_an_improper_model():
    rng = np.random.default_rng(6)
    model = _random_model(rng, 5, 2, 2)
    y = rng.normal(size=(3, 5, 2))
    y[2, 1, 0] = np.nan
    with pytest.raises(ShapeError, match="same places"):
        shared_covariance_log_likelihood(model, y)
    m_in = StateSpaceModel(np.eye(1), np.eye(1), np.eye(1), np.eye(1), [0.0], np.eye(1), input_transition=np.eye(1))
    with pytest.raises(ShapeError, match="shared_covariance_log_likelihood does not take known inputs"):
        shared_covariance_log_likelihood(m_in, np.zeros((4, 1)))
    flat = StateSpaceModel(np.eye(1), np.eye(1), np.zeros((1, 1)), np.zeros((1, 1)), [0.0], np.zeros((1, 1)))
    with pytest.raises(ModelError, match="not positive definite"):
        shared_covariance_log_likelihood(flat, np.ones((3, 1)))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), T=st.integers(2, 8), n=st.integers(1, 3), m=st.integers(1, 2),
       B=st.integers(1, 3), log_s=st.floats(-6.0, 6.0), p_missing=st.sampled_from([0.0, 0.4]))
def test_process_scale_log_likelihood_is_the_density_of_the_scaled_model(seed, T, n, m, B, log_s, p_missing):
    rng = np.random.default_rng(seed)
    model = _random_model(rng, T, n, m)
    y = rng.normal(size=(B, T, m)) * 2.0
    y[:, rng.random((T, m)) < p_missing] = np.nan
    s = float(np.exp(log_s))
    scaled = model.replace(process_cov=s * model.process_cov)
    loglik = process_scale_log_likelihood(model, y)
    got = loglik(s)
    np.testing.assert_allclose(got, [_dense_log_likelihood(scaled, y[b]) for b in range(B)], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(got, shared_covariance_log_likelihood(scaled, y), rtol=1e-12, atol=1e-12)
    assert isinstance(process_scale_log_likelihood(model, y[0])(s), float)


def test_process_scale_log_likelihood_refuses_a_bad_scale():
    rng = np.random.default_rng(7)
    loglik = process_scale_log_likelihood(_random_model(rng, 4, 2, 1), rng.normal(size=(4, 1)))
    for bad in (0.0, -1.0, np.nan, np.inf):
        with pytest.raises(InputError, match="scale"):
            loglik(bad)
