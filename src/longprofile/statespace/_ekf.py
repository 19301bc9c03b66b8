"""Extended Kalman filter and its RTS smoother for nonlinear additive-noise models."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from numba import typeof, types
from numba.core.errors import NumbaError

from .._jit import njit
from .._validation import as_float_array, require_symmetric_psd
from ..errors import InputError, ModelError, ShapeError
from ._ekf_kernels import ekf_kernel
from ._kalman import rts_smoother
from ._linalg_kernels import FD_REL_STEP
from ._model import StateSpaceModel
from ._prepare import as_observation_batch, covariance_storage, noise_terms, nonlinear_inputs
from ._results import FilterResult, SmootherResult
from ._status import raise_status

__all__ = ["NonlinearStateSpaceModel", "extended_kalman_filter", "extended_rts_smoother", "is_jitted", "check_functions"]



def is_jitted(fn) -> bool:
    """True if ``fn`` is a numba ``@njit`` function (a CPU dispatcher) that compiled loops can call."""
    if fn is None:
        return False
    try:
        from numba.core.registry import CPUDispatcher
    except ImportError:  # pragma: no cover - numba is a hard dependency
        return False
    return isinstance(fn, CPUDispatcher)


@dataclass(frozen=True, eq=False)
class NonlinearStateSpaceModel:
    r"""Nonlinear state-space model with additive Gaussian noise.

    .. math::

        x_0 &\sim \mathcal N(x_0^-, P_0^-) \\
        x_{k+1} &= f(x_k, u_k, k) + w_k, \qquad w_k \sim \mathcal N(0, Q_k) \\
        y_k &= h(x_k, u_k, k) + v_k, \qquad v_k \sim \mathcal N(0, R_k)

    Parameters
    ----------
    transition_fn : callable ``f(x, u, k) -> (n,) ndarray``
        State transition from step k to k+1. ``x`` is (n,), ``u`` the (p,) row
        of the known inputs at step k (an empty (0,) array when no inputs are
        given), ``k`` the integer step. Must return a new array and not modify
        its arguments.
    observation_fn : callable ``h(x, u, k) -> (m,) ndarray``
        Observation function at step k.
    process_cov : (n, n) or (T-1, n, n) array_like
        Q, symmetric positive semi-definite (time-varying with a leading T-1 axis).
    obs_cov : (m, m) or (T, m, m) array_like
        R, symmetric positive semi-definite, positive definite on observed components.
    initial_mean : (n,) array_like
        Prior mean of x_0 (before y_0).
    initial_cov : (n, n) array_like
        Prior covariance of x_0.
    transition_jacobian : callable ``f_jac(x, u, k) -> (n, n) ndarray``, optional
        Analytic df/dx. Central finite differences when None.
    observation_jacobian : callable ``h_jac(x, u, k) -> (m, n) ndarray``, optional
        Analytic dh/dx. Central finite differences when None.
    params : (P,) array_like, optional
        Model parameters passed unchanged to every model function. When given, every function takes them as
        an extra argument after ``k``: ``f(x, u, k, params)``, ``h(x, u, k, params)``, the Jacobians
        ``f_jac(x, u, k, params)``, ``h_jac(x, u, k, params)`` and the fused steps
        ``transition_step(x, u, k, params, x_next, F)``, ``observation_step(x, u, k, params, y_hat, H)``
        (dynamax's ``f(x, u, k, params)``). Stored as a read-only finite float64 vector (the functions must
        not modify it). None (default): the functions take ``(x, u, k)`` (``(x, u, k, out, J)`` for the
        steps). Parameters read at run time instead of frozen into a closure let ONE compiled function (and
        one compiled filter loop) serve every parameter set: a new vehicle is a new array, not a new
        compilation.
    transition_step, observation_step : numba ``@njit`` functions, optional (both or neither)
        Fused, allocation-free versions of the model for the compiled loops:
        ``transition_step(x, u, k, x_next, F)`` writes ``f(x, u, k)`` into
        ``x_next`` (n,) and its Jacobian into ``F`` (n, n);
        ``observation_step(x, u, k, y_hat, H)`` writes ``h`` (m,) and its
        Jacobian (m, n). Both return None. One call computes a function and
        its Jacobian at the same point, so shared sub-expressions (tyre forces,
        damper tensions) are evaluated once and nothing is allocated per step.
        The Jacobian arrays start at zero and keep their content between calls:
        entries that are always zero need not be written. The filters check the
        steps against the separate functions at the initial state (ModelError
        if they disagree); the checks and the smoother use the separate
        functions.

    Notes
    -----
    The filters run compiled loops (numba) that call the model functions (about a microsecond per step
    for n = 3, m = 2). Plain Python functions are compiled with ``numba.njit`` when the model is built
    (numba's nopython mode: numpy operations numba supports; arrays they read from enclosing scopes are
    frozen at compile time), each behind a small compiled wrapper that returns a new C-contiguous float64
    array; a function numba cannot compile is refused with a :class:`~longprofile.errors.ModelError` when the
    model is built. Jitted functions that compile for C-contiguous float64 arrays, i.e.
    ``(x (n,), u (p,), k int64) -> array`` (with ``params`` (P,) after ``k`` when the model has them), run in a
    loop compiled for their *signature* and cached on disk
    by numba (compiled once per machine; a new process loads it); other jitted functions run in a loop
    compiled for their identity (once per process). Finite differences use the central step
    h_j = eps^(1/3) max(|x_j|, 1) (error O(h^2) + O(eps/h)). (Until 2026-12-03 plain Python functions ran
    a second, pure-Python copy of the filter; it is now the test suite's oracle,
    ``tests/statespace/_ekf_reference.py``.)
    """

    transition_fn: Callable
    observation_fn: Callable
    process_cov: np.ndarray
    obs_cov: np.ndarray
    initial_mean: np.ndarray
    initial_cov: np.ndarray
    transition_jacobian: Callable | None = None
    observation_jacobian: Callable | None = None
    transition_step: Callable | None = None
    observation_step: Callable | None = None
    params: np.ndarray | None = None
    _compiled: bool = field(default=False, init=False, repr=False)

    def __post_init__(self):
        if self.params is not None:
            object.__setattr__(self, "params", _as_params(self.params))
        call = self.call_signature
        for name in ("transition_fn", "observation_fn"):
            if not callable(getattr(self, name)):
                raise InputError(f"{name} must be callable as {call}; got {type(getattr(self, name)).__name__}.")
        for name in ("transition_jacobian", "observation_jacobian"):
            val = getattr(self, name)
            if val is not None and not callable(val):
                raise InputError(f"{name} must be None (finite differences) or callable as {call}; "
                                 f"got {type(val).__name__}.")
        x0 = as_float_array("initial_mean", self.initial_mean, ndim=1, allow_nan=False)
        P0 = as_float_array("initial_cov", self.initial_cov, ndim=2, allow_nan=False)
        Q = as_float_array("process_cov (Q)", self.process_cov, ndim=(2, 3), allow_nan=False)
        R = as_float_array("obs_cov (R)", self.obs_cov, ndim=(2, 3), allow_nan=False)
        n = x0.shape[0]
        if n < 1:
            raise ShapeError("initial_mean must have at least one state; got shape (0,).")
        if P0.shape != (n, n):
            raise ShapeError(f"initial_cov (P0) must have shape ({n}, {n}) to match initial_mean; got {P0.shape}.")
        if Q.shape[-2:] != (n, n):
            raise ShapeError(f"process_cov (Q) must have shape ({n}, {n}) or (T-1, {n}, {n}); got {Q.shape}.")
        m = R.shape[-1]
        if R.shape[-2] != m or m < 1:
            raise ShapeError(f"obs_cov (R) must have shape (m, m) or (T, m, m); got {R.shape}.")
        require_symmetric_psd("process_cov (Q)", Q)
        require_symmetric_psd("obs_cov (R)", R)
        require_symmetric_psd("initial_cov (P0)", P0)
        for k, v in (("initial_mean", x0), ("initial_cov", P0), ("process_cov", Q), ("obs_cov", R)):
            v = np.ascontiguousarray(v)
            v.setflags(write=False)
            object.__setattr__(self, k, v)
        if (self.transition_step is None) != (self.observation_step is None):
            raise InputError("give both transition_step and observation_step (fused model steps), or neither; got "
                             f"transition_step={'None' if self.transition_step is None else 'a function'}, "
                             f"observation_step={'None' if self.observation_step is None else 'a function'}.")
        for name in ("transition_step", "observation_step"):
            val = getattr(self, name)
            if val is not None and not is_jitted(val):
                raise InputError(f"{name} must be a numba @njit function {self.step_signature} (the compiled "
                                 f"loops call it); got {type(val).__name__}. Leave it None to use transition_fn / "
                                 "observation_fn.")
        for name, ndim in (("transition_fn", 1), ("observation_fn", 1), ("transition_jacobian", 2),
                           ("observation_jacobian", 2)):
            fn = getattr(self, name)
            if fn is not None and not is_jitted(fn):
                object.__setattr__(self, name, compile_model_function(fn, ndim, name=name,
                                                                      with_params=self.params is not None))
        object.__setattr__(self, "_compiled", True)

    @property
    def call_signature(self) -> str:
        """How the model functions are called: ``"fn(x, u, k)"``, or ``"fn(x, u, k, params)"`` with params."""
        return "fn(x, u, k)" if self.params is None else "fn(x, u, k, params)"

    @property
    def step_signature(self) -> str:
        """How the fused steps are called: ``"g(x, u, k, out, out_jacobian)"`` (params inserted after k)."""
        return "g(x, u, k, out, out_jacobian)" if self.params is None else "g(x, u, k, params, out, out_jacobian)"

    def model_args(self, x, u, k) -> tuple:
        """The arguments of a model function at (x, u, k): ``(x, u, k)`` or ``(x, u, k, params)`` (a writeable
        copy of params: the functions are compiled for writeable arrays)."""
        return (x, u, k) if self.params is None else (x, u, k, self.kernel_params())

    def kernel_params(self):
        """``params`` as the compiled loops take it: None, or a writeable C-contiguous copy (the loops are typed
        for writeable arrays; the model's own copy is read-only)."""
        return None if self.params is None else np.array(self.params)

    @property
    def n_states(self) -> int:
        """Number of states n."""
        return self.initial_mean.shape[0]

    @property
    def n_obs(self) -> int:
        """Number of observations m per step."""
        return self.obs_cov.shape[-1]

    @property
    def is_compiled(self) -> bool:
        """True: every model function is numba-jitted (plain Python functions are compiled when the model is
        built), so the filters run compiled loops. Kept for compatibility; always True since 2026-12-03."""
        return self._compiled


def _as_params(value) -> np.ndarray:
    """``params`` of a model: a read-only, C-contiguous, finite float64 vector (InputError / ShapeError else)."""
    try:
        dtype = np.asarray(value).dtype
    except (TypeError, ValueError):  # ragged nested sequences
        dtype = np.dtype(object)
    if dtype.kind not in "iuf":
        raise InputError(f"params must be a 1-D array of real numbers (float64; passed unchanged to every model "
                         f"function); got dtype {dtype}.")
    arr = np.ascontiguousarray(as_float_array("params", value, ndim=1, allow_nan=False)).copy()
    arr.setflags(write=False)
    return arr


@njit
def _new_vector(r):
    """``r`` copied into a new C-contiguous float64 vector (a loop, not a slice assignment: cheaper to compile)."""
    r = np.asarray(r)
    out = np.empty(r.shape[0])
    for i in range(r.shape[0]):
        out[i] = r[i]
    return out


@njit
def _new_matrix(r):
    """``r`` copied into a new C-contiguous float64 matrix."""
    r = np.asarray(r)
    out = np.empty((r.shape[0], r.shape[1]))
    for i in range(r.shape[0]):
        for j in range(r.shape[1]):
            out[i, j] = r[i, j]
    return out


def _copying(g, ndim: int, with_params: bool):
    """A function returning ``g``'s result copied into a new C-contiguous float64 array (jitted by the caller)."""
    copy = _new_vector if ndim == 1 else _new_matrix
    if with_params:
        def f(x, u, k, params):
            return copy(g(x, u, k, params))
    else:
        def f(x, u, k):
            return copy(g(x, u, k))
    return f


def compile_model_function(fn, ndim: int, *, name: str = "the model function", with_params: bool = False):
    """``fn(x, u, k)`` (``fn(x, u, k, params)`` with ``with_params``; plain Python) compiled with ``numba.njit``
    for C-contiguous float64 ``x`` (n,), ``u`` (p,), an int64 ``k`` (and float64 ``params`` (P,)), so that the
    compiled loops typed by signature (cached on disk) can call it. When it does not return a new C-contiguous
    float64 array of ``ndim`` dimensions (1: f, h; 2: Jacobians) -- e.g. it returns an array it read from an
    enclosing scope, which numba freezes read-only -- a jitted wrapper copies the result into one. ModelError,
    naming the function, if numba cannot compile it or its result is not such an array."""
    ftype = _function_types(with_params)[0 if ndim == 1 else 1]
    args = ftype.signature.args
    call = "fn(x, u, k, params)" if with_params else "fn(x, u, k)"
    inner = njit(fn)
    try:
        inner.compile(args)
    except TypeError as exc:  # numba's "Signature mismatch": the function does not take these arguments
        raise ModelError(f"{name} must be callable as {call}: {_first_line(exc)}") from None
    except NumbaError as exc:
        raise ModelError(f"{name} could not be compiled by numba (the filters run compiled loops; plain Python "
                         f"functions are compiled with numba.njit, which supports numpy arrays and scalars, not "
                         f"Python objects): {_first_line(exc)}") from None
    want = ftype.signature.return_type
    if inner.overloads[args].signature.return_type == want:
        return inner
    out = njit(_copying(inner, ndim, with_params))
    try:
        out.compile(args)
    except NumbaError:
        got = inner.overloads[args].signature.return_type
        raise ModelError(f"{name} must return a {ndim}-D float array ({call}); numba types its result as "
                         f"{got}.") from None
    return out


def _first_line(exc) -> str:
    """The first line of a numba error that says what failed (not numba's "Failed in ... pipeline" header)."""
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip() and not ln.strip().startswith("Failed in")]
    return lines[0] if lines else type(exc).__name__


