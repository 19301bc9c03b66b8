"""The calibration benchmark's sensor-warning rows (issue 13, 2026-12-06; docs/vehicle-slope.md, "The joint grade's
NIS floor, V_y's spread, and the sensor warnings"): the warnings are sorted by kind from the start of their texts,
and a drive is counted when one names a sensor."""

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from longprofile.vehicle import SensorSpec, default_vehicle, drive_scenario, estimate_slope, simulate_drive

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

from benchmarks.bench_vehicle_calibration import SENSOR_WARNINGS, _warning_kinds, _warning_row  # noqa: E402

CAR = default_vehicle()


class _Stub:
    def __init__(self, texts):
        self._texts = texts

    def warnings(self):
        return self._texts


def test_warning_kinds_and_the_row_count_drives_with_a_sensor_warning():
    assert _warning_kinds(_Stub([])) == set()
    assert _warning_kinds(_Stub(["slope leaves the plausible range ...", "something new"])) == {"slope > 10 %", "other"}
    warned = [{"wheel scale"}, {"slope > 10 %"}, set(), {"gyro", "force vs accelerometer"}]
    row = _warning_row("sensor bias", warned)
    assert row.value == 50.0 and "detection rate" in row.detail and "2 of 4" in row.detail
    assert "gyro 1" in row.detail and "slope > 10 % 1" in row.detail
    assert "false-flag rate" in _warning_row("own model", warned).detail
    assert set(SENSOR_WARNINGS) == {"gyro", "wheel scale", "force vs accelerometer", "unverified"}


@pytest.fixture(scope="module")
def hill():
    return drive_scenario("hill", duration=20.0)


def test_the_kinds_match_the_estimators_texts(hill):
    """A gyro offset of 3e-3 rad/s and wheel scale errors of 0.4 % (the benchmark's sensor-bias family) are named by
    kind; the same drive with the simulator's in-spec sensors has no sensor warning."""
    bad = simulate_drive(hill, CAR, sensors=SensorSpec(yaw_rate_offset=3e-3), seed=2)
    log = replace(bad.log, wheel_speeds=bad.log.wheel_speeds * np.array([1.004, 0.996, 1.0, 1.004]))
    assert {"gyro", "wheel scale"} <= _warning_kinds(estimate_slope(log, CAR))
    good = simulate_drive(hill, CAR, seed=2)
    assert not _warning_kinds(estimate_slope(good.log, CAR)) & set(SENSOR_WARNINGS)
