"""Prediction-error identification (paper 000, §4): OE and ARMAX by Gauss-Newton, ARX start."""

import json

import numpy as np
import pytest
from scipy import signal, stats

from longprofile.errors import ConvergenceError, InputError, ShapeError
from longprofile.identify import fit_armax, fit_arx, fit_output_error, simulate_model, step_response
from longprofile.road.apl._model import paper_identified_model

N = 5000


def _crenels(amplitude=5.0):
    # essai 1: 5000 points, 10 fronts (Te = 7.5 ms)
    k = np.arange(N)
    u = np.where(((k + 250) // 500) % 2 == 1, amplitude, 0.0)
    assert np.count_nonzero(np.diff(u)) == 10
    return u


def _reduced_421():
    """§4.2.1 as printed, with its exact pole/zero cancellation at z = 1 removed (A(1) = B(1) = 0)."""
    m = paper_identified_model("4.2.1-crenels")
    a, ra = np.polydiv(m.denominator[::-1], [-1.0, 1.0])
    b, rb = np.polydiv(m.numerator[::-1], [-1.0, 1.0])
    assert abs(ra[-1]) < 1e-12 and abs(rb[-1]) < 1e-12
    b = b[::-1]
    return np.r_[0.0, b[b != 0]] if b[0] == 0 else b, a[::-1]


@pytest.mark.parametrize("seed", [0, 1])
def test_oe_crenels_estimate_in_99_percent_region(seed):
    b, a = _reduced_421()
    u = _crenels()
    y_true = signal.lfilter(b, a, u)
    y = y_true + np.random.default_rng(seed).normal(0.0, 0.14, N)
    est = fit_output_error(u, y, na=4, nb=4, nk=1, dt=7.5e-3)
    assert est.converged and est.stable
    theta0 = np.r_[b[1:], a[1:]]
    d = est.params - theta0
    chi2 = d @ np.linalg.solve(est.covariance, d)
    assert chi2 < stats.chi2.ppf(0.99, theta0.size)
    assert est.residual_std == pytest.approx(0.14, rel=0.05)
    # triple-differentiator step response: minimum about -0.5 (paper §4.2.2), same shape as the truth
    s = step_response(est, 3000)
    s_true = signal.lfilter(b, a, np.ones(3000))
    assert s.min() == pytest.approx(-0.5, abs=0.03)
    assert np.max(np.abs(s - s_true)) < 0.03
    assert est.fit_simulation > 75 and est.fit_prediction == pytest.approx(est.fit_simulation)
    assert est.poles.size == 4 and est.zeros.size == 3


def test_oe_paper_orders_551_on_the_printed_model():
    m = paper_identified_model("4.2.1-crenels")
    u = _crenels()
    y = signal.lfilter(m.numerator, m.denominator, u) + np.random.default_rng(4).normal(0.0, 0.14, N)
    est = fit_output_error(u, y, na=5, nb=5, nk=1, dt=7.5e-3)
    assert est.converged and est.stable
    assert est.residual_std == pytest.approx(0.1409, rel=0.05)  # paper: 0.1409
    assert step_response(est, 400).min() == pytest.approx(-0.5, abs=0.03)
    near_one = est.zeros[np.abs(est.zeros - 1) < 0.1]
    assert near_one.size >= 2  # the differentiators (one may cancel against the pole at 1)
    d = json.loads(json.dumps(est.to_dict()))
    assert d["orders"] == {"na": 5, "nb": 5, "nk": 1} and len(d["params"]) == 10


def test_arx_is_exact_on_noise_free_arx_data():
    rng = np.random.default_rng(0)
    a = np.array([1.0, -1.5, 0.7])
    b = np.array([0.0, 0.0, 1.0, 0.5])
    u = rng.normal(size=2000)
    y = signal.lfilter(b, a, u)
    est = fit_arx(u, y, na=2, nb=2, nk=2)
    assert np.allclose(est.denominator, a, atol=1e-10)
    assert np.allclose(est.numerator, b, atol=1e-10)


def test_armax_estimate_in_99_percent_region():
    rng = np.random.default_rng(2)
    a = np.array([1.0, -1.2, 0.5])
    b = np.array([0.0, 1.0, 0.4])
    c = np.array([1.0, 0.6])
    n = 6000
    u = np.sign(rng.normal(size=n))
    e = rng.normal(0, 0.3, n)
    y = signal.lfilter(b, a, u) + signal.lfilter(c, a, e)
    est = fit_armax(u, y, na=2, nb=2, nc=1, nk=1)
    assert est.converged and est.stable
    theta0 = np.r_[a[1:], b[1:], c[1:]]
    d = est.params - theta0
    assert d @ np.linalg.solve(est.covariance, d) < stats.chi2.ppf(0.99, theta0.size)
    assert est.residual_std == pytest.approx(0.3, rel=0.05)
    assert est.fit_prediction > est.fit_simulation  # the noise model helps one-step prediction
    assert np.allclose(simulate_model(est, u[:50]), signal.lfilter(est.numerator, est.denominator, u[:50]))


def test_non_converged_fit_is_reported_never_silent():
    b, a = _reduced_421()
    u = _crenels()
    y = signal.lfilter(b, a, u) + np.random.default_rng(0).normal(0.0, 0.14, N)
    with pytest.raises(ConvergenceError, match="did not converge|unstable"):
        fit_output_error(u, y, na=4, nb=4, nk=1, max_iterations=1)
    flagged = fit_output_error(u, y, na=4, nb=4, nk=1, max_iterations=1, on_failure="flag")
    assert not (flagged.converged and flagged.stable)


def test_input_errors():
    u = np.random.default_rng(0).normal(size=500)
    with pytest.raises(ShapeError, match="same length"):
        fit_output_error(u, u[:-1], na=2, nb=2)
    with pytest.raises(InputError, match="too few"):
        fit_output_error(u[:30], u[:30], na=5, nb=5)
    with pytest.raises(InputError, match="constant"):
        fit_arx(np.ones(500), u, na=1, nb=1)
    with pytest.raises(InputError, match="on_failure"):
        fit_output_error(u, u, na=1, nb=1, on_failure="ignore")
