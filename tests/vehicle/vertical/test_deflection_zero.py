"""Suspension deflection sensors must read zero at the static ride height (session 37): the force-balance check.

Before, a 20 mm zero offset on every ``dz21_*`` of a 5 s configuration-3 log tripled the front-left tyre-load error
without a word. The mean deflection itself is no test (the asymmetric dampers pull the car down by 3-30 mm on rough
roads, on the simulator as on a real car), so the check balances the mean suspension forces.
"""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from longprofile.cli.app import app
from longprofile.vehicle import estimate_vertical_log, sensors_to_frame, vertical_test_run
from longprofile.vehicle.vertical import DEFLECTION_OFFSET_LIMIT, deflection_zero_check

DZ = [f"dz21_{c}" for c in ("FL", "FR", "RL", "RR")]


@pytest.fixture(scope="module")
def run():
    """The guide's vertical log: configuration 3, class C road, 20 m/s, 5 s."""
    return vertical_test_run(3, test="road", road_class="C", speed=20.0, duration=5.0, seed=0)


def _shifted(sensors, offset):
    return replace(sensors, displacement=sensors.displacement + np.asarray(offset))


def test_a_zeroed_log_passes_though_its_mean_deflection_is_far_from_zero(run):
    sim, sensors = run
    check = estimate_vertical_log(sensors).deflection_check
    assert np.all(np.abs(check.mean) > 0.008)  # the dampers pull the car down: the mean itself is no test
    np.testing.assert_allclose(check.mean, sim.suspension_deflection.mean(axis=0), atol=5e-4)  # the truth's, too
    assert not check.suspect and np.all(np.abs(check.offset) < 2e-3)
    assert estimate_vertical_log(sensors).warnings() == []


@settings(max_examples=8, deadline=None)
@given(offset=st.lists(st.floats(-0.03, 0.03), min_size=4, max_size=4))
def test_the_offset_found_is_the_offset_added(run, offset):
    _, sensors = run
    base = deflection_zero_check(sensors).offset
    found = deflection_zero_check(_shifted(sensors, offset)).offset
    np.testing.assert_allclose(found - base, offset, atol=1e-5)  # the progressive springs solved for (Newton)


def test_a_20_mm_offset_is_named_in_one_line_with_its_mean_and_what_to_do(run):
    _, sensors = run
    res = estimate_vertical_log(_shifted(sensors, [0.02] * 4))
    (line,) = [w for w in res.warnings() if "static ride height" in w]
    assert "\n" not in line and all(c in line for c in DZ)
    mean = res.deflection_check.mean
    assert f"{1e3 * mean[0]:+.1f}" in line and "mm" in line
    assert "zero each sensor at the static ride height or subtract its static reading" in line
    # one corner: only that channel is named
    res = estimate_vertical_log(_shifted(sensors, [0.0, 0.0, -0.008, 0.0]))
    (line,) = [w for w in res.warnings() if "static ride height" in w]
    assert line.startswith("dz21_RL does not read zero") and "dz21_FL" not in line
    assert DEFLECTION_OFFSET_LIMIT == 0.005


def test_a_log_too_short_for_the_mean_is_not_checked(run):
    _, sensors = run
    short = replace(sensors, time=sensors.time[:1500], displacement=sensors.displacement[:1500] + 0.02,
                    ax=sensors.ax[:1500], ay=sensors.ay[:1500], yaw_rate=sensors.yaw_rate[:1500],
                    wheel_accel=sensors.wheel_accel[:1500])
    assert deflection_zero_check(short) is None


def test_the_command_warns_about_a_log_not_zeroed_at_static_ride_height(run, tmp_path):
    sim, sensors = run
    frame = sensors_to_frame(sensors, sim)
    frame[DZ] = frame[DZ] + 0.02
    frame.to_csv(tmp_path / "vlog.csv", index=False)
    res = CliRunner().invoke(app, ["vehicle", "vertical", "estimate", str(tmp_path / "vlog.csv"), "-o",
                                   str(tmp_path / "s.csv")])
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    assert "warning: dz21_FL, dz21_FR, dz21_RL, dz21_RR do not read zero at the static ride height" in text
    assert "subtract its static reading" in text
    assert len(pd.read_csv(tmp_path / "s.csv")) == len(frame)
