"""Prediction-error identification of polynomial input-output models: ARX, output-error, ARMAX.

The models (q^-1 the backward shift, e white):

* ARX:    A(q) y = B(q) u + e
* OE:     y = B(q) / F(q) u + e            (paper 000 §4.1: ARMAX with C = A, "erreur de sortie")
* ARMAX:  A(q) y = B(q) u + C(q) e

with A = 1 + a1 q^-1 + ... + a_na q^-na, B = q^-nk (b0 + b1 q^-1 + ... + b_{nb-1} q^-(nb-1)),
C = 1 + c1 q^-1 + ... (MATLAB System Identification Toolbox conventions for na, nb, nc, nk).

The residuals of OE and ARMAX are recursive IIR filters of known polynomials, computed with
:func:`scipy.signal.lfilter` (filtering, not a state-space loop). The Gaussian maximum-likelihood
estimate minimises the sum of squared prediction errors; it is found by Gauss-Newton with
Levenberg-Marquardt damping (:func:`scipy.optimize.least_squares`, method "lm") from the ARX
least-squares estimate, with analytic Jacobians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import as_float_array, require_positive
from ..errors import ConvergenceError, InputError, ShapeError

__all__ = ["IdentifiedModel", "fit_arx", "fit_output_error", "fit_armax", "simulate_model", "step_response"]


@dataclass(frozen=True, eq=False)
class IdentifiedModel:
    """An identified polynomial model and its fit statistics.

    Attributes
    ----------
    structure : str
        ``"arx"``, ``"oe"`` or ``"armax"``.
    orders : dict
        ``na``, ``nb``, ``nk`` (and ``nc`` for ARMAX).
    numerator : (nk + nb,) ndarray
        B in ascending powers of q^-1, with nk leading zeros.
    denominator : (na + 1,) ndarray
        A (ARX, ARMAX) or F (OE), leading 1.
    noise_numerator : (nc + 1,) ndarray or None
        C (ARMAX), None otherwise.
    dt : float or None
        Sampling step of the data, s.
    params : (p,) ndarray
        Estimated parameters in the order of ``param_names``.
    param_names : tuple of str
        ``a1.., b0.., c1..`` (``f1..`` for OE).
    covariance : (p, p) ndarray
        Cramér-Rao (asymptotic) covariance sigma^2 (J'J)^-1.
    std_errors : (p,) ndarray
    residual_std : float
        Standard deviation of the prediction errors (the paper's "écart type objet-modèle").
    n_iterations : int
        Gauss-Newton (Jacobian) evaluations; 0 for ARX.
    converged : bool
        The optimiser met its tolerance.
    stable : bool
        All poles (and, for ARMAX, the roots of C) inside the unit circle.
    zeros, poles : ndarray
        Roots of B (without the delay) and of A/F, in z.
    fit_simulation : float
        100 (1 - ||y - y_sim|| / ||y - mean y||), %, y_sim = B/A u from rest.
    fit_prediction : float
        Same with the one-step-ahead predictor (equal to the simulation fit for OE).
    n_samples : int
    message : str
        Optimiser message.
    """

    structure: str
    orders: dict
    numerator: np.ndarray
    denominator: np.ndarray
    noise_numerator: np.ndarray | None
    dt: float | None
    params: np.ndarray
    param_names: tuple
    covariance: np.ndarray
    std_errors: np.ndarray
    residual_std: float
    n_iterations: int
    converged: bool
    stable: bool
    zeros: np.ndarray
    poles: np.ndarray
    fit_simulation: float
    fit_prediction: float
    n_samples: int
    message: str

    def to_dict(self) -> dict:
        """JSON-serialisable description (complex roots as [re, im] pairs)."""
        c = lambda z: [[float(v.real), float(v.imag)] for v in np.atleast_1d(z)]  # noqa: E731
        return dict(structure=self.structure, orders=dict(self.orders), numerator=self.numerator.tolist(),
                    denominator=self.denominator.tolist(),
                    noise_numerator=None if self.noise_numerator is None else self.noise_numerator.tolist(),
                    dt=self.dt, params=self.params.tolist(), param_names=list(self.param_names),
                    std_errors=self.std_errors.tolist(), covariance=self.covariance.tolist(),
                    residual_std=float(self.residual_std), n_iterations=int(self.n_iterations),
                    converged=bool(self.converged), stable=bool(self.stable), zeros=c(self.zeros), poles=c(self.poles),
                    fit_simulation=float(self.fit_simulation), fit_prediction=float(self.fit_prediction),
                    n_samples=self.n_samples, message=self.message)


def _lfilter(b, a, x):
    """scipy.signal.lfilter(b, a, x), imported on first use (scipy.signal costs ~1 s at start-up)."""
    from scipy.signal import lfilter

    return lfilter(b, a, x)


def _least_squares(*args, **kwargs):
    """scipy.optimize.least_squares, imported on first use."""
    from scipy.optimize import least_squares

    return least_squares(*args, **kwargs)


def _check_data(u, y, na, nb, nk, nc=0):
    u = as_float_array("u", u, ndim=1, allow_nan=False)
    y = as_float_array("y", y, ndim=1, allow_nan=False)
    if u.shape != y.shape:
        raise ShapeError(f"u and y must have the same length; got {u.shape[0]} and {y.shape[0]}.")
    for name, v, lo in (("na", na, 0), ("nb", nb, 1), ("nk", nk, 0), ("nc", nc, 0)):
        if int(v) != v or v < lo:
            raise InputError(f"{name} must be an integer >= {lo}; got {v!r}.")
    p = int(na) + int(nb) + int(nc)
    n_min = max(10 * p, int(na) + int(nb) + int(nk) + 20)
    if y.size < n_min:
        raise InputError(f"{y.size} samples are too few to identify {p} parameters; need at least {n_min}.")
    if np.std(u) == 0:
        raise InputError("u is constant: it does not excite the system, nothing can be identified.")
    return u, y, int(na), int(nb), int(nk), int(nc)


def _shift(x, k):
    """q^-k x with zero initial conditions."""
    if k == 0:
        return x
    out = np.zeros_like(x)
    out[k:] = x[:-k]
    return out


def _stabilise(poly):
    """Reflect roots outside the unit circle inside (same magnitude response up to a gain)."""
    if poly.size <= 1:
        return poly
    r = np.roots(poly)
    bad = np.abs(r) >= 1.0
    if not bad.any():
        return poly
    r[bad] = 1.0 / np.conj(r[bad])
    return np.real(np.poly(r))


def _fit_percent(y, yhat):
    den = np.linalg.norm(y - y.mean())
    return float(100.0 * (1.0 - np.linalg.norm(y - yhat) / den)) if den > 0 else float("nan")


def _covariance(J, resid, p):
    N = resid.size
    sigma2 = float(resid @ resid) / max(N - p, 1)
    # (J'J)^-1 by SVD (pseudo-inverse on a numerically singular direction)
    _, s, Vt = np.linalg.svd(J, full_matrices=False)
    tol = s.max() * max(J.shape) * np.finfo(float).eps
    inv = np.where(s > tol, 1.0 / np.where(s > tol, s, 1.0) ** 2, 0.0)
    cov = (Vt.T * inv) @ Vt * sigma2
    return cov, np.sqrt(np.maximum(np.diag(cov), 0.0)), sigma2


def _roots(poly):
    poly = np.trim_zeros(np.asarray(poly, float), "b")
    return np.roots(poly) if poly.size > 1 else np.array([], dtype=complex)


def _arx_ls(u, y, na, nb, nk):
    cols = [-_shift(y, j) for j in range(1, na + 1)] + [_shift(u, nk + i) for i in range(nb)]
    Phi = np.column_stack(cols)
    start = max(na, nk + nb - 1)
    theta, *_ = np.linalg.lstsq(Phi[start:], y[start:], rcond=None)
    return theta, Phi, start


def fit_arx(u, y, *, na: int, nb: int, nk: int = 1, dt: float | None = None) -> IdentifiedModel:
    """Least-squares ARX model A(q) y = B(q) u + e.

    Parameters
    ----------
    u, y : (T,) array_like
        Input and output samples.
    na, nb, nk : int
        Orders: na poles, nb numerator coefficients, nk samples of delay.
    dt : float, optional
        Sampling step, s (stored for the user).

    Returns
    -------
    IdentifiedModel
    """
    u, y, na, nb, nk, _ = _check_data(u, y, na, nb, nk)
    theta, Phi, start = _arx_ls(u, y, na, nb, nk)
    resid = y[start:] - Phi[start:] @ theta
    cov, se, sigma2 = _covariance(Phi[start:], resid, theta.size)
    a = np.r_[1.0, theta[:na]]
    b = np.r_[np.zeros(nk), theta[na:]]
    ysim = _lfilter(b, a, u) if np.all(np.abs(_roots(a)) < 1) else np.full_like(y, np.nan)
    return IdentifiedModel(
        structure="arx", orders=dict(na=na, nb=nb, nk=nk), numerator=b, denominator=a, noise_numerator=None,
        dt=None if dt is None else require_positive("dt", dt), params=theta,
        param_names=tuple([f"a{j}" for j in range(1, na + 1)] + [f"b{i}" for i in range(nb)]),
        covariance=cov, std_errors=se, residual_std=float(np.sqrt(np.mean(resid ** 2))), n_iterations=0,
        converged=True, stable=bool(np.all(np.abs(_roots(a)) < 1)), zeros=_roots(b[nk:]), poles=_roots(a),
        fit_simulation=_fit_percent(y, ysim), fit_prediction=_fit_percent(y[start:], Phi[start:] @ theta),
        n_samples=y.size, message="linear least squares")


def _finish(structure, orders, b, a, c, dt, theta, names, J, resid, res, u, y, on_failure, yhat_pred):
    cov, se, sigma2 = _covariance(J, resid, theta.size)
    poles = _roots(a)
    stable = bool(np.all(np.abs(poles) < 1)) and (c is None or bool(np.all(np.abs(_roots(c)) < 1)))
    converged = bool(res.success) and bool(np.all(np.isfinite(theta)))
    ysim = _lfilter(b, a, u) if stable else np.full_like(y, np.nan)
    model = IdentifiedModel(
        structure=structure, orders=orders, numerator=b, denominator=a, noise_numerator=c,
        dt=None if dt is None else require_positive("dt", dt), params=theta, param_names=tuple(names),
        covariance=cov, std_errors=se, residual_std=float(np.sqrt(np.mean(resid ** 2))),
        n_iterations=int(res.njev if res.njev is not None else res.nfev), converged=converged, stable=stable,
        zeros=_roots(b[orders["nk"]:]), poles=poles, fit_simulation=_fit_percent(y, ysim),
        fit_prediction=_fit_percent(y, yhat_pred), n_samples=y.size, message=str(res.message))
    if on_failure == "raise" and not (converged and stable):
        what = "did not converge" if not converged else (
            f"converged to an unstable model (max |pole| = {np.abs(poles).max():.4f})")
        raise ConvergenceError(f"{structure.upper()} identification {what} after {model.n_iterations} iterations "
                               f"({res.message}). Try other orders or delay, a richer excitation, or "
                               "on_failure='flag' to inspect the estimate.")
    return model


def _check_on_failure(on_failure):
    if on_failure not in ("raise", "flag"):
        raise InputError(f"on_failure must be 'raise' or 'flag'; got {on_failure!r}.")


def _steiglitz_mcbride(u, y, na, nb, nk, n_iter: int = 8):
    """Start values for OE: ARX, then Steiglitz-McBride iterations (ARX on data prefiltered by 1/F).

    Returns theta = [b (nb), f1..f_na] with F stabilised. Plain ARX is biased when the noise is
    white on the output; the prefiltered iterations remove most of that bias, so the Gauss-Newton
    search starts near the ML estimate instead of in a local minimum.
    """
    theta, _, _ = _arx_ls(u, y, na, nb, nk)
    f = _stabilise(np.r_[1.0, theta[:na]])
    best = np.r_[theta[na:], f[1:]]
    best_loss = np.inf
    for _ in range(n_iter):
        uf = _lfilter([1.0], f, u)
        yf = _lfilter([1.0], f, y)
        theta, _, _ = _arx_ls(uf, yf, na, nb, nk)
        f = _stabilise(np.r_[1.0, theta[:na]])
        cand = np.r_[theta[na:], f[1:]]
        e = y - _lfilter(np.r_[np.zeros(nk), cand[:nb]], f, u)
        loss = float(e @ e)
        if np.isfinite(loss) and loss < best_loss:
            best, best_loss = cand, loss
    return best


def fit_output_error(u, y, *, na: int, nb: int, nk: int = 1, dt: float | None = None, max_iterations: int = 200,
                     tol: float = 1e-10, on_failure: str = "raise") -> IdentifiedModel:
    """Output-error model y = B(q)/F(q) u + e by prediction-error maximum likelihood (paper 000, §4).

    Parameters
    ----------
    u, y : (T,) array_like
        Input and output samples (the system is assumed at rest before the record).
    na, nb, nk : int
        Orders of F (na), of B (nb coefficients) and the delay nk (paper: 5, 5, 1).
    dt : float, optional
        Sampling step, s.
    max_iterations : int
        Maximum residual evaluations of the damped Gauss-Newton (Levenberg-Marquardt) search.
    tol : float
        Relative tolerance on the parameters and the loss.
    on_failure : {"raise", "flag"}
        A non-converged or unstable estimate raises :class:`ConvergenceError` (default) or is
        returned with ``converged`` / ``stable`` False.

    Returns
    -------
    IdentifiedModel
        ``denominator`` is F; ``param_names`` are ``b0.., f1..``.

    Notes
    -----
    Residuals e = y - B/F u and their analytic derivatives (de/db_i = -q^-(nk+i) u / F,
    de/df_j = q^-j y_hat / F) are IIR filters (``lfilter``). During the iterations F is
    stabilised by reflecting roots outside the unit circle (so the residuals stay finite); the
    returned estimate is checked for stability. Start: the ARX least-squares estimate refined by
    Steiglitz-McBride iterations (ARX on data prefiltered by 1/F).
    """
    _check_on_failure(on_failure)
    u, y, na, nb, nk, _ = _check_data(u, y, na, nb, nk)
    theta0 = _steiglitz_mcbride(u, y, na, nb, nk)

    def unpack(th):
        return np.r_[np.zeros(nk), th[:nb]], np.r_[1.0, th[nb:]]

    def resid(th):
        b, f = unpack(th)
        return y - _lfilter(b, _stabilise(f), u)

    def jac(th):
        b, f = unpack(th)
        f = _stabilise(f)
        uf = _lfilter([1.0], f, u)
        yhat = _lfilter(b, f, u)
        yf = _lfilter([1.0], f, yhat)
        cols = [-_shift(uf, nk + i) for i in range(nb)] + [_shift(yf, j) for j in range(1, na + 1)]
        return np.column_stack(cols)

    res = _least_squares(resid, theta0, jac=jac, method="lm", xtol=tol, ftol=tol, gtol=tol,
                                 max_nfev=int(max_iterations))
    th = res.x
    b, f = unpack(th)
    e = y - _lfilter(b, f, u) if np.all(np.abs(_roots(f)) < 1) else res.fun
    names = [f"b{i}" for i in range(nb)] + [f"f{j}" for j in range(1, na + 1)]
    return _finish("oe", dict(na=na, nb=nb, nk=nk), b, f, None, dt, th, names, jac(th), e, res, u, y,
                   on_failure, y - e)


def fit_armax(u, y, *, na: int, nb: int, nc: int, nk: int = 1, dt: float | None = None,
              max_iterations: int = 200, tol: float = 1e-10, on_failure: str = "raise") -> IdentifiedModel:
    """ARMAX model A(q) y = B(q) u + C(q) e by prediction-error maximum likelihood (paper 000, §4.1).

    Parameters
    ----------
    na, nb, nc, nk : int
        Orders of A, B (coefficients), C and the delay.
    Other parameters as :func:`fit_output_error`.

    Returns
    -------
    IdentifiedModel
        ``fit_prediction`` uses the one-step predictor y - e; ``fit_simulation`` B/A u.

    Notes
    -----
    Prediction errors e = (A y - B u) / C with derivatives de/da_j = q^-j y / C,
    de/db_i = -q^-(nk+i) u / C, de/dc_j = -q^-j e / C; C is kept minimum-phase by root
    reflection during the iterations. Start: ARX least squares with C = 1.
    """
    _check_on_failure(on_failure)
    u, y, na, nb, nk, nc = _check_data(u, y, na, nb, nk, nc)
    if nc < 1:
        raise InputError("nc must be >= 1 for ARMAX (use fit_arx for C = 1).")
    theta_arx, _, _ = _arx_ls(u, y, na, nb, nk)
    theta0 = np.r_[theta_arx, np.zeros(nc)]

    def unpack(th):
        return np.r_[1.0, th[:na]], np.r_[np.zeros(nk), th[na:na + nb]], np.r_[1.0, th[na + nb:]]

    def resid(th):
        a, b, c = unpack(th)
        c = _stabilise(c)
        return _lfilter(a, c, y) - _lfilter(b, c, u)

    def jac(th):
        a, b, c = unpack(th)
        c = _stabilise(c)
        e = _lfilter(a, c, y) - _lfilter(b, c, u)
        yc = _lfilter([1.0], c, y)
        uc = _lfilter([1.0], c, u)
        ec = _lfilter([1.0], c, e)
        cols = ([_shift(yc, j) for j in range(1, na + 1)] + [-_shift(uc, nk + i) for i in range(nb)]
                + [-_shift(ec, j) for j in range(1, nc + 1)])
        return np.column_stack(cols)

    res = _least_squares(resid, theta0, jac=jac, method="lm", xtol=tol, ftol=tol, gtol=tol,
                                 max_nfev=int(max_iterations))
    th = res.x
    a, b, c = unpack(th)
    e = resid(th)
    names = [f"a{j}" for j in range(1, na + 1)] + [f"b{i}" for i in range(nb)] + [f"c{j}" for j in range(1, nc + 1)]
    return _finish("armax", dict(na=na, nb=nb, nc=nc, nk=nk), b, a, c, dt, th, names, jac(th), e, res, u, y,
                   on_failure, y - e)


def simulate_model(model: IdentifiedModel, u) -> np.ndarray:
    """Noise-free simulation B/A u from rest, (T,)."""
    u = as_float_array("u", u, ndim=1, allow_nan=False)
    return _lfilter(model.numerator, model.denominator, u)


def step_response(model: IdentifiedModel, n_samples: int) -> np.ndarray:
    """Unit-step response of B/A, (n_samples,)."""
    return simulate_model(model, np.ones(int(n_samples)))
