"""Vertical logs: accelerometers that still include gravity are refused, deflections of inverted sign are named
(session 38, a vehicle engineer's probe).

Before, +9.81 m/s² on the wheel or body accelerometers gave body-velocity RMS errors of 1-3 m/s (0.026 clean)
without a word, and deflections logged positive in compression were warned about as "not zeroed".
"""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from longprofile.cli.app import app, main
from longprofile.errors import UnitsError
from longprofile.vehicle import estimate_vertical_log, sensors_to_frame, vertical_test_run
from longprofile.vehicle.vertical import check_vertical_accel_means

G = 9.80665
CORNERS = ("FL", "FR", "RL", "RR")


def _estimate(path, out):
    return CliRunner().invoke(app, ["vehicle", "vertical", "estimate", str(path), "-o", str(out)])


@pytest.mark.parametrize("config,column", [(3, "wheel_accel"), (2, "body_accel")])
def test_accelerometers_with_gravity_are_refused_in_one_line_naming_them(tmp_path, capsys, config, column):
    sim, sensors = vertical_test_run(config, test="road", road_class="C", speed=20.0, duration=4.0, seed=1)
    frame = sensors_to_frame(sensors, sim)
    names = [f"{column}_{c}" for c in CORNERS]
    frame[names] = frame[names] + G  # z up, as an IMU logs its specific force
    frame.to_csv(tmp_path / "g.csv", index=False)
    capsys.readouterr()
    assert main(["vehicle", "vertical", "estimate", str(tmp_path / "g.csv"), "-o", str(tmp_path / "s.csv")]) == 2
    captured = capsys.readouterr()
    out = captured.out + captured.err
    text = " ".join(out.split())
    assert "error:" in text and "Traceback" not in out
    assert ", ".join(names) in text and "gravity is included: subtract 9.80665 m/s² (1 g)" in text
    assert not (tmp_path / "s.csv").exists()


def test_gravity_in_g_undeclared_and_a_z_down_axis_get_their_own_fix(run3):
    sim, sensors = run3
    in_g = replace(sensors, wheel_accel=sensors.wheel_accel / G + 1.0)
    with pytest.raises(UnitsError, match=r"in g with gravity included\? .*--units 'wheel_accel_\*=g'"):
        check_vertical_accel_means(in_g)
    down = replace(sensors, wheel_accel=-sensors.wheel_accel - G)
    with pytest.raises(UnitsError, match="axis points down: negate these columns, then subtract"):
        estimate_vertical_log(down)  # the library entry refuses too, before running the filters
    one = sensors.wheel_accel.copy()
    one[:, 2] += G
    with pytest.raises(UnitsError, match=r"log: wheel_accel_RL averages \+9\.8"):
        check_vertical_accel_means(replace(sensors, wheel_accel=one))


@pytest.fixture(scope="module")
def run3():
    return vertical_test_run(3, test="road", road_class="B", speed=25.0, duration=12.0, seed=2)


@settings(max_examples=10, deadline=None)
@given(road_class=st.sampled_from("ABCDE"), speed=st.floats(5.0, 40.0), duration=st.floats(0.2, 3.0),
       test=st.sampled_from(["road", "track", "sweep"]), config=st.sampled_from([2, 3]), seed=st.integers(0, 99))
def test_clean_drives_pass_however_short_or_rough(road_class, speed, duration, test, config, seed):
    # a short log's mean is its vertical speed change over its length: up to 13 m/s² on 0.2 s of class E road
    _, sensors = vertical_test_run(config, test=test, road_class=road_class, speed=speed, duration=duration,
                                   seed=seed)
    check_vertical_accel_means(sensors)


@pytest.mark.parametrize("config", [2, 3])
def test_deflections_of_inverted_sign_are_named_as_such(config):
    _, sensors = vertical_test_run(config, test="road", road_class="C", speed=20.0, duration=6.0, seed=3)
    assert estimate_vertical_log(sensors).warnings() == []
    with pytest.raises(UnitsError, match=r"sign inverted\? .*--accept-check sensor_sign"):  # session 40: refused
        estimate_vertical_log(replace(sensors, displacement=-sensors.displacement))
    flipped = estimate_vertical_log(replace(sensors, displacement=-sensors.displacement), accept=("sensor_sign",))
    check = flipped.deflection_check
    assert check.inverted.all() and np.all(check.sign < -0.5)
    (line,) = flipped.warnings()
    assert line.startswith("dz21_FL, dz21_FR, dz21_RL, dz21_RR: sign inverted?")
    assert "negate these columns" in line and "do not read zero" not in line
    assert ("body" if config == 2 else "wheel") + " accelerometers imply" in line


def test_one_corner_of_inverted_sign_is_the_one_named():
    _, sensors = vertical_test_run(2, test="road", road_class="C", speed=20.0, duration=6.0, seed=4)
    dz = sensors.displacement.copy()
    dz[:, 1] *= -1
    (line,) = estimate_vertical_log(replace(sensors, displacement=dz), accept="sensor_sign").warnings()
    assert line.startswith("dz21_FR: sign inverted? it moves against") and "negate this column" in line


def test_the_command_refuses_a_deflection_logged_positive_in_compression(tmp_path, capsys):
    sim, sensors = vertical_test_run(3, test="road", road_class="C", speed=20.0, duration=5.0, seed=0)
    frame = sensors_to_frame(sensors, sim)
    dz = [f"dz21_{c}" for c in CORNERS]
    frame[dz] = -frame[dz]
    frame.to_csv(tmp_path / "v.csv", index=False)
    capsys.readouterr()
    # session 40: correlation < -0.9 is refused, not warned
    assert main(["vehicle", "vertical", "estimate", str(tmp_path / "v.csv"), "-o", str(tmp_path / "s.csv")]) == 2
    captured = capsys.readouterr()
    text = " ".join((captured.out + captured.err).split())
    assert "error:" in text and "dz21_FL, dz21_FR, dz21_RL, dz21_RR: sign inverted?" in text
    assert "not read zero" not in text and "--accept-check sensor_sign" in text
    assert not (tmp_path / "s.csv").exists()
