"""Fixed-lag smoother: E[x_t | y_0..t+L] against external oracles.

Oracles: pykalman's smoother run on the record truncated at t + L (E[x_t | y_0..t+L] is by definition the
fixed-interval smoother of that prefix), the steady-state filter of the model augmented with L delayed copies
of the state (the textbook fixed-lag construction, Anderson & Moore 1979 §7.3), the Kalman filter (L = 0)
and the RTS / steady-state smoother (L beyond the smoother's memory).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from longprofile.errors import InputError, NotDetectableError, ShapeError
from longprofile.statespace import (
    StateSpaceModel,
    fixed_lag_smoother,
    kalman_filter,
    rts_smoother,
    steady_state_filter,
    steady_state_gain,
    steady_state_smoother,
)
from tests.statespace._models import draw, random_model

PROPS = settings(max_examples=10, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])


def _pykalman_smooth(model, y):
    import pykalman
    kf = pykalman.KalmanFilter(transition_matrices=model.transition, observation_matrices=model.observation,
                               transition_covariance=model.process_cov, observation_covariance=model.obs_cov,
                               initial_state_mean=model.initial_mean, initial_state_covariance=model.initial_cov)
    return kf.smooth(np.ma.masked_invalid(y))


@pytest.mark.parametrize("missing", [False, True], ids=["complete", "missing"])
@pytest.mark.parametrize("n,m", [(2, 1), (3, 2)])
def test_matches_pykalman_smoother_of_the_truncated_record(n, m, missing):
    rng = np.random.default_rng(10 * n + m + missing)
    T = 60
    model = random_model(rng, n, m, T)
    _x, y = draw(model, T, rng)
    if missing:
        y[[3, 20, 21, 22]] = np.nan  # whole steps: pykalman drops a partly observed step entirely
    for lag in (1, 4, 15):
        res = fixed_lag_smoother(model, y, lag)
        for t in (0, 5, 19, 29, 44, T - lag - 1, T - 2):
            mean, cov = _pykalman_smooth(model, y[:min(t + lag, T - 1) + 1])
            assert_allclose(res.mean[t], mean[t], rtol=0, atol=1e-9)
            assert_allclose(res.cov[t], cov[t], rtol=0, atol=1e-9)
            assert_allclose(res.std[t], np.sqrt(np.diag(cov[t])), rtol=0, atol=1e-9)


@PROPS
@given(st.integers(0, 2 ** 31 - 1), st.integers(0, 12), st.integers(0, 49))
def test_time_varying_model_matches_rts_smoother_of_the_prefix(seed, lag, t):
    rng = np.random.default_rng(seed)
    T = 50
    model = random_model(rng, 3, 2, T, tv=True, tv_cov=True, offsets=True, tv_offsets=True)
    _x, y = draw(model, T, rng)
    y[rng.random(y.shape) < 0.1] = np.nan
    res = fixed_lag_smoother(model, y, lag, states=[2, 0])
    s = min(t + lag, T - 1)
    prefix = StateSpaceModel(model.transition[:s], model.observation[:s + 1], model.process_cov[:s],
                             model.obs_cov[:s + 1], model.initial_mean, model.initial_cov,
                             state_offset=model.state_offset[:s], obs_offset=model.obs_offset[:s + 1])
    ref = rts_smoother(prefix, kalman_filter(prefix, y[:s + 1]))
    assert_allclose(res.mean[t], ref.mean[t, [2, 0]], rtol=0, atol=1e-9)
    assert_allclose(res.cov[t], ref.cov[t][np.ix_([2, 0], [2, 0])], rtol=0, atol=1e-9)


def test_lag_zero_is_the_filter_and_long_lag_is_the_smoother():
    rng = np.random.default_rng(3)
    T = 400
    model = random_model(rng, 3, 1, T)
    _x, y = draw(model, T, rng)
    filt = kalman_filter(model, y)
    smooth = rts_smoother(model, filt)
    zero = fixed_lag_smoother(model, y, 0)
    assert_allclose(zero.mean, filt.mean, rtol=0, atol=1e-12)
    assert_allclose(zero.cov, filt.cov, rtol=0, atol=1e-12)
    long = fixed_lag_smoother(model, y, 150)  # the closed loop has radius < 0.9: memory << 150 samples
    assert_allclose(long.mean, smooth.mean, rtol=0, atol=1e-8)
    assert_allclose(long.cov, smooth.cov, rtol=0, atol=1e-8)
    # stationary counterparts
    zero_ss = fixed_lag_smoother(model, y, 0, stationary=True)
    assert_allclose(zero_ss.mean, steady_state_filter(model, y).mean, rtol=0, atol=1e-12)
    long_ss = fixed_lag_smoother(model, y, 150, stationary=True)
    assert_allclose(long_ss.mean, steady_state_smoother(model, y).mean, rtol=0, atol=1e-8)
    assert long_ss.method == "steady-state" and long.method == "exact"


def _augmented(model, lag, states):
    """The model with lag delayed copies of x[states]: z_k = [x_k, x_{k-1}[s], ..., x_{k-lag}[s]]."""
    n, k = model.n_states, len(states)
    N = n + lag * k
    F = np.zeros((N, N))
    F[:n, :n] = model.transition
    sel = np.zeros((k, n))
    sel[np.arange(k), states] = 1.0
    if lag:
        F[n:n + k, :n] = sel
        for i in range(1, lag):
            F[n + i * k:n + (i + 1) * k, n + (i - 1) * k:n + i * k] = np.eye(k)
    H = np.hstack([model.observation, np.zeros((model.n_obs, lag * k))])
    Q = np.zeros((N, N))
    Q[:n, :n] = model.process_cov
    return StateSpaceModel(F, H, Q, model.obs_cov, np.zeros(N), np.eye(N))


@pytest.mark.parametrize("lag", [1, 6])
def test_stationary_matches_the_augmented_state_steady_state_filter(lag):
    rng = np.random.default_rng(lag)
    T = 300
    model = random_model(rng, 3, 2, T)
    model = model.replace(initial_mean=np.zeros(3))
    _x, y = draw(model, T, rng)
    states = [1, 2]
    res = fixed_lag_smoother(model, y, lag, stationary=True, states=states)
    aug = _augmented(model, lag, states)
    z = steady_state_filter(aug, y).mean
    oldest = slice(aug.n_states - 2, aug.n_states)  # x_{k-lag}[states] given y_0..k
    assert_allclose(res.mean[:T - lag], z[lag:, oldest], rtol=0, atol=1e-9)
    cov_aug = steady_state_gain(aug).cov[oldest, oldest]
    assert_allclose(res.cov[T // 2], cov_aug, rtol=0, atol=1e-9)


@PROPS
@given(st.integers(0, 2 ** 31 - 1), st.integers(0, 20), st.booleans())
def test_latency_is_respected_and_variance_decreases_with_lag(seed, lag, stationary):
    rng = np.random.default_rng(seed)
    T = 120
    model = random_model(rng, 2, 1, T)
    _x, y = draw(model, T, rng)
    t = int(rng.integers(0, T - lag - 1))
    changed = y.copy()
    changed[t + lag + 1:] += rng.normal(size=changed[t + lag + 1:].shape) * 10
    a = fixed_lag_smoother(model, y, lag, stationary=stationary)
    b = fixed_lag_smoother(model, changed, lag, stationary=stationary)
    assert_allclose(a.mean[:t + 1], b.mean[:t + 1], rtol=0, atol=1e-10)
    assert not np.allclose(a.mean[t + 1:], b.mean[t + 1:])
    longer = fixed_lag_smoother(model, y, lag + 1, stationary=stationary)
    assert np.all(longer.std <= a.std + 1e-12)


def test_errors():
    rng = np.random.default_rng(0)
    model = random_model(rng, 2, 1, 20)
    y = rng.normal(size=20)
    for bad in (-1, 2.5, True, "3"):
        with pytest.raises(InputError, match="lag"):
            fixed_lag_smoother(model, y, bad)
    with pytest.raises(InputError, match="states"):
        fixed_lag_smoother(model, y, 2, states=[5])
    with pytest.raises(InputError, match="states"):
        fixed_lag_smoother(model, y, 2, states=[])
    with pytest.raises(InputError, match="exact gains only"):
        fixed_lag_smoother(model, np.zeros((2, 20, 1)), 2, stationary=True)
    with pytest.raises(InputError, match="no known inputs"):
        fixed_lag_smoother(model, np.zeros((2, 20, 1)), 2, u=np.zeros((20, 1)))
    two_patterns = np.zeros((2, 20, 1))
    two_patterns[1, 4] = np.nan
    with pytest.raises(ShapeError):
        fixed_lag_smoother(model, two_patterns, 2)
    blind = StateSpaceModel(np.diag([1.0, 0.5]), np.array([[0.0, 1.0]]), np.eye(2), np.eye(1), np.zeros(2),
                            np.eye(2))
    with pytest.raises(NotDetectableError):
        fixed_lag_smoother(blind, y, 2, stationary=True)
    fixed_lag_smoother(blind, y, 2)  # the exact path runs with the growing covariance
    with pytest.raises(InputError, match="NaN|missing"):
        fixed_lag_smoother(model, np.where(np.arange(20) == 3, np.nan, y), 2, stationary=True)


@pytest.mark.parametrize("stationary", [False, True], ids=["exact", "steady-state"])
def test_known_inputs_match_the_smoother_of_the_prefix(stationary):
    rng = np.random.default_rng(5)
    T, lag = 200, 7
    model = random_model(rng, 3, 1, T, p=2, offsets=True)
    u = rng.normal(size=(T, 2))
    _x, y = draw(model, T, rng, u=u)
    res = fixed_lag_smoother(model, y, lag, u=u, stationary=stationary)
    for t in (150, 170, T - lag - 1):
        s = t + lag
        if stationary:  # after the start-up transient the stationary smoother of the prefix is the oracle
            ref = steady_state_smoother(model, y[:s + 1], u=u[:s + 1]).mean[t]
        else:
            ref = rts_smoother(model, kalman_filter(model, y[:s + 1], u=u[:s + 1])).mean[t]
        assert_allclose(res.mean[t], ref, rtol=0, atol=1e-9)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**31 - 1), T=st.integers(2, 40), n=st.integers(1, 4), k=st.integers(1, 3),
       lag=st.integers(1, 45))
def test_window_sums_equal_the_term_by_term_sums(seed, T, n, k, lag):
    # the two-stacks composition of the compiled kernel against the definition, summed term by term per t:
    # a_t = sum_{i=1..L_t} M_t...M_{t+i-1} g_{t+i}, B_t likewise with G, L_t = min(lag, T - 1 - t); any lag,
    # including lags that do not divide T and lags longer than the record
    from longprofile.statespace._fixed_lag_kernels import fixed_lag_window_sums
    rng = np.random.default_rng(seed)
    M = rng.normal(size=(T - 1, n, n)) * 0.6
    S = int(rng.integers(1, 4))  # series sharing M, G, Ps
    g = rng.normal(size=(S, T, n))
    A = rng.normal(size=(T, n, n))
    G = A @ np.swapaxes(A, 1, 2)
    Ps = rng.normal(size=(T, k, n))
    dmean, dcov = np.empty((S, T, k)), np.empty((T, k, k))
    fixed_lag_window_sums(M, g, G, Ps, min(lag, T - 1), dmean, dcov)
    for t in range(T):
        phi, a, B = np.eye(n), np.zeros((S, n)), np.zeros((n, n))
        for i in range(1, min(lag, T - 1 - t) + 1):
            phi = phi @ M[t + i - 1]
            a += g[:, t + i] @ phi.T
            B += phi @ G[t + i] @ phi.T
        assert_allclose(dmean[:, t], a @ Ps[t].T, rtol=1e-9, atol=1e-9)
        assert_allclose(dcov[t], Ps[t] @ B @ Ps[t].T, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("missing", [False, True], ids=["complete", "missing"])
def test_a_batch_equals_one_call_per_series(missing):
    rng = np.random.default_rng(4)
    model = random_model(rng, 3, 2, 60)
    Y = rng.normal(size=(5, 60, 2))
    if missing:
        Y[:, 10:14, 0] = np.nan
        Y[:, 30, :] = np.nan
    res = fixed_lag_smoother(model, Y, 7, states=[2, 0])
    assert res.mean.shape == (5, 60, 2) and res.cov.shape == (60, 2, 2)
    for b in range(5):
        one = fixed_lag_smoother(model, Y[b], 7, states=[2, 0])
        assert_allclose(res.mean[b], one.mean, rtol=0, atol=1e-10)
        assert_allclose(res.cov, one.cov, rtol=0, atol=1e-12)
