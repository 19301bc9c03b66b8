"""Small compiled linear-algebra helpers shared by the engine's numba loops (private).

One copy of each helper for :mod:`._kernels` (linear filter/smoother),
:mod:`._ekf_kernels` (extended Kalman filter) and the other compiled loops of
``statespace``. They work in place on the leading block of preallocated
scratch arrays (sizes passed explicitly), never allocate (but
:func:`update_scratch`, which allocates those arrays), and trust their
inputs. All but :func:`fd_jacobian` are ``cache=True``; numba inlines them into
the callers' loops, so splitting them out costs nothing at run time. The
``inline="always"`` ones are inlined by numba itself, so they are compiled with
their caller's floating-point flags (the same operations as the loops they
replaced, in fastmath and strict callers alike).

Floating-point flags: contraction (FMA) and reassociation are allowed;
NaN/inf semantics are kept (missing data is NaN).

Disk cache: ``njit`` is :func:`longprofile._jit.njit`, whose cache directory is
keyed by the sources of every kernel file, so editing a helper here recompiles
every caller (no stale machine code, nothing to delete by hand).
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.extending import overload

from .._jit import njit

__all__ = [
    "FASTMATH", "FD_REL_STEP", "at", "cholesky_lower", "inverse_diagonal", "forward_sub", "backward_sub_t",
    "solve_rows", "affine_map", "joseph_update", "joseph_entry", "sandwich_sym", "gather_block", "matmul_into",
    "update_scratch", "innovation_loglik", "LOG2PI", "copy1", "copy2", "all_finite1", "all_finite2", "fd_jacobian",
    "call_model",
]

# Floating-point contraction/reassociation only: NaN and inf semantics are kept (missing data is NaN).
FASTMATH = {"contract", "reassoc", "nsz", "arcp"}

#: log(2 pi), of the Gaussian log-likelihood.
LOG2PI = float(np.log(2.0 * np.pi))

# Central differences: truncation O(h^2), round-off O(eps/h) -> h ~ eps^(1/3) relative to the state's scale.
FD_REL_STEP = float(np.finfo(float).eps ** (1.0 / 3.0))


@njit(cache=True, inline="always")
def at(K, k):
    """Index of step k in a model term with leading axis K (K = 1: constant term, index 0)."""
    return k if K > 1 else 0


@njit(cache=True, fastmath=FASTMATH)
def cholesky_lower(A, k, rel_tol):
    """In-place lower Cholesky of the leading k x k block of A (lower triangle read).

    Returns False if a pivot is not positive (``<= rel_tol`` times the original
    diagonal entry, or NaN), i.e. the block is not numerically positive definite.
    """
    for j in range(k):
        s = A[j, j]
        djj = s
        for l in range(j):
            s -= A[j, l] * A[j, l]
        if not (s > rel_tol * abs(djj)) or s <= 0.0:
            return False
        ljj = np.sqrt(s)
        A[j, j] = ljj
        for i in range(j + 1, k):
            t = A[i, j]
            for l in range(j):
                t -= A[i, l] * A[j, l]
            A[i, j] = t / ljj
    return True


@njit(cache=True, fastmath=FASTMATH)
def inverse_diagonal(L, k, dinv):
    """dinv[i] = 1 / L[i, i] (the triangular solves then multiply instead of dividing)."""
    for i in range(k):
        dinv[i] = 1.0 / L[i, i]


@njit(cache=True, fastmath=FASTMATH)
def forward_sub(L, dinv, k, b):
    """Solve L z = b in place (L lower, leading k x k block, dinv its inverse diagonal)."""
    for i in range(k):
        s = b[i]
        for l in range(i):
            s -= L[i, l] * b[l]
        b[i] = s * dinv[i]


@njit(cache=True, fastmath=FASTMATH)
def backward_sub_t(L, dinv, k, b):
    """Solve L^T z = b in place (L lower, leading k x k block, dinv its inverse diagonal)."""
    for i in range(k - 1, -1, -1):
        s = b[i]
        for l in range(i + 1, k):
            s -= L[l, i] * b[l]
        b[i] = s * dinv[i]


@njit(cache=True, fastmath=FASTMATH)
def solve_rows(L, dinv, k, X, r, work):
    """X[i, :k] <- X[i, :k] (L L')^-1 for the first r rows (L lower Cholesky factor, dinv its inverse diagonal).

    This is the gain K = P H' S^-1 computed row by row; ``work`` is scratch of length >= k.
    """
    for i in range(r):
        for j in range(k):
            work[j] = X[i, j]
        forward_sub(L, dinv, k, work)
        backward_sub_t(L, dinv, k, work)
        for j in range(k):
            X[i, j] = work[j]


@njit(cache=True, inline="always")
def affine_map(M, km, x, r, c, N, kn, u, ub, t, off, ko, out):
    """out[i] = M[km, i, :c] x + N[kn, i, :] u[ub, t] + off[ko, i] for i < r.

    Model terms carry a leading time axis (see :func:`at`). This is both the observation
    prediction H x + D u + d and the state prediction F x + B u + c.
    """
    p = N.shape[2]
    for i in range(r):
        s = off[ko, i]
        for l in range(c):
            s += M[km, i, l] * x[l]
        for l in range(p):
            s += N[kn, i, l] * u[ub, t, l]
        out[i] = s


@njit(cache=True, fastmath=FASTMATH)
def joseph_update(P, K, Ho, Ro, n, k, A, AP, KR):
    """P <- (I - K Ho) P (I - K Ho)' + K Ro K' in place, symmetric (Joseph form).

    P (n, n); K (n, k) gain on the k observed components; Ho (k, n) their rows of H;
    Ro (k, k) their block of R (used as given). A, AP (n, n) and KR (n, k) are scratch.
    """
    for i in range(n):
        for j in range(n):
            s = 1.0 if i == j else 0.0
            for a in range(k):
                s -= K[i, a] * Ho[a, j]
            A[i, j] = s
    matmul_into(A, P, n, n, n, AP)
    matmul_into(K, Ro, n, k, k, KR)
    for i in range(n):
        for j in range(i, n):
            s = joseph_entry(AP, A, KR, K, i, j, n, k)
            P[i, j] = s
            P[j, i] = s


@njit(cache=True, inline="always")
def joseph_entry(AP, A, KR, K, i, j, n, k):
    """Entry (i, j) of the Joseph-form covariance AP A' + (KR K' + K KR')/2 from its products (n states, k
    observed): AP = (I - K H) P, A = I - K H, KR = K R (see :func:`joseph_update`)."""
    s = 0.0
    for c in range(n):
        s += AP[i, c] * A[j, c]
    t = 0.0
    for a in range(k):
        t += KR[i, a] * K[j, a] + KR[j, a] * K[i, a]
    s += 0.5 * t
    return s


@njit(cache=True, inline="always")
def gather_block(src, rows, cols, r, c, out):
    """out[a, b] = src[rows[a], cols[b]] for a < r, b < c (a block of a matrix at the given indices)."""
    for a in range(r):
        for b in range(c):
            out[a, b] = src[rows[a], cols[b]]


@njit(cache=True, inline="always")
def matmul_into(X, Y, r, inner, c, out):
    """out[:r, :c] = X[:r, :inner] Y[:inner, :c], each entry summed in the order of the inner index (Y may be a
    transposed view: ``Y.T`` gives X Y')."""
    for i in range(r):
        for j in range(c):
            s = 0.0
            for q in range(inner):
                s += X[i, q] * Y[q, j]
            out[i, j] = s


@njit(cache=True, inline="always")
def innovation_loglik(L, dinv, e, k, n_obs, w):
    """log N(e; 0, S) of an innovation e (k,) from the Cholesky factor L (k, k) of its covariance S, with
    ``n_obs`` observed components in the 2 pi term (rows of L that are the identity add nothing). Writes the
    inverse diagonal of L into ``dinv`` and the whitened innovation L^-1 e into ``w``."""
    inverse_diagonal(L, k, dinv)
    logdet = 0.0
    for a in range(k):
        w[a] = e[a]
        logdet += 2.0 * math.log(L[a, a])
    forward_sub(L, dinv, k, w)
    quad = 0.0
    for a in range(k):
        quad += w[a] * w[a]
    return -0.5 * (n_obs * LOG2PI + logdet + quad)


@njit(cache=True, inline="always")
def update_scratch(n, m):
    """The scratch arrays of a measurement update with n states and m observations, allocated:
    S, L (m, m); PHt, K, KR (n, m); e, w, dinv (m,)."""
    return (np.empty((m, m)), np.empty((m, m)), np.empty((n, m)), np.empty((n, m)), np.empty((n, m)),
            np.empty(m), np.empty(m), np.empty(m))


@njit(cache=True, fastmath=FASTMATH)
def sandwich_sym(M, P, N, work, out):
    """out = M P M' + (N + N')/2, symmetric; work = P M' (kept: it is P H' for the gain).

    M (r, n), P (n, n), N (r, r), work (n, r), out (r, r). ``out`` may be ``P`` itself
    (in-place covariance prediction F P F' + Q): P is read only while ``work`` is formed.
    """
    n = P.shape[0]
    r = M.shape[0]
    for i in range(n):
        for a in range(r):
            s = 0.0
            for j in range(n):
                s += P[i, j] * M[a, j]
            work[i, a] = s
    for a in range(r):
        for b in range(a, r):
            s = 0.5 * (N[a, b] + N[b, a])
            for i in range(n):
                s += M[a, i] * work[i, b]
            out[a, b] = s
            out[b, a] = s


@njit(cache=True)
def copy1(src, dst):
    """dst[:] = src[:len(dst)] as a loop (slice assignment pulls string formatting into numba's compile)."""
    for i in range(dst.shape[0]):
        dst[i] = src[i]


@njit(cache=True)
def copy2(src, dst):
    """dst[:, :] = src as a loop (see :func:`copy1`)."""
    for i in range(dst.shape[0]):
        for j in range(dst.shape[1]):
            dst[i, j] = src[i, j]


@njit(cache=True)
def all_finite1(a):
    """True when every entry of the 1-D array a is finite."""
    for i in range(a.shape[0]):
        if not np.isfinite(a[i]):
            return False
    return True


@njit(cache=True)
def all_finite2(a, r, c):
    """True when every entry of the leading r x c block of a is finite."""
    for i in range(r):
        for j in range(c):
            if not np.isfinite(a[i, j]):
                return False
    return True


def call_model(fn, params, x, u, k):
    """``fn(x, u, k)`` when ``params`` is None, else ``fn(x, u, k, params)`` (compiled code only).

    The model-parameter convention of :class:`longprofile.statespace.NonlinearStateSpaceModel`: the choice is
    made when numba types the call (``params`` None or an array), so the compiled loops have no run-time branch.
    """
    raise NotImplementedError("call_model runs inside numba-compiled loops only")


@overload(call_model, inline="always")
def _call_model_overload(fn, params, x, u, k):
    if isinstance(params, types.NoneType):
        def without_params(fn, params, x, u, k):
            return fn(x, u, k)
        return without_params

    def with_params(fn, params, x, u, k):
        return fn(x, u, k, params)
    return with_params


def fd_jacobian(fn, params, x, u, k, xw, J):
    """Central-difference Jacobian of fn(., u, k) (``fn(., u, k, params)`` unless ``params`` is None) at x
    into J (rows: outputs); xw is scratch of x's size (compiled code only).

    Step h_j = eps^(1/3) max(|x_j|, 1), re-derived as (x + h) - (x - h) so the divisor is exact.
    Not cached: numba specialises it per user function (keyed on the function's identity).

    An overload, not an ``@njit`` function: numba looks an overload's implementation up by the exact
    argument types, whereas a jitted function first rates its compiled signatures against the new
    arguments -- and rating a 3-argument model function against a signature compiled for a 4-argument
    one (``f(x, u, k, params)``) raises a ``TypeError`` that numba does not catch (numba 0.68,
    ``types.Dispatcher.can_convert_to`` catches ``NumbaError`` only). Models with and without
    parameters in one process then failed to compile.
    """
    raise NotImplementedError("fd_jacobian runs inside numba-compiled loops only")


@overload(fd_jacobian)
def _fd_jacobian_overload(fn, params, x, u, k, xw, J):
    def impl(fn, params, x, u, k, xw, J):
        n = x.shape[0]
        for j in range(n):
            xw[j] = x[j]
        for j in range(n):
            step = FD_REL_STEP * max(abs(x[j]), 1.0)
            hi = x[j] + step
            lo = x[j] - step
            xw[j] = hi
            a = call_model(fn, params, xw, u, k)
            xw[j] = lo
            b = call_model(fn, params, xw, u, k)
            xw[j] = x[j]
            inv = 1.0 / (hi - lo)
            for i in range(a.shape[0]):
                J[i, j] = (a[i] - b[i]) * inv
    return impl
