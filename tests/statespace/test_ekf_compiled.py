"""The EKF's compiled loops: typed by signature (cached on disk, a new process loads it) or by identity, with
separate model functions or fused in-place steps -- the same numbers as the reference EKF (a plain NumPy loop,
``tests/statespace/_ekf_reference.py``) everywhere."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from numba import njit

from longprofile.errors import InputError, ModelError
from longprofile.statespace import NonlinearStateSpaceModel, StateSpaceModel, extended_kalman_filter, kalman_filter
from longprofile.statespace._ekf import cached_ekf_kernel, model_function_types

from ._ekf_reference import reference_ekf

_rng = np.random.default_rng(7)
F_LIN = np.array([[0.9, 0.1, 0.0], [-0.1, 0.8, 0.2], [0.0, 0.05, 0.95]])
H_LIN = np.array([[1.0, 0.0, 0.5], [0.0, 1.0, -0.3]])
B_LIN = np.array([[0.5], [0.0], [-0.2]])
C_OFF = np.array([0.1, -0.2, 0.05])
Q_LIN = np.diag([0.05, 0.02, 0.03])
R_LIN = np.array([[0.2, 0.05], [0.05, 0.1]])


@njit(cache=True)
def lin_f(x, u, k):
    out = C_OFF.copy()
    for i in range(3):
        for j in range(3):
            out[i] += F_LIN[i, j] * x[j]
        out[i] += B_LIN[i, 0] * u[0]
    return out


@njit(cache=True)
def lin_h(x, u, k):
    out = np.zeros(2)
    for i in range(2):
        for j in range(3):
            out[i] += H_LIN[i, j] * x[j]
    return out


@njit(cache=True)
def lin_fj(x, u, k):
    return F_LIN.copy()


@njit(cache=True)
def lin_hj(x, u, k):
    return H_LIN.copy()


@njit(cache=True)
def pend_f(x, u, k):  # pendulum, Euler step
    out = np.empty(2)
    out[0] = x[0] + 0.01 * x[1]
    out[1] = x[1] - 0.01 * 9.81 * np.sin(x[0])
    return out


@njit(cache=True)
def pend_h(x, u, k):
    out = np.empty(1)
    out[0] = np.sin(x[0])
    return out


@njit(cache=True)
def pend_fj(x, u, k):
    J = np.empty((2, 2))
    J[0, 0], J[0, 1] = 1.0, 0.01
    J[1, 0], J[1, 1] = -0.01 * 9.81 * np.cos(x[0]), 1.0
    return J


@njit(cache=True)
def pend_hj(x, u, k):
    H = np.zeros((1, 2))
    H[0, 0] = np.cos(x[0])
    return H


@njit(cache=True)
def pend_fstep(x, u, k, out, J):  # fused f and Jacobian, in place (the zero-initialised J keeps its content)
    c = np.cos(x[0])
    out[0] = x[0] + 0.01 * x[1]
    out[1] = x[1] - 0.01 * 9.81 * np.sin(x[0])
    J[0, 0], J[0, 1] = 1.0, 0.01
    J[1, 0], J[1, 1] = -0.01 * 9.81 * c, 1.0


@njit(cache=True)
def pend_hstep(x, u, k, out, H):
    out[0] = np.sin(x[0])
    H[0, 0] = np.cos(x[0])


@njit(cache=True)
def pend_hstep_wrong(x, u, k, out, H):
    out[0] = np.sin(x[0])
    H[0, 0] = 1.0


@njit(cache=True)
def strided_f(x, u, k):  # returns a non-contiguous array: cannot be typed for the cached loop
    out = np.empty(2 * x.shape[0])
    for i in range(x.shape[0]):
        out[2 * i] = x[i]
    return out[::2]


@njit(cache=True)
def ident_h(x, u, k):
    return x.copy()


@njit(cache=True)
def blow_up_f(x, u, k):
    out = x * 10.0
    if k == 5:
        out[0] = np.inf
    return out


def _data(T=200):
    u = _rng.normal(size=(T, 1))
    y = _rng.normal(size=(T, 2))
    y[10:15, 0] = np.nan
    y[40, :] = np.nan
    return y, u


def _reference(model, y, u=None):
    """The reference EKF on the Python bodies of the model's jitted functions, one series at a time."""
    fns = [None if fn is None else fn.py_func for fn in (model.transition_fn, model.observation_fn,
                                                         model.transition_jacobian, model.observation_jacobian)]
    return reference_ekf(fns[0], fns[1], model.process_cov, model.obs_cov, model.initial_mean, model.initial_cov,
                         y, u, fj=fns[2], hj=fns[3])


