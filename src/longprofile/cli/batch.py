"""``longprofile batch iri | reconstruct | report``: a survey network, thousands of files at once (docs/batch.md)."""

from __future__ import annotations

import signal
from pathlib import Path

import typer

from . import _common
from ._common import OVERWRITE, check_output_folder, console, parse_tracks, progress
from ._road_indices import GAPS, MIN_VALID

batch_app = typer.Typer(help="Survey networks: run `road iri` / `road reconstruct` over many files in parallel "
                             "(resumable), and the network report.", no_args_is_help=True)

_PATTERNS_HELP = ("Input files or quoted glob patterns, expanded by longprofile ('surveys/**/*.erd': ** = any "
                  "depth). Profiles: ERD, or CSV/Parquet with distance_m and one column per track with its unit.")
_OUTPUT_HELP = ("Results folder: manifest.parquet + segments/ (Parquet dataset partitioned by route). An existing "
                "results folder needs --resume or --overwrite.")
_WORKERS_HELP = "Parallel workers for processes/threads (default: the CPUs available)."
_SCHEDULER_HELP = ("processes (a local process pool, default), threads, serial, or tcp://HOST:PORT to use a running "
                   "Dask scheduler (pip install longprofile\\[dask]; inputs and -o must be on a filesystem every "
                   "worker sees).")
_RESUME_HELP = "Continue an interrupted run: skip the files already done with the same content and options."
_OVERWRITE_HELP = "Replace the results already in the folder (only the manifest and the dataset are removed)."
_UNITS_HELP = "Report units of the IRI table: si (m, m/km) or us (ft, in/mi)."


def _run(task, patterns: list[str], output: Path, workers: int | None, scheduler: str, resume: bool,
         overwrite: bool) -> None:
    """Expand the patterns, make the one library call (run_batch) with a progress bar, report, exit code."""
    from ..batch import EXIT_SOME_FAILED, expand_paths, run_batch

    _warn_ignored_workers(workers, scheduler)
    paths = expand_paths(patterns)
    bar = progress()
    state = {}

    def start(n):
        bar.start()
        state.update(task=bar.add_task(f"batch {task.name} ({scheduler})", total=n), total=n, done=0)

    def result(row):
        bar.advance(state["task"])
        state["done"] += 1

    # the first Ctrl-C or SIGTERM stops the run; later ones are ignored until it has written its manifest, stopped its
    # pool and printed the line below
    with _terminate_as_interrupt():
        try:
            summary = run_batch(task, paths, output, executor=scheduler, workers=workers, resume=resume,
                                overwrite=overwrite, on_start=start, on_result=result)
        except KeyboardInterrupt:  # the manifest holds the files done (run_batch writes it on the way out)
            bar.stop()
            if "total" in state:
                console.print(f"[yellow]interrupted after {state['done']} of {state['total']} files:[/yellow] the "
                              f"results so far are in {output}; the same command with --resume continues.",
                              highlight=False, soft_wrap=True)
            else:
                console.print("[yellow]interrupted[/yellow] before the first file.", highlight=False, soft_wrap=True)
            raise typer.Exit(130) from None
        finally:
            bar.stop()
    if summary.ok:
        console.print(summary.line(), markup=False, highlight=False, soft_wrap=True)
        return
    console.print(f"[red]some files failed:[/red] {summary.line()}", highlight=False, soft_wrap=True)
    raise typer.Exit(EXIT_SOME_FAILED)


def _warn_ignored_workers(workers: int | None, scheduler: str) -> None:
    """One line when ``--workers`` has no effect: the serial scheduler runs one file at a time, and a Dask cluster's
    workers are those started on it (it was silently ignored)."""
    if workers is None or scheduler in ("processes", "threads"):
        return
    if scheduler == "serial":
        why = "--scheduler serial runs one file at a time in this process"
    elif "://" in scheduler:
        why = (f"the Dask scheduler {scheduler} runs the files on the workers started on its cluster (start more with "
               "`dask worker`)")
    else:
        return  # an unknown scheduler is refused by run_batch
    console.print(f"[yellow]warning:[/yellow] --workers {workers} is ignored: {why}.", highlight=False,
                  soft_wrap=True)


def _terminate_as_interrupt():
    """SIGTERM (``kill``, a scheduler's timeout, systemd) ends a batch as Ctrl-C does: the manifest written, the pool
    shut down, the resume hint printed. Python's default ended it at once (exit 143, no manifest of the last files,
    the pool workers left running; session 35, a probe). After the first SIGINT or SIGTERM the others are ignored
    until the block ends (a second Ctrl-C hung the shutdown), and in the ``longprofile`` process until it has exited.
    Main thread only; in a process that goes on (``main`` called in-process) the previous handlers come back after."""
    from .._interrupt import interrupt_once

    return interrupt_once(signal.SIGINT, signal.SIGTERM, keep_ignoring=_common.COMMAND_PROCESS)


