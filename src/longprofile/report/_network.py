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
from ._road import _CSS, _FAIR, _GOOD, _POOR, _condition, _figure, _table_html

__all__ = ["write_network_report", "plot_network_routes", "plot_iri_histogram"]

_NONE = "#bdbdbd"
_COLOURS = {"good": _GOOD, "fair": _FAIR, "poor": _POOR, "none": _NONE}
#: Routes per condition-strip figure, and at most this many routes drawn (the worst, when there are more).
ROUTES_PER_FIGURE = 40
MAX_ROUTES_DRAWN = 200
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


def plot_network_routes(summary, routes, *, title: str = ""):
    """Condition strip chart: one row per route, each segment coloured good / fair / poor along its stations.

    Parameters
    ----------
    summary : NetworkSummary
    routes : sequence of str
        Routes to draw, top to bottom.
    title : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    seg = summary.segments
    fig = _figure(height=1.1 + 0.26 * max(len(routes), 1))
    ax = fig.add_subplot()
    lo, hi = np.inf, -np.inf
    for row, route in enumerate(routes):
        s = seg[seg["route"] == route]
        if len(s) == 0:
            continue
        spans = list(zip(s["start"].to_numpy(), (s["end"] - s["start"]).to_numpy()))
        ax.broken_barh(spans, (row - 0.38, 0.76), facecolors=[_COLOURS[c] for c in s["condition"]], linewidth=0)
        lo, hi = min(lo, float(s["start"].min())), max(hi, float(s["end"].max()))
    if np.isfinite(lo) and hi > lo:
        ax.set_xlim(lo, hi)
    ax.set_yticks(range(len(routes)))
    ax.set_yticklabels([r if len(r) <= 34 else "…" + r[-33:] for r in routes], fontsize=8)
    ax.set_ylim(len(routes) - 0.5, -0.5)
    ax.set_xlabel(f"station [{summary.station_unit}]")
    ax.set_title(title or "Condition along each route", loc="left", fontsize=10)
    ax.grid(axis="x", color="0.9", lw=0.8)
    ax.set_axisbelow(True)
    ax.legend(handles=_legend_handles(summary.limits, summary.iri_unit), loc="lower right", fontsize=8, ncol=4,
              bbox_to_anchor=(1.0, 1.0), borderaxespad=0.1, frameon=False, handlelength=1.2)
    return fig


def plot_worst_routes(summary, routes):
    """Segment IRI against station for a few routes (one panel each), with the condition bands."""
    seg = summary.segments
    good, poor = summary.limits
    n = max(len(routes), 1)
    fig = _figure(height=0.6 + 1.55 * n)
    axes = fig.subplots(n, 1, squeeze=False)[:, 0]
    top = max(float(np.nanmax(seg["segment_iri"], initial=0.0)) if len(seg) else 0.0, poor) * 1.12
    for ax, route in zip(axes, routes):
        s = seg[seg["route"] == route]
        x = np.append(s["start"].to_numpy(), s["end"].to_numpy()[-1:])
        y = s["segment_iri"].to_numpy()
        ax.axhspan(0, good, color=_GOOD, alpha=0.10, lw=0)
        ax.axhspan(good, poor, color=_FAIR, alpha=0.12, lw=0)
        ax.axhspan(poor, top, color=_POOR, alpha=0.10, lw=0)
        if y.size:
            ax.stairs(y, x, color="0.15", lw=1.2)
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
    figs = {}
    for k in range(0, len(drawn), ROUTES_PER_FIGURE):
        chunk = drawn[k:k + ROUTES_PER_FIGURE]
        name = f"routes-{k // ROUTES_PER_FIGURE + 1:02d}.png"
        label = (f" (routes {k + 1}–{k + len(chunk)} of {len(drawn)})" if len(drawn) > ROUTES_PER_FIGURE else "")
        figs[name] = plot_network_routes(summary, chunk, title="Condition along each route" + label)
    worst_routes = list(routes["route"].head(6)) if len(routes) else []
    if worst_routes:
        figs["worst_routes.png"] = plot_worst_routes(summary, worst_routes)
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
    n_files = len(summary.results.manifest)
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
    """A sentence when the manifest holds more inputs with results than the last run was given (rows kept by
    ``--resume`` of files not given again): the manifest does not record which, so only the count is known."""
    res = summary.results
    done = int(res.manifest["status"].isin(["ok", "skipped"]).sum())
    gone = len(res.missing_inputs)
    if res.n_inputs is None or done - gone <= res.n_inputs:
        return ""
    return (f"The manifest holds results of {done - gone - res.n_inputs} more existing file(s) than the last run was "
            "given (rows kept by --resume from earlier runs); the manifest does not record which, so they are "
            "counted.")