def _fd_jacobian_py(fn, x, u, k, *params):
    n = x.shape[0]
    cols = []
    xw = x.copy()
    for j in range(n):
        step = FD_REL_STEP * max(abs(x[j]), 1.0)
        hi, lo = x[j] + step, x[j] - step
        xw[j] = hi
        a = np.asarray(fn(xw, u, k, *params), dtype=np.float64)
        xw[j] = lo
        b = np.asarray(fn(xw, u, k, *params), dtype=np.float64)
        xw[j] = x[j]
        cols.append((a - b) / (hi - lo))
    return np.stack(cols, axis=-1)


def _call(model, which, x, u, k):
    """Evaluate f/h or their Jacobians from Python, for the checks and the smoother (finite differences when
    absent); the model's params, if any, are passed after k."""
    args = model.model_args(x, u, k)
    if which == "f":
        return np.asarray(model.transition_fn(*args), dtype=np.float64)
    if which == "h":
        return np.asarray(model.observation_fn(*args), dtype=np.float64)
    if which == "F":
        fn, jac = model.transition_fn, model.transition_jacobian
    else:
        fn, jac = model.observation_fn, model.observation_jacobian
    return _fd_jacobian_py(fn, *args) if jac is None else np.asarray(jac(*args), float)


def check_functions(model, u0):
    """Call every model function once at the prior mean: shapes and finiteness, with clear errors."""
    n, m = model.n_states, model.n_obs
    x = model.initial_mean.copy()
    expect = (("f", "transition_fn", (n,)), ("h", "observation_fn", (m,)),
              ("F", "transition_jacobian", (n, n)), ("H", "observation_jacobian", (m, n)))
    for which, name, shape in expect:
        try:
            out = _call(model, which, x, u0, 0)
        except NumbaError as exc:
            raise ModelError(f"{name} could not be compiled by numba (the filters run compiled loops): "
                             f"{_first_line(exc)}") from None
        except (ValueError, TypeError, IndexError, ArithmeticError) as exc:
            raise ModelError(f"{name} failed when called as {model.call_signature} with x = initial_mean (shape "
                             f"({n},)), u of shape {u0.shape}, k = 0{_params_note(model)}: {type(exc).__name__}: "
                             f"{exc}") from exc
        if out.shape != shape:
            raise ShapeError(f"{name} must return shape {shape}; it returned {out.shape} at x = initial_mean.")
        if not np.all(np.isfinite(out)):
            raise ModelError(f"{name} returned non-finite values at x = initial_mean, k = 0: {out}.")


