"""Planar 4-wheel model of paper 001, eq. (11)-(20): Jacobians, physics checks against textbook oracles."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.vehicle import (
    DriveScenario,
    SensorSpec,
    default_vehicle,
    drive_scenario,
    planar_ekf_model,
    simulate_drive,
    slope_ekf_model,
)

CAR = default_vehicle()
STAGGERED = CAR.with_changes(track=(1.58, 1.60), wheel_radius=(0.30, 0.309), longitudinal_stiffness=(60000.0, 70000.0),
                             cornering_stiffness=(50000.0, 65000.0))
G = 9.80665


def _fd(fn, x, u, params, h=1e-6, side=0):
    """Central (side 0) or one-sided (+1 forward, -1 backward) finite-difference Jacobian."""
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h * max(1.0, abs(x[j]))
        hi, lo = (x + e, x - e) if side == 0 else ((x + e, x) if side > 0 else (x, x - e))
        cols.append((fn(hi, u, 0, params) - fn(lo, u, 0, params)) / (np.sum(hi - lo)))
    return np.stack(cols, axis=1)


def _assert_jacobian(J, fn, x, u, params, rtol=1e-5, atol=1e-8):
    """J equals the central difference; where a step straddles a kink of the model (the Dugoff force's branch change
    at lambda = 1 is continuous but not differentiable) the forward and backward slopes differ, and J must be one of
    them (the analytic Jacobian takes the branch of the point itself)."""
    central = _fd(fn, x, u, params)
    ok = np.isclose(J, central, rtol=rtol, atol=atol)
    if ok.all():
        return
    fwd, bwd = _fd(fn, x, u, params, side=1), _fd(fn, x, u, params, side=-1)
    kink = ~np.isclose(fwd, bwd, rtol=1e-4, atol=atol)
    one_sided = np.isclose(J, fwd, rtol=1e-3, atol=atol) | np.isclose(J, bwd, rtol=1e-3, atol=atol)
    assert np.all(ok | (kink & one_sided)), (J, central, fwd, bwd)


@st.composite
def operating_points(draw):
    vx = draw(st.floats(3.0, 40.0))
    x = np.array([vx, draw(st.floats(-1.0, 1.0)), draw(st.floats(-0.5, 0.5))])
    u = np.empty(13)
    u[0] = draw(st.floats(-0.1, 0.1))                     # steering FL
    u[12] = u[0] + draw(st.sampled_from([0.0, 0.0, -0.01, 0.004]))  # FR: equal, or toe / Ackermann
    for i in range(4):                                     # wheel speeds: slips of +-15 %
        u[1 + i] = vx * (1 + draw(st.floats(-0.15, 0.15))) / CAR.wheel_radius
    u[5] = draw(st.floats(-6.0, 6.0))                      # a_x
    u[6] = draw(st.floats(-6.0, 6.0))                      # a_y
    u[7] = draw(st.floats(-0.15, 0.15))                    # slope input
    u[8:12] = draw(st.sampled_from([0.2, 0.5, 0.8, 1.0]))  # mu: saturated and linear Dugoff branches
    theta = draw(st.floats(-0.15, 0.15))
    return x, u, theta


@settings(max_examples=60, deadline=None)
@given(operating_points())
def test_ekf_jacobians_match_finite_differences(point):
    x, u, theta = point
    for car in (CAR, STAGGERED):  # equal axles, and per-axle track, radius and stiffnesses
        model = planar_ekf_model(car, 1e-3)
        p = model.kernel_params()
        _assert_jacobian(model.transition_jacobian(x, u, 0, p), model.transition_fn, x, u, p)
        H = model.observation_jacobian(x, u, 0, p)
        np.testing.assert_allclose(H, _fd(model.observation_fn, x, u, p), atol=1e-9)
        joint = slope_ekf_model(car, 1e-3)
        xj = np.append(x, theta)
        pj = joint.kernel_params()
        _assert_jacobian(joint.transition_jacobian(xj, u, 0, pj), joint.transition_fn, xj, u, pj)


def test_eq20_yaw_row_uses_yaw_inertia_not_mass():
    # pure yaw moment: only the right wheels pull (omega differs), so dr/dt = M_z / I_z (eq. (11)); eq. (20)
    # as printed divides by M, which would make the yaw response I_z / M = 1.7 times larger.
    model = planar_ekf_model(CAR, 1e-3)
    x = np.array([20.0, 0.0, 0.0])
    u = np.zeros(13)
    u[1:5] = 20.0 / CAR.wheel_radius
    u[2] *= 1.002
    u[8:12] = 1.0
    x1 = model.transition_fn(*model.model_args(x, u, 0))
    fx = CAR.longitudinal_stiffness * 0.002 / 1.002 / (1 - 0.002 / 1.002)  # Dugoff linear branch, eq. (15)
    mz = CAR.track / 2 * fx
    assert (x1[2] - x[2]) / 1e-3 == pytest.approx(mz / CAR.yaw_inertia, rel=1e-6)
    assert (x1[0] - x[0]) / 1e-3 == pytest.approx((fx - CAR.aero_longitudinal * 400) / CAR.mass, rel=1e-6)


def _steady_scenario(speed, steer, slope_deg=0.0, duration=8.0, dt=2e-3):
    t = np.arange(int(duration / dt)) * dt
    ramp = np.clip(t / 1.0, 0, 1)
    s = np.arange(0.0, 400.0, 1.0)
    return DriveScenario("steady", dt, np.full(t.size, speed), steer * ramp, s, np.full(s.size, np.radians(slope_deg)),
                         np.full((s.size, 2), 1.0), speed)


def test_steady_cornering_matches_linear_bicycle_model():
    # textbook oracle (Rajamani 2012, eq. 3.29-ish / Gillespie): r = V delta / (L + K V^2),
    # K = M/L (l_r/C_f - l_f/C_r), axle cornering stiffness C = 2 C_y0, valid in the linear tyre range.
    V, delta = 20.0, 0.01
    sim = simulate_drive(_steady_scenario(V, delta), CAR, sensors=SensorSpec.ideal(), seed=0)
    L = CAR.wheelbase
    C = 2 * CAR.cornering_stiffness
    K = CAR.mass / L * (CAR.cg_to_rear_axle / C - CAR.cg_to_front_axle / C)
    r_expected = V * delta / (L + K * V ** 2)
    r = sim.truth.yaw_rate[-500:].mean()
    assert r == pytest.approx(r_expected, rel=0.02)
    # lateral acceleration = V r in steady state, and the accelerometer channel agrees
    assert sim.truth.accel_y[-500:].mean() == pytest.approx(V * r, rel=0.01)


def test_loads_and_force_balance_on_a_grade():
    sim = simulate_drive(_steady_scenario(20.0, 0.0, slope_deg=4.0, duration=6.0), CAR, sensors=SensorSpec.ideal())
    tr = sim.truth
    theta = np.radians(4.0)
    # eq. (19): the four loads carry M g cos(theta) at every step
    np.testing.assert_allclose(tr.normal_force.sum(axis=1), CAR.mass * G * np.cos(theta), rtol=1e-12)
    # steady climb: traction balances grade and drag; front (driven) axle carries it
    last = slice(-500, None)
    traction = tr.fx[last].sum(axis=1).mean()
    assert traction == pytest.approx(CAR.mass * G * np.sin(theta) + CAR.aero_longitudinal * 400.0, rel=2e-3)
    assert abs(tr.fx[last, 2:].mean()) < 1.0
    # accelerometer reads the grade at constant speed (specific force)
    assert tr.accel_x[last].mean() == pytest.approx(G * np.sin(theta) + 0.0, abs=2e-3)
    # longitudinal load transfer H M a_x / L moves load to the rear axle
    front = tr.normal_force[last, :2].sum(axis=1).mean()
    expected_front = CAR.mass * (G * np.cos(theta) * CAR.cg_to_rear_axle - CAR.cg_height * tr.accel_x[last].mean()) / CAR.wheelbase
    assert front == pytest.approx(expected_front, rel=1e-6)


def test_ekf_transition_agrees_with_the_simulator_physics():
    # the EKF's Euler step (eq. (20), allocation-free kernel) fed with the true inputs reproduces the
    # simulator's RK4 step (independent implementation of (11)-(19)) to O(dt^2)
    sim = simulate_drive(drive_scenario("low-mu", duration=12.0), CAR, sensors=SensorSpec.ideal())
    tr = sim.truth
    dt = sim.log.dt
    model = planar_ekf_model(CAR, dt)
    worst = np.zeros(3)
    for k in range(1, tr.vx.size - 1, 97):
        u = np.concatenate([[tr.steering_angle[k]], tr.wheel_speeds[k], [tr.accel_x[k - 1], tr.accel_y[k - 1]],
                            [tr.slope[k]], tr.friction[k], [tr.steering_angle[k]]])  # loads lag one step
        x = np.array([tr.vx[k], tr.vy[k], tr.yaw_rate[k]])
        x_next = np.array([tr.vx[k + 1], tr.vy[k + 1], tr.yaw_rate[k + 1]])
        worst = np.maximum(worst, np.abs(model.transition_fn(*model.model_args(x, u, k)) - x_next))
    assert np.all(worst < [2e-5, 2e-5, 2e-5]), worst
