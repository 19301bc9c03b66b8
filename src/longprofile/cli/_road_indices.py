"""``longprofile road iri`` and ``longprofile road report``: roughness indices of a profile file."""

from __future__ import annotations

import sys
from pathlib import Path

import typer
from rich.markup import escape

from ._common import (
    OVERWRITE,
    TABLE_SUFFIXES,
    check_output_folder,
    check_output_path,
    check_plot_path,
    console,
    progress,
)
from ._road_tracks import file_tracks

#: ``--gaps`` and ``--min-valid`` of ``road iri``, ``road report`` and ``batch iri`` (one meaning everywhere).
GAPS = typer.Option("refuse", "--gaps", help="Missing (NaN) elevations or station steps over 1 m: refuse (default) or "
                    "restart (the IRI over the measured parts, the quarter car restarted after each gap, each run of "
                    "data as its own file; docs/road-indices.md, 'Profiles with gaps').")
MIN_VALID = typer.Option(0.8, "--min-valid", help="With --gaps restart: the smallest measured fraction of a segment "
                         "or window for its IRI to be given (default 0.8); below it the IRI is empty, with the "
                         "reason in the note column.")

_FILE_HELP = ("Profile file: CSV/Parquet with a distance_m column and one column per track named with its unit "
              "(left_mm, right_m, ...), or an ERD file.")


def _check_plausible(result, profile) -> None:
    """Warn when a track holds one elevation over metres (a dropout written as a value), the IRI is out of any road's
    range (an elevation unit mistake is the usual cause) or the stations are coarse enough to bias it
    (:func:`longprofile.road.iri_notes`, the sentences ``batch iri`` writes to its manifest)."""
    from ..road import iri_notes

    for note in iri_notes(result, profile):
        console.print(f"[yellow]warning:[/yellow] {escape(note)}", highlight=False, soft_wrap=True)


def _print_section_iri(result, iri_unit: str, what: str) -> None:
    """The one-line summary of ``road iri`` and ``road report``: the section IRI of each track, with the MRI and HRI
    of two tracks (in/mi to the unit, m/km to 0.01, as agencies print them), then ``what`` was computed."""
    prec = 0 if iri_unit == "in/mi" else 2

    def num(v):  # a track without IRI (--gaps restart, a dead track): no number
        return f"{v:.{prec}f}" if v == v else "none"

    summary = ", ".join(f"{t} {num(v)}" for t, v in zip(result.tracks, result.section_iri))
    if result.section_mri is not None:
        summary += f"; MRI {num(result.section_mri)}, HRI {num(result.section_hri)}"
    console.print(f"section IRI ({iri_unit}): {summary} ({what})", markup=False, soft_wrap=True)


def _warn_gaps(note: str) -> None:
    """The one warning of a profile analysed with --gaps restart (its gaps, the segments affected and without IRI)."""
    if note:
        console.print(f"[yellow]warning:[/yellow] {escape(note)}", highlight=False, soft_wrap=True)


#: Length units the deprecated ``--units`` still accepts as the elevation unit (before ``--units si|us``).
_ELEVATION_UNITS = ("m", "mm", "cm", "km", "in", "ft", "mi")


def _split_units(units: str | None, elevation_unit: str | None, *, report_units: bool = True):
    """(report units "si"/"us", elevation unit) from ``--units`` and ``--elevation-unit``.

    ``--units si|us`` chooses the report units; a length unit there is the old meaning (elevation unit of
    columns without one), still accepted with a one-line deprecation note.
    """
    from ..errors import UnitsError

    if units is None:
        return "si", elevation_unit
    key = units.strip().lower()
    if key in ("si", "us"):
        if not report_units and key == "us":
            raise UnitsError("`road report` is written in SI units only; --units us is not available here (use "
                             "`longprofile road iri FILE --units us` for a US-units IRI table).")
        return key, elevation_unit
    if key in _ELEVATION_UNITS:
        if elevation_unit is not None and elevation_unit.strip().lower() != key:
            raise UnitsError(f"--units {units} (deprecated elevation unit) contradicts --elevation-unit "
                             f"{elevation_unit}; give only --elevation-unit.")
        console.print(f"note: --units {units} as the elevation unit is deprecated; use --elevation-unit {units} "
                      "(--units now takes si|us, the report units).", markup=False)
        return "si", key
    raise UnitsError(f"--units must be si or us (report units); got {units!r}. The elevation unit of columns "
                     "without one is --elevation-unit (m, mm, cm, in, ft).")


