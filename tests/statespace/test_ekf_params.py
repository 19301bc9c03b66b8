"""Explicit model parameters (issue 12): ``NonlinearStateSpaceModel(params=...)`` calls every model function as
``f(x, u, k, params)`` (steps ``g(x, u, k, params, out, J)``), so one compiled function serves every parameter set."""

import dataclasses

import numpy as np
import pytest
from numba import njit

from longprofile.errors import InputError, ModelError, ShapeError
from longprofile.statespace import (
    NonlinearStateSpaceModel,
    block_extended_kalman_filter,
    extended_kalman_filter,
    extended_rts_smoother,
)
from longprofile.statespace._ekf import cached_ekf_kernel

A, B = 0.9, 0.2
RNG = np.random.default_rng(3)
Y = RNG.normal(size=(60, 2))
U = RNG.normal(size=(60, 1))


# the same model twice: parameters as an argument, and frozen into the functions (3-argument convention)
def f_p(x, u, k, params):
    return np.array([params[0] * x[0] + params[1] * np.sin(x[1]), params[0] * x[1] + u[0]])


def h_p(x, u, k, params):
    return np.array([x[0] + 0.1 * x[1] ** 2, x[1]])


def fj_p(x, u, k, params):
    return np.array([[params[0], params[1] * np.cos(x[1])], [0.0, params[0]]])


def hj_p(x, u, k, params):
    return np.array([[1.0, 0.2 * x[1]], [0.0, 1.0]])


def f_c(x, u, k):
    return np.array([A * x[0] + B * np.sin(x[1]), A * x[1] + u[0]])


def h_c(x, u, k):
    return np.array([x[0] + 0.1 * x[1] ** 2, x[1]])


def fj_c(x, u, k):
    return np.array([[A, B * np.cos(x[1])], [0.0, A]])


def hj_c(x, u, k):
    return np.array([[1.0, 0.2 * x[1]], [0.0, 1.0]])


@njit
def f_step_p(x, u, k, params, out, F):
    out[0] = params[0] * x[0] + params[1] * np.sin(x[1])
    out[1] = params[0] * x[1] + u[0]
    F[0, 0] = params[0]
    F[0, 1] = params[1] * np.cos(x[1])
    F[1, 1] = params[0]


@njit
def h_step_p(x, u, k, params, out, H):
    out[0] = x[0] + 0.1 * x[1] ** 2
    out[1] = x[1]
    H[0, 0] = 1.0
    H[0, 1] = 0.2 * x[1]
    H[1, 1] = 1.0


COV = dict(process_cov=np.diag([0.1, 0.2]), obs_cov=np.diag([0.3, 0.4]), initial_mean=np.array([0.5, -0.2]),
           initial_cov=np.eye(2))


def _params_model(jitted: bool, jacobians: bool, params=(A, B), steps=False):
    fns = [f_p, h_p, fj_p, hj_p]
    if jitted:
        fns = [njit(fn) for fn in fns]
    jac = dict(transition_jacobian=fns[2], observation_jacobian=fns[3]) if jacobians else {}
    if steps:
        jac.update(transition_step=f_step_p, observation_step=h_step_p)
    return NonlinearStateSpaceModel(fns[0], fns[1], **COV, **jac, params=np.array(params))


def _closure_model(jacobians: bool):
    jac = dict(transition_jacobian=fj_c, observation_jacobian=hj_c) if jacobians else {}
    return NonlinearStateSpaceModel(f_c, h_c, **COV, **jac)


