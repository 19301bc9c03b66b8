"""Legend labels of the vertical-state figures: the simulation figure draws the truth, not an estimate."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")


@pytest.fixture(scope="module")
def simulation():
    from longprofile.vehicle import vertical_test_run

    sim, _ = vertical_test_run(2, test="road", duration=1.0, seed=0)
    return sim


def _legend_labels(fig):
    return [text.get_text() for ax in fig.axes if ax.get_legend() is not None
            for text in ax.get_legend().get_texts()]


def test_simulation_figure_labels_its_curve_as_the_truth(simulation):
    from longprofile.report import plot_vertical_simulation

    fig = plot_vertical_simulation(simulation, 2)
    labels = _legend_labels(fig)
    assert labels, "the simulation figure has a legend"
    assert not any("estimate" in label.lower() for label in labels), labels
    assert any("truth" in label for label in labels) and any("config 2" in label for label in labels), labels
    # the states drawn are the simulated ones (front-left corner, inside the default window)
    t = simulation.time
    sel = (t >= min(1.0, t[-1] / 4)) & (t <= min(6.0, t[-1]))
    np.testing.assert_array_equal(fig.axes[0].get_lines()[0].get_ydata(), simulation.suspension_deflection[sel, 0])


def test_estimate_figure_still_labels_its_curve_as_an_estimate(simulation):
    from longprofile.report import plot_vertical_estimate
    from longprofile.vehicle import VerticalStateEstimate

    n = simulation.time.size
    # an estimate-shaped record of the simulated states (the figure reads only the arrays, config and method)
    estimate = VerticalStateEstimate(
        time=simulation.time, suspension_deflection=simulation.suspension_deflection,
        suspension_velocity=simulation.suspension_velocity, vehicle_disturbance=np.zeros((n, 4)),
        tyre_deflection=simulation.tyre_deflection, tyre_force=simulation.tyre_force,
        body_velocity=simulation.body_velocity, wheel_velocity=simulation.wheel_velocity,
        state_std=np.zeros((n, 16)), config=2, method="corner-ekf", filtered=None)
    assert _legend_labels(plot_vertical_estimate(estimate)) == ["estimate (config 2)"]
