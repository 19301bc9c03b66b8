"""Joint faulting from profile. Oracle: synthetic jointed slabs (grade + known steps at known joints), where the
fault is known exactly; with noise, the least-squares standard error of the step bounds the error."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.road import Profile
from longprofile.road.indices._faulting import joint_faulting


def _slabs(faults, spacing=4.5, dx=0.019, grade=0.02, noise=0.0, seed=0):
    x = np.arange(0, spacing * (len(faults) + 1), dx)
    joints = spacing * np.arange(1, len(faults) + 1)
    z = grade * x + 100.0
    for j, f in zip(joints, faults):
        z -= f * (x > j)  # positive fault: the leave slab is lower
    z += np.random.default_rng(seed).normal(0, noise, x.size)
    return Profile(distance=x, elevation=z), joints


@settings(max_examples=20, deadline=None)
@given(faults=st.lists(st.floats(-0.01, 0.01), min_size=1, max_size=6), grade=st.floats(-0.06, 0.06))
def test_exact_steps_on_a_grade(faults, grade):
    prof, joints = _slabs(faults, grade=grade)
    res = joint_faulting(prof, joints)
    assert np.allclose(res.joints.fault_m, faults, atol=1e-9)
    assert res.mean_fault["left"] == pytest.approx(np.mean(faults), abs=1e-9)


def test_noise_within_least_squares_error():
    faults = [0.003, -0.002, 0.0045, 0.001, 0.0]
    noise = 2e-4
    prof, joints = _slabs(faults, noise=noise, seed=4)
    res = joint_faulting(prof, joints, window=0.3, gap=0.05)
    # std of the step estimate ~ noise * sqrt(1/n_a + 1/n_b + ...) ~ noise * sqrt(2 / 15) * ~2 (slope term)
    assert np.max(np.abs(res.joints.fault_m - faults)) < 4 * noise * np.sqrt(4 / 15)


def test_bad_joints():
    prof, _ = _slabs([0.001])
    with pytest.raises(InputError, match="outside the profile"):
        joint_faulting(prof, [100.0])
    with pytest.raises(InputError, match="fewer than 2 samples"):
        joint_faulting(prof, [4.5], window=0.01)


def test_step_statistic_equals_joint_faulting_at_every_station():
    # Oracle: the vectorised normal equations against numpy.linalg.lstsq of joint_faulting, station by station
    from longprofile.road.indices._faulting import step_statistic

    prof, _ = _slabs([0.002, -0.003], noise=1e-4, seed=1, dx=0.025)
    st, f = step_statistic(prof, "left")
    some = st[::97]
    res = joint_faulting(prof, some)
    assert np.allclose(f[::97], res.joints.fault_m, rtol=1e-7, atol=1e-12)


@settings(max_examples=15, deadline=None)
@given(faults=st.lists(st.floats(0.002, 0.01) | st.floats(-0.01, -0.002), min_size=1, max_size=5))
def test_find_joints_locates_faulted_joints(faults):
    from longprofile.road.indices._faulting import find_joints

    prof, joints = _slabs(faults, dx=0.025, noise=5e-5, seed=len(faults))
    found = find_joints(prof, "left", min_fault=1e-3)
    assert found.size == len(joints)
    assert np.max(np.abs(found - joints)) <= 0.025 + 1e-9  # within one sample
    smooth, _ = _slabs([0.0] * len(faults), dx=0.025, noise=5e-5)
    assert find_joints(smooth, "left", min_fault=1e-3).size == 0
