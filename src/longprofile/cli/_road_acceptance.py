"""``longprofile road acceptance``: smoothness acceptance report (lots, localized roughness, grinding)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.markup import escape

from ..errors import OutputError
from ._common import OVERWRITE, check_output_folder, console
from ._road_tracks import file_tracks

#: Suffixes of a file, not a folder: ``-o report.html`` is refused (it made a folder named report.html).
FILE_SUFFIXES = (".html", ".htm", ".csv", ".json", ".pdf", ".png", ".svg", ".txt", ".parquet", ".zip", ".xlsx")

_FILE_HELP = "Profile file (CSV/Parquet with distance_m and <track>_<unit> columns, or ERD)."


def acceptance_command(
    file: Path = typer.Argument(..., help=_FILE_HELP),
    spec: Path = typer.Option(None, "--spec", help="Spec file (TOML): units and the tables lot, localized, exclusions, "
                              "pay, grinding (docs/road-acceptance.md); unknown keys are errors. Default: SI defaults."),
    output: Path = typer.Option(..., "--output", "-o", help="Report folder (index.html, PNG, CSV, summary.json, "
                                "ground profile)."),
    track: str = typer.Option(None, "--track", help="Comma-separated tracks (default: all)."),
    elevation_unit: str = typer.Option(None, "--elevation-unit", help="Elevation unit of columns without one "
                                       "(m, mm, cm, in, ft)."),
    grind: bool = typer.Option(True, "--grind/--no-grind", help="Run the grinding simulation when the spec "
                               "gives a threshold."),
    check_units: bool = typer.Option(True, "--check-units/--no-check-units",
                                     help="Refuse a section whose IRI is outside any paved road's 0.2-50 m/km (a "
                                          "dead sensor, metres under a mm label) and a track holding one exact "
                                          "elevation over 2 m outside the exclusions (a dropout written as a "
                                          "value); --no-check-units computes the acceptance anyway, with the "
                                          "warning on the console, in the report and in summary.json."),
    overwrite: bool = OVERWRITE,
):
    """Smoothness acceptance: lot IRI/MRI, localized roughness, exclusions, pay factors, grinding, one HTML page."""
    from ..io import read_profile
    from ..report import REPORT_FILES, write_acceptance_report
    from ..road import default_spec, read_spec, simulate_grinding, smoothness_acceptance

    out = Path(output)
    hint = f"the report needs a folder, e.g. -o {out.with_suffix('')}_acceptance/."
    if out.suffix.lower() in FILE_SUFFIXES and not out.is_dir():
        raise OutputError(f"-o {output}: the acceptance report is a folder (index.html, figures, tables), not a "
                          f"{out.suffix} file; {hint}")
    s = read_spec(spec) if spec is not None else default_spec()
    inputs = (file, spec) + ((Path(s.events),) if s.events else ())  # the events table is an input too
    check_output_folder(out, *inputs, overwrite=overwrite, writes=REPORT_FILES["acceptance"], hint=hint)
    profile = read_profile(file, units=elevation_unit, tracks=file_tracks(track, file))
    result = smoothness_acceptance(profile, s, check_units=check_units)
    ground = []  # the grinding runs inside the report, once the figures that do not need it are queued (drawn by
    # the command's figure helper meanwhile, when one runs)

    def grinding():
        if grind and (s.grind_threshold or s.localized_threshold):
            ground.append(simulate_grinding(profile, result.spec, acceptance=result))  # zones as clipped
        return ground[0] if ground else None

    files = write_acceptance_report(result, out, grinding=grinding, title=f"Smoothness acceptance: {file.name}",
                                    inputs=inputs, overwrite=overwrite, ground_profile=True)
    _print_summary(result, ground[0] if ground else None)
    console.print(f"report: {files[0]} ({len(files)} files)", markup=False)


def _print_summary(result, grinding) -> None:
    """The console's account of an acceptance: the lots over the section, the warnings, the pay (lots needing
    corrective work named), the localized roughness (or that it was not assessed) and the grinding's outcome."""
    console.print(result.lots_text(), markup=False, soft_wrap=True)
    for w in result.warnings:
        console.print(f"[yellow]warning:[/yellow] {escape(w)}", highlight=False, soft_wrap=True)
    check = " -- CHECK THE WARNING(S) ABOVE BEFORE PAYING" if result.warnings and result.spec.pay_schedule else ""
    console.print(f"pay: {result.pay_text()}{check}", markup=False, soft_wrap=True)
    console.print(result.localized_text() + ("" if grinding is None else "; " + grinding.summary()), markup=False,
                  soft_wrap=True)


def register(app: typer.Typer) -> None:
    """Attach ``acceptance`` to the ``road`` group."""
    app.command("acceptance")(acceptance_command)
