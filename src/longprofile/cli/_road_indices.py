"""``longprofile road iri`` and ``longprofile road report``: roughness indices of a profile file."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from ._common import check_output_path, console, progress

_FILE_HELP = ("Profile file: CSV/Parquet with a distance_m column and one column per track named with its unit "
              "(left_mm, right_m, ...), or an ERD file.")


def _tracks(track: str | None):
    if track is None:
        return None
    names = [t.strip() for t in track.split(",") if t.strip()]
    return names or None


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

    profile = read_profile(file, units=units, tracks=_tracks(track))
    result = iri(profile, segment_length=segment, lead_in=lead_in)
    table = result.to_frame()
    if output == "-":
        table.to_csv(sys.stdout, index=False)
    else:
        write_table(table, check_output_path(Path(output), file))
    if plot is not None:
        plot_iri(result, check_output_path(plot, file))
    summary = ", ".join(f"{t} {v:.2f}" for t, v in zip(result.tracks, result.section_iri))
    extra = "" if result.section_mri is None else f"; MRI {result.section_mri:.2f}, HRI {result.section_hri:.2f}"
    console.print(f"section IRI (m/km): {summary}{extra} ({len(table)} segment(s) of {segment:g} m)", markup=False)


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

    with progress() as bar:
        task = bar.add_task("road report", total=3)
        profile = read_profile(file, units=units, tracks=_tracks(track))
        bar.advance(task)
        analysis = analyse_roughness(profile, segment_length=segment, window=window, threshold=threshold)
        bar.advance(task)
        files = write_road_report(analysis, output, inputs=(file,))
        if plot is not None:
            files.append(plot_iri(analysis.iri, check_output_path(plot, file)))
        bar.advance(task)
    console.print(f"report: {files[0]} ({len(files)} files)", markup=False)


def register(app: typer.Typer) -> None:
    """Attach ``iri`` and ``report`` to the ``road`` group."""
    app.command("iri")(iri_command)
    app.command("report")(report_command)
