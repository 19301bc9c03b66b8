"""``longprofile demo``: the end-to-end job on built-in sample data, writing under ``out/``."""

from __future__ import annotations

import importlib
from pathlib import Path

import typer

from ..errors import OutputError
from ._common import console

# Each step is a module with ``run_demo(outdir: Path) -> list[Path]`` (files written).
DEMO_STEPS = [
    ("derivative estimators (paper 002)", "longprofile.signal._demo"),
    ("Kalman smoothing (state-space engine)", "longprofile.statespace._demo"),
    ("road profile from the APL trailer (paper 000)", "longprofile.road._demo_apl"),
    ("IRI report on the APL reconstruction (ASTM E1926, ISO 8608)", "longprofile.road._demo_report"),
    ("rail settlement from inclinometers (paper 004)", "longprofile.rail._demo"),
    ("rail monitoring service: day-by-day replay through the ingestion API (issue 15)", "longprofile.rail.service._serve"),
    ("road slope and vehicle states (paper 001)", "longprofile.vehicle._demo_slope"),
    ("vertical vehicle states (thesis 003)", "longprofile.vehicle._demo_vertical"),
]


def demo(output: Path = typer.Option(Path("out"), "--output", "-o", help="Folder for the demo outputs.")):
    """Run every demo on built-in sample data and write plots and tables under OUTPUT."""
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
