"""``longprofile road iri`` and ``longprofile road report``: roughness indices of a profile file."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from ._common import check_output_path, check_plot_path, console, progress

_FILE_HELP = ("Profile file: CSV/Parquet with a distance_m column and one column per track named with its unit "
              "(left_mm, right_m, ...), or an ERD file.")


#: Columns of ``longprofile road reconstruct`` output: one profile (``elevation``) plus diagnostics.
_RECONSTRUCT_COLUMNS = ("distance_m", "elevation_m", "std_m", "raw_m", "raw_std_m")


def _tracks(track: str | None, file: Path | None = None):
    if track is None:
        if file is not None and _is_reconstruct_output(file):
            console.print(f"note: {file} is a `road reconstruct` output: analysing its profile track 'elevation' "
                          "(std_m and the undetrended raw_m are not tracks; pass --track to choose).", markup=False)
            return ["elevation"]
        return None
    names = [t.strip() for t in track.split(",") if t.strip()]
    return names or None


def _is_reconstruct_output(file: Path) -> bool:
    """True when the header is exactly the column set written by ``road reconstruct``."""
    import pandas as pd

    try:
        if Path(file).suffix.lower() in (".parquet", ".pq"):
            import pyarrow.parquet as pq

            names = pq.read_schema(file).names
        else:
            names = list(pd.read_csv(file, comment="#", nrows=0).columns)
    except Exception:  # unreadable: read_profile reports it properly
        return False
    return [c for c in names if not str(c).startswith("__")] == list(_RECONSTRUCT_COLUMNS)


def _check_plausible(result) -> None:
    """Warn when the IRI is out of any road's range (an elevation column in mm labelled m is the usual cause)."""
    import numpy as np

    worst = float(np.nanmax(result.section_iri)) if np.size(result.section_iri) else 0.0
    if worst > 50.0:
        console.print(f"[yellow]warning:[/yellow] section IRI {worst:.3g} m/km is beyond any road (unpaved roads "
                      "are below about 25 m/km): check the elevation unit in the column names (e.g. left_mm).")


def iri_command(
    file: Path = typer.Argument(..., help=_FILE_HELP),
    output: str = typer.Option("-", "--output", "-o", help="IRI table (.csv or .parquet); '-' = CSV on stdout."),
    segment: float = typer.Option(100.0, "--segment", help="Segment length, m."),
    track: str = typer.Option(None, "--track", help="Comma-separated tracks (default: all), e.g. left,right."),
    units: str = typer.Option(None, "--units", help="Elevation unit for columns without one (m, mm, in, ft)."),
    lead_in: float = typer.Option(11.0, "--lead-in", help="Initialisation length, m (ASTM E1926: 11)."),
    plot: Path = typer.Option(None, "--plot", help="Also draw the IRI per segment to this PNG."),
):
    """IRI per segment (ASTM E1926), with MRI and HRI for two tracks."""
    from ..io import read_profile, write_table
    from ..report import plot_iri
    from ..road import iri

    out = None if output == "-" else check_output_path(Path(output), file)
    png = check_plot_path(plot, file, out)
    profile = read_profile(file, units=units, tracks=_tracks(track, file))
    result = iri(profile, segment_length=segment, lead_in=lead_in)
    _check_plausible(result)
    table = result.to_frame()
    if output == "-":
        table.to_csv(sys.stdout, index=False)
    else:
        write_table(table, out)
    if plot is not None:
        plot_iri(result, png)
    summary = ", ".join(f"{t} {v:.2f}" for t, v in zip(result.tracks, result.section_iri))
    extra = "" if result.section_mri is None else f"; MRI {result.section_mri:.2f}, HRI {result.section_hri:.2f}"
    console.print(f"section IRI (m/km): {summary}{extra} ({len(table)} segment(s) of {segment:g} m)", markup=False)
    if len(table) == 0:
        console.print(f"note: the profile ({profile.distance[-1] - profile.distance[0]:g} m) is shorter than one "
                      f"{segment:g} m segment: only the section IRI is given; use a shorter --segment.", markup=False)


def report_command(
    file: Path = typer.Argument(..., help=_FILE_HELP),
    output: Path = typer.Option(..., "--output", "-o", help="Report folder (index.html, PNG figures, CSV tables)."),
    segment: float = typer.Option(100.0, "--segment", help="IRI segment length, m."),
    track: str = typer.Option(None, "--track", help="Comma-separated tracks (default: all)."),
    units: str = typer.Option(None, "--units", help="Elevation unit for columns without one (m, mm, in, ft)."),
    window: float = typer.Option(25.0, "--window", help="Localised roughness window, m."),
    threshold: float = typer.Option(2.7, "--threshold", help="Localised roughness threshold, m/km."),
    plot: Path = typer.Option(None, "--plot", help="Also draw the IRI per segment to this PNG."),
):
    """HTML roughness report: profile, IRI per segment, localised roughness, PSD with ISO 8608 class, tables."""
    from ..io import read_profile
    from ..report import plot_iri, write_road_report
    from ..road import analyse_roughness

    png = check_plot_path(plot, file)
    with progress() as bar:
        task = bar.add_task("road report", total=3)
        profile = read_profile(file, units=units, tracks=_tracks(track, file))
        bar.advance(task)
        analysis = analyse_roughness(profile, segment_length=segment, window=window, threshold=threshold)
        bar.advance(task)
        files = write_road_report(analysis, output, inputs=(file,))
        if plot is not None:
            files.append(plot_iri(analysis.iri, png))
        bar.advance(task)
    console.print(f"report: {files[0]} ({len(files)} files)", markup=False)


def register(app: typer.Typer) -> None:
    """Attach ``iri`` and ``report`` to the ``road`` group."""
    app.command("iri")(iri_command)
    app.command("report")(report_command)
