"""Network roughness report: one HTML page over a batch results folder, its PNG figures and CSV tables.

Rendering only: every number comes from :func:`longprofile.batch.summarize_network`. The page is
``report/templates/network_report.html`` (Jinja2), like the single-file report: text escaped with
:func:`html.escape` here, figures embedded as PNG.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from ._html import REPORT_FILES, img_tag, render, report_folder, write_csv, write_figures, write_text
from ._layout import fixed_figure, fixed_grid
from ._road import _CSS, _FAIR, _GOOD, _POOR, _condition, _figure, _table_html

__all__ = ["write_network_report", "plot_network_routes", "plot_iri_histogram"]

_NONE = "#bdbdbd"
_COLOURS = {"good": _GOOD, "fair": _FAIR, "poor": _POOR, "none": _NONE}
#: Routes per condition-strip figure, and at most this many routes drawn (the worst, when there are more).
ROUTES_PER_FIGURE = 40
MAX_ROUTES_DRAWN = 200
#: Condition order of the strips' colour codes (:func:`condition_spans`).
CONDITIONS = ("good", "fair", "poor", "none")
#: Bins per pixel of a figure's data area: the strips and the IRI lines are reduced to this resolution before
#: drawing (a network of 1.3 million overlapping windows took 30 s to draw one rectangle per window, session 38).
PIXEL_BINS = 2
#: Condition codes in the order a tie in a bin is given (the worse first; "no segment", code 4, last).
_TIE_ORDER = np.array([2, 1, 0, 3, 4])
_EXTRA_CSS = """
.card.bad{border-color:#c62828;background:#c6282815}td.err{text-align:left;font-family:ui-monospace,monospace;
font-size:0.85em;white-space:normal;max-width:720px}th.l{text-align:left}td.path{text-align:left;word-break:break-all;max-width:380px}
"""


#: IRI unit label -> column-name suffix (as ``road iri``: ``mean_iri_m_per_km``, ``mean_iri_in_per_mi``).
_IRI_SUFFIX = {"m/km": "m_per_km", "in/mi": "in_per_mi", "mm/m": "mm_per_m"}
_STATION_COLUMNS = ("start", "end", "length", "peak_start", "peak_end")
_IRI_COLUMNS = ("mean_iri", "max_iri", "segment_iri")


def with_units(table, summary):
    """``table`` with its station and IRI columns named with their unit, as ``road iri`` names them
    (``start_m`` / ``start_ft``, ``mean_iri_m_per_km`` / ``mean_iri_in_per_mi``): the CSV files and the page."""
    su, iu = summary.station_unit, _IRI_SUFFIX.get(summary.iri_unit, summary.iri_unit.replace("/", "_per_"))
    names = {c: f"{c}_{su}" for c in _STATION_COLUMNS} | {c: f"{c}_{iu}" for c in _IRI_COLUMNS}
    return table.rename(columns={c: n for c, n in names.items() if c in table.columns})


def _legend_handles(limits, unit):
    from matplotlib.patches import Patch

    good, poor = limits
    labels = {"good": f"good < {good:.3g} {unit}", "fair": "fair", "poor": f"poor > {poor:.3g} {unit}",
              "none": "no value"}
    return [Patch(color=_COLOURS[c], label=labels[c]) for c in ("good", "fair", "poor", "none")]


def route_positions(segments) -> dict:
    """Route -> row positions of its segments in ``segments`` (``NetworkSummary.segments``), ordered by start then end.

    One pass over the table for all the routes drawn (selecting each route's rows by a comparison over the whole
    table was routes x segments).
    """
    if not len(segments):
        return {}
    start, end = segments["start"].to_numpy(dtype=float), segments["end"].to_numpy(dtype=float)
    out = {}
    for route, pos in segments.groupby("route", sort=False).indices.items():
        out[str(route)] = pos[np.lexsort((end[pos], start[pos]))]
    return out


def _data_bins(ax) -> int:
    """Bins across the data area of ``ax``: PIXEL_BINS per pixel of the PNG (the figure's resolution)."""
    return max(int(np.ceil(ax.get_window_extent().width * PIXEL_BINS)), 1)


def condition_spans(start, end, code, lo, hi, bins):
    """Rectangles of one route's condition strip: ``(x0, width, code)``, at most ``bins`` of them.

    Parameters
    ----------
    start, end : ndarray
        Segment (or window) stations, ordered by start then end.
    code : ndarray of int
        Condition of each segment: index into ``CONDITIONS`` (good, fair, poor, none).
    lo, hi : float
        Station range of the axis.
    bins : int
        Bins across the axis (a few per pixel).

    Notes
    -----
    Each segment shows from its start to the next one's start (or its end, if sooner): what drawing the segments
    in order, each over the one before, shows, and the stretch ``summarize_network`` counts for it. Consecutive
    segments of one condition are one rectangle (the picture is unchanged, and the length drawn per condition is
    the route's covered length per condition, ``routes.csv``: share x length). When a route still has more
    rectangles than ``bins`` (a condition changing several times per pixel, where drawing every segment showed, per
    pixel, whichever segment the renderer drew last), each bin takes the condition covering the most of its length
    (or stays blank when most of it has no segment); ties go to the worse condition (poor, fair, good, then none).
    At most ``bins`` rectangles; consecutive bins of one condition are one.
    """
    stop = np.minimum(end, np.append(start[1:], np.inf))
    keep = stop > start
    s, t, c = start[keep], stop[keep], code[keep]
    if s.size == 0:
        return s, s, c
    first = np.flatnonzero(np.r_[True, (c[1:] != c[:-1]) | (s[1:] > t[:-1])])
    last = np.r_[first[1:] - 1, s.size - 1]
    s, t, c = s[first], t[last], c[first]
    if s.size <= bins:
        return s, t - s, c
    edges = np.linspace(lo, hi, bins + 1)
    widths = np.zeros((bins, len(CONDITIONS) + 1))  # length per condition in each bin, then the length without any
    for k in range(len(CONDITIONS)):
        m = c == k
        if m.any():  # covered length of condition k up to each edge: linear inside its runs, flat between
            w = t[m] - s[m]
            cum = np.column_stack([np.cumsum(w) - w, np.cumsum(w)]).ravel()
            widths[:, k] = np.diff(np.interp(edges, np.column_stack([s[m], t[m]]).ravel(), cum))
    widths[:, -1] = np.diff(edges) - widths[:, :-1].sum(axis=1)
    code = _TIE_ORDER[np.argmax(widths[:, _TIE_ORDER], axis=1)]
    drawn = np.flatnonzero(code < len(CONDITIONS))
    if drawn.size == 0:
        return drawn.astype(float), drawn.astype(float), drawn
    first = drawn[np.r_[True, (code[drawn[1:]] != code[drawn[:-1]]) | (np.diff(drawn) > 1)]]
    last = np.r_[drawn[np.searchsorted(drawn, first[1:]) - 1], drawn[-1]]
    return edges[first], edges[last + 1] - edges[first], code[first]


def plot_network_routes(summary, routes, *, title: str = "", positions=None):
    """Condition strip chart: one row per route, each segment coloured good / fair / poor along its stations.

    Parameters
    ----------
    summary : NetworkSummary
    routes : sequence of str
        Routes to draw, top to bottom.
    title : str
    positions : dict, optional
        :func:`route_positions` of ``summary.segments`` (computed when not given).

    Returns
    -------
    matplotlib.figure.Figure
        All the strips are one collection of rectangles, at most ``bins`` per route where ``bins`` is
        :data:`PIXEL_BINS` per pixel of the data area (:func:`condition_spans`): a route of 10^5 windows costs
        what a route of 10^3 does.
    """
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import to_rgba_array

    seg = summary.segments
    positions = route_positions(seg) if positions is None else positions
    labels = [r if len(r) <= 34 else "…" + r[-33:] for r in routes]
    # left margin for the route names (8 pt labels: ~0.068 in per character at most; they were cut at 0.85 in)
    fig = fixed_figure(10.0, 1.1 + 0.26 * max(len(routes), 1), dpi=110,
                       left=max(0.85, 0.2 + 0.068 * max(map(len, labels), default=0)))
    ax = fig.add_subplot()
    rows = [(row, positions[r]) for row, r in enumerate(routes) if len(positions.get(r, ()))]
    start, end = seg["start"].to_numpy(dtype=float), seg["end"].to_numpy(dtype=float)
    lo = min((float(start[p].min()) for _, p in rows), default=np.inf)
    hi = max((float(end[p].max()) for _, p in rows), default=-np.inf)
    condition = seg["condition"].to_numpy()
    bins = _data_bins(ax)
    verts, colours = [], []
    palette = to_rgba_array([_COLOURS[c] for c in CONDITIONS])
    for row, p in rows:
        code = np.select([condition[p] == c for c in CONDITIONS[:-1]], range(len(CONDITIONS) - 1), len(CONDITIONS) - 1)
        x0, w, c = condition_spans(start[p], end[p], code, lo, hi, bins)
        y0, y1 = np.full(x0.size, row - 0.38), np.full(x0.size, row + 0.38)
        verts.append(np.stack([np.column_stack([x0, y0]), np.column_stack([x0, y1]),
                               np.column_stack([x0 + w, y1]), np.column_stack([x0 + w, y0])], axis=1))
        colours.append(palette[c])
    if verts:
        ax.add_collection(PolyCollection(np.concatenate(verts), facecolors=np.concatenate(colours), linewidths=0))
    if np.isfinite(lo) and hi > lo:
        ax.set_xlim(lo, hi)
    ax.set_yticks(range(len(routes)))
    ax.set_yticklabels(labels, fontsize=8)
    ax.set_ylim(len(routes) - 0.5, -0.5)
    ax.set_xlabel(f"station [{summary.station_unit}]")
    ax.set_title(title or "Condition along each route", loc="left", fontsize=10)
    ax.grid(axis="x", color="0.9", lw=0.8)
    ax.set_axisbelow(True)
    ax.legend(handles=_legend_handles(summary.limits, summary.iri_unit), loc="lower right", fontsize=8, ncol=4,
              bbox_to_anchor=(1.0, 1.0), borderaxespad=0.1, frameon=False, handlelength=1.2)
    return fig


def _first_per_bin(index, binof):
    """The first of ``index`` (increasing) in each bin ``binof[index]``."""
    b = binof[index]
    return index[np.r_[True, b[1:] != b[:-1]]] if index.size else index


def step_envelope(start, y, bins):
    """Positions of the steps kept to draw a step line ``y`` (step k from ``start[k]``) at ``bins`` bins across its
    range: in each bin its first and last step, its lowest and highest value, and where a gap (NaN) begins and
    ends. At most ``6 * bins`` steps; all of them when there are no more than ``4 * bins``.

    Each bin drawn from these keeps the vertical extent of the full line (lowest to highest value) and the values at
    its edges, so at a bin narrower than a pixel the drawn line covers the same pixels (the min/max envelope used
    for large time series); what is lost is the order of the values inside a bin.
    """
    n = y.size
    if n <= 4 * bins:
        return np.arange(n)
    span = start[-1] - start[0]
    binof = np.minimum(((start - start[0]) / (span if span > 0 else 1.0) * bins).astype(np.int64), bins - 1)
    firsts = np.flatnonzero(np.r_[True, binof[1:] != binof[:-1]])
    lasts = np.r_[firsts[1:] - 1, n - 1]
    counts = np.diff(np.r_[firsts, n])
    nan = np.isnan(y)
    kept = [firsts, lasts]
    for fill, reduce in ((np.inf, np.minimum), (-np.inf, np.maximum)):
        v = np.where(nan, fill, y)
        extreme = np.repeat(reduce.reduceat(v, firsts), counts)
        kept.append(_first_per_bin(np.flatnonzero(v == extreme), binof))
    edges = np.flatnonzero(nan[1:] != nan[:-1]) + 1
    kept += [_first_per_bin(edges[nan[edges]], binof), _first_per_bin(edges[~nan[edges]], binof)]
    return np.unique(np.concatenate(kept))


def plot_worst_routes(summary, routes, *, positions=None):
    """Segment IRI against station for a few routes (one panel each), with the condition bands.

    Each route's step line is drawn from at most ``6 * bins`` of its segments (:func:`step_envelope`, ``bins`` =
    :data:`PIXEL_BINS` per pixel of the panel): the same line at the figure's resolution.
    """
    from matplotlib.patches import StepPatch

    seg = summary.segments
    positions = route_positions(seg) if positions is None else positions
    good, poor = summary.limits
    n = max(len(routes), 1)
    fig = _figure(height=0.6 + 1.55 * n)
    # 0.55 in between panels: the tick labels of one panel and the route name over the next (they overlapped)
    axes = fixed_grid(fig, n, 1, hspace=0.55)[:, 0]
    top = max(float(np.nanmax(seg["segment_iri"], initial=0.0)) if len(seg) else 0.0, poor) * 1.12
    start, end = seg["start"].to_numpy(dtype=float), seg["end"].to_numpy(dtype=float)
    iri = seg["segment_iri"].to_numpy(dtype=float)
    for ax, route in zip(axes, routes):
        p = positions.get(route, np.zeros(0, dtype=np.int64))
        ax.axhspan(0, good, color=_GOOD, alpha=0.10, lw=0)
        ax.axhspan(good, poor, color=_FAIR, alpha=0.12, lw=0)
        ax.axhspan(poor, top, color=_POOR, alpha=0.10, lw=0)
        if p.size:
            x = np.append(start[p], end[p][-1:])
            keep = step_envelope(start[p], iri[p], _data_bins(ax))
            # ax.stairs's limits update walks the path vertex by vertex in Python; both limits are set here
            ax.add_artist(StepPatch(iri[p][keep], np.append(x[keep], x[-1]), baseline=0, fill=False,
                                    edgecolor="0.15", lw=1.2))
            ax.set_xlim(x[0], x[-1])
        ax.set_ylim(0, top)
        ax.set_ylabel(summary.iri_unit, fontsize=8)
        ax.set_title(route, fontsize=9, loc="left")
        ax.tick_params(labelsize=8)
    axes[-1].set_xlabel(f"station [{summary.station_unit}]")
    return fig


def plot_iri_histogram(summary, *, bins: int = 40):
    """Distribution of the segment IRI of the counted routes: segments per bin, bins coloured by condition, limits
    marked."""
    seg = summary.segments
    v = (seg[seg["counted"]] if "counted" in seg else seg)["segment_iri"].to_numpy(dtype=float)
    v = v[np.isfinite(v)]
    good, poor = summary.limits
    fig = _figure(height=3.4)
    ax = fig.add_subplot()
    hi = max(float(np.quantile(v, 0.995)) * 1.05 if v.size else 0.0, poor * 1.4)
    width = hi / bins
    edges = np.unique(np.concatenate([np.arange(0.0, hi + width, width), [good, poor]]))
    edges = np.append(edges, max(edges[-1], float(v.max()) if v.size else 0.0) + width)  # the tail in the last bin
    counts, _ = np.histogram(v, bins=edges)
    mid = 0.5 * (edges[:-1] + edges[1:])
    colours = [_GOOD if m < good else (_POOR if m > poor else _FAIR) for m in mid]
    ax.bar(edges[:-1], counts, width=np.diff(edges), align="edge", color=colours, edgecolor="white", lw=0.4)
    ax.axvline(good, color=_GOOD, ls="--", lw=1, label=f"good < {good:.3g}")
    ax.axvline(poor, color=_POOR, ls="--", lw=1, label=f"poor > {poor:.3g}")
    ax.set_xlim(0, edges[-1])
    ax.set_xlabel(f"segment IRI [{summary.iri_unit}]  ({summary.segment_iri})")
    ax.set_ylabel("segments")
    ax.set_title(f"Distribution of the segment IRI ({v.size} segments)")
    ax.legend(loc="upper right", fontsize=8)
    return fig


def _num(x) -> str:
    return "–" if not np.isfinite(x) else f"{x:.2f}"


def _pct(x) -> str:
    return "–" if not np.isfinite(x) else f"{100 * x:.0f} %"


def _failed_html(failed, limit=500) -> str:
    if len(failed) == 0:
        return "<p>No file failed.</p>"
    rows = "".join(f'<tr><td class="path">{html.escape(str(r.path))}</td><td class="err">{html.escape(str(r.error))}'
                   "</td></tr>" for r in failed.head(limit).itertuples())
    more = (f"<p class='small'>{len(failed) - limit} more in failed.csv.</p>" if len(failed) > limit else "")
    return f"<table><thead><tr><th>file</th><th class='l'>error</th></tr></thead><tbody>{rows}</tbody></table>{more}"


_REPORT_FILES = REPORT_FILES["network"]


def write_network_report(summary, outdir, *, title: str | None = None, inputs=(),
                         overwrite: bool = True) -> list[Path]:
    """Write ``index.html`` (figures embedded), the PNG figures and the CSV tables of a network into ``outdir``.

    Parameters
    ----------
    summary : NetworkSummary
        From :func:`longprofile.batch.summarize_network`.
    outdir : path-like
        Report folder (created; files of an earlier report there are replaced).
    title : str, optional
    inputs : sequence of path-like
        The results folder(s) read, to refuse writing into them.
    overwrite : bool, default True
        False refuses an existing, non-empty ``outdir`` (:class:`~longprofile.errors.OutputError`).

    Returns
    -------
    list of Path
        Files written, ``index.html`` first.
    """
    out = report_folder(outdir, inputs, writes=_REPORT_FILES, overwrite=overwrite)
    tables = {"routes.csv": with_units(summary.routes, summary), "worst_segments.csv": with_units(summary.worst, summary),
              "failed.csv": summary.failed}
    written = [write_csv(df, out / fname) for fname, df in tables.items()]
    figs, drawn = _network_figures(summary)
    for stale in out.glob("routes-*.png"):  # an earlier report of a bigger network
        if stale.name not in figs:
            stale.unlink()
    paths, images = write_figures(figs, out)
    written.extend(paths)
    page = render("network_report.html", **_page_context(summary, tables, figs, images, drawn, title))
    written.insert(0, write_text(out / "index.html", page))
    return written


def _network_figures(summary):
    """The figures by file name (condition strips of the routes drawn, the worst routes, the histogram) and the
    routes drawn: all up to MAX_ROUTES_DRAWN, by name."""
    routes = summary.routes
    drawn = sorted(routes["route"].head(MAX_ROUTES_DRAWN)) if len(routes) else []
    positions = route_positions(summary.segments)
    figs = {}
    for k in range(0, len(drawn), ROUTES_PER_FIGURE):
        chunk = drawn[k:k + ROUTES_PER_FIGURE]
        name = f"routes-{k // ROUTES_PER_FIGURE + 1:02d}.png"
        label = (f" (routes {k + 1}–{k + len(chunk)} of {len(drawn)})" if len(drawn) > ROUTES_PER_FIGURE else "")
        figs[name] = plot_network_routes(summary, chunk, title="Condition along each route" + label,
                                         positions=positions)
    worst_routes = list(routes["route"].head(6)) if len(routes) else []
    if worst_routes:
        figs["worst_routes.png"] = plot_worst_routes(summary, worst_routes, positions=positions)
    if len(summary.segments):
        figs["iri_histogram.png"] = plot_iri_histogram(summary)
    return figs, drawn


def _length_text(summary, length) -> str:
    su = summary.station_unit
    value = length / (1000.0 if su == "m" else (5280.0 if su == "ft" else 1.0))
    return f"{value:.1f} {dict(m='km', ft='mi').get(su, su)}"


def _network_cards(summary) -> list[str]:
    """The summary cards of the page: files, measured length, mean segment IRI, condition shares."""
    counts, routes = summary.counts, summary.routes
    n_files = sum(counts.values())  # rows of the last run (rows kept from earlier runs are in the "left out" card)
    good, poor = summary.limits
    unit = summary.iri_unit
    counted = summary.segments["counted"] if "counted" in summary.segments else None
    n_seg = int(counted.sum()) if counted is not None else len(summary.segments)
    kind = "overlapping windows" if summary.overlapping else "segments"
    n_routes = int((routes["counted"] == "yes").sum()) if "counted" in routes else len(routes)
    measured = summary.measured if np.isfinite(summary.measured) else summary.length
    gaps = summary.length - measured
    detail = (f"of {_length_text(summary, summary.length)} surveyed, {_length_text(summary, gaps)} unmeasured (gaps); "
              if gaps > 1e-6 * max(summary.length, 1.0) else "")
    detail += "overlapping windows counted once; " if summary.overlapping else ""
    cards = [f'<div class="card">Network, measured length<b>{_length_text(summary, measured)}</b><span class="small">'
             f"{detail}{n_seg} {kind}, {n_routes} routes</span></div>",
             f'<div class="card"{_condition(summary.mean_iri, summary.limits)}>'
             f'Mean segment IRI<b>{_num(summary.mean_iri)} {unit}</b><span class="small">length-weighted</span></div>']
    parts = (("good", _GOOD), ("fair", _FAIR), ("poor", _POOR), ("none", _NONE))
    shares = " · ".join(f'<span style="color:{colour}">{_pct(summary.share[c])}</span>' for c, colour in parts)
    cards.append(f'<div class="card">Condition, share of the length<b>{shares}</b><span class="small">good · fair · '
                 f'poor · no IRI (unmeasured or too short; good &lt; {good:.3g}, poor &gt; {poor:.3g} {unit})</span>'
                 "</div>")
    excluded = summary.excluded
    if excluded is not None and len(excluded):
        cards.append(f'<div class="card bad">Left out of the totals<b>{len(excluded)} files, '
                     f'{_length_text(summary, float(excluded["length"].sum()))}</b><span class="small">listed below '
                     "and in routes.csv (column counted)</span></div>")
    res = summary.results
    interrupted = res.complete is False
    total = max(n_files, res.n_inputs or 0)
    bad = " bad" if counts["error"] or interrupted else ""
    cards.insert(0, f'<div class="card{bad}">Files<b>{counts["ok"] + counts["skipped"]} / {total} done</b>'
                 f'<span class="small">{counts["error"]} failed'
                 + (f", {counts['skipped']} kept from an earlier run" if counts["skipped"] else "")
                 + (f"; the run was interrupted after {n_files} of {total} inputs: --resume finishes it"
                    if interrupted else "") + "</span></div>")
    return cards


def _network_tables(summary) -> tuple[str, str]:
    """The HTML tables of the worst segments and of the routes (first 100); "" for an empty one."""
    routes = summary.routes
    highlight = (lambda c, v: _condition(float(v), summary.limits)
                 if (str(c) in summary.value_columns or str(c).startswith(_IRI_COLUMNS))
                 and isinstance(v, (float, np.floating)) else "")
    dup = ["segment_iri"] if summary.segment_iri_column is not None else []  # a copy of a column shown
    worst = with_units(summary.worst.drop(columns=["file", "condition"] + dup, errors="ignore"), summary)
    worst_html = _table_html(worst, fmt="{:.2f}", highlight=highlight) if len(worst) else ""
    rtab = routes.head(100).copy()
    for c in ("good", "fair", "poor", "none"):
        if c in rtab:
            rtab[c] = [_pct(x) for x in rtab[c]]
    rtab = with_units(rtab.drop(columns=["file"]), summary)
    routes_html = _table_html(rtab, fmt="{:.2f}", highlight=highlight) if len(rtab) else ""
    return worst_html, routes_html


#: The alternative text of each figure of the page (the condition strips: every ``routes-NN.png``).
_ALT = {"worst_routes.png": "worst routes", "iri_histogram.png": "histogram"}


def _page_context(summary, tables, figs, images, drawn, title) -> dict:
    """Everything ``templates/network_report.html`` shows: cards, figures as ``<img>`` tags, tables, the run."""
    res, routes = summary.results, summary.routes
    n_files = len(res.manifest)
    worst_table, routes_table = _network_tables(summary)
    name = title or f"Network roughness report — {res.folder.name}"
    meta = (f"{n_files} input files, task {res.task}; IRI in {summary.iri_unit} per segment (the IRI report of each "
            f"file); segment IRI = {summary.segment_iri}.")
    warnings = summary.warnings
    excluded = summary.excluded.head(500) if summary.excluded is not None else summary.failed.head(0)
    return dict(
        name=html.escape(name), css=_CSS + _EXTRA_CSS, meta=html.escape(meta), cards=_network_cards(summary),
        img={f: img_tag(images, f, _ALT.get(f, "condition along each route")) for f in images},
        strips=[img_tag(images, f, "condition along each route") for f in figs if f.startswith("routes-")],
        n_drawn=len(drawn), n_routes=len(routes), good=f"{summary.limits[0]:.3g}", poor=f"{summary.limits[1]:.3g}",
        unit=summary.iri_unit, worst_table=worst_table, routes_table=routes_table,
        n_failed=summary.counts["error"], failed_table=_failed_html(summary.failed),
        excluded=[(html.escape(str(r.path)), html.escape(str(r.reason)), html.escape(_length_text(summary, r.length)))
                  for r in excluded.itertuples()], n_excluded=len(excluded), unseen=html.escape(_unseen_note(summary)),
        n_warnings=len(warnings), warnings=[(html.escape(str(r.path)), html.escape(str(r.warning)))
                                            for r in warnings.head(500).itertuples()],
        folder=html.escape(str(res.folder)), options=html.escape(json.dumps(res.options)),
        version=html.escape(str(res.manifest["longprofile_version"].iloc[0] if n_files else "")),
        files=[html.escape(f) for f in list(tables) + list(figs)])


def _unseen_note(summary) -> str:
    """A sentence when a manifest written before session 38 (no ``run`` column: which run saw each row is unknown)
    holds more inputs with results than the last run was given (rows kept by ``--resume`` of files not given again):
    only the count is known. Newer manifests list such rows as "not in the last run"
    (:func:`longprofile.batch.summarize_network`)."""
    res = summary.results
    if getattr(res, "last_run", None) is not None:
        return ""
    done = int(res.manifest["status"].isin(["ok", "skipped"]).sum())
    gone = len(res.missing_inputs)
    if res.n_inputs is None or done - gone <= res.n_inputs:
        return ""
    return (f"The manifest holds results of {done - gone - res.n_inputs} more existing file(s) than the last run was "
            "given (rows kept by --resume from earlier runs); this folder was written before the manifest recorded "
            "which run saw each file, so they are counted.")
