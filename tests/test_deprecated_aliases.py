"""The documented deprecated figure aliases (issue 12 moved the figures to ``longprofile.report``) still work.

Each alias is called through its public package namespace; it must warn (pointing at ``longprofile.report``) and
return the same kind of figure as the new report function.
"""

import importlib

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402


@pytest.fixture(scope="module")
def drive():
    from longprofile.vehicle import default_vehicle, drive_scenario, estimate_slope, simulate_drive

    car = default_vehicle()
    sim = simulate_drive(drive_scenario("hill", duration=1.5), car, seed=0)
    return sim, estimate_slope(sim.log, car, method="cascade")


@pytest.fixture(scope="module")
def vertical():
    from longprofile.vehicle import VerticalStateEstimate, sensors_to_frame, vertical_test_run

    sim, sensors = vertical_test_run(3, test="road", duration=1.0, seed=0)
    # a perfect estimate (the simulated states) keeps the test free of the corner EKFs' numba compile (~3 s):
    # the alias is what is tested here, not the estimator
    n = sim.time.size
    estimate = VerticalStateEstimate(
        time=sim.time, suspension_deflection=sim.suspension_deflection, suspension_velocity=sim.suspension_velocity,
        vehicle_disturbance=np.zeros((n, 4)), tyre_deflection=sim.tyre_deflection, tyre_force=sim.tyre_force,
        body_velocity=sim.body_velocity, wheel_velocity=sim.wheel_velocity, state_std=np.zeros((n, 16)),
        config=sensors.config, method="simulated", filtered=None)
    return (estimate, sensors_to_frame(sensors, sim))


def _derivative_args(request):
    from longprofile.signal import derivative

    dt = 1e-2
    x = np.sin(np.arange(300) * dt)
    return (x, dt, derivative(x, dt, method="ml", window=20, degree=2)), {"truth": np.cos(np.arange(300) * dt)}


_CASES = {
    "road.apl.plot_frequency_response": lambda request: (
        ([importlib.import_module("longprofile.road.apl").apl_model(20.0, 0.05)],), {"tolerance": 0.1}),
    "signal.plot_derivative": _derivative_args,
    "vehicle.plot_drive": lambda request: ((request.getfixturevalue("drive")[0],), {"title": "t"}),
    "vehicle.plot_slope_estimate": lambda request: (
        (request.getfixturevalue("drive")[1], request.getfixturevalue("drive")[0].truth), {}),
    "vehicle.plot_vertical_estimate": lambda request: (request.getfixturevalue("vertical"), {"corner": 1}),
}


@pytest.mark.parametrize("alias", sorted(_CASES))
def test_deprecated_alias_warns_and_draws_the_report_figure(alias, request):
    package, name = alias.rsplit(".", 1)
    old = getattr(importlib.import_module(f"longprofile.{package}"), name)
    new = getattr(importlib.import_module("longprofile.report"), name)
    args, kwargs = _CASES[alias](request)  # the simulations are built only for the aliases that need them
    figures = []
    try:
        with pytest.warns(DeprecationWarning, match="longprofile.report") as record:
            figures.append(old(*args, **kwargs))
        assert any(f"longprofile.{package}.{name}" in str(w.message) for w in record)
        figures.append(new(*args, **kwargs))
        fig_old, fig_new = figures
        assert isinstance(fig_old, Figure)
        assert len(fig_old.axes) == len(fig_new.axes) > 0
    finally:
        import matplotlib.pyplot as plt

        for fig in figures:
            plt.close(fig)
