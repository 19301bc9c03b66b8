"""Figures of the planar vehicle / road slope estimation, paper 001 (matplotlib Figure objects, no pyplot state)."""

from __future__ import annotations

import numpy as np

from ._layout import fixed_figure, fixed_grid

__all__ = ["plot_slope_estimate", "plot_drive", "plot_sensitivity", "plot_speed_measurement"]

_WHEELS = ("fl", "fr", "rl", "rr")
_TRUTH_COLUMNS = ["true_vx", "true_vy", "true_yaw_rate", "true_slope"] + [f"true_fx_{w}" for w in _WHEELS]


def _figure(rows, height=2.1, *, left=0.9, right=0.2, bottom=0.5, top=0.45, gap=0.3):
    """``rows`` panels sharing the time axis, with fixed margins and gaps in inches (suptitle on top)."""
    fig = fixed_figure(9.0, height * rows, left=left, right=right, bottom=bottom, top=top)
    return fig, fixed_grid(fig, rows, 1, hspace=gap, sharex=True)[:, 0]


def _band(ax, t, value, std, color, label):
    ax.plot(t, value, color=color, lw=1.0, label=label)
    if std is not None:
        ax.fill_between(t, value - 2 * std, value + 2 * std, color=color, alpha=0.2, lw=0, label=f"{label} ±2σ")


def _truth_arrays(truth):
    """The true states the overlay draws, from a DriveTruth or a table of true_* columns (None: no overlay)."""
    if truth is None:
        return None
    if hasattr(truth, "columns"):
        if not all(c in truth.columns for c in _TRUTH_COLUMNS):
            return None
        return {"vx": truth["true_vx"].to_numpy(float), "vy": truth["true_vy"].to_numpy(float),
                "yaw_rate": truth["true_yaw_rate"].to_numpy(float), "slope": truth["true_slope"].to_numpy(float),
                "fx": np.column_stack([truth[f"true_fx_{w}"].to_numpy(float) for w in _WHEELS])}
    return {k: getattr(truth, k) for k in ("vx", "vy", "yaw_rate", "slope", "fx")}


def plot_slope_estimate(estimate, truth=None, *, title: str = ""):
    """Estimated V_x, V_y, yaw rate, slope and F_res with ±2σ bands; the truth overlaid when given.

    Parameters
    ----------
    estimate : SlopeEstimate
        Output of :func:`estimate_slope`.
    truth : DriveTruth or pandas.DataFrame, optional
        True states of a simulated drive (same time base): a DriveTruth, or a simulated log's table with the
        ``true_vx, true_vy, true_yaw_rate, true_slope, true_fx_fl..rr`` columns (no overlay if it lacks them,
        e.g. a real log).
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    truth = _truth_arrays(truth)
    fig, ax = _figure(5)
    t = estimate.time
    panels = [("vx", "V_x [m/s]", 1.0), ("vy", "V_y [m/s]", 1.0), ("yaw_rate", "yaw rate [deg/s]", np.degrees(1.0)),
              ("slope", "slope [deg]", np.degrees(1.0))]
    for a, (key, label, scale) in zip(ax, panels):
        if truth is not None:
            a.plot(t, truth[key] * scale, color="k", lw=0.8, label="true")
        _band(a, t, getattr(estimate, key) * scale, getattr(estimate, f"{key}_std") * scale, "C0",
              f"estimated ({estimate.method})")
        a.set_ylabel(label)
        a.grid(alpha=0.3)
    ax[0].legend(loc="best", fontsize=7)
    if truth is not None:
        ax[4].plot(t, truth["fx"].sum(axis=1), color="k", lw=0.8, label="true ΣF_x (wheel axes)")
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
    R = simulation.vehicle.wheel_radius_of_each  # each wheel's own rolling radius (staggered tyres)
    ax[0].plot(t, tr.vx, color="k", lw=1.0, label="true V_x")
    for i, w in enumerate(("FL", "FR", "RL", "RR")):
        ax[0].plot(t, R[i] * log.wheel_speeds[:, i], lw=0.6, label=f"R ω {w}")
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


def _slope_error_figure(simulation, twin, twin_label: str, curves, *, band_label: str, error_label: str,
                        ncol: int, ylim=None, twin_line_label: str | None = None):
    """The two-panel figure of :func:`plot_sensitivity` and :func:`plot_speed_measurement`.

    Top: the true grade, with ``twin`` (grey) on a twin axis labelled ``twin_label``; bottom: the slope-error
    ``curves`` (``(values, plot keyword arguments)`` pairs) over the ±0.3° target band; a grid on both panels.
    Returns ``(fig, axes)``.
    """
    from matplotlib.figure import Figure

    t = simulation.log.time
    fig = Figure(figsize=(9.0, 6.0), layout="constrained")
    ax = fig.subplots(2, 1, sharex=True)
    ax[0].plot(t, np.degrees(simulation.truth.slope), color="k", label="true grade [deg]")
    ax[0].set_ylabel("grade [deg]")
    ax0b = ax[0].twinx()
    ax0b.plot(t, twin, color="C7", lw=0.8, **({} if twin_line_label is None else {"label": twin_line_label}))
    ax0b.set_ylabel(twin_label, color="C7")
    ax[0].legend(loc="upper left", fontsize=7)
    for values, style in curves:
        ax[1].plot(t, values, **style)
    # the band after the curves: the legend lists the curves first
    ax[1].axhspan(-0.3, 0.3, color="g", alpha=0.1, label=band_label)
    if ylim is not None:
        ax[1].set_ylim(*ylim)
    ax[1].set_ylabel(error_label)
    ax[1].set_xlabel("time [s]")
    ax[1].legend(fontsize=7, ncol=ncol)
    for a in ax:
        a.grid(alpha=0.3)
    return fig, ax


def plot_sensitivity(simulation, errors: dict, *, title: str = ""):
    """Slope error over time for each case of :func:`sensitivity_study`, with the true grade and speed."""
    curves = [(e, {"lw": 1.4 if k == "nominal" else 0.9, "color": "k" if k == "nominal" else None, "label": k})
              for k, e in errors.items()]
    fig, _ = _slope_error_figure(simulation, simulation.truth.vx, "V_x [m/s]", curves, band_label="±0.3° target",
                                 error_label="slope error [deg]", ncol=3, twin_line_label="V_x [m/s]")
    fig.suptitle(title or f"Slope sensitivity to the vehicle model ({simulation.scenario} drive)")
    return fig


def plot_speed_measurement(simulation, estimates: dict, *, title: str = ""):
    """Slope error over time with the paper's and the robust V_x measurement (from :func:`speed_measurement_study`).

    ``estimates`` maps (method, speed_measurement) to a SlopeEstimate of ``simulation.log``.
    """
    tr = simulation.truth
    styles = {"rear-mean": ":", "robust": "-"}
    curves = [(np.degrees(est.slope - tr.slope), {"ls": styles.get(sm, "-"), "lw": 1.0,
                                                  "color": "C0" if method == "cascade" else "C3",
                                                  "label": f"{method}, V_x {sm}"})
              for (method, sm), est in estimates.items()]
    fig, _ = _slope_error_figure(simulation, tr.accel_x, "a_x (specific force) [m/s²]", curves, band_label="±0.3°",
                                 error_label="slope error [deg] (clipped ±10)", ncol=2, ylim=(-10, 10))
    fig.suptitle(title or f"V_x measurement: paper's rear-wheel mean vs slip-robust ({simulation.scenario} drive)")
    return fig
