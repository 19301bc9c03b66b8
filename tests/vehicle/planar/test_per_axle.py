"""Issue 14: a real car's description: per-axle track, rolling radius and tyre stiffnesses (staggered tyres),
measured front-left / front-right steer angles, and the Ackermann option of the simulator."""

import dataclasses
import math
import re

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.vehicle import (
    DriveLog,
    DriveScenario,
    ackermann_angles,
    default_vehicle,
    estimate_slope,
    load_vehicle,
    planar_inputs,
    read_drive_log,
    simulate_drive,
)

CAR = default_vehicle()
#: staggered truth of the accuracy tests: rear tyres 10 % larger, front cornering stiffness 20 % lower
STAGGERED = CAR.with_changes(wheel_radius=(0.30, 0.33), cornering_stiffness=(44000.0, 55000.0))
#: the same car described with equal axles (the mean of each pair), what a scalar-only file could say
AVERAGED = CAR.with_changes(wheel_radius=0.315, cornering_stiffness=49500.0)
WHEELS = [f"wheel_speed_{w}" for w in ("fl", "fr", "rl", "rr")]
# TOML key -> (Vehicle attribute, per-axle property, value line of the default car written by to_toml)
PER_AXLE_KEYS = {
    "body.track": ("track", "tracks", "track = 1.5  # m"),
    "wheels.radius": ("wheel_radius", "wheel_radii", "radius = 0.3  # m"),
    "wheels.longitudinal_stiffness": ("longitudinal_stiffness", "longitudinal_stiffnesses",
                                      "longitudinal_stiffness = 60000.0  # N"),
    "wheels.cornering_stiffness": ("cornering_stiffness", "cornering_stiffnesses",
                                   "cornering_stiffness = 50000.0  # N/rad"),
}


def _rms(e, m):
    return float(np.sqrt(np.mean(e[m] ** 2)))


def _write(tmp_path, key, value_text, name="car.toml"):
    _, _, line = PER_AXLE_KEYS[key]
    text = CAR.to_toml()
    assert line in text
    path = tmp_path / name
    path.write_text(text.replace(line, f"{line.split(' = ')[0]} = {value_text}"))
    return path


# ----------------------------------------------------------------------------------------------- (a) TOML schema

@pytest.mark.parametrize("key", sorted(PER_AXLE_KEYS))
def test_a_front_rear_pair_and_a_scalar_both_load(tmp_path, key):
    attr, prop, _ = PER_AXLE_KEYS[key]
    base = getattr(CAR, attr)
    pair = load_vehicle(_write(tmp_path, key, f"[{base * 0.9!r}, {base * 1.1!r}]"))
    assert getattr(pair, prop) == pytest.approx((base * 0.9, base * 1.1), rel=1e-15)
    assert getattr(pair, attr) == pytest.approx((base * 0.9, base * 1.1), rel=1e-15)
    scalar = load_vehicle(_write(tmp_path, key, repr(base)))  # an old, scalar-only car file
    assert getattr(scalar, prop) == (base, base) and scalar == CAR
    equal_pair = load_vehicle(_write(tmp_path, key, f"[{base!r}, {base!r}]"))
    assert equal_pair == CAR  # a pair of equal values is the scalar car
    np.testing.assert_array_equal(equal_pair.as_array(), CAR.as_array())
    assert pair != CAR and not np.array_equal(pair.as_array(), CAR.as_array())


def test_the_parameter_vector_carries_both_axles():
    from longprofile.vehicle.planar._params import (
        N_PARAMS,
        P_CX0_F,
        P_CX0_R,
        P_CY0_F,
        P_CY0_R,
        P_R_F,
        P_R_R,
        P_TRACK_F,
        P_TRACK_R,
    )

    car = CAR.with_changes(track=(1.52, 1.58), wheel_radius=(0.30, 0.33), longitudinal_stiffness=(6e4, 7e4),
                           cornering_stiffness=(4.4e4, 5.5e4))
    p = car.as_array()
    assert p.shape == (N_PARAMS,)
    assert (p[P_TRACK_F], p[P_TRACK_R], p[P_R_F], p[P_R_R]) == (1.52, 1.58, 0.30, 0.33)
    assert (p[P_CX0_F], p[P_CX0_R], p[P_CY0_F], p[P_CY0_R]) == (6e4, 7e4, 4.4e4, 5.5e4)
    np.testing.assert_array_equal(car.wheel_radius_of_each, [0.30, 0.30, 0.33, 0.33])


