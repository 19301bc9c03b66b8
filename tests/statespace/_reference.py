"""Pure-NumPy reference Kalman filter and RTS smoother (the test oracle of the compiled kernels).

This is the plain loop longprofile started from (validated against pykalman); the
library itself runs the numba kernels of ``longprofile.statespace._kernels``.
Tests import it as ``from tests.statespace._reference import reference_filter, reference_smoother``.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from longprofile.statespace import FilterResult, SmootherResult, StateSpaceModel
from longprofile.statespace._prepare import prepare_inputs, prepare_observations

__all__ = ["reference_filter", "reference_smoother"]

_LOG2PI = float(np.log(2.0 * np.pi))


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
            c = cho_factor(S, lower=True)
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


def reference_filter(model: StateSpaceModel, y, *, u=None, store_covariances: bool = True) -> FilterResult:
    """Same contract as :func:`longprofile.statespace.kalman_filter`, one Python loop per series."""
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
        G = np.linalg.solve(Pp, F @ cov[k]).T
        sm[k] = mean[k] + G @ (sm[k + 1] - pmean[k + 1])
        sc[k] = _symmetrize(cov[k] + G @ (sc[k + 1] - Pp) @ G.T)
        cc[k] = G @ sc[k + 1]
    return sm, sc, cc


def reference_smoother(model: StateSpaceModel, filtered: FilterResult) -> SmootherResult:
    """Same contract as :func:`longprofile.statespace.rts_smoother`, one Python loop per series."""
    if filtered.mean.ndim == 3:
        outs = [_smooth_one(model, filtered.mean[b], filtered.cov[b], filtered.pred_mean[b], filtered.pred_cov[b])
                for b in range(filtered.mean.shape[0])]
        sm, sc, cc = (np.stack([o[i] for o in outs]) for i in range(3))
    else:
        sm, sc, cc = _smooth_one(model, filtered.mean, filtered.cov, filtered.pred_mean, filtered.pred_cov)
    return SmootherResult(mean=sm, cov=sc, cross_cov=cc, filtered=filtered)
