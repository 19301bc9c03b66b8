"""Compiled extended-Kalman-filter loop for numba-jitted model functions (private).

The user's ``f``, ``h`` (and optional Jacobians) are numba dispatchers passed
as arguments; numba specialises the loop for them (calls are direct, usually
inlined by LLVM). A Jacobian argument that is ``None`` is replaced by central
finite differences (branch pruned at compile time). The kernel allocates only
what the user functions return; all scratch arrays are allocated once.

Because numba keys such specialisations on the identity of the function
arguments, they are compiled once per process and model functions
(``cache=True`` cannot persist them: it would only grow the cache directory).

Status codes returned by :func:`ekf_kernel` (the wrapper turns them into
exceptions): 0 ok, 1 innovation covariance not positive definite, 2 non-finite
transition output or Jacobian, 3 non-finite observation output or Jacobian,
4 non-finite predicted covariance.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._linalg_kernels import (
    FD_REL_STEP,
    all_finite2,
    cholesky_lower,
    copy1,
    copy2,
    fd_jacobian,
    forward_sub,
    inverse_diagonal,
    joseph_update,
    sandwich_sym,
    solve_rows,
)

__all__ = ["ekf_kernel", "fd_jacobian", "FD_REL_STEP"]

_LOG2PI = float(np.log(2.0 * np.pi))


@njit(cache=True)
def _update(x, P, Jh, yhat, yk, R, PHt, S, L, K, A, AP, KR, e, w, dinv, Ho, Ro, obs, innov_k):
    """Joseph-form measurement update on the observed components of yk (NaN = missing), in place.

    The observed rows of H, the observed block of S and of R are gathered first, then the
    engine's shared Cholesky / triangular-solve / Joseph helpers run on that leading block.
    Returns (status, number observed, log-likelihood contribution); status 1 = S not PD, 3 = non-finite.
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
        return 0, 0, 0.0
    for a in range(mo):
        ya = yk[obs[a]] - yhat[obs[a]]
        if not np.isfinite(ya):
            return 3, 0, 0.0
        e[a] = ya
        for b in range(mo):
            L[a, b] = S[obs[a], obs[b]]
            Ro[a, b] = R[obs[a], obs[b]]
        for j in range(n):
            Ho[a, j] = Jh[obs[a], j]
        for i in range(n):
            K[i, a] = PHt[i, obs[a]]
    if not cholesky_lower(L, mo, 0.0):
        return 1, 0, 0.0
    inverse_diagonal(L, mo, dinv)
    logdet = 0.0
    for a in range(mo):
        w[a] = e[a]
        logdet += 2.0 * np.log(L[a, a])
    forward_sub(L, dinv, mo, w)
    quad = 0.0
    for a in range(mo):
        quad += w[a] * w[a]
    ll = -0.5 * (mo * _LOG2PI + logdet + quad)
    solve_rows(L, dinv, mo, K, n, w)  # K = P H_o' S_o^-1
    for i in range(n):
        s = x[i]
        for a in range(mo):
            s += K[i, a] * e[a]
        x[i] = s
    joseph_update(P, K, Ho, Ro, n, mo, A, AP, KR)
    for a in range(mo):
        innov_k[obs[a]] = e[a]
    return 0, mo, ll


@njit
def ekf_kernel(f, h, fjac, hjac, Q3, R3, x0, P0, y, u, store,
               mean, cov, pmean, pcov, innov, icov, ll_steps, Fj, Hj, state):
    """EKF over one series. ``store`` False: cov/pcov/icov/Fj/Hj are dummies and not written.

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
    Jf = np.empty((n, n))
    Jh = np.empty((m, n))
    S = np.empty((m, m))
    L = np.empty((m, m))
    PHt = np.empty((n, m))
    K = np.empty((n, m))
    A = np.empty((n, n))
    AP = np.empty((n, n))
    KR = np.empty((n, m))
    e = np.empty(m)
    w = np.empty(m)
    dinv = np.empty(m)
    Ho = np.empty((m, n))
    Ro = np.empty((m, m))
    obs = np.empty(m, np.int64)
    n_obs = 0
    state[0] = 0
    state[1] = 0
    for k in range(T):
        uk = u[k]
        copy1(x, pmean[k])
        if store:
            copy2(P, pcov[k])
        yhat = h(x, uk, k)
        if hjac is None:
            fd_jacobian(h, x, uk, k, xw, Jh)
        else:
            copy2(hjac(x, uk, k), Jh)
        if not all_finite2(Jh, m, n):
            state[0] = 3
            state[1] = k
            return n_obs
        sandwich_sym(Jh, P, R3[k if R3.shape[0] > 1 else 0], PHt, S)  # PHt = P H', S = H P H' + R
        if store:
            copy2(Jh, Hj[k])
            copy2(S, icov[k])
        status, mo, ll = _update(x, P, Jh, yhat, y[k], R3[k if R3.shape[0] > 1 else 0], PHt, S, L, K, A, AP,
                                 KR, e, w, dinv, Ho, Ro, obs, innov[k])
        if status != 0:
            state[0] = status
            state[1] = k
            return n_obs
        ll_steps[k] = ll
        n_obs += mo
        copy1(x, mean[k])
        if store:
            copy2(P, cov[k])
        if k < T - 1:
            if fjac is None:
                fd_jacobian(f, x, uk, k, xw, Jf)
            else:
                copy2(fjac(x, uk, k), Jf)
            if not all_finite2(Jf, n, n):
                state[0] = 2
                state[1] = k
                return n_obs
            if store:
                copy2(Jf, Fj[k])
            xn = f(x, uk, k)
            for i in range(n):
                if not np.isfinite(xn[i]):
                    state[0] = 2
                    state[1] = k
                    return n_obs
                x[i] = xn[i]
            sandwich_sym(Jf, P, Q3[k if Q3.shape[0] > 1 else 0], AP, P)  # P <- F P F' + Q
            for i in range(n):
                if not np.isfinite(P[i, i]):
                    state[0] = 4
                    state[1] = k
                    return n_obs
    return n_obs
