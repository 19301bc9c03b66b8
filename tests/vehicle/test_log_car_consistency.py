"""The log checked against the car file (session 39): the steering gain against the steady-state bicycle model of
paper 001, and front/rear wheel-speed columns told apart by the driven axle's slip."""

import re
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.cli.app import main
from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.vehicle import DriveScenario, default_vehicle, read_drive_log, simulate_drive
from longprofile.vehicle._consistency import steady_state_yaw_rate
from longprofile.vehicle._logs import check_drive_log

CAR = default_vehicle()
SWAP = [2, 3, 0, 1]
RENAME = ("wheel_speed_fl=wheel_speed_rl,wheel_speed_fr=wheel_speed_rr,wheel_speed_rl=wheel_speed_fl,"
          "wheel_speed_rr=wheel_speed_fr")


@pytest.fixture(scope="module")
def turning():
    """15 s of the low-mu drive (20 m/s, sine steering): the steering gain is checked on it."""
    return simulate_drive("low-mu", seed=3).log


@pytest.fixture(scope="module")
def hill():
    """The hill drive (straight, accelerating and braking): the axle order is checked on it, not the steering gain."""
    return simulate_drive("hill", seed=1).log


def _named(log, car=CAR, **kw):
    return {c.name: c for c in check_drive_log(log, car, raise_on_error=False, **kw)}


def _scaled(log, f):
    return replace(log, steering_angle=log.steering_angle * f)


def _steady_circle(speed, delta, car=CAR):
    """The simulator's yaw rate after 12 s of constant speed and steering (paper 001's full model, Dugoff tyres)."""
    n = 12000
    s = np.arange(0.0, 2000.0, 0.5)
    sc = DriveScenario("circle", 1e-3, np.full(n, speed), np.full(n, delta), s, np.zeros(s.size),
                       np.full((s.size, 2), 0.9), speed)
    sim = simulate_drive(sc, car, seed=0)
    return float(np.mean(sim.truth.yaw_rate[-2000:]))


@settings(max_examples=6, deadline=None)
@given(speed=st.floats(8.0, 28.0), a_y=st.floats(0.5, 2.5), rear=st.sampled_from([1.0, 1.3]))
def test_the_steady_state_yaw_rate_is_the_simulators_on_a_steady_circle(speed, a_y, rear):
    # oracle: the 4-wheel simulator (eq. (11)-(19), Dugoff tyres, load transfer) in a steady turn, not the formula
    car = CAR.with_changes(cornering_stiffness=(50000.0, 50000.0 * rear))
    kin = a_y / speed  # the steady yaw rate of the wanted a_y, its steer from the formula itself
    delta = kin / float(steady_state_yaw_rate(1.0, speed, car))
    r = _steady_circle(speed, delta, car)
    assert r == pytest.approx(float(steady_state_yaw_rate(delta, speed, car)), rel=0.03)


def test_the_clean_drive_passes_and_a_straight_drive_is_not_checked(turning, hill):
    c = _named(turning)["steering_gain"]
    assert c.ok is True and c.warning == "" and 0.95 < c.ratio < 1.05 and c.samples * turning.dt > 1.0
    h = _named(hill)["steering_gain"]
    assert h.ok is None and h.warning == ""  # no steering: no check, silently
    check_drive_log(turning, CAR)  # nothing raised


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(f=st.floats(1.0 / 1.08, 1.08))
def test_a_steering_scale_within_8_percent_passes_silently(turning, f):
    c = _named(_scaled(turning, f))["steering_gain"]
    assert c.ok is True and c.warning == ""


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(f=st.floats(1.5, 2.0), up=st.booleans())
def test_a_steering_scale_of_1_5_to_2_is_named_with_its_factor(turning, f, up):
    f = f if up else 1.0 / f
    c = _named(_scaled(turning, f))["steering_gain"]
    clean = _named(turning)["steering_gain"].ratio
    assert c.ratio == pytest.approx(clean / f, rel=0.05)  # the gain measures the scale
    if c.ok is False:
        with pytest.raises(UnitsError, match=r"steering_angle reads .* times the road-wheel angle.*"
                                             r"--accept-check steering_gain"):
            check_drive_log(_scaled(turning, f), CAR)
        assert _named(_scaled(turning, f), accept=["steering_gain"])["steering_gain"].warning
    else:
        assert "steady-state bicycle-model yaw rate" in c.warning
        factor = float(re.search(r"reads ([0-9.]+) times", c.warning).group(1))
        assert factor == pytest.approx(f / clean, rel=0.01)


def test_a_wrong_steering_ratio_names_the_ratio_the_log_suggests(turning):
    frame = turning.to_frame()
    frame["steering_wheel_angle"] = frame.pop("steering_angle") * 15.0
    car = CAR.with_changes(steering_ratio=10.0)  # the log's ratio is 15: 1.5x off
    _, checks = read_drive_log(frame, car)
    warning = {c.name: c for c in checks}["steering_gain"].warning
    suggested = float(re.search(r"body.steering_ratio 10 wrong \(this log suggests about ([0-9.]+)\)", warning)[1])
    assert suggested == pytest.approx(15.0, rel=0.06)


