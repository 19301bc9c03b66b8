"""``longprofile road simulate | reconstruct | identify``: the APL trailer (paper 000)."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from ._common import (
    OVERWRITE,
    PROFILE_SUFFIXES,
    TABLE_SUFFIXES,
    check_output_path,
    check_plot_path,
    console,
    progress,
    save_plot,
)


def _truth_column(file: Path):
    """The ``true_m`` column of a simulated recording, for the plot (None when the file has none)."""
    from ..io import read_table

    table = read_table(file)
    return table["true_m"].to_numpy(dtype=float) if "true_m" in table.columns else None


def simulate_command(
    output: Path = typer.Option(..., "--output", "-o", help="Recording table (.csv/.parquet): distance_m, true_m, apl_m."),
    profile: str = typer.Option("iso8608", "--profile",
                                help="iso8608, bump, crenels, speed-hump, sine-arcs or white-noise."),
    road_class: str = typer.Option("C", "--road-class", help="ISO 8608 class A..H (for --profile iso8608)."),
    length: float = typer.Option(1000.0, "--length", help="Length, m."),
    speed: float = typer.Option(20.0, "--speed", help="Towing speed, m/s."),
    dx: float = typer.Option(0.05, "--dx", help="Spacing, m."),
    noise: float = typer.Option(0.02, "--noise", help="Measurement noise std as a fraction of the signal RMS."),
    seed: int = typer.Option(0, "--seed", min=0, help="Random seed of the noise and, without --road-seed, of the "
                             "road (drawn first, then the noise)."),
    road_seed: int = typer.Option(None, "--road-seed", min=0, help="Random seed of the road alone (iso8608, "
                                  "white-noise); default: --seed. --road-seed S --seed N is the road of --seed S "
                                  "with the noise of --seed N: another --seed records the same road with new noise."),
    plot: Path = typer.Option(None, "--plot", help="Also draw the truth and the signal to this PNG."),
    overwrite: bool = OVERWRITE,
):
    """Simulate an APL recording (eq. 1, Table 1) of a synthetic road, with the truth column."""
    from ..io import write_table
    from ..report import plot_recording
    from ..road.apl import apl_model, simulate_apl_recording

    out = check_output_path(output, suffixes=TABLE_SUFFIXES, overwrite=overwrite)
    png = check_plot_path(plot, out, overwrite=overwrite)
    rec = simulate_apl_recording(profile, apl_model(speed, dx), length=length, road_class=road_class,
                                 noise_fraction=noise, rng=seed, road_rng=road_seed)
    write_table(rec.to_frame(), out)
    if plot is not None:
        save_plot(png, plot_recording, rec.distance, rec.true_elevation, rec.signal,
                  title=f"simulated APL recording: {profile}, {speed:g} m/s, dx {dx:g} m", savefig={"dpi": 120})
    console.print(f"simulated {rec.distance.size} samples ({profile}, {speed:g} m/s, dx {dx:g} m, "
                  f"noise std {rec.noise_std * 1e3:.3g} mm) -> {output}")


def reconstruct_command(
    file: Path = typer.Argument(..., help="APL recording: CSV/Parquet with the stations (distance_m, or another unit: "
                                              "distance_ft, station_km) and the signal column (m)."),
    output: Path = typer.Option(..., "--output", "-o",
                                help="Profile to write: .csv/.parquet table with distance_m, elevation_m, std_m, raw_m, "
                                     "raw_std_m; or .erd (ProVAL/UMTRI text) with the elevation track only, in mm "
                                     "(the std and raw columns go to CSV/Parquet only)."),
    speed: float = typer.Option(None, "--speed", help="Towing speed, m/s. Default: the file's speed column (speed_kmh, "
                                "'Speed \\[km/h]', speed_m_s: its median over moving samples, matched to a calibrated "
                                "model), else 20 m/s (paper 000's 72 km/h). A --speed more than 1 % (0.25 % at 6 m/s) "
                                "off the file's is refused. A speed column that varies beyond that tolerance: the "
                                "trailer is re-discretised at each station's speed (smoother or filter)."),
    dx: float = typer.Option(0.05, "--dx", help="Spacing, m (must match the file's stations)."),
    method: str = typer.Option("smoother", "--method", help="smoother (best, offline), fixed-lag (real time, constant latency), double (paper §3), or filter (the paper's causal Kalman filter: poor in the 1-50 m band, see docs/road-apl.md)."),
    model: Path = typer.Option(None, "--model", help="Identified model JSON (from `road identify`) instead of Table 1."),
    column: str = typer.Option("apl_m", "--column",
                               help="Name of the signal column, in metres; a unit suffix converts it (apl_mm). A file "
                                    "whose only apl column is apl_mm or 'APL [mm]' is read from that column."),
    q: float = typer.Option(None, "--q", help="Elevation-increment variance, m^2 (default: maximum likelihood)."),
    r: float = typer.Option(None, "--r", help="Noise variance, m^2 (default: maximum likelihood)."),
    input_model: str = typer.Option(None, "--input-model",
                                    help="Road model: wiener (paper) or ar1 (§5.2). Default: wiener; ar1 (2 m) for fixed-lag."),
    correlation_length: float = typer.Option(None, "--correlation-length", help="AR(1) correlation length, m."),
    highpass: float = typer.Option(100.0, "--highpass-wavelength", help="Detrending cut-off wavelength, m."),
    lag: float = typer.Option(None, "--lag", help="fixed-lag latency, m (default: the longer of 4 pendulum time "
                                                   "constants and the calibrated lag: 83 m at 20 m/s, 120 m at 6 m/s)."),
    instrument_uncertainty: str = typer.Option(
        None, "--instrument-uncertainty",
        help="Declared 1-sigma uncertainty of the trailer model, added to std_m (smoother and fixed-lag only), e.g. "
             "freq=0.115,gain=0.029: freq = relative 1-sigma of each natural frequency (pendulum, damper), gain = "
             "relative 1-sigma of the gain, each in [0, 1) (a uniform tolerance of +-t is t/sqrt(3)); optional "
             "window=<m>, an averaging length of the squared sensitivity (default 0: per sample). Costs one more "
             "reconstruction per uncertain parameter. Default: none (std_m is the posterior std alone)."),
    short_waves: str = typer.Option(
        None, "--short-waves",
        help="Road spectrum std_m is computed under: record (the model's, scaled by what the record shows where the "
             "trailer resolves the road and continued beyond; default) or prior (the model's own at every "
             "wavenumber: the std_m before 2026-12-06). docs/road-apl.md."),
    plot: Path = typer.Option(None, "--plot", help="Also draw the reconstruction to this PNG."),
    overwrite: bool = OVERWRITE,
):
    """Reconstruct the road profile from an APL signal (smoother, Kalman filter, double filtering or fixed lag)."""
    import numpy as np
    from rich.markup import escape

    from ..errors import InputError
    from ..io import read_apl_record, write_erd, write_table
    from ..road.apl import (
        SHORT_WAVE_OPTIONS,
        InstrumentUncertainty,
        detrend_profile,
        reconstruct_towed,
    )

    uncertainty = None if instrument_uncertainty is None else InstrumentUncertainty.parse(instrument_uncertainty)
    if short_waves is not None and short_waves not in SHORT_WAVE_OPTIONS:
        raise InputError(f"--short-waves must be one of {', '.join(SHORT_WAVE_OPTIONS)}; got {short_waves!r}.")
    out = check_output_path(output, file, suffixes=PROFILE_SUFFIXES, overwrite=overwrite)
    png = check_plot_path(plot, file, out, overwrite=overwrite)
    record = read_apl_record(file, column=column, dx=dx)
    recording, signal = record.recording, record.recording.signal
    for note in record.notes:
        console.print(f"[cyan]note:[/cyan] {escape(note)}")
    with progress() as bar:
        task = bar.add_task(f"reconstruct ({method})", total=1)
        towed = reconstruct_towed(signal, record.speed, dx=dx, speed=speed, model_file=model, source=str(file),
                                  time_samples=record.time_samples,
                                  method=method, q=q, r=r, input_model=input_model,
                                  correlation_length=correlation_length, highpass_wavelength=highpass, lag_m=lag,
                                  instrument_uncertainty=uncertainty, short_waves=short_waves)
        rec, speed = towed.reconstruction, towed.towing.speed
        bar.advance(task)
    for note in towed.notes:
        console.print(f"[cyan]note:[/cyan] {escape(note)}")
    if Path(output).suffix.lower() == ".erd":
        write_erd(rec.to_profile(name=f"{method} reconstruction of {Path(file).name}"),
                  out, units="mm")
    else:
        write_table(rec.to_frame(), out, metadata=_provenance(file, column, speed, dx, model, rec, q, r))
    if plot is not None:
        from ..report import plot_reconstructions  # matplotlib only when a plot is asked for

        truth = _truth_column(file)
        if truth is not None:  # detrended here: the figure helper then needs neither the road package nor scipy
            truth = detrend_profile(truth - truth[0], dx, highpass_wavelength=highpass)
        std = None if rec.profile.std is None else rec.profile.std[:, 0]
        save_plot(png, plot_reconstructions, signal.distance, signal.elevation[:, 0],
                  {method: (rec.profile.elevation[:, 0], std)}, truth=truth, truth_detrended=True,
                  title=f"{file.name}: {method}", savefig={"dpi": 120})
    extra = "" if rec.q is None else f" (q = {rec.q:.3g} m^2, r = {rec.r:.3g} m^2)"
    if rec.lag_m is not None:
        extra += f", latency {rec.lag_m:g} m = {rec.lag_m / speed:.2f} s"
    console.print(f"reconstructed {signal.n_samples} samples by {method}{extra} -> {output}")
    for warning in rec.warnings:
        console.print(f"[yellow]warning:[/yellow] {warning}")
    n_missing = 0 if towed.in_time else int(np.isnan(signal.elevation[:, 0]).sum())  # in time: none is missing
    if n_missing:
        if recording.absent:
            console.print(f"[yellow]warning:[/yellow] {_absent_stations(recording.absent)}")
        console.print(f"[yellow]note:[/yellow] {n_missing} missing (NaN) sample(s) in {column!r} were bridged by the "
                      f"{method}; {_gap_columns(rec)} the larger uncertainty there.")


def _gap_columns(rec) -> str:
    """Which output columns carry the larger uncertainty in the gaps (no ``raw_std`` on the long-record smoother)."""
    cols = [c for c, v in (("std_m", rec.profile.std), ("raw_std_m", rec.raw_std)) if v is not None]
    return " and ".join(cols) + (" includes" if len(cols) == 1 else " include")


def _absent_stations(absent) -> str:
    """What a recording's stations absent from its grid became (``APLSignalFile.absent``), for a warning."""
    first, last, n = absent[0]
    total = sum(k for _, _, k in absent)
    return (f"{total} station(s) absent from the record's grid ({len(absent)} gap(s), the first {first:.3f} .. "
            f"{last:.3f} m, {n} sample(s): rows a logger dropped?) are read as missing samples, bridged by the "
            "reconstruction; if rows were cut on purpose, reconstruct each part on its own.")