def _same(a, b):
    for name in ("mean", "cov", "pred_mean", "pred_cov", "log_likelihood_steps", "transition_jacobians",
                 "observation_jacobians"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


@pytest.mark.parametrize("jitted", [False, True], ids=["python", "njit"])
@pytest.mark.parametrize("jacobians", [True, False], ids=["analytic", "finite-differences"])
def test_a_params_model_filters_as_the_equivalent_closure_model(jitted, jacobians):
    ours, ref = _params_model(jitted, jacobians), _closure_model(jacobians)
    fo, fr = extended_kalman_filter(ours, Y, u=U), extended_kalman_filter(ref, Y, u=U)
    _same(fo, fr)
    so, sr = extended_rts_smoother(ours, fo), extended_rts_smoother(ref, fr)
    np.testing.assert_array_equal(so.mean, sr.mean)
    blocks = dict(state_blocks=[0, 1], obs_blocks=[0, 1])
    _same(block_extended_kalman_filter(ours, Y, u=U, **blocks), block_extended_kalman_filter(ref, Y, u=U, **blocks))
    # the smoother's relinearisation (no stored Jacobians) calls F(x, u, k, params) from Python too
    bare = dataclasses.replace(fo, transition_jacobians=None)
    np.testing.assert_allclose(extended_rts_smoother(ours, bare, u=U).mean, so.mean, rtol=1e-12, atol=1e-12)


def test_fused_steps_with_params_match_the_separate_functions():
    sep = extended_kalman_filter(_params_model(True, True), Y, u=U)
    fused = extended_kalman_filter(_params_model(True, True, steps=True), Y, u=U)
    np.testing.assert_allclose(fused.mean, sep.mean, rtol=1e-13, atol=1e-13)
    with pytest.raises(ModelError, match="disagrees"):  # the steps are checked with the model's params
        # f ignores params (uses A, B); the steps read B = 0 from them
        extended_kalman_filter(NonlinearStateSpaceModel(lambda x, u, k, p: np.array([A * x[0] + B * np.sin(x[1]), A * x[1] + u[0]]), h_p, **COV,
                                                        transition_step=f_step_p, observation_step=h_step_p,
                                                        transition_jacobian=fj_p, observation_jacobian=hj_p,
                                                        params=[A, 0.0]), Y, u=U)
    with pytest.raises(InputError, match=r"g\(x, u, k, params, out, out_jacobian\)"):
        NonlinearStateSpaceModel(f_p, h_p, **COV, transition_step=f_p, observation_step=h_p, params=[A, B])


@pytest.mark.parametrize("jitted", [False, True], ids=["python", "njit"])
def test_new_params_change_the_result_without_compiling_anything(jitted):
    model = _params_model(jitted, True)
    first = extended_kalman_filter(model, Y, u=U).mean

    def functions(m):
        return m.transition_fn, m.observation_fn, m.transition_jacobian, m.observation_jacobian

    counts = [len(fn.overloads) for fn in functions(model)] + [len(cached_ekf_kernel().overloads)]
    other = dataclasses.replace(model, params=[0.5, -0.3])  # a new parameter set, the same compiled functions
    assert all(a is b for a, b in zip(functions(model), functions(other)))
    second = extended_kalman_filter(other, Y, u=U).mean
    assert not np.allclose(first, second)  # the parameters are used...
    assert [len(fn.overloads) for fn in functions(other)] + [len(cached_ekf_kernel().overloads)] == counts  # at run time
    np.testing.assert_array_equal(extended_kalman_filter(dataclasses.replace(other, params=[A, B]), Y, u=U).mean,
                                  first)


@pytest.mark.parametrize("bad, error, match", [
    ([A, np.nan], InputError, "params must be finite"),
    ([A, np.inf], InputError, "params must be finite"),
    (np.array([1 + 2j, 0]), InputError, "real numbers"),
    (["a", "b"], InputError, "real numbers"),
    (np.eye(2), ShapeError, "params must be 1-D"),
    (0.5, ShapeError, "params must be 1-D"),
])
def test_wrong_params_are_refused_with_one_clear_error(bad, error, match):
    with pytest.raises(error, match=match):
        NonlinearStateSpaceModel(f_p, h_p, **COV, params=bad)


def test_params_are_stored_read_only_and_a_three_argument_function_is_refused():
    model = _params_model(True, True)
    assert model.params.dtype == np.float64 and not model.params.flags.writeable
    with pytest.raises(ModelError, match=r"transition_fn must be callable as fn\(x, u, k, params\)"):  # f(x, u, k) cannot be called as f(x, u, k, params)
        NonlinearStateSpaceModel(f_c, h_p, **COV, params=[A, B])