def _params_note(model) -> str:
    return "" if model.params is None else f", params of shape {model.params.shape}"


def ekf_kernel_outputs(T: int, n: int, m: int, store: bool) -> tuple:
    """Arrays that :func:`._ekf_kernels.ekf_kernel` fills, in its argument order after ``store``:
    mean, cov, pmean, pcov, innov, icov, ll_steps, Fj, Hj, state (covariances and Jacobians are
    (1, ., .) dummies when not ``store``)."""
    mean, pmean, innov, ll_steps = np.empty((T, n)), np.empty((T, n)), np.empty((T, m)), np.empty(T)
    if store:
        cov, pcov, icov = np.empty((T, n, n)), np.empty((T, n, n)), np.empty((T, m, m))
        Fj, Hj = np.empty((max(T - 1, 0), n, n)), np.empty((T, m, n))
    else:
        cov, pcov, icov = np.empty((1, n, n)), np.empty((1, n, n)), np.empty((1, m, m))
        Fj, Hj = np.empty((1, n, n)), np.empty((1, m, n))
    return mean, cov, pmean, pcov, innov, icov, ll_steps, Fj, Hj, np.zeros(2, dtype=np.int64)


def ekf_kernel_result(outputs: tuple, n_obs, store: bool) -> tuple:
    """Raise the kernel's status as a ModelError (with the step), else return
    (mean, cov, pmean, pcov, innov, icov, ll_steps, n_obs, Fj, Hj) with None for what was not stored."""
    mean, cov, pmean, pcov, innov, icov, ll_steps, Fj, Hj, state = outputs
    raise_status(state[0], state[1], "ekf")
    if not store:
        cov = pcov = icov = Fj = Hj = None
    return mean, cov, pmean, pcov, innov, icov, ll_steps, int(n_obs), Fj, Hj


