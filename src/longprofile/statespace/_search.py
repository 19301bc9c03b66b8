"""Many bounded scalar searches in lockstep, each step's evaluations in one batched call.

A maximum-likelihood fit of one scalar per series (e.g. the prior intensity of every day of the rail all-days model,
docs/rail.md step 10) runs hundreds of bounded Brent searches of a few dozen evaluations each. Run one after the
other, each evaluation is a separate call into the engine, and the calls' fixed cost dwarfs the compiled work. Here
every search is scipy's bounded Brent method (``scipy.optimize.minimize_scalar(method="bounded")``: golden section
with parabolic steps, Brent 1973 ch. 5, Forsythe, Malcolm & Moler 1977 ``fmin``), written as a generator that yields
the point it needs next; all searches advance together and each round's points are evaluated in one call of a
vectorised objective. Every search takes exactly the steps scipy's takes on the same values (tested bit for bit).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import sqrt

import numpy as np

from ..errors import InputError

__all__ = ["BoundedSearchResult", "minimize_scalar_bounded_batch"]


@dataclass(frozen=True, eq=False)
class BoundedSearchResult:
    """Output of :func:`minimize_scalar_bounded_batch` (the fields of scipy's ``OptimizeResult``, one per search).

    Attributes
    ----------
    x, fun : (B,) ndarray
        The minimiser found and its value.
    nfev : (B,) ndarray of int
        Evaluations of each search.
    status : (B,) ndarray of int
        0 converged, 1 maximum number of evaluations reached, 2 NaN met (as scipy's).
    """

    x: np.ndarray
    fun: np.ndarray
    nfev: np.ndarray
    status: np.ndarray


def _bounded_brent(x1, x2, xatol, maxfun):
    """scipy's ``_minimize_scalar_bounded`` (scipy 1.17) as a generator: yields x, receives f(x); returns
    (xf, fx, num, flag). The statements and their order are scipy's, so the floating-point results are too."""
    sqrt_eps = sqrt(2.2e-16)
    golden_mean = 0.5 * (3.0 - sqrt(5.0))
    a, b = x1, x2
    fulc = a + golden_mean * (b - a)
    nfc, xf = fulc, fulc
    rat = e = 0.0
    x = xf
    fx = yield x
    num = 1
    fu = np.inf
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = sqrt_eps * np.abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    flag = 0
    while np.abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        golden = 1
        if np.abs(e) > tol1:  # parabolic fit
            golden = 0
            r = (xf - nfc) * (fx - ffulc)
            q = (xf - fulc) * (fx - fnfc)
            p = (xf - fulc) * q - (xf - nfc) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = np.abs(q)
            r = e
            e = rat
            if (np.abs(p) < np.abs(0.5 * q * r)) and (p > q * (a - xf)) and (p < q * (b - xf)):
                rat = (p + 0.0) / q
                x = xf + rat
                if ((x - a) < tol2) or ((b - x) < tol2):
                    si = np.sign(xm - xf) + ((xm - xf) == 0)
                    rat = tol1 * si
            else:
                golden = 1
        if golden:  # golden-section step
            e = (a - xf) if xf >= xm else (b - xf)
            rat = golden_mean * e
        si = np.sign(rat) + (rat == 0)
        x = xf + si * np.maximum(np.abs(rat), tol1)
        fu = yield x
        num += 1
        if fu <= fx:
            if x >= xf:
                a = xf
            else:
                b = xf
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            if x < xf:
                a = x
            else:
                b = x
            if (fu <= fnfc) or (nfc == xf):
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif (fu <= ffulc) or (fulc == xf) or (fulc == nfc):
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = sqrt_eps * np.abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= maxfun:
            flag = 1
            break
    if np.isnan(xf) or np.isnan(fx) or np.isnan(fu):
        flag = 2
    return xf, fx, num, flag


def minimize_scalar_bounded_batch(fun, lower, upper, *, xatol: float = 1e-5, maxiter: int = 500) -> BoundedSearchResult:
    r"""Minimise B scalar functions, each on its own interval, by scipy's bounded Brent method in lockstep.

    Parameters
    ----------
    fun : callable
        ``fun(index, x) -> values``: index (k,) int array of the searches that need a value, x (k,) their points;
        returns the k objective values (e.g. one engine call for all of them).
    lower, upper : (B,) array_like
        Finite bounds, lower <= upper.
    xatol, maxiter
        As ``scipy.optimize.minimize_scalar(method="bounded", options=...)``.

    Returns
    -------
    BoundedSearchResult
        Search b's x, fun, nfev and status equal scipy's ``minimize_scalar(lambda t: f_b(t), bounds=(lower[b],
        upper[b]), method="bounded", options={"xatol": xatol, "maxiter": maxiter})`` bit for bit, f_b being what
        ``fun`` returns for b.

    Notes
    -----
    Each round asks ``fun`` once for the next point of every search still running; a search takes as many rounds
    as scipy's takes evaluations (about 25 at xatol 1e-3 on an interval of two decades of log r).
    """
    lo = np.asarray(lower, float)
    hi = np.asarray(upper, float)
    if lo.ndim != 1 or hi.shape != lo.shape:
        raise InputError(f"lower and upper must be (B,) arrays of one shape; got {lo.shape} and {hi.shape}.")
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))) or np.any(lo > hi):
        raise InputError("the bounds must be finite with lower <= upper.")
    B = lo.size
    out = np.empty((4, B))
    gens = [_bounded_brent(lo[b], hi[b], xatol, maxiter) for b in range(B)]
    active = list(range(B))
    points = [gen.send(None) for gen in gens]
    while active:
        idx = np.array(active, dtype=np.int64)
        vals = np.asarray(fun(idx, np.array([points[b] for b in active], dtype=float)), dtype=float)
        still = []
        for b, v in zip(active, vals):
            try:
                points[b] = gens[b].send(v)
                still.append(b)
            except StopIteration as stop:
                out[:, b] = stop.value
        active = still
    return BoundedSearchResult(x=out[0], fun=out[1], nfev=out[2].astype(np.int64), status=out[3].astype(np.int64))
