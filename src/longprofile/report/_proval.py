"""Figures of the other ProVAL analyses (Ride Number, straightedge, Profile Index, faulting), in the report's units.

Rendering only: every number comes from an :class:`longprofile.road.IndexReport` (its tables).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._atomic import save_figure
from ._layout import fixed_figure

__all__ = ["plot_index_report"]


def _tracks(report) -> list[str]:
    return [t for t in report.metadata.get("tracks", "").split(",") if t]


def _segment_bars(ax, table, columns, labels, lu):
    start, end = table[f"start_{lu}"].to_numpy(), table[f"end_{lu}"].to_numpy()
    width = (end - start) / (len(columns) + 1)
    for j, (c, label) in enumerate(zip(columns, labels)):
        ax.bar(start + (j + 0.5) * width, table[c].to_numpy(), width=width * 0.95, align="edge", label=label,
               alpha=0.9)
    if start.size:
        ax.set_xlim(float(start[0]), float(end[-1]))


def _ride_number(ax, report, lu, su):
    t = report.table
    names = _tracks(report)
    _segment_bars(ax, t, [f"rn_{n}" for n in names], [f"RN {n}" for n in names], lu)
    if len(names) > 1 and len(t):
        ax.step(np.append(t[f"start_{lu}"], t[f"end_{lu}"].iloc[-1:]), np.append(t["rn"], t["rn"].iloc[-1:]),
                where="post", color="0.2", lw=1.2, ls=":", label="RN (tracks combined)")
    ax.axhline(report.metadata["section_rn"], color="k", lw=1, ls="--",
               label=f"section RN {report.metadata['section_rn']:.2f}")
    ax.set_ylim(0, 5)
    ax.set_ylabel("Ride Number (0-5)")
    return f"Ride Number (ASTM E1489) per {report.metadata['segment']:g} {lu} segment"


def _straightedge(ax, report, lu, su):
    from ._road import _envelope

    d, meta = report.detail, report.metadata
    x = d[f"station_{lu}"].to_numpy()
    for n in _tracks(report):
        xb, lo, hi = _envelope(x, d[f"deviation_{n}_{su}"].to_numpy())
        if lo is hi:  # few enough stations to draw each
            ax.plot(xb, hi, lw=0.6, label=f"deviation {n}")
        else:  # the min/max envelope per bin: every spike stays visible
            ax.fill_between(xb, lo, hi, lw=0.6, alpha=0.8, label=f"deviation {n}")
    thr = meta["threshold"]
    for s in (1, -1):
        ax.axhline(s * thr, color="#c62828", lw=1, ls="--", label=f"threshold ±{thr:g} {su}" if s > 0 else None)
    if len(report.table):
        ax.plot(report.table[f"peak_{lu}"], report.table[f"deviation_{su}"], "v", ms=3, color="#c62828",
                label=f"{len(report.table)} defect(s)")
    if x.size:
        ax.set_xlim(float(x[0]), float(x[-1]))
    ax.set_ylabel(f"deviation [{su}]")
    return f"Rolling straightedge {meta['length']:g} {lu}: deviation from its chord (positive = bump)"


def _profile_index(ax, report, lu, su):
    names, meta = _tracks(report), report.metadata
    unit = meta["pi_unit"]
    col = unit.replace("/", "_per_")
    _segment_bars(ax, report.table, [f"pi_{n}_{col}" for n in names], [f"PI {n}" for n in names], lu)
    ax.set_ylabel(f"Profile Index [{unit}]")
    return (f"Profile Index (CT 526) per {meta['segment']:g} {lu} segment, {meta['blanking_band']:g} {su} blanking "
            f"band; {meta['n_bumps']} bump(s)")


def _faulting(ax, report, lu, su):
    t = report.table
    for n in _tracks(report):
        rows = t[t.track == n]
        x, f = rows[f"joint_{lu}"].to_numpy(), rows[f"fault_{su}"].to_numpy()
        ax.vlines(x, 0, f, lw=0.8, alpha=0.7)
        ax.plot(x, f, "o", ms=3, label=f"fault {n} ({len(rows)} joint(s))")
    ax.axhline(0, color="0.3", lw=0.8)
    ax.set_ylabel(f"fault [{su}] (+ = leave slab lower)")
    return "Joint faulting (AASHTO R 36 practice): approach minus leave elevation at each joint"


_DRAW = {"ride-number": _ride_number, "straightedge": _straightedge, "profile-index": _profile_index,
         "faulting": _faulting}


def plot_index_report(report, path) -> Path:
    """Draw an :class:`~longprofile.road.IndexReport` in its own units to a figure file; return the path.

    Ride Number and Profile Index: bars per segment and track; straightedge: the deviation along the road with the
    threshold and the defects' peaks; faulting: the fault at each joint found.
    """
    fig = fixed_figure(10.0, 3.6, left=0.85, dpi=110)
    ax = fig.add_subplot()
    lu, su = report.length_unit, report.small_unit
    title = _DRAW[report.kind](ax, report, lu, su)
    ax.set_xlabel(f"station [{lu}]")
    ax.set_title(title)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize=8, ncol=3)
    return save_figure(fig, path)  # temporary file + os.replace: an older figure survives a failure