def _ekf_compiled(model, Q3, R3, y, u, store, store_var=False):
    T, m = y.shape
    outputs = ekf_kernel_outputs(T, model.n_states, m, store)
    var = np.empty((T, model.n_states + m) if store_var else (1, model.n_states + m))
    data = ((model.kernel_params(), Q3, R3, model.initial_mean, model.initial_cov, y, u, store) + tuple(outputs)
            + (store_var, var))
    fns = model_functions(model)
    fn_types = model_function_types(model)
    if fn_types is None:  # jitted functions of another signature: loop compiled for their identity, per process
        n_obs = ekf_kernel(*fns, *data)
    else:
        n_obs = cached_ekf_kernel().compile(fn_types + tuple(typeof(a) for a in data))(*fns, *data)
    n = model.n_states
    return ekf_kernel_result(outputs, n_obs, store) + ((var[:, :n], var[:, n:]) if store_var else (None, None))


# ---------------------------------------------------------------- loop typed by signature (cached on disk)
#
# numba types a jitted function passed as an argument by its identity (types.Dispatcher), so a loop
# specialised for it can never be found in the on-disk cache by another process (numba/numba#2956,
# #6251, #6284) and every new process would pay the compile again (5-20 s for the vehicle models of
# paper 001 on a loaded machine). Compiled instead for first-class function types -- the functions'
# signature -- the loop calls them through pointers resolved at call time, its machine code does not
# depend on which functions are passed, and ``cache=True`` persists it (keyed on the signature and on
# the loop's source file). Measured on the paper-001 vehicle model the pointer calls cost nothing
# measurable against the inlined loop (docs/statespace-notes.md).

