"""Figure of a longitudinal profile (rendering only: the numbers come from the :class:`~longprofile.road.Profile`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_profile"]


def plot_profile(profile, path, *, title: str | None = None, units: str = "mm") -> Path:
    """Draw the elevation of every track against the station to a figure file; return the path.

    Parameters
    ----------
    profile : Profile
        Stations in m, elevations in m (NaN gaps are left blank).
    path : path-like
        Figure file (.png, .pdf, .svg...; by matplotlib from the suffix).
    title : str, optional
        Default: the profile name and its sampling.
    units : str
        Elevation unit of the axis (m, mm, cm, in, ft...).

    Notes
    -----
    Long profiles (more than 60 000 samples) are drawn as the min/max envelope over bins, so every spike
    stays visible; the station axis is in km beyond 10 km.
    """
    from ..core import unit_factor
    from ._road import _envelope, _figure

    factor = unit_factor(units)
    x = profile.distance
    km = x.size and (x[-1] - x[0]) > 10_000.0
    xs = x / 1000.0 if km else x
    fig = _figure(10.0, 3.8)
    ax = fig.add_subplot()
    for j, track in enumerate(profile.tracks):
        xb, lo, hi = _envelope(xs, profile.elevation[:, j] / factor)
        if lo is hi:
            ax.plot(xb, lo, lw=0.8, label=track)
        else:
            ax.fill_between(xb, lo, hi, lw=0.5, alpha=0.7, label=f"{track} (min/max per bin)")
    ax.set_xlabel("station (km)" if km else "station (m)")
    ax.set_ylabel(f"elevation ({units})")
    spacing = profile.spacing
    step = f", dx {spacing:.4g} m" if spacing is not None else ", irregular stations"
    ax.set_title(title or f"{profile.name or 'profile'}: {profile.n_samples} samples{step}")
    if np.isfinite(xs).any():
        ax.set_xlim(float(xs[0]), float(xs[-1]))
    ax.legend(loc="upper right", fontsize=8)
    from ..io import save_figure

    return save_figure(fig, path, dpi=120)  # temporary file + os.replace: an older figure survives a failure
