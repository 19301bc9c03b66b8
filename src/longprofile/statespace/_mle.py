"""Maximum-likelihood estimation of state-space model parameters from the innovation likelihood."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.optimize import minimize

from .._validation import as_float_array
from ..errors import ConvergenceError, InputError, ModelError, ShapeError
from ._kalman import kalman_filter, log_likelihood
from ._model import StateSpaceModel

__all__ = ["MLEResult", "fit_mle"]


@dataclass(frozen=True, eq=False)
class MLEResult:
    """Output of :func:`fit_mle`.

    Attributes
    ----------
    params : (k,) ndarray
        Maximum-likelihood estimate of theta (in the parametrisation ``build`` takes).
    std_errors : (k,) ndarray
        sqrt(diag(cov)); NaN for a parameter at a bound or when the Hessian is not positive definite.
    cov : (k, k) ndarray
        Asymptotic covariance: inverse of the numerical Hessian of -log-likelihood at ``params``
        (NaN rows/columns where std_errors is NaN).
    log_likelihood : float
        Maximised log-likelihood.
    converged : bool
        True for a returned result (a failed optimisation raises ConvergenceError, carrying
        a result with ``converged=False`` in its ``result`` attribute).
    n_iterations : int
        Optimiser iterations.
    message : str
        Optimiser message, plus notes on bounds or the Hessian.
    param_names : tuple of str
        One name per parameter (``theta[i]`` when not given).
    aic, bic : float
        2k - 2 logL and k ln(N) - 2 logL, N the number of observed scalar samples.
    n_observed : int
        N, the number of observed scalar components in y.
    """

    params: np.ndarray
    std_errors: np.ndarray
    cov: np.ndarray
    log_likelihood: float
    converged: bool
    n_iterations: int
    message: str
    param_names: tuple
    aic: float
    bic: float
    n_observed: int


def _neg_loglik_factory(build, y, u):
    def nll(theta):
        try:
            model = build(np.array(theta, dtype=np.float64))
        except ModelError:
            return np.inf  # invalid model (e.g. a negative variance): outside the feasible set
        if not isinstance(model, StateSpaceModel):
            raise InputError(f"build(theta) must return a StateSpaceModel; it returned {type(model).__name__}.")
        try:
            ll = log_likelihood(model, y, u=u)
        except ModelError:
            return np.inf
        ll = float(np.sum(ll))
        return -ll if np.isfinite(ll) else np.inf
    return nll


def _hessian(fun, x, steps):
    """Central-difference Hessian with per-parameter steps; diagonal from f(x +- h), off-diagonal from 4 points."""
    k = x.size
    f0 = fun(x)
    H = np.empty((k, k))
    E = np.diag(steps)
    fp = np.array([fun(x + E[i]) for i in range(k)])
    fm = np.array([fun(x - E[i]) for i in range(k)])
    for i in range(k):
        H[i, i] = (fp[i] - 2.0 * f0 + fm[i]) / steps[i] ** 2
        for j in range(i + 1, k):
            v = (fun(x + E[i] + E[j]) - fun(x + E[i] - E[j]) - fun(x - E[i] + E[j]) + fun(x - E[i] - E[j]))
            H[i, j] = H[j, i] = v / (4.0 * steps[i] * steps[j])
    return H


def _richardson_hessian(fun, x, steps):
    """Richardson extrapolation of two central-difference Hessians (steps h and h/2): error O(h^4)."""
    H1 = _hessian(fun, x, steps)
    H2 = _hessian(fun, x, steps / 2.0)
    return (4.0 * H2 - H1) / 3.0


def fit_mle(build: Callable[[np.ndarray], StateSpaceModel], y, theta0, *, u=None,
            bounds: Sequence[tuple] | None = None, param_names: Sequence[str] | None = None,
            method: str = "L-BFGS-B", options: dict | None = None) -> MLEResult:
    """Maximum-likelihood estimate of model parameters, with standard errors from the Hessian.

    Parameters
    ----------
    build : callable ``build(theta) -> StateSpaceModel``
        Pure function from the parameter vector to a model. It may raise
        :class:`~longprofile.errors.ModelError` for infeasible theta (the
        likelihood is then taken as 0, i.e. -log L = inf). Prefer
        parametrisations that are unconstrained (e.g. log-variances) or give ``bounds``.
    y : (T,), (T, m) or (B, T, m) array_like
        Observations (NaN = missing). A batch is fitted jointly (sum of log-likelihoods).
    theta0 : (k,) array_like
        Starting values.
    u : (T, p) or (B, T, p) array_like, optional
        Known inputs.
    bounds : sequence of (low, high), optional
        Box bounds per parameter (None for unbounded), for methods that support them.
    param_names : sequence of str, optional
        Names used in the result and in messages.
    method : str, default "L-BFGS-B"
        Any :func:`scipy.optimize.minimize` method that needs no analytic gradient
        ("L-BFGS-B", "Nelder-Mead", "Powell", "BFGS", ...).
    options : dict, optional
        Passed to :func:`scipy.optimize.minimize`.

    Returns
    -------
    MLEResult

    Raises
    ------
    ConvergenceError
        If the optimiser reports failure or ends at a non-finite likelihood. The
        exception's ``result`` attribute holds the last iterate (``converged=False``)
        for inspection; a result is never returned silently unconverged.
    InputError, ShapeError
        On invalid theta0, bounds or names.

    Notes
    -----
    Objective: -log L(theta) from :func:`log_likelihood` (prediction-error
    decomposition of the Kalman filter). Standard errors: the inverse of the
    Hessian of -log L at the optimum (observed information), computed by
    central differences with steps h_i = eps^(1/4) max(|theta_i|, 0.1)
    (balancing truncation O(h^2) and round-off O(eps/h^2)) and Richardson
    extrapolation (h and h/2). Parameters within 2 h_i of a bound are held
    fixed: their standard errors are NaN and the message says so (the usual
    asymptotics do not hold on a boundary). If the Hessian of the free
    parameters is not positive definite (flat or non-identifiable direction),
    std_errors and cov are NaN and the message says so.
    """
    theta0, names, bounds, lo, hi = _check_parameters(theta0, param_names, bounds)
    k = theta0.size
    nll = _neg_loglik_factory(build, y, u)
    f0 = nll(theta0)
    if not np.isfinite(f0):
        raise InputError(f"the log-likelihood is not finite at theta0 = {dict(zip(names, theta0))}: build(theta0) "
                         "is infeasible or the data are impossible under it. Choose other starting values.")
    res = minimize(nll, theta0, method=method, bounds=bounds, options=options)
    params = np.asarray(res.x, dtype=np.float64)
    fval = float(res.fun)
    n_iter = int(getattr(res, "nit", 0) or 0)
    model = build(params.copy()) if np.isfinite(fval) else None
    n_obs = int(np.sum(kalman_filter(model, y, u=u, store_covariances=False).n_observed)) if model else 0
    ll = -fval
    aic = 2.0 * k - 2.0 * ll
    bic = float(k * np.log(max(n_obs, 1)) - 2.0 * ll)

    def result(std, cov, converged, message):
        return MLEResult(params=params, std_errors=std, cov=cov, log_likelihood=ll, converged=converged,
                         n_iterations=n_iter, message=message, param_names=names, aic=aic, bic=bic,
                         n_observed=n_obs)

    nan_cov = np.full((k, k), np.nan)
    if not res.success or not np.isfinite(fval):
        exc = ConvergenceError(
            f"maximum-likelihood fit did not converge ({method}: {res.message}) after {n_iter} iterations; last "
            f"params {dict(zip(names, params))}, log-likelihood {ll:.6g}. Try other starting values, a "
            "reparametrisation (log-variances), bounds, or method='Nelder-Mead'.")
        exc.result = result(np.full(k, np.nan), nan_cov, False, str(res.message))
        raise exc

    steps = np.finfo(float).eps ** 0.25 * np.maximum(np.abs(params), 0.1)
    free = (params - 2.0 * steps > lo) & (params + 2.0 * steps < hi)
    notes = [str(res.message)]
    if not free.all():
        notes.append("at a bound (standard error undefined): " + ", ".join(n for n, f in zip(names, free) if not f))
    std, cov = _standard_errors(nll, params, steps, free, nan_cov, notes)
    return result(std, cov, True, "; ".join(notes))


def _check_parameters(theta0, param_names, bounds):
    """fit_mle's parameter arguments checked: (theta0, names, bounds as tuples, low and high bounds)."""
    theta0 = as_float_array("theta0", theta0, ndim=1, allow_nan=False)
    k = theta0.size
    if k < 1:
        raise ShapeError("theta0 must have at least one parameter.")
    names = tuple(param_names) if param_names is not None else tuple(f"theta[{i}]" for i in range(k))
    if len(names) != k:
        raise ShapeError(f"param_names must have one name per parameter ({k}); got {len(names)}.")
    if bounds is not None:
        bounds = [tuple(b) for b in bounds]
        if len(bounds) != k or any(len(b) != 2 for b in bounds):
            raise ShapeError(f"bounds must be {k} (low, high) pairs; got {bounds}.")
        lo = np.array([-np.inf if b[0] is None else float(b[0]) for b in bounds])
        hi = np.array([np.inf if b[1] is None else float(b[1]) for b in bounds])
        if np.any(lo >= hi) or np.any(theta0 < lo) or np.any(theta0 > hi):
            raise InputError(f"theta0 = {theta0} must lie within bounds {bounds} (with low < high).")
    else:
        lo, hi = np.full(k, -np.inf), np.full(k, np.inf)
    return theta0, names, bounds, lo, hi


def _standard_errors(nll, params, steps, free, nan_cov, notes):
    """(std, cov) of the free parameters from the Richardson Hessian of -log L at the optimum (NaN elsewhere; NaN
    everywhere, and a line appended to ``notes``, when that Hessian is not positive definite)."""
    k = params.size
    std = np.full(k, np.nan)
    cov = nan_cov.copy()
    if free.any():
        idx = np.flatnonzero(free)

        def sub(t):
            full = params.copy()
            full[idx] = t
            return nll(full)

        Hs = _richardson_hessian(sub, params[idx], steps[idx])
        Hs = 0.5 * (Hs + Hs.T)
        chol = None
        if np.all(np.isfinite(Hs)):
            try:
                chol = cho_factor(Hs, lower=True)
            except np.linalg.LinAlgError:
                chol = None
        if chol is not None:
            cs = cho_solve(chol, np.eye(idx.size))  # the covariance is the inverse itself (Cholesky solve)
            cs = 0.5 * (cs + cs.T)
            cov[np.ix_(idx, idx)] = cs
            std[idx] = np.sqrt(np.diag(cs))
        else:
            notes.append("Hessian of -log L not positive definite at the optimum (flat or non-identifiable "
                         "direction): standard errors undefined")
    return std, cov
