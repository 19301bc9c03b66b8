"""``longprofile road compare``: profile comparison and profiler certification (AASHTO R 56 practice)."""

from __future__ import annotations

from pathlib import Path

import typer

from ._common import OVERWRITE, check_output_folder, console, parse_tracks
from ._road_tracks import RENAME, file_tracks, parse_renames, renamed

_FILE_HELP = "Profile file (CSV/Parquet with distance_m and <track>_<unit> columns, or ERD)."


def compare_command(
    reference: Path = typer.Argument(..., help="Reference profile. " + _FILE_HELP),
    runs: list[Path] = typer.Argument(..., help="Runs of the profiler under test (one or more files)."),
    output: Path = typer.Option(..., "--output", "-o", help="Output folder: runs.csv, pairs.csv, summary.json "
                                "(and correlation.png with --plot)."),
    plot: bool = typer.Option(False, "--plot", help="Also draw the correlation against offset of every run."),
    track: str = typer.Option(None, "--track", help="Comma-separated tracks (default: the reference's tracks "
                              "present in every run)."),
    rename: str = RENAME,
    filter: str = typer.Option("iri", "--filter", help="iri (golden-car filter, default), bandpass (needs "
                               "--band) or none."),
    band: str = typer.Option(None, "--band", help="Wavelength band for --filter bandpass, m: SHORT,LONG."),
    max_offset: float = typer.Option(5.0, "--max-offset", help="Largest distance offset searched, m."),
    spacing: float = typer.Option(None, "--spacing", help="Resample every profile to this step, m (needed when "
                                  "the files have different or irregular sample intervals)."),
    repeatability: float = typer.Option(None, "--repeatability", help="Repeatability threshold, a rating in (0, 1] "
                                        "(default 0.92, AASHTO R 56 as recalled)."),
    accuracy: float = typer.Option(None, "--accuracy", help="Accuracy threshold, a rating in (0, 1] (default 0.90)."),
    elevation_unit: str = typer.Option(None, "--elevation-unit", help="Elevation unit of columns without one "
                                       "(m, mm, cm, in, ft)."),
    overwrite: bool = OVERWRITE,
):
    """Cross-correlate runs with a reference and with each other (Karamihas' method, AASHTO R 56 practice)."""
    from ..errors import InputError
    from ..report import REPORT_FILES, write_compare_report
    from ..road import certify_profiler

    inputs = [reference, *runs]
    out = Path(output)
    check_output_folder(out, *inputs, overwrite=overwrite, writes=REPORT_FILES["compare"],
                        hint=f"give a folder, e.g. -o {out.with_suffix('')}_compare/.")
    bands = None
    if band is not None:
        try:
            bands = tuple(float(v) for v in band.split(","))
        except ValueError:
            raise InputError(f"--band must be SHORT,LONG in m (e.g. 0.5,50); got {band!r}.") from None
    tracks = parse_tracks(track)
    renames = parse_renames(rename)
    ref, *profiles = _read_profiles(inputs, tracks, renames, elevation_unit)
    _refuse_repeated(inputs, [ref, *profiles])
    thresholds = {k: v for k, v in (("repeatability", repeatability), ("accuracy", accuracy)) if v is not None}
    from ..road.smoothness import MIN_REFERENCE_COVERAGE

    res = certify_profiler(ref, profiles, tracks=tracks, filter=filter, band=bands, max_offset=max_offset,
                           spacing=spacing, thresholds=thresholds or None, names=[Path(r).name for r in runs])
    write_compare_report(res, out, reference=reference, runs=runs, plot=plot, overwrite=overwrite)
    for w in res.warnings:
        console.print(f"[yellow]warning:[/yellow] {w}", highlight=False, soft_wrap=True)
    for t in res.accuracy:
        rep = res.repeatability[t]
        rep_text = "not judged (one run)" if rep != rep else f"{rep:.3f} (>= {res.thresholds['repeatability']:g})"
        console.print(f"{t}: accuracy {res.accuracy[t]:.3f} (>= {res.thresholds['accuracy']:g}), "
                      f"repeatability {rep_text}", markup=False, soft_wrap=True)
    short = res.runs[res.runs["coverage"] < MIN_REFERENCE_COVERAGE]
    for row in short.drop_duplicates("run").itertuples():
        console.print(f"{row.run} covers {100 * row.coverage:.0f} % of the reference (at least "
                      f"{100 * MIN_REFERENCE_COVERAGE:.0f} % needed to certify): FAIL", markup=False, soft_wrap=True)
    console.print(f"{'PASS' if res.passed else 'FAIL'}: {len(runs)} run(s) against {reference}; tables in {out}",
                  markup=False, soft_wrap=True)


def _read_profiles(files, tracks, renames: dict, elevation_unit):
    """The profiles of ``files``: their ``tracks`` (each file's own default, with its note, when not given), then
    ``renames`` applied where a file has the track; with renames every track is read and ``tracks`` (new names)
    chosen by the comparison. A name to rename that no file has is refused."""
    from ..errors import InputError
    from ..io import read_profile

    profiles, found = [], {}
    for f in files:
        profile = read_profile(f, units=elevation_unit,
                               tracks=tracks if tracks is not None and not renames else file_tracks(None, f))
        found.update({t.casefold(): t for t in profile.tracks})
        profiles.append(renamed(profile, renames, source=f, strict=False))
    unused = [old for old in renames if old.casefold() not in found]
    if unused:
        raise InputError(f"--rename {unused[0]}={renames[unused[0]]}: no file has the track {unused[0]!r}; their "
                         f"tracks are {sorted(found.values())}.")
    return profiles


def _refuse_repeated(files, profiles) -> None:
    """Refuse a run that is the reference (or an earlier run) again: the same file, or the same stations and
    elevations (a copy, another format): a profile compared with itself scores 1.000 whatever the profiler."""
    import os

    import numpy as np

    from ..errors import InputError

    for j in range(1, len(files)):
        for i in range(j):
            try:
                same_file = os.path.samefile(files[i], files[j])
            except OSError:
                same_file = False
            a, b = profiles[i], profiles[j]
            if not same_file and not (np.array_equal(a.distance, b.distance) and a.elevation.shape == b.elevation.shape
                                      and np.array_equal(a.elevation, b.elevation, equal_nan=True)):
                continue
            what = "the reference" if i == 0 else f"run {files[i]}"
            how = "the same file" if same_file else "the same stations and elevations"
            raise InputError(f"run {files[j]} is {what} again ({how}): a profile compared with itself scores 1.000 "
                             "whatever the profiler; pass the runs of the profiler under test, each once.")


def register(app: typer.Typer) -> None:
    """Attach ``compare`` to the ``road`` group."""
    app.command("compare")(compare_command)
