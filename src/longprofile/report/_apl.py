"""Figures for the APL workflow (paper 000): recordings, reconstructions, identification (matplotlib Figure objects,
no pyplot state)."""

from __future__ import annotations

import numpy as np

from ._layout import fixed_figure, fixed_grid

__all__ = ["plot_recording", "plot_reconstructions", "plot_identification", "plot_frequency_response",
           "warm_reconstructions"]


def _figure(rows, height=2.6, sharex=True):
    """``rows`` panels, fixed margins; gaps for the x labels and titles of every panel unless they share x."""
    fig = fixed_figure(10.0, height * rows, left=1.0, top=0.4)
    return fig, fixed_grid(fig, rows, 1, hspace=0.45 if sharex else 0.85, sharex=sharex)[:, 0]


def plot_recording(distance, true_elevation, signal, *, title=""):
    """The true profile and the simulated APL signal, mm against m."""
    fig, (ax,) = _figure(1, 3.5)
    ax.set_title(title)
    ax.plot(distance, 1e3 * (np.asarray(true_elevation) - true_elevation[0]), lw=0.8, label="true profile")
    ax.plot(distance, 1e3 * np.asarray(signal), lw=0.8, label="APL signal")
    ax.set_xlabel("distance (m)")
    ax.set_ylabel("elevation (mm)")
    ax.legend()
    return fig


def _elevation_and_std(rec):
    """(detrended elevation, its std or None) of a value of ``plot_reconstructions``' dict."""
    if isinstance(rec, tuple):
        z, s = rec
        return np.asarray(z), None if s is None else np.asarray(s)
    profile = getattr(rec, "profile", None)  # a Reconstruction (duck-typed: no import of the road package here)
    if profile is not None:
        return profile.elevation[:, 0], None if profile.std is None else profile.std[:, 0]
    return np.asarray(rec), None


