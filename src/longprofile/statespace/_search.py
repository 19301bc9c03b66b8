"""Many bounded scalar searches in lockstep, each step's evaluations in one batched call.

A maximum-likelihood fit of one scalar per series (e.g. the prior intensity of every day of the rail all-days model,
docs/rail.md step 10) runs hundreds of bounded Brent searches of a few dozen evaluations each. Run one after the
other, each evaluation is a separate call into the engine, and the calls' fixed cost dwarfs the compiled work. Here
every search is scipy's bounded Brent method (``scipy.optimize.minimize_scalar(method="bounded")``: golden section
with parabolic steps, Brent 1973 ch. 5, Forsythe, Malcolm & Moler 1977 ``fmin``), its scalar statements written
element-wise over the searches still running (the same IEEE operations, so the same values); all searches advance
together and each round's points are evaluated in one call of a vectorised objective. Every search takes exactly the
steps scipy's takes on the same values (tested bit for bit).
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


_SQRT_EPS = sqrt(2.2e-16)
_GOLDEN = 0.5 * (3.0 - sqrt(5.0))


def _step_points(st, i, xatol):
    """The next point of the searches ``i`` (scipy's parabolic-or-golden step, element-wise; updates rat, e)."""
    a, b, xf, nfc, fulc = st["a"][i], st["b"][i], st["xf"][i], st["nfc"][i], st["fulc"][i]
    fx, fnfc, ffulc, xm = st["fx"][i], st["fnfc"][i], st["ffulc"][i], st["xm"][i]
    tol1, tol2, e, rat = st["tol1"][i], st["tol2"][i], st["e"][i].copy(), st["rat"][i].copy()
    golden = np.ones(i.size, dtype=bool)
    par = np.abs(e) > tol1
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        r = (xf - nfc) * (fx - ffulc)
        q = (xf - fulc) * (fx - fnfc)
        p = (xf - fulc) * q - (xf - nfc) * r
        q = 2.0 * (q - r)
        p = np.where(q > 0.0, -p, p)
        q = np.abs(q)
        r = e.copy()
        e = np.where(par, rat, e)
        ok = par & (np.abs(p) < np.abs(0.5 * q * r)) & (p > q * (a - xf)) & (p < q * (b - xf))
        rat = np.where(ok, (p + 0.0) / q, rat)
    x = xf + rat
    near = ok & (((x - a) < tol2) | ((b - x) < tol2))
    rat = np.where(near, tol1 * (np.sign(xm - xf) + ((xm - xf) == 0)), rat)
    golden &= ~ok
    e = np.where(golden, np.where(xf >= xm, a - xf, b - xf), e)
    rat = np.where(golden, _GOLDEN * e, rat)
    st["e"][i], st["rat"][i] = e, rat
    return xf + (np.sign(rat) + (rat == 0)) * np.maximum(np.abs(rat), tol1)


def _take(st, i, x, fu, xatol):
    """scipy's bookkeeping after f(x) = fu for the searches ``i``, element-wise."""
    a, b, xf, fx = st["a"][i], st["b"][i], st["xf"][i], st["fx"][i]
    nfc, fnfc, fulc, ffulc = st["nfc"][i], st["fnfc"][i], st["fulc"][i], st["ffulc"][i]
    better = fu <= fx
    worse = ~better
    c1 = worse & ((fu <= fnfc) | (nfc == xf))
    c2 = worse & ~c1 & ((fu <= ffulc) | (fulc == xf) | (fulc == nfc))
    st["a"][i] = np.where(better, np.where(x >= xf, xf, a), np.where(x < xf, x, a))
    st["b"][i] = np.where(better, np.where(x >= xf, b, xf), np.where(x < xf, b, x))
    st["fulc"][i] = np.where(better | c1, nfc, np.where(c2, x, fulc))
    st["ffulc"][i] = np.where(better | c1, fnfc, np.where(c2, fu, ffulc))
    st["nfc"][i] = np.where(better, xf, np.where(c1, x, nfc))
    st["fnfc"][i] = np.where(better, fx, np.where(c1, fu, fnfc))
    st["xf"][i] = np.where(better, x, xf)
    st["fx"][i] = np.where(better, fu, fx)
    st["fu"][i] = fu
    _tolerances(st, i, xatol)


def _tolerances(st, i, xatol):
    st["xm"][i] = 0.5 * (st["a"][i] + st["b"][i])
    st["tol1"][i] = _SQRT_EPS * np.abs(st["xf"][i]) + xatol / 3.0
    st["tol2"][i] = 2.0 * st["tol1"][i]


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
    fulc = lo + _GOLDEN * (hi - lo)
    st = {"a": lo.copy(), "b": hi.copy(), "fulc": fulc, "nfc": fulc.copy(), "xf": fulc.copy(), "rat": np.zeros(B),
          "e": np.zeros(B), "fu": np.full(B, np.inf), "xm": np.empty(B), "tol1": np.empty(B), "tol2": np.empty(B)}
    everyone = np.arange(B)
    fx = np.asarray(fun(everyone, fulc.copy()), dtype=float) if B else np.empty(0)
    st.update(fx=fx.copy(), ffulc=fx.copy(), fnfc=fx.copy())
    _tolerances(st, everyone, xatol)
    num = np.ones(B, dtype=np.int64)
    flag = np.zeros(B, dtype=np.int64)
    active = np.abs(st["xf"] - st["xm"]) > (st["tol2"] - 0.5 * (st["b"] - st["a"]))
    while active.any():
        i = np.nonzero(active)[0]
        x = _step_points(st, i, xatol)
        _take(st, i, x, np.asarray(fun(i, x), dtype=float), xatol)
        num[i] += 1
        done = num[i] >= maxiter
        flag[i[done]] = 1
        active[i] = ~done & (np.abs(st["xf"][i] - st["xm"][i]) > (st["tol2"][i] - 0.5 * (st["b"][i] - st["a"][i])))
    flag[np.isnan(st["xf"]) | np.isnan(st["fx"]) | np.isnan(st["fu"])] = 2
    return BoundedSearchResult(x=st["xf"], fun=st["fx"], nfev=num, status=flag)
