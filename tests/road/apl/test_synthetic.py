"""Synthetic profiles with known truth (paper 000 test shapes)."""

import numpy as np
import pytest

from longprofile.errors import InputError
from longprofile.road.apl._synthetic import (
    bump_profile,
    crenel_profile,
    sine_arcs_profile,
    speed_hump_profile,
    white_noise_profile,
)


def test_bump_dimensions_and_symmetry():
    p = bump_profile(60.0, 0.05, width=10.0, height=0.02)
    z = p.elevation[:, 0]
    assert z.max() == pytest.approx(0.02, rel=1e-6)
    support = p.distance[z > 0]
    assert support.max() - support.min() == pytest.approx(10.0, abs=0.11)
    assert np.allclose(z, z[::-1], atol=1e-12)  # centred bump on a symmetric grid
    for shape in ("half-sine", "triangle"):
        assert bump_profile(shape=shape).elevation.max() == pytest.approx(0.02, rel=1e-3)
    with pytest.raises(InputError, match="shape"):
        bump_profile(shape="square")


def test_crenels_fronts_and_alternation():
    p = crenel_profile(200.0, 0.05, width=10.0, height=0.01, n_crenels=5)
    z = p.elevation[:, 0]
    fronts = np.count_nonzero(np.diff(z) != 0)
    assert fronts == 10  # essai 1: 10 fronts
    assert set(np.round(np.unique(z), 6)) == {-0.01, 0.0, 0.01}
    with pytest.raises(InputError, match="does not fit"):
        crenel_profile(30.0, 0.05, n_crenels=5)


def test_speed_hump_and_sine_arcs():
    h = speed_hump_profile(width=5.0, height=0.05, ramp=0.5).elevation[:, 0]
    assert h.max() == pytest.approx(0.05)
    assert np.count_nonzero(h > 0) * 0.05 == pytest.approx(5.0, abs=0.15)
    s = sine_arcs_profile(n_arcs=5, arc_length=10.0, height=0.01).elevation[:, 0]
    assert s.min() >= 0 and s.max() == pytest.approx(0.01, rel=1e-3)
    # 5 separate arcs
    assert np.count_nonzero(np.diff((s > 0).astype(int)) == 1) == 5


def test_white_noise_is_seedable():
    a = white_noise_profile(rng=3).elevation
    assert np.array_equal(a, white_noise_profile(rng=3).elevation)
    assert a.std() == pytest.approx(0.005, rel=0.05)
    with pytest.raises(InputError, match="samples"):
        white_noise_profile(length=0.1, dx=0.05)
