"""Thesis tables 4.4 / 4.5 on the simulator: thesis-style references, rankings, the config-1 velocity chain."""

import dataclasses

import numpy as np
import pytest

from longprofile.errors import InputError, ShapeError
from longprofile.vehicle import VerticalVehicleParams, epsilon_score, reproduce_thesis_tables
from longprofile.vehicle.vertical._estimate import CONFIG1_COMFORT_LEAK_HZ, _blended_relative_velocity, _comfort_model
from longprofile.vehicle.vertical._evaluate import _bench_run, _reference, thesis_references
from longprofile.vehicle.vertical._model import vertical_params_arrays

DURATION = 8.0  # short runs: the orders asserted below hold at 8 s and at the documented 30 s


@pytest.fixture(scope="module")
def tables():
    return {ref: reproduce_thesis_tables(duration=DURATION, seed=0, reference=ref) for ref in ("truth", "thesis")}


def _eps(df, test, variable):
    sub = df[(df["test"] == test) & (df["variable"] == variable)].set_index("config")["epsilon"]
    return {c: float(sub[c]) for c in (1, 2, 3)}


@pytest.mark.parametrize("reference", ["truth", "thesis"])
def test_ranking_of_configurations(tables, reference):
    df = tables[reference]
    assert set(df["reference"]) == {reference}
    for test in ("bench", "track"):
        d = _eps(df, test, "suspension_deflection")
        assert max(d.values()) - min(d.values()) < 1.0          # thesis: the same for every configuration
        v = _eps(df, test, "suspension_velocity")
        assert v[3] > v[2] > v[1]                                 # thesis: 3 > 2 >= 1
        w = _eps(df, test, "wheel_velocity")
        assert w[3] > max(w[1], w[2])                             # thesis: 3 best
        b = _eps(df, test, "body_velocity")
        # thesis: 2 > 3 > 1. Ours keeps config 1 last but puts 3 ahead of 2 with EITHER reference: the
        # documented disagreement (docs/vehicle-vertical.md, "Thesis tables reproduced").
        assert b[3] > b[2] > b[1]
    t = _eps(df, "bench", "tyre_force")
    assert t[3] > t[2] > t[1]
    w = _eps(df, "bench", "wheel_velocity")
    assert w[3] > w[2] > w[1]
    assert df["thesis"].notna().all()


def test_config1_absolute_velocities_are_sensible_on_bench_and_track(tables):
    # before the leaky comfort model and the blended relative velocity: -267 % (body) / -1107 % (wheel), track
    for df in tables.values():
        for test in ("bench", "track"):
            for v in ("body_velocity", "wheel_velocity"):
                assert _eps(df, test, v)[1] > 10.0


def test_thesis_references_are_the_truth_for_perfect_sensors():
    # oracle: with noise-free accelerometers and displacement, the thesis's processing returns the truth
    # (up to its own high-pass/60 Hz low-pass), so the two reference sets differ only by sensor errors
    p = dataclasses.replace(VerticalVehicleParams(), suspension_friction=100.0)
    sim = _bench_run(6.0, 1, p, 1e-3)
    refs = thesis_references(sim, displacement=sim.suspension_deflection, body_accel=sim.body_accel,
                             wheel_accel=sim.wheel_accel)
    k = slice(1000, -1000)
    for v in ("suspension_deflection", "tyre_force", "body_velocity", "wheel_velocity"):
        assert np.all(epsilon_score(_reference(sim, v)[k], refs[v][k]) > 99.0), v
    # the relative-velocity reference is high-passed at 0.3 Hz: close, not equal
    assert np.all(epsilon_score(sim.suspension_velocity[k], refs["suspension_velocity"][k]) > 90.0)
    with pytest.raises(ShapeError, match="body_accel"):
        thesis_references(sim, displacement=sim.suspension_deflection, body_accel=sim.body_accel[:10],
                          wheel_accel=sim.wheel_accel)


def test_bad_reference_is_refused():
    with pytest.raises(InputError, match="reference must be one of"):
        reproduce_thesis_tables(duration=1.0, reference="measured")
    with pytest.raises(InputError, match="duration"):
        reproduce_thesis_tables(duration=0.0)


def test_comfort_model_integrator_is_leaky_and_bounded():
    corner, coupling, scalars = vertical_params_arrays(VerticalVehicleParams())
    T, dt = 20000, 1e-3
    dz = np.full((T, 4), 0.01)                     # a constant deflection error: a constant force error
    zero = np.zeros((T, 4))
    leak = np.exp(-2 * np.pi * CONFIG1_COMFORT_LEAK_HZ * dt)
    v = _comfort_model(dz, zero, zero, zero, zero, corner, coupling, scalars, dt, leak)
    pure = _comfort_model(dz, zero, zero, zero, zero, corner, coupling, scalars, dt, 1.0)
    acc = pure[0, 0] / dt
    assert np.all(np.abs(v) <= abs(acc) * dt / (1 - leak) * (1 + 1e-9))   # bounded by the leak's DC gain
    np.testing.assert_allclose(v[-1, 0], acc * dt / (1 - leak), rtol=1e-6)  # converged, not drifting
    np.testing.assert_allclose(pure[-1, 0], acc * dt * T, rtol=1e-9)         # the thesis's pure integrator drifts


def test_blended_relative_velocity_is_exact_on_consistent_signals():
    dt = 1e-3
    t = np.arange(5000) * dt
    z = 0.01 * np.sin(2 * np.pi * 1.3 * t)[:, None] * np.ones(4) + 0.002 * np.sin(2 * np.pi * 12 * t)[:, None]
    v = np.zeros_like(z)
    v[1:] = np.diff(z, axis=0) / dt
    np.testing.assert_allclose(_blended_relative_velocity(z, v, dt, 20.0)[1:], v[1:], atol=1e-12)
