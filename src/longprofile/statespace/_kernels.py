"""Compiled (numba) loops of the linear state-space engine.

The kernels trust their inputs: the public wrappers in :mod:`._kalman` and
:mod:`._sampling` validate once, convert to C-contiguous float64 and call them.
No kernel allocates per step: work arrays are allocated once per call and the
small matrix products are written out as loops (n, m are small).

Conventions shared by all kernels
---------------------------------
* Model terms always carry a leading "time" axis K: K = 1 for a constant term
  (index 0 is used at every step), K = T-1 (transition side) or K = T
  (observation side) for a time-varying one. ``_at(K, k)`` picks the index.
* Absent inputs are passed as arrays with p = 0 columns, absent offsets as
  zeros of shape (1, n) / (1, m), so one kernel serves every model.
* Known inputs ``u`` are (1, T, p) when shared by the whole batch, else (NB, T, p).
* Output covariance arrays are (NB, T, ., .) when stored and (1, 1, ., .)
  scratch otherwise (``store`` flag; the scratch then holds the last step's
  filtered and predicted covariances of the last series): one kernel gives the full and the
  means-only filter.
* Errors are reported through ``status`` = [batch, step, code] (a :class:`._status.KernelStatus`);
  the wrapper raises the matching :mod:`longprofile.errors` exception (:func:`._status.raise_status`).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .._jit import njit
from ._linalg_kernels import FASTMATH as _FASTMATH
from ._linalg_kernels import (
    affine_map,
    cholesky_lower,
    forward_sub,
    inverse_diagonal,
    matmul_into,
    solve_rows,
    update_scratch,
)
from ._linalg_kernels import at as _at
from ._status import NOT_PD, OK

__all__ = [
    "kalman_filter_kernel",
    "rts_smoother_kernel",
    "backward_sample_kernel",
    "backward_conditional_cov_kernel",
    "simulate_kernel",
]

_LOG2PI = math.log(2.0 * math.pi)


# Sizes up to these are compiled with n and m as compile-time constants (fully unrolled small
# matrix products, about twice as fast); larger models use the generic (run-time size) kernel.
MAX_FIXED_STATES = 8
MAX_FIXED_OBS = 4


def _fixed(n: int, limit: int) -> int:
    return n if 0 < n <= limit else 0


@functools.lru_cache(maxsize=None)
def _make_filter_kernel(n_fixed: int, m_fixed: int):
    """Build (or load from numba's cache) the filter kernel for constant sizes (0 = run-time size)."""
    N_FIXED = n_fixed
    M_FIXED = m_fixed

    @njit(cache=True, fastmath=_FASTMATH)
    def kernel(F, H, Q, R, Bm, Dm, c, d, x0, P0, y, u, store,
               mean, cov, pmean, pcov, innov, icov, ll, nobs, status):
        NB = y.shape[0]
        T = y.shape[1]
        n = N_FIXED if N_FIXED > 0 else x0.shape[0]
        m = M_FIXED if M_FIXED > 0 else y.shape[2]
        x = np.empty(n)
        xn = np.empty(n)
        P = np.empty((n, n))
        AP = np.empty((n, n))
        FP = np.empty((n, n))
        APHt = np.empty((n, m))
        S, L, PHt, Kg, KR, e, w, dinv = update_scratch(n, m)
        yhat = np.empty(m)
        obs = np.empty(m, np.bool_)
        status[0] = -1
        status[1] = -1
        status[2] = OK
        for b in range(NB):
            ub = b if u.shape[0] > 1 else 0
            qb = b if Q.shape[0] > 1 else 0  # per-series covariances (leading series axis 1 or NB)
            rb = b if R.shape[0] > 1 else 0
            pb = b if P0.shape[0] > 1 else 0
            for i in range(n):
                x[i] = x0[i]
                for j in range(n):
                    P[i, j] = P0[pb, i, j]
            count = 0
            for t in range(T):
                sb = b if store else 0
                st = t if store else 0
                for i in range(n):
                    pmean[b, t, i] = x[i]
                if store or t == T - 1:  # means-only: the last step's covariances are kept in the scratch
                    for i in range(n):
                        for j in range(n):
                            pcov[sb, st, i, j] = P[i, j]
                kh = _at(H.shape[0], t)
                kr = _at(R.shape[1], t)
                kd = _at(Dm.shape[0], t)
                kdo = _at(d.shape[0], t)
                affine_map(H, kh, x, m, n, Dm, kd, u, ub, t, d, kdo, yhat)  # H x + D u + d
                # P H'
                for i in range(n):
                    for j in range(m):
                        s = 0.0
                        for l in range(n):
                            s += P[i, l] * H[kh, j, l]
                        PHt[i, j] = s
                # S = H P H' + R, symmetric, over all m components
                for i in range(m):
                    for j in range(i + 1):
                        s = 0.5 * (R[rb, kr, i, j] + R[rb, kr, j, i])
                        for l in range(n):
                            s += H[kh, i, l] * PHt[l, j]
                        S[i, j] = s
                        S[j, i] = s
                if store or icov.shape[1] == T:  # means-only runs may still keep the (small) S_k
                    for i in range(m):
                        for j in range(m):
                            icov[b if icov.shape[0] > 1 else 0, t, i, j] = S[i, j]
                mo = 0
                for i in range(m):
                    v = y[b, t, i]
                    obs[i] = not math.isnan(v)
                    if obs[i]:
                        mo += 1
                        e[i] = v - yhat[i]
                        innov[b, t, i] = e[i]
                    else:
                        e[i] = 0.0
                        innov[b, t, i] = np.nan
                llt = 0.0
                if mo > 0:
                    # Missing components: their rows/columns of S become the identity and their
                    # innovation 0, so they get a zero gain column and add nothing to the likelihood:
                    # exactly the update with the observed rows of H and R only.
                    for i in range(m):
                        for j in range(i + 1):
                            if obs[i] and obs[j]:
                                L[i, j] = S[i, j]
                            else:
                                L[i, j] = 1.0 if i == j else 0.0
                    if not cholesky_lower(L, m, 0.0):
                        status[0] = b
                        status[1] = t
                        status[2] = NOT_PD
                        return
                    # _linalg_kernels.innovation_loglik written out: called here, it changed the rounding of
                    # this fastmath kernel (1 ulp in some steps' likelihood with n, m fixed, measured)
                    inverse_diagonal(L, m, dinv)
                    logdet = 0.0
                    for i in range(m):
                        w[i] = e[i]
                        logdet += 2.0 * math.log(L[i, i])
                    forward_sub(L, dinv, m, w)
                    quad = 0.0
                    for i in range(m):
                        quad += w[i] * w[i]
                    llt = -0.5 * (mo * _LOG2PI + logdet + quad)
                    count += mo
                    # gain K = P H_o' S_o^{-1}, row by row (zero columns on missing components)
                    for i in range(n):
                        for j in range(m):
                            Kg[i, j] = PHt[i, j] if obs[j] else 0.0
                    solve_rows(L, dinv, m, Kg, n, w)
                    for i in range(n):
                        s = x[i]
                        for j in range(m):
                            s += Kg[i, j] * e[j]
                        x[i] = s
                    # Joseph form P = A P A' + K R K', A = I - K H, evaluated factor by factor:
                    # AP = P - K (P H')',  (AP) A' = AP - (AP H') K'
                    for i in range(n):
                        for j in range(n):
                            s = P[i, j]
                            for a in range(m):
                                s -= Kg[i, a] * PHt[j, a]
                            AP[i, j] = s
                    for i in range(n):
                        for a in range(m):
                            s = 0.0
                            for l in range(n):
                                s += AP[i, l] * H[kh, a, l]
                            APHt[i, a] = s
                    for i in range(n):
                        for a in range(m):
                            s = 0.0
                            for a2 in range(m):
                                s += Kg[i, a2] * R[rb, kr, a2, a]
                            KR[i, a] = s
                    for i in range(n):
                        for j in range(i + 1):
                            s = 0.5 * (AP[i, j] + AP[j, i])
                            for a in range(m):
                                s += (0.5 * (KR[i, a] * Kg[j, a] + KR[j, a] * Kg[i, a])
                                      - 0.5 * (APHt[i, a] * Kg[j, a] + APHt[j, a] * Kg[i, a]))
                            P[i, j] = s
                            P[j, i] = s
                ll[b, t] = llt
                for i in range(n):
                    mean[b, t, i] = x[i]
                if store or t == T - 1:
                    for i in range(n):
                        for j in range(n):
                            cov[sb, st, i, j] = P[i, j]
                if t < T - 1:
                    kf = _at(F.shape[0], t)
                    kq = _at(Q.shape[1], t)
                    kb = _at(Bm.shape[0], t)
                    kc = _at(c.shape[0], t)
                    affine_map(F, kf, x, n, n, Bm, kb, u, ub, t, c, kc, xn)  # F x + B u + c
                    for i in range(n):
                        x[i] = xn[i]
                    for i in range(n):
                        for j in range(n):
                            s = 0.0
                            for l in range(n):
                                s += F[kf, i, l] * P[l, j]
                            FP[i, j] = s
                    for i in range(n):
                        for j in range(i + 1):
                            s = 0.5 * (Q[qb, kq, i, j] + Q[qb, kq, j, i])
                            for l in range(n):
                                s += FP[i, l] * F[kf, j, l]
                            P[i, j] = s
                            P[j, i] = s
            nobs[b] = count

    return kernel


def kalman_filter_kernel(F, H, Q, R, Bm, Dm, c, d, x0, P0, y, u, store,
                         mean, cov, pmean, pcov, innov, icov, ll, nobs, status):
    """Joseph-form Kalman filter over a batch, NaN components = missing.

    Shapes: F (KF,n,n), H (KH,m,n), Q (SQ,KQ,n,n), R (SR,KR,m,m), Bm (KB,n,p),
    Dm (KD,m,p), c (Kc,n), d (Kd,m), x0 (n,), P0 (SP,n,n), y (NB,T,m),
    u (1 or NB, T, p). Outputs: mean, pmean (NB,T,n); innov (NB,T,m);
    ll (NB,T); nobs (NB,) int64; cov, pcov (NB,T,n,n) and icov (NB,T,m,m)
    when ``store`` else (1,1,.,.) scratch; status (3,) int64. The series axes SQ, SR, SP of the noise and
    initial covariances are 1 (shared by the batch) or NB (one per series).
    """
    kernel = _make_filter_kernel(_fixed(x0.shape[0], MAX_FIXED_STATES), _fixed(y.shape[2], MAX_FIXED_OBS))
    kernel(F, H, Q, R, Bm, Dm, c, d, x0, P0, y, u, store, mean, cov, pmean, pcov, innov, icov, ll, nobs, status)


@functools.lru_cache(maxsize=None)
def _make_smoother_kernel(n_fixed: int):
    """Build (or load from numba's cache) the RTS kernel for a constant n (0 = run-time size)."""
    N_FIXED = n_fixed

    @njit(cache=True, fastmath=_FASTMATH)
    def kernel(F, mean, cov, pmean, pcov, store_gains, sm, sc, cc, gains):
        NB = mean.shape[0]
        T = mean.shape[1]
        n = N_FIXED if N_FIXED > 0 else mean.shape[2]
        Lp = np.empty((n, n))
        FP = np.empty((n, n))
        G = np.empty((n, n))
        GD = np.empty((n, n))
        r = np.empty(n)
        col = np.empty(n)
        dinv = np.empty(n)
        for b in range(NB):
            for i in range(n):
                sm[b, T - 1, i] = mean[b, T - 1, i]
                for j in range(n):
                    sc[b, T - 1, i, j] = cov[b, T - 1, i, j]
            for t in range(T - 2, -1, -1):
                kf = _at(F.shape[0], t)
                # FP = F P_t|t
                for i in range(n):
                    for j in range(n):
                        s = 0.0
                        for l in range(n):
                            s += F[kf, i, l] * cov[b, t, l, j]
                        FP[i, j] = s
                for i in range(n):
                    for j in range(i + 1):
                        Lp[i, j] = pcov[b, t + 1, i, j]
                if cholesky_lower(Lp, n, 1e-13):
                    # G = (F P)' Pp^{-1}, row by row
                    inverse_diagonal(Lp, n, dinv)
                    for j in range(n):
                        for i in range(n):
                            G[j, i] = FP[i, j]
                    solve_rows(Lp, dinv, n, G, n, col)
                else:
                    _pinv_gain(pcov[b, t + 1], FP, G, n)
                if store_gains:
                    for i in range(n):
                        for j in range(n):
                            gains[b, t, i, j] = G[i, j]
                for i in range(n):
                    r[i] = sm[b, t + 1, i] - pmean[b, t + 1, i]
                for i in range(n):
                    s = mean[b, t, i]
                    for l in range(n):
                        s += G[i, l] * r[l]
                    sm[b, t, i] = s
                # P_t|T = P_t|t + G (P_t+1|T - P_t+1|t) G'
                for i in range(n):
                    for j in range(n):
                        s = 0.0
                        for l in range(n):
                            s += G[i, l] * (sc[b, t + 1, l, j] - pcov[b, t + 1, l, j])
                        GD[i, j] = s
                for i in range(n):
                    for j in range(i + 1):
                        s = 0.5 * (cov[b, t, i, j] + cov[b, t, j, i])
                        for l in range(n):
                            s += 0.5 * (GD[i, l] * G[j, l] + GD[j, l] * G[i, l])
                        sc[b, t, i, j] = s
                        sc[b, t, j, i] = s
                # Cov(x_t, x_t+1 | y) = G P_t+1|T
                for i in range(n):
                    for j in range(n):
                        s = 0.0
                        for l in range(n):
                            s += G[i, l] * sc[b, t + 1, l, j]
                        cc[b, t, i, j] = s

    return kernel


@njit(cache=True)
def _pinv_gain(Pp, FP, G, n):
    """G = (F P)' Pp^+ with an eigen-decomposition pseudo-inverse (singular predicted covariance)."""
    A = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            A[i, j] = 0.5 * (Pp[i, j] + Pp[j, i])
    ev, V = np.linalg.eigh(A)
    emax = 0.0
    for i in range(n):
        emax = max(emax, abs(ev[i]))
    cut = 1e-12 * emax
    for i in range(n):
        for j in range(n):
            s = 0.0
            for l in range(n):
                if ev[l] > cut:
                    s += V[i, l] * V[j, l] / ev[l]
            A[i, j] = s
    matmul_into(FP.T, A, n, n, n, G)


def rts_smoother_kernel(F, mean, cov, pmean, pcov, store_gains, sm, sc, cc, gains):
    """Rauch-Tung-Striebel smoother over a batch.

    Shapes: F (KF,n,n); mean, pmean (NB,T,n); cov, pcov (NB,T,n,n). Outputs:
    sm (NB,T,n), sc (NB,T,n,n), cc (NB,max(T-1,0),n,n) with
    ``cc[b,t] = Cov(x_t, x_{t+1} | y)``; gains (NB,T-1,n,n) smoother gains
    G_t = P_t|t F_t' P_t+1|t^{-1} when ``store_gains`` else (1,1,n,n) scratch.
    A predicted covariance that is not numerically positive definite is
    inverted by an eigen-decomposition pseudo-inverse (the only allocating path).
    """
    kernel = _make_smoother_kernel(_fixed(mean.shape[2], MAX_FIXED_STATES))
    kernel(F, mean, cov, pmean, pcov, store_gains, sm, sc, cc, gains)


@njit(cache=True, fastmath=_FASTMATH)
def backward_conditional_cov_kernel(cov, pcov, gains, out):
    """out[t] = P_t|t - G_t P_t+1|t G_t' (symmetrised) for t < T-1 and out[T-1] = P_T-1|T-1.

    cov, pcov (T,n,n); gains (T-1,n,n); out (T,n,n): the covariance of x_t | x_t+1, y_0..t in FFBS.
    """
    T, n = cov.shape[0], cov.shape[1]
    GP = np.empty((n, n))
    for t in range(T - 1):
        for i in range(n):
            for j in range(n):
                s = 0.0
                for l in range(n):
                    s += gains[t, i, l] * pcov[t + 1, l, j]
                GP[i, j] = s
        for i in range(n):
            for j in range(i + 1):
                s = 0.0
                for l in range(n):
                    s += 0.5 * (GP[i, l] * gains[t, j, l] + GP[j, l] * gains[t, i, l])
                v = 0.5 * (cov[t, i, j] + cov[t, j, i]) - s
                out[t, i, j] = v
                out[t, j, i] = v
    for i in range(n):
        for j in range(n):
            out[T - 1, i, j] = 0.5 * (cov[T - 1, i, j] + cov[T - 1, j, i])


@njit(cache=True, fastmath=_FASTMATH)
def backward_sample_kernel(mean, pmean, gains, roots, z, out):
    """Backward pass of forward-filter backward-sample (Carter-Kohn).

    mean, pmean (T,n); gains (T-1,n,n); roots (T,n,n) with ``roots[t] roots[t]'``
    the covariance of x_t | x_{t+1}, y_0..t (t < T-1) and of x_{T-1} | y;
    z (S,T,n) standard normal draws; out (S,T,n).
    """
    S, T, n = z.shape
    r = np.empty(n)
    for s_ in range(S):
        for i in range(n):
            v = mean[T - 1, i]
            for l in range(n):
                v += roots[T - 1, i, l] * z[s_, T - 1, l]
            out[s_, T - 1, i] = v
        for t in range(T - 2, -1, -1):
            for i in range(n):
                r[i] = out[s_, t + 1, i] - pmean[t + 1, i]
            for i in range(n):
                v = mean[t, i]
                for l in range(n):
                    v += gains[t, i, l] * r[l] + roots[t, i, l] * z[s_, t, l]
                out[s_, t, i] = v


@njit(cache=True, fastmath=_FASTMATH)
def simulate_kernel(F, H, Bm, Dm, c, d, u, x0, w, v, x, y):
    """Draw a trajectory: x (T,n), y (T,m) from x0 (n,), process noise w (T-1,n),
    observation noise v (T,m), inputs u (1,T,p); model terms as in the filter kernel."""
    T, n = x.shape
    m = y.shape[1]
    for i in range(n):
        x[0, i] = x0[i]
    for t in range(T):
        kh = _at(H.shape[0], t)
        kd = _at(Dm.shape[0], t)
        kdo = _at(d.shape[0], t)
        affine_map(H, kh, x[t], m, n, Dm, kd, u, 0, t, d, kdo, y[t])
        for i in range(m):
            y[t, i] += v[t, i]
        if t < T - 1:
            kf = _at(F.shape[0], t)
            kb = _at(Bm.shape[0], t)
            kc = _at(c.shape[0], t)
            affine_map(F, kf, x[t], n, n, Bm, kb, u, 0, t, c, kc, x[t + 1])
            for i in range(n):
                x[t + 1, i] += w[t, i]
