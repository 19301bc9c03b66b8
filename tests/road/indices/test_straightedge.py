"""Rolling straightedge simulation: oracles are closed forms on a sine and a step (midpoint-chord geometry)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.road import Profile
from longprofile.road.indices._straightedge import STRAIGHTEDGE_10FT, rolling_straightedge


@settings(max_examples=25)
@given(wavelength=st.floats(1.0, 30.0), amp=st.floats(1e-4, 1e-2))
def test_sine_closed_form(wavelength, amp):
    # Oracle: d(x) = A (1 - cos(pi L / lambda)) sin(2 pi x / lambda) for z = A sin(2 pi x / lambda).
    dx = 0.0254
    x = np.arange(0, 60.0, dx)
    k = 2 * np.pi / wavelength
    res = rolling_straightedge(Profile(distance=x, elevation=amp * np.sin(k * x)), length=STRAIGHTEDGE_10FT)
    expected = amp * (1 - np.cos(k * STRAIGHTEDGE_10FT / 2)) * np.sin(k * res.station)
    # supports fall between samples: linear interpolation error <= A k^2 dx^2 / 8
    assert np.max(np.abs(res.deviation[:, 0] - expected)) <= amp * k * k * dx * dx / 8 * 1.01 + 1e-15


def test_step_gives_half_height_and_defects():
    # Oracle: a step h at x0 puts the chord at h/2 for centres within L/2 of it: +h/2 after, -h/2 before.
    x = np.arange(0, 20.0, 0.05)
    h = 0.01
    z = np.where(x >= 10.0, h, 0.0)
    res = rolling_straightedge(Profile(distance=x, elevation=z), length=2.0, threshold=0.004)
    c, d = res.station, res.deviation[:, 0]
    assert np.allclose(d[(c >= 10.0) & (c < 11.0 - 1e-9)], h / 2)
    assert np.allclose(d[(c < 10.0 - 0.05 - 1e-9) & (c > 9.0 + 1e-9)], -h / 2, atol=1e-12)
    assert np.allclose(d[(c < 8.9) | (c > 11.1)], 0.0)
    (defect,) = res.defects  # one contiguous run of |d| > threshold around the step
    assert defect.start == pytest.approx(9.0) and defect.end == pytest.approx(10.95)
    assert abs(defect.peak_deviation) == pytest.approx(h / 2)
    assert res.max_abs_deviation[0] == pytest.approx(h / 2)


def test_straight_line_has_no_deviation_and_irregular_ok():
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.uniform(0.01, 0.05, 2000))
    res = rolling_straightedge(Profile(distance=x, elevation=0.02 * x + 3.0))
    assert np.max(np.abs(res.deviation)) < 1e-12


def test_errors():
    x = np.arange(0, 2.0, 0.1)
    with pytest.raises(InputError, match="shorter than the straightedge"):
        rolling_straightedge(Profile(distance=x, elevation=x * 0), length=3.048)
    with pytest.raises(InputError):
        rolling_straightedge(Profile(distance=x, elevation=x * 0), length=-1)
