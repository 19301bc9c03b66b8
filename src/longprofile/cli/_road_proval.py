"""``longprofile road ride-number``, ``road straightedge``, ``road profile-index``, ``road faulting``: ProVAL's other
analyses of a profile file (read -> one ``longprofile.road`` call -> write), next to ``road iri``."""

from __future__ import annotations

import sys
from pathlib import Path

import typer
from rich.markup import escape

from ._common import (
    OVERWRITE,
    TABLE_SUFFIXES,
    check_distinct_outputs,
    check_output_path,
    check_plot_path,
    console,
)
from ._road_indices import _FILE_HELP, _split_units
from ._road_tracks import file_tracks

_PROFILE = typer.Argument(..., help=_FILE_HELP + " A missing (NaN) elevation or a station step over 1 m is refused: "
                          "cut the profile there (only `road iri` computes over gaps).")
_OUTPUT = "'-' = CSV on stdout (default); .csv or .parquet, the metadata in its header."
_UNITS = typer.Option(None, "--units", help="Report units: si (m, mm; default) or us (ft, in); every length option "
                      "is in them.")
_ELEVATION = typer.Option(None, "--elevation-unit", help="Elevation unit of columns without one (m, mm, cm, in, ft).")
_TRACK = typer.Option(None, "--track", help="Comma-separated tracks (default: all), e.g. left,right.")
_PLOT = typer.Option(None, "--plot", help="Also draw the result to this figure (PNG, PDF, SVG).")
_LENGTH = typer.Option(None, "--length", help="Straightedge length in the report's length unit (default 3 m; 10 ft "
                       "with --units us).")
_THRESHOLD = typer.Option(None, "--threshold", help="Deviation limit, mm or in (default 3 mm; 1/8 in = 0.125 with "
                          "--units us).")
_TRACE = typer.Option(None, "--trace", help="Also write the deviation at every station (.csv/.parquet).")
_WINDOW = typer.Option(0.3, "--window", help="Profile fitted on each side of a joint, m in both unit systems "
                       "(default 0.3).")
_GAP = typer.Option(0.05, "--gap", help="Profile skipped on each side of a joint, m in both unit systems (default "
                    "0.05).")


def _run(function: str, args: dict, detail: str | None = None) -> None:
    """Check every output before any work, read the profile, make the one library call
    ``longprofile.road.<function>(profile, units=..., **options)`` (an :class:`~longprofile.road.IndexReport`; the
    command's own options in ``args`` are named as the function's keywords), write its tables and figure, print its
    warnings and summary. ``detail``: the option (``trace``, ``bumps``) naming the file of the second table."""
    from .. import road
    from ..io import read_profile, write_report_table

    args = dict(args)
    file, output, plot, overwrite = (args.pop(k) for k in ("file", "output", "plot", "overwrite"))
    units, elevation_unit, track = (args.pop(k) for k in ("units", "elevation_unit", "track"))
    second, option = (args.pop(detail), f"--{detail}") if detail else (None, "")
    out = None if output == "-" else check_output_path(Path(output), file, suffixes=TABLE_SUFFIXES,
                                                        overwrite=overwrite)
    det = None if second is None else check_output_path(second, file, suffixes=TABLE_SUFFIXES, overwrite=overwrite,
                                                         what=option)
    png = check_plot_path(plot, file, overwrite=overwrite)
    check_distinct_outputs({"-o": out, option: det, "--plot": png})
    report_units, elevation = _split_units(units, elevation_unit)
    profile = read_profile(file, units=elevation, tracks=file_tracks(track, file))
    rep = getattr(road, function)(profile, units=report_units, **args)
    for note in rep.notes:
        console.print(f"[yellow]warning:[/yellow] {escape(note)}", highlight=False, soft_wrap=True)
    write_report_table(rep.to_frame(), sys.stdout if out is None else out, rep.metadata)
    if det is not None:
        write_report_table(rep.detail_frame(), det, rep.metadata)
    if png is not None:
        from ..report import draw, plot_index_report  # matplotlib only when drawing

        draw(plot_index_report, rep, png)
    for line in rep.summary:
        console.print(line, markup=False, soft_wrap=True)


