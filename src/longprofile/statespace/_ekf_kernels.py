"""Compiled extended-Kalman-filter loop for numba-jitted model functions (private).

The model enters as numba functions passed as arguments, in one of two conventions:

* separate functions ``f(x, u, k) -> (n,)``, ``h(x, u, k) -> (m,)`` and optional Jacobians
  (``None``: central finite differences); each call returns a new array;
* fused in-place steps ``fstep(x, u, k, x_next, F)`` and ``hstep(x, u, k, y_hat, H)`` that write the
  function and its Jacobian into the loop's preallocated arrays (no allocation per step).

With model parameters (the loop's ``params`` argument an array instead of None) every call gets them after
``k``: ``f(x, u, k, params)``, ``fstep(x, u, k, params, x_next, F)``.

The arguments of the unused convention are ``None`` and numba prunes their branches at compile
time, so there is one loop for both. The loop is compiled either for the functions' identity
(numba dispatchers: calls inlined, compiled once per process) or for their signature
(first-class function types: calls through pointers, cached on disk; see :mod:`._ekf`).

Status codes returned by :func:`ekf_kernel` (the wrapper turns them into
exceptions): 0 ok, 1 innovation covariance not positive definite, 2 non-finite
transition output or Jacobian, 3 non-finite observation output or Jacobian,
4 non-finite predicted covariance.
"""

from __future__ import annotations

import numpy as np
from numba import types
from numba.extending import overload

from .._jit import njit
from ._linalg_kernels import (
    FD_REL_STEP,
    all_finite2,
    call_model,
    cholesky_lower,
    copy1,
    copy2,
    fd_jacobian,
    innovation_loglik,
    joseph_update,
    sandwich_sym,
    solve_rows,
    update_scratch,
)
from ._status import COVARIANCE_NOT_FINITE, NOT_PD, OBSERVATION_NOT_FINITE, OK, TRANSITION_NOT_FINITE

__all__ = ["ekf_kernel", "model_eval", "fd_jacobian", "FD_REL_STEP"]


def model_eval(fn, jac, step, params, x, u, k, xw, out, J):
    """Value of a model function at (x, u, k), its Jacobian written into J (compiled code only).

    ``step`` given (fused convention): ``step(x, u, k, out, J)`` and ``out`` is returned; otherwise
    ``fn(x, u, k)`` is returned and J is ``jac(x, u, k)`` or central finite differences (``jac`` None,
    ``xw`` scratch). With model parameters (``params`` an array, not None) every call gets them after
    ``k``: ``fn(x, u, k, params)``, ``step(x, u, k, params, out, J)``. The conventions are chosen when numba
    types the call (see the overload below), so the loop has no run-time branch and the unused functions
    may be None.
    """
    raise NotImplementedError("model_eval runs inside numba-compiled loops only")


@overload(model_eval, inline="always")
def _model_eval_overload(fn, jac, step, params, x, u, k, xw, out, J):
    if not isinstance(step, types.NoneType):
        if isinstance(params, types.NoneType):
            def fused(fn, jac, step, params, x, u, k, xw, out, J):
                step(x, u, k, out, J)
                return out
            return fused

        def fused_params(fn, jac, step, params, x, u, k, xw, out, J):
            step(x, u, k, params, out, J)
            return out
        return fused_params
    if isinstance(jac, types.NoneType):
        def finite_differences(fn, jac, step, params, x, u, k, xw, out, J):
            fd_jacobian(fn, params, x, u, k, xw, J)
            return call_model(fn, params, x, u, k)
        return finite_differences

    def analytic(fn, jac, step, params, x, u, k, xw, out, J):
        copy2(call_model(jac, params, x, u, k), J)
        return call_model(fn, params, x, u, k)
    return analytic


@njit(cache=True)
def _update(x, P, Jh, yhat, yk, R, PHt, S, L, K, A, AP, KR, e, w, dinv, Ho, Ro, obs, innov_k):
    """Joseph-form measurement update on the observed components of yk (NaN = missing), in place.

    The observed rows of H, the observed block of S and of R are gathered first, then the
    engine's shared Cholesky / triangular-solve / Joseph helpers run on that leading block.
    Returns (status, number observed, log-likelihood contribution); status a :class:`._status.KernelStatus`.
    """
    n = x.shape[0]
    m = yk.shape[0]
    mo = 0
    for a in range(m):
        innov_k[a] = np.nan
        if not np.isnan(yk[a]):
            obs[mo] = a
            mo += 1
    if mo == 0:
        return OK, 0, 0.0
    for a in range(mo):
        ya = yk[obs[a]] - yhat[obs[a]]
        if not np.isfinite(ya):
            return OBSERVATION_NOT_FINITE, 0, 0.0
        e[a] = ya
        for b in range(mo):
            L[a, b] = S[obs[a], obs[b]]
            Ro[a, b] = R[obs[a], obs[b]]
        for j in range(n):
            Ho[a, j] = Jh[obs[a], j]
        for i in range(n):
            K[i, a] = PHt[i, obs[a]]
    if not cholesky_lower(L, mo, 0.0):
        return NOT_PD, 0, 0.0
    ll = innovation_loglik(L, dinv, e, mo, mo, w)
    solve_rows(L, dinv, mo, K, n, w)  # K = P H_o' S_o^-1
    for i in range(n):
        s = x[i]
        for a in range(mo):
            s += K[i, a] * e[a]
        x[i] = s
    joseph_update(P, K, Ho, Ro, n, mo, A, AP, KR)
    for a in range(mo):
        innov_k[obs[a]] = e[a]
    return OK, mo, ll


