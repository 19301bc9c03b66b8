"""Road roughness report: a self-contained HTML page, its PNG figures and CSV tables.

Rendering only: every number comes from :func:`longprofile.road.analyse_roughness`.
"""

from __future__ import annotations

import html
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from ..io import save_figure
from ._html import REPORT_FILES, figure_pngs, img_tag, render, report_folder, write_csv, write_pngs, write_text
from ._layout import fixed_figure
from ._render import current_renderer

__all__ = ["IRI_CONDITION_LIMITS", "plot_iri", "plot_iri_report", "write_road_report", "road_report_tables",
           "road_report_figures"]

#: IRI condition limits in m/km: good below 1.50 (95 in/mi), poor above 2.68 (170 in/mi) -- the FHWA pavement
#: condition thresholds for IRI (23 CFR 490.313). Used for the colours of the report; configurable.
IRI_CONDITION_LIMITS = (1.50, 2.68)

_GOOD, _FAIR, _POOR = "#2e7d32", "#f9a825", "#c62828"


def _figure(width=10.0, height=3.6):
    return fixed_figure(width, height, left=0.85, dpi=110)


def _envelope(x, y, max_points=60000):
    """Min/max envelope of y over bins when there are too many points to draw (keeps every spike visible)."""
    n = x.size
    if n <= max_points:
        return x, y, y
    k = int(np.ceil(n / (max_points // 2)))
    m = (n // k) * k
    xb = x[:m].reshape(-1, k).mean(axis=1)
    yb = y[:m].reshape(-1, k)
    with warnings.catch_warnings():  # a bin wholly in a gap (NaN, gaps="restart") stays NaN: the line breaks there
        warnings.simplefilter("ignore", RuntimeWarning)
        return xb, np.nanmin(yb, axis=1), np.nanmax(yb, axis=1)


def _iri_axes(ax, result, limits, reference=None, reference_label="reference"):
    good, poor = limits
    top = max(float(np.nanmax(result.iri, initial=0.0)), poor) * 1.25
    if reference is not None and reference.iri.size:
        top = max(top, float(np.nanmax(reference.iri)) * 1.25)
    x0, x1 = (result.segment_start[0], result.segment_end[-1]) if result.iri.shape[0] else (0.0, 1.0)
    ax.axhspan(0, good, color=_GOOD, alpha=0.10, lw=0)
    ax.axhspan(good, poor, color=_FAIR, alpha=0.12, lw=0)
    ax.axhspan(poor, top, color=_POOR, alpha=0.10, lw=0)
    ax.axhline(good, color=_GOOD, lw=1, ls="--", label=f"good < {good:.2f} m/km")
    ax.axhline(poor, color=_POOR, lw=1, ls="--", label=f"poor > {poor:.2f} m/km")
    k = len(result.tracks)
    width = result.segment_length / (k + 1)
    for j, t in enumerate(result.tracks):
        ax.bar(result.segment_start + (j + 0.5) * width, result.iri[:, j], width=width * 0.95, align="edge",
               label=f"IRI {t}", alpha=0.9)
    if reference is not None:
        for j, t in enumerate(reference.tracks):
            ax.step(np.append(reference.segment_start, reference.segment_end[-1:]),
                    np.append(reference.iri[:, j], reference.iri[-1:, j]), where="post", color="k", lw=1.5,
                    label=f"IRI {reference_label}" + (f" ({t})" if len(reference.tracks) > 1 else ""))
    if result.mri is not None:
        ax.step(np.append(result.segment_start, result.segment_end[-1:]), np.append(result.mri, result.mri[-1:]),
                where="post", color="0.2", lw=1.2, ls=":", label="MRI")
    ax.set_xlim(x0, x1)
    ax.set_ylim(0, top)
    ax.set_xlabel("station [m]")
    ax.set_ylabel("IRI [m/km]")
    ax.set_title(f"IRI per {result.segment_length:g} m segment")
    ax.legend(loc="upper right", fontsize=8, ncol=3)


def plot_iri(result, path, *, limits=IRI_CONDITION_LIMITS) -> Path:
    """Bar chart of the IRI per segment with the condition limits, saved as PNG."""
    fig = _figure()
    _iri_axes(fig.add_subplot(), result, limits)
    return save_figure(fig, path)  # temporary file + os.replace: an older figure survives a failure


def plot_iri_report(report, path, *, limits=IRI_CONDITION_LIMITS) -> Path:
    """Draw an :class:`~longprofile.road.IRIReport` in its own units, with the condition limits; return the path.

    Fixed segments: bars per segment and track (MRI as a step line). Continuous and overlapping windows: the
    IRI of each window against the station of its centre (IRI along the road), one line per track. The
    limits are given in m/km (default FHWA good < 1.50, poor > 2.68 m/km) and converted to the report's IRI
    unit (x 63.36 for in/mi).
    """
    factor = 63.36 if report.units == "us" else 1.0
    good, poor = (float(v) * factor for v in limits)
    lu, iu = report.length_unit, report.iri_unit
    fig = _figure()
    ax = fig.add_subplot()
    values = report.iri
    top = max(float(np.nanmax(values, initial=0.0)), poor) * 1.15
    ax.axhspan(0, good, color=_GOOD, alpha=0.10, lw=0)
    ax.axhspan(good, poor, color=_FAIR, alpha=0.12, lw=0)
    ax.axhspan(poor, top, color=_POOR, alpha=0.10, lw=0)
    ax.axhline(good, color=_GOOD, lw=1, ls="--", label=f"good < {good:.3g} {iu}")
    ax.axhline(poor, color=_POOR, lw=1, ls="--", label=f"poor > {poor:.3g} {iu}")
    start, end = report.interval_start, report.interval_end
    meta = report.metadata
    if report.mode == "fixed":
        k = len(report.tracks)
        width = (end - start) / (k + 1)
        for j, t in enumerate(report.tracks):
            ax.bar(start + (j + 0.5) * width, values[:, j], width=width * 0.95, align="edge", label=f"IRI {t}",
                   alpha=0.9)
        if report.mri is not None and start.size:
            ax.step(np.append(start, end[-1:]), np.append(report.mri, report.mri[-1:]), where="post", color="0.2",
                    lw=1.2, ls=":", label="MRI")
        title = f"IRI per {meta.get('interval', 0):g} {lu} segment"
    else:
        centre = 0.5 * (start + end)
        for j, t in enumerate(report.tracks):
            xb, lo, hi = _envelope(centre, values[:, j])
            ax.plot(xb, hi, lw=0.9, label=f"IRI {t}")
        if report.mri is not None:
            xb, lo, hi = _envelope(centre, report.mri)
            ax.plot(xb, hi, lw=1.0, color="0.2", ls=":", label="MRI")
        title = (f"{report.mode.capitalize()} IRI: {meta.get('window', 0):g} {lu} window every "
                 f"{meta.get('step', 0):.4g} {lu}")
    if start.size:
        ax.set_xlim(float(start[0]), float(end[-1]))
    ax.set_ylim(0, top)
    ax.set_xlabel(f"station [{lu}]" + (" (window centre)" if report.mode != "fixed" else ""))
    ax.set_ylabel(f"IRI [{iu}]")
    ma = "moving average applied" if meta.get("moving_average_applied") else "no moving average"
    ax.set_title(f"{title} ({ma})")
    ax.legend(loc="upper right", fontsize=8, ncol=3)
    return save_figure(fig, path)  # temporary file + os.replace: an older figure survives a failure


def _profile_figure(analysis, reference_profile=None, reference_label="reference"):
    p = analysis.profile
    fig = _figure(height=3.4)
    ax = fig.add_subplot()
    for j, t in enumerate(p.tracks):
        x, lo, hi = _envelope(p.distance, p.elevation[:, j] * 1000)
        if lo is hi:
            line, = ax.plot(x, lo, lw=0.8, label=t)
        else:
            ax.fill_between(x, lo, hi, lw=0.5, alpha=0.8, label=f"{t} (min-max per bin)")
        if p.std is not None and np.isfinite(p.std[:, j]).any():
            xs, s_lo, s_hi = _envelope(p.distance, (p.elevation[:, j] - 2 * p.std[:, j]) * 1000)
            _, s_lo2, s_hi2 = _envelope(p.distance, (p.elevation[:, j] + 2 * p.std[:, j]) * 1000)
            ax.fill_between(xs, s_lo, s_hi2, alpha=0.2, lw=0, label=f"{t} ± 2σ")
    gaps = getattr(analysis.iri, "gaps", None)
    for i, (_tracks, a, b) in enumerate((gaps.gaps + gaps.dropped) if gaps is not None else ()):
        ax.axvspan(a, b, color="0.75", alpha=0.5, lw=0, label="no data (gap, run < lead-in)" if i == 0 else None)
    if reference_profile is not None:
        for j, _t in enumerate(reference_profile.tracks):
            x, lo, hi = _envelope(reference_profile.distance, reference_profile.elevation[:, j] * 1000)
            ax.plot(x, hi, color="k", lw=0.6, alpha=0.5, zorder=1, label=f"{reference_label}")
    ax.set_xlabel("station [m]")
    ax.set_ylabel("elevation [mm]")
    ax.set_title("Longitudinal profile")
    ax.legend(loc="upper right", fontsize=8, ncol=3)
    return fig


def _localized_figure(loc):
    fig = _figure(height=3.2)
    ax = fig.add_subplot()
    for j, t in enumerate(loc.tracks):
        x, lo, hi = _envelope(loc.station, loc.continuous_iri[:, j])
        ax.plot(x, hi, lw=0.9, label=f"{t}")
    ax.axhline(loc.threshold, color=_POOR, ls="--", lw=1.2, label=f"threshold {loc.threshold:g} m/km")
    for d in loc.defects:
        ax.axvspan(d.start, d.end, color=_POOR, alpha=0.15, lw=0)
    ax.set_xlabel("window centre [m]")
    ax.set_ylabel(f"IRI over {loc.window:g} m [m/km]")
    ax.set_title("Localised roughness (continuous short-interval IRI); shaded: above threshold")
    ax.set_ylim(bottom=0)
    ax.legend(loc="upper right", fontsize=8, ncol=4)
    return fig


def _psd_figure(analysis):
    from ..road import ISO8608_CLASSES, iso8608_gd

    psd = analysis.psd
    fig = _figure(height=4.2)
    ax = fig.add_subplot()
    n = psd.wavenumber[1:]
    grid = np.geomspace(0.01, max(3.0, n[-1]), 200)
    for letter, (lo, _, _hi) in ISO8608_CLASSES.items():
        if lo > 0:
            ax.loglog(grid, iso8608_gd(grid, lo), color="0.6", lw=0.8)
            ax.text(0.1, lo * 1.1, f"{chr(ord(letter) - 1)}|{letter}", fontsize=7, color="0.35", clip_on=True)
    for j, t in enumerate(psd.tracks):
        ax.loglog(n, psd.psd[1:, j], lw=1.0, label=f"{t} (Welch)")
        if analysis.iso8608 is not None:
            f = analysis.iso8608[j]
            ax.loglog(grid, iso8608_gd(grid, f.gd_n0), ls="--", lw=1.2,
                      label=f"{t}: Gd(0.1) = {f.gd_n0 * 1e6:.0f}e-6 m³, class {f.road_class}")
    ax.axvspan(0.011, 2.83, color="0.9", alpha=0.3, lw=0)
    ax.set_xlim(grid[0], grid[-1])
    positive = psd.psd[1:][psd.psd[1:] > 0]
    ymax = float(positive.max()) if positive.size else 1e-3
    ax.set_ylim(ymax * 1e-7, ymax * 30)
    ax.set_xlabel("spatial frequency n [cycle/m]")
    ax.set_ylabel("Gd(n) [m³]")
    ax.set_title("Displacement PSD with the ISO 8608 class limits (grey lines, w = 2)")
    ax.legend(loc="lower left", fontsize=8)
    return fig


def _table_html(df: pd.DataFrame, *, fmt="{:.3f}", highlight=None) -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
    rows = []
    for _, r in df.iterrows():
        cells = []
        for c in df.columns:
            v = r[c]
            style = ""
            if highlight is not None:
                style = highlight(c, v)
            if isinstance(v, (float, np.floating)) and not np.isfinite(v):
                text = "—"  # no value: e.g. a segment measured over less than min_valid (gaps="restart")
            elif isinstance(v, (float, np.floating)):
                text = f"{v:.1f}" if str(c).endswith("_m") else fmt.format(v)
            else:
                text = html.escape(str(v))
            cells.append(f"<td{style}>{text}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:24px auto;max-width:1150px;
color:#222;line-height:1.45}
h1{font-size:1.6em;margin-bottom:0}h2{border-bottom:2px solid #ddd;padding-bottom:3px;margin-top:1.6em}
.sub{color:#666;margin-top:2px}table{border-collapse:collapse;margin:8px 0;font-size:0.9em}
th,td{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#f3f3f3}
td:first-child,th:first-child{text-align:left}img{max-width:100%;border:1px solid #eee}
.cards{display:flex;gap:12px;flex-wrap:wrap}.card{border:1px solid #ddd;border-radius:6px;padding:8px 14px;
min-width:150px}.card b{font-size:1.5em;display:block}.note{background:#fff8e1;border-left:4px solid #f9a825;
padding:6px 10px;margin:8px 0}.small{font-size:0.85em;color:#555}
"""


def _condition(v, limits):
    good, poor = limits
    if not np.isfinite(v):
        return ""
    colour = _GOOD if v < good else (_POOR if v > poor else _FAIR)
    return f' style="background:{colour}22"'


#: Files the report writes into its folder (an input with one of these names there would be overwritten).
_REPORT_FILES = REPORT_FILES["road"]


def road_report_tables(analysis, *, reference=None, reference_label: str = "reference") -> dict[str, pd.DataFrame]:
    """The CSV tables of the road report, by file name: ``iri_segments.csv`` (with the reference's IRI per segment
    when it has the same segments), ``localized_roughness.csv`` and, when computed, ``psd.csv``, ``iso8608.csv``,
    ``waveband_energy.csv``.

    Parameters
    ----------
    analysis, reference : RoughnessAnalysis
        From :func:`longprofile.road.analyse_roughness` (reference optional).
    reference_label : str
        The reference's name in the column names.
    """
    iri_df = analysis.iri.to_frame()
    if reference is not None and reference.iri.iri.shape[0] == iri_df.shape[0]:
        for j, t in enumerate(reference.iri.tracks):
            key = reference_label if len(reference.iri.tracks) == 1 else f"{reference_label}_{t}"
            iri_df[f"iri_{key}_m_per_km".replace(" ", "_")] = reference.iri.iri[:, j]
    tables = {"iri_segments.csv": iri_df, "localized_roughness.csv": analysis.localized.to_frame()}
    if analysis.psd is not None:
        psd_df = pd.DataFrame({"wavenumber_cycles_per_m": analysis.psd.wavenumber})
        for j, t in enumerate(analysis.psd.tracks):
            psd_df[f"psd_{t}_m3"] = analysis.psd.psd[:, j]
        tables["psd.csv"] = psd_df
    if analysis.iso8608 is not None:
        tables["iso8608.csv"] = pd.DataFrame({
            "track": analysis.psd.tracks,  # the tracks with a PSD (a dead track, --gaps restart, has none)
            "gd_n0_w2_m3": [f.gd_n0 for f in analysis.iso8608],
            "class_w2": [f.road_class for f in analysis.iso8608],
            "gd_n0_free_m3": [f.gd_n0_free for f in analysis.iso8608],
            "waviness_free": [f.waviness for f in analysis.iso8608],
            "class_free": [f.road_class_free for f in analysis.iso8608],
        })
    if analysis.waveband is not None:
        tables["waveband_energy.csv"] = analysis.waveband.to_frame()
    return tables


def road_report_figures(analysis, *, reference=None, reference_label: str = "reference",
                        limits=IRI_CONDITION_LIMITS) -> dict:
    """The figures of the road report, by PNG file name: ``profile.png``, ``iri.png``,
    ``localized_roughness.png`` and, when computed, ``psd.png`` (matplotlib Figure objects)."""
    return {fname: build(analysis, reference, reference_label, limits)
            for fname, build in _report_figures(analysis).items()}


def _report_profile(analysis, reference, reference_label, limits):
    return _profile_figure(analysis, None if reference is None else reference.profile, reference_label)


def _report_iri(analysis, reference, reference_label, limits):
    fig = _figure()
    _iri_axes(fig.add_subplot(), analysis.iri, limits, None if reference is None else reference.iri, reference_label)
    return fig


def _report_localized(analysis, reference, reference_label, limits):
    return _localized_figure(analysis.localized)


def _report_psd(analysis, reference, reference_label, limits):
    return _psd_figure(analysis)


def _report_figures(analysis) -> dict:
    """:func:`road_report_figures`' figures by PNG file name: the function drawing each (``function(analysis,
    reference, reference_label, limits)`` -> Figure)."""
    figs = {"profile.png": _report_profile, "iri.png": _report_iri, "localized_roughness.png": _report_localized}
    if analysis.psd is not None:
        figs["psd.png"] = _report_psd
    return figs


def _iri_text(v) -> str:
    """A section IRI for a card: "—" for none (a track without a measured run, --gaps restart)."""
    return f"{v:.2f} m/km" if np.isfinite(v) else "— (no IRI)"


def _summary_cards(analysis, reference, reference_label, limits) -> list[str]:
    """The summary cards of the page: section IRI (and MRI/HRI), the reference, ISO 8608 classes, defects."""
    res, p = analysis.iri, analysis.profile
    cards = []
    for j, t in enumerate(res.tracks):
        v = float(res.section_iri[j])
        cards.append(f'<div class="card"{_condition(v, limits)}>IRI {html.escape(t)}<b>{_iri_text(v)}</b>'
                     f'<span class="small">{res.section_start:.1f}–{res.section_end:.1f} m</span></div>')
    if res.section_mri is not None:
        cards.append(f'<div class="card"{_condition(res.section_mri, limits)}>MRI<b>{_iri_text(res.section_mri)}</b>'
                     f'<span class="small">HRI {_iri_text(res.section_hri)}</span></div>')
    if reference is not None:
        for j, t in enumerate(reference.iri.tracks):
            v = float(reference.iri.section_iri[j])
            cards.append(f'<div class="card">IRI {html.escape(reference_label)}<b>{v:.2f} m/km</b>'
                         f'<span class="small">{html.escape(t)}</span></div>')
    if analysis.iso8608 is not None:
        for j, f in enumerate(analysis.iso8608):
            cards.append(f'<div class="card">ISO 8608 {html.escape(analysis.psd.tracks[j])}<b>class {f.road_class}</b>'
                         f'<span class="small">Gd(0.1) = {f.gd_n0 * 1e6:.0f}·10⁻⁶ m³ (w = 2)</span></div>')
    loc = analysis.localized
    n_def = len(loc.defects)
    above = sum(d.end - d.start for d in loc.defects) / max(len(loc.tracks), 1)
    span = float(p.distance[-1] - p.distance[0])
    share = f"; {above:.0f} m = {100 * above / span:.0f} % of the length" if n_def and span > 0 else ""
    cards.append(f'<div class="card">Localised roughness<b>{n_def} location{"s" if n_def != 1 else ""}</b>'
                 f'<span class="small">{loc.window:g} m IRI &gt; {loc.threshold:g} m/km{share}</span></div>')
    return cards


def _section_html(analysis, tables, images, limits) -> dict[str, str]:
    """The HTML pieces of the page built from the tables: segment, defect, ISO 8608, waveband and PSD sections."""
    loc = analysis.localized
    highlight = (lambda c, v: _condition(float(v), limits) if "iri" in str(c) or str(c).startswith(("mri", "hri"))
                 else "")
    iri_df = tables["iri_segments.csv"]
    seg_table = (_table_html(iri_df, fmt="{:.2f}", highlight=highlight) if len(iri_df)
                 else "<p>No complete segment.</p>")
    def_df = loc.to_frame()
    def_table = (_table_html(def_df, fmt="{:.1f}") if len(def_df)
                 else f"<p>No location above {loc.threshold:g} m/km.</p>")
    iso_table = _table_html(tables["iso8608.csv"], fmt="{:.4g}") if "iso8608.csv" in tables else ""
    wave_html = ""
    if analysis.waveband is not None:
        wdf = analysis.waveband.to_frame()
        wave_html = ("<h2>Waveband energies</h2><p>Mean square of the profile band-passed in each wavelength band, "
                     + (f"per {analysis.waveband.segment_end[0] - analysis.waveband.segment_start[0]:g} m segment, "
                        if len(analysis.waveband.segment_start) else "per segment, ")
                     + f"in mm². Bands: {', '.join(analysis.waveband.bands)}.</p>"
                     + (_table_html(wdf, fmt="{:.3g}") if len(wdf) else "<p>No complete segment.</p>"))
    psd_html = ""
    if analysis.psd is not None:
        psd_html = (f"<h2>Spectrum and ISO 8608 class</h2>{img_tag(images, 'psd.png', 'PSD')}"
                    f"<p class='small'>Welch estimate, {analysis.psd.segment_length:g} m Hann segments, 50 % overlap, "
                    "linear detrend. Gd(n0) at n0 = 0.1 cycle/m fitted over 0.011–2.83 cycle/m with w = 2 (the "
                    "ISO 8608 classification) and with a free waviness w.</p>" + iso_table)
    return dict(seg_table=seg_table, def_table=def_table, wave_html=wave_html, psd_html=psd_html)


def write_road_report(analysis, outdir, *, reference=None, reference_label: str = "reference",
                      limits=IRI_CONDITION_LIMITS, title: str | None = None, inputs=(),
                      overwrite: bool = True) -> list[Path]:
    """Write ``index.html`` (figures embedded), the PNG figures and the CSV tables into ``outdir``.

    Parameters
    ----------
    analysis : RoughnessAnalysis
        From :func:`longprofile.road.analyse_roughness`.
    outdir : path-like
        Output folder (created).
    reference : RoughnessAnalysis, optional
        A second analysis shown beside (e.g. the true profile of a simulation).
    reference_label : str
        Its name in the tables and legends.
    limits : (float, float)
        IRI condition limits (good below, poor above), m/km. Default FHWA 1.50 / 2.68 m/km.
    title : str, optional
        Page title (default from the profile name).
    inputs : sequence of path-like
        Input files, to refuse writing over them.
    overwrite : bool, default True
        False refuses an existing, non-empty ``outdir`` (:class:`~longprofile.errors.OutputError`).

    Returns
    -------
    list of Path
        Files written.

    Notes
    -----
    The page is ``report/templates/road_report.html`` (Jinja2) filled from :func:`road_report_tables` and
    :func:`road_report_figures`.
    """
    out = Path(outdir)
    report_folder(out, inputs, writes=_REPORT_FILES, overwrite=overwrite)
    written: list[Path] = []
    res, p, loc = analysis.iri, analysis.profile, analysis.localized
    name = title or f"Road roughness report — {analysis.profile.name or 'profile'}"
    # drawn by the command's figure helper while the tables are written, when one runs (report/_render.py)
    figures = current_renderer().submit(figure_pngs, _report_figures(analysis), analysis, reference, reference_label,
                                        limits)
    tables = road_report_tables(analysis, reference=reference, reference_label=reference_label)
    for fname, df in tables.items():
        written.append(write_csv(df, out / fname))
    paths, images = write_pngs(figures.result(), out)
    written.extend(paths)
    spacing = p.spacing
    meta = (f"{p.n_samples} samples, stations {p.distance[0]:.2f}–{p.distance[-1]:.2f} m, "
            + (f"constant step {spacing * 1000:.1f} mm" if spacing is not None else "irregular stations")
            + f"; tracks: {', '.join(p.tracks)}.")
    ma = "applied" if res.moving_average else "not needed at this spacing"
    if getattr(res, "moving_average_reason", ""):
        ma = f"{'applied' if res.moving_average else 'not applied'} ({html.escape(res.moving_average_reason)})"
    page = render(
        "road_report.html", name=html.escape(name), css=_CSS, meta=html.escape(meta),
        cards=_summary_cards(analysis, reference, reference_label, limits),
        notes="".join(f'<div class="note">{html.escape(n)}</div>' for n in analysis.notes),
        img={f: img_tag(images, f, alt) for f, alt in (("profile.png", "profile"), ("iri.png", "IRI per segment"),
                                                       ("localized_roughness.png", "continuous IRI"))},
        good=f"{limits[0]:.2f}", poor=f"{limits[1]:.2f}", lead_in=f"{res.lead_in:g}", moving_average=ma,
        window=f"{loc.window:g}", threshold=f"{loc.threshold:g}",
        files=[html.escape(f) for f in list(tables) + list(images)],
        **_section_html(analysis, tables, images, limits))
    written.insert(0, write_text(out / "index.html", page))
    return written
