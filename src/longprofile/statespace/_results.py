"""Result containers of the state-space engine (frozen dataclasses, read by name)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FilterResult", "SmootherResult"]


@dataclass(frozen=True, eq=False)
class FilterResult:
    """Output of :func:`kalman_filter` and :func:`extended_kalman_filter`.

    Shapes are given for one series; a batched run adds a leading axis B to
    every per-step field and to ``log_likelihood``.

    Attributes
    ----------
    mean : (T, n) ndarray
        Filtered means E[x_t | y_0..t].
    cov : (T, n, n) ndarray or None
        Filtered covariances; None when the filter ran with ``store_covariances=False``.
    pred_mean : (T, n) ndarray or None
        Predicted means E[x_t | y_0..t-1]; ``pred_mean[0]`` is the model's initial mean.
        None only from ``steady_state_filter(..., store_predictions=False)``.
    pred_cov : (T, n, n) ndarray or None
        Predicted covariances; None when covariances were not stored.
    innovation : (T, m) ndarray or None
        y_t - E[y_t | y_0..t-1]; NaN on the missing components (None as for ``pred_mean``).
    innovation_cov : (T, m, m) ndarray or None
        Covariance of the innovation (over all m components, observed or not).
    log_likelihood : float or (B,) ndarray
        Total Gaussian log-likelihood of the observed components.
    log_likelihood_steps : (T,) ndarray or None
        Per-step contributions (0 where the whole step is missing; None as for ``pred_mean``).
    n_observed : int or (B,) ndarray
        Number of observed scalar components that entered the likelihood.
    method : str
        Which algorithm produced the result (e.g. ``"joseph"``, ``"steady-state"``, ``"ekf"``).
    variance : (T, n) ndarray or None
        Diagonal of the filtered covariances, kept without them by ``store_covariances="variances"`` of
        :func:`extended_kalman_filter` and :func:`block_extended_kalman_filter` (O(T n) memory instead of
        O(T n^2)); None otherwise (take ``np.diagonal(cov, axis1=-2, axis2=-1)`` when ``cov`` is stored).
    innovation_variance : (T, m) ndarray or None
        Diagonal of the innovation covariances, kept with ``variance`` by ``store_covariances="variances"`` (what
        a normalized innovation squared, ``innovation**2 / innovation_variance``, needs); None otherwise (take
        the diagonal of ``innovation_cov`` when it is stored).
    """

    mean: np.ndarray
    cov: np.ndarray | None
    pred_mean: np.ndarray | None
    pred_cov: np.ndarray | None
    innovation: np.ndarray | None
    innovation_cov: np.ndarray | None
    log_likelihood: float | np.ndarray
    log_likelihood_steps: np.ndarray | None
    n_observed: int | np.ndarray
    method: str = "joseph"
    # EKF only: the linearisations used at each step (F_k at the filtered mean, H_k at the predicted mean).
    transition_jacobians: np.ndarray | None = None
    observation_jacobians: np.ndarray | None = None
    variance: np.ndarray | None = None
    innovation_variance: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class SmootherResult:
    """Output of :func:`rts_smoother` and :func:`extended_rts_smoother`.

    Attributes
    ----------
    mean : (T, n) ndarray
        Smoothed means E[x_t | y_0..T-1].
    cov : (T, n, n) ndarray or None
        Smoothed covariances (None when the smoother ran means-only).
    cross_cov : (T-1, n, n) ndarray or None
        Lag-one covariances Cov(x_t, x_{t+1} | y) — a true covariance, not a second moment.
    filtered : FilterResult or None
        The forward pass the smoother was run on (None only for the documented
        low-memory mode of :func:`steady_state_smoother`).
    """

    mean: np.ndarray
    cov: np.ndarray | None
    cross_cov: np.ndarray | None
    filtered: FilterResult | None