_VEC = types.Array(types.float64, 1, "C")
_MAT = types.Array(types.float64, 2, "C")
#: Type of f and h: (x (n,), u (p,), k) -> (n,) or (m,).
FUNCTION_TYPE = types.FunctionType(_VEC(_VEC, _VEC, types.int64))
#: Type of the Jacobians: (x, u, k) -> (n, n) or (m, n).
JACOBIAN_TYPE = types.FunctionType(_MAT(_VEC, _VEC, types.int64))
#: Type of the fused steps: (x, u, k, out (n,) or (m,), out_jacobian) -> None.
STEP_TYPE = types.FunctionType(types.none(_VEC, _VEC, types.int64, _VEC, _MAT))
#: The same with model parameters (P,) after k: f(x, u, k, params), step(x, u, k, params, out, out_jacobian).
FUNCTION_TYPE_PARAMS = types.FunctionType(_VEC(_VEC, _VEC, types.int64, _VEC))
JACOBIAN_TYPE_PARAMS = types.FunctionType(_MAT(_VEC, _VEC, types.int64, _VEC))
STEP_TYPE_PARAMS = types.FunctionType(types.none(_VEC, _VEC, types.int64, _VEC, _VEC, _MAT))


def _function_types(with_params: bool) -> tuple:
    """(function, Jacobian, step) types of the model functions without or with params."""
    if with_params:
        return FUNCTION_TYPE_PARAMS, JACOBIAN_TYPE_PARAMS, STEP_TYPE_PARAMS
    return FUNCTION_TYPE, JACOBIAN_TYPE, STEP_TYPE