BAD_VALUES = [
    ("wheels.radius", "[0.30, 0.31, 0.32]", r"wheel_radius must be one number \(both axles\) or a \[front, rear\] pair"
                                            r".*got 3 value"),
    ("wheels.radius", "[0.30]", r"wheel_radius must be one number .*got 1 value"),
    ("wheels.radius", "[]", r"wheel_radius must be one number .*got 0 value"),
    ("body.track", "[1.5, -1.5]", r"track\[rear\] must be finite and > 0 m; got -1.5"),
    ("body.track", "-1.5", r"track must be finite and > 0 m; got -1.5"),
    ("wheels.cornering_stiffness", "[0.0, 50000.0]", r"cornering_stiffness\[front\] must be finite and > 0 N/rad"),
    ("wheels.longitudinal_stiffness", "[60000.0, nan]", r"longitudinal_stiffness\[rear\] must be finite"),
    ("wheels.cornering_stiffness", '[50000.0, "stiff"]', r"cornering_stiffness\[rear\] must be a number"),
    ("wheels.radius", "[[0.3, 0.3], 0.3]", r"wheel_radius\[front\] must be a number"),
]


@pytest.mark.parametrize("key, value, message", BAD_VALUES, ids=[f"{k}={v}" for k, v, _ in BAD_VALUES])
def test_a_bad_per_axle_value_is_an_error_naming_the_file_and_the_key(tmp_path, key, value, message):
    path = _write(tmp_path, key, value, name="bad.toml")
    with pytest.raises(InputFormatError, match=message) as exc:
        load_vehicle(path)
    text = str(exc.value)
    assert text.startswith(str(path)) and f"(key '{key}')" in text, text


@pytest.mark.parametrize("line, bad_key, table", [
    ("radius = 0.3  # m", "radius_rear", "wheels"),
    ("track = 1.5  # m", "track_front", "body"),
])
def test_an_unknown_key_is_an_error_naming_it(tmp_path, line, bad_key, table):
    path = tmp_path / "bad.toml"
    path.write_text(CAR.to_toml().replace(line, f"{line}\n{bad_key} = [0.3, 0.3]"))
    with pytest.raises(InputFormatError, match=rf"unknown key '{bad_key}' in table '{table}'"):
        load_vehicle(path)


@pytest.mark.parametrize("attr", ["track", "wheel_radius", "longitudinal_stiffness", "cornering_stiffness"])
def test_invalid_pairs_are_refused_by_the_dataclass_too(attr):
    with pytest.raises(InputError, match=rf"{attr} must be one number"):
        CAR.with_changes(**{attr: (1.0, 1.0, 1.0)})
    with pytest.raises(InputError, match=rf"{attr}\[front\] must be finite and > 0"):
        CAR.with_changes(**{attr: (-1.0, 1.0)})
    assert getattr(CAR.with_changes(**{attr: np.array([2.0, 3.0])}), attr) == (2.0, 3.0)  # array_like accepted



@settings(max_examples=25, deadline=None)
@given(track=st.tuples(st.floats(1.2, 1.8), st.floats(1.2, 1.8)), radius=st.tuples(st.floats(0.25, 0.40),
                                                                                   st.floats(0.25, 0.40)),
       # plausible per-tyre stiffnesses for the default car's loads (4..50 and 4..30 times each tyre's load, session 38)
       cx=st.tuples(st.floats(2e4, 1.5e5), st.floats(2e4, 1.5e5)), cy=st.tuples(st.floats(2e4, 9e4), st.floats(2e4, 9e4)))
