"""Steady-state gain, filter and smoother: against statsmodels, a Riccati iteration and the exact filter."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, ModelError, NotDetectableError, ShapeError
from longprofile.statespace import (
    StateSpaceModel,
    kalman_filter,
    rts_smoother,
    steady_state_filter,
    steady_state_gain,
    steady_state_smoothed_cov,
    steady_state_smoother,
)


def random_model(seed, n=4, m=2, p=0, offsets=False, rho=0.97):
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((n, n))
    F *= rho / max(abs(np.linalg.eigvals(F)))
    H = rng.standard_normal((m, n))
    A = rng.standard_normal((n, n))
    Q = A @ A.T * 0.1 + 1e-3 * np.eye(n)
    C = rng.standard_normal((m, m))
    R = C @ C.T * 0.2 + 0.1 * np.eye(m)
    kw = {}
    if p:
        kw["input_transition"] = rng.standard_normal((n, p))
        kw["input_observation"] = rng.standard_normal((m, p))
    if offsets:
        kw["state_offset"] = rng.standard_normal(n)
        kw["obs_offset"] = rng.standard_normal(m)
    return StateSpaceModel(F, H, Q, R, rng.standard_normal(n), 3.0 * np.eye(n), **kw)


def riccati_iteration(F, H, Q, R, n_iter=5000):
    """Independent oracle: iterate the predicted-covariance Riccati recursion to convergence."""
    P = Q.copy()
    for _ in range(n_iter):
        S = H @ P @ H.T + R
        P = F @ P @ F.T - F @ P @ H.T @ np.linalg.solve(S, H @ P @ F.T) + Q
        P = 0.5 * (P + P.T)
    return P


def test_gain_matches_statsmodels_and_riccati_iteration():
    from statsmodels.tsa.statespace.kalman_filter import KalmanFilter

    model = random_model(0)
    n, m = model.n_states, model.n_obs
    ss = steady_state_gain(model)
    y = np.random.default_rng(1).standard_normal((400, m))
    kf = KalmanFilter(k_endog=m, k_states=n, design=model.observation, obs_cov=model.obs_cov,
                      transition=model.transition, selection=np.eye(n), state_cov=model.process_cov)
    kf.initialize_known(model.initial_mean, model.initial_cov)
    kf.bind(y)
    res = kf.filter()
    np.testing.assert_allclose(ss.pred_cov, res.predicted_state_cov[:, :, -1], rtol=1e-9, atol=1e-11)
    # statsmodels' kalman_gain is the predictive gain F K.
    np.testing.assert_allclose(model.transition @ ss.gain, res.kalman_gain[:, :, -1], rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(ss.cov, res.filtered_state_cov[:, :, -1], rtol=1e-9, atol=1e-11)
    P_it = riccati_iteration(model.transition, model.observation, model.process_cov, model.obs_cov)
    np.testing.assert_allclose(ss.pred_cov, P_it, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(ss.innovation_cov, model.observation @ P_it @ model.observation.T + model.obs_cov,
                               rtol=1e-9)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 5), m=st.integers(1, 3))
def test_gain_solves_dare_and_stabilises(seed, n, m):
    model = random_model(seed, n=n, m=m)
    ss = steady_state_gain(model)
    F, H, Q, R = model.transition, model.observation, model.process_cov, model.obs_cov
    P = ss.pred_cov
    resid = F @ P @ F.T - F @ P @ H.T @ np.linalg.solve(H @ P @ H.T + R, H @ P @ F.T) + Q - P
    assert np.abs(resid).max() <= 1e-9 * max(1.0, np.abs(P).max())
    assert np.max(np.abs(np.linalg.eigvals((np.eye(n) - ss.gain @ H) @ F))) < 1.0
    assert np.all(np.linalg.eigvalsh(P - ss.cov) >= -1e-10)  # measurement update never adds uncertainty
    assert ss.closed_loop_radius == pytest.approx(np.max(np.abs(np.linalg.eigvals((np.eye(n) - ss.gain @ H) @ F))))
    Ps = steady_state_smoothed_cov(model)
    assert np.all(np.linalg.eigvalsh(ss.cov - Ps) >= -1e-10 * np.abs(ss.cov).max())  # smoothing never adds either


@pytest.mark.parametrize("p, offsets", [(0, False), (2, True)])
def test_filter_equals_kalman_filter_after_transient(p, offsets):
    model = random_model(3, n=4, m=2, p=p, offsets=offsets)
    rng = np.random.default_rng(4)
    T = 600
    y = rng.standard_normal((T, 2))
    u = rng.standard_normal((T, p)) if p else None
    exact = kalman_filter(model, y, u=u)
    fast = steady_state_filter(model, y, u=u)
    assert fast.method == "steady-state" and fast.cov is None and fast.pred_cov is None
    sl = slice(200, None)
    np.testing.assert_allclose(fast.mean[sl], exact.mean[sl], atol=1e-8)
    np.testing.assert_allclose(fast.pred_mean[sl], exact.pred_mean[sl], atol=1e-8)
    np.testing.assert_allclose(fast.innovation[sl], exact.innovation[sl], atol=1e-8)
    np.testing.assert_allclose(fast.log_likelihood_steps[sl], exact.log_likelihood_steps[sl], atol=1e-8)
    np.testing.assert_allclose(fast.pred_mean[0], model.initial_mean)
    assert fast.n_observed == T * 2
    assert np.isclose(fast.log_likelihood, fast.log_likelihood_steps.sum())
    # the first steps really differ (the exact filter starts from initial_cov): the comparison can fail
    assert np.abs(fast.mean[0] - exact.mean[0]).max() > 1e-6


@pytest.mark.parametrize("p, offsets", [(0, False), (2, True)])
def test_filter_is_the_constant_gain_recursion_from_the_first_sample(p, offsets):
    # oracle: the textbook order (predict -> innovation -> update) with the DARE gain, in NumPy; the kernel
    # runs the closed-loop form, so this checks the algebra of that rewrite from step 0 (no transient excuse)
    model = random_model(7, n=5, m=2, p=p, offsets=offsets)
    rng = np.random.default_rng(8)
    T = 300
    y = rng.standard_normal((T, 2))
    u = rng.standard_normal((T, p)) if p else None
    K = steady_state_gain(model).gain
    F, H = model.transition, model.observation
    B = model.input_transition if p else np.zeros((5, 0))
    D = model.input_observation if p else np.zeros((2, 0))
    c = model.state_offset if offsets else np.zeros(5)
    d = model.obs_offset if offsets else np.zeros(2)
    uu = u if p else np.zeros((T, 0))
    xp = model.initial_mean.copy()
    ref_mean, ref_pred, ref_innov = np.empty((T, 5)), np.empty((T, 5)), np.empty((T, 2))
    for k in range(T):
        e = y[k] - H @ xp - D @ uu[k] - d
        xf = xp + K @ e
        ref_pred[k], ref_innov[k], ref_mean[k] = xp, e, xf
        xp = F @ xf + B @ uu[k] + c
    fast = steady_state_filter(model, y, u=u)
    np.testing.assert_allclose(fast.mean, ref_mean, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(fast.pred_mean, ref_pred, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(fast.innovation, ref_innov, rtol=1e-10, atol=1e-10)


def test_store_predictions_false_keeps_means_and_total_likelihood():
    model = random_model(9, n=6, m=1)
    y = np.random.default_rng(10).standard_normal((3, 400, 1))
    full = steady_state_filter(model, y)
    lean = steady_state_filter(model, y, store_predictions=False)
    assert lean.pred_mean is None and lean.innovation is None and lean.log_likelihood_steps is None
    np.testing.assert_array_equal(lean.mean, full.mean)
    np.testing.assert_allclose(lean.log_likelihood, full.log_likelihood, rtol=1e-13)
    np.testing.assert_allclose(full.log_likelihood, full.log_likelihood_steps.sum(axis=-1), rtol=1e-12)
    one = steady_state_filter(model, y[1], store_predictions=False)
    np.testing.assert_array_equal(one.mean, full.mean[1])
    assert one.log_likelihood == pytest.approx(full.log_likelihood[1], rel=1e-13)


@pytest.mark.parametrize("p, offsets", [(0, False), (1, True)])
def test_smoother_equals_rts_after_transient(p, offsets):
    model = random_model(5, n=3, m=1, p=p, offsets=offsets)
    rng = np.random.default_rng(6)
    T = 600
    y = rng.standard_normal(T)
    u = rng.standard_normal((T, p)) if p else None
    exact = rts_smoother(model, kalman_filter(model, y, u=u))
    fast = steady_state_smoother(model, y, u=u)
    np.testing.assert_allclose(fast.mean[200:], exact.mean[200:], atol=1e-8)
    assert fast.cov is None and fast.cross_cov is None
    np.testing.assert_allclose(fast.filtered.mean[200:], exact.filtered.mean[200:], atol=1e-8)
    # the constant smoothed covariance is the one the exact smoother reaches mid-series
    np.testing.assert_allclose(steady_state_smoothed_cov(model), exact.cov[T // 2], atol=1e-10)
    lean = steady_state_smoother(model, y, u=u, store_filtered=False, gain=steady_state_gain(model))
    assert lean.filtered is None
    np.testing.assert_array_equal(lean.mean, fast.mean)


def test_singular_predicted_covariance():
    # a deterministic stable state (no process noise) makes P_p exactly singular: the smoother gain must
    # not blow up (minimum-norm solution) and still equal the exact smoother
    F = np.array([[0.5, 0.0], [0.3, 0.9]])
    model = StateSpaceModel(F, np.array([[1.0, 1.0]]), np.diag([0.0, 1.0]), np.eye(1), np.zeros(2), np.eye(2))
    assert np.linalg.matrix_rank(steady_state_gain(model).pred_cov) == 1
    y = np.random.default_rng(14).standard_normal(400)
    exact = rts_smoother(model, kalman_filter(model, y))
    np.testing.assert_allclose(steady_state_smoother(model, y).mean[100:], exact.mean[100:], atol=1e-10)
    np.testing.assert_allclose(steady_state_smoothed_cov(model), exact.cov[200], atol=1e-10)


def test_batched_equals_loop():
    model = random_model(8, n=2, m=1)
    y = np.random.default_rng(9).standard_normal((3, 200, 1))
    batch = steady_state_filter(model, y)
    sm = steady_state_smoother(model, y)
    for b in range(3):
        one = steady_state_filter(model, y[b])
        np.testing.assert_array_equal(batch.mean[b], one.mean)
        assert batch.log_likelihood[b] == pytest.approx(one.log_likelihood)
        np.testing.assert_array_equal(sm.mean[b], steady_state_smoother(model, y[b]).mean)


def test_large_state_uses_generic_kernel():
    model = random_model(10, n=10, m=5)
    y = np.random.default_rng(11).standard_normal((300, 5))
    np.testing.assert_allclose(steady_state_filter(model, y).mean[150:], kalman_filter(model, y).mean[150:],
                               atol=1e-8)
    np.testing.assert_allclose(steady_state_smoother(model, y).mean[150:250],
                               rts_smoother(model, kalman_filter(model, y)).mean[150:250], atol=1e-8)


def test_undetectable_unit_root_raises():
    # APL-like: an integrator (absolute elevation) that the sensor cannot see, next to an observed stable state
    F = np.array([[1.0, 0.1], [0.0, 0.6]])
    H = np.array([[0.0, 1.0]])
    model = StateSpaceModel(F, H, np.eye(2) * 0.01, np.eye(1), np.zeros(2), np.eye(2))
    with pytest.raises(NotDetectableError, match=r"not detectable.*eigenvalue 1 .*direction \[1\. 0\.\]"):
        steady_state_gain(model)
    with pytest.raises(NotDetectableError, match="leak"):
        steady_state_filter(model, np.zeros(10))
    # the same model with a leak on the integrator is fine
    steady_state_gain(model.replace(transition=np.array([[0.999, 0.1], [0.0, 0.6]])))


def test_unexcited_unit_root_raises():
    model = StateSpaceModel(np.eye(1), np.eye(1), np.zeros((1, 1)), np.eye(1), np.zeros(1), np.eye(1))
    with pytest.raises(NotDetectableError, match="not stabilisable"):
        steady_state_gain(model)


def test_input_errors():
    model = random_model(12, n=2, m=1)
    y = np.ones(50)
    y[7] = np.nan
    with pytest.raises(InputError, match=r"missing \(NaN\).*first at index \(7, 0\).*kalman_filter"):
        steady_state_filter(model, y)
    with pytest.raises(InputError, match="NaN"):
        steady_state_smoother(model, y)
    tv = model.replace(obs_cov=np.ones((50, 1, 1)))
    with pytest.raises(ModelError, match="time-invariant"):
        steady_state_filter(tv, np.ones(50))
    other = random_model(13, n=3, m=1)
    with pytest.raises(ShapeError, match=r"gain has shape \(3, 1\)"):
        steady_state_filter(model, np.ones(50), gain=steady_state_gain(other))
    singular = model.replace(obs_cov=np.zeros((1, 1)))
    with pytest.raises(ModelError, match="positive definite"):
        steady_state_gain(singular)