def identify_command(
    input: Path = typer.Option(..., "--input", help="Input table (CSV/Parquet) with the excitation column."),
    output_file: Path = typer.Option(..., "--output", help="Output table (CSV/Parquet) with the response column."),
    orders: tuple[int, int, int] = typer.Option((5, 5, 1), "--orders", help="na nb nk (paper: 5 5 1)."),
    model_out: Path = typer.Option(..., "-o", "--model-out", help="Model JSON (loadable by `reconstruct --model`)."),
    structure: str = typer.Option("oe", "--structure", help="oe (output error) or armax."),
    nc: int = typer.Option(1, "--nc", help="Order of C for armax."),
    input_column: str = typer.Option("u", "--input-column", help="Column of the input table."),
    output_column: str = typer.Option("y", "--output-column", help="Column of the output table."),
    speed: float = typer.Option(20.0, "--speed", help="Towing speed the model is for, m/s."),
    dx: float = typer.Option(0.05, "--dx", help="Spacing the model is for, m (dt = dx / speed; a bench file's "
                             "time stamps, e.g. time_s, must be dt apart: a 7.5 ms bench at 20 m/s is --dx 0.15)."),
    plot: Path = typer.Option(None, "--plot", help="Also draw measured vs simulated output and the step response."),
    overwrite: bool = OVERWRITE,
):
    """Identify the trailer (OE or ARMAX by prediction-error ML, Gauss-Newton) from bench input/output records."""
    from ..io import read_sampled_column
    from ..report import plot_identification
    from ..road.apl import check_identification_structure, identify_trailer, save_model

    check_identification_structure(structure, flag="--structure")  # before reading the files
    model_path = check_output_path(model_out, input, output_file, suffixes=(".json",), overwrite=overwrite)
    png = check_plot_path(plot, input, output_file, model_path, overwrite=overwrite)
    u = _bench_column(read_sampled_column, input, input_column, "--input-column", dx, speed)
    y = _bench_column(read_sampled_column, output_file, output_column, "--output-column", dx, speed)
    na, nb, nk = orders
    dt = dx / speed
    with progress() as bar:
        task = bar.add_task(f"identify {structure.upper()}({na},{nb},{nk})", total=1)
        model, est = identify_trailer(u, y, speed=speed, dx=dx, orders=orders, structure=structure, nc=nc,
                                      name=f"{structure.upper()}({na},{nb},{nk}) identified from {Path(input).name}")
        bar.advance(task)
    save_model(model_path, model, fit=est)  # atomic: an older model file survives a failure
    if plot is not None:
        save_plot(png, plot_identification, u, y, est, dt=dt, savefig={"dpi": 120})
    console.print(f"{structure.upper()} converged in {est.n_iterations} iterations, residual std "
                  f"{est.residual_std:.4g}, simulation fit {est.fit_simulation:.1f} % -> {model_out}")
    sys.stdout.flush()


