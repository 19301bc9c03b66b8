"""Compiled loops of the steady-state (constant-gain) Kalman filter and smoother (private).

Why numba and not scipy.signal: the steady-state filter is an LTI system, but
scipy has no multi-output state-space filter in C (``dlsim`` loops in Python)
and the transfer-function route needs one IIR filter per state (6 states x 3
biquads for the APL model, measured at ~120 M samples/s per 3-section
``sosfilt`` pass, i.e. < 20 M samples/s for all states), is numerically poor
for high orders and gives neither the predicted means nor the innovations.
The recursion below is the filter itself (the Kalman update with a frozen
gain, written in closed-loop form so that only one n x n product is carried
from step to step), allocation-free, one pass over the data.

For small models (n <= 8, m <= 4, p <= 4 known inputs) the sizes are passed to
numba as literals so that the inner loops are fully unrolled (measured ~1.4x
faster for n = 6, m = 1, and ~1.15x more for p = 0 than a run-time p = 0);
larger models use the same code with run-time sizes. Kernels trust
their inputs: the public wrappers in ``_steady.py`` validate everything.
"""

from __future__ import annotations

import numpy as np
from numba import literally

from .._jit import njit
from ._linalg_kernels import FASTMATH

__all__ = ["filter_kernel", "smooth_kernel", "MAX_LITERAL_STATES", "MAX_LITERAL_OBS", "MAX_LITERAL_INPUTS"]

MAX_LITERAL_STATES = 8
MAX_LITERAL_OBS = 4
MAX_LITERAL_INPUTS = 4


@njit(cache=True, fastmath=FASTMATH)
def _filter_impl(N, M, P, A, G, Bc, cc, K, H, D, d, Sinv, x0, y, u, const, mean, pmean, innov, ll_steps,
                 store_extra):
    """Constant-gain filter. Returns the sum of the quadratic forms e' S^-1 e.

    innov: e[k]  = y[k] - H xp[k] - D u[k] - d         (xp[0] = x0)
    filt:  xf[k] = xp[k] + K e[k]
    pred:  xp[k+1] = F xf[k] + B u[k] + c = A xp[k] + G y[k] + Bc u[k] + cc

    with the closed-loop matrices A = F (I - K H), G = F K, Bc = B - F K D, cc = c - F K d.
    Only the last line feeds back, so the loop-carried dependency is one n x n product
    (the innovation, filtered mean and likelihood are computed off that chain): about
    1.4x faster than the textbook order xp -> e -> xf -> xp, equal to round-off.
    With ``store_extra`` the per-step ll_steps[k] = -(const + e' S^-1 e) / 2 are written
    with innovations and predicted means; otherwise those arrays are not touched.
    """
    T = y.shape[0]
    xp = np.empty(N)
    xn = np.empty(N)
    e = np.empty(M)
    for i in range(N):
        xp[i] = x0[i]
    quad = 0.0
    for k in range(T):
        for i in range(N):
            s = cc[i]
            for j in range(N):
                s += A[i, j] * xp[j]
            for j in range(M):
                s += G[i, j] * y[k, j]
            for q in range(P):
                s += Bc[i, q] * u[k, q]
            xn[i] = s
        for j in range(M):
            s = y[k, j] - d[j]
            for i in range(N):
                s -= H[j, i] * xp[i]
            for q in range(P):
                s -= D[j, q] * u[k, q]
            e[j] = s
        qk = 0.0
        for j in range(M):
            t = 0.0
            for i in range(M):
                t += Sinv[j, i] * e[i]
            qk += e[j] * t
        quad += qk
        if store_extra:
            for j in range(M):
                innov[k, j] = e[j]
            ll_steps[k] = -0.5 * (const + qk)
        for i in range(N):
            if store_extra:
                pmean[k, i] = xp[i]
            s = xp[i]
            for j in range(M):
                s += K[i, j] * e[j]
            mean[k, i] = s
        for i in range(N):
            xp[i] = xn[i]
    return quad


