"""Extended Kalman filter whose compiled loop is cached on disk across processes (private).

:func:`extended_kalman_filter` compiles its loop for the model functions themselves: numba types a
jitted function passed as an argument by its identity (``types.Dispatcher``), so the specialised loop
can never be found in the on-disk cache by another process (numba/numba#2956, #6251, #6284) and every
new process pays the compile again (5-20 s for the vehicle models of paper 001 on a loaded machine).

Here the same loop (:func:`._ekf_kernels.ekf_kernel`, not a copy) is compiled for **first-class
function types** instead: ``f`` and ``h`` are typed ``FunctionType(array(float64, 1d, C)(array(float64,
1d, C), array(float64, 1d, C), int64))`` and the Jacobians ``FunctionType(array(float64, 2d, C)(...))``,
i.e. by their signature only. The loop then calls the user's functions through a function pointer
resolved at call time, so its machine code does not depend on which functions are passed and numba
caches it on disk (``cache=True``), keyed on the signature and on the source file of the loop.

Consequences (named assumptions):

* The model functions must be numba ``@njit`` functions that compile for the signature above and
  return C-contiguous float64 arrays (1-D for f, h; 2-D for the Jacobians). Otherwise the call falls
  back to :func:`extended_kalman_filter`, with the same results.
* The user's functions are compiled on their own (decorate them with ``cache=True`` to cache them too;
  closures are cached per value of their captured variables).
* The calls are not inlined into the loop. Measured on the paper-001 vehicle model (n = 3, m = 2,
  20 000 steps, 12:48 UTC, load average 4.6) this costs nothing measurable: 2.6-2.8 us/step against
  2.8-3.4 us/step for the inlined loop in the same processes, with identical means and covariances.
* Cache invalidation: numba re-compiles when ``_ekf_kernels.py`` changes (its time stamp and size key
  the cache). Like every ``cache=True`` function in the package, a change only in a helper it calls
  (``_linalg_kernels.py``) is not detected by numba; clear ``__pycache__`` after editing those.
"""

from __future__ import annotations

import functools
import inspect

import numpy as np
from numba import njit, types, typeof
from numba.core.errors import NumbaError

from . import _ekf, _ekf_kernels
from ._ekf import NonlinearStateSpaceModel, extended_kalman_filter, is_jitted
from ._results import FilterResult

__all__ = ["extended_kalman_filter_cached"]

_VEC = types.Array(types.float64, 1, "C")
_MAT = types.Array(types.float64, 2, "C")
#: Type of f and h in the cached loop: (x (n,), u (p,), k) -> (n,) or (m,).
FUNCTION_TYPE = types.FunctionType(_VEC(_VEC, _VEC, types.int64))
#: Type of the Jacobians: (x, u, k) -> (n, n) or (m, n).
JACOBIAN_TYPE = types.FunctionType(_MAT(_VEC, _VEC, types.int64))


#: Arguments of ``_ekf_kernels.ekf_kernel`` this module was written against.
_KERNEL_ARGS = ("f", "h", "fjac", "hjac", "Q3", "R3", "x0", "P0", "y", "u", "store", "mean", "cov", "pmean", "pcov",
                "innov", "icov", "ll_steps", "Fj", "Hj", "state")
#: Helpers of ``_ekf`` reused here (input checks, output arrays and status errors shared with the engine's EKF).
_EKF_HELPERS = ("_prepare", "_check_functions", "ekf_kernel_outputs", "ekf_kernel_result")


@functools.cache
def _engine_compatible() -> bool:
    """True if the engine's EKF loop and helpers still have the interface this module calls.

    Guards against an engine refactor: if they changed, :func:`extended_kalman_filter_cached` runs
    :func:`extended_kalman_filter` (same results, compiled per process) instead of failing, and the
    cache-hit test of ``tests/statespace/test_ekf_cached.py`` fails to flag it.
    """
    kernel = getattr(_ekf_kernels, "ekf_kernel", None)
    py_func = getattr(kernel, "py_func", None)
    if py_func is None or tuple(inspect.signature(py_func).parameters) != _KERNEL_ARGS:
        return False
    return all(callable(getattr(_ekf, name, None)) for name in _EKF_HELPERS)


@functools.cache
def cached_kernel():
    """The engine's EKF loop as a ``cache=True`` dispatcher (compiled only for function-typed arguments)."""
    return njit(cache=True)(_ekf_kernels.ekf_kernel.py_func)


