"""Kalman filter and RTS smoother for :class:`StateSpaceModel`.

This module holds the public entry points: validation, shaping and the
dispatch to the loops. The loops themselves are the only filter loops in the
package.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from .._validation import as_float_array
from ..errors import ModelError, ShapeError
from ._model import StateSpaceModel
from ._results import FilterResult, SmootherResult

__all__ = ["kalman_filter", "rts_smoother", "log_likelihood", "prepare_observations", "prepare_inputs"]

_LOG2PI = float(np.log(2.0 * np.pi))


def prepare_observations(model: StateSpaceModel, y) -> tuple[np.ndarray, bool]:
    """Validate ``y`` against ``model``; return a (B, T, m) float64 array and whether it was batched.

    ``y`` may be (T,) when m = 1, (T, m), or (B, T, m). NaN marks a missing component.
    """
    m = model.n_obs
    arr = as_float_array("y", y, ndim=(1, 2, 3))
    batched = arr.ndim == 3
    if arr.ndim == 1:
        if m != 1:
            raise ShapeError(f"y is 1-D, which is only accepted for m = 1 observation; the model has m = {m}. "
                             "Pass y with shape (T, m).")
        arr = arr[:, None]
    if arr.ndim == 2:
        arr = arr[None]
    if arr.shape[-1] != m:
        raise ShapeError(f"y must have m = {m} columns (one per observation of the model); got shape {np.shape(y)}.")
    if arr.shape[1] < 1:
        raise ShapeError("y has no samples.")
    model.check_length(arr.shape[1])
    return np.ascontiguousarray(arr), batched


def prepare_inputs(model: StateSpaceModel, u, n_steps: int, n_batch: int) -> np.ndarray | None:
    """Validate known inputs ``u``: (T, p) shared by all series, or (B, T, p). Returns (B, T, p) or None."""
    p = model.n_inputs
    if u is None:
        if p:
            raise ShapeError(f"the model has p = {p} known inputs (B or D is set); pass u with shape (T, {p}).")
        return None
    if not p:
        raise ShapeError("u was given but the model has no input matrices (input_transition / input_observation).")
    arr = as_float_array("u", u, ndim=(1, 2, 3), allow_nan=False)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim == 2:
        arr = np.broadcast_to(arr[None], (n_batch,) + arr.shape)
    if arr.shape[1:] != (n_steps, p) or arr.shape[0] != n_batch:
        raise ShapeError(f"u must have shape (T, p) = ({n_steps}, {p}) or (B, T, p) = ({n_batch}, {n_steps}, {p}); "
                         f"got {np.shape(u)}.")
    return np.ascontiguousarray(arr)


def _symmetrize(a):
    return 0.5 * (a + a.T)


def _filter_one(model: StateSpaceModel, y: np.ndarray, u: np.ndarray | None, store_cov: bool):
    """Reference loop for one series: y (T, m), u (T, p) or None. Joseph-form update."""
    T, m = y.shape
    n = model.n_states
    mean = np.empty((T, n))
    pmean = np.empty((T, n))
    cov = np.empty((T, n, n)) if store_cov else None
    pcov = np.empty((T, n, n)) if store_cov else None
    innov = np.full((T, m), np.nan)
    icov = np.empty((T, m, m)) if store_cov else None
    ll_steps = np.zeros(T)
    n_obs = 0
    x = model.initial_mean.copy()
    P = model.initial_cov.copy()
    eye = np.eye(n)
    for k in range(T):
        pmean[k] = x
        if store_cov:
            pcov[k] = P
        H = model.at("observation", k)
        R = model.at("obs_cov", k)
        yhat = H @ x
        D = model.at("input_observation", k)
        if D is not None:
            yhat = yhat + D @ u[k]
        d = model.at("obs_offset", k)
        if d is not None:
            yhat = yhat + d
        S_full = H @ P @ H.T + R
        if store_cov:
            icov[k] = _symmetrize(S_full)
        obs = ~np.isnan(y[k])
        if obs.any():
            Ho = H[obs]
            e = y[k, obs] - yhat[obs]
            S = S_full[np.ix_(obs, obs)]
            try:
                c = cho_factor(S, lower=True)
            except np.linalg.LinAlgError:
                raise ModelError(f"innovation covariance is not positive definite at step {k}; "
                                 "obs_cov (R) must be positive definite on the observed components.") from None
            PHt = P @ Ho.T
            K = cho_solve(c, PHt.T).T
            x = x + K @ e
            A = eye - K @ Ho
            P = A @ P @ A.T + K @ R[np.ix_(obs, obs)] @ K.T
            P = _symmetrize(P)
            innov[k, obs] = e
            logdet = 2.0 * np.sum(np.log(np.diag(c[0])))
            ll_steps[k] = -0.5 * (obs.sum() * _LOG2PI + logdet + e @ cho_solve(c, e))
            n_obs += int(obs.sum())
        mean[k] = x
        if store_cov:
            cov[k] = P
        if k < T - 1:
            F = model.at("transition", k)
            x = F @ x
            B = model.at("input_transition", k)
            if B is not None:
                x = x + B @ u[k]
            c_ = model.at("state_offset", k)
            if c_ is not None:
                x = x + c_
            P = _symmetrize(F @ P @ F.T + model.at("process_cov", k))
    return mean, cov, pmean, pcov, innov, icov, ll_steps, n_obs


def kalman_filter(model: StateSpaceModel, y, *, u=None, store_covariances: bool = True) -> FilterResult:
    """Kalman filter with missing data (NaN) and a Joseph-form covariance update.

    Parameters
    ----------
    model : StateSpaceModel
        The linear-Gaussian model.
    y : (T,), (T, m) or (B, T, m) array_like
        Observations; NaN marks a missing component (the update then uses only
        the observed rows of H and R). A 3-D array is a batch of B independent
        series of the same model.
    u : (T, p) or (B, T, p) array_like, optional
        Known inputs; ``u[k]`` enters the observation at step k and the transition k -> k+1.
    store_covariances : bool, default True
        If False, only means, innovations and the likelihood are returned
        (``cov``, ``pred_cov``, ``innovation_cov`` are None): O(T n) memory.

    Returns
    -------
    FilterResult

    Notes
    -----
    Timing convention: ``model.initial_mean`` is the prior of x_0 before y_0,
    ``pred_mean[t]`` = E[x_t | y_<t], ``mean[t]`` = E[x_t | y_<=t].
    """
    Y, batched = prepare_observations(model, y)
    nb, T, m = Y.shape
    U = prepare_inputs(model, u, T, nb)
    outs = [_filter_one(model, Y[b], None if U is None else U[b], store_covariances) for b in range(nb)]
    stack = (lambda i: np.stack([o[i] for o in outs])) if batched else (lambda i: outs[0][i])
    ll_steps = stack(6)
    nobs = np.array([o[7] for o in outs]) if batched else outs[0][7]
    return FilterResult(
        mean=stack(0), cov=stack(1) if store_covariances else None,
        pred_mean=stack(2), pred_cov=stack(3) if store_covariances else None,
        innovation=stack(4), innovation_cov=stack(5) if store_covariances else None,
        log_likelihood=ll_steps.sum(axis=-1) if batched else float(ll_steps.sum()),
        log_likelihood_steps=ll_steps, n_observed=nobs, method="joseph")


def log_likelihood(model: StateSpaceModel, y, *, u=None) -> float | np.ndarray:
    """Gaussian log-likelihood of ``y`` under ``model`` (prediction-error decomposition).

    Missing components (NaN) do not count. Returns a float, or (B,) for batched ``y``.
    """
    return kalman_filter(model, y, u=u, store_covariances=False).log_likelihood


def _smooth_one(model, mean, cov, pmean, pcov):
    T, n = mean.shape
    sm = np.empty_like(mean)
    sc = np.empty_like(cov)
    cc = np.empty((max(T - 1, 0), n, n))
    sm[-1] = mean[-1]
    sc[-1] = cov[-1]
    for k in range(T - 2, -1, -1):
        F = model.at("transition", k)
        Pp = pcov[k + 1]
        # G = P_f F' Pp^{-1} via a symmetric solve (no explicit inverse)
        try:
            G = np.linalg.solve(Pp, F @ cov[k]).T
        except np.linalg.LinAlgError:
            G = (np.linalg.pinv(Pp) @ (F @ cov[k])).T
        sm[k] = mean[k] + G @ (sm[k + 1] - pmean[k + 1])
        sc[k] = _symmetrize(cov[k] + G @ (sc[k + 1] - Pp) @ G.T)
        cc[k] = G @ sc[k + 1]
    return sm, sc, cc


def rts_smoother(model: StateSpaceModel, filtered: FilterResult) -> SmootherResult:
    """Rauch–Tung–Striebel smoother on the output of :func:`kalman_filter`.

    Parameters
    ----------
    model : StateSpaceModel
        The model the filter was run with.
    filtered : FilterResult
        Output of :func:`kalman_filter` with covariances stored.

    Returns
    -------
    SmootherResult
        Smoothed means and covariances, and lag-one cross-covariances
        ``cross_cov[t] = Cov(x_t, x_{t+1} | y)``.
    """
    if filtered.cov is None:
        raise ShapeError("rts_smoother needs the filtered covariances; run kalman_filter with store_covariances=True.")
    if filtered.mean.ndim == 3:
        outs = [_smooth_one(model, filtered.mean[b], filtered.cov[b], filtered.pred_mean[b], filtered.pred_cov[b])
                for b in range(filtered.mean.shape[0])]
        sm, sc, cc = (np.stack([o[i] for o in outs]) for i in range(3))
    else:
        sm, sc, cc = _smooth_one(model, filtered.mean, filtered.cov, filtered.pred_mean, filtered.pred_cov)
    return SmootherResult(mean=sm, cov=sc, cross_cov=cc, filtered=filtered)
