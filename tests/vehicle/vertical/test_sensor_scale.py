"""Sensor scale of a vertical log (session 41, issue 13 §2 "never a silent wrong number"): body accelerometers logged
in g but undeclared (configuration 2) and a suspension deflection sensor of half its gain ran through
``vehicle vertical estimate`` without a word (session 40's probe). Now the first is refused (``body_accel_unit``, an
opt-out as ``wheel_accel_unit``) and the second is named in a warning with its measured gain."""

from dataclasses import replace

import numpy as np
import pytest

from longprofile.cli.app import main
from longprofile.errors import UnitsError
from longprofile.vehicle import estimate_vertical_log, sensors_to_frame, vertical_test_run
from longprofile.vehicle.vertical import (
    BODY_ACCEL_RATIO_RANGE,
    DEFLECTION_GAIN_RANGE,
    body_accelerometer_ratio,
    deflection_gains,
)

G = 9.80665
HALF_FL = np.array([0.5, 1.0, 1.0, 1.0])


@pytest.fixture(scope="module")
def runs():
    return {c: vertical_test_run(c, test="road", road_class="C", speed=20.0, duration=6.0, seed=3) for c in (2, 3)}


def _cli(tmp_path, capsys, frame, *extra):
    frame.to_csv(tmp_path / "log.csv", index=False)
    capsys.readouterr()
    code = main(["vehicle", "vertical", "estimate", str(tmp_path / "log.csv"), "-o", str(tmp_path / "s.csv"), *extra])
    captured = capsys.readouterr()
    return code, " ".join((captured.out + captured.err).split())


def test_body_accelerometers_in_g_are_refused_with_the_unit_to_declare(runs, tmp_path, capsys):
    sim, sensors = runs[2]
    assert body_accelerometer_ratio(sensors) == pytest.approx(1.0, abs=0.1)
    in_g = replace(sensors, body_accel=sensors.body_accel / G)
    ratio = body_accelerometer_ratio(in_g)
    assert ratio == pytest.approx(1.0 / G, rel=0.15) and ratio < BODY_ACCEL_RATIO_RANGE[0]
    frame = sensors_to_frame(in_g, sim)
    code, text = _cli(tmp_path, capsys, frame)
    assert code == 2 and "error:" in text and "Traceback" not in text
    assert "accelerations in g? Declare them: --units 'body_accel_*=g'" in text and "body_accel_unit" in text
    assert not (tmp_path / "s.csv").exists()
    # declared, the same log is read in m/s² and passes; accepted, it runs with the line as a warning
    code, text = _cli(tmp_path, capsys, frame, "--units", "body_accel_*=g")
    assert code == 0 and "warning" not in text
    code, text = _cli(tmp_path, capsys, frame, "--accept-check", "body_accel_unit", "--overwrite")
    assert code == 0 and "warning: " in text and "accelerations in g?" in text
    with pytest.raises(UnitsError, match="body_accel_unit"):
        estimate_vertical_log(in_g)


@pytest.mark.parametrize("config", [2, 3])
def test_a_deflection_sensor_of_half_gain_is_named_with_its_gain(runs, tmp_path, capsys, config):
    sim, sensors = runs[config]
    clean = deflection_gains(sensors)
    lo, hi = DEFLECTION_GAIN_RANGE
    judged = clean[np.isfinite(clean)]
    assert judged.size >= 2 and np.all((judged > 0.9 * lo) & (judged < hi))
    half = replace(sensors, displacement=sensors.displacement * HALF_FL)
    gains = deflection_gains(half)
    assert gains[0] == pytest.approx(0.5 * (clean[0] if config == 3 else np.median(clean)), rel=0.15)
    assert not estimate_vertical_log(sensors).warnings()
    code, text = _cli(tmp_path, capsys, sensors_to_frame(half, sim))
    assert code == 0 and "warning: dz21_FL reads 0.5" in text and "check the sensor's calibration" in text
    assert "dz21_FR" not in text.split("warning: dz21_FL")[1].split("passes")[0]  # only the faulty channel named
