"""The derivative figure (``differentiate --plot``): its title fits inside the figure (session 37: cut at both edges)."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")


@pytest.mark.parametrize("label, kwargs", [
    ("wheel_speed_rl", {"method": "polyfit", "window": 45, "degree": 2}),
    ("wheel_speed_rl", {"method": "kalman", "q_over_r": 1e6}),
    ("front_left_wheel_speed_from_the_abs_controller_can_bus", {"method": "polyfit", "window": 45, "degree": 2}),
])
def test_the_title_fits_inside_the_figure(label, kwargs):
    from longprofile.report import plot_derivative
    from longprofile.signal import derivative

    dt = 1e-3
    x = np.sin(np.arange(2000) * dt) + np.random.default_rng(0).normal(0, 1e-3, 2000)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = plot_derivative(x, dt, derivative(x, dt, **kwargs), label=label)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()  # constrained layout places the title
    (title,) = [t for t in fig.texts if t.get_text()]  # the suptitle
    box = title.get_window_extent(canvas.get_renderer())
    width = fig.get_figwidth() * fig.dpi
    assert box.x0 >= 0 and box.x1 <= width, (box, width, title.get_text())
    assert label in title.get_text().replace("\n", "") and "band" in title.get_text()
