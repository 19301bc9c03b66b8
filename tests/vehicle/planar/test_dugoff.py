"""Dugoff tyre model, paper 001 eq. (15)-(17)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.vehicle import dugoff_forces

CX0, CY0 = 6e4, 5e4


def _paper_formula(lam, alpha, fn, mu):
    """Eq. (15)-(17) exactly as printed (with 1/(1 - lambda) and k), scalar, independent of the kernel."""
    t = math.tan(alpha)
    den = 2.0 * math.sqrt(CX0 ** 2 * lam ** 2 + CY0 ** 2 * t ** 2)
    sigma = math.inf if den == 0 else (1 - lam) * mu * fn / den
    k = (2 - sigma) * sigma if sigma < 1 else 1.0
    return CX0 * lam / (1 - lam) * k, CY0 * t / (1 - lam) * k


slips = st.floats(-0.9, 0.9)
angles = st.floats(-1.2, 1.2)
loads = st.floats(0.0, 8000.0)
frictions = st.floats(0.05, 1.2)


@settings(max_examples=200, deadline=None)
@given(slips, angles, loads, frictions)
def test_matches_paper_formula(lam, alpha, fn, mu):
    f = dugoff_forces(lam, alpha, fn, mu, longitudinal_stiffness=CX0, cornering_stiffness=CY0)
    fx, fy = _paper_formula(lam, alpha, fn, mu)
    assert float(f.longitudinal) == pytest.approx(fx, rel=1e-9, abs=1e-7)
    assert float(f.lateral) == pytest.approx(fy, rel=1e-9, abs=1e-7)


@settings(max_examples=200, deadline=None)
@given(slips, angles, loads, frictions)
def test_resultant_never_exceeds_adhesion(lam, alpha, fn, mu):
    # |F| = (mu Fn / 2)(2 - sigma) when sigma < 1 and <= mu Fn / 2 otherwise: always <= mu Fn
    f = dugoff_forces(lam, alpha, fn, mu, longitudinal_stiffness=CX0, cornering_stiffness=CY0)
    assert math.hypot(float(f.longitudinal), float(f.lateral)) <= mu * fn * (1 + 1e-12) + 1e-9


def test_linear_region_and_symmetry():
    lam = np.array([1e-4, -1e-4, 0.0, 0.0])
    alpha = np.array([0.0, 0.0, 1e-4, -1e-4])
    f = dugoff_forces(lam, alpha, 4000.0, 0.9, longitudinal_stiffness=CX0, cornering_stiffness=CY0)
    np.testing.assert_allclose(f.longitudinal[:2], CX0 * lam[:2], rtol=2e-4)
    np.testing.assert_allclose(f.lateral[2:], CY0 * alpha[2:], rtol=2e-4)
    assert f.lateral[2] == -f.lateral[3]
    # saturation: a locked wheel (slip -1) gives at most mu Fn
    locked = dugoff_forces(-1.0, 0.0, 4000.0, 0.9, longitudinal_stiffness=CX0, cornering_stiffness=CY0)
    assert -0.9 * 4000.0 <= float(locked.longitudinal) < -0.8 * 0.9 * 4000.0


def test_broadcasting_shape():
    f = dugoff_forces(np.zeros((3, 4)) + 0.01, 0.02, np.full(4, 4000.0), 0.8,
                      longitudinal_stiffness=CX0, cornering_stiffness=CY0)
    assert f.longitudinal.shape == (3, 4) and f.lateral.shape == (3, 4)


@pytest.mark.parametrize("kw, message", [
    (dict(slip=1.0), "slip must be in \\[-1, 1\\)"),
    (dict(slip_angle=2.0), "slip_angle must be in"),
    (dict(normal_force=-1.0), "normal_force must be >= 0"),
    (dict(friction=0.0), "friction must be > 0"),
    (dict(slip=float("nan")), "slip must be finite"),
])
def test_invalid_inputs(kw, message):
    args = dict(slip=0.01, slip_angle=0.01, normal_force=4000.0, friction=0.8) | kw
    with pytest.raises(InputError, match=message):
        dugoff_forces(args["slip"], args["slip_angle"], args["normal_force"], args["friction"],
                      longitudinal_stiffness=CX0, cornering_stiffness=CY0)
    with pytest.raises(InputError, match="cornering_stiffness must be finite and > 0"):
        dugoff_forces(0.0, 0.0, 1.0, 1.0, longitudinal_stiffness=CX0, cornering_stiffness=0.0)
