"""Bounded scalar minimisation by Brent's method (golden section with parabolic interpolation).

R. P. Brent, *Algorithms for Minimization without Derivatives*, Prentice-Hall, 1973, chapter 5 (procedure
``localmin``). Used by :func:`~longprofile.road.apl.fit_noise_variances` to search log10(q / r).

Why not :func:`scipy.optimize.minimize_scalar` (``method="bounded"``, the same algorithm): importing
``scipy.optimize`` pulls its linear-programming (HiGHS), FFT, special-function, spatial and sparse-solver modules, and
costs 0.18-0.28 s of CPU even after numpy, pandas, scipy.linalg and numba are loaded (issue 12, measured 2026-12-07,
five runs) for a one-dimensional search of about ten evaluations. Every ``longprofile road reconstruct`` method paid
it. On the q/r fits of simulated records the two give the same q and r to the last bit
(tests/road/apl/test_minimize.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from ...errors import InputError

__all__ = ["ScalarMinimum", "minimize_bounded"]

#: The golden-section fraction (3 - sqrt 5) / 2 = 1 - 1/phi: the share of an interval a golden step covers.
GOLDEN = (3.0 - math.sqrt(5.0)) / 2.0
#: Relative part of the tolerance: sqrt of the double precision epsilon, the value Brent (1973, ch. 5) advises.
RELATIVE_TOLERANCE = math.sqrt(2.0 ** -52)


@dataclass(frozen=True)
class ScalarMinimum:
    """Result of :func:`minimize_bounded`.

    Attributes
    ----------
    x : float
        The minimiser found.
    fun : float
        f(x) (not recomputed: the value of the evaluation at x).
    nfev : int
        Number of evaluations of f.
    success : bool
        True when the interval shrank below the tolerance within ``maxiter`` evaluations and f(x) is not NaN.
    """

    x: float
    fun: float
    nfev: int
    success: bool


def _parabolic_step(x, w, v, fx, fw, fv):
    """(p, q) with p / q the step from x to the vertex of the parabola through (x, fx), (w, fw), (v, fv).

    q >= 0 (the sign is carried by p). NaN when a value is infinite: every test on the step then fails and
    the caller takes a golden-section step.
    """
    xw, xv = x - w, x - v
    dw, dv = xw * (fx - fv), xv * (fx - fw)
    p = xv * dv - xw * dw
    q = 2.0 * (dv - dw)
    return (-p, q) if q > 0.0 else (p, -q)


def minimize_bounded(fun: Callable[[float], float], a: float, b: float, *, xatol: float = 1e-5,
                     maxiter: int = 500) -> ScalarMinimum:
    """Minimise a function of one variable on [a, b] by Brent's method (Brent 1973, ch. 5).

    Each step is a parabolic interpolation through the three best points when it falls inside the bracket and
    shrinks the step taken two iterations before by at least half; otherwise a golden-section step into the larger
    part of the bracket. No point is evaluated closer than the tolerance to a point already evaluated or to a, b.
    For a unimodal f the result is within about xatol of the minimiser (of a or b when the minimum is at a bound);
    for any f it is a local minimum to that tolerance.

    Parameters
    ----------
    fun : callable
        f(x) -> float. May return inf (an infeasible point: never chosen over a finite value) or NaN.
    a, b : float
        The interval, a < b, both finite.
    xatol : float
        Absolute tolerance on x, > 0. Brent's tolerance is tol = sqrt(eps) |x| + xatol / 3 and the search stops
        once the bracket around x satisfies max(x - a', b' - x) <= 2 tol, so the minimiser is within 2 tol
        (about 2/3 xatol for |x| << xatol / sqrt(eps)) of x.
    maxiter : int
        Most evaluations of f after the first.

    Returns
    -------
    ScalarMinimum

    Raises
    ------
    InputError
        If the interval or the tolerance is not valid.

    Notes
    -----
    ASSUMPTION: f is unimodal on [a, b] (true of the concentrated likelihood in log10(q / r) on the bracket the
    caller's grid gives); otherwise the result is some local minimum, as with any bracketing method.
    """
    a, b, xatol = float(a), float(b), float(xatol)
    if not (math.isfinite(a) and math.isfinite(b) and a < b):
        raise InputError(f"the search interval must be finite with a < b; got [{a}, {b}].")
    if not (xatol > 0.0 and math.isfinite(xatol)):
        raise InputError(f"xatol must be a positive number; got {xatol}.")
    x = w = v = a + GOLDEN * (b - a)
    fx = fw = fv = float(fun(x))
    nfev = 1
    d = e = 0.0  # the last step, and the one before it
    converged = False
    while nfev <= maxiter:
        mid = 0.5 * (a + b)
        tol = RELATIVE_TOLERANCE * abs(x) + xatol / 3.0
        if abs(x - mid) <= 2.0 * tol - 0.5 * (b - a):
            converged = True
            break
        golden = True
        if abs(e) > tol:
            p, q = _parabolic_step(x, w, v, fx, fw, fv)
            if abs(p) < abs(0.5 * q * e) and q * (a - x) < p < q * (b - x):
                e, d, golden = d, p / q, False
                if (x + d) - a < 2.0 * tol or b - (x + d) < 2.0 * tol:
                    d = tol if x < mid else -tol  # too close to an end: a minimal step towards the middle
        if golden:
            e = (b - x) if x < mid else (a - x)
            d = GOLDEN * e
        u = x + (d if abs(d) >= tol else math.copysign(tol, d))
        fu = float(fun(u))
        nfev += 1
        if fu <= fx:  # u is the new best: the bracket shrinks to the side of x that holds u
            if u < x:
                b = x
            else:
                a = x
            v, w, x, fv, fw, fx = w, x, u, fw, fx, fu
        else:  # x stays: u becomes an end of the bracket, and one of the two other points if it beats them
            if u < x:
                a = u
            else:
                b = u
            if fu <= fw or w == x:
                v, w, fv, fw = w, u, fw, fu
            elif fu <= fv or v == x or v == w:
                v, fv = u, fu
    return ScalarMinimum(x=x, fun=fx, nfev=nfev, success=converged and not math.isnan(fx))
