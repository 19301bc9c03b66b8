"""Simulator of the planar model: scenarios, sensors (encoder quantisation, noise, offsets), logs."""

import numpy as np
import pandas as pd
import pytest

from longprofile.errors import InputError, InputFormatError, ShapeError
from longprofile.vehicle import (
    LOG_COLUMNS,
    SCENARIOS,
    DriveLog,
    SensorSpec,
    default_vehicle,
    drive_scenario,
    simulate_drive,
)


@pytest.fixture(scope="module")
def low_mu():
    return simulate_drive(drive_scenario("low-mu", duration=20.0), seed=3)


def test_seeded_and_deterministic():
    a = simulate_drive(drive_scenario("hill", duration=2.0), seed=1)
    b = simulate_drive(drive_scenario("hill", duration=2.0), seed=1)
    c = simulate_drive(drive_scenario("hill", duration=2.0), seed=2)
    pd.testing.assert_frame_equal(a.to_frame(), b.to_frame())
    np.testing.assert_array_equal(a.truth.vx, c.truth.vx)  # physics does not depend on the seed
    assert not np.array_equal(a.log.yaw_rate, c.log.yaw_rate)


def test_encoder_quantisation_and_sensor_offsets():
    spec = SensorSpec(encoder_teeth=48, encoder_clock=1e5, encoder_jitter=0.0, yaw_rate_noise=0.0,
                      yaw_rate_offset=0.01, accel_noise=0.0, accel_offset=0.0, steering_noise=0.0,
                      steering_offset=0.0, steering_resolution=1e-3)
    sim = simulate_drive(drive_scenario("paper", duration=3.0), sensors=spec, seed=0)
    w_true, w = sim.truth.wheel_speeds, sim.log.wheel_speeds
    # period measurement over 4 tooth pitches timed with a 100 kHz clock: one clock tick of error at most,
    # plus the change of speed within the window (tiny at constant speed)
    pitch = 2 * np.pi / 48
    tick_error = w_true ** 2 / (4 * pitch) * 1e-5
    assert np.all(np.abs(w - w_true)[100:] <= 1.5 * tick_error[100:] + 0.01)
    assert len(np.unique(w[:, 0])) < 0.5 * w.shape[0]  # held between edges: quantised, not continuous
    np.testing.assert_allclose(sim.log.yaw_rate - sim.truth.yaw_rate, 0.01, atol=1e-12)
    assert np.allclose(np.round(sim.log.steering_angle / 1e-3) * 1e-3, sim.log.steering_angle)


def test_low_mu_patch_reaches_front_wheels_first(low_mu):
    tr = low_mu.truth
    first_front = np.argmax(tr.friction[:, 0] < 0.5)
    first_rear = np.argmax(tr.friction[:, 2] < 0.5)
    wheelbase = default_vehicle().wheelbase
    gap = tr.distance[first_rear] - tr.distance[first_front]
    assert gap == pytest.approx(wheelbase, abs=0.05)
    # on the patch the driven front wheels need more slip for the same traction
    on = tr.friction[:, 0] < 0.5
    assert np.abs(tr.slip[on, 0]).max() > 1.5 * np.abs(tr.slip[~on, 0]).max()


def test_hill_scenario_climbs_and_brakes():
    sim = simulate_drive("hill", seed=0)
    tr = sim.truth
    assert tr.vx.max() > 26.0 and tr.vx[-1] == pytest.approx(12.0, abs=0.3)
    assert np.degrees(tr.slope.max()) == pytest.approx(np.degrees(np.arctan(0.06)), rel=1e-6)
    assert tr.slip[:, 2].min() < -1e-3  # rear brakes in action while braking


def test_log_round_trip_and_missing_channels(low_mu, tmp_path):
    frame = low_mu.log.to_frame()
    assert tuple(frame.columns) == LOG_COLUMNS
    back = DriveLog.from_frame(frame)
    np.testing.assert_array_equal(back.wheel_speeds, low_mu.log.wheel_speeds)
    with pytest.raises(InputFormatError, match=r"x.csv: missing channel\(s\) wheel_speed_rr \(rad/s\), yaw_rate \(rad/s\)"):
        DriveLog.from_frame(frame.drop(columns=["yaw_rate", "wheel_speed_rr"]), source="x.csv")
    frame.loc[5, "accel_x"] = np.nan
    with pytest.raises(InputFormatError, match="column 'accel_x' has a missing or non-numeric value at row 5"):
        DriveLog.from_frame(frame)


def test_drive_log_validation():
    t = np.arange(10) * 1e-3
    ok = dict(time=t, steering_angle=np.zeros(10), wheel_speeds=np.ones((10, 4)), yaw_rate=np.zeros(10),
              accel_x=np.zeros(10), accel_y=np.zeros(10))
    DriveLog(**ok)
    with pytest.raises(ShapeError, match="wheel_speeds must have shape"):
        DriveLog(**(ok | {"wheel_speeds": np.ones((10, 3))}))
    with pytest.raises(InputError, match="uniformly sampled"):
        DriveLog(**(ok | {"time": t ** 1.5}))
    with pytest.raises(InputError, match="wheel_speeds must be >= 0"):
        DriveLog(**(ok | {"wheel_speeds": -np.ones((10, 4))}))


def test_scenario_errors():
    assert set(SCENARIOS) == {"paper", "hill", "low-mu"}
    with pytest.raises(InputError, match="unknown scenario 'moon'"):
        drive_scenario("moon")
    with pytest.raises(InputError, match="dt must be finite and > 0"):
        drive_scenario("paper", dt=0.0)
