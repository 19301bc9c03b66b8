"""7-DOF vertical model, simulator, sensors and observability of thesis 003."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, InputFormatError, ShapeError
from longprofile.road import Profile
from longprofile.vehicle import (
    VerticalVehicleParams,
    bench_sweep_road,
    corner_observability,
    measure_vertical,
    sensors_from_frame,
    sensors_to_frame,
    simulate_vertical,
    steering_sine_manoeuvre,
    wheel_road_inputs,
)
from longprofile.vehicle.vertical._model import (
    NO_MR,
    corner_observation,
    corner_observation_jacobian,
    corner_observation_step,
    corner_transition,
    corner_transition_jacobian,
    corner_transition_step,
    damper_force,
    spring_force,
    vertical_params_arrays,
)

DT = 1e-3
P = VerticalVehicleParams()


@pytest.fixture(scope="module")
def manoeuvre_sim():
    rng = np.random.default_rng(0)
    T = 2000
    road = np.cumsum(rng.normal(0, 2e-4, (T, 4)), axis=0)
    ax, ay, psidd = steering_sine_manoeuvre(DT, duration=(T - 1) * DT, f_end=3.0)
    return simulate_vertical(road, DT, ax=ax + 1.0, ay=ay, yaw_accel=psidd)


def test_thesis_parameter_checks():
    # digest §2.6 sanity checks: m = 1810 kg, wheel hop 12.9 Hz front / 13.3 Hz rear (measured ~13 Hz)
    assert P.sprung_mass == pytest.approx(1810.0)
    assert P.wheel_hop_frequency(0) == pytest.approx(12.9, abs=0.05)
    assert P.wheel_hop_frequency(1) == pytest.approx(13.3, abs=0.1)
    assert P.roll_axis_inertia == pytest.approx(1400 + 1810 * 0.36)


def test_invalid_parameters_raise():
    with pytest.raises(InputError, match="tyre_stiffness must be > 0"):
        VerticalVehicleParams(tyre_stiffness=0.0)
    with pytest.raises(InputError, match="damper_rebound must be three"):
        VerticalVehicleParams(damper_rebound=(1.0, 2.0, 0.0))
    with pytest.raises(InputError, match="must exceed the four wheel masses"):
        VerticalVehicleParams(total_mass=150.0)


def test_steady_cornering_and_braking_load_transfer_match_textbook():
    # total lateral load transfer = M a_y h_cg (moment about the ground), longitudinal = M a_x h_cg / L
    T = 4000
    ay = 4.0
    sim = simulate_vertical(np.zeros((T, 4)), DT, ay=np.full(T, ay))
    half = np.array([P.track_front, P.track_front, P.track_rear, P.track_rear]) / 2
    side = np.array([1, -1, 1, -1])
    moment = np.sum(sim.tyre_force[-1] * side * half)
    assert moment == pytest.approx(-P.total_mass * ay * P.cg_height, rel=2e-3)
    assert sim.state[-1, 1] > 0  # left side up in a left turn (a_y > 0)
    sim = simulate_vertical(np.zeros((T, 4)), DT, ax=np.full(T, -5.0))
    front_gain = sim.tyre_force[-1, :2].sum()
    assert front_gain == pytest.approx(P.total_mass * 5.0 * P.cg_height / P.wheelbase, rel=2e-3)
    assert sim.state[-1, 2] > 0  # nose down when braking


def test_static_equilibrium_is_kept():
    sim = simulate_vertical(np.full((500, 4), 0.02), DT)
    assert np.abs(sim.state[:, 7:]).max() < 1e-12
    assert np.abs(sim.suspension_deflection).max() < 1e-12


def test_corner_model_reproduces_the_seven_dof_accelerations(manoeuvre_sim):
    sim = manoeuvre_sim
    corner, coupling, scalars = vertical_params_arrays(P)
    for k in (10, 700, 1999):
        x = np.zeros(16)
        x[0::4], x[1::4], x[3::4] = sim.suspension_velocity[k], sim.suspension_deflection[k], sim.tyre_deflection[k]
        u = np.r_[sim.ax[k], sim.ay[k], sim.yaw_accel[k], np.zeros(4)]
        np.testing.assert_allclose(corner_observation(x, u, corner, coupling, scalars, 2, NO_MR)[4:],
                                   sim.body_accel[k], atol=1e-9)
        np.testing.assert_allclose(corner_observation(x, u, corner, coupling, scalars, 3, NO_MR)[4:],
                                   sim.wheel_accel[k], atol=1e-9)


def _fd(fn, x, scale):
    J = []
    for j in range(x.size):
        h = 1e-7 * scale[j]
        e = np.zeros_like(x)
        e[j] = h
        J.append((fn(x + e) - fn(x - e)) / (2 * h))
    return np.array(J).T


def test_jacobians_match_finite_differences(manoeuvre_sim):
    sim = manoeuvre_sim
    corner, coupling, scalars = vertical_params_arrays(P)
    k = 1500
    x = np.zeros(16)
    x[0::4], x[1::4], x[3::4] = sim.suspension_velocity[k], sim.suspension_deflection[k], sim.tyre_deflection[k]
    x[2::4] = [30.0, -20.0, 10.0, 5.0]
    u = np.r_[sim.ax[k], sim.ay[k], sim.yaw_accel[k], np.zeros(4)]
    scale = np.tile([1.0, 1.0, 1e4, 1.0], 4)
    Jn = _fd(lambda z: corner_transition(z, u, corner, coupling, scalars, DT, 0.99, 0.9, NO_MR), x, scale)
    J = corner_transition_jacobian(x, u, corner, coupling, scalars, DT, 0.99, 0.9, False, NO_MR)
    np.testing.assert_allclose(J, Jn, rtol=1e-6, atol=1e-9)
    Jd = corner_transition_jacobian(x, u, corner, coupling, scalars, DT, 0.99, 0.9, True, NO_MR)
    mask = np.kron(np.eye(4), np.ones((4, 4))) > 0
    assert np.all(Jd[~mask] == 0)
    for config in (2, 3):
        Hn = _fd(lambda z: corner_observation(z, u, corner, coupling, scalars, config, NO_MR), x, scale)
        H = corner_observation_jacobian(x, u, corner, coupling, scalars, config, False, NO_MR)
        np.testing.assert_allclose(H, Hn, rtol=1e-6, atol=1e-6)


def test_fused_steps_equal_the_separate_functions(manoeuvre_sim):
    # the block EKF's fast path must compute exactly f, h and the decentralised (block-diagonal) Jacobians
    sim = manoeuvre_sim
    corner, coupling, scalars = vertical_params_arrays(P)
    k = 1200
    x = np.zeros(16)
    x[0::4], x[1::4], x[3::4] = sim.suspension_velocity[k], sim.suspension_deflection[k], sim.tyre_deflection[k]
    x[2::4] = [30.0, -20.0, 10.0, 5.0]
    u = np.r_[sim.ax[k], sim.ay[k], sim.yaw_accel[k], 50.0, -20.0, 0.0, 10.0]
    out, J = np.zeros(16), np.full((16, 16), 7.0)
    corner_transition_step(x, u, corner, coupling, scalars, DT, 0.99, 0.9, NO_MR, out, J)
    np.testing.assert_array_equal(out, corner_transition(x, u, corner, coupling, scalars, DT, 0.99, 0.9, NO_MR))
    Jd = corner_transition_jacobian(x, u, corner, coupling, scalars, DT, 0.99, 0.9, True, NO_MR)
    nz = Jd != 0
    np.testing.assert_array_equal(J[nz], Jd[nz])
    assert np.all(J[~nz] == 7.0)  # structural zeros are not written (the engine keeps them at zero)
    for config in (1, 2, 3):
        m = 4 if config == 1 else 8
        y, H = np.zeros(m), np.zeros((m, 16))
        corner_observation_step(x, u, corner, coupling, scalars, config, NO_MR, y, H)
        np.testing.assert_array_equal(y, corner_observation(x, u, corner, coupling, scalars, config, NO_MR))
        np.testing.assert_array_equal(H, corner_observation_jacobian(x, u, corner, coupling, scalars, config, True,
                                                                     NO_MR))


@settings(max_examples=40, deadline=None)
@given(st.floats(-1.5, 1.5), st.floats(-0.12, 0.12))
def test_force_slopes_match_finite_differences(v, dz):
    a = (1938.0, 1237.0, 0.075, 823.3, 439.5, 0.1003, 1000.0)
    h = 1e-7
    f, slope = damper_force(v, *a)
    num = (damper_force(v + h, *a)[0] - damper_force(v - h, *a)[0]) / (2 * h)
    assert slope == pytest.approx(num, rel=1e-4, abs=1e-2)
    if v > 0.01:
        assert f > 0 and f > -damper_force(-v, *a)[0]  # rebound stiffer than compression
    fs, ks = spring_force(dz, 40e3, 61e3)
    assert fs == pytest.approx(40e3 * dz * (1 + 61e3 * dz ** 4))
    assert ks == pytest.approx((spring_force(dz + h, 40e3, 61e3)[0] - spring_force(dz - h, 40e3, 61e3)[0]) / (2 * h),
                               rel=1e-5)


def test_bench_sweep_has_constant_peak_velocity_and_thesis_frequencies():
    z = bench_sweep_road(DT, mode="pitch")
    assert z.shape == (35001, 4)
    np.testing.assert_array_equal(np.sign(z[100]), np.sign(z[100, 0]) * np.array([1, 1, -1, -1]))
    v = np.gradient(z[:, 0], DT)
    for t0 in (2.0, 15.0, 30.0):
        seg = slice(int(t0 / DT), int((t0 + 1.5) / DT))
        assert np.abs(v[seg]).max() == pytest.approx(0.157, rel=0.04)
    with pytest.raises(InputError, match="mode must be one of"):
        bench_sweep_road(DT, mode="yaw")


def test_rear_wheels_see_the_front_track_delayed():
    x = np.arange(0, 200.0, 0.05)
    z = np.column_stack([np.sin(x / 3.0), np.cos(x / 7.0)]) * 0.01
    prof = Profile(distance=x, elevation=z, tracks=("left", "right"))
    V = 20.0
    r = wheel_road_inputs(prof, V, DT, duration=5.0)
    lag = int(round(P.wheelbase / V / DT))
    np.testing.assert_allclose(r[lag:, 2], r[:-lag, 0], atol=2e-5)
    np.testing.assert_allclose(r[lag:, 3], r[:-lag, 1], atol=2e-5)
    with pytest.raises(InputError, match="lengthen the profile"):
        wheel_road_inputs(prof, V, DT, duration=100.0)


def test_sensors_are_quantised_seeded_and_round_trip(manoeuvre_sim):
    s1 = measure_vertical(manoeuvre_sim, 3, rng=4)
    s2 = measure_vertical(manoeuvre_sim, 3, rng=4)
    np.testing.assert_array_equal(s1.wheel_accel, s2.wheel_accel)
    q = 0.3 / 1024
    np.testing.assert_allclose(s1.displacement / q, np.round(s1.displacement / q), atol=1e-6)
    assert s1.body_accel is None
    err = s1.displacement - manoeuvre_sim.suspension_deflection
    assert 2e-8 < err.var() < 4e-8  # the thesis's R = 3e-8 m^2
    df = sensors_to_frame(s1, manoeuvre_sim)
    back = sensors_from_frame(df, 3)
    np.testing.assert_array_equal(back.wheel_accel, s1.wheel_accel)
    assert back.dt == pytest.approx(DT)
    with pytest.raises(InputFormatError, match="needs column"):
        sensors_from_frame(df, 2)
    with pytest.raises(InputError, match="config must be 1, 2 or 3"):
        measure_vertical(manoeuvre_sim, 4)


def test_simulator_input_errors():
    with pytest.raises(ShapeError, match=r"road must have shape \(T, 4\)"):
        simulate_vertical(np.zeros((10, 3)), DT)
    with pytest.raises(ShapeError, match="ay must have one value per sample"):
        simulate_vertical(np.zeros((10, 4)), DT, ay=np.zeros(9))


def test_absolute_model_common_shift_is_unobservable():
    # thesis §3.5.1: direction ~ [0 l 0 l 0 l] (Vs6 = [-0.01, 0.58, -0.01, 0.58, 0.01, 0.58])
    for config in (1, 2, 3):
        r = corner_observability(config, model="absolute")
        assert r.rank == 5
        np.testing.assert_allclose(np.abs(r.weakest_direction), [0, 3 ** -0.5, 0, 3 ** -0.5, 0, 3 ** -0.5], atol=1e-6)


def test_relative_model_disturbance_weakly_observable_with_displacements_only():
    # thesis §3.5.2: relative model observable; weakest direction almost pure P with displacement only (Vs4 P=-0.99);
    # a body accelerometer makes P appear in the measurement (larger smallest singular value).
    r1 = corner_observability(1)
    r2 = corner_observability(2)
    assert r1.rank == 4 and r1.state_names[2] == "P"
    assert abs(r1.weakest_direction[2]) > 0.99
    assert r2.singular_values[-1] > 50 * r1.singular_values[-1]
    with pytest.raises(InputError, match="model must be"):
        corner_observability(1, model="modal")


def test_friction_changes_the_simulated_car():
    road = bench_sweep_road(DT, duration=2.0, f_end=5.0)
    a = simulate_vertical(road, DT)
    b = simulate_vertical(road, DT, params=dataclasses.replace(P, suspension_friction=200.0))
    assert np.abs(a.suspension_velocity - b.suspension_velocity).max() > 1e-3


def test_the_model_functions_are_disk_cached_so_a_new_process_does_not_compile_them():
    """Start-up (issues 12, 14): without numba's disk cache every ``vehicle vertical estimate`` compiled the six
    closures and the engine loop specialised on them again (13 compilations, ~3 s of its 8.6 s). Since issue 12
    they are module-level functions taking the car as ``params``: one cached set for every car."""
    from numba.core.caching import NullCache

    from longprofile.vehicle.vertical._model import VerticalVehicleParams, vertical_ekf_model

    model = vertical_ekf_model(3, 1e-3, params=VerticalVehicleParams())
    fns = [model.transition_fn, model.observation_fn, model.transition_jacobian, model.observation_jacobian,
           model.transition_step, model.observation_step]
    assert all(not isinstance(fn._cache, NullCache) for fn in fns)