def iri_command(
    file: Path = typer.Argument(..., help=_FILE_HELP),
    output: str = typer.Option("-", "--output", "-o", help="IRI table (.csv or .parquet) with the metadata in its "
                               "header; '-' = CSV on stdout."),
    mode: str = typer.Option("fixed", "--mode", help="fixed (consecutive segments), continuous (sliding window) or "
                             "overlapping (windows every --step < --window)."),
    segment: float = typer.Option(None, "--segment", help="Fixed segment length in the report's length unit "
                                  "(default 100 m, or 528 ft = 0.1 mi with --units us)."),
    window: float = typer.Option(None, "--window", help="Window length, continuous/overlapping (default: continuous "
                                 "25 ft = 7.62 m; overlapping the segment length)."),
    step: float = typer.Option(None, "--step", help="Distance between window starts (default: continuous one "
                               "sample; overlapping half the window)."),
    start: float = typer.Option(None, "--start", help="Station of the first interval, report length unit "
                                "(default: the first station)."),
    units: str = typer.Option(None, "--units", help="Report units: si (m, m/km; default) or us (ft, in/mi)."),
    elevation_unit: str = typer.Option(None, "--elevation-unit", help="Elevation unit of columns without one "
                                       "(m, mm, cm, in, ft)."),
    moving_average: str = typer.Option("auto", "--moving-average", help="250 mm moving average: auto (ASTM E1926 "
                                       "rule), on or off."),
    track: str = typer.Option(None, "--track", help="Comma-separated tracks (default: all), e.g. left,right."),
    lead_in: float = typer.Option(11.0, "--lead-in", help="Initialisation length, m (ASTM E1926: 11)."),
    plot: Path = typer.Option(None, "--plot", help="Also draw the report (segments or IRI along the road)."),
    gaps: str = GAPS,
    min_valid: float = MIN_VALID,
    overwrite: bool = OVERWRITE,
):
    """IRI per fixed segment, continuous or overlapping window (ASTM E1926), SI or US units, MRI/HRI."""
    from ..io import read_profile, write_report_table
    from ..road import iri_report

    out = None if output == "-" else check_output_path(Path(output), file, suffixes=TABLE_SUFFIXES,
                                                        overwrite=overwrite)
    png = check_plot_path(plot, file, out, overwrite=overwrite)
    report_units, elevation = _split_units(units, elevation_unit)
    interval = segment if segment is not None else (528.0 if report_units == "us" else 100.0)
    profile = read_profile(file, units=elevation, tracks=file_tracks(track, file))
    rep = iri_report(profile, mode=mode, interval=interval, window=window, step=step, start=start,
                     units=report_units, lead_in=lead_in, moving_average=moving_average, gaps=gaps,
                     min_valid=min_valid)
    _check_plausible(rep, profile)
    _warn_gaps(rep.metadata.get("gap_note", ""))
    table = rep.to_frame()
    write_report_table(table, sys.stdout if out is None else out, rep.metadata)
    if png is not None:
        from ..report import draw, plot_iri_report  # matplotlib only when drawing (in the figure helper if one runs)

        draw(plot_iri_report, rep, png)
    meta, lu = rep.metadata, rep.length_unit
    what = (f"{len(table)} segment(s) of {meta['interval']:g} {lu}" if rep.mode == "fixed" else
            f"{len(table)} {rep.mode} window(s) of {meta['window']:g} {lu} every {meta['step']:.4g} {lu}")
    _print_section_iri(rep, rep.iri_unit, f"{what} from {meta['start']:g} {lu}")
    console.print(f"moving average: {'applied' if meta['moving_average_applied'] else 'not applied'} "
                  f"({meta['moving_average_reason']})", markup=False, soft_wrap=True)
    if len(table) == 0:
        span = meta["last_station"] - meta["start"]
        console.print(f"note: the profile from {meta['start']:g} {lu} ({span:g} {lu}) is shorter than one "
                      f"{meta['interval']:g} {lu} segment: only the section IRI is given; use a shorter --segment.",
                      markup=False)


def report_command(
    file: Path = typer.Argument(..., help=_FILE_HELP),
    output: Path = typer.Option(..., "--output", "-o", help="Report folder (index.html, PNG figures, CSV tables)."),
    segment: float = typer.Option(100.0, "--segment", help="IRI segment length, m."),
    track: str = typer.Option(None, "--track", help="Comma-separated tracks (default: all)."),
    units: str = typer.Option(None, "--units", help="Deprecated alias of --elevation-unit (the report is in SI)."),
    elevation_unit: str = typer.Option(None, "--elevation-unit", help="Elevation unit of columns without one "
                                       "(m, mm, cm, in, ft)."),
    window: float = typer.Option(25.0, "--window", help="Localised roughness window, m."),
    threshold: float = typer.Option(2.7, "--threshold", help="Localised roughness threshold, m/km."),
    plot: Path = typer.Option(None, "--plot", help="Also draw the IRI per segment to this PNG."),
    gaps: str = GAPS,
    min_valid: float = MIN_VALID,
    overwrite: bool = OVERWRITE,
):
    """HTML roughness report: profile, IRI per segment, localised roughness, PSD with ISO 8608 class, tables."""
    from ..io import read_profile
    from ..report import REPORT_FILES, draw, plot_iri, write_road_report
    from ..road import analyse_roughness

    check_output_folder(output, file, overwrite=overwrite, writes=REPORT_FILES["road"], others={"--plot": plot},
                        hint=f"the report needs a folder, e.g. -o {Path(output).with_suffix('')}_report/.")
    png = check_plot_path(plot, file, overwrite=overwrite)
    _, elevation = _split_units(units, elevation_unit, report_units=False)
    with progress() as bar:
        task = bar.add_task("road report", total=3)
        profile = read_profile(file, units=elevation, tracks=file_tracks(track, file))
        bar.advance(task)
        analysis = analyse_roughness(profile, segment_length=segment, window=window, threshold=threshold, gaps=gaps,
                                     min_valid=min_valid)
        bar.advance(task)
        _check_plausible(analysis.iri, profile)
        if analysis.iri.gaps is not None:
            _warn_gaps(analysis.iri.gaps.message())
        files = write_road_report(analysis, output, inputs=(file,), overwrite=overwrite)
        if plot is not None:
            files.append(draw(plot_iri, analysis.iri, png))
        bar.advance(task)
    res = analysis.iri
    start = res.segment_start[0] if len(res.segment_start) else res.section_start
    _print_section_iri(res, "m/km", f"{len(res.segment_start)} segment(s) of {res.segment_length:g} m from "
                                    f"{start:g} m")
    console.print(f"report: {files[0]} ({len(files)} files)", markup=False)


def register(app: typer.Typer) -> None:
    """Attach ``iri`` and ``report`` to the ``road`` group."""
    app.command("iri")(iri_command)
    app.command("report")(report_command)
