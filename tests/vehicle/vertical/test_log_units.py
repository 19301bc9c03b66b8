"""A vertical log in a user's units (session 35, a user's probe): wheel accelerations in g gave states as wrong as
the signals are large, without a word; a dead channel (one value all along) did too."""

from __future__ import annotations

import pytest

from longprofile.errors import InputFormatError, UnitsError
from longprofile.vehicle.vertical import (
    WHEEL_ACCEL_RATIO_RANGE,
    estimate_vertical_log,
    sensors_from_frame,
    sensors_to_frame,
    vertical_test_run,
    wheel_accelerometer_ratio,
)


@pytest.fixture(scope="module", params=["A", "C", "E"])
def log(request):
    _, sensors = vertical_test_run(3, road_class=request.param, speed=20.0, duration=4.0, seed=2)
    return sensors_to_frame(sensors)


def test_wheel_accelerations_in_g_are_named_and_si_are_not(log):
    si = sensors_from_frame(log, 3)
    g = log.copy()
    g[[f"wheel_accel_{c}" for c in ("FL", "FR", "RL", "RR")]] /= 9.80665
    lo, hi = WHEEL_ACCEL_RATIO_RANGE
    assert lo <= wheel_accelerometer_ratio(si) <= hi
    assert wheel_accelerometer_ratio(sensors_from_frame(g, 3)) < lo
    with pytest.raises(UnitsError, match=r"accelerations in g\? .*--accept-check wheel_accel_unit"):
        estimate_vertical_log(sensors_from_frame(g, 3))  # session 40: refused, no longer a warning
    res = estimate_vertical_log(sensors_from_frame(g, 3), accept=["wheel_accel_unit"])
    assert any("accelerations in g" in w for w in res.warnings())


@pytest.mark.parametrize("column", ["wheel_accel_RR", "dz21_FL"])
def test_a_channel_holding_one_value_is_refused(log, column):
    dead = log.assign(**{column: 0.0123})
    with pytest.raises(InputFormatError, match=f"column '{column}' holds one value"):
        sensors_from_frame(dead, 3)


def test_no_ratio_without_wheel_accelerometers():
    _, sensors = vertical_test_run(2, road_class="C", speed=20.0, duration=2.0, seed=1)
    assert wheel_accelerometer_ratio(sensors) is None


def test_the_road_under_the_wheels_lines_up_with_the_road_driven(tmp_path):
    """`simulate --road` starts the run with the rear axle on the profile's first station and `estimate --profile`
    took the first sample as the front axle's chainage 0: the wheels' profile was 2.96 m (one wheelbase) off."""
    import numpy as np
    import pandas as pd

    from longprofile.cli.app import main
    from longprofile.road import iso8608_profile

    road = iso8608_profile(300.0, 0.05, "C", rng=5)
    pd.DataFrame({"distance_m": road.distance, "left_m": road.elevation[:, 0]}).to_csv(tmp_path / "r.csv", index=False)
    assert main(["vehicle", "vertical", "simulate", "--road", str(tmp_path / "r.csv"), "--config", "3", "--speed", "20",
                 "--duration", "8", "-o", str(tmp_path / "log.csv")]) == 0
    assert main(["vehicle", "vertical", "estimate", str(tmp_path / "log.csv"), "-o", str(tmp_path / "s.csv"),
                 "--profile", str(tmp_path / "w.csv"), "--speed", "20"]) == 0
    w = pd.read_csv(tmp_path / "w.csv", comment="#")
    x, fl = w["distance_m"].to_numpy(), w["fl_m"].to_numpy()
    shifts = np.arange(-4.0, 4.0, 0.05)
    corr = [np.corrcoef(fl, np.interp(x + s, road.distance, road.elevation[:, 0]))[0, 1] for s in shifts]
    assert abs(shifts[int(np.argmax(corr))]) < 0.1 and max(corr) > 0.8
