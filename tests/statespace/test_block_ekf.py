"""Decentralised block EKF == the engine's EKF with every cross-block term removed (thesis 003 §3.1)."""

import numpy as np
import pytest
from numba import njit

from longprofile.errors import InputError, ModelError, ShapeError
from longprofile.statespace import NonlinearStateSpaceModel, block_extended_kalman_filter, extended_kalman_filter

from ._ekf_reference import reference_ekf


# two coupled pendulum-like blocks of two states each; the blocks interact through the means only
@njit
def _f(x, u, k):
    out = np.empty(4)
    out[0] = x[0] + 0.01 * x[1]
    out[1] = x[1] - 0.01 * (np.sin(x[0]) + 0.3 * (x[0] - x[2])) + 0.01 * u[0]
    out[2] = x[2] + 0.01 * x[3]
    out[3] = x[3] - 0.01 * (np.sin(x[2]) + 0.3 * (x[2] - x[0]))
    return out


@njit
def _fjac_block(x, u, k):
    J = np.zeros((4, 4))
    J[0, 0], J[0, 1] = 1.0, 0.01
    J[1, 0], J[1, 1] = -0.01 * (np.cos(x[0]) + 0.3), 1.0
    J[2, 2], J[2, 3] = 1.0, 0.01
    J[3, 2], J[3, 3] = -0.01 * (np.cos(x[2]) + 0.3), 1.0
    return J


@njit
def _h(x, u, k):
    out = np.empty(3)
    out[0] = x[0]
    out[1] = np.sin(x[2])
    out[2] = x[1] * x[1]
    return out


@njit
def _hjac(x, u, k):
    H = np.zeros((3, 4))
    H[0, 0] = 1.0
    H[1, 2] = np.cos(x[2])
    H[2, 1] = 2 * x[1]
    return H


@njit
def _fstep(x, u, k, out, J):  # fused f + block Jacobian, as the fast path expects (zeros left unwritten)
    fx = _f(x, u, k)
    for i in range(4):
        out[i] = fx[i]
    J[0, 0], J[0, 1] = 1.0, 0.01
    J[1, 0], J[1, 1] = -0.01 * (np.cos(x[0]) + 0.3), 1.0
    J[2, 2], J[2, 3] = 1.0, 0.01
    J[3, 2], J[3, 3] = -0.01 * (np.cos(x[2]) + 0.3), 1.0


@njit
def _hstep(x, u, k, out, H):
    hx = _h(x, u, k)
    for i in range(3):
        out[i] = hx[i]
    H[0, 0] = 1.0
    H[1, 2] = np.cos(x[2])
    H[2, 1] = 2 * x[1]


@njit
def _hstep_wrong(x, u, k, out, H):
    _hstep(x, u, k, out, H)
    H[2, 1] = 2 * x[1] + 0.5  # wrong Jacobian entry


def _model(Q=None, *, steps=(None, None), jacobians=True):
    """The coupled test model."""
    f, h, fj, hj = (_f, _h, _fjac_block, _hjac)
    if not jacobians:
        fj = hj = None
    return NonlinearStateSpaceModel(f, h, np.diag([1e-4, 1e-3, 2e-4, 1e-3]) if Q is None else Q,
                                    np.diag([0.01, 0.02, 0.05]), np.array([0.5, 0.0, -0.3, 0.1]),
                                    np.diag([0.1, 0.2, 0.1, 0.2]), transition_jacobian=fj, observation_jacobian=hj,
                                    transition_step=steps[0], observation_step=steps[1])


def _data(T=300, seed=0):
    rng = np.random.default_rng(seed)
    y = np.column_stack([np.sin(np.arange(T) * 0.05), np.cos(np.arange(T) * 0.03), np.full(T, 0.01)])
    y = y + 0.1 * rng.standard_normal(y.shape)
    y[10, 1] = np.nan
    y[20] = np.nan
    return y, rng.standard_normal((T, 1))


SB = np.array([0, 0, 1, 1])
OB = np.array([0, 1, 0])