@batch_app.command("iri")
def iri_command(
    patterns: list[str] = typer.Argument(..., help=_PATTERNS_HELP),
    output: Path = typer.Option(..., "--output", "-o", help=_OUTPUT_HELP),
    workers: int = typer.Option(None, "--workers", min=1, help=_WORKERS_HELP),
    scheduler: str = typer.Option("processes", "--scheduler", help=_SCHEDULER_HELP),
    resume: bool = typer.Option(False, "--resume", help=_RESUME_HELP),
    overwrite: bool = typer.Option(False, "--overwrite", help=_OVERWRITE_HELP),
    mode: str = typer.Option("fixed", "--mode", help="fixed (consecutive segments), continuous (sliding window) or "
                             "overlapping (windows every --step < --window), as `road iri`."),
    segment: float = typer.Option(None, "--segment", help="Fixed segment length in the report's length unit "
                                  "(default 100 m, or 528 ft = 0.1 mi with --units us)."),
    window: float = typer.Option(None, "--window", help="Window length, continuous/overlapping."),
    step: float = typer.Option(None, "--step", help="Distance between window starts, continuous/overlapping."),
    start: float = typer.Option(None, "--start", help="Station of the first interval, report length unit "
                                "(default: each file's first station)."),
    units: str = typer.Option("si", "--units", help=_UNITS_HELP),
    elevation_unit: str = typer.Option(None, "--elevation-unit",
                                       help="Elevation unit of file columns that do not name one (m, mm, cm, in, ft)."),
    moving_average: str = typer.Option("auto", "--moving-average", help="250 mm moving average: auto (ASTM E1926 "
                                       "rule), on or off."),
    track: str = typer.Option(None, "--track", help="Comma-separated tracks (default: all), e.g. left,right."),
    lead_in: float = typer.Option(11.0, "--lead-in", help="Initialisation length, m (ASTM E1926: 11)."),
    gaps: str = GAPS,
    min_valid: float = MIN_VALID,
):
    """IRI per segment of every profile file (as `longprofile road iri`), into one Parquet dataset."""
    from ..batch import IRITask

    task = IRITask(mode=mode, interval=segment, window=window, step=step, start=start, units=units,
                   tracks=parse_tracks(track), lead_in=lead_in, moving_average=moving_average,
                   elevation_unit=elevation_unit, gaps=gaps.strip().lower(), min_valid=min_valid)
    _run(task, patterns, output, workers, scheduler, resume, overwrite)


@batch_app.command("reconstruct")
def reconstruct_command(
    patterns: list[str] = typer.Argument(..., help="APL recordings (CSV/Parquet with the stations, distance_m "
                                                   "or distance_ft, ..., and the signal column) or quoted glob "
                                                   "patterns ('runs/**/*.parquet')."),
    output: Path = typer.Option(..., "--output", "-o", help=_OUTPUT_HELP + " Profiles go to profiles/."),
    workers: int = typer.Option(None, "--workers", min=1, help=_WORKERS_HELP),
    scheduler: str = typer.Option("processes", "--scheduler", help=_SCHEDULER_HELP),
    resume: bool = typer.Option(False, "--resume", help=_RESUME_HELP),
    overwrite: bool = typer.Option(False, "--overwrite", help=_OVERWRITE_HELP),
    speed: float = typer.Option(None, "--speed", help="Towing speed, m/s. Default: each file's speed column, else "
                                "20 m/s (as `road reconstruct`)."),
    dx: float = typer.Option(0.05, "--dx", help="Spacing, m (must match the files' distance_m)."),
    method: str = typer.Option("smoother", "--method", help="smoother, fixed-lag, double or filter (as `road "
                                                            "reconstruct`)."),
    column: str = typer.Option("apl_m", "--column", help="Name of the signal column (m, or with its unit: apl_mm)."),
    highpass: float = typer.Option(100.0, "--highpass-wavelength", help="Detrending cut-off wavelength, m."),
    lag: float = typer.Option(None, "--lag", help="fixed-lag latency, m (default: the longer of 4 pendulum time "
                                   "constants and the calibrated lag: 83 m at 20 m/s, 120 m at 6 m/s)."),
    segment: float = typer.Option(None, "--segment", help="IRI segment length of the reconstruction, report length "
                                  "unit (default 100 m, or 528 ft with --units us)."),
    units: str = typer.Option("si", "--units", help=_UNITS_HELP),
):
    """Reconstruct every APL recording (as `longprofile road reconstruct`) and the IRI of each reconstruction."""
    from ..batch import ReconstructTask

    task = ReconstructTask(speed=speed, dx=dx, method=method, column=column, highpass_wavelength=highpass, lag=lag,
                           interval=segment, units=units)
    _run(task, patterns, output, workers, scheduler, resume, overwrite)


@batch_app.command("report")
def report_command(
    results: Path = typer.Argument(..., help="Results folder of `longprofile batch iri|reconstruct`."),
    output: Path = typer.Option(..., "--output", "-o", help="Report folder (index.html, PNG figures, CSV tables)."),
    worst: int = typer.Option(20, "--worst", min=1, help="Rows of the worst-segments table."),
    overwrite: bool = OVERWRITE,
):
    """Network report: IRI along each route, distribution of segment IRI, worst segments, failed files."""
    from ..batch import read_results, summarize_network
    from ..report import write_network_report

    check_output_folder(output, results, overwrite=overwrite)
    files = write_network_report(summarize_network(read_results(results), n_worst=worst), output, inputs=(results,),
                                 overwrite=overwrite)
    console.print(f"network report: {files[0]} ({len(files)} files)", markup=False)
