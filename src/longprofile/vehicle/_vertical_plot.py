"""Tables and figures of vertical state estimates (thesis 003); matplotlib Figure objects, no pyplot state."""

from __future__ import annotations

import pandas as pd

from ._vertical_estimate import VerticalStateEstimate
from ._vertical_model import CORNER_NAMES

__all__ = ["estimate_to_frame", "plot_vertical_estimate"]

_FIELDS = (("suspension_deflection", "dz21", "m"), ("suspension_velocity", "dz21dot", "m/s"),
           ("vehicle_disturbance", "disturbance", "N"), ("tyre_deflection", "dz10", "m"),
           ("tyre_force", "tyre_force", "N"), ("body_velocity", "body_velocity", "m/s"),
           ("wheel_velocity", "wheel_velocity", "m/s"))


def estimate_to_frame(estimate: VerticalStateEstimate) -> pd.DataFrame:
    """One row per sample: ``time`` and ``<quantity>_<corner>`` for the seven estimated quantities (SI units)."""
    cols = {"time": estimate.time}
    for attr, prefix, _unit in _FIELDS:
        arr = getattr(estimate, attr)
        for c, name in enumerate(CORNER_NAMES):
            cols[f"{prefix}_{name}"] = arr[:, c]
    return pd.DataFrame(cols)


def plot_vertical_estimate(estimate: VerticalStateEstimate, truth: pd.DataFrame | None = None, *, corner: int = 0,
                           window: tuple[float, float] | None = None):
    """Figure of the estimated states of one corner (default front-left), with the truth when available.

    Parameters
    ----------
    estimate : VerticalStateEstimate
    truth : pandas.DataFrame, optional
        A simulated log with ``true_*`` columns (:func:`sensors_to_frame` with the simulation).
    corner : int
        0..3 = FL, FR, RL, RR.
    window : (float, float), optional
        Time window to draw, s (default: the first 5 s after 1 s, or the whole record if shorter).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    name = CORNER_NAMES[corner]
    t = estimate.time
    if window is None:
        window = (min(1.0, t[-1] / 4), min(6.0, t[-1]))
    sel = (t >= window[0]) & (t <= window[1])
    panels = (("suspension_deflection", "true_dz21", "suspension deflection dZ21 (m)"),
              ("suspension_velocity", "true_dz21dot", "damper velocity (m/s)"),
              ("tyre_force", "true_tyre_force", "dynamic tyre load (N)"),
              ("body_velocity", "true_body_velocity", "body velocity above wheel (m/s)"),
              ("wheel_velocity", "true_wheel_velocity", "wheel velocity (m/s)"))
    fig = Figure(figsize=(9, 11))
    axes = fig.subplots(len(panels), 1, sharex=True)
    for ax, (attr, tcol, label) in zip(axes, panels):
        col = f"{tcol}_{name}"
        if truth is not None and col in truth.columns:
            ax.plot(t[sel], truth[col].to_numpy(float)[sel], color="0.3", lw=1.2, label="true")
        ax.plot(t[sel], getattr(estimate, attr)[sel, corner], color="tab:red", lw=0.9,
                label=f"estimate (config {estimate.config})")
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(f"Vertical states, corner {name} — {estimate.method} (thesis 003)")
    fig.tight_layout()
    return fig
