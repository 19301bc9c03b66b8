"""The MagneRide (MR damper) car: MR force model, skyhook current, first-order lag, estimator map, tables."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from longprofile.errors import InputError, ShapeError
from longprofile.vehicle.vertical._estimate import damper_velocity_from_displacement, mr_actuator_force, nominal_mr_map
from longprofile.vehicle.vertical._evaluate import reproduce_thesis_tables
from longprofile.vehicle.vertical._model import mr_controlled_force, skyhook_current
from longprofile.vehicle.vertical._params import THESIS_MR_TIME_CONSTANT, MRDamperParams
from longprofile.vehicle.vertical._simulate import (
    measure_vertical,
    sensors_from_frame,
    sensors_to_frame,
    simulate_vertical,
    vertical_test_run,
)

MR = MRDamperParams()
current = st.floats(0.0, 5.0)
velocity = st.floats(-1.5, 1.5)


# ------------------------------------------------------------------------------------------------ physics


@given(current, current, velocity)
def test_mr_force_is_monotone_in_current_and_dissipative(i1, i2, v):
    lo, hi = sorted((i1, i2))
    f_lo = mr_controlled_force(lo, v, MR.max_force, MR.saturation_current, MR.yield_velocity)
    f_hi = mr_controlled_force(hi, v, MR.max_force, MR.saturation_current, MR.yield_velocity)
    assert f_lo * v >= 0.0 and f_hi * v >= 0.0                 # the force has the sign of the damper velocity
    assert abs(f_hi) >= abs(f_lo) - 1e-9                       # more current, more force
    assert abs(f_hi) <= MR.max_force                            # bounded by the saturated yield force


def test_mr_force_is_zero_without_current_and_odd_in_velocity():
    for v in (-0.3, -0.01, 0.0, 0.02, 0.5):
        assert mr_controlled_force(0.0, v, 3000.0, 2.0, 0.03) == 0.0
        assert mr_controlled_force(-1.0, v, 3000.0, 2.0, 0.03) == 0.0        # negative current counts as 0
        assert mr_controlled_force(3.0, -v, 3000.0, 2.0, 0.03) == -mr_controlled_force(3.0, v, 3000.0, 2.0, 0.03)
    # oracle: F_max (1 - e^{-i/i_sat}) tanh(v/v_y)
    assert mr_controlled_force(2.0, 0.03, 3000.0, 2.0, 0.03) == pytest.approx(3000 * (1 - math.exp(-1)) * math.tanh(1))


@given(st.floats(-0.6, 0.6), st.floats(-1.0, 1.0))
def test_skyhook_current_inverts_the_map_when_dissipative(z2d, v):
    arr = MR.as_array()
    i = skyhook_current(z2d, v, arr)
    assert 0.0 <= i <= MR.max_current
    if z2d * v <= 0.0:
        assert i == 0.0                                          # the damper cannot push: no current
        return
    f = mr_controlled_force(i, v, MR.max_force, MR.saturation_current, MR.yield_velocity)
    want = MR.skyhook_gain * abs(z2d)
    if i < MR.max_current:
        assert abs(f) == pytest.approx(want, rel=1e-9)           # the requested skyhook force c_sky |Z2dot|
        assert f * z2d >= 0                                      # pulling against the body velocity
    else:
        assert abs(f) <= want * (1 + 1e-12)                      # saturated: as much as the damper can


def test_current_to_force_lag_is_first_order():
    # oracle: from the recorded force and true damper velocity, recover the effective current and check the
    # exact first-order recursion i_eff[k+1] = i_cmd[k] + (i_eff[k] - i_cmd[k]) exp(-dt/tau)
    tau, dt = 0.015, 1e-3
    mr = MRDamperParams(time_constant=tau)
    sim, _ = vertical_test_run(1, test="road", duration=3.0, mr_damper=mr)
    v, F, icmd = sim.suspension_velocity, sim.actuator_force, sim.damper_current
    ok = np.abs(np.tanh(v / mr.yield_velocity)) > 0.3          # where the map is invertible accurately
    cap = np.where(ok, mr.max_force * np.tanh(v / mr.yield_velocity), 1.0)
    ratio = np.clip(np.where(ok, F / cap, 0.0), 0.0, 1 - 1e-12)
    ieff = -mr.saturation_current * np.log1p(-ratio)
    pred = icmd[:-1] + (ieff[:-1] - icmd[:-1]) * math.exp(-dt / tau)
    both = ok[:-1] & ok[1:]
    assert both.sum() > 1000 and (icmd > 0).mean() > 0.2        # the controller is active on a class C road
    np.testing.assert_allclose(ieff[1:][both], pred[both], atol=1e-6)
    lagged = np.abs(ieff[1:][both] - icmd[1:][both]).max()
    assert lagged > 0.5                                          # the lag is visible (the current jumps)
    # tau = 0: the force is the static map at the commanded current
    sim0, _ = vertical_test_run(1, test="road", duration=1.0, mr_damper=dataclasses.replace(mr, time_constant=0.0))
    static = mr_actuator_force(sim0.damper_current, sim0.suspension_velocity,
                               dataclasses.replace(mr, time_constant=0.0))
    np.testing.assert_allclose(sim0.actuator_force, static, rtol=1e-12, atol=1e-9)


def test_mr_car_without_current_is_the_passive_car():
    # oracle: skyhook gain 0 -> zero current -> exactly the passive car's motion
    sim_p, _ = vertical_test_run(1, test="road", duration=1.0)
    sim_m, sens = vertical_test_run(1, test="road", duration=1.0, mr_damper=MRDamperParams(skyhook_gain=0.0))
    np.testing.assert_array_equal(sim_m.state, sim_p.state)
    assert np.all(sens.damper_current == 0.0) and sim_p.damper_current is None
    assert THESIS_MR_TIME_CONSTANT == pytest.approx(1 / (2 * np.pi * 80))


def test_skyhook_reduces_body_velocity():
    sim_p, _ = vertical_test_run(1, test="road", duration=6.0)
    sim_m, _ = vertical_test_run(1, test="road", duration=6.0, mr_damper=MR)
    assert np.std(sim_m.body_velocity) < 0.95 * np.std(sim_p.body_velocity)


def test_mr_params_and_simulator_input_errors():
    with pytest.raises(InputError, match="max_current"):
        MRDamperParams(max_current=0.0)
    with pytest.raises(InputError, match="time_constant"):
        MRDamperParams(time_constant=-0.01)
    road = np.zeros((10, 4))
    with pytest.raises(InputError, match="not both"):
        simulate_vertical(road, 1e-3, mr_damper=MR, actuator_force=np.zeros((10, 4)))
    with pytest.raises(InputError, match="MRDamperParams"):
        simulate_vertical(road, 1e-3, mr_damper="magneride")


# ------------------------------------------------------------------------------------------------ estimator side


def test_nominal_map_and_actuator_force():
    nm = nominal_mr_map(MRDamperParams(time_constant=0.02), force_error=0.12)
    assert nm.time_constant == 0.0 and nm.max_force == pytest.approx(1.12 * 3000.0)
    i = np.array([[0.0, 1.0, 5.0, -2.0]])
    v = np.array([[0.1, -0.1, 0.1, 0.1]])
    f = mr_actuator_force(i, v, nm)
    assert f[0, 0] == 0.0 and f[0, 3] == 0.0 and f[0, 1] < 0 < f[0, 2]
    np.testing.assert_allclose(mr_actuator_force(i, v, nominal_mr_map(MR, force_error=0.0)) * 1.12, f)
    with pytest.raises(ShapeError):
        mr_actuator_force(np.zeros((5, 4)), np.zeros((4, 4)))
    with pytest.raises(InputError, match="force_error"):
        nominal_mr_map(MR, force_error=-1.5)


def test_damper_velocity_from_displacement_follows_a_slow_sine():
    dt = 1e-3
    t = np.arange(4000) * dt
    d = 0.02 * np.sin(2 * np.pi * 1.0 * t)[:, None] * np.ones(4)
    v = damper_velocity_from_displacement(d, dt)
    true = 0.02 * 2 * np.pi * np.cos(2 * np.pi * t)
    # 1 Hz, well inside the 20 Hz band: amplitude within 1 %, phase lag ~ sqrt(2) f / f_c = 0.07 rad
    assert abs(np.std(v[1000:, 0]) / np.std(true[1000:]) - 1) < 0.01
    assert np.max(np.abs(v[1000:, 0] - true[1000:])) < 0.08 * 0.126


def test_sensor_log_round_trip_keeps_the_currents():
    sim, _ = vertical_test_run(1, test="road", duration=0.5, mr_damper=MR)
    sens = measure_vertical(sim, 3, rng=0)
    np.testing.assert_array_equal(sens.damper_current, sim.damper_current)
    back = sensors_from_frame(sensors_to_frame(sens, sim), 3)
    np.testing.assert_array_equal(back.damper_current, sens.damper_current)
    passive = sensors_from_frame(sensors_to_frame(measure_vertical(vertical_test_run(1, duration=0.5)[0], 1)), 1)
    assert passive.damper_current is None


# ------------------------------------------------------------------------------------------------ tables

DURATION = 8.0  # the orders asserted hold at 8 s and at the documented 30 s (docs, "MagneRide car")


@pytest.fixture(scope="module")
def magneride_tables():
    return {ref: reproduce_thesis_tables(duration=DURATION, seed=0, reference=ref, car="magneride")
            for ref in ("truth", "thesis")}


def _eps(df, test, variable):
    sub = df[(df["test"] == test) & (df["variable"] == variable)].set_index("config")["epsilon"]
    return {c: float(sub[c]) for c in (1, 2, 3)}


@pytest.mark.parametrize("reference", ["truth", "thesis"])
def test_magneride_ranking(magneride_tables, reference):
    df = magneride_tables[reference]
    assert set(df["car"]) == {"magneride"}
    b = _eps(df, "bench", "body_velocity")
    assert b[2] > b[3] > b[1]                          # the THESIS's order 2 > 3 > 1 (ideal car: 3 > 2 > 1)
    for test in ("bench", "track"):
        v = _eps(df, test, "suspension_velocity")
        assert v[3] > v[2] > v[1]                      # thesis: 3 > 2 >= 1
        w = _eps(df, test, "wheel_velocity")
        assert w[3] > max(w[1], w[2])                  # thesis: 3 best
    t = _eps(df, "bench", "tyre_force")
    assert t[3] > t[2] > t[1]
    tb = _eps(df, "track", "body_velocity")
    assert tb[1] < min(tb[2], tb[3])                   # config 1 last
    assert abs(tb[2] - tb[3]) < 4.0                    # track Z2dot: a tie (30 s: 84.3 vs 83.9), documented


def test_magneride_with_no_current_reproduces_the_ideal_tables():
    ideal = reproduce_thesis_tables(duration=2.0, seed=1)
    mr0 = reproduce_thesis_tables(duration=2.0, seed=1, car="magneride", mr_damper=MRDamperParams(skyhook_gain=0.0))
    np.testing.assert_array_equal(ideal["epsilon"].to_numpy(), mr0["epsilon"].to_numpy())
    with pytest.raises(InputError, match="car must be one of"):
        reproduce_thesis_tables(duration=2.0, car="lotus")
