"""The joint EKF's grade band with its own NIS floor (issue 13, 2026-12-06 afternoon; docs/vehicle-slope.md, "The
joint grade's NIS floor"): ``SlopeUncertainty.grade_nis_floor`` 0.01 instead of ``nis_floor`` 0.1;
``SlopeUncertainty.until_2026_12_06_pm()`` gives the estimator of that morning."""

import numpy as np
import pytest

from longprofile.errors import InputError
from longprofile.vehicle import (
    SlopeUncertainty,
    drive_scenario,
    estimate_slope,
    simulate_drive,
)
from longprofile.vehicle.planar._estimate import nis_inflation
from tests._fingerprint import assert_same_fingerprint, fingerprint

from ._bands import CAR, Z90, hill_drive, slope_outputs

#: fingerprint (tests/_fingerprint.py) of estimate_slope's outputs at b4ad596 (the morning of 2026-12-06, default
#: SlopeUncertainty then), hill drive of 10 s, gyro offset 2e-3 rad/s, seed 4, both methods
MORNING = {
    'cascade.slope': ([10000], 'fb701ba16878b120',
        [84.23547653824392, 84.96381684304122, 84.81579832929137], 84.7409531286758),
    'cascade.slope_std': ([10000], 'fb701ba16878b120',
        [41.76809309867964, 41.996872290764955, 41.89689038233895], 41.965810524037536),
    'cascade.vx': ([10000], 'fb701ba16878b120',
        [155811.1225844089, 156481.05226385331, 156198.38716839076], 156475.17416462832),
    'cascade.vx_std': ([10000], 'fb701ba16878b120',
        [1558.396545133361, 1565.0964864129344, 1562.2698122219458], 1565.0381838905573),
    'cascade.vy': ([10000], 'fb701ba16878b120',
        [35.370956496837955, 35.66964567939885, 35.53209672441548], 35.64730215507106),
    'cascade.vy_std': ([10000], 'fb701ba16878b120',
        [180.34177609824764, 182.12218224658477, 181.32859981867907], 181.37013657816738),
    'cascade.yaw_rate': ([10000], 'fb701ba16878b120',
        [1.3045129082825022, 1.305208805898892, 1.3165810598788186], 7.617509436095352),
    'cascade.yaw_rate_std': ([10000], 'fb701ba16878b120',
        [10.490961211014735, 10.522635886695928, 10.516434791459485], 10.532634833991903),
    'joint.slope': ([10000], 'fb701ba16878b120',
        [97.43072623455551, 98.3138292797827, 98.11242572614601], 98.0361477924163),
    'joint.slope_std': ([10000], 'fb701ba16878b120',
        [43.885636123831674, 44.100013355076385, 44.02185386327987], 44.072040843300876),
    'joint.vx': ([10000], 'fb701ba16878b120',
        [155810.67788732165, 156480.6335944719, 156197.9799537056], 156474.76981441048),
    'joint.vx_std': ([10000], 'fb701ba16878b120',
        [1558.2547276231298, 1564.955167564162, 1562.128363490344], 1564.896347992662),
    'joint.vy': ([10000], 'fb701ba16878b120',
        [35.370565353834245, 35.669244456439735, 35.53171891400643], 35.64692066766159),
    'joint.vy_std': ([10000], 'fb701ba16878b120',
        [180.34152485773134, 182.1219280380408, 181.3283544216651], 181.3698830681785),
    'joint.yaw_rate': ([10000], 'fb701ba16878b120',
        [1.304513165611791, 1.3052103608472212, 1.3165817285213661], 7.6175149261707755),
    'joint.yaw_rate_std': ([10000], 'fb701ba16878b120',
        [10.490959249746496, 10.522633938037334, 10.516432702912674], 10.532632845235657),
}


@pytest.fixture(scope="module")
def hill():
    return hill_drive()