def test_block_filter_equals_dense_ekf_with_block_diagonal_structure():
    y, u = _data()
    model = _model()
    # the oracle: the reference EKF (plain NumPy loop) on the same functions, dense covariance
    dense = reference_ekf(_f.py_func, _h.py_func, model.process_cov, model.obs_cov, model.initial_mean,
                          model.initial_cov, y, u, fj=_fjac_block.py_func, hj=_hjac.py_func)
    assert dense.method != "block-ekf"
    block = block_extended_kalman_filter(model, y, u=u, state_blocks=SB, obs_blocks=OB)
    # the dense EKF keeps the covariance block-diagonal here (block Jacobians, H, Q, R, P0) — same algorithm
    np.testing.assert_allclose(block.mean, dense.mean, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(block.cov, dense.cov, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(block.pred_mean, dense.pred_mean, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(block.innovation, dense.innovation, rtol=1e-9, atol=1e-11, equal_nan=True)
    assert block.log_likelihood == pytest.approx(dense.log_likelihood, rel=1e-9)
    assert block.n_observed == dense.n_observed == 3 * 300 - 4
    assert block.method == "block-ekf"
    light = block_extended_kalman_filter(model, y, u=u, state_blocks=SB, obs_blocks=OB, store_covariances=False)
    np.testing.assert_array_equal(light.mean, block.mean)
    assert light.cov is None and light.transition_jacobians is None


def test_fused_steps_give_the_same_filter():
    y, u = _data(T=200)
    model = _model()
    ref = block_extended_kalman_filter(model, y, u=u, state_blocks=SB, obs_blocks=OB)
    for sb, ob in ((SB, OB), (np.array([0, 1, 1, 1]), np.array([0, 1, 1]))):  # uniform and unequal blocks
        if sb is not SB:
            ref = block_extended_kalman_filter(model, y, u=u, state_blocks=sb, obs_blocks=ob)
        fused = block_extended_kalman_filter(_model(steps=(_fstep, _hstep)), y, u=u, state_blocks=sb, obs_blocks=ob)
        for name in ("mean", "cov", "pred_mean", "innovation", "innovation_cov", "log_likelihood_steps",
                     "transition_jacobians", "observation_jacobians"):
            np.testing.assert_array_equal(getattr(fused, name), getattr(ref, name), err_msg=name)
    with pytest.raises(InputError, match="both transition_step and observation_step"):
        _model(steps=(_fstep, None))
    with pytest.raises(ModelError, match="observation_step disagrees"):
        block_extended_kalman_filter(_model(steps=(_fstep, _hstep_wrong)), y, u=u, state_blocks=SB, obs_blocks=OB)
    with pytest.raises(InputError, match="must be a numba"):
        _model(steps=(_fstep, lambda x, u, k, out, H: None))
    # the steps write the diagonal blocks only: against the model's true (finite-difference) Jacobian the block
    # filter accepts them and the dense EKF, which uses the whole Jacobian, refuses them
    fd_model = _model(steps=(_fstep, _hstep), jacobians=False)
    block_extended_kalman_filter(fd_model, y[:5], u=u[:5], state_blocks=SB, obs_blocks=OB)
    with pytest.raises(ModelError, match="transition_step disagrees"):
        extended_kalman_filter(fd_model, y, u=u)


def test_cross_block_terms_are_ignored():
    y, u = _data(T=100)
    Q = np.diag([1e-4, 1e-3, 2e-4, 1e-3])
    Q_cross = Q.copy()
    Q_cross[0, 2] = Q_cross[2, 0] = 5e-5
    a = block_extended_kalman_filter(_model(Q), y, u=u, state_blocks=SB, obs_blocks=OB)
    b = block_extended_kalman_filter(_model(Q_cross), y, u=u, state_blocks=SB, obs_blocks=OB)
    np.testing.assert_array_equal(a.mean, b.mean)
    assert np.all(a.cov[:, :2, 2:] == 0)


def test_block_filter_errors():
    y, u = _data(T=30)
    with pytest.raises(ShapeError, match="state_blocks must be 4 integer"):
        block_extended_kalman_filter(_model(), y, u=u, state_blocks=[0, 1], obs_blocks=OB)
    with pytest.raises(InputError, match="every label"):
        block_extended_kalman_filter(_model(), y, u=u, state_blocks=np.array([0, 0, 2, 2]), obs_blocks=OB)
    with pytest.raises(ShapeError, match=r"y must have shape \(T, 3\)"):
        block_extended_kalman_filter(_model(), y[:, :2], u=u, state_blocks=SB, obs_blocks=OB)


def test_plain_python_functions_run_the_compiled_block_filter():
    """The model compiles plain Python functions (numba.njit), so the block filter takes them like jitted ones."""
    y, u = _data(T=60)
    jitted = _model()
    plain = NonlinearStateSpaceModel(_f.py_func, _h.py_func, jitted.process_cov, jitted.obs_cov, jitted.initial_mean,
                                     jitted.initial_cov, transition_jacobian=_fjac_block.py_func,
                                     observation_jacobian=_hjac.py_func)
    a = block_extended_kalman_filter(jitted, y, u=u, state_blocks=SB, obs_blocks=OB)
    b = block_extended_kalman_filter(plain, y, u=u, state_blocks=SB, obs_blocks=OB)
    np.testing.assert_array_equal(b.mean, a.mean)
    np.testing.assert_array_equal(b.cov, a.cov)


def test_finite_difference_jacobians_give_the_analytic_filter():
    y, u = _data(T=100)
    ref = block_extended_kalman_filter(_model(), y, u=u, state_blocks=SB, obs_blocks=OB)
    fd = block_extended_kalman_filter(_model(jacobians=False), y, u=u, state_blocks=SB, obs_blocks=OB)
    np.testing.assert_allclose(fd.mean, ref.mean, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(fd.cov, ref.cov, rtol=1e-6, atol=1e-10)


@njit
def _fjac_nan_at_3(x, u, k):
    J = _fjac_block(x, u, k)
    if k == 3:
        J[1, 1] = np.nan
    return J


@njit
def _fjac_huge_at_2(x, u, k):
    J = _fjac_block(x, u, k)
    if k == 2:
        J[0, 0] = 1e200
    return J


@njit
def _hjac_nan_at_4(x, u, k):
    H = _hjac(x, u, k)
    if k == 4:
        H[1, 2] = np.inf
    return H


def test_block_filter_non_finite_jacobian_and_covariance_like_the_ekf():
    y, u = _data(T=30)
    base = _model()
    cases = ((dict(transition_jacobian=_fjac_nan_at_3), r"transition_fn or its Jacobian returned non-finite values "
                                                         r"at step 3\."),
             (dict(observation_jacobian=_hjac_nan_at_4), r"observation_fn or its Jacobian returned non-finite values "
                                                         r"at step 4\."),
             (dict(transition_jacobian=_fjac_huge_at_2), r"predicted covariance became non-finite at step 2 -> 3"))
    for change, message in cases:
        model = NonlinearStateSpaceModel(base.transition_fn, base.observation_fn, base.process_cov, base.obs_cov,
                                         base.initial_mean, base.initial_cov,
                                         transition_jacobian=change.get("transition_jacobian", _fjac_block),
                                         observation_jacobian=change.get("observation_jacobian", _hjac))
        with pytest.raises(ModelError, match=message):
            block_extended_kalman_filter(model, y, u=u, state_blocks=SB, obs_blocks=OB)
        with pytest.raises(ModelError, match=message):
            extended_kalman_filter(model, y, u=u)


def test_variances_mode_keeps_the_innovation_variances_of_both_filters():
    """``store_covariances="variances"`` keeps diag(S_k) (T, m) besides diag(P_k): what a normalized innovation
    squared needs without the (T, m, m) history (session 41); equal to the full history's diagonal."""
    from longprofile.statespace import extended_kalman_filter

    y, u = _data(T=120)
    model = _model()
    for run in (lambda **kw: block_extended_kalman_filter(model, y, u=u, state_blocks=SB, obs_blocks=OB, **kw),
                lambda **kw: extended_kalman_filter(model, y, u=u, **kw)):
        full, lean = run(), run(store_covariances="variances")
        assert lean.innovation_cov is None and lean.innovation_variance.shape == (120, 3)
        np.testing.assert_array_equal(lean.innovation_variance, np.diagonal(full.innovation_cov, axis1=1, axis2=2))
        np.testing.assert_array_equal(lean.variance, np.diagonal(full.cov, axis1=1, axis2=2))
        np.testing.assert_array_equal(lean.mean, full.mean)
        assert full.innovation_variance is None and run(store_covariances=False).innovation_variance is None