def test_to_toml_round_trips_a_staggered_car(tmp_path_factory, track, radius, cx, cy):
    car = CAR.with_changes(track=track, wheel_radius=radius, longitudinal_stiffness=cx, cornering_stiffness=cy,
                           name="staggered")
    path = tmp_path_factory.mktemp("cars") / "staggered.toml"
    path.write_text(car.to_toml())
    back = load_vehicle(path)
    assert back == car
    np.testing.assert_array_equal(back.as_array(), car.as_array())
    assert (back.tracks, back.wheel_radii) == (tuple(map(float, track)), tuple(map(float, radius)))


def test_the_packaged_default_car_is_still_scalar_and_unchanged():
    assert CAR.track == 1.5 and CAR.wheel_radius == 0.3
    assert CAR.longitudinal_stiffness == 60000.0 and CAR.cornering_stiffness == 50000.0
    assert CAR.tracks == (1.5, 1.5) and CAR.cornering_stiffnesses == (50000.0, 50000.0)
    assert "[" not in CAR.to_toml().split("[wheels]")[1].split("friction")[0]  # written back as scalars


# --------------------------------------------------------------------------------------------- (b) Ackermann

@settings(max_examples=200, deadline=None)
@given(delta=st.floats(1e-3, 0.6), sign=st.sampled_from([1.0, -1.0]), lf=st.floats(0.9, 1.6),
       lr=st.floats(1.0, 1.9), track=st.floats(1.2, 1.8))
def test_ackermann_angles_satisfy_the_closed_form(delta, sign, lf, lr, track):
    car = CAR.with_changes(cg_to_front_axle=lf, cg_to_rear_axle=lr, track=(track, 1.55))
    L = lf + lr
    d = sign * delta
    fl, fr = ackermann_angles(np.array([d]), car)[0]
    inner, outer = (fl, fr) if d > 0 else (fr, fl)  # a left turn (delta > 0) has the left wheel inside
    assert np.sign(fl) == np.sign(fr) == np.sign(d)
    assert abs(inner) > abs(d) > abs(outer)  # the inner wheel steers more
    # Ackermann condition: both wheel normals meet on the rear axle line, cot(outer) - cot(inner) = S_f / L
    assert 1 / math.tan(abs(outer)) - 1 / math.tan(abs(inner)) == pytest.approx(track / L, rel=1e-9)
    # ... at the bicycle model's turn centre L / tan(delta) (the front track, not the rear one, counts)
    assert 1 / math.tan(abs(inner)) == pytest.approx(1 / math.tan(delta) - track / (2 * L), rel=1e-9)
    # sign symmetry: steering the other way swaps and negates the two wheels
    np.testing.assert_allclose(ackermann_angles(np.array([-d]), car)[0], [-fr, -fl], rtol=1e-14, atol=0)
    # their mean is the bicycle angle to third order: mean - delta ~ (S/2L)^2 delta^3
    if delta <= 0.3:
        assert abs(0.5 * (fl + fr) - d) <= 1.2 * (track / (2 * L)) ** 2 * delta ** 3 + 1e-15


def test_ackermann_angles_are_zero_at_zero_and_keep_the_shape():
    out = ackermann_angles(np.zeros(5), CAR)
    assert out.shape == (5, 2)
    np.testing.assert_array_equal(out, 0.0)
    small = ackermann_angles(np.array([1e-6]), CAR)[0]
    np.testing.assert_allclose(small, 1e-6, rtol=1e-6)