def test_until_2026_12_06_pm_reproduces_the_morning_and_the_new_default_moves_only_the_joint_grade_band(hill):
    assert_same_fingerprint(fingerprint(slope_outputs(hill.log, SlopeUncertainty.until_2026_12_06_pm())), MORNING)
    # the default of then; the yaw rate's band changed after (session 38, SlopeUncertainty.until_2026_12_07)
    new = slope_outputs(hill.log, SlopeUncertainty.until_2026_12_07())
    moved = "joint.slope_std"
    assert_same_fingerprint(fingerprint({k: v for k, v in new.items() if k != moved}),
                            {k: v for k, v in MORNING.items() if k != moved})
    with pytest.raises(AssertionError):
        assert_same_fingerprint(fingerprint({moved: new[moved]}), {moved: MORNING[moved]})


def test_the_grade_floor_replaces_nis_floor_in_the_joint_grade_variance_only(hill):
    """Without the force correction (no block scatter in the band) the joint's variance of sin(theta) differs between
    the floors 0.1 and 0.01 by exactly P_theta (max(NIS, 0.1) - max(NIS, 0.01)) cos^2: >= 0, and > 0 at most samples
    of this drive (its windowed V_x NIS is below 0.1 there, the finding behind the change)."""
    kw = dict(method="joint", force_correction=False)
    old = estimate_slope(hill.log, CAR, uncertainty=SlopeUncertainty(grade_nis_floor=None), **kw)
    new = estimate_slope(hill.log, CAR, **kw)
    np.testing.assert_array_equal(old.slope, new.slope)
    for k in ("vx_std", "vy_std", "yaw_rate_std"):
        np.testing.assert_array_equal(getattr(old, k), getattr(new, k))
    f = new.filtered
    raw = nis_inflation(f.innovation, f.innovation_cov, 1000, floor=1e-12)[:, 0]
    c2 = np.cos(new.slope) ** 2
    expected = f.cov[:, 3, 3] * (np.maximum(raw, 0.1) - np.maximum(raw, 0.01)) * c2
    diff = (old.slope_std ** 2 - new.slope_std ** 2) * c2
    np.testing.assert_allclose(diff, expected, rtol=1e-6, atol=1e-15)
    assert np.mean(raw < 0.1) > 0.5
    assert np.all(diff >= -1e-15) and np.mean(diff > 0) > 0.5


@pytest.mark.parametrize("seed", [0, 1])
def test_with_the_force_correction_the_band_narrows_but_keeps_the_block_scatter(seed):
    """The new band is at most the old one, narrower at a good part of the samples of the own car's hill drive
    (42 % when written; median 0.93x), at least the force fit's block scatter (the larger of filter and scatter:
    residual_overlap), and still covers that drive at >= 85 %."""
    sim = simulate_drive(drive_scenario("hill", duration=20.0), CAR, seed=seed)
    old = estimate_slope(sim.log, CAR, method="joint", uncertainty=SlopeUncertainty.until_2026_12_06_pm())
    new = estimate_slope(sim.log, CAR, method="joint")
    np.testing.assert_array_equal(old.slope, new.slope)
    assert np.all(new.slope_std <= old.slope_std * (1 + 1e-12))
    assert np.mean(new.slope_std < old.slope_std * (1 - 1e-6)) > 0.3
    assert np.median(new.slope_std) < 0.97 * np.median(old.slope_std)
    c2 = np.cos(new.slope) ** 2
    assert np.all(new.slope_std ** 2 * c2 >= new.force_fit.residual_std ** 2 * (1 - 1e-9))
    keep = sim.log.time >= 2.0
    inside = np.abs(new.slope - sim.truth.slope)[keep] <= Z90 * new.slope_std[keep]
    assert np.mean(inside) >= 0.85


def test_grade_nis_floor_is_checked_and_defaults():
    assert SlopeUncertainty().grade_floor == 0.01
    assert SlopeUncertainty(grade_nis_floor=None).grade_floor == SlopeUncertainty().nis_floor
    assert SlopeUncertainty.noise_only().grade_floor == 1.0
    assert SlopeUncertainty.until_2026_12_06().grade_floor == 0.1
    assert SlopeUncertainty.until_2026_12_06_pm() == SlopeUncertainty(grade_nis_floor=None, unverified_accel_offset_std=None,
                                                                    unverified_gyro_offset_std=None,
                                                                    yaw_rate_from_gain=False)
    for bad in (0.0, -0.1, 1.5, float("nan"), True, "0.1"):
        with pytest.raises(InputError, match="grade_nis_floor"):
            SlopeUncertainty(grade_nis_floor=bad)
