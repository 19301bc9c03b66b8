"""``longprofile road convert``: a profile file from one format to another (CSV, Parquet, ERD), by suffix."""

from __future__ import annotations

from pathlib import Path

import typer

from ._common import OVERWRITE, PROFILE_SUFFIXES, check_output_path, check_plot_path, console
from ._road_tracks import RENAME, file_tracks, parse_renames, renamed


def convert_command(
    file: Path = typer.Argument(..., help="Profile to read: CSV/Parquet with a distance_m column and one column per "
                                          "track named with its unit (left_mm, right_m, ...), or an ERD file."),
    output: Path = typer.Argument(..., help="Profile to write, format by suffix: .csv, .parquet or .erd (ERD: "
                                            "regular stations and elevations only; std columns are not kept)."),
    units: str = typer.Option(None, "--units", help="Elevation unit written: m, mm, cm, in, ft (default: mm for "
                                                    "ERD, m for CSV/Parquet)."),
    distance_unit: str = typer.Option("m", "--distance-unit", help="Station unit written: m (default), ft, km, mi "
                                      "(distance_ft in CSV/Parquet; XUNITS feet in ERD: with --units in, the US "
                                      "file ProVAL writes)."),
    input_units: str = typer.Option(None, "--elevation-unit", "--input-units",
                                    help="Elevation unit of input columns that do not give one (m, mm, cm, in, ft), as "
                                         "in `road iri`; never guessed."),
    track: str = typer.Option(None, "--track", help="Comma-separated tracks to keep (default: all), e.g. left,right."),
    rename: str = RENAME,
    spacing: float = typer.Option(None, "--spacing", help="Resample the profile onto a regular grid of this step, m "
                                  "(linear interpolation from the first station, as `road compare --spacing`): "
                                  "irregular or rounded stations can then be written as ERD. Default: stations kept."),
    plot: Path = typer.Option(None, "--plot", help="Also draw the profile to this PNG."),
    overwrite: bool = OVERWRITE,
):
    """Convert a profile file (CSV, Parquet, ERD) into another; values kept exactly (CSV/Parquet) or to 1e-7 m (ERD)."""
    from ..core import unit_factor
    from ..io import read_profile, write_profile

    out = check_output_path(output, file, suffixes=PROFILE_SUFFIXES, overwrite=overwrite)
    png = check_plot_path(plot, file, out, overwrite=overwrite)
    erd = out.suffix.lower() == ".erd"
    units = units or ("mm" if erd else "m")
    unit_factor(units)
    unit_factor(distance_unit, what="distance")
    renames = parse_renames(rename)
    profile = read_profile(file, units=input_units, tracks=file_tracks(track, file, verb="converting"))
    profile = renamed(profile, renames, source=file)
    if spacing is not None:
        profile = _resampled(profile, spacing, file)
    write_profile(profile, out, units=units, distance_units=distance_unit)
    if plot is not None:
        from ..report import draw, plot_profile  # matplotlib only when drawing (in the figure helper if one runs)

        draw(plot_profile, profile, png)
    x = profile.distance
    step = profile.spacing
    console.print(f"converted {profile.n_samples} samples x {len(profile.tracks)} track(s) "
                  f"({', '.join(profile.tracks)}; stations {x[0]:g} .. {x[-1]:g} m"
                  f"{'' if step is None else f', dx {step:g} m'}{'' if spacing is None else ', resampled'}) in {units} -> {out}", markup=False)
    if erd and profile.std is not None:
        console.print("note: the standard deviation columns are not written to ERD (elevations only); convert to "
                      "CSV or Parquet to keep them.", markup=False)


def _resampled(profile, spacing: float, source=None):
    """``profile`` linearly resampled onto a grid of ``spacing`` m from its first station (its std is not kept)."""
    from ..road import resample_profile

    _refuse_apl_dropout(profile, spacing, source)
    if profile.std is not None:
        console.print("note: --spacing resamples the elevations only; the standard deviation columns are not "
                      "written.", markup=False)
    return resample_profile(profile, spacing)


#: The longest station step an APL signal track (``apl``) is resampled across, in new samples: more is a dropout,
#: which linear interpolation would turn into a straight signal that ``road reconstruct`` reads as measured.
APL_MAX_INTERPOLATED_STEP = 2


def _refuse_apl_dropout(profile, spacing: float, source=None) -> None:
    """Refuse ``--spacing`` on an APL signal track whose stations leave a hole longer than
    :data:`APL_MAX_INTERPOLATED_STEP` new samples (a profile's track is interpolated, as documented)."""
    import numpy as np

    from ..errors import InputError

    if not any(str(t).lower() == "apl" for t in profile.tracks) or profile.n_samples < 2:
        return
    step = np.diff(profile.distance)
    i = int(np.argmax(step))
    if step[i] > APL_MAX_INTERPOLATED_STEP * spacing * (1 + 1e-9):
        x = profile.distance
        raise InputError(f"{source or profile.name or 'the file'}: the APL signal has no sample between stations {x[i]:g} and "
                         f"{x[i + 1]:g} m ({step[i]:g} m): --spacing would interpolate the signal across that "
                         "dropout, and road reconstruct would take it as measured; give the file to road reconstruct "
                         "as it is (stations absent from its grid are read as missing samples) or write the "
                         "missing samples as empty cells.")


def register(app: typer.Typer) -> None:
    """Attach ``convert`` to the ``road`` group."""
    app.command("convert")(convert_command)
