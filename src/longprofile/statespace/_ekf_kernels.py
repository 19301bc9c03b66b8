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

__all__ = ["ekf_kernel", "fd_jacobian", "FD_REL_STEP"]

# Central differences: truncation O(h^2), round-off O(eps/h) -> h ~ eps^(1/3) relative to the state's scale.
FD_REL_STEP = float(np.finfo(float).eps ** (1.0 / 3.0))
_LOG2PI = float(np.log(2.0 * np.pi))


@njit
def fd_jacobian(fn, x, u, k, xw, J):
    """Central-difference Jacobian of fn(., u, k) at x into J (rows: outputs); xw is scratch of x's size."""
    n = x.shape[0]
    for j in range(n):
        xw[j] = x[j]
    for j in range(n):
        step = FD_REL_STEP * max(abs(x[j]), 1.0)
        hi = x[j] + step
        lo = x[j] - step
        xw[j] = hi
        a = fn(xw, u, k)
        xw[j] = lo
        b = fn(xw, u, k)
        xw[j] = x[j]
        inv = 1.0 / (hi - lo)
        for i in range(a.shape[0]):
            J[i, j] = (a[i] - b[i]) * inv


@njit(cache=True)
def _all_finite2(a, r, c):
    for i in range(r):
        for j in range(c):
            if not np.isfinite(a[i, j]):
                return False
    return True


@njit(cache=True)
def _copy1(src, dst):
    for i in range(dst.shape[0]):
        dst[i] = src[i]


@njit(cache=True)
def _copy2(src, dst):
    for i in range(dst.shape[0]):
        for j in range(dst.shape[1]):
            dst[i, j] = src[i, j]


@njit(cache=True)
def _innovation_cov(P, Jh, R, PHt, S):
    """PHt = P H', S = H P H' + (R + R')/2."""
    n = P.shape[0]
    m = Jh.shape[0]
    for i in range(n):
        for a in range(m):
            s = 0.0
            for j in range(n):
                s += P[i, j] * Jh[a, j]
            PHt[i, a] = s
    for a in range(m):
        for b in range(a, m):
            s = 0.5 * (R[a, b] + R[b, a])
            for i in range(n):
                s += Jh[a, i] * PHt[i, b]
            S[a, b] = s
            S[b, a] = s


@njit(cache=True)
def _update(x, P, Jh, yhat, yk, R, PHt, S, L, K, A, AP, KR, e, w, obs, innov_k):
    """Joseph-form measurement update on the observed components of yk (NaN = missing), in place.

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
    for a in range(mo):
        for b in range(a + 1):
            s = S[obs[a], obs[b]]
            for c in range(b):
                s -= L[a, c] * L[b, c]
            if a == b:
                if not s > 0.0:
                    return 1, 0, 0.0
                L[a, a] = np.sqrt(s)
            else:
                L[a, b] = s / L[b, b]
    quad = 0.0
    logdet = 0.0
    for a in range(mo):
        s = e[a]
        for c in range(a):
            s -= L[a, c] * w[c]
        w[a] = s / L[a, a]
        quad += w[a] * w[a]
        logdet += 2.0 * np.log(L[a, a])
    ll = -0.5 * (mo * _LOG2PI + logdet + quad)
    for i in range(n):
        for a in range(mo):
            s = PHt[i, obs[a]]
            for c in range(a):
                s -= L[a, c] * K[i, c]
            K[i, a] = s / L[a, a]
        for a in range(mo - 1, -1, -1):
            s = K[i, a]
            for c in range(a + 1, mo):
                s -= L[c, a] * K[i, c]
            K[i, a] = s / L[a, a]
    for i in range(n):
        s = x[i]
        for a in range(mo):
            s += K[i, a] * e[a]
        x[i] = s
    for i in range(n):
        for j in range(n):
            s = 1.0 if i == j else 0.0
            for a in range(mo):
                s -= K[i, a] * Jh[obs[a], j]
            A[i, j] = s
    for i in range(n):
        for j in range(n):
            s = 0.0
            for c in range(n):
                s += A[i, c] * P[c, j]
            AP[i, j] = s
    for i in range(n):
        for a in range(mo):
            s = 0.0
            for b in range(mo):
                s += K[i, b] * R[obs[b], obs[a]]
            KR[i, a] = s
    for i in range(n):
        for j in range(i, n):
            s = 0.0
            for c in range(n):
                s += AP[i, c] * A[j, c]
            t = 0.0
            for a in range(mo):
                t += KR[i, a] * K[j, a] + KR[j, a] * K[i, a]
            s += 0.5 * t
            P[i, j] = s
            P[j, i] = s
    for a in range(mo):
        innov_k[obs[a]] = e[a]
    return 0, mo, ll


@njit(cache=True)
def _predict_cov(P, Jf, Q, AP):
    """P <- F P F' + (Q + Q')/2, symmetric, in place."""
    n = P.shape[0]
    for i in range(n):
        for j in range(n):
            s = 0.0
            for c in range(n):
                s += Jf[i, c] * P[c, j]
            AP[i, j] = s
    for i in range(n):
        for j in range(i, n):
            s = 0.5 * (Q[i, j] + Q[j, i])
            for c in range(n):
                s += AP[i, c] * Jf[j, c]
            P[i, j] = s
            P[j, i] = s


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
    _copy1(x0, x)
    _copy2(P0, P)
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
    obs = np.empty(m, np.int64)
    n_obs = 0
    state[0] = 0
    state[1] = 0
    for k in range(T):
        uk = u[k]
        _copy1(x, pmean[k])
        if store:
            _copy2(P, pcov[k])
        yhat = h(x, uk, k)
        if hjac is None:
            fd_jacobian(h, x, uk, k, xw, Jh)
        else:
            _copy2(hjac(x, uk, k), Jh)
        if not _all_finite2(Jh, m, n):
            state[0] = 3
            state[1] = k
            return n_obs
        _innovation_cov(P, Jh, R3[k if R3.shape[0] > 1 else 0], PHt, S)
        if store:
            _copy2(Jh, Hj[k])
            _copy2(S, icov[k])
        status, mo, ll = _update(x, P, Jh, yhat, y[k], R3[k if R3.shape[0] > 1 else 0], PHt, S, L, K, A, AP,
                                 KR, e, w, obs, innov[k])
        if status != 0:
            state[0] = status
            state[1] = k
            return n_obs
        ll_steps[k] = ll
        n_obs += mo
        _copy1(x, mean[k])
        if store:
            _copy2(P, cov[k])
        if k < T - 1:
            if fjac is None:
                fd_jacobian(f, x, uk, k, xw, Jf)
            else:
                _copy2(fjac(x, uk, k), Jf)
            if not _all_finite2(Jf, n, n):
                state[0] = 2
                state[1] = k
                return n_obs
            if store:
                _copy2(Jf, Fj[k])
            xn = f(x, uk, k)
            for i in range(n):
                if not np.isfinite(xn[i]):
                    state[0] = 2
                    state[1] = k
                    return n_obs
                x[i] = xn[i]
            _predict_cov(P, Jf, Q3[k if Q3.shape[0] > 1 else 0], AP)
            for i in range(n):
                if not np.isfinite(P[i, i]):
                    state[0] = 4
                    state[1] = k
                    return n_obs
    return n_obs