def plot_reconstructions(distance, signal, reconstructions: dict, *, truth=None, highpass_wavelength=None,
                         dx=None, title="", truth_detrended: bool = False):
    """Comparison of reconstructions (dict name -> detrended elevation, m), optional truth and 90 % band.

    ``reconstructions`` values may be arrays, :class:`~longprofile.road.apl.Reconstruction` objects (their detrended
    profile and, for the smoother, +/- 1.645 std are drawn) or ``(elevation, std)`` pairs of arrays (std None: no
    band). The truth is detrended the same way (``dx`` and ``highpass_wavelength``), or drawn as given with
    ``truth_detrended=True`` (then ``dx`` is not needed).
    """
    fig, (ax, ax2) = _figure(2, 3.4, sharex=False)
    x = np.asarray(distance)
    # the zoom panel shows a 60 m window in the middle: only its samples (and one beyond each end) are drawn there
    mid = x[x.size // 2]
    zoom = slice(max(int(np.searchsorted(x, mid - 30)) - 1, 0), int(np.searchsorted(x, mid + 30, side="right")) + 1)
    ax.plot(x, 1e3 * np.asarray(signal), color="0.6", lw=0.7, label="APL signal")
    if truth is not None and (truth_detrended or dx is not None):
        if truth_detrended:
            t = np.asarray(truth)
        else:
            from ..road.apl import detrend_profile

            t = detrend_profile(np.asarray(truth) - truth[0], dx, highpass_wavelength=highpass_wavelength)
        ax.plot(x, 1e3 * t, color="k", lw=1.0, label="true (detrended)")
        ax2.plot(x[zoom], 1e3 * t[zoom], color="k", lw=1.0, label="true (detrended)")
    for name, rec in reconstructions.items():
        z, std = _elevation_and_std(rec)
        line, = ax.plot(x, 1e3 * z, lw=0.8, label=name)
        ax2.plot(x[zoom], 1e3 * z[zoom], lw=0.8, color=line.get_color(), label=name)
        if std is not None:
            z, s = z[zoom], std[zoom]
            ax2.fill_between(x[zoom], 1e3 * (z - 1.645 * s), 1e3 * (z + 1.645 * s), color=line.get_color(),
                             alpha=0.25, label=f"{name} 90 % band")
    ax.set_ylabel("elevation (mm)")
    ax.set_xlabel("distance (m)")
    ax.legend(fontsize=7, ncol=3, loc="upper right")  # a fixed place: "best" searches every vertex of the record
    ax.set_title(title)
    ax2.set_xlim(mid - 30, mid + 30)
    ax2.set_title(f"zoom on {mid - 30:g}-{mid + 30:g} m", fontsize=9)
    ax2.set_ylabel("elevation (mm)")
    ax2.set_xlabel("distance (m)")
    ax2.legend(fontsize=7, ncol=3, loc="upper right")
    return fig


def warm_reconstructions() -> None:
    """Draw :func:`plot_reconstructions` once on 2000 synthetic samples, to nothing: a figure helper's warm-up for
    ``road reconstruct --plot`` (fonts, band, legends and the PNG writer used once before the real figure)."""
    import io

    x = np.arange(2000) * 0.05
    z = 1e-3 * np.sin(x)
    fig = plot_reconstructions(x, z, {"warm": (z, np.full(x.size, 1e-4))}, truth=z, truth_detrended=True,
                               title="warm")
    fig.savefig(io.BytesIO(), format="png", dpi=120)


def plot_identification(u, y, model, *, dt=None):
    """Measured vs simulated output, and the identified step response."""
    from ..identify import simulate_model, step_response

    fig, (ax1, ax2, ax3) = _figure(3, 2.6)
    t = np.arange(len(y)) * (dt or 1.0)
    ax1.plot(t, u, lw=0.8)
    ax1.set_ylabel("input u")
    ax2.plot(t, y, lw=0.6, color="0.5", label="measured y")
    if model.stable:
        ax2.plot(t, simulate_model(model, u), lw=0.8, label=f"simulated (fit {model.fit_simulation:.1f} %)")
        s = step_response(model, len(y))
        ax3.plot(t, s, lw=0.9)
    else:
        ax3.text(0.5, 0.5, "unstable model: no simulation or step response", transform=ax3.transAxes,
                 ha="center", color="C3")
    ax2.legend(fontsize=7)
    ax2.set_ylabel("output y")
    ax3.set_ylabel("step response\n(output per unit input)")
    orders = ", ".join(f"{k} = {v}" for k, v in model.orders.items())
    ax1.set_title(f"{model.structure.upper()} identification ({orders}): residual std {model.residual_std:.3g}, "
                  f"{'converged' if model.converged else 'NOT converged'}, {'stable' if model.stable else 'UNSTABLE'}")
    ax3.set_xlabel("time (s)" if dt else "sample")
    return fig


def plot_frequency_response(models, *, tolerance: float = 0.1):
    """Magnitude, phase and group delay of one or more APL models, with the |H| ~ 1 band shaded (paper 000, §2).

    Parameters
    ----------
    models : APLModel or sequence of APLModel
    tolerance : float
        Half-width of the shaded band: |H| within 1 +/- tolerance (:func:`longprofile.road.apl.passband`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    from ..errors import ModelError
    from ..road.apl import APLModel, frequency_response, passband

    models = [models] if isinstance(models, APLModel) else list(models)
    fig = Figure(figsize=(8, 9), layout="constrained")
    axm, axp, axg = fig.subplots(3, 1, sharex=True)
    for m in models:
        fr = frequency_response(m, np.logspace(-2, np.log10(0.5 / m.dt), 3000))
        axm.semilogx(fr.frequency, fr.magnitude, label=m.name)
        axp.semilogx(fr.frequency, np.degrees(fr.phase))
        axg.semilogx(fr.frequency, fr.group_delay * 1e3)
        try:
            lo, hi = passband(m, tolerance=tolerance)
            axm.axvspan(lo, hi, alpha=0.08, color=axm.lines[-1].get_color())
        except ModelError:
            pass
    axm.axhline(1.0, color="k", lw=0.5)
    axm.set_ylabel("|H|")
    axm.set_ylim(0, 1.3)
    axm.legend(fontsize=7)
    axm.set_title(f"APL frequency response (shaded: |H| within 1 +/- {tolerance})")
    axp.set_ylabel("phase (deg)")
    axg.set_ylabel("group delay (ms)")
    axg.set_xlabel("frequency (Hz)")
    return fig
