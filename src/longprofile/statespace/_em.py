"""Expectation-maximisation statistics of a linear-Gaussian model from its smoother output."""

from __future__ import annotations

import numpy as np

from .._jit import njit
from ..errors import ShapeError
from ._model import StateSpaceModel
from ._results import SmootherResult

__all__ = ["process_noise_moments", "process_noise_energy"]


def process_noise_moments(model: StateSpaceModel, smoothed: SmootherResult) -> np.ndarray:
    r"""Posterior second moments of the process noise, E[w_t w_t^T | y], w_t = x_{t+1} - F_t x_t - c_t.

    The E-step statistic of the process covariance in EM (Shumway & Stoffer 1982): with smoothed
    means m_t, covariances P_t and lag-one covariances C_t = Cov(x_t, x_{t+1} | y),

        E[w_t w_t^T | y] = d_t d_t^T + P_{t+1} - F_t C_t - C_t^T F_t^T + F_t P_t F_t^T,
        d_t = m_{t+1} - F_t m_t - c_t.

    Parameters
    ----------
    model : StateSpaceModel
        The model the smoother ran on (no known inputs; constant or time-varying F, c).
    smoothed : SmootherResult or GroupedSmootherResult
        From :func:`rts_smoother` or :func:`shared_covariance_smoother`: ``mean`` (T, n) or (B, T, n);
        ``cov`` (T, n, n) shared or (B, T, n, n); ``cross_cov`` (T-1, n, n) or (B, T-1, n, n). From
        :func:`grouped_covariance_smoother`: the covariance terms once per group, then each series its group's.

    Returns
    -------
    (T-1, n, n) or (B, T-1, n, n) ndarray
        One moment per step (and per series for a batched ``mean``).
    """
    if model.n_inputs:
        raise ShapeError("process_noise_moments does not take known inputs (the model has B or D).")
    if smoothed.cov is None or smoothed.cross_cov is None:
        raise ShapeError("process_noise_moments needs the smoothed covariances and lag-one cross-covariances.")
    group = getattr(smoothed, "group", None)  # GroupedSmootherResult: covariances per group
    m = np.asarray(smoothed.mean, float)
    P = np.asarray(smoothed.cov, float)
    C = np.asarray(smoothed.cross_cov, float)
    T, n = m.shape[-2], m.shape[-1]
    F = np.asarray(model.transition, float)
    F = np.broadcast_to(F, (T - 1, n, n)) if F.ndim == 2 else F
    c = np.zeros((T - 1, n)) if model.state_offset is None else np.asarray(model.state_offset, float)
    c = np.broadcast_to(c, (T - 1, n)) if c.ndim == 1 else c
    d = m[..., 1:, :] - np.einsum("tab,...tb->...ta", F, m[..., :-1, :]) - c
    FC = np.einsum("tab,...tbc->...tac", F, C)
    S = P[..., 1:, :, :] - FC - np.swapaxes(FC, -1, -2) + np.einsum("tab,...tbc,tdc->...tad", F, P[..., :-1, :, :], F)
    return d[..., :, None] * d[..., None, :] + (S if group is None else S[group])


@njit(cache=True)
def _energy_kernel(m, P, C, group, F, c, W, out):  # pragma: no cover - compiled
    """out[b, t] = tr(W_t E[w_t w_t^T | y]) of series b, its covariance terms those of its group."""
    B, T, n = m.shape
    G = P.shape[0]
    cov_term = np.empty((G, T - 1))
    FP = np.empty((n, n))
    for g in range(G):
        for t in range(T - 1):
            for a in range(n):
                for b in range(n):
                    s = 0.0
                    for q in range(n):
                        s += F[t, a, q] * P[g, t, q, b]
                    FP[a, b] = s
            acc = 0.0
            for a in range(n):
                for b in range(n):
                    s = P[g, t + 1, b, a]
                    for q in range(n):  # (P' - F C - C' F' + F P F')[b, a]
                        s += -F[t, b, q] * C[g, t, q, a] - C[g, t, q, b] * F[t, a, q] + FP[b, q] * F[t, a, q]
                    acc += W[t, a, b] * s
            cov_term[g, t] = acc
    d = np.empty(n)
    for b in range(B):
        for t in range(T - 1):
            for a in range(n):
                s = m[b, t + 1, a] - c[t, a]
                for q in range(n):
                    s -= F[t, a, q] * m[b, t, q]
                d[a] = s
            acc = 0.0
            for a in range(n):
                for q in range(n):
                    acc += W[t, a, q] * d[q] * d[a]
            out[b, t] = acc + cov_term[group[b], t]
    return out


def process_noise_energy(model: StateSpaceModel, smoothed, weight) -> np.ndarray:
    r"""Posterior expectation of a quadratic form of the process noise, E[w_t^T W_t w_t | y] = tr(W_t E[w_t w_t^T | y]).

    The E-step statistic of a scaled process covariance (Shumway & Stoffer 1982; with W_t = Q_t^-1 its expectation
    under the model is n): :func:`process_noise_moments` contracted with W_t, without forming the (B, T-1, n, n)
    moments (one compiled pass; the covariance part once per group of a :class:`GroupedSmootherResult`).

    Parameters
    ----------
    model : StateSpaceModel
        The model the smoother ran on (no known inputs).
    smoothed : SmootherResult or GroupedSmootherResult
        Batched means (B, T, n) with shared covariances (T, n, n), or a grouped result.
    weight : (n, n) or (T-1, n, n) array_like
        W_t.

    Returns
    -------
    (B, T-1) ndarray
        Equal to ``einsum("tab,btba->bt", W, process_noise_moments(model, smoothed))`` to round-off.
    """
    if model.n_inputs:
        raise ShapeError("process_noise_energy does not take known inputs (the model has B or D).")
    m = np.asarray(smoothed.mean, float)
    if m.ndim != 3:
        raise ShapeError(f"process_noise_energy needs batched means (B, T, n); got shape {m.shape}.")
    B, T, n = m.shape
    group = getattr(smoothed, "group", None)
    P = np.asarray(smoothed.cov, float)
    C = np.asarray(smoothed.cross_cov, float)
    if group is None:
        if P.shape != (T, n, n):
            raise ShapeError("process_noise_energy needs covariances shared by the batch (T, n, n) or a grouped result.")
        P, C, group = P[None], C[None], np.zeros(B, dtype=np.int64)
    F = np.asarray(model.transition, float)
    F = np.ascontiguousarray(np.broadcast_to(F, (T - 1, n, n)))
    c = np.zeros((T - 1, n)) if model.state_offset is None else np.asarray(model.state_offset, float)
    c = np.ascontiguousarray(np.broadcast_to(c, (T - 1, n)))
    W = np.ascontiguousarray(np.broadcast_to(np.asarray(weight, float), (T - 1, n, n)))
    return _energy_kernel(np.ascontiguousarray(m), np.ascontiguousarray(P), np.ascontiguousarray(C),
                          np.asarray(group, dtype=np.int64), F, c, W, np.empty((B, T - 1)))
