"""Pure-NumPy reference extended Kalman filter (the test oracle of the engine's compiled EKF loops).

This is the Python loop the engine ran for plain-Python model functions until 2026-12-03; the library now
compiles such functions with numba and runs only its compiled loops (``statespace/_ekf_kernels.py``,
``statespace/_block_ekf.py``). Same algorithm: Joseph-form update, NaN = missing component, Jacobian F_k at
the filtered mean, H_k at the predicted mean, central finite differences h_j = eps^(1/3) max(|x_j|, 1) when a
Jacobian is not given (S. Särkkä, *Bayesian Filtering and Smoothing*, 2013, Alg. 5.4).
Tests import it as ``from tests.statespace._ekf_reference import reference_ekf``.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from longprofile.statespace import FilterResult

__all__ = ["reference_ekf"]

_LOG2PI = float(np.log(2.0 * np.pi))
_FD_REL_STEP = float(np.finfo(float).eps ** (1.0 / 3.0))  # as the engine (statespace._linalg_kernels.FD_REL_STEP)


def _at(fn, x, j, value, u, k):
    xj = x.copy()
    xj[j] = value
    return np.asarray(fn(xj, u, k), dtype=np.float64)


def _fd_jacobian(fn, x, u, k):
    """Central differences, step eps^(1/3) max(|x_j|, 1), divided by the step as represented ((x+h) - (x-h))."""
    hi = x + _FD_REL_STEP * np.maximum(np.abs(x), 1.0)
    lo = x - _FD_REL_STEP * np.maximum(np.abs(x), 1.0)
    return np.stack([(_at(fn, x, j, hi[j], u, k) - _at(fn, x, j, lo[j], u, k)) / (hi[j] - lo[j])
                     for j in range(x.shape[0])], axis=-1)


def _jacobian(fn, jac, x, u, k):
    return _fd_jacobian(fn, x, u, k) if jac is None else np.asarray(jac(x, u, k), dtype=np.float64)


def reference_ekf(f, h, Q, R, x0, P0, y, u=None, *, fj=None, hj=None) -> FilterResult:
    """EKF of one series ``y`` (T, m) with plain Python ``f(x, u, k)``, ``h`` (and Jacobians ``fj``, ``hj``; None =
    finite differences); ``Q`` (n, n) or (T-1, n, n), ``R`` (m, m) or (T, m, m); ``u`` (T, p) or None."""
    y = np.asarray(y, dtype=float)
    y = y[:, None] if y.ndim == 1 else y
    T, m = y.shape
    n = len(x0)
    u = np.zeros((T, 0)) if u is None else np.asarray(u, dtype=float).reshape(T, -1)
    Q3 = np.asarray(Q, dtype=float)
    Q3 = Q3[None] if Q3.ndim == 2 else Q3
    R3 = np.asarray(R, dtype=float)
    R3 = R3[None] if R3.ndim == 2 else R3
    mean, pmean, innov, ll_steps = np.empty((T, n)), np.empty((T, n)), np.full((T, m), np.nan), np.zeros(T)
    cov, pcov, icov = np.empty((T, n, n)), np.empty((T, n, n)), np.empty((T, m, m))
    Fj, Hj = np.empty((max(T - 1, 0), n, n)), np.empty((T, m, n))
    x, P = np.array(x0, dtype=float), np.array(P0, dtype=float)
    eye = np.eye(n)
    n_obs = 0
    for k in range(T):
        uk = u[k]
        Rk = R3[k if R3.shape[0] > 1 else 0]
        pmean[k], pcov[k] = x, P
        yhat = np.asarray(h(x, uk, k), dtype=np.float64)
        H = _jacobian(h, hj, x, uk, k)
        Hj[k] = H
        S = H @ P @ H.T + 0.5 * (Rk + Rk.T)
        S = 0.5 * (S + S.T)
        icov[k] = S
        obs = ~np.isnan(y[k])
        if obs.any():
            Ho = H[obs]
            e = y[k, obs] - yhat[obs]
            c = cho_factor(S[np.ix_(obs, obs)], lower=True)
            K = cho_solve(c, Ho @ P).T
            x = x + K @ e
            A = eye - K @ Ho
            P = A @ P @ A.T + K @ Rk[np.ix_(obs, obs)] @ K.T
            P = 0.5 * (P + P.T)
            innov[k, obs] = e
            ll_steps[k] = -0.5 * (obs.sum() * _LOG2PI + 2.0 * np.sum(np.log(np.diag(c[0]))) + e @ cho_solve(c, e))
            n_obs += int(obs.sum())
        mean[k], cov[k] = x, P
        if k < T - 1:
            F = _jacobian(f, fj, x, uk, k)
            Fj[k] = F
            x = np.asarray(f(x, uk, k), dtype=np.float64)
            Qk = Q3[k if Q3.shape[0] > 1 else 0]
            P = F @ P @ F.T + 0.5 * (Qk + Qk.T)
            P = 0.5 * (P + P.T)
    return FilterResult(mean=mean, cov=cov, pred_mean=pmean, pred_cov=pcov, innovation=innov, innovation_cov=icov,
                        log_likelihood=float(ll_steps.sum()), log_likelihood_steps=ll_steps, n_observed=n_obs,
                        method="ekf", transition_jacobians=Fj, observation_jacobians=Hj)