@pytest.mark.parametrize("driven", ["front", "rear"])
def test_swapped_axles_are_named_and_the_suggested_rename_fixes_them(driven):
    car = CAR.with_changes(driven_axle=driven)
    log = simulate_drive("hill", car, seed=2).log
    assert _named(log, car)["axle_order"].ok is True
    swapped = replace(log, wheel_speeds=log.wheel_speeds[:, SWAP])
    c = _named(swapped, car)["axle_order"]
    assert c.ok is False and c.ratio < -0.5
    with pytest.raises(InputFormatError, match=r"wheel_speed_fl/fr look like the rear wheels.*are the front and rear "
                                         r"columns swapped\? \(--rename " + re.escape(RENAME)):
        check_drive_log(swapped, car)
    frame = swapped.to_frame()
    rename = dict(kv.split("=") for kv in RENAME.split(","))
    fixed, checks = read_drive_log(frame, car, rename=rename)
    np.testing.assert_array_equal(fixed.wheel_speeds, log.wheel_speeds)
    assert {c.name: c for c in checks}["axle_order"].ok is True


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(scale=st.lists(st.floats(0.98, 1.02), min_size=4, max_size=4), lag=st.integers(0, 20))
def test_the_axle_order_survives_radius_errors_and_lag_and_the_swap_is_refused(hill, scale, lag):
    # wheel radii off by up to 2 % each (the front/rear check allows 3 %) and the wheel speeds late by up to 20 ms
    w = hill.wheel_speeds * np.array(scale)
    w = np.vstack([np.repeat(w[:1], lag, axis=0), w[:w.shape[0] - lag]])
    log = replace(hill, wheel_speeds=w)
    assert _named(log)["axle_order"].ok is True
    assert _named(replace(log, wheel_speeds=w[:, SWAP]))["axle_order"].ok is False


def test_an_all_wheel_drive_car_or_a_steady_speed_leaves_the_axle_order_unchecked(hill, turning):
    awd = CAR.with_changes(driven_axle="all")
    assert _named(hill, awd)["axle_order"].ok is None
    steady = simulate_drive("paper", seed=0).log
    steady = replace(steady, time=steady.time[:5000], steering_angle=steady.steering_angle[:5000],
                     wheel_speeds=steady.wheel_speeds[:5000], yaw_rate=steady.yaw_rate[:5000],
                     accel_x=steady.accel_x[:5000], accel_y=steady.accel_y[:5000])  # 5 s at 25 m/s on the level
    assert _named(steady)["axle_order"].ok is None


def test_the_cli_refuses_a_swap_in_one_line_and_accept_check_goes_on(hill, tmp_path, capsys):
    path = tmp_path / "swapped.csv"
    frame = hill.to_frame().iloc[::5].reset_index(drop=True)  # 200 Hz
    frame = frame.rename(columns={"wheel_speed_fl": "wheel_speed_rl", "wheel_speed_fr": "wheel_speed_rr",
                                  "wheel_speed_rl": "wheel_speed_fl", "wheel_speed_rr": "wheel_speed_fr"})
    pd.DataFrame(frame).to_csv(path, index=False)
    assert main(["vehicle", "slope", str(path), "-o", str(tmp_path / "a.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 1 and "are the front and rear columns swapped? (--rename" in err
    assert "Traceback" not in err
    assert main(["vehicle", "slope", str(path), "-o", str(tmp_path / "b.csv"), "--rename", RENAME]) == 0
    capsys.readouterr()
    assert main(["vehicle", "slope", str(path), "-o", str(tmp_path / "c.csv"), "--accept-check", "axle_order"]) == 0
    assert "warning: wheel_speed_fl/fr look like the rear wheels" in " ".join("".join(capsys.readouterr()).split())
    assert main(["vehicle", "slope", str(path), "-o", str(tmp_path / "d.csv"), "--accept-check", "axle"]) == 2
    assert "the checks it can accept are ['steering_gain', 'axle_order']" in capsys.readouterr().err


def test_accept_names_only_known_checks(turning):
    with pytest.raises(InputError, match=r"--accept-check names \['steering'\]"):
        check_drive_log(turning, CAR, accept=["steering"])


def test_an_accelerometer_of_opposite_sign_is_named_not_taken_for_swapped_axles(hill):
    flipped = replace(hill, accel_x=-hill.accel_x)
    assert _named(flipped)["axle_order"].ok is None
    with pytest.raises(UnitsError, match=r"accel_x of opposite sign") as err:
        check_drive_log(flipped, CAR)
    assert "swapped" not in str(err.value)
