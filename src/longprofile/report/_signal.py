"""Figures of derivative estimates (matplotlib Figure objects, no pyplot state)."""

from __future__ import annotations

import textwrap

import numpy as np

from ..signal import DerivativeResult

__all__ = ["plot_derivative", "plot_derivative_comparison"]


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
    total = result.params.get("std", "noise") == "total"  # the std printed in the table (docs/signal.md, Calibration)
    ax2.fill_between(t, d - 2 * s, d + 2 * s, color="C1", alpha=0.25, lw=0,
                     label="±2 std (noise and model error)" if total else "±2 std (noise)")
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
    # two lines, each wrapped to the figure's width (a 12 pt title holds about 90 characters across 9 in)
    what = (f"{'derivative' if order == 1 else f'derivative of order {order}'} of {label} by {result.method}"
            f" ({setting}{', ' if setting else ''}dt = {dt:g} s)")
    band = "band: " + ("noise and the model's bias and lag (std total)" if total else "noise only, not bias (std noise)")
    fig.suptitle("\n".join(textwrap.fill(line, 90) for line in (what, band)))
    return fig


def plot_derivative_comparison(t, x, truth, rows, *, noise_std: float):
    """Three panels comparing tuned derivative estimators on a signal with a known derivative (``longprofile demo``).

    Parameters
    ----------
    t, x, truth : (T,) ndarray
        Time (s), the measured signal and its true derivative.
    rows : list of (name, settings, DerivativeResult, rms_error)
        The best setting of each estimator (``longprofile.demos.signal.tuned_estimates``).
    noise_std : float
        Noise std of ``x`` (for the legend).

    Returns
    -------
    matplotlib.figure.Figure
        The signal; the estimates on t in [2, 3.5] s; the RMS error of each estimator (log scale).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 8), constrained_layout=True)
    FigureCanvasAgg(fig)
    ax_sig, ax_der, ax_err = fig.subplots(3, 1, gridspec_kw={"height_ratios": [1, 2, 1.2]})
    ax_sig.plot(t, x, lw=0.5, color="0.5", label=f"measured (noise std {noise_std})")
    ax_sig.set_ylabel("x")
    ax_sig.set_xlabel("time (s)")
    ax_sig.legend(loc="upper right")
    zoom = (t >= 2.0) & (t <= 3.5)
    for i, (name, _opt, res, err) in enumerate(rows):
        if name.startswith("backward n=2") or name.startswith("polyfit"):
            continue
        ax_der.plot(t[zoom], res.derivative[zoom], lw=0.9 if "backward" not in name else 0.4,
                    color=f"C{i}", alpha=0.4 if "backward" in name else 1.0, label=f"{name} ({err:.3f})")
    ax_der.plot(t[zoom], truth[zoom], color="k", lw=1.5, ls="--", label="true derivative")
    ax_der.set_ylim(truth[zoom].min() - 3, truth[zoom].max() + 3)
    ax_der.set_ylabel("dx/dt (1/s)")
    ax_der.set_xlabel("time (s)")
    ax_der.legend(loc="upper right", ncol=2, fontsize=8, title="estimator (RMS error)")
    names = [r[0] for r in rows]
    errs = [r[3] for r in rows]
    ax_err.barh(names, errs, color=[f"C{i}" for i in range(len(rows))])
    ax_err.set_xscale("log")
    ax_err.set_xlabel("RMS derivative error (1/s), best setting of each estimator")
    for yi, (e, (_, opt, _, _)) in enumerate(zip(errs, rows)):
        label = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in opt.items()
                          if k not in ("method", "smooth"))
        ax_err.text(e, yi, f"  {e:.3g}  {label}", va="center", fontsize=7)
    fig.suptitle("Derivative estimators of paper 002 on a noisy signal with known derivative")
    return fig