def ride_number_command(
    file: Path = _PROFILE,
    output: str = typer.Option("-", "--output", "-o", help=f"Ride Number per segment: {_OUTPUT}"),
    segment: float = typer.Option(None, "--segment", help="Segment length in the report's length unit (default 100 "
                                  "m; 528 ft = 0.1 mi with --units us)."),
    units: str = _UNITS,
    elevation_unit: str = _ELEVATION,
    track: str = _TRACK,
    lead_in: float = typer.Option(11.0, "--lead-in", help="Quarter-car initialisation length, m (as the IRI: 11)."),
    moving_average: str = typer.Option("auto", "--moving-average", help="250 mm moving average: auto (the IRI's "
                                       "ASTM E1926 rule), on or off."),
    plot: Path = _PLOT,
    overwrite: bool = OVERWRITE,
):
    """Ride Number (ASTM E1489) of the section and per segment, 0 (impassable) to 5 (perfect).

    Defaults (ASSUMPTIONS, docs/road-indices.md): the quarter car and RN = 5 exp(-160 PI) as recalled from ASTM
    E1489 / ProVAL; 100 m (0.1 mi) segments; the tracks' PI combined by RMS.
    """
    _run("ride_number_report", locals())


def straightedge_command(
    file: Path = _PROFILE,
    output: str = typer.Option("-", "--output", "-o", help=f"Defects (|deviation| over the threshold): {_OUTPUT}"),
    length: float = _LENGTH, threshold: float = _THRESHOLD, trace: Path = _TRACE,
    units: str = _UNITS, elevation_unit: str = _ELEVATION, track: str = _TRACK,
    plot: Path = _PLOT, overwrite: bool = OVERWRITE,
):
    """Rolling straightedge: deviation of the profile from the chord of a straightedge, and the defects over a limit.

    Deviation = elevation under the mid-length wheel minus the chord between the two end supports (positive = bump),
    at every station whose supports lie on the profile. Defaults (ASSUMPTIONS, docs/road-indices.md): 3 m with 3 mm
    (SI), 10 ft with 1/8 in (US); point supports.
    """
    _run("straightedge_report", locals(), detail="trace")


def profile_index_command(
    file: Path = _PROFILE,
    output: str = typer.Option("-", "--output", "-o", help=f"Profile Index per segment: {_OUTPUT}"),
    segment: float = typer.Option(None, "--segment", help="Segment length in the report's length unit (default 100 "
                                  "m = 0.1 km; 528 ft = 0.1 mi with --units us)."),
    blanking_band: float = typer.Option(None, "--blanking-band", help="Blanking band width, mm or in (default 5 mm; "
                                        "0.2 in with --units us); 0 for the zero-blanking-band PI."),
    bumps: Path = typer.Option(None, "--bumps", help="Also write the bumps over the 0.3 in / 25 ft template "
                               "(.csv/.parquet)."),
    units: str = _UNITS, elevation_unit: str = _ELEVATION, track: str = _TRACK,
    plot: Path = _PLOT, overwrite: bool = OVERWRITE,
):
    """California profilograph Profile Index (CT 526 practice) per segment, mm/km or in/mi, and the bumps.

    The 25 ft profilograph is simulated on the profile; the scallops outside the blanking band are summed per
    segment. Defaults (ASSUMPTIONS, docs/road-indices.md): 0.2 in (5 mm) band, 0.1 mi (0.1 km) segments, the wheel
    layout, the 0.03 in x 2 ft smallest scallop, the 2 ft pre-filter and the 0.3 in / 25 ft bump template.
    """
    _run("profile_index_report", locals(), detail="bumps")


def faulting_command(
    file: Path = _PROFILE,
    output: str = typer.Option("-", "--output", "-o", help=f"Fault at each joint found: {_OUTPUT}"),
    window: float = _WINDOW, gap: float = _GAP,
    min_fault: float = typer.Option(None, "--min-fault", help="Smallest |fault| of a joint found, mm or in (default "
                                    "1 mm; 0.04 in with --units us)."),
    min_joint_spacing: float = typer.Option(None, "--min-joint-spacing", help="Smallest distance between two "
                                            "joints, report length unit (default 3 m; 10 ft with --units us)."),
    units: str = _UNITS, elevation_unit: str = _ELEVATION, track: str = _TRACK,
    plot: Path = _PLOT, overwrite: bool = OVERWRITE,
):
    """Joint faulting (AASHTO R 36 practice): the step at each transverse joint, found in the profile.

    The joints (and so their spacing) are detected: peaks of the least-squares step across every station, at least
    --min-joint-spacing apart; fault = approach minus leave elevation (positive: the slab after the joint is lower).
    Defaults (ASSUMPTIONS, docs/road-indices.md): 0.3 m windows, 0.05 m gap, 1 mm smallest fault, 3 m spacing.
    """
    _run("faulting_report", locals())


def register(app: typer.Typer) -> None:
    """Attach ``ride-number``, ``straightedge``, ``profile-index`` and ``faulting`` to the ``road`` group."""
    app.command("ride-number")(ride_number_command)
    app.command("straightedge")(straightedge_command)
    app.command("profile-index")(profile_index_command)
    app.command("faulting")(faulting_command)
