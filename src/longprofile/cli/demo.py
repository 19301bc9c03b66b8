"""``longprofile demo``: the end-to-end job on built-in sample data, writing under ``out/``."""

from __future__ import annotations

import importlib
from pathlib import Path

import typer

from ..errors import OutputError
from ._common import console

# Each step is a module with ``run_demo(outdir: Path) -> list[Path]`` (files written).
DEMO_STEPS = [
    ("derivative estimators (paper 002)", "longprofile.demos.signal"),
    ("Kalman smoothing (state-space engine)", "longprofile.demos.statespace"),
    ("road profile from the APL trailer (paper 000)", "longprofile.demos.road_apl"),
    ("IRI report on the APL reconstruction (ASTM E1926, ISO 8608)", "longprofile.demos.road_report"),
    ("rail settlement from inclinometers (paper 004)", "longprofile.demos.rail"),
    ("rail monitoring service: day-by-day replay through the ingestion API (issue 15)", "longprofile.demos.rail_service"),
    ("road slope and vehicle states (paper 001)", "longprofile.demos.vehicle_slope"),
    ("vertical vehicle states (thesis 003)", "longprofile.demos.vehicle_vertical"),
]


def demo(output: Path = typer.Option(Path("out"), "--output", "-o", help="Folder for the demo outputs (its demo "
                                     "files are regenerated on every run; no --overwrite needed).")):
    """Run every demo on built-in sample data and write plots and tables under OUTPUT.

    The demo owns its folder: running it again replaces the files it wrote there (other files are left alone),
    unlike the other commands, which refuse an existing output without --overwrite.
    """
    if output.exists() and not output.is_dir():
        raise OutputError(f"--output {output} is a file; the demo writes into a folder, e.g. -o out.")
    try:
        output.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create the demo folder {output}: {exc.strerror or exc}.") from None
    written = []
    for title, module in DEMO_STEPS:
        console.print(f"[bold]demo:[/bold] {title}")
        files = importlib.import_module(module).run_demo(output)
        for f in files:
            console.print(f"  wrote {f}")
        written.extend(files)
    console.print(f"[green]demo finished:[/green] {len(written)} files in {output}/")