@functools.cache
def cached_ekf_kernel():
    """The engine's EKF loop as a ``cache=True`` dispatcher (compiled only for function-typed arguments)."""
    return njit(cache=True)(ekf_kernel.py_func)


def model_functions(model) -> tuple:
    """The arguments (f, h, f_jac, h_jac, f_step, h_step) of the compiled loops: the fused steps when the
    model has them (the separate functions then None), else the separate functions (steps None)."""
    if model.transition_step is not None:
        return None, None, None, None, model.transition_step, model.observation_step
    return (model.transition_fn, model.observation_fn, model.transition_jacobian, model.observation_jacobian,
            None, None)


def _function_type(fn, ftype):
    """``ftype`` if the jitted ``fn`` compiles for it with the exact return type, ``types.none`` for None, else None."""
    if fn is None:
        return types.none
    args = ftype.signature.args
    try:
        fn.compile(args)
    except (NumbaError, TypeError, ValueError):
        return None
    cres = fn.overloads.get(args)
    if cres is None or cres.signature.return_type != ftype.signature.return_type:
        return None
    return ftype


def model_function_types(model):
    """numba types of :func:`model_functions` for the signature-typed (disk-cached) loop, or None when a
    function does not compile for C-contiguous float64 arrays with the exact return type."""
    fn_t, jac_t, step_t = _function_types(model.params is not None)
    kinds = (fn_t, fn_t, jac_t, jac_t, step_t, step_t)
    out = tuple(_function_type(fn, ftype) for fn, ftype in zip(model_functions(model), kinds))
    return None if any(t is None for t in out) else out


def check_model_steps(model, u0, jacobian_mask=None):
    """ModelError unless the fused steps reproduce f, h and their Jacobians at the initial state.

    ``jacobian_mask`` (bool, (n, n) for F and (m, n) for H as a pair) restricts the Jacobian comparison
    to the entries a filter uses (the block filter uses the diagonal blocks only); None compares all.
    """
    if model.transition_step is None:
        return
    x0 = np.ascontiguousarray(model.initial_mean, dtype=float)
    u0 = np.ascontiguousarray(u0, dtype=float)
    n, m = model.n_states, model.n_obs
    for name, step, which, size, mask in (
            ("transition_step", model.transition_step, "f", n, None if jacobian_mask is None else jacobian_mask[0]),
            ("observation_step", model.observation_step, "h", m, None if jacobian_mask is None else jacobian_mask[1])):
        out, J = np.zeros(size), np.zeros((size, n))
        try:
            step(*model.model_args(x0, u0, 0), out, J)
        except (ValueError, TypeError, IndexError, ArithmeticError, NumbaError) as exc:
            raise ModelError(f"{name} failed when called as {model.step_signature} with x = initial_mean "
                             f"(shape ({n},)), u of shape {u0.shape}, k = 0{_params_note(model)}, out ({size},), "
                             f"out_jacobian ({size}, {n}): {type(exc).__name__}: {str(exc).splitlines()[0]}") from None
        ref = _call(model, which, x0, u0, 0)
        Jref = _call(model, which.upper(), x0, u0, 0)
        sel = np.ones(J.shape, bool) if mask is None else mask
        analytic = (model.transition_jacobian if which == "f" else model.observation_jacobian) is not None
        rtol, atol = (1e-10, 1e-12) if analytic else (1e-6, 1e-8)  # finite differences: error ~ eps^(2/3)
        if not (np.allclose(out, ref, rtol=1e-10, atol=1e-12) and np.allclose(J[sel], Jref[sel], rtol=rtol,
                                                                                 atol=atol)):
            raise ModelError(f"{name} disagrees with {'transition' if which == 'f' else 'observation'}_fn and its "
                             "Jacobian at the initial state: the fused step must compute the same function and "
                             "Jacobian.")