def test_linear_model_matches_the_kalman_filter_and_the_reference_ekf():
    y, u = _data()
    x0, P0 = np.array([0.5, -0.2, 0.1]), np.eye(3)
    model = NonlinearStateSpaceModel(lin_f, lin_h, Q_LIN, R_LIN, x0, P0, transition_jacobian=lin_fj,
                                     observation_jacobian=lin_hj)
    assert model_function_types(model) is not None  # runs the signature-typed (disk-cached) loop
    got = extended_kalman_filter(model, y, u=u)
    kf = kalman_filter(StateSpaceModel(F_LIN, H_LIN, Q_LIN, R_LIN, x0, P0, input_transition=B_LIN,
                                       state_offset=C_OFF), y, u=u)
    np.testing.assert_allclose(got.mean, kf.mean, atol=1e-10)
    np.testing.assert_allclose(got.cov, kf.cov, atol=1e-10)
    assert got.log_likelihood == pytest.approx(kf.log_likelihood, abs=1e-8)
    ref = _reference(model, y, u)
    for name in ("mean", "cov", "pred_mean", "pred_cov", "innovation_cov", "transition_jacobians",
                 "observation_jacobians", "log_likelihood_steps"):
        np.testing.assert_allclose(getattr(got, name), getattr(ref, name), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got.innovation, ref.innovation, rtol=1e-12, atol=1e-12)  # NaN where missing
    assert got.n_observed == ref.n_observed and got.method == "ekf"


def test_finite_difference_jacobians_batches_and_means_only_match_the_reference_ekf():
    T = 150
    truth = 0.3 * np.sin(0.05 * np.arange(T))
    y = (np.sin(truth) + 0.05 * _rng.normal(size=T))[:, None]
    model = NonlinearStateSpaceModel(pend_f, pend_h, np.diag([1e-5, 1e-4]), np.array([[0.05 ** 2]]),
                                     np.array([0.2, 0.0]), np.diag([0.1, 0.1]))
    yb = np.stack([y, y[::-1]])
    for store in (True, False):
        got = extended_kalman_filter(model, yb, store_covariances=store)
        for b in range(2):
            ref = _reference(model, yb[b])
            np.testing.assert_allclose(got.mean[b], ref.mean, rtol=1e-8, atol=1e-10)  # FD amplifies ulp differences
            np.testing.assert_allclose(got.log_likelihood[b], ref.log_likelihood, rtol=1e-8)
        assert (got.cov is None) == (not store)


def test_fused_steps_give_the_same_filter_as_the_separate_functions():
    T = 150
    y = (np.sin(0.3 * np.sin(0.05 * np.arange(T))) + 0.05 * _rng.normal(size=T))[:, None]
    y[20:25] = np.nan
    kw = dict(process_cov=np.diag([1e-5, 1e-4]), obs_cov=np.array([[0.05 ** 2]]), initial_mean=np.array([0.2, 0.0]),
              initial_cov=np.diag([0.1, 0.1]), transition_jacobian=pend_fj, observation_jacobian=pend_hj)
    separate = NonlinearStateSpaceModel(pend_f, pend_h, **kw)
    fused = NonlinearStateSpaceModel(pend_f, pend_h, **kw, transition_step=pend_fstep, observation_step=pend_hstep)
    a, b = extended_kalman_filter(separate, y), extended_kalman_filter(fused, y)
    for name in ("mean", "cov", "pred_mean", "pred_cov", "innovation", "innovation_cov", "log_likelihood_steps",
                 "transition_jacobians", "observation_jacobians"):
        np.testing.assert_array_equal(getattr(b, name), getattr(a, name), err_msg=name)
    with pytest.raises(ModelError, match="observation_step disagrees"):
        extended_kalman_filter(NonlinearStateSpaceModel(pend_f, pend_h, **kw, transition_step=pend_fstep,
                                                        observation_step=pend_hstep_wrong), y)
    with pytest.raises(InputError, match="both transition_step and observation_step"):
        NonlinearStateSpaceModel(pend_f, pend_h, **kw, transition_step=pend_fstep)
    with pytest.raises(InputError, match="transition_step must be a numba"):
        NonlinearStateSpaceModel(pend_f, pend_h, **kw, transition_step=pend_fstep.py_func, observation_step=pend_hstep)


