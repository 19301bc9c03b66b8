"""Vertical logs: a chassis-control engineer's probe (session 40).

Before: ``--profile X -o X`` wrote the states then replaced them with the road; one missing wheel accelerometer or
damper current silently dropped the other three; inverted accelerometers were blamed on the deflection sensors; a
1 MHz time base (``--units time=ms`` on seconds), currents in mA or negative, a lateral axis to the right, a_y in g
and swapped corners passed without a word; a deflection sign correlation of -0.99 and wheel accelerometers in g were
only warned about; the simulator wrote class-H logs its own estimator refused; ``--units`` silently beat a header.
"""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from longprofile.cli.app import main
from longprofile.errors import InputError, UnitsError
from longprofile.vehicle import (
    MRDamperParams,
    estimate_vertical_log,
    parse_units,
    read_vertical_log,
    sensors_to_frame,
    vertical_test_run,
)

G = 9.80665
CORNERS = ("FL", "FR", "RL", "RR")


def _run(args, capsys):
    capsys.readouterr()
    code = main(["vehicle", "vertical", *map(str, args)])
    captured = capsys.readouterr()
    return code, " ".join((captured.out + captured.err).split())


@pytest.fixture(scope="module")
def run3():
    return vertical_test_run(3, test="road", road_class="C", speed=20.0, duration=5.0, seed=0)


@pytest.fixture(scope="module")
def frame3(run3):
    sim, sensors = run3
    return sensors_to_frame(sensors, sim)


def test_profile_onto_the_states_file_is_refused_before_any_work(tmp_path, frame3, capsys):
    frame3.to_csv(tmp_path / "v3.csv", index=False)
    for out, prof in (("e.csv", "e.csv"), ("e_iri.csv", "e.csv")):
        code, text = _run(["estimate", tmp_path / "v3.csv", "--profile", tmp_path / prof, "--speed", 20, "-o",
                           tmp_path / out], capsys)
        assert code == 2 and "is the same file as the -o output" in text and "Traceback" not in text
        assert not (tmp_path / out).exists() and not (tmp_path / prof).exists()


def test_one_missing_wheel_accelerometer_is_refused_and_config_1_says_what_it_ignores(tmp_path, frame3, capsys):
    frame3.drop(columns=["wheel_accel_RR"]).to_csv(tmp_path / "m.csv", index=False)
    code, text = _run(["estimate", tmp_path / "m.csv", "-o", tmp_path / "s.csv"], capsys)
    assert code == 2 and "but no wheel_accel_RR" in text and "--config 1" in text
    assert not (tmp_path / "s.csv").exists()
    code, text = _run(["estimate", tmp_path / "m.csv", "--config", "1", "-o", tmp_path / "s.csv"], capsys)
    assert code == 0 and "note: --config 1 ignores the log's wheel_accel_FL, wheel_accel_FR, wheel_accel_RL" in text


def test_one_stray_wheel_accelerometer_in_a_body_log_is_refused_naming_config_2():
    sim, sensors = vertical_test_run(2, test="road", road_class="C", speed=20.0, duration=3.0, seed=1)
    frame = sensors_to_frame(sensors, sim).assign(wheel_accel_FL=0.0)
    with pytest.raises(InputError, match=r"wheel_accel_FL but no wheel_accel_FR.*--config 2 ignores"):
        read_vertical_log(frame)
    notes = []
    assert read_vertical_log(frame, 2, notes=notes)[1] == 2 and notes == ["--config 2 ignores the log's wheel_accel_FL"]


@pytest.fixture(scope="module")
def magneride():
    sim, sensors = vertical_test_run(1, test="road", road_class="C", speed=20.0, duration=3.0, seed=2,
                                     mr_damper=MRDamperParams())
    return sensors_to_frame(sensors, sim)


def test_currents_missing_at_one_corner_in_ma_or_negative_are_refused(magneride):
    with pytest.raises(InputError, match="current_FL, current_FR, current_RL but no current_RR"):
        read_vertical_log(magneride.drop(columns=["current_RR"]))
    cur = [f"current_{c}" for c in CORNERS]
    ma = magneride.assign(**{c: 1000 * magneride[c] for c in cur})
    with pytest.raises(UnitsError, match=r"reach 5000 A .*in mA\? declare it: --units 'current_\*=mA'"):
        read_vertical_log(ma)
    got, _ = read_vertical_log(ma, units=parse_units("current_*=mA"))
    np.testing.assert_allclose(got.damper_current, magneride[cur].to_numpy(), rtol=1e-12)
    with pytest.raises(UnitsError, match="current_FL goes down to -5 A: .*sign or an offset"):
        read_vertical_log(magneride.assign(current_FL=-magneride["current_FL"]))


def test_a_time_in_seconds_declared_as_ms_is_refused_and_a_10_khz_log_is_read(frame3):
    with pytest.raises(UnitsError, match=r"1e\+06 Hz .*time unit mistake"):
        read_vertical_log(frame3, units={"time": "ms"})
    fast = pd.DataFrame({c: np.repeat(frame3[c].to_numpy()[:500], 10) for c in frame3.columns})
    fast["time"] = np.arange(len(fast)) * 1e-4  # a 10 kHz logger
    sensors, _ = read_vertical_log(fast)
    assert sensors.dt == pytest.approx(1e-4)


