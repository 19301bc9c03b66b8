"""Smoothness acceptance and profile-comparison reports: HTML page, figures, CSV tables (rendering only).

Every number comes from :func:`longprofile.road.smoothness._acceptance.smoothness_acceptance`,
:func:`longprofile.road.smoothness._grinding.simulate_grinding` and :func:`longprofile.road.smoothness._compare.certify_profiler`.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from ..io import atomic_path
from ._html import REPORT_FILES, img_tag, png_bytes, render, report_folder, write_pngs, write_text
from ._layout import fixed_figure
from ._render import current_renderer

__all__ = ["plot_certification", "write_acceptance_report"]

#: Files of the acceptance report, with the ground profile the CLI writes beside it (``road acceptance``).
_ACCEPTANCE_FILES = REPORT_FILES["acceptance"]


def _figure(width=10.0, height=3.4):
    # titles are given y=1.0 (where matplotlib's automatic placement puts them on these axes, without top ticks)
    # so that drawing skips measuring the axes for it
    return fixed_figure(width, height, bottom=0.5, dpi=90)


def _prepare(outdir, inputs, names, overwrite=True):
    return report_folder(outdir, inputs, writes=names, overwrite=overwrite)


def _envelope(x, y, max_points=3000):
    """Min/max envelope over bins when there are too many points to draw (keeps every spike)."""
    if x.size <= max_points:
        return x, y, y
    k = int(np.ceil(x.size / (max_points // 2)))
    m = (x.size // k) * k
    yb = y[:m].reshape(-1, k)
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return x[:m].reshape(-1, k).mean(axis=1), np.nanmin(yb, axis=1), np.nanmax(yb, axis=1)


def _spans(ax, ranges, **style) -> None:
    """Vertical bands over the x ranges ``[(a, b), ...]`` from the bottom to the top of the axes: the picture of
    one ``axvspan`` per range (x limits included), drawn as one collection (no patch and no limit update per
    range: a report with a hundred defects drew them in a third of a second)."""
    from matplotlib.collections import PolyCollection

    ranges = [(float(a), float(b)) for a, b in ranges]
    if not ranges:
        return
    verts = [[(a, 0.0), (a, 1.0), (b, 1.0), (b, 0.0)] for a, b in ranges]
    ax.add_collection(PolyCollection(verts, transform=ax.get_xaxis_transform(), **style), autolim=False)
    ax.dataLim.update_from_data_x(np.array(ranges, dtype=float).ravel(), ignore=False)
    ax.autoscale_view(scaley=False)


def _bars(ax, left, height, width, color) -> None:
    """Bars from 0 to ``height`` over ``[left, left + width]``: the picture of ``ax.bar(..., align="edge")``
    (y limits stuck at 0, margins elsewhere), drawn as one collection instead of one patch per bar."""
    from matplotlib.collections import PolyCollection

    left, height, width = (np.asarray(v, dtype=float) for v in (left, height, width))
    ok = np.isfinite(height)  # a NaN bar draws nothing, as in ax.bar
    verts = [[(a, 0.0), (a, h), (a + w, h), (a + w, 0.0)] for a, h, w in zip(left[ok], height[ok], width[ok])]
    colours = np.asarray(color, dtype=object)[ok] if not isinstance(color, str) else color
    bars = PolyCollection(verts, facecolors=colours, edgecolors="none", linewidths=0)
    bars.sticky_edges.y.append(0.0)
    ax.add_collection(bars, autolim=True)
    ax.autoscale_view()


def _png(fig) -> bytes:
    return png_bytes(fig)  # zlib level 1 (report._html: PNG_COMPRESS_LEVEL)


def _lots_png(start, index, width, colours, exclusions, labels: dict) -> bytes:
    """PNG of the lot index bars (grey: excluded zones)."""
    fig = _figure()
    ax = fig.add_subplot()
    _bars(ax, start, index, width, colours)
    _spans(ax, exclusions, color="0.6", alpha=0.3, lw=0)
    ax.set_xlabel(labels["x"])
    ax.set_ylabel(labels["y"])
    ax.set_title(labels["title"], y=1.0)  # see _figure
    return _png(fig)


def _localized_png(before, after, threshold, defects, exclusions, labels: dict) -> bytes:
    """PNG of the localized roughness map: envelopes ``(x, low, high)`` before and (optional) after grinding."""
    fig = _figure()
    ax = fig.add_subplot()
    ax.fill_between(*before, color="#1565c0", lw=0.6, label="localized index (before)")
    if after is not None:
        ax.fill_between(*after, color="#2e7d32", alpha=0.6, lw=0.6, label="after grinding")
    if threshold is not None:
        ax.axhline(threshold, color="#c62828", ls="--", lw=1, label=labels["threshold"])
    _spans(ax, defects, color="#c62828", alpha=0.15, lw=0)
    _spans(ax, exclusions, color="0.6", alpha=0.3, lw=0)
    ax.set_xlabel(labels["x"])
    ax.set_ylabel(labels["y"])
    ax.set_title(labels["title"], y=1.0)
    ax.legend(loc="upper right", fontsize=8)
    return _png(fig)


def _histogram_png(low, length, width, labels: dict) -> bytes:
    """PNG of the lot index histogram (length per class)."""
    fig = _figure(6.0, 3.2)
    ax = fig.add_subplot()
    _bars(ax, low, length, width, "#1565c0")
    ax.set_xlabel(labels["x"])
    ax.set_ylabel(labels["y"])
    ax.set_title("Lot index histogram", y=1.0)
    return _png(fig)


def _write_csv(frame, path: Path) -> None:
    """CSV through pyarrow (pandas' float formatting takes seconds for the per-sample localized table)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    with atomic_path(path) as tmp:  # an older file is replaced only once the new one is complete
        pacsv.write_csv(pa.Table.from_pandas(frame, preserve_index=False), tmp)


def _table(frame, floatfmt="{:.3f}", max_rows=500) -> str:
    shown = frame.head(max_rows)
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in shown.columns)
    rows = []
    for _, r in shown.iterrows():
        cells = []
        for v in r.tolist():
            if isinstance(v, (float, np.floating)):
                cells.append("<td>–</td>" if not np.isfinite(v) else f"<td>{floatfmt.format(v)}</td>")
            else:
                cells.append(f"<td>{html.escape(str(v))}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    more = f"<p>… {len(frame) - max_rows} more rows in the CSV.</p>" if len(frame) > max_rows else ""
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>{more}"


def _submit_figures(renderer, result) -> dict:
    """Queue the figures of the acceptance report that do not need the grinding on ``renderer``: ``{file name:
    job}`` (``job.result()`` is the PNG). Only arrays, strings and numbers go to the figure functions (they may run
    in a helper process)."""
    spec, lots = result.spec, result.lots
    lu, iu, name = spec.length_unit, spec.iri_unit, spec.index.upper()
    colours = ["#2e7d32" if pf >= 1.0 else ("#f9a825" if np.isfinite(pf) else "#c62828")
               for pf in lots.pay_factor.to_numpy(dtype=float)] if spec.pay_schedule else "#1565c0"
    width = (lots.end - lots.start).to_numpy()
    exclusions = [tuple(map(float, z)) for z in spec.exclusions]
    hist = result.histogram
    return {
        "lots.png": renderer.submit(_lots_png, lots.start.to_numpy(dtype=float), lots["index"].to_numpy(dtype=float),
                                    width * 0.95, colours, exclusions,
                                    {"x": f"station [{lu}]", "y": f"lot {name} [{iu}]",
                                     "title": f"{name} per {spec.lot_length:g} {lu} lot (grey: excluded)"}),
        "histogram.png": renderer.submit(_histogram_png, hist.low.to_numpy(dtype=float),
                                         hist.length.to_numpy(dtype=float),
                                         (hist.high - hist.low).to_numpy(dtype=float) * 0.95,
                                         {"x": f"lot {name} [{iu}]", "y": f"length [{lu}]"}),
    }


def _submit_localized_figure(renderer, result, grinding):
    """Queue the localized roughness map (before and, with a grind list, after grinding) on ``renderer``."""
    spec = result.spec
    lu, iu, threshold = spec.length_unit, spec.iri_unit, spec.localized_threshold
    loc = result.localized
    before = _envelope(loc.station.to_numpy(), loc["index"].to_numpy(dtype=float))
    after = (_envelope(grinding.station, grinding.index_after) if grinding is not None and len(grinding.grinds)
             else None)
    return renderer.submit(
        _localized_png, before, after, threshold,
        [(float(a), float(b)) for a, b in zip(result.defects.start, result.defects.end)],
        [tuple(map(float, z)) for z in spec.exclusions],
        {"x": f"station [{lu}]", "y": f"continuous IRI [{iu}]",
         "title": f"Localized roughness: {spec.localized_window:g} {lu} window",
         "threshold": None if threshold is None else f"threshold {threshold:g} {iu}"})


def write_acceptance_report(result, outdir, *, grinding=None, title: str | None = None, inputs=(),
                            overwrite: bool = True, renderer=None, ground_profile: bool = False) -> list[Path]:
    """Write the acceptance report: ``index.html`` (figures embedded), PNG figures, CSV tables, summary.json.

    Parameters
    ----------
    result : AcceptanceResult
        From :func:`longprofile.road.smoothness_acceptance`.
    outdir : path-like
        Folder (created).
    grinding : GrindingResult or callable, optional
        From :func:`longprofile.road.simulate_grinding`: grind list and the localized roughness after grinding; or
        a function of no argument that returns it (or None), called once the figures that do not need it are
        queued (with a background ``renderer`` they are drawn while it runs).
    title : str, optional
    inputs : sequence of path-like
        Input files, never overwritten.
    overwrite : bool, default True
        False refuses an existing, non-empty ``outdir`` (:class:`~longprofile.errors.OutputError`).
    renderer : optional
        Where the figures are drawn (:func:`~longprofile.report.figure_renderer`; default: the
        :func:`~longprofile.report.current_renderer`, in this process unless a command set a helper).
    ground_profile : bool, default False
        Also write the profile after grinding, ``profile_ground.csv`` (when the grind list is not empty).

    Returns
    -------
    list of Path
        Files written, ``index.html`` first.
    """
    out = _prepare(outdir, inputs, _ACCEPTANCE_FILES, overwrite)
    renderer = renderer or current_renderer()
    jobs = _submit_figures(renderer, result)  # drawn while the grinding runs and the tables are written
    if callable(grinding):
        grinding = grinding()
    jobs["localized.png"] = _submit_localized_figure(renderer, result, grinding)
    tables, written = _write_tables(out, result, grinding, ground_profile)
    paths, images = write_pngs({name: jobs[name].result() for name in ("lots.png", "localized.png", "histogram.png")},
                               out)
    written += paths
    written.append(write_text(out / "summary.json", json.dumps(_summary(result, grinding), indent=2, default=float)))
    page = render("acceptance_report.html", **_page_context(result, grinding, list(tables), images, title))
    return [write_text(out / "index.html", page)] + written


def _write_tables(out: Path, result, grinding, ground_profile: bool) -> tuple[dict, list[Path]]:
    """Write the tables (lots, localized roughness as Parquet, defects, histogram, grinds; the ground profile when
    asked and ground), their columns named with their units (:meth:`AcceptanceSpec.with_unit_names`); return them
    by file name and the paths written."""
    tables = {"lots.csv": result.lots, "localized.parquet": result.localized, "defects.csv": result.defects,
              "histogram.csv": result.histogram}
    if grinding is not None:
        tables["grinds.csv"] = grinding.grinds
    written = []
    for name, frame in tables.items():
        frame = result.spec.with_unit_names(frame)  # start_m, iri_left_m_per_km, max_depth_mm: as `road iri` names
        if name.endswith(".parquet"):  # one row per sample: Parquet (a CSV of 400k rows takes ~0.6 s)
            with atomic_path(out / name) as tmp:
                frame.to_parquet(tmp, index=False, use_dictionary=False)  # floats: dictionary pages cost 4x
        else:
            _write_csv(frame, out / name)
        written.append(out / name)
    if ground_profile and grinding is not None and len(grinding.grinds):
        from ..io import write_profile

        written.append(write_profile(grinding.profile, out / "profile_ground.csv"))
    return tables, written


def _summary(result, grinding) -> dict:
    """``summary.json``: the warnings, the console's sentences (lots, pay, localized roughness), pay summary,
    metadata, the spec and (with a grinding) its outcome."""
    summary = {"warnings": list(result.warnings),
               "text": {"lots": result.lots_text(), "pay": result.pay_text(), "localized": result.localized_text()},
               "pay": result.pay_summary, "metadata": result.metadata,
               "spec": {k: (list(v) if isinstance(v, tuple) else v) for k, v in vars(result.spec).items()}}
    if grinding is not None:
        summary["grinding"] = {"threshold": grinding.threshold, "achieved": grinding.achieved,
                               "areas": int(grinding.grinds["area"].nunique()) if len(grinding.grinds) else 0,
                               **grinding.metadata}
    return summary


def _sentence(text: str, capital: bool = True) -> str:
    """``text`` escaped for the page, as a sentence (capital first letter unless not ``capital``, final full stop)."""
    return html.escape((text[:1].upper() if capital else text[:1]) + text[1:] + ("" if text.endswith(".") else "."))


def _grinding_context(grinding, spec) -> dict | None:
    """The grinding section of the page: target, verdict (bold when not achieved), model, grind list (HTML, its
    columns named with their units as in grinds.csv)."""
    if grinding is None:
        return None
    line = _sentence(grinding.summary())
    return {"threshold": f"{grinding.threshold:g}", "verdict": line if grinding.achieved else f"<b>{line}</b>",
            "model": html.escape(grinding.metadata["model"]),
            "table": _table(spec.with_unit_names(grinding.grinds)) if len(grinding.grinds) else ""}


def _page_context(result, grinding, tables: list[str], images: dict, title: str | None) -> dict:
    """Everything ``templates/acceptance_report.html`` shows: escaped text, numbers as shown, HTML tables (columns
    named with their units, as the CSVs), the figures as ``<img>`` tags by file name."""
    spec, ps = result.spec, result.pay_summary
    pay = _sentence(result.pay_text(), capital=False)
    if spec.pay_schedule and (ps["lots_corrective_work"] or result.warnings):
        pay = f"<b>{pay}</b>"
    return dict(name=html.escape(title or "Smoothness acceptance"), lu=spec.length_unit, iu=spec.iri_unit,
                warnings=[_sentence(w) for w in result.warnings], lots_text=_sentence(result.lots_text()),
                localized=_sentence(result.localized_text()),
                lot_length=f"{spec.lot_length:g}", index=spec.index.upper(), window=f"{spec.localized_window:g}",
                threshold=("" if spec.localized_threshold is None else f"{spec.localized_threshold:g}"),
                n_exclusions=len(spec.exclusions),
                ma_reason=html.escape(str(result.metadata.get("moving_average_reason", ""))), pay=pay,
                img={n: img_tag(images, n, n) for n in images}, lots_table=_table(spec.with_unit_names(result.lots)),
                defects_table=_table(spec.with_unit_names(result.defects)), grinding=_grinding_context(grinding, spec),
                histogram_table=_table(spec.with_unit_names(result.histogram)), tables=tables)


def plot_certification(result, comparisons, path) -> Path:
    """Correlation against offset for each run (accuracy against the reference), with the thresholds.

    Parameters
    ----------
    result : CertificationResult
    comparisons : dict
        ``{(run, track): ProfileComparison}`` against the reference.
    path : path-like
        Figure file (PNG/PDF/SVG by suffix).
    """
    fig = _figure(8.0, 3.6)
    ax = fig.add_subplot()
    for (run, track), c in comparisons.items():
        ax.plot(c.lags, c.curve, lw=1, label=f"{run} ({track}): {c.correlation:.3f} at {c.offset:+.2f} m")
    ax.axhline(result.thresholds["accuracy"], color="#c62828", ls="--", lw=1,
               label=f"accuracy threshold {result.thresholds['accuracy']:g}")
    ax.set_xlabel("offset added to the run's stations [m]")
    ax.set_ylabel("cross-correlation")
    ax.set_title(f"Cross-correlation with the reference ({result.metadata['filter']} filter)")
    ax.legend(fontsize=7, loc="lower right")
    from ..io import save_figure

    return save_figure(fig, path)  # temporary file + os.replace: an older figure survives a failure