def _prepare(model, y, u):
    if not isinstance(model, NonlinearStateSpaceModel):
        raise InputError(f"extended_kalman_filter needs a NonlinearStateSpaceModel; got {type(model).__name__} "
                         "(use kalman_filter for a linear StateSpaceModel).")
    arr, batched = as_observation_batch(y, model.n_obs)
    nb, T, _ = arr.shape
    Q3, R3 = noise_terms(model.process_cov, model.obs_cov, T)
    return arr, batched, Q3, R3, nonlinear_inputs(u, T, nb)


def extended_kalman_filter(model: NonlinearStateSpaceModel, y, *, u=None,
                           store_covariances: bool | str = True) -> FilterResult:
    """Extended Kalman filter (first-order linearisation, Joseph-form update, NaN = missing).

    Parameters
    ----------
    model : NonlinearStateSpaceModel
        f, h (and optional Jacobians), Q, R and the prior of x_0.
    y : (T,), (T, m) or (B, T, m) array_like
        Observations; NaN marks a missing component (only the observed rows of
        H_k and R_k enter the update). A 3-D array is a batch of series.
    u : (T, p) or (B, T, p) array_like, optional
        Known inputs; row ``u[k]`` is passed to f and h at step k.
    store_covariances : bool or "variances", default True
        If False, ``cov``, ``pred_cov``, ``innovation_cov`` and the Jacobians
        are None (O(T n) memory); the smoother then cannot run. ``"variances"``:
        the same, plus the diagonal of each filtered covariance
        (``FilterResult.variance``, (T, n)) and of each innovation covariance
        (``FilterResult.innovation_variance``, (T, m)); the filtered numbers
        are the same in all three modes.

    Returns
    -------
    FilterResult
        As :func:`kalman_filter`, ``method = "ekf"``, plus
        ``transition_jacobians`` (T-1, n, n): F_k = df/dx at the filtered mean
        x[k|k], and ``observation_jacobians`` (T, m, n): H_k = dh/dx at the
        predicted mean x[k|k-1] — the linearisations actually used.

    Raises
    ------
    ModelError
        If a model function fails, returns the wrong shape or non-finite
        values, or the innovation covariance is not positive definite.
    ShapeError, InputError
        On inconsistent y, u or time-varying Q/R lengths.

    Notes
    -----
    Step k: predicted mean x[k|k-1] (``pred_mean[k]``), H_k = dh/dx there,
    S_k = H_k P H_k' + R_k, K = P H_o' S_o^-1 (Cholesky), x[k|k] = x[k|k-1] + K (y - h(x[k|k-1])),
    P[k|k] = (I - K H_o) P (I - K H_o)' + K R_o K' (Joseph form; S. Särkkä,
    *Bayesian Filtering and Smoothing*, 2013, Alg. 5.4). Then F_k = df/dx at
    x[k|k], x[k+1|k] = f(x[k|k], u_k, k), P[k+1|k] = F_k P F_k' + Q_k.
    Vehicle models of paper 001 (eq. 20) and thesis 003 use this filter.
    """
    Y, batched, Q3, R3, U = _prepare(model, y, u)
    u0 = U[0, 0] if U.shape[1] else np.zeros(0)
    check_functions(model, u0)
    check_model_steps(model, u0)
    store, store_var = covariance_storage(store_covariances)
    outs = [_ekf_compiled(model, Q3, R3, Y[b], U[b], store, store_var) for b in range(Y.shape[0])]
    if batched:
        def stack(i):
            return None if outs[0][i] is None else np.stack([o[i] for o in outs])
    else:
        def stack(i):
            return outs[0][i]
    ll_steps = stack(6)
    return FilterResult(
        mean=stack(0), cov=stack(1), pred_mean=stack(2), pred_cov=stack(3), innovation=stack(4),
        innovation_cov=stack(5), log_likelihood=ll_steps.sum(axis=-1) if batched else float(ll_steps.sum()),
        log_likelihood_steps=ll_steps, n_observed=np.array([o[7] for o in outs]) if batched else outs[0][7],
        method="ekf", transition_jacobians=stack(8), observation_jacobians=stack(9), variance=stack(10),
        innovation_variance=stack(11))


