"""End anchors of the health tests' prediction (docs/rail.md, "Sensor health on settlements that are not a bowl")."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.rail import SettlementSettings
from longprofile.rail._settle import HEALTH_ANCHOR_DECADES, _running_median3, fit_end_anchor


def _slopes(seed, kind, D=20, N=31, noise=1e-5):
    """Daily slope changes (rad) of a settlement growing linearly over the days: a Gaussian bowl inside the span or a
    uniform tilt of the whole span (a rigid rotation: every sensor's angle changes by the same amount)."""
    rng = np.random.default_rng(seed)
    x = np.cumsum(np.r_[0.0, rng.uniform(2.0, 4.0, N - 1)])
    grow = np.linspace(0.0, 1.0, D)[:, None]
    depth = rng.uniform(5e-3, 2e-2)
    if kind == "bowl":
        c, w = rng.uniform(0.4, 0.6) * x[-1], rng.uniform(6.0, 12.0)
        u = (x - c) / w
        slope = depth * u / w * np.exp(-0.5 * u**2)  # derivative of -depth exp(-u^2/2)
    else:
        slope = np.full(N, -depth / x[-1])
    M = grow * slope[None, :] + noise * rng.standard_normal((D, N))
    M[0] = 0.0
    return x, M


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_fit_end_anchor_tilt_frees_ends_bowl_keeps_them(seed):
    x, tilt = _slopes(seed, "tilt")
    sz, ll = fit_end_anchor(x, tilt)
    assert ll.shape == (HEALTH_ANCHOR_DECADES + 1,)
    assert sz >= 1e-3  # the far end moves by 5-20 mm: the anchor at 10 um is rejected
    x, bowl = _slopes(seed, "bowl")
    sz, _ = fit_end_anchor(x, bowl)
    assert sz <= 1e-4  # white noise, ends that do not move: the anchor holds


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(seed=st.integers(0, 2**31 - 1), j=st.integers(1, 29), jump=st.floats(3e-4, 1e-3))
@example(seed=4842, j=1, jump=8.8e-4)  # next to an end: the end's median of two let half the jump through (session 27)
def test_fit_end_anchor_a_single_faulty_sensor_does_not_free_the_ends(seed, j, jump):
    # a detached sensor: a jump of 0.02-0.06 deg from mid-record on, alone; without the running median it moves the
    # slopes' integral by jump x spacing (~1-3 mm) and frees the ends. Away from the bowl's flanks only: a jump at
    # the flank's steepest sensor can pass the 3-point median and free the ends (seed 1, sensor 10; docs/rail.md)
    x, bowl = _slopes(seed, "bowl")
    assume(np.abs(bowl[-1, j - 1:j + 2]).max() < 0.1 * np.abs(bowl[-1]).max())
    bowl[10:, j] += jump
    assert fit_end_anchor(x, bowl)[0] <= 1e-4


def test_running_median3_ignores_one_sensor_and_keeps_a_shared_change():
    rng = np.random.default_rng(1)
    M = np.tile(np.linspace(-1.0, 1.0, 12), (4, 1)) + 1e-3 * rng.standard_normal((4, 12))
    M[:, 5] += 50.0
    M[:, 8] = np.nan
    out = _running_median3(M)
    assert np.all(np.isnan(out[:, 8]))
    assert np.all(np.abs(out[:, 5] - M[:, 4:7:2].mean(axis=1)) < 0.3)  # the spike is gone
    assert np.allclose(_running_median3(np.full((3, 7), 2.5)), 2.5)  # a uniform change (a tilt) is kept


def test_health_end_anchor_setting():
    assert SettlementSettings().health_end_anchor == "all-days"  # since 2026-12-06 (docs/rail.md)
    assert SettlementSettings.until_2026_12_06().health_end_anchor == "fixed"
    with pytest.raises(InputError):
        SettlementSettings(health_end_anchor="free")