@njit
def ekf_kernel(f, h, fjac, hjac, fstep, hstep, params, Q3, R3, x0, P0, y, u, store,
               mean, cov, pmean, pcov, innov, icov, ll_steps, Fj, Hj, state, store_var, var):
    """EKF over one series. ``store`` False: cov/pcov/icov/Fj/Hj are dummies and not written; ``store_var``:
    the diagonal of each filtered covariance is written to ``var[k, :n]`` and that of the innovation covariance to
    ``var[k, n:]`` (``var`` is (T, n + m); a dummy otherwise).

    ``fstep``/``hstep`` None: the model is ``f``, ``h`` and the Jacobians (None = finite differences);
    otherwise the fused steps are called and ``f``, ``h``, ``fjac``, ``hjac`` are None. The Jacobian
    arrays the steps write into start at zero and keep their content between calls. ``params`` (None or a
    1-D float64 array) is passed unchanged to every model call (:func:`model_eval`).
    ``state`` (2,) int64 receives (status, step). Returns the number of observed components.
    Only this loop is compiled per set of model functions; the linear algebra is in cached helpers.
    """
    T, m = y.shape
    n = x0.shape[0]
    x = np.empty(n)
    P = np.empty((n, n))
    copy1(x0, x)
    copy2(P0, P)
    xw = np.empty(n)
    x_next = np.empty(n)
    y_hat = np.empty(m)
    Jf = np.zeros((n, n))
    Jh = np.zeros((m, n))
    S, L, PHt, K, KR, e, w, dinv = update_scratch(n, m)
    A = np.empty((n, n))
    AP = np.empty((n, n))
    Ho = np.empty((m, n))
    Ro = np.empty((m, m))
    obs = np.empty(m, np.int64)
    n_obs = 0
    state[0] = OK
    state[1] = 0
    for k in range(T):
        uk = u[k]
        copy1(x, pmean[k])
        if store:
            copy2(P, pcov[k])
        yhat = model_eval(h, hjac, hstep, params, x, uk, k, xw, y_hat, Jh)
        if not all_finite2(Jh, m, n):
            state[0] = OBSERVATION_NOT_FINITE
            state[1] = k
            return n_obs
        sandwich_sym(Jh, P, R3[k if R3.shape[0] > 1 else 0], PHt, S)  # PHt = P H', S = H P H' + R
        if store:
            copy2(Jh, Hj[k])
            copy2(S, icov[k])
        if store_var:
            for a in range(m):
                var[k, n + a] = S[a, a]
        status, mo, ll = _update(x, P, Jh, yhat, y[k], R3[k if R3.shape[0] > 1 else 0], PHt, S, L, K, A, AP,
                                 KR, e, w, dinv, Ho, Ro, obs, innov[k])
        if status != OK:
            state[0] = status
            state[1] = k
            return n_obs
        ll_steps[k] = ll
        n_obs += mo
        copy1(x, mean[k])
        if store:
            copy2(P, cov[k])
        if store_var:
            for i in range(n):
                var[k, i] = P[i, i]
        if k < T - 1:
            xn = model_eval(f, fjac, fstep, params, x, uk, k, xw, x_next, Jf)
            if not all_finite2(Jf, n, n):
                state[0] = TRANSITION_NOT_FINITE
                state[1] = k
                return n_obs
            if store:
                copy2(Jf, Fj[k])
            for i in range(n):
                if not np.isfinite(xn[i]):
                    state[0] = TRANSITION_NOT_FINITE
                    state[1] = k
                    return n_obs
                x[i] = xn[i]
            sandwich_sym(Jf, P, Q3[k if Q3.shape[0] > 1 else 0], AP, P)  # P <- F P F' + Q
            for i in range(n):
                if not np.isfinite(P[i, i]):
                    state[0] = COVARIANCE_NOT_FINITE
                    state[1] = k
                    return n_obs
    return n_obs