def test_jitted_functions_of_another_signature_run_the_per_process_loop():
    y = _rng.normal(size=(30, 2))
    P0 = np.eye(2)
    strided = NonlinearStateSpaceModel(strided_f, ident_h, np.eye(2) * 0.1, np.eye(2), np.zeros(2), P0)
    # a jitted function returning a non-contiguous array cannot be typed for the cached loop
    assert strided.is_compiled and model_function_types(strided) is None
    assert model_function_types(NonlinearStateSpaceModel(pend_f, pend_h, np.eye(2), np.eye(1), np.zeros(2),
                                                         P0)) is not None
    np.testing.assert_allclose(extended_kalman_filter(strided, y).mean, _reference(strided, y).mean,
                               rtol=1e-10, atol=1e-12)


def test_non_finite_transition_raises_model_error_with_the_step():
    model = NonlinearStateSpaceModel(blow_up_f, pend_h, np.eye(2) * 0.1, np.eye(1), np.ones(2), np.eye(2))
    with pytest.raises(ModelError, match="step 5"):
        extended_kalman_filter(model, np.zeros(20))


_SCRIPT = textwrap.dedent("""
    import numpy as np
    from numba import njit
    from longprofile.statespace import NonlinearStateSpaceModel, extended_kalman_filter
    from longprofile.statespace._ekf import cached_ekf_kernel

    @njit
    def f(x, u, k):
        return 0.9 * x

    @njit
    def h(x, u, k):
        return x[:1].copy()

    model = NonlinearStateSpaceModel(f, h, np.eye(2) * 0.1, np.eye(1), np.zeros(2), np.eye(2))
    extended_kalman_filter(model, np.ones((50, 1)))
    st = cached_ekf_kernel().stats
    print(sum(st.cache_hits.values()), sum(st.cache_misses.values()))
""")


def test_the_compiled_loop_is_loaded_from_disk_by_a_new_process():
    # the first process may compile and write the cache; the second one must only load it
    runs = [subprocess.run([sys.executable, "-c", _SCRIPT], capture_output=True, text=True, timeout=300)
            for _ in range(2)]
    for r in runs:
        assert r.returncode == 0, r.stderr
    hits, misses = (int(v) for v in runs[1].stdout.split())
    assert (hits, misses) == (1, 0)
    assert cached_ekf_kernel() is cached_ekf_kernel()


_MIXED_SCRIPT = textwrap.dedent("""
    import sys
    import numpy as np
    from numba import njit
    from longprofile.statespace import NonlinearStateSpaceModel, extended_kalman_filter, _ekf

    # the signature-typed loop compiled in this process (not loaded from the disk cache), as on a fresh machine
    _fresh = njit(_ekf.ekf_kernel.py_func)
    _ekf.cached_ekf_kernel = lambda: _fresh

    @njit
    def f3(x, u, k):
        return 0.9 * x

    @njit
    def f4(x, u, k, p):
        return p[0] * x

    @njit
    def strided3(x, u, k):  # not typeable for the cached loop: the per-process loop
        out = np.empty(2 * x.shape[0])
        for i in range(x.shape[0]):
            out[2 * i] = 0.9 * x[i]
        return out[::2]

    @njit
    def strided4(x, u, k, p):
        out = np.empty(2 * x.shape[0])
        for i in range(x.shape[0]):
            out[2 * i] = p[0] * x[i]
        return out[::2]

    @njit
    def h3(x, u, k):
        return x[:1].copy()

    @njit
    def h4(x, u, k, p):
        return x[:1].copy()

    def model(f, h, params):
        return NonlinearStateSpaceModel(f, h, np.eye(2) * 0.1, np.eye(1), np.zeros(2), np.eye(2), params=params)

    y = np.ones((20, 1))
    with_params = (f4, h4, np.array([0.9])), (strided4, h4, np.array([0.9]))
    without = (f3, h3, None), (strided3, h3, None)
    order = with_params + without if sys.argv[1] == "params-first" else without + with_params
    means = [extended_kalman_filter(model(*m), y).mean for m in order]  # finite-difference Jacobians
    for m in means[1:]:
        np.testing.assert_allclose(m, means[0], rtol=1e-12, atol=1e-14)
    print("ok")
""")


@pytest.mark.parametrize("order", ["params-first", "plain-first"])
def test_models_with_and_without_params_share_a_process(order):
    # the finite-difference helper is specialised per model function; numba 0.68 raised "Signature mismatch:
    # 4 argument types given, but function takes 3" when a 3-argument function met a helper already compiled
    # for a 4-argument one (and the reverse): the failure CI saw when test orders mixed the two conventions
    r = subprocess.run([sys.executable, "-c", _MIXED_SCRIPT, order], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr[-2000:]
