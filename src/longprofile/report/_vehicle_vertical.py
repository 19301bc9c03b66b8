"""Figures of vertical state estimates, thesis 003 (matplotlib Figure objects, no pyplot state)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd

    from ..vehicle.vertical import VerticalSimulation, VerticalStateEstimate

from ._layout import fixed_figure, fixed_grid

__all__ = ["plot_vertical_estimate", "plot_vertical_simulation", "plot_thesis_tables"]


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
    return _corner_figure(estimate, truth, corner, window)


def plot_vertical_simulation(simulation: VerticalSimulation, config: int, *, corner: int = 0,
                             window: tuple[float, float] | None = None):
    """Figure of the TRUE states of one corner of a simulated run (default front-left), in the layout of
    :func:`plot_vertical_estimate` (method "simulation (truth)").

    Parameters
    ----------
    simulation : VerticalSimulation
        Output of :func:`~longprofile.vehicle.simulate_vertical` (or :func:`~longprofile.vehicle.vertical_test_run`).
    config : int
        Sensor configuration of the run's log (1, 2 or 3; shown in the legend).
    corner : int
        0..3 = FL, FR, RL, RR.
    window : (float, float), optional
        Time window to draw, s (default: the first 5 s after 1 s, or the whole record if shorter).

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _corner_figure(simulation, None, corner, window, config=config, method="simulation (truth)",
                          label=f"truth (config {config})")


def _corner_figure(states, truth, corner, window, *, config=None, method=None, label=None):
    """The five-panel figure of one corner; ``states`` has ``time`` and the per-corner (T, 4) arrays.

    ``label`` names the ``states`` curve in the legend (default ``"estimate (config N)"``).
    """
    from ..vehicle.vertical import CORNER_NAMES

    Z90 = 1.6448536269514722  # two-sided 90 % of a normal distribution

    config = states.config if config is None else config
    method = states.method if method is None else method
    label = f"estimate (config {config})" if label is None else label
    name = CORNER_NAMES[corner]
    t = states.time
    if window is None:
        window = (min(1.0, t[-1] / 4), min(6.0, t[-1]))
    sel = (t >= window[0]) & (t <= window[1])
    panels = (("suspension_deflection", "true_dz21", "suspension deflection dZ21 (m)"),
              ("suspension_velocity", "true_dz21dot", "damper velocity (m/s)"),
              ("tyre_force", "true_tyre_force", "dynamic tyre load (N)"),
              ("body_velocity", "true_body_velocity", "body velocity above wheel (m/s)"),
              ("wheel_velocity", "true_wheel_velocity", "wheel velocity (m/s)"))
    fig = fixed_figure(9.0, 11.0, left=0.95, top=0.5)
    axes = fixed_grid(fig, len(panels), 1, hspace=0.25, sharex=True)[:, 0]
    for ax, (attr, tcol, ylabel) in zip(axes, panels):
        col = f"{tcol}_{name}"
        if truth is not None and col in truth.columns:
            ax.plot(t[sel], truth[col].to_numpy(float)[sel], color="0.3", lw=1.2, label="true")
        value = getattr(states, attr)[sel, corner]
        ax.plot(t[sel], value, color="tab:red", lw=0.9, label=label)
        std = getattr(getattr(states, "calibrated_std", None), attr, None)  # the filter's states only (session 41)
        if std is not None:
            half = Z90 * std[sel, corner]
            ax.fill_between(t[sel], value - half, value + half, color="tab:red", alpha=0.2, lw=0,
                            label="calibrated 90 % band")
        ax.set_ylabel(ylabel, fontsize=8)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(f"Vertical states, corner {name} — {method} (thesis 003)")
    return fig


_TABLE_LABELS = {"suspension_deflection": "ΔZ21", "suspension_velocity": "ΔŻ21", "tyre_force": "tyre load",
                 "body_velocity": "Ż2 (body)", "wheel_velocity": "Ż1 (wheel)"}


def plot_thesis_tables(table: pd.DataFrame):
    """Bar chart of :func:`reproduce_thesis_tables`: ours (solid) next to the thesis (hatched), per test.

    Parameters
    ----------
    table : pandas.DataFrame
        Output of :func:`reproduce_thesis_tables` (columns ``test, config, variable, epsilon, thesis``).

    Returns
    -------
    matplotlib.figure.Figure
        One panel per test; eps (%) clipped at -50 % for readability (the bar is labelled with its value).
    """
    import numpy as np

    tests = list(dict.fromkeys(table["test"]))
    colours = {1: "tab:blue", 2: "tab:orange", 3: "tab:green"}
    fig = fixed_figure(10.0, 4.0 * len(tests), bottom=0.7, top=0.85)
    axes = fixed_grid(fig, len(tests), 1, hspace=0.7)[:, 0]
    ref = table["reference"].iloc[0] if "reference" in table.columns else "truth"
    for ax, test in zip(axes, tests):
        sub = table[table["test"] == test]
        variables = list(dict.fromkeys(sub["variable"]))
        x = np.arange(len(variables))
        w = 0.13
        for j, config in enumerate((1, 2, 3)):
            rows = sub[sub["config"] == config].set_index("variable").reindex(variables)
            ours = rows["epsilon"].to_numpy(float)
            ax.bar(x + (2 * j - 2.5) * w, np.maximum(ours, -50.0), w, color=colours[config],
                   label=f"ours, config {config}")
            for xi, v in zip(x + (2 * j - 2.5) * w, ours):
                if v < -50.0:
                    ax.annotate(f"{v:.0f}", (xi, -50.0), fontsize=7, ha="center", va="bottom", rotation=90)
            ax.bar(x + (2 * j - 1.5) * w, rows["thesis"].to_numpy(float), w, color=colours[config], alpha=0.45,
                   hatch="//", label=f"thesis, config {config}")
        ax.set_xticks(x, [_TABLE_LABELS.get(v, v) for v in variables])
        ax.set_ylabel("ε (%)")
        ax.set_ylim(min(-5.0, float(np.nanmin(np.maximum(sub["epsilon"], -50.0))) - 5), 105)
        ax.axhline(0.0, color="0.4", lw=0.8)
        ax.grid(axis="y", alpha=0.3)
        ax.set_title(f"{test} test (front-left corner) — thesis Table {'4.4' if test == 'bench' else '4.5'}")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, ncol=6, fontsize=7, loc="lower center")
    car = f"car: {table['car'].iloc[0]}, " if "car" in table.columns and len(table) else ""
    fig.suptitle(f"Thesis 003 result tables reproduced on the simulator ({car}reference: {ref})")

    return fig