@njit(cache=True)
def _filter_literal(N, M, P, A, G, Bc, cc, K, H, D, d, Sinv, x0, y, u, const, mean, pmean, innov, ll_steps,
                    store_extra):
    return _filter_impl(literally(N), literally(M), literally(P), A, G, Bc, cc, K, H, D, d, Sinv, x0, y, u, const,
                        mean, pmean, innov, ll_steps, store_extra)


@njit(cache=True, fastmath=FASTMATH)
def _smooth_impl(N, P, I_GF, G, GB, Gc, u, xf, xs):
    """Constant-gain RTS backward pass; ``xs`` may be the same array as ``xf`` (in place).

    xs[k] = xf[k] + G (xs[k+1] - F xf[k] - B u[k] - c) = (I - G F) xf[k] + G xs[k+1] - G B u[k] - G c
    """
    T = xf.shape[0]
    tmp = np.empty(N)
    for i in range(N):
        xs[T - 1, i] = xf[T - 1, i]
    for k in range(T - 2, -1, -1):
        for i in range(N):
            s = -Gc[i]
            for j in range(N):
                s += I_GF[i, j] * xf[k, j] + G[i, j] * xs[k + 1, j]
            for q in range(P):
                s -= GB[i, q] * u[k, q]
            tmp[i] = s
        for i in range(N):
            xs[k, i] = tmp[i]


@njit(cache=True)
def _smooth_literal(N, P, I_GF, G, GB, Gc, u, xf, xs):
    _smooth_impl(literally(N), literally(P), I_GF, G, GB, Gc, u, xf, xs)


# Per-size trampolines: a jitted closure whose sizes are compile-time constants calls the ``literally``
# wrapper with literal arguments, so numba resolves the unrolled (disk-cached) specialisation directly.
# Calling the wrapper from Python instead would re-run type inference on every call (~30 ms). The trampolines
# are disk-cached too (numba keys a closure's cache entry on its captured sizes), so a new process loads them.
_TRAMPOLINES: dict = {}


def _trampoline(kind, n, m, p):
    key = (kind, n, m, p)
    fn = _TRAMPOLINES.get(key)
    if fn is not None:
        return fn
    N, M, P = n, m, p
    if kind == "filter":
        @njit(cache=True)
        def fn(A, G, Bc, cc, K, H, D, d, Sinv, x0, y, u, const, mean, pmean, innov, ll_steps, store_extra):
            return _filter_literal(N, M, P, A, G, Bc, cc, K, H, D, d, Sinv, x0, y, u, const, mean, pmean, innov,
                                   ll_steps, store_extra)
    else:
        @njit(cache=True)
        def fn(I_GF, G, GB, Gc, u, xf, xs):
            _smooth_literal(N, P, I_GF, G, GB, Gc, u, xf, xs)
    _TRAMPOLINES[key] = fn
    return fn


def filter_kernel(A, G, Bc, cc, K, H, D, d, Sinv, x0, y, u, const, mean, pmean, innov, ll_steps, store_extra):
    """Dispatch to the unrolled (small sizes) or generic compiled constant-gain filter (see ``_filter_impl``)."""
    n, m, p = A.shape[0], H.shape[0], u.shape[1]
    if n <= MAX_LITERAL_STATES and m <= MAX_LITERAL_OBS and p <= MAX_LITERAL_INPUTS:
        return _trampoline("filter", n, m, p)(A, G, Bc, cc, K, H, D, d, Sinv, x0, y, u, const, mean, pmean, innov,
                                              ll_steps, store_extra)
    return _filter_impl(n, m, p, A, G, Bc, cc, K, H, D, d, Sinv, x0, y, u, const, mean, pmean, innov, ll_steps,
                        store_extra)


def smooth_kernel(I_GF, G, GB, Gc, u, xf, xs):
    """Dispatch to the unrolled (small sizes) or generic compiled constant-gain backward pass."""
    n, p = G.shape[0], u.shape[1]
    if n <= MAX_LITERAL_STATES and p <= MAX_LITERAL_INPUTS:
        _trampoline("smooth", n, 0, p)(I_GF, G, GB, Gc, u, xf, xs)
    else:
        _smooth_impl(n, p, I_GF, G, GB, Gc, u, xf, xs)