def test_simulator_ackermann_option():
    sc = _turning(duration=4.0)
    sim = simulate_drive(sc, CAR, seed=0, steering_geometry="ackermann")
    np.testing.assert_array_equal(sim.truth.wheel_steering, ackermann_angles(sc.steering, CAR))
    assert sim.log.wheel_steering.shape == (sc.steering.size, 2)
    # the measured wheel angles carry the steering sensor model (offset 5e-4 rad, noise 2e-4, step 1e-4)
    err = sim.log.wheel_steering - sim.truth.wheel_steering
    assert abs(err.mean() - 5e-4) < 5e-5 and err.std() < 4e-4
    frame = sim.log.to_frame()
    assert {"steer_fl", "steer_fr"} <= set(frame.columns) and {"true_steer_fl"} <= set(sim.to_frame().columns)
    parallel = simulate_drive(sc, CAR, seed=0)
    assert parallel.log.wheel_steering is None and parallel.truth.wheel_steering is None
    # the two geometries turn the car differently (inner wheel steers more than the parallel one)
    assert np.abs(sim.truth.yaw_rate - parallel.truth.yaw_rate).max() > 3e-4  # 6.4e-4 rad/s measured
    with pytest.raises(InputError, match="steering_geometry must be 'parallel' or 'ackermann'"):
        simulate_drive(sc, CAR, steering_geometry="anti-ackermann")


# ---------------------------------------------------------------------------------------------- (c) log columns

def _turning(amp=0.12, speed=10.0, duration=12.0, mu=0.8, dt=1e-3):
    """Sine steering at 0.2 Hz (lateral acceleration up to 0.42 g at the defaults), flat then a 3 degree grade; the road
    adhesion is the car file's (0.8), so the estimator's tyre model is right."""
    t = np.arange(int(round(duration / dt))) * dt
    steer = amp * np.sin(2 * np.pi * 0.2 * (t - 1.0)) * np.clip((t - 1.0) / 2.0, 0.0, 1.0)
    s = np.arange(0.0, 2000.0, 0.5)
    slope = np.radians(3.0) * np.clip((s - 60.0) / 60.0, 0.0, 1.0)
    return DriveScenario("turning", dt, np.full(t.size, speed), steer, s, slope, np.full((s.size, 2), mu), speed)


@pytest.fixture(scope="module")
def ackermann_drive():
    return simulate_drive(_turning(), CAR, seed=0, steering_geometry="ackermann")


def test_steer_columns_are_read_and_used_by_the_estimator(ackermann_drive):
    sim = ackermann_drive
    tr, m = sim.truth, sim.log.time >= 2.0
    frame = sim.log.to_frame()
    log, _ = read_drive_log(frame, CAR)
    np.testing.assert_array_equal(log.wheel_steering, sim.log.wheel_steering)
    u = planar_inputs(log, CAR)
    np.testing.assert_array_equal(u[:, 0], log.wheel_steering[:, 0])  # delta_FL
    np.testing.assert_array_equal(u[:, 12], log.wheel_steering[:, 1])  # delta_FR
    bare, _ = read_drive_log(frame.drop(columns=["steer_fl", "steer_fr"]), CAR)
    assert bare.wheel_steering is None
    with_wheels, bicycle = estimate_slope(log, CAR), estimate_slope(bare, CAR)
    assert np.abs(with_wheels.vy - bicycle.vy).max() > 1e-3
    # the Ackermann truth is better explained by the two measured angles than by the bicycle angle:
    # measured 0.0020 vs 0.0037 m/s RMS of V_y on this drive (seeds 0-2)
    assert _rms(with_wheels.vy - tr.vy, m) < 0.7 * _rms(bicycle.vy - tr.vy, m)


