"""Figures of derivative estimates (matplotlib Figure objects, no pyplot state)."""

from __future__ import annotations

import numpy as np

from ._derivative import DerivativeResult

__all__ = ["plot_derivative"]


def plot_derivative(x, dt: float, result: DerivativeResult, *, truth=None, label: str = "x"):
    """Two stacked panels: the signal (and ``result.value``), the derivative with a ±2 std band.

    Parameters
    ----------
    x : (T,) array_like
        The measured signal.
    dt : float
        Sample interval (s).
    result : DerivativeResult
        Output of :func:`derivative` on ``x`` (1-D).
    truth : (T,) array_like, optional
        True derivative, drawn when given.
    label : str, default "x"
        Name of the signal for the axis labels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    x = np.asarray(x, dtype=float)
    t = np.arange(x.shape[0]) * dt
    fig = Figure(figsize=(9, 6), constrained_layout=True)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(t, x, lw=0.6, color="0.6", label=f"{label} (measured)")
    if result.method in ("polyfit", "kalman"):
        ax1.plot(t, result.value, lw=1.0, color="C0", label="smoothed value")
    ax1.set_ylabel(label)
    ax1.legend(loc="best")
    d, s = result.derivative, result.derivative_std
    ax2.fill_between(t, d - 2 * s, d + 2 * s, color="C1", alpha=0.25, lw=0, label="±2 std (noise)")
    ax2.plot(t, d, lw=0.8, color="C1", label=f"derivative ({result.method})")
    if truth is not None:
        ax2.plot(t, np.asarray(truth, dtype=float), lw=1.0, color="k", ls="--", label="true derivative")
    order = result.params.get("order", 1)
    ax2.set_ylabel(f"d{'^' + str(order) if order > 1 else ''}{label}/dt{'^' + str(order) if order > 1 else ''}"
                   f" ({label} units / s{'^' + str(order) if order > 1 else ''})")
    ax2.set_xlabel("time (s)")
    ax2.legend(loc="best")
    p = result.params
    setting = ", ".join(f"{k.replace('_', ' ')} {p[k]:g}" for k in ("window", "degree", "q_over_r") if k in p)
    fig.suptitle(f"{'derivative' if order == 1 else f'derivative of order {order}'} of {label} by {result.method}"
                 f" ({setting}{', ' if setting else ''}dt = {dt:g} s); band = noise only, not bias")
    return fig
