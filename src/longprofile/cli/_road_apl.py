"""``longprofile road simulate | reconstruct | identify``: the APL trailer (paper 000)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import typer

from ._common import PROFILE_SUFFIXES, TABLE_SUFFIXES, check_output_path, check_plot_path, console, progress


def _instrument(speed: float, dx: float, model_file: Path | None):
    """The trailer model: Table 1 for (speed, dx), or a saved identified model checked against them."""
    from ..errors import InputFormatError, UnitsError
    from ..road.apl import apl_model, apl_model_from_dict

    if model_file is None:
        return apl_model(speed, dx)
    try:
        data = json.loads(Path(model_file).read_text())
    except FileNotFoundError:
        from ..errors import InputError

        raise InputError(f"{model_file}: no such file.") from None
    except json.JSONDecodeError as exc:
        raise InputFormatError(f"{model_file}: not valid JSON ({exc}).") from None
    model = apl_model_from_dict(data.get("model", data) if isinstance(data, dict) else data)
    if model.dx is not None and abs(model.dx - dx) > 1e-9 * dx:
        raise UnitsError(f"{model_file} was identified for dx = {model.dx:g} m; this record uses --dx {dx:g} m. "
                         "Identify the trailer at this spacing.")
    if model.speed is not None and abs(model.speed - speed) > 1e-9 * speed:
        raise UnitsError(f"{model_file} was identified for {model.speed:g} m/s; this record uses --speed {speed:g}.")
    if abs(model.dt - dx / speed) > 1e-9 * model.dt:
        raise UnitsError(f"{model_file} has dt = {model.dt:g} s but --dx / --speed = {dx / speed:g} s.")
    return model


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
    seed: int = typer.Option(0, "--seed", help="Random seed."),
    plot: Path = typer.Option(None, "--plot", help="Also draw the truth and the signal to this PNG."),
):
    """Simulate an APL recording (eq. 1, Table 1) of a synthetic road, with the truth column."""
    import pandas as pd

    from ..io import write_table
    from ..road._apl_plots import plot_recording
    from ..road.apl import apl_model, simulate_apl_recording

    png = check_plot_path(plot, check_output_path(output, suffixes=TABLE_SUFFIXES))
    rec = simulate_apl_recording(profile, apl_model(speed, dx), length=length, road_class=road_class,
                                 noise_fraction=noise, rng=seed)
    write_table(pd.DataFrame(dict(distance_m=rec.distance, true_m=rec.true_elevation, apl_m=rec.signal)),
                check_output_path(output))
    if plot is not None:
        plot_recording(rec.distance, rec.true_elevation, rec.signal,
                       title=f"simulated APL recording: {profile}, {speed:g} m/s, dx {dx:g} m").savefig(png, dpi=120)
    console.print(f"simulated {rec.distance.size} samples ({profile}, {speed:g} m/s, dx {dx:g} m, "
                  f"noise std {rec.noise_std * 1e3:.3g} mm) -> {output}")


def reconstruct_command(
    file: Path = typer.Argument(..., help="APL recording: CSV/Parquet with distance_m and the signal column (m)."),
    output: Path = typer.Option(..., "--output", "-o",
                                help="Profile to write: .csv/.parquet table with distance_m, elevation_m, std_m, raw_m, "
                                     "raw_std_m; or .erd (ProVAL/UMTRI text) with the elevation track only, in mm "
                                     "(the std and raw columns go to CSV/Parquet only)."),
    speed: float = typer.Option(20.0, "--speed", help="Towing speed, m/s."),
    dx: float = typer.Option(0.05, "--dx", help="Spacing, m (must match the file's distance_m)."),
    method: str = typer.Option("smoother", "--method", help="smoother (best, offline), fixed-lag (real time, constant latency), double (paper §3), or filter (the paper's causal Kalman filter: poor in the 1-50 m band, see docs/road-apl.md)."),
    model: Path = typer.Option(None, "--model", help="Identified model JSON (from `road identify`) instead of Table 1."),
    column: str = typer.Option("apl_m", "--column", help="Name of the signal column, in metres."),
    q: float = typer.Option(None, "--q", help="Elevation-increment variance, m^2 (default: maximum likelihood)."),
    r: float = typer.Option(None, "--r", help="Noise variance, m^2 (default: maximum likelihood)."),
    input_model: str = typer.Option(None, "--input-model",
                                    help="Road model: wiener (paper) or ar1 (§5.2). Default: wiener; ar1 (2 m) for fixed-lag."),
    correlation_length: float = typer.Option(None, "--correlation-length", help="AR(1) correlation length, m."),
    highpass: float = typer.Option(100.0, "--highpass-wavelength", help="Detrending cut-off wavelength, m."),
    lag: float = typer.Option(None, "--lag", help="fixed-lag latency, m (default: 4 pendulum time constants, 83 m "
                                                   "at 20 m/s)."),
    plot: Path = typer.Option(None, "--plot", help="Also draw the reconstruction to this PNG."),
):
    """Reconstruct the road profile from an APL signal (smoother, Kalman filter, double filtering or fixed lag)."""
    import numpy as np

    from ..errors import InputError, UnitsError
    from ..io import read_apl_signal, write_erd, write_table
    from ..road import Profile
    from ..road._apl_plots import plot_reconstructions
    from ..road.apl import reconstruct_profile

    check_output_path(output, file, suffixes=PROFILE_SUFFIXES)
    png = check_plot_path(plot, file, output)
    signal = read_apl_signal(file, column=column)
    values = signal.elevation[:, 0]
    spacing = signal.spacing
    if spacing is None:
        raise InputError(f"{file}: distance_m is not evenly spaced; the APL samples every dx. Resample first.")
    if abs(spacing - dx) > 1e-6 * dx:
        raise UnitsError(f"{file}: the samples are {spacing:g} m apart but --dx is {dx:g} m.")
    instrument = _instrument(speed, dx, model)
    with progress() as bar:
        task = bar.add_task(f"reconstruct ({method})", total=1)
        rec = reconstruct_profile(signal, instrument, method=method, q=q, r=r, input_model=input_model,
                                  correlation_length=correlation_length, highpass_wavelength=highpass, lag_m=lag)
        bar.advance(task)
    if Path(output).suffix.lower() == ".erd":
        write_erd(Profile(rec.profile.distance, rec.profile.elevation[:, 0], tracks=("elevation",),
                          name=f"{method} reconstruction of {Path(file).name}"), check_output_path(output, file),
                  units="mm")
    else:
        write_table(rec.to_frame(), check_output_path(output, file))
    if plot is not None:
        truth = _truth_column(file)
        fig = plot_reconstructions(signal.distance, signal.elevation[:, 0], {method: rec}, truth=truth,
                                   highpass_wavelength=highpass, dx=dx, title=f"{file.name}: {method}")
        fig.savefig(png, dpi=120)
    extra = "" if rec.q is None else f" (q = {rec.q:.3g} m^2, r = {rec.r:.3g} m^2)"
    if rec.lag_m is not None:
        extra += f", latency {rec.lag_m:g} m = {rec.lag_m / speed:.2f} s"
    console.print(f"reconstructed {signal.n_samples} samples by {method}{extra} -> {output}")
    n_missing = int(np.isnan(values).sum())
    if n_missing:
        console.print(f"[yellow]note:[/yellow] {n_missing} missing (NaN) sample(s) in {column!r} were bridged by the "
                      f"{method}; raw_std_m shows the larger uncertainty there.")


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
    dx: float = typer.Option(0.05, "--dx", help="Spacing the model is for, m (dt = dx / speed)."),
    plot: Path = typer.Option(None, "--plot", help="Also draw measured vs simulated output and the step response."),
):
    """Identify the trailer (OE or ARMAX by prediction-error ML, Gauss-Newton) from bench input/output records."""
    from ..errors import InputError
    from ..identify import fit_armax, fit_output_error
    from ..io import read_table
    from ..road._apl_plots import plot_identification
    from ..road.apl import apl_model_from_polynomials

    check_output_path(model_out, input, output_file, suffixes=(".json",))
    png = check_plot_path(plot, input, output_file, model_out)
    u = read_table(input, required=[input_column], numeric=[input_column])[input_column].to_numpy()
    y = read_table(output_file, required=[output_column], numeric=[output_column])[output_column].to_numpy()
    if u.size != y.size:
        raise InputError(f"{input} has {u.size} rows but {output_file} has {y.size}; they must be sample-aligned.")
    na, nb, nk = orders
    dt = dx / speed
    with progress() as bar:
        task = bar.add_task(f"identify {structure.upper()}({na},{nb},{nk})", total=1)
        if structure == "oe":
            est = fit_output_error(u, y, na=na, nb=nb, nk=nk, dt=dt)
        elif structure == "armax":
            est = fit_armax(u, y, na=na, nb=nb, nc=nc, nk=nk, dt=dt)
        else:
            raise InputError(f"--structure must be oe or armax; got {structure!r}.")
        bar.advance(task)
    model = apl_model_from_polynomials(est.numerator, est.denominator, dt=dt, speed=speed, dx=dx,
                                       name=f"{structure.upper()}({na},{nb},{nk}) identified from {Path(input).name}")
    path = check_output_path(model_out, input, output_file)
    path.write_text(json.dumps(dict(model=model.to_dict(), fit=est.to_dict()), indent=2))
    if plot is not None:
        plot_identification(u, y, est, dt=dt).savefig(png, dpi=120)
    console.print(f"{structure.upper()} converged in {est.n_iterations} iterations, residual std "
                  f"{est.residual_std:.4g}, simulation fit {est.fit_simulation:.1f} % -> {model_out}")
    sys.stdout.flush()


def register(app: typer.Typer) -> None:
    """Attach ``simulate``, ``reconstruct`` and ``identify`` to the ``road`` group."""
    app.command("simulate")(simulate_command)
    app.command("reconstruct")(reconstruct_command)
    app.command("identify")(identify_command)
