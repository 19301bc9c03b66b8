"""Expectation-maximisation statistics of a linear-Gaussian model from its smoother output."""

from __future__ import annotations

import numpy as np

from ..errors import ShapeError
from ._model import StateSpaceModel
from ._results import SmootherResult

__all__ = ["process_noise_moments"]


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
