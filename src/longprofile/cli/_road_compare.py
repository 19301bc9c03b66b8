"""``longprofile road compare``: profile comparison and profiler certification (AASHTO R 56 practice)."""

from __future__ import annotations

from pathlib import Path

import typer

from ._common import OVERWRITE, check_output_folder, check_plot_path, console

_FILE_HELP = "Profile file (CSV/Parquet with distance_m and <track>_<unit> columns, or ERD)."


def compare_command(
    reference: Path = typer.Argument(..., help="Reference profile. " + _FILE_HELP),
    runs: list[Path] = typer.Argument(..., help="Runs of the profiler under test (one or more files)."),
    output: Path = typer.Option(..., "--output", "-o", help="Output folder: runs.csv, pairs.csv, summary.json "
                                "(and correlation.png with --plot)."),
    plot: bool = typer.Option(False, "--plot", help="Also draw the correlation against offset of every run."),
    track: str = typer.Option(None, "--track", help="Comma-separated tracks (default: the reference's tracks "
                              "present in every run)."),
    filter: str = typer.Option("iri", "--filter", help="iri (golden-car filter, default), bandpass (needs "
                               "--band) or none."),
    band: str = typer.Option(None, "--band", help="Wavelength band for --filter bandpass, m: SHORT,LONG."),
    max_offset: float = typer.Option(5.0, "--max-offset", help="Largest distance offset searched, m."),
    spacing: float = typer.Option(None, "--spacing", help="Resample every profile to this step, m (needed when "
                                  "the files have different or irregular sample intervals)."),
    repeatability: float = typer.Option(None, "--repeatability", help="Repeatability threshold (default 0.92, "
                                        "AASHTO R 56 as recalled)."),
    accuracy: float = typer.Option(None, "--accuracy", help="Accuracy threshold (default 0.90)."),
    elevation_unit: str = typer.Option(None, "--elevation-unit", help="Elevation unit of columns without one "
                                       "(m, mm, cm, in, ft)."),
    overwrite: bool = OVERWRITE,
):
    """Cross-correlate runs with a reference and with each other (Karamihas' method, AASHTO R 56 practice)."""
    import json

    from ..errors import InputError, OutputError
    from ..io import read_profile
    from ..report import plot_certification
    from ..road import certify_profiler

    inputs = [reference, *runs]
    out = Path(output)
    if any(out.resolve() == Path(p).resolve() for p in inputs):
        raise OutputError(f"output folder {out} is an input; choose another folder.")
    if out.exists() and not out.is_dir():
        raise OutputError(f"output {out} is a file; give a folder, e.g. -o {out.with_suffix('')}_compare/.")
    check_output_folder(out, *inputs, overwrite=overwrite)
    png = check_plot_path(out / "correlation.png", *inputs, overwrite=True) if plot else None
    bands = None
    if band is not None:
        try:
            bands = tuple(float(v) for v in band.split(","))
        except ValueError:
            raise InputError(f"--band must be SHORT,LONG in m (e.g. 0.5,50); got {band!r}.") from None
    tracks = None if track is None else [t.strip() for t in track.split(",") if t.strip()]
    ref = read_profile(reference, units=elevation_unit, tracks=tracks)
    profiles = [read_profile(r, units=elevation_unit, tracks=tracks) for r in runs]
    thresholds = {k: v for k, v in (("repeatability", repeatability), ("accuracy", accuracy)) if v is not None}
    res = certify_profiler(ref, profiles, tracks=tracks, filter=filter, band=bands, max_offset=max_offset,
                           spacing=spacing, thresholds=thresholds or None, names=[Path(r).name for r in runs])
    from ..io import atomic_path

    out.mkdir(parents=True, exist_ok=True)
    for name, frame in (("runs.csv", res.runs), ("pairs.csv", res.pairs)):
        with atomic_path(out / name) as tmp:  # an older file is replaced only once the new one is complete
            frame.to_csv(tmp, index=False)
    summary = {"reference": str(reference), "runs": [str(r) for r in runs], "passed": res.passed,
               "repeatability": res.repeatability, "accuracy": res.accuracy, "reference_iri_m_per_km":
               res.reference_iri, "thresholds": res.thresholds, "metadata": res.metadata}
    with atomic_path(out / "summary.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2, default=float), encoding="utf-8")
    if png is not None:
        plot_certification(res, res.comparisons, png)
    for t in res.accuracy:
        rep = res.repeatability[t]
        rep_text = "n/a (one run)" if rep != rep else f"{rep:.3f} (>= {res.thresholds['repeatability']:g})"
        console.print(f"{t}: accuracy {res.accuracy[t]:.3f} (>= {res.thresholds['accuracy']:g}), "
                      f"repeatability {rep_text}", markup=False, soft_wrap=True)
    console.print(f"{'PASS' if res.passed else 'FAIL'}: {len(runs)} run(s) against {reference}; tables in {out}",
                  markup=False, soft_wrap=True)


def register(app: typer.Typer) -> None:
    """Attach ``compare`` to the ``road`` group."""
    app.command("compare")(compare_command)
