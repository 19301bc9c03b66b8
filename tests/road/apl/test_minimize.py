"""The bounded scalar minimiser of the q/r fit (Brent 1973, ch. 5), against scipy.optimize's as the oracle.

``road reconstruct`` no longer imports scipy.optimize (0.18-0.23 s of start-up, issue 12): the private
minimiser must find what scipy's ``minimize_scalar(method="bounded")`` finds, on test functions and on the
likelihood search of :func:`fit_noise_variances`.
"""

from __future__ import annotations

import math
import warnings

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from longprofile.errors import InputError
from longprofile.road.apl import _deconvolution, apl_model, fit_noise_variances, simulate_apl_recording
from longprofile.road.apl._minimize import minimize_bounded


def _scipy(f, a, b, xatol):
    with warnings.catch_warnings():  # scipy's parabola through an infinite value warns; ours stays quiet
        warnings.simplefilter("ignore", RuntimeWarning)
        return minimize_scalar(f, bounds=(a, b), method="bounded", options={"xatol": xatol})


def _shape(kind, centre, width, scale):
    """A smooth unimodal function with its minimum at ``centre`` (at a bound when centre is outside)."""
    if kind == "quartic":
        return lambda x: scale * (((x - centre) / width) ** 4 + 0.3 * ((x - centre) / width) ** 2)
    if kind == "flat-quartic":
        return lambda x: scale * ((x - centre) / width) ** 4
    if kind == "log-cosh":  # |z| - log 2 beyond |z| = 300, where cosh overflows (equal to round-off there)
        return lambda x: scale * (math.log(math.cosh(z)) if abs(z := (x - centre) / width) < 300
                                  else abs(z) - math.log(2))
    return lambda x: scale * math.exp(min((x - centre) / width, 700.0))  # "exp": monotone, minimum at a


@settings(max_examples=300, deadline=None)
@given(kind=st.sampled_from(["quartic", "flat-quartic", "log-cosh", "exp"]),
       a=st.floats(-100.0, 100.0), log_length=st.floats(-2.0, 2.0), where=st.floats(-0.5, 1.5),
       log_width=st.floats(-1.5, 0.5), log_scale=st.floats(-3.0, 3.0), log_xatol=st.floats(-6.0, -2.0))
def test_the_minimiser_finds_what_scipy_finds(kind, a, log_length, where, log_width, log_scale, log_xatol):
    length, xatol = 10.0 ** log_length, 10.0 ** log_xatol
    b = a + length
    f = _shape(kind, a + where * length, length * 10.0 ** log_width, 10.0 ** log_scale)
    ours, ref = minimize_bounded(f, a, b, xatol=xatol), _scipy(f, a, b, xatol)
    assert ours.success and ref.success
    assert a <= ours.x <= b and ours.fun == f(ours.x)
    at_same_bound = any(abs(ours.x - e) <= xatol and abs(ref.x - e) <= xatol for e in (a, b))
    assert abs(ours.x - ref.x) <= 2 * xatol or at_same_bound, (ours, ref.x)
    # within 2 xatol of scipy's x, so no higher than f rises over that distance from it
    rise = max(f(min(max(ref.x + s * 2 * xatol, a), b)) for s in (-1.0, 1.0)) - ref.fun
    assert ours.fun <= ref.fun + rise + 1e-12 * abs(ref.fun), (ours, ref.x, ref.fun)
    assert ours.nfev <= ref.nfev + 3  # no dearer than scipy's


def test_infeasible_points_are_never_chosen_and_raise_no_warning():
    # the likelihood search's NotDetectableError region (neg returns inf)
    f = lambda x: math.inf if x < -1.0 else (x - 0.5) ** 2  # noqa: E731
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = minimize_bounded(f, -8.0, 4.0, xatol=1e-3)
    assert res.success and abs(res.x - 0.5) <= 1e-3 and math.isfinite(res.fun)
    everywhere = minimize_bounded(lambda x: math.inf, -1.0, 1.0, xatol=1e-3)
    assert everywhere.fun == math.inf  # the caller raises ConvergenceError for it, as with scipy's


@pytest.mark.parametrize("a, b, xatol", [(1.0, 1.0, 1e-3), (2.0, 1.0, 1e-3), (0.0, math.inf, 1e-3),
                                         (0.0, 1.0, 0.0), (0.0, 1.0, math.nan)])
def test_bad_interval_or_tolerance_is_one_clear_error(a, b, xatol):
    with pytest.raises(InputError, match="interval|xatol"):
        minimize_bounded(lambda x: x * x, a, b, xatol=xatol)


def test_the_evaluation_budget_is_kept():
    res = minimize_bounded(lambda x: abs(x - 0.3), 0.0, 1.0, xatol=1e-12, maxiter=5)
    assert res.nfev == 6 and not res.success


# ---- fit_noise_variances: the q, r scipy's minimiser gave -----------------------------------------------------
#: log10(q / r) is searched with xatol = 1e-3, so the bound allowed is one xatol in the ratio (0.23 %). Measured
#: 2026-12-07 on these three records and on class B 1 km, class E 2 km: identical q, r and likelihood (difference 0).
RATIO_RTOL = 10.0 ** 1e-3 - 1.0


@pytest.mark.parametrize("length, road_class, seed", [(300.0, "C", 1), (1000.0, "C", 0), (1000.0, "D", 7)])
def test_noise_fit_equals_the_fit_with_scipys_minimiser(length, road_class, seed, monkeypatch):
    m = apl_model(20.0, 0.05)
    y = simulate_apl_recording("iso8608", m, length=length, road_class=road_class, rng=seed).signal
    ours = fit_noise_variances(y, m)
    monkeypatch.setattr(_deconvolution, "minimize_bounded",
                        lambda f, a, b, xatol: _scipy(f, a, b, xatol))
    ref = fit_noise_variances(y, m)
    assert ours.converged and ref.converged
    assert abs((ours.q / ours.r) / (ref.q / ref.r) - 1.0) < RATIO_RTOL
    assert ours.r == pytest.approx(ref.r, rel=RATIO_RTOL) and ours.q == pytest.approx(ref.q, rel=RATIO_RTOL)
    assert ours.log_likelihood >= ref.log_likelihood - 1e-9 * abs(ref.log_likelihood)