def extended_rts_smoother(model: NonlinearStateSpaceModel, filtered: FilterResult, *, u=None) -> SmootherResult:
    """Extended RTS smoother using the filter's stored linearisations and predicted moments.

    Parameters
    ----------
    model : NonlinearStateSpaceModel
        The model the filter ran with (its Q and R are used).
    filtered : FilterResult
        Output of :func:`extended_kalman_filter` with covariances stored.
    u : (T, p) or (B, T, p) array_like, optional
        Known inputs; only needed when ``filtered`` carries no
        ``transition_jacobians`` (then F_k is re-evaluated at the filtered means).

    Returns
    -------
    SmootherResult
        Smoothed means (T, n), covariances (T, n, n) and lag-one cross-covariances (T-1, n, n).

    Raises
    ------
    ShapeError
        If ``filtered`` has no covariances.

    Notes
    -----
    G_k = P[k|k] F_k' P[k+1|k]^-1, x_s[k] = x[k|k] + G_k (x_s[k+1] - x[k+1|k]),
    P_s[k] = P[k|k] + G_k (P_s[k+1] - P[k+1|k]) G_k' (Särkkä 2013, Alg. 9.3).
    The predicted mean and covariance are the ones the filter stored —
    x[k+1|k] = f(x[k|k]) — not recomputed as F_k x[k|k] (with a Jacobian in
    place of f): doing so is the bug of filterpy's ``rts_smoother`` used on an
    EKF (rlabbe/filterpy#278), which biases the smoothed means of any
    nonlinear (or affine-offset) transition. The backward pass itself is the
    engine's :func:`rts_smoother` run on the time-varying linearised model.
    """
    if filtered.cov is None or filtered.pred_cov is None:
        raise ShapeError("extended_rts_smoother needs the filtered covariances; run extended_kalman_filter with "
                         "store_covariances=True.")
    batched = filtered.mean.ndim == 3
    Fj = filtered.transition_jacobians
    if Fj is None:
        Fj = _relinearise(model, filtered, u)
    n = model.n_states

    def one(b):
        pick = (lambda a: a[b]) if batched else (lambda a: a)
        mean = pick(filtered.mean)
        T = mean.shape[0]
        fr = FilterResult(mean=mean, cov=pick(filtered.cov), pred_mean=pick(filtered.pred_mean),
                          pred_cov=pick(filtered.pred_cov), innovation=pick(filtered.innovation),
                          innovation_cov=None, log_likelihood=0.0, log_likelihood_steps=np.zeros(T),
                          n_observed=0, method=filtered.method)
        if T == 1:
            return SmootherResult(mean=mean.copy(), cov=fr.cov.copy(), cross_cov=np.empty((0, n, n)), filtered=fr)
        Q = model.process_cov
        lin = StateSpaceModel(transition=pick(Fj), observation=np.zeros((1, n)),
                              process_cov=Q if Q.ndim == 3 else np.broadcast_to(Q, (T - 1, n, n)),
                              obs_cov=np.ones((1, 1)), initial_mean=model.initial_mean,
                              initial_cov=model.initial_cov, check_psd=False)
        return rts_smoother(lin, fr)

    if batched:
        outs = [one(b) for b in range(filtered.mean.shape[0])]
        sm, sc, cc = (np.stack([getattr(o, a) for o in outs]) for a in ("mean", "cov", "cross_cov"))
    else:
        o = one(None)
        sm, sc, cc = o.mean, o.cov, o.cross_cov
    return SmootherResult(mean=sm, cov=sc, cross_cov=cc, filtered=filtered)


def _relinearise(model, filtered, u):
    mean = filtered.mean if filtered.mean.ndim == 3 else filtered.mean[None]
    nb, T, n = mean.shape
    U = nonlinear_inputs(u, T, nb)
    out = np.empty((nb, max(T - 1, 0), n, n))
    for b in range(nb):
        for k in range(T - 1):
            out[b, k] = _call(model, "F", mean[b, k], U[b, k], k)
    return out if filtered.mean.ndim == 3 else out[0]
