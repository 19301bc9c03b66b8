"""Compiled lag sums of the exact fixed-lag smoother (private; see :func:`._fixed_lag.fixed_lag_smoother`).

The fixed-lag estimate adds to the filtered one, for each t, the window sums

    a_t = sum_{i=1..L} M_t ... M_{t+i-1} g_{t+i},      B_t = sum_{i=1..L} (M_t ... M_{t+i-1}) G_{t+i} (...)'

with M_j the transposed closed loop of the prediction error, g_j = H_j' S_j^-1 e_j and G_j = H_j' S_j^-1 H_j.
Each sum is the value at 0 of a composition of L maps, T_t o ... o T_{t+L-1}, with the affine map
T_j(z) = M_j (g_{j+1} + z) for a_t and the congruence T_j(Z) = M_j (G_{j+1} + Z) M_j' for B_t (T_j is the
identity for j >= T - 1: the last windows are truncated at the record's end). Composition is associative,
so every window is one suffix of a block of L maps composed with one prefix of the next block (the
sliding-window "two stacks" aggregation): O(T n^3) work for any L, against O(T L n^2 k) for summing each
window term by term, and no subtraction of long running sums (every term of B_t stays a sum of
positive semi-definite parts).

A map is held as (Phi, c) for z -> Phi z + c and (Phi, C) for Z -> Phi Z Phi' + C; (Phi1, c1) o (Phi2, c2) =
(Phi1 Phi2, Phi1 c2 + c1) and (Phi1, C1) o (Phi2, C2) = (Phi1 Phi2, Phi1 C2 Phi1' + C1).
"""

from __future__ import annotations

import numpy as np

from .._jit import njit
from ._linalg_kernels import FASTMATH, matmul_into

__all__ = ["fixed_lag_window_sums"]


@njit(cache=True, fastmath=FASTMATH)
def _congruence(A, X, n, work, out):
    """out = A X A' (A, X (n, n)); work (n, n)."""
    matmul_into(A, X, n, n, n, work)
    matmul_into(work, A.T, n, n, n, out)


@njit(cache=True, fastmath=FASTMATH)
def fixed_lag_window_sums(M, g, G, Ps, lag, dmean, dcov):
    """dmean[s, t] = Ps[t] a_t of series s and dcov[t] = Ps[t] B_t Ps[t]' for every t (module docstring).

    M (T - 1, n, n), G (T, n, n), Ps (T, k, n) (the selected rows of the predicted covariance) are shared by the
    batch; g (S, T, n) holds each series' H' S^-1 e. lag >= 1; dmean (S, T, k) and dcov (T, k, k) are written.
    """
    S, T, n = g.shape
    k = Ps.shape[1]
    L = lag
    sphi = np.empty((L, n, n))  # suffix maps of the current block: S_t = T_t o ... o T_{b+L-1}
    sc = np.empty((L, S, n))
    sC = np.empty((L, n, n))
    phi = np.empty((n, n))
    c = np.empty((S, n))
    C = np.empty((n, n))
    pphi = np.empty((n, n))  # prefix map of the next block: P = T_{b+L} o ... o T_{t+L-1}
    pc = np.empty((S, n))
    pC = np.empty((n, n))
    A = np.empty((n, n))
    X = np.empty((n, n))
    work = np.empty((n, n))
    v = np.empty(n)
    Q = np.empty((k, n))
    for b in range(0, T, L):
        # suffixes, from the block's last map down to its first (identity maps beyond T - 2)
        c[:, :] = 0.0
        for i in range(n):
            for j in range(n):
                phi[i, j] = 1.0 if i == j else 0.0
                C[i, j] = 0.0
        for t in range(b + L - 1, b - 1, -1):
            if t <= T - 2:
                for r in range(S):
                    for i in range(n):
                        v[i] = g[r, t + 1, i] + c[r, i]
                    for i in range(n):
                        acc = 0.0
                        for q in range(n):
                            acc += M[t, i, q] * v[q]
                        c[r, i] = acc
                for i in range(n):
                    for j in range(n):
                        X[i, j] = G[t + 1, i, j] + C[i, j]
                matmul_into(M[t], phi, n, n, n, A)
                phi[:, :] = A
                _congruence(M[t], X, n, work, C)
            if t < T:
                sphi[t - b] = phi
                sc[t - b] = c
                sC[t - b] = C
        # windows of the block: S_t o P, with P grown by one map per step
        pc[:, :] = 0.0
        for i in range(n):
            for j in range(n):
                pphi[i, j] = 1.0 if i == j else 0.0
                pC[i, j] = 0.0
        for t in range(b, min(b + L, T)):
            jm = t + L - 1
            if t > b and jm <= T - 2:
                matmul_into(pphi, M[jm], n, n, n, A)
                for r in range(S):
                    for i in range(n):
                        acc = pc[r, i]
                        for q in range(n):
                            acc += A[i, q] * g[r, jm + 1, q]
                        pc[r, i] = acc
                _congruence(A, G[jm + 1], n, work, X)
                for i in range(n):
                    for j in range(n):
                        pC[i, j] += X[i, j]
                pphi[:, :] = A
            w = t - b
            matmul_into(Ps[t], sphi[w], k, n, n, Q)
            for r in range(S):
                for a in range(k):
                    acc = 0.0
                    for q in range(n):
                        acc += Q[a, q] * pc[r, q] + Ps[t, a, q] * sc[w, r, q]
                    dmean[r, t, a] = acc
            for a in range(k):
                for a2 in range(k):
                    acc = 0.0
                    for i in range(n):
                        qi = 0.0
                        pi = 0.0
                        for j in range(n):
                            qi += pC[i, j] * Q[a2, j]
                            pi += sC[w, i, j] * Ps[t, a2, j]
                        acc += Q[a, i] * qi + Ps[t, a, i] * pi
                    dcov[t, a, a2] = acc