def _function_type(fn, ftype):
    """``ftype`` if the jitted ``fn`` compiles for it with the exact return type, ``types.none`` for None, else None."""
    if fn is None:
        return types.none
    if not is_jitted(fn):
        return None
    args = ftype.signature.args
    try:
        fn.compile(args)
    except (NumbaError, TypeError, ValueError):
        return None
    cres = fn.overloads.get(args)
    if cres is None or cres.signature.return_type != ftype.signature.return_type:
        return None
    return ftype


def _model_types(model):
    """Function types of (f, h, f_jac, h_jac), or None when the model cannot use the cached loop."""
    kinds = ((model.transition_fn, FUNCTION_TYPE), (model.observation_fn, FUNCTION_TYPE),
             (model.transition_jacobian, JACOBIAN_TYPE), (model.observation_jacobian, JACOBIAN_TYPE))
    out = []
    for fn, ftype in kinds:
        if fn is None and ftype is FUNCTION_TYPE:
            return None
        t = _function_type(fn, ftype)
        if t is None:
            return None
        out.append(t)
    return tuple(out)


def _run_cached(model, fn_types, Q3, R3, y, u, store):
    """One series through the disk-cached loop; outputs and status handling are the engine EKF's own."""
    T, m = y.shape
    outputs = _ekf.ekf_kernel_outputs(T, model.n_states, m, store)
    data = (Q3, R3, model.initial_mean, model.initial_cov, y, u, store) + tuple(outputs)
    entry = cached_kernel().compile(fn_types + tuple(typeof(a) for a in data))
    n_obs = entry(model.transition_fn, model.observation_fn, model.transition_jacobian, model.observation_jacobian,
                  *data)
    return _ekf.ekf_kernel_result(outputs, n_obs, store)


def extended_kalman_filter_cached(model: NonlinearStateSpaceModel, y, *, u=None,
                                  store_covariances: bool = True) -> FilterResult:
    """:func:`extended_kalman_filter` with its compiled loop cached on disk (compiled once per machine).

    Same parameters, result, errors and numbers as :func:`extended_kalman_filter` (Joseph-form EKF,
    NaN = missing, Jacobians stored). The difference is the compile cost: the loop is typed on the
    signature of the model functions, not on their identity, so a new process loads it from numba's
    cache instead of compiling it (measured 0.02 s against 5-20 s, see the module notes). Use it in
    command-line tools and scripts that run one filter per process.

    Parameters
    ----------
    model : NonlinearStateSpaceModel
        numba-jitted ``f(x, u, k) -> (n,)``, ``h(x, u, k) -> (m,)`` returning C-contiguous float64
        arrays (Jacobians ``(n, n)``, ``(m, n)`` likewise, or None for finite differences). Models
        that do not fit (Python functions, other return types) run :func:`extended_kalman_filter`.
    y : (T,), (T, m) or (B, T, m) array_like
        Observations, NaN = missing.
    u : (T, p) or (B, T, p) array_like, optional
        Known inputs; row ``u[k]`` is passed to f and h.
    store_covariances : bool, default True
        As in :func:`extended_kalman_filter`.

    Returns
    -------
    FilterResult
        ``method = "ekf"``, with ``transition_jacobians`` and ``observation_jacobians``.
    """
    usable = isinstance(model, NonlinearStateSpaceModel) and model.is_compiled and _engine_compatible()
    fn_types = _model_types(model) if usable else None
    if fn_types is None:
        return extended_kalman_filter(model, y, u=u, store_covariances=store_covariances)
    Y, batched, Q3, R3, U = _ekf._prepare(model, y, u)
    if not U.flags.writeable:
        U = U.copy()
    _ekf._check_functions(model, U[0, 0] if U.shape[1] else np.zeros(0))
    outs = [_run_cached(model, fn_types, Q3, R3, Y[b], U[b], store_covariances) for b in range(Y.shape[0])]

    def stack(i):
        if not batched:
            return outs[0][i]
        return None if outs[0][i] is None else np.stack([o[i] for o in outs])

    ll_steps = stack(6)
    return FilterResult(
        mean=stack(0), cov=stack(1), pred_mean=stack(2), pred_cov=stack(3), innovation=stack(4),
        innovation_cov=stack(5), log_likelihood=ll_steps.sum(axis=-1) if batched else float(ll_steps.sum()),
        log_likelihood_steps=ll_steps, n_observed=np.array([o[7] for o in outs]) if batched else outs[0][7],
        method="ekf", transition_jacobians=stack(8), observation_jacobians=stack(9))