def test_units_that_contradict_a_header_are_refused_and_mm_per_s2_is_read(frame3):
    dz = {f"dz21_{c}": f"dz21_{c} [mm]" for c in CORNERS}
    mm = frame3.assign(**{c: 1000 * frame3[c] for c in dz}).rename(columns=dz)
    with pytest.raises(UnitsError, match=r"'dz21_FL' is headed in mm but --units says m"):
        read_vertical_log(mm, units=parse_units("dz21_*=m"))
    wa = {f"wheel_accel_{c}": f"wheel_accel_{c} [mm/s^2]" for c in CORNERS}
    got, _ = read_vertical_log(frame3.assign(**{c: 1000 * frame3[c] for c in wa}).rename(columns=wa))
    np.testing.assert_allclose(got.wheel_accel, frame3[list(wa)].to_numpy(), rtol=1e-12)


@pytest.mark.parametrize("config,kind", [(3, "wheel_accel"), (2, "body_accel")])
def test_inverted_accelerometers_are_named_not_the_deflections(config, kind):
    _, sensors = vertical_test_run(config, test="road", road_class="C", speed=20.0, duration=6.0, seed=3)
    field = "wheel_accel" if config == 3 else "body_accel"
    inverted = replace(sensors, **{field: -getattr(sensors, field)})
    with pytest.raises(UnitsError, match=rf"{kind}_FL, {kind}_FR, {kind}_RL, {kind}_RR: sign inverted \(z down\?\)\? "
                                         rf".*negate {kind}_FL.*--accept-check sensor_sign"):
        estimate_vertical_log(inverted)
    (line,) = estimate_vertical_log(inverted, accept=["sensor_sign"]).warnings()
    assert line.startswith(f"{kind}_FL") and "negate dz21" not in line and "negate these columns" not in line
    assert estimate_vertical_log(inverted, accept=["sensor_sign"]).deflection_check.sign_culprit == "accelerometer"


def test_wheel_accelerometers_in_g_and_swapped_corners_are_refused_with_an_opt_out(run3):
    _, sensors = run3
    with pytest.raises(UnitsError, match=r"accelerations in g\? .*--accept-check wheel_accel_unit"):
        estimate_vertical_log(replace(sensors, wheel_accel=sensors.wheel_accel / G))
    assert estimate_vertical_log(replace(sensors, wheel_accel=sensors.wheel_accel / G),
                                 accept="wheel_accel_unit").warnings()
    dz = sensors.displacement[:, [1, 0, 2, 3]]
    with pytest.raises(UnitsError, match=r"dz21_FL moves with wheel_accel_FR .*swapped corners\? .*corner_order"):
        estimate_vertical_log(replace(sensors, displacement=dz))
    with pytest.raises(InputError, match="--accept-check names \\['corner-order'\\]"):
        estimate_vertical_log(sensors, accept=["corner-order"])


@pytest.fixture(scope="module")
def track():
    return vertical_test_run(1, test="track", speed=22.0, duration=10.0, seed=4)[1]


def test_a_lateral_axis_to_the_right_or_ay_in_g_is_refused(track):
    assert estimate_vertical_log(track).warnings() == []
    right = replace(track, ay=-track.ay, yaw_rate=-track.yaw_rate)
    with pytest.raises(UnitsError, match=r"lateral axis to the RIGHT .*negate ay and yaw_rate"):
        estimate_vertical_log(right)
    with pytest.raises(UnitsError, match=r"ay in g\? declare it: --units ay=g"):
        estimate_vertical_log(replace(track, ay=track.ay / G))


def test_a_yaw_rate_in_degrees_undeclared_is_refused(frame3):
    turning = frame3.assign(yaw_rate=np.degrees(0.17 * np.sin(frame3["time"])))  # 0.17 rad/s peak, in deg/s
    with pytest.raises(UnitsError, match=r"yaw_rate reaches 9\.7\d rad/s .*--units yaw_rate=deg/s"):
        read_vertical_log(turning)
    read_vertical_log(turning, units={"yaw_rate": "deg/s"})


def test_the_simulator_refuses_what_the_estimator_would_refuse(tmp_path, capsys):
    code, text = _run(["simulate", "--road-class", "H", "--speed", 40, "--duration", 3, "-o", tmp_path / "h.csv"],
                      capsys)
    assert code == 2 and "beyond the 0.3 m span" in text and not (tmp_path / "h.csv").exists()


def test_options_the_log_does_not_use_are_refused_in_one_line(tmp_path, frame3, capsys):
    frame3.to_csv(tmp_path / "v3.csv", index=False)
    code, text = _run(["estimate", tmp_path / "v3.csv", "--speed", 20, "-o", tmp_path / "s.csv"], capsys)
    assert code == 2 and "--speed is used with --profile only" in text
    code, text = _run(["estimate", tmp_path / "v3.csv", "--mr-map-velocity", "filter", "-o", tmp_path / "s.csv"],
                      capsys)
    assert code == 2 and "no current_FL..RR columns (a passive car): drop the option" in text
    assert not (tmp_path / "s.csv").exists()
