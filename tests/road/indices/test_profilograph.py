"""Profilograph simulation and Profile Index.

Oracles (closed forms, independent of the implementation): the trace of a sine has the gain
|1 - mean_i exp(j k d_i)| with the phase of that complex number; a sine trace of amplitude a gives one scallop of
height a - b/2 per half wavelength, PI = 2 (a - b/2) / lambda; a single triangular bump of height h gives one
bump above a template lower than h and none above one higher.
"""

import numpy as np
import pytest

from longprofile.errors import InputError
from longprofile.road import Profile
from longprofile.road.indices._profilograph import (
    CALIFORNIA_WHEELS_FT,
    ProfilographTrace,
    profilograph_index,
    profilograph_trace,
)


@pytest.mark.parametrize("wavelength", [3.0, 7.62, 15.0, 40.0])
def test_trace_of_sine_closed_form(wavelength):
    dx = 0.0254
    x = np.arange(0, 200.0, dx)
    k = 2 * np.pi / wavelength
    tr = profilograph_trace(Profile(distance=x, elevation=1e-3 * np.sin(k * x)))
    d = np.array(CALIFORNIA_WHEELS_FT) * 0.3048
    g = 1 - np.mean(np.exp(1j * k * d))
    expected = 1e-3 * np.imag(g * np.exp(1j * k * tr.station))
    assert np.max(np.abs(tr.trace[:, 0] - expected)) < 1e-3 * (k * dx) ** 2  # linear-interpolation error bound
    assert tr.station[0] == pytest.approx(12.5 * 0.3048, abs=dx)


def _trace(s, y):
    return ProfilographTrace(station=s, trace=y[:, None], tracks=("left",), wheels=np.array([-1.0, 1.0]))


@pytest.mark.parametrize("band", [0.0, 0.2 * 0.0254])
def test_profile_index_of_sine_trace(band):
    dx, lam, a = 0.0254, 10.0, 5e-3
    s = np.arange(0, 1000.0 + dx / 2, dx)
    res = profilograph_index(_trace(s, a * np.sin(2 * np.pi * s / lam)), segment_length=100.0, blanking_band=band,
                        lowpass=None)
    expected = 2 * (a - band / 2) / lam * 1000.0  # m/km
    assert np.allclose(res.profile_index[:, 0], expected, rtol=0.01)


def test_scallop_below_minimum_height_not_counted():
    dx, lam, a = 0.0254, 10.0, 3e-3  # 3 mm - 2.54 mm = 0.46 mm < 0.03 in: not a scallop
    s = np.arange(0, 201.0, dx)
    res = profilograph_index(_trace(s, a * np.sin(2 * np.pi * s / lam)), segment_length=100.0, lowpass=None)
    assert np.all(res.profile_index == 0.0)


def test_small_scallops_not_counted_and_bumps():
    dx = 0.0254
    s = np.arange(0, 401.0, dx)
    y = 0.5e-3 * np.sin(2 * np.pi * s / 3.0)  # 0.5 mm: 0.5 - 2.54 < 0 -> inside the 0.2 in band
    h = 10e-3
    y = y + np.clip(h * (1 - np.abs(s - 200.0) / 2.0), 0, None)  # triangular bump, 10 mm high, 4 m base
    res = profilograph_index(_trace(s, y), segment_length=100.0, lowpass=None)
    assert res.profile_index[0, 0] == 0.0 and res.profile_index[3, 0] == 0.0
    assert res.profile_index[1, 0] > 0 or res.profile_index[2, 0] > 0
    assert len(res.bumps) == 1
    assert res.bumps.peak_m[0] == pytest.approx(200.0, abs=0.05)
    assert res.bumps.height_m[0] == pytest.approx(h, rel=0.1)
    none = profilograph_index(_trace(s, y), segment_length=100.0, lowpass=None, bump_template=(12e-3, 7.62))
    assert none.bumps.empty


def test_errors():
    x = np.arange(0, 5.0, 0.05)
    with pytest.raises(InputError, match="shorter than the profilograph frame"):
        profilograph_trace(Profile(distance=x, elevation=x * 0))
    s = np.arange(0, 50.0, 0.05)
    with pytest.raises(InputError, match="shorter than one segment"):
        profilograph_index(_trace(s, s * 0), segment_length=100.0)
