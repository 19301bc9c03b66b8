"""Extended Kalman filter and smoother: linear limit, filterpy's EKF, finite differences, the reference EKF, plain
Python model functions (compiled by the model)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from longprofile.errors import InputError, ModelError, ShapeError
from longprofile.statespace import (
    NonlinearStateSpaceModel,
    StateSpaceModel,
    extended_kalman_filter,
    extended_rts_smoother,
    kalman_filter,
    rts_smoother,
)

from ._ekf_reference import reference_ekf

# ---------------------------------------------------------------- a linear model with input and offset
_rng = np.random.default_rng(42)
N, M, P = 3, 2, 1
F_LIN = _rng.standard_normal((N, N))
F_LIN *= 0.95 / max(abs(np.linalg.eigvals(F_LIN)))
H_LIN = _rng.standard_normal((M, N))
B_LIN = _rng.standard_normal((N, P))
D_LIN = _rng.standard_normal((M, P))
C_LIN = np.array([0.3, -0.2, 0.1])  # affine offset: recomputing the prediction as F x (filterpy#278) would miss it
D_OFF = np.array([0.05, -0.1])


@njit
def _affine(A, x, Bm, u, c):
    # explicit loops: cheaper to compile than `@` (numba's BLAS binding)
    out = c.copy()
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            out[i] += A[i, j] * x[j]
        for j in range(Bm.shape[1]):
            out[i] += Bm[i, j] * u[j]
    return out


@njit
def lin_f(x, u, k):
    return _affine(F_LIN, x, B_LIN, u, C_LIN)


@njit
def lin_h(x, u, k):
    return _affine(H_LIN, x, D_LIN, u, D_OFF)


@njit
def lin_fj(x, u, k):
    return F_LIN.copy()


@njit
def lin_hj(x, u, k):
    return H_LIN.copy()


def linear_case(T=120):
    rng = np.random.default_rng(1)
    A = rng.standard_normal((T - 1, N, N))
    Q = 0.05 * A @ np.swapaxes(A, 1, 2) + 0.01 * np.eye(N)  # time-varying Q
    R = np.array([[0.4, 0.1], [0.1, 0.3]])
    x0, P0 = np.array([1.0, -1.0, 0.5]), np.diag([2.0, 1.0, 0.5])
    lin = StateSpaceModel(F_LIN, H_LIN, Q, R, x0, P0, input_transition=B_LIN, input_observation=D_LIN,
                          state_offset=C_LIN, obs_offset=D_OFF)
    y = rng.standard_normal((T, M))
    y[4, 0] = np.nan  # partially missing
    y[10] = np.nan  # fully missing step
    y[-3:] = np.nan  # missing run at the end
    u = rng.standard_normal((T, P))
    return lin, (Q, R, x0, P0), y, u


@pytest.mark.parametrize("plain", [False, True])
@pytest.mark.parametrize("analytic", [True, False])
def test_linear_model_equals_kalman_filter_and_rts(plain, analytic):
    lin, (Q, R, x0, P0), y, u = linear_case()
    fns = (lin_f, lin_h, lin_fj, lin_hj)
    if plain:  # plain Python functions: the model compiles them (numba.njit) for the compiled loops
        fns = tuple(fn.py_func for fn in fns)
    f, h, fj, hj = fns
    if not analytic:
        fj = hj = None
    model = NonlinearStateSpaceModel(f, h, Q, R, x0, P0, transition_jacobian=fj, observation_jacobian=hj)
    assert model.is_compiled
    kf = kalman_filter(lin, y, u=u)
    ekf = extended_kalman_filter(model, y, u=u)
    tol = 1e-10 if analytic else 1e-8  # finite differences of an affine map are exact to ~1e-10 relative
    assert ekf.method == "ekf"
    for name in ("mean", "cov", "pred_mean", "pred_cov", "innovation_cov", "log_likelihood_steps"):
        np.testing.assert_allclose(getattr(ekf, name), getattr(kf, name), atol=tol, rtol=0, err_msg=name)
    np.testing.assert_allclose(ekf.innovation, kf.innovation, atol=tol, rtol=0)  # NaN at the same places
    assert ekf.n_observed == kf.n_observed
    assert ekf.log_likelihood == pytest.approx(kf.log_likelihood, abs=1e-8)
    assert ekf.transition_jacobians.shape == (len(y) - 1, N, N)
    assert ekf.observation_jacobians.shape == (len(y), M, N)
    np.testing.assert_allclose(ekf.transition_jacobians, np.broadcast_to(F_LIN, (len(y) - 1, N, N)), atol=tol)
    rts = rts_smoother(lin, kf)
    ers = extended_rts_smoother(model, ekf)
    np.testing.assert_allclose(ers.mean, rts.mean, atol=tol, rtol=0)
    np.testing.assert_allclose(ers.cov, rts.cov, atol=tol, rtol=0)
    np.testing.assert_allclose(ers.cross_cov, rts.cross_cov, atol=tol, rtol=0)
    assert ers.filtered is ekf


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 3), m=st.integers(1, 2), missing=st.floats(0.0, 0.5))
def test_random_linear_models_with_plain_python_functions_equal_kalman_filter(seed, n, m, missing):
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((n, n))
    F *= 0.9 / max(abs(np.linalg.eigvals(F)))
    H = rng.standard_normal((m, n))
    A = rng.standard_normal((n, n))
    Q = A @ A.T * 0.1 + 1e-3 * np.eye(n)
    R = np.eye(m) * 0.5
    x0, P0 = rng.standard_normal(n), np.eye(n)
    y = rng.standard_normal((30, m))
    y[rng.random((30, m)) < missing] = np.nan
    lin = StateSpaceModel(F, H, Q, R, x0, P0)
    model = NonlinearStateSpaceModel(lambda x, u, k: F @ x, lambda x, u, k: H @ x, Q, R, x0, P0,
                                     lambda x, u, k: F, lambda x, u, k: H)
    kf, ekf = kalman_filter(lin, y), extended_kalman_filter(model, y)
    np.testing.assert_allclose(ekf.mean, kf.mean, atol=1e-10)
    np.testing.assert_allclose(ekf.cov, kf.cov, atol=1e-10)
    assert ekf.log_likelihood == pytest.approx(kf.log_likelihood, abs=1e-9)
    np.testing.assert_allclose(extended_rts_smoother(model, ekf).cov, rts_smoother(lin, kf).cov, atol=1e-10)


# ---------------------------------------------------------------- a nonlinear pendulum
DT, G_OVER_L = 0.01, 9.81


@njit
def pend_f(x, u, k):
    out = np.empty(2)
    out[0] = x[0] + DT * x[1]
    out[1] = x[1] - DT * G_OVER_L * np.sin(x[0])
    return out


@njit
def pend_fj(x, u, k):
    J = np.empty((2, 2))
    J[0, 0] = 1.0
    J[0, 1] = DT
    J[1, 0] = -DT * G_OVER_L * np.cos(x[0])
    J[1, 1] = 1.0
    return J


@njit
def pend_h(x, u, k):
    out = np.empty(2)
    out[0] = np.sin(x[0])
    out[1] = 1.0 - np.cos(x[0])
    return out


@njit
def pend_hj(x, u, k):
    J = np.zeros((2, 2))
    J[0, 0] = np.cos(x[0])
    J[1, 0] = np.sin(x[0])
    return J


PEND_Q = np.diag([1e-6, 1e-4])
PEND_R = np.diag([0.01, 0.02]) ** 2


def pendulum_data(T=300, seed=3):
    rng = np.random.default_rng(seed)
    x = np.array([0.8, 0.0])
    ys = []
    for _ in range(T):
        ys.append(pend_h.py_func(x, None, 0) + rng.multivariate_normal(np.zeros(2), PEND_R))
        x = pend_f.py_func(x, None, 0) + rng.multivariate_normal(np.zeros(2), PEND_Q)
    return np.array(ys)


def test_pendulum_matches_filterpy_extended_kalman_filter():
    from filterpy.kalman import ExtendedKalmanFilter

    class PendulumEKF(ExtendedKalmanFilter):
        def predict_x(self, u=0):
            self.x = pend_f.py_func(self.x[:, 0], None, 0)[:, None]

    y = pendulum_data()
    x0, P0 = np.array([0.5, 0.1]), np.diag([0.2, 0.5])
    model = NonlinearStateSpaceModel(pend_f, pend_h, PEND_Q, PEND_R, x0, P0, pend_fj, pend_hj)
    ours = extended_kalman_filter(model, y)
    fp = PendulumEKF(dim_x=2, dim_z=2)
    fp.x, fp.P, fp.Q, fp.R = x0[:, None].copy(), P0.copy(), PEND_Q.copy(), PEND_R.copy()
    means, covs = [], []
    for k in range(len(y)):
        if k > 0:
            fp.F = pend_fj.py_func(fp.x[:, 0], None, 0)  # Jacobian at the filtered mean, as ours
            fp.predict()
        fp.update(y[k][:, None], lambda x: pend_hj.py_func(x[:, 0], None, 0),
                  lambda x: pend_h.py_func(x[:, 0], None, 0)[:, None])
        means.append(fp.x[:, 0].copy())
        covs.append(fp.P.copy())
    np.testing.assert_allclose(ours.mean, np.array(means), atol=1e-10)
    np.testing.assert_allclose(ours.cov, np.array(covs), atol=1e-10)


def test_compiled_filter_equals_the_reference_ekf_on_nonlinear_model_with_missing_data():
    y = pendulum_data(T=200, seed=4)
    y[7, 1] = np.nan
    y[20] = np.nan
    x0, P0 = np.array([0.5, 0.1]), np.diag([0.2, 0.5])
    compiled = NonlinearStateSpaceModel(pend_f, pend_h, PEND_Q, PEND_R, x0, P0, pend_fj, pend_hj)
    python = NonlinearStateSpaceModel(pend_f.py_func, pend_h.py_func, PEND_Q, PEND_R, x0, P0, pend_fj.py_func,
                                      pend_hj.py_func)  # plain functions, compiled by the model
    a, b = extended_kalman_filter(compiled, y), extended_kalman_filter(python, y)
    ref = reference_ekf(pend_f.py_func, pend_h.py_func, PEND_Q, PEND_R, x0, P0, y, fj=pend_fj.py_func,
                        hj=pend_hj.py_func)
    for name in ("mean", "cov", "pred_mean", "pred_cov", "innovation", "innovation_cov", "transition_jacobians",
                 "observation_jacobians", "log_likelihood_steps"):
        np.testing.assert_allclose(getattr(a, name), getattr(ref, name), atol=1e-12, rtol=0, err_msg=name)
        np.testing.assert_array_equal(getattr(b, name), getattr(a, name), err_msg=name)
    assert a.n_observed == ref.n_observed
    sa, sb = extended_rts_smoother(compiled, a), extended_rts_smoother(python, b)
    np.testing.assert_allclose(sa.mean, sb.mean, atol=1e-12)
    # smoothing never increases the posterior variance
    assert np.all(np.diagonal(sa.cov, axis1=1, axis2=2) <= np.diagonal(a.cov, axis1=1, axis2=2) + 1e-15)
    # means-only mode gives the same means and no covariances
    lean = extended_kalman_filter(compiled, y, store_covariances=False)
    np.testing.assert_array_equal(lean.mean, a.mean)
    assert lean.cov is None and lean.transition_jacobians is None
    with pytest.raises(ShapeError, match="store_covariances=True"):
        extended_rts_smoother(compiled, lean)


def test_finite_difference_jacobians_match_analytic():
    y = pendulum_data(T=100, seed=5)
    x0, P0 = np.array([0.5, 0.1]), np.diag([0.2, 0.5])
    analytic = NonlinearStateSpaceModel(pend_f.py_func, pend_h.py_func, PEND_Q, PEND_R, x0, P0,
                                        pend_fj.py_func, pend_hj.py_func)
    numeric = NonlinearStateSpaceModel(pend_f.py_func, pend_h.py_func, PEND_Q, PEND_R, x0, P0)
    a, b = extended_kalman_filter(analytic, y), extended_kalman_filter(numeric, y)
    np.testing.assert_allclose(b.transition_jacobians, a.transition_jacobians, atol=1e-9)
    np.testing.assert_allclose(b.observation_jacobians, a.observation_jacobians, atol=1e-9)
    np.testing.assert_allclose(b.mean, a.mean, atol=1e-7)


def test_batched_equals_loop():
    y = np.stack([pendulum_data(T=50, seed=s) for s in (6, 7)])
    model = NonlinearStateSpaceModel(pend_f.py_func, pend_h.py_func, PEND_Q, PEND_R, np.zeros(2), np.eye(2),
                                     pend_fj.py_func, pend_hj.py_func)
    batch = extended_kalman_filter(model, y)
    sm = extended_rts_smoother(model, batch)
    for b in range(2):
        one = extended_kalman_filter(model, y[b])
        np.testing.assert_array_equal(batch.mean[b], one.mean)
        np.testing.assert_allclose(sm.mean[b], extended_rts_smoother(model, one).mean, atol=1e-14)
    assert batch.log_likelihood.shape == (2,)


def test_model_and_input_errors():
    x0, P0 = np.zeros(2), np.eye(2)
    with pytest.raises(InputError, match="transition_fn must be callable"):
        NonlinearStateSpaceModel(1.0, pend_h.py_func, PEND_Q, PEND_R, x0, P0)
    with pytest.raises(ShapeError, match=r"process_cov \(Q\) must have shape \(2, 2\)"):
        NonlinearStateSpaceModel(pend_f.py_func, pend_h.py_func, np.eye(3), PEND_R, x0, P0)
    with pytest.raises(ModelError, match="positive semi-definite"):
        NonlinearStateSpaceModel(pend_f.py_func, pend_h.py_func, -PEND_Q, PEND_R, x0, P0)
    bad_h = NonlinearStateSpaceModel(pend_f.py_func, lambda x, u, k: x[:1], PEND_Q, PEND_R, x0, P0)
    with pytest.raises(ShapeError, match=r"observation_fn must return shape \(2,\)"):
        extended_kalman_filter(bad_h, np.zeros((5, 2)))
    with pytest.raises(ModelError, match="observation_fn could not be compiled by numba .*Untyped global name"):
        NonlinearStateSpaceModel(pend_f.py_func, lambda x, u, k: np.asarray(object()), PEND_Q, PEND_R, x0, P0)
    with pytest.raises(ModelError, match=r"observation_fn must return a 1-D float array .*float64"):
        NonlinearStateSpaceModel(pend_f.py_func, lambda x, u, k: x[0], PEND_Q, PEND_R, x0, P0)
    model = NonlinearStateSpaceModel(pend_f.py_func, pend_h.py_func, PEND_Q, PEND_R, x0, P0)
    with pytest.raises(ShapeError, match="m = 2 columns"):
        extended_kalman_filter(model, np.zeros((5, 3)))
    with pytest.raises(InputError, match="NonlinearStateSpaceModel"):
        extended_kalman_filter(StateSpaceModel(np.eye(2), np.eye(2), PEND_Q, PEND_R, x0, P0), np.zeros((5, 2)))
    blows_up = NonlinearStateSpaceModel(lambda x, u, k: x if k == 0 else x * np.nan, pend_h.py_func, PEND_Q,
                                        PEND_R, np.ones(2), P0, transition_jacobian=lambda x, u, k: np.eye(2))
    with pytest.raises(ModelError, match="non-finite values at step 1"):
        extended_kalman_filter(blows_up, np.zeros((5, 2)))
    huge_jacobian = NonlinearStateSpaceModel(pend_f.py_func, pend_h.py_func, PEND_Q, PEND_R, x0, P0,
                                             transition_jacobian=lambda x, u, k: np.eye(2) * 1e300)
    with pytest.raises(ModelError, match="predicted covariance became non-finite at step 0"):
        extended_kalman_filter(huge_jacobian, np.zeros((5, 2)))
    no_noise = NonlinearStateSpaceModel(pend_f.py_func, pend_h.py_func, np.zeros((2, 2)), np.zeros((2, 2)), x0,
                                        np.zeros((2, 2)))
    with pytest.raises(ModelError, match="not positive definite at step 0"):
        extended_kalman_filter(no_noise, np.zeros((5, 2)))
