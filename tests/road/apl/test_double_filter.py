"""Double filtering (paper 000, §3, eqs. 4-5)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, UnitsError
from longprofile.road import Profile
from longprofile.road.apl._double_filter import double_filter
from longprofile.road.apl._model import apl_model, apl_response, frequency_response
from longprofile.road.apl._synthetic import bump_profile, crenel_profile


@settings(max_examples=10, deadline=None)
@given(st.floats(0.5, 30.0))
def test_sinusoid_gets_magnitude_squared_and_zero_phase(f_hz):
    m = apl_model(20.0, 0.05)
    n = 40000
    t = np.arange(n) * m.dt
    u = np.sin(2 * np.pi * f_hz * t)
    g = double_filter(apl_response(u, m), m)
    mid = slice(n // 4, 3 * n // 4)
    # least-squares fit of a sin + b cos on the middle: b ~ 0 (zero phase), a ~ |H|^2
    X = np.c_[np.sin(2 * np.pi * f_hz * t[mid]), np.cos(2 * np.pi * f_hz * t[mid])]
    a, b = np.linalg.lstsq(X, g[mid], rcond=None)[0]
    H2 = frequency_response(m, [f_hz]).magnitude[0] ** 2
    assert a == pytest.approx(H2, abs=2e-3)
    assert abs(b) < 2e-3


def test_transfer_is_exactly_h_times_h_reversed():
    m = apl_model(20.0, 0.15)
    x = np.zeros(4001)
    x[2000] = 1.0
    g = double_filter(apl_response(x, m, initial="rest"), m, initial="rest")
    # impulse response of H(z^-1) H(z) is the autocorrelation of h: symmetric about the impulse
    assert np.allclose(g[2000 - 500:2000], g[2001:2501][::-1], atol=1e-12)
    h = apl_response(np.r_[1.0, np.zeros(3000)], m, initial="rest")
    assert g[2000] == pytest.approx(np.sum(h * h), rel=1e-9)


def _symmetry_centre(g, lo, hi):
    """Centre (in samples, may be half-integer) about which g is most symmetric, and the asymmetry there."""
    best = (np.inf, None)
    half = min(lo, g.size - 1 - hi)
    for c2 in range(2 * lo, 2 * hi + 1):  # candidate centre c2 / 2
        left = g[(c2 - 1) // 2 - np.arange(half) if c2 % 2 else c2 // 2 - 1 - np.arange(half)]
        right = g[(c2 + 1) // 2 + np.arange(half) if c2 % 2 else c2 // 2 + 1 + np.arange(half)]
        asym = np.max(np.abs(left - right))
        if asym < best[0]:
            best = (asym, c2 / 2)
    return best[1], best[0] / np.max(np.abs(g))


@pytest.mark.parametrize("make", [lambda: bump_profile(400.0, 0.05, width=10.0, height=0.02),
                                  lambda: crenel_profile(400.0, 0.05, width=10.0, height=0.01)])
def test_symmetric_defect_gives_symmetric_centred_image(make):
    p = make()
    m = apl_model(20.0, 0.05)
    y = apl_response(p, m)
    g = double_filter(y, m).elevation[:, 0]
    z = p.elevation[:, 0]
    centre_true = np.sum(np.arange(z.size) * np.abs(z)) / np.sum(np.abs(z))  # in samples
    lo, hi = int(centre_true) - 100, int(centre_true) + 100
    c, asym = _symmetry_centre(g, lo, hi)
    assert abs(c - centre_true) <= 1.0  # location error <= 1 sample
    assert asym < 1e-3
    # the raw APL image is neither symmetric nor centred (phase distortion)
    cy, asym_y = _symmetry_centre(y.elevation[:, 0], lo, hi)
    assert asym_y > 0.1


def test_errors():
    m = apl_model()
    with pytest.raises(UnitsError):
        double_filter(Profile(np.arange(10) * 0.1, np.zeros(10)), m)
    z = np.zeros(10)
    z[3] = np.nan
    with pytest.raises(InputError, match="missing"):
        double_filter(Profile(np.arange(10) * 0.05, z), m)