def _bench_column(reader, path, column: str, flag: str, dx: float, speed: float):
    """``reader(path, column, dx=dx, speed=speed)``; a missing column's refusal names the option that chooses it."""
    from ..errors import InputFormatError

    try:
        return reader(path, column, dx=dx, speed=speed)
    except InputFormatError as exc:
        if "missing column" not in str(exc):
            raise
        raise InputFormatError(f"{str(exc).rstrip('.')}; choose the column with {flag} NAME.") from None


def _provenance(file, column: str, speed: float, dx: float, model, rec, q, r) -> dict:
    """How a ``road reconstruct`` profile was made, for its ``#`` lines (CSV) or Parquet metadata (read back by
    ``longprofile.io.read_report_table``; every profile reader skips them)."""
    from .. import __version__

    smoothed = rec.method in ("smoother", "fixed-lag")
    varying = {} if rec.speed_range is None else {
        "towing_speed": "varying: the trailer re-discretised at each station's speed (docs/road-apl.md, 'Varying "
                        "towing speed')",
        "speed_min_median_max_m_per_s": list(rec.speed_range)}
    return {
        "software": f"longprofile {__version__}",
        "command": "road reconstruct",
        "source": str(file),
        "column": column,
        "speed_m_per_s": speed,
        **varying,
        "dx_m": dx,
        "model": "paper 000 eq. (1), Table 1" if model is None else str(model),
        "method": rec.method,
        "input_model": rec.input_model,
        "correlation_length_m": rec.correlation_length,
        "q_m2": rec.q,
        "r_m2": rec.r,
        "q_r": None if rec.q is None else ("given" if q is not None and r is not None else "maximum likelihood"),
        "highpass_wavelength_m": rec.highpass_wavelength,
        "lag_m": rec.lag_m,
        "short_waves": ("record" if rec.road_spectrum is not None else "prior") if smoothed else None,
        "instrument_uncertainty": None if rec.instrument_uncertainty is None else str(rec.instrument_uncertainty),
        "warnings": list(rec.warnings),
    }


def register(app: typer.Typer) -> None:
    """Attach ``simulate``, ``reconstruct`` and ``identify`` to the ``road`` group."""
    app.command("simulate")(simulate_command)
    app.command("reconstruct")(reconstruct_command)
    app.command("identify")(identify_command)