def test_equal_steer_columns_act_exactly_as_that_steering_angle(ackermann_drive):
    frame = ackermann_drive.log.to_frame()
    delta = frame["steering_angle"].to_numpy()
    # the steer columns take precedence: steering_angle (here deliberately 20 % off) is not used by the model
    both = frame.assign(steer_fl=delta, steer_fr=delta, steering_angle=1.2 * delta)
    only = frame.drop(columns=["steer_fl", "steer_fr"])
    a = estimate_slope(read_drive_log(both, CAR, check=False)[0], CAR)
    b = estimate_slope(read_drive_log(only, CAR, check=False)[0], CAR)
    for k in ("vx", "vy", "yaw_rate", "slope"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    np.testing.assert_array_equal(a.fx, b.fx)


def test_steering_angle_may_be_omitted_and_steer_columns_take_units(ackermann_drive):
    frame = ackermann_drive.log.to_frame()
    g = frame.drop(columns=["steering_angle"])
    log = DriveLog.from_frame(g)
    np.testing.assert_allclose(log.steering_angle, 0.5 * (frame.steer_fl + frame.steer_fr), rtol=0, atol=1e-18)
    deg = g.assign(steer_fl=np.degrees(g.steer_fl), steer_fr=np.degrees(g.steer_fr))
    deg = deg.rename(columns={"steer_fl": "steer_fl [deg]", "steer_fr": "steer_fr [deg]"})
    back, _ = read_drive_log(deg, CAR)
    np.testing.assert_allclose(back.wheel_steering, ackermann_drive.log.wheel_steering, rtol=1e-13, atol=1e-16)


def test_one_steer_column_alone_is_an_error_naming_the_other(ackermann_drive):
    frame = ackermann_drive.log.to_frame()
    with pytest.raises(InputFormatError, match="'steer_fr' is missing: the wheel steering angles come as a pair"):
        DriveLog.from_frame(frame.drop(columns=["steer_fr"]))
    with pytest.raises(InputFormatError, match="'steer_fl' is missing"):
        read_drive_log(frame.drop(columns=["steer_fl"]), CAR)


@pytest.fixture(scope="module")
def staggered_paper():
    return simulate_drive("paper", STAGGERED, seed=0)


@pytest.mark.parametrize("unit, factor", [("m/s", 1.0), ("km/h", 3.6)])
def test_translational_wheel_speeds_convert_with_each_wheels_own_radius(staggered_paper, unit, factor):
    log = staggered_paper.log
    frame = log.to_frame().iloc[:12000].reset_index(drop=True)
    radii = STAGGERED.wheel_radius_of_each
    assert radii[2] / radii[0] == pytest.approx(1.1)  # a single radius would be 10 % off on one axle
    speeds = frame.assign(**{c: frame[c] * radii[i] * factor for i, c in enumerate(WHEELS)})
    back, checks = read_drive_log(speeds, STAGGERED, units=dict.fromkeys(WHEELS, unit))
    np.testing.assert_allclose(back.wheel_speeds, frame[WHEELS].to_numpy(), rtol=1e-13)
    assert all(c.ok is not False for c in checks)
    via_header, _ = read_drive_log(speeds.rename(columns={c: f"{c} [{unit}]" for c in WHEELS}), STAGGERED)
    np.testing.assert_allclose(via_header.wheel_speeds, back.wheel_speeds, rtol=0, atol=0)


def test_convert_units_takes_a_radius_per_column():
    from longprofile.errors import UnitsError
    from longprofile.vehicle._logs import convert_units

    frame = pd.DataFrame({"a": [3.0, 6.0], "b": [3.3, 6.6]})
    q = {"a": "wheel", "b": "wheel"}
    out = convert_units(frame, {"a": "m/s", "b": "m/s"}, q, wheel_radius={"a": 0.30, "b": 0.33})
    np.testing.assert_allclose(out[["a", "b"]].to_numpy(), [[10.0, 10.0], [20.0, 20.0]], rtol=1e-15)
    with pytest.raises(UnitsError, match="column 'b' in m/s: a wheel radius is needed"):
        convert_units(frame, {"a": "m/s", "b": "m/s"}, q, wheel_radius={"a": 0.30})


def test_a_correct_staggered_log_passes_the_checks(staggered_paper):
    _, checks = read_drive_log(staggered_paper.log.to_frame().iloc[:12000].reset_index(drop=True), STAGGERED)
    by = {c.name: c for c in checks}
    assert by["yaw_rate_vs_wheels"].ok and abs(by["yaw_rate_vs_wheels"].ratio - 1) < 0.02
    assert by["steering_vs_yaw_rate"].ok and by["accel_y_vs_vx_r"].ok
    assert by["front_vs_rear_wheel_speed"].ok and abs(by["front_vs_rear_wheel_speed"].ratio - 1) < 0.01


def test_a_staggered_car_described_with_one_radius_is_refused_naming_the_radius(staggered_paper):
    """The averaged description gives a 21 deg slope error with exit 0 unless the log check sees the radii."""
    frame = staggered_paper.log.to_frame().iloc[:12000].reset_index(drop=True)
    with pytest.raises(UnitsError, match=r"wheels\.radius.*staggered") as err:
        read_drive_log(frame, AVERAGED)
    # the suggested front radius, with the rear one right: 0.315 / 1.10 ~ 0.286 (the rear is 0.315, not 0.33)
    suggested = float(re.search(r"front one is about ([0-9.]+) m", str(err.value)).group(1))
    assert abs(suggested - 0.315 * 0.30 / 0.33) < 0.005
    _, checks = read_drive_log(frame, AVERAGED, check=False)
    assert checks == ()


# ---------------------------------------------------------------------------------------- (d) staggered accuracy

@pytest.mark.parametrize("method", ["cascade", "joint"])
def test_the_staggered_description_beats_the_averaged_one(staggered_paper, method):
    # measured on seeds 0-9 (docs/vehicle-slope.md, "Per-axle parameters"): right / averaged description,
    # cascade RMS V_x 0.0027 / 1.13 m/s, V_y 0.0026 / 0.068 m/s, slope 0.20 / 21.5 deg
    sim = staggered_paper
    tr, m = sim.truth, sim.log.time >= 2.0
    right = estimate_slope(sim.log, STAGGERED, method=method)
    averaged = estimate_slope(sim.log, AVERAGED, method=method)
    for k in ("vx", "vy"):
        assert _rms(getattr(right, k) - getattr(tr, k), m) < 0.2 * _rms(getattr(averaged, k) - getattr(tr, k), m), k
    assert _rms(right.slope - tr.slope, m) < 0.1 * _rms(averaged.slope - tr.slope, m)
    # the right description meets the paper-scenario targets of the equal-axle car (test_slope.py)
    assert np.degrees(_rms(right.slope - tr.slope, m)) <= 0.3
    assert _rms(right.vx - tr.vx, m) / _rms(tr.vx, m) <= 0.01 and _rms(right.vy - tr.vy, m) <= 0.1


def test_per_axle_cornering_stiffness_alone_improves_the_sideslip(staggered_paper):
    # radius right, only C_y averaged: V_x and the slope hardly change, V_y does (0.0026 vs 0.0063 m/s RMS)
    sim = staggered_paper
    tr, m = sim.truth, sim.log.time >= 2.0
    right = estimate_slope(sim.log, STAGGERED)
    cy_avg = estimate_slope(sim.log, STAGGERED.with_changes(cornering_stiffness=49500.0))
    assert _rms(right.vy - tr.vy, m) < 0.6 * _rms(cy_avg.vy - tr.vy, m)


def test_a_staggered_simulation_is_consistent_with_the_ekf_step():
    # the EKF's Euler step fed with the true inputs reproduces the simulator's RK4 step on a staggered,
    # Ackermann-steered car (per-axle radius, track and stiffnesses, two steer angles), as on the default car
    from longprofile.vehicle import SensorSpec, planar_ekf_model

    car = STAGGERED.with_changes(track=(1.52, 1.58), longitudinal_stiffness=(55000.0, 65000.0))
    sim = simulate_drive(_turning(duration=8.0), car, sensors=SensorSpec.ideal(), steering_geometry="ackermann")
    tr = sim.truth
    model = planar_ekf_model(car, sim.log.dt)
    worst = {"wheels": np.zeros(3), "bicycle": np.zeros(3)}
    for k in range(1, tr.vx.size - 1, 97):
        x = np.array([tr.vx[k], tr.vy[k], tr.yaw_rate[k]])
        x_next = np.array([tr.vx[k + 1], tr.vy[k + 1], tr.yaw_rate[k + 1]])
        for label, (dl, dr) in (("wheels", tr.wheel_steering[k]), ("bicycle", (tr.steering_angle[k],) * 2)):
            u = np.concatenate([[dl], tr.wheel_speeds[k], [tr.accel_x[k - 1], tr.accel_y[k - 1]], [tr.slope[k]],
                                tr.friction[k], [dr]])  # the simulator's loads lag one step
            worst[label] = np.maximum(worst[label], np.abs(model.transition_fn(*model.model_args(x, u, k)) - x_next))
    assert np.all(worst["wheels"] < 2e-5), worst
    assert worst["bicycle"][1] > 2 * worst["wheels"][1]  # one angle for both wheels is a model error here


def test_dataclass_replace_keeps_the_log_valid(ackermann_drive):
    log = dataclasses.replace(ackermann_drive.log, wheel_steering=None)
    np.testing.assert_array_equal(log.front_steering, np.column_stack([log.steering_angle] * 2))
    from longprofile.errors import ShapeError

    with pytest.raises(ShapeError, match=r"wheel_steering must have shape \(T, 2\)"):
        dataclasses.replace(ackermann_drive.log, wheel_steering=np.zeros((3, 2)))


# ------------------------------------------------------------------------------------ steer consistency checks

def test_consistent_steer_channels_pass_the_three_steer_checks(ackermann_drive):
    frame = ackermann_drive.log.to_frame()
    for g in (frame, frame.drop(columns=["steering_angle"]),
              frame.assign(steer_fl=frame.steering_angle, steer_fr=frame.steering_angle)):  # parallel linkage
        _, checks = read_drive_log(g, CAR)
        by = {c.name: c for c in checks}
        for name in ("steer_fr_vs_steer_fl", "steer_difference_vs_ackermann", "steering_angle_vs_steer_mean",
                     "steering_vs_yaw_rate"):
            assert by[name].ok is True, (name, by[name])
        assert abs(by["steer_fr_vs_steer_fl"].ratio - 1) < 0.05
    # a log without the steer channels has the axle-speed checks only, none of the steer ones
    _, checks = read_drive_log(frame.drop(columns=["steer_fl", "steer_fr"]), CAR)
    assert [c.name for c in checks] == ["yaw_rate_vs_wheels", "accel_y_vs_vx_r", "steering_offset",
                                        "steering_vs_yaw_rate", "steering_gain", "accel_x_vs_dvx",
                                        "front_vs_rear_wheel_speed", "axle_order"]


STEER_MISTAKES = [
    ("steer_fr of opposite sign", lambda f: f.assign(steer_fr=-f.steer_fr),
     ["steer_fr / steer_fl = -1", "opposite signs"]),
    ("steer_fr in degrees", lambda f: f.assign(steer_fr=np.degrees(f.steer_fr)),
     ["steer_fr / steer_fl = 57", "steer_fr in degrees"]),
    ("3 degree offset on steer_fr", lambda f: f.assign(steer_fr=f.steer_fr + np.radians(3.0)),
     ["steer_fl - steer_fr", "Ackermann linkage gives", "offset between the two steer sensors"]),
    ("steering_angle is the steering-wheel angle", lambda f: f.assign(steering_angle=15 * f.steering_angle),
     ["steering_angle / mean(steer_fl, steer_fr) = 15", "steering-WHEEL angle", "does not use steering_angle"]),
    ("both steer channels of opposite sign", lambda f: f.assign(steer_fl=-f.steer_fl, steer_fr=-f.steer_fr),
     ["mean(steer_fl, steer_fr) has the opposite sign of the turn", "negate steer_fl and steer_fr"]),
]


@pytest.mark.parametrize("name, transform, texts", STEER_MISTAKES, ids=[m[0] for m in STEER_MISTAKES])
def test_inconsistent_steer_channels_are_reported_naming_them(ackermann_drive, name, transform, texts):
    from longprofile.errors import UnitsError

    with pytest.raises(UnitsError, match="implausible channels") as exc:
        read_drive_log(transform(ackermann_drive.log.to_frame()), CAR, source="car.csv")
    for text in texts:
        assert text in str(exc.value), (text, str(exc.value))
