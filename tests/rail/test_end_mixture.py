"""The settlement's ends when one sensor carries the evidence (docs/rail.md, "The settlement's ends when one sensor
carries the evidence"; ``SettlementSettings.end_ambiguity``)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.rail import SettlementSettings, estimate_settlement, validate_site
from longprofile.rail._health import SensorHealth
from longprofile.rail._scenarios import SHAPE_FAMILIES, simulate_scenario
from longprofile.rail._settle import END_MIXTURE_WEIGHT, _restored_slopes

Z90 = 1.6449


def _site(family, seed):
    sc = simulate_scenario(SHAPE_FAMILIES[family] if family in SHAPE_FAMILIES else family, seed)
    return sc, validate_site(sc.sensors, sc.readings, sc.survey)


def _z(sc, res):
    return (res.dz[1:] - sc.truth.settlement[1:]) / res.dz_std[1:]


def test_a_step_seen_by_one_excluded_sensor_is_covered_by_the_mixture():
    """A joint step (calibration seed 303): the transition's only sensor (reversed by the scenario) is excluded, the
    far half fell 16.6 mm and the anchored bands claim 0 +/- 0.02 mm at the far end; the mixture covers it, with the
    same mean."""
    sc, site = _site("faults-joint-step", 303)
    off = estimate_settlement(site, n_monte_carlo=0)
    mix = estimate_settlement(site, n_monte_carlo=0, end_ambiguity="mixture")
    assert off.settings["end_mixture_weight"] == 0.0 and off.settings["settlement_sigma_z"] < 1e-4
    assert mix.settings["end_mixture_weight"] == END_MIXTURE_WEIGHT and mix.settings["end_mixture_sigma_z"] > 1e-4
    z_off, z_mix = _z(sc, off), _z(sc, mix)
    assert abs(z_off[-1, -1]) > 100.0  # the pinned far end, the truth 16.6 mm away
    assert abs(z_mix[-1, -1]) < Z90
    assert np.mean(np.abs(z_mix) <= Z90) > np.mean(np.abs(z_off) <= Z90) + 0.3
    assert np.sqrt(np.mean(z_mix**2)) < 2.0 < 100.0 < np.sqrt(np.mean(z_off**2))
    assert np.array_equal(mix.dz, off.dz)
    assert np.all(mix.dz_std >= off.dz_std)
    assert any("end_ambiguity='mixture'" in w for w in mix.warnings)


@pytest.mark.parametrize("family, seed", [("faults", 301), ("faults-tilt", 300)])
def test_mixture_never_narrows_a_band_nor_moves_the_mean(family, seed):
    """Mean and rate unchanged bit for bit, every std (daily, rate, maximum settlement's) at least the anchored one's;
    where all sensors together do not loosen the ends (the bowl site) the result is the anchored one bit for bit."""
    sc, site = _site(family, seed)
    off = estimate_settlement(site, n_monte_carlo=40)
    mix = estimate_settlement(site, n_monte_carlo=40, end_ambiguity="mixture")
    assert np.array_equal(mix.dz, off.dz) and np.array_equal(mix.smoothed.rate, off.smoothed.rate, equal_nan=True)
    assert np.all(mix.dz_std >= off.dz_std)
    assert np.all(mix.smoothed.rate_std[1:] >= off.smoothed.rate_std[1:])
    fired = mix.settings["end_mixture_weight"] > 0
    assert fired == (family == "faults-tilt")
    if not fired:
        for k in ("dz_std", "max_settlement_mean", "max_settlement_std", "max_settlement_lower",
                  "max_settlement_upper"):
            assert np.array_equal(getattr(mix, k), getattr(off, k), equal_nan=True)
        assert mix.warnings == off.warnings
    else:
        assert np.mean(np.abs(_z(sc, mix)) <= Z90) >= np.mean(np.abs(_z(sc, off)) <= Z90)


def test_until_2026_12_06_is_unchanged_by_the_option():
    """The older defaults ignore nothing they did not ignore before: with settlement_end_anchor="fixed" the mixture
    never applies (the step site, bit for bit)."""
    sc, site = _site("faults-joint-step", 303)
    old = estimate_settlement(site, SettlementSettings.until_2026_12_06(n_monte_carlo=20))
    mix = estimate_settlement(site, SettlementSettings.until_2026_12_06(n_monte_carlo=20, end_ambiguity="mixture"))
    for k in ("dz", "dz_std", "max_settlement_lower", "max_settlement_upper"):
        assert np.array_equal(getattr(old, k), getattr(mix, k), equal_nan=True)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(3, 9), d=st.integers(2, 6))
def test_restored_slopes(seed, n, d):
    """Every sensor back but the user's exclusions and the dead, frozen and late ones (NaN); those flagged reversed
    with the other sign; the input is not modified."""
    rng = np.random.default_rng(seed)
    M = rng.normal(size=(d, n))
    keep = M.copy()
    status = rng.choice(["ok", "reversed", "detached", "dead", "frozen", "late"], n).tolist()
    user = sorted(set(rng.integers(0, n, rng.integers(0, 3)).tolist()))
    health = SensorHealth(sensor_ids=[f"S{i}" for i in range(n)], status=np.array(status), detail=np.array([""] * n),
                          excluded=np.array([s != "ok" for s in status]), loo_score=np.ones(n))
    out = _restored_slopes(M, health, user)
    assert np.array_equal(M, keep)
    for j in range(n):
        if j in user or status[j] in ("dead", "frozen", "late"):
            assert np.isnan(out[:, j]).all()
        else:
            assert np.array_equal(out[:, j], -M[:, j] if status[j] == "reversed" else M[:, j])
