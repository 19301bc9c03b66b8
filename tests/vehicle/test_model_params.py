"""The vehicle EKF models take their parameters as the engine's ``params`` (issue 12): one compiled set of model
functions (and one compiled filter loop) for every vehicle, settings that used to travel in the input row."""

import dataclasses

import numpy as np
import pytest

from longprofile.errors import InputError
from longprofile.statespace import block_extended_kalman_filter, extended_kalman_filter
from longprofile.statespace._ekf import cached_ekf_kernel
from longprofile.vehicle import default_vehicle, drive_scenario, planar_ekf_model, simulate_drive, slope_ekf_model
from longprofile.vehicle.planar import planar_inputs, planar_measurements
from longprofile.vehicle.vertical import STATE_BLOCKS, VerticalVehicleParams
from longprofile.vehicle.vertical._estimate import estimate_vertical_states, vertical_ekf_inputs
from longprofile.vehicle.vertical._model import N_PAR, PAR_DECENTRALISED, PAR_DT, vertical_ekf_model
from longprofile.vehicle.vertical._simulate import vertical_test_run


def _functions(model):
    return (model.transition_fn, model.observation_fn, model.transition_jacobian, model.observation_jacobian,
            model.transition_step, model.observation_step)


def _overloads(model):
    return [len(fn.overloads) for fn in _functions(model)] + [len(cached_ekf_kernel().overloads)]


@pytest.mark.parametrize("builder, n", [(planar_ekf_model, 3), (slope_ekf_model, 4)])
def test_every_vehicle_runs_the_same_compiled_planar_model(builder, n):
    car = default_vehicle()
    heavy = car.with_changes(mass=car.mass * 1.1)
    sim = simulate_drive(drive_scenario("hill", duration=2.0), car, seed=1)
    log = sim.log
    u = planar_inputs(log, car)
    y = planar_measurements(log, car)
    x0 = [y[0, 0], 0.0, y[0, 1], 0.0][:n]
    ref = builder(car, log.dt, initial_state=x0)
    first = extended_kalman_filter(ref, y, u=u, store_covariances=False).mean
    counts = _overloads(ref)
    other = builder(heavy, log.dt, initial_state=x0)
    assert all(a is b for a, b in zip(_functions(ref), _functions(other)))  # no per-vehicle closure any more
    np.testing.assert_array_equal(other.params[:-1], heavy.as_array())
    assert other.params[-1] == log.dt
    second = extended_kalman_filter(other, y, u=u, store_covariances=False).mean
    assert _overloads(other) == counts  # nothing compiled for the second vehicle
    assert not np.array_equal(first, second)  # and its mass is used


def test_every_vertical_car_and_setting_runs_the_same_compiled_model():
    _, sens = vertical_test_run(1, test="road", road_class="C", speed=20.0, duration=0.5, seed=0)
    u = vertical_ekf_inputs(sens)
    assert u.shape == (sens.time.size, 12)
    blocks = dict(state_blocks=STATE_BLOCKS, obs_blocks=np.arange(4))
    a = vertical_ekf_model(1, sens.dt)
    assert a.params.shape == (N_PAR,) and a.params[PAR_DT] == sens.dt and a.params[PAR_DECENTRALISED] == 1.0
    ra = block_extended_kalman_filter(a, sens.displacement, u=u, **blocks).mean
    counts = [len(fn.overloads) for fn in _functions(a)]
    p = VerticalVehicleParams()
    soft = dataclasses.replace(p, tyre_stiffness=0.8 * p.tyre_stiffness)
    b = vertical_ekf_model(1, sens.dt, params=soft)
    assert all(x is y for x, y in zip(_functions(a), _functions(b)))
    rb = block_extended_kalman_filter(b, sens.displacement, u=u, **blocks).mean
    assert [len(fn.overloads) for fn in _functions(b)] == counts
    assert not np.array_equal(ra, rb)


def test_the_settings_left_the_input_row():
    _, sens = vertical_test_run(1, test="road", road_class="C", speed=20.0, duration=0.3, seed=0)
    with pytest.warns(DeprecationWarning, match="decentralised"):
        legacy_call = vertical_ekf_inputs(sens, decentralised=False)
    u = vertical_ekf_inputs(sens)
    np.testing.assert_array_equal(legacy_call, u)
    # a 17-column row of the earlier layout (dt, alpha_veh, alpha_route, config, decentralised in columns 7-11)
    # (values there are ignored) gives the same filter: the model reads the MR map from the last five columns, the rest from its params
    legacy = np.hstack([u[:, :7], np.tile([sens.dt, 0.99, 0.9, 1.0, 0.0], (u.shape[0], 1)), u[:, 7:]])
    central = vertical_ekf_model(1, sens.dt, fused_steps=False, decentralised=False)
    new = extended_kalman_filter(central, sens.displacement, u=u)
    old = extended_kalman_filter(central, sens.displacement, u=legacy)
    np.testing.assert_array_equal(new.mean, old.mean)
    est = estimate_vertical_states(sens, decentralised=False)
    np.testing.assert_array_equal(est.filtered.mean, new.mean)
    with pytest.raises(InputError, match="fused_steps=False"):
        vertical_ekf_model(1, sens.dt, decentralised=False)
