"""Figures for the planar vehicle / road slope estimation (matplotlib Figure objects, no pyplot state)."""

from __future__ import annotations

import numpy as np

__all__ = ["plot_slope_estimate", "plot_drive"]


def _figure(rows, height=2.1):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, height * rows), layout="constrained")
    axes = fig.subplots(rows, 1, sharex=True)
    return fig, np.atleast_1d(axes)


def _band(ax, t, value, std, color, label):
    ax.plot(t, value, color=color, lw=1.0, label=label)
    if std is not None:
        ax.fill_between(t, value - 2 * std, value + 2 * std, color=color, alpha=0.2, lw=0, label=f"{label} ±2σ")


def plot_slope_estimate(estimate, truth=None, *, title: str = ""):
    """Estimated V_x, V_y, yaw rate, slope and F_res with ±2σ bands; the truth overlaid when given.

    Parameters
    ----------
    estimate : SlopeEstimate
        Output of :func:`estimate_slope`.
    truth : DriveTruth, optional
        True states of a simulated drive (same time base).
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _figure(5)
    t = estimate.time
    panels = [("vx", "V_x [m/s]", 1.0), ("vy", "V_y [m/s]", 1.0), ("yaw_rate", "yaw rate [deg/s]", np.degrees(1.0)),
              ("slope", "slope [deg]", np.degrees(1.0))]
    for a, (key, label, scale) in zip(ax, panels):
        if truth is not None:
            a.plot(t, getattr(truth, key) * scale, color="k", lw=0.8, label="true")
        _band(a, t, getattr(estimate, key) * scale, getattr(estimate, f"{key}_std") * scale, "C0",
              f"estimated ({estimate.method})")
        a.set_ylabel(label)
        a.grid(alpha=0.3)
    ax[0].legend(loc="best", fontsize=7)
    if truth is not None:
        ax[4].plot(t, truth.fx.sum(axis=1), color="k", lw=0.8, label="true ΣF_x (wheel axes)")
    _band(ax[4], t, estimate.fx.sum(axis=1), np.sqrt((estimate.fx_std ** 2).sum(axis=1)), "C1", "estimated ΣF_x")
    ax[4].set_ylabel("ΣF_x [N]")
    ax[4].legend(loc="best", fontsize=7)
    ax[4].grid(alpha=0.3)
    ax[-1].set_xlabel("time [s]")
    fig.suptitle(title or "Vehicle states and road slope (paper 001)")
    return fig


def plot_drive(simulation, *, title: str = ""):
    """Overview of a simulated drive: speeds, steering, yaw rate, grade and adhesion along time."""
    tr = simulation.truth
    log = simulation.log
    t = log.time
    fig, ax = _figure(4)
    R = simulation.vehicle.wheel_radius
    ax[0].plot(t, tr.vx, color="k", lw=1.0, label="true V_x")
    for i, w in enumerate(("FL", "FR", "RL", "RR")):
        ax[0].plot(t, R * log.wheel_speeds[:, i], lw=0.6, label=f"R ω {w}")
    ax[0].set_ylabel("speed [m/s]")
    ax[0].legend(fontsize=7, ncol=5)
    ax[1].plot(t, np.degrees(log.steering_angle), lw=0.8, label="steering (measured)")
    ax[1].plot(t, np.degrees(log.yaw_rate), lw=0.6, label="yaw rate [deg/s] (measured)")
    ax[1].set_ylabel("deg, deg/s")
    ax[1].legend(fontsize=7)
    ax[2].plot(t, np.degrees(tr.slope), color="k", lw=1.0)
    ax[2].set_ylabel("true slope [deg]")
    ax[3].plot(t, tr.friction, lw=0.8)
    ax[3].set_ylabel("adhesion μ")
    for a in ax:
        a.grid(alpha=0.3)
    ax[-1].set_xlabel("time [s]")
    fig.suptitle(title or f"Simulated drive: {simulation.scenario}")
    return fig
