"""``longprofile differentiate``: derivative of a noisy sampled signal (paper 002)."""

from __future__ import annotations

from pathlib import Path

import typer

from ._common import check_output_path, check_plot_path, console


def differentiate(
    file: Path = typer.Argument(..., help="Input table (.csv or .parquet) with one row per sample."),
    column: str = typer.Option(..., "--column", "-c", help="Column holding the signal."),
    dt: float = typer.Option(..., "--dt", help="Sample interval, s."),
    output: Path = typer.Option(..., "--output", "-o", help="Table to write (.csv or .parquet): value, derivative, "
                                                            "derivative_std (one row per input row)."),
    method: str = typer.Option("ml", "--method", "-m", help="ml, polyfit, backward or kalman (docs/signal.md)."),
    window: int | None = typer.Option(None, "--window", "-w",
                                      help="N, past samples per estimate; required by ml and polyfit (e.g. 45)."),
    degree: int | None = typer.Option(None, "--degree", "-d",
                                      help="Motion model: 1 velocity, 2 acceleration, 3 jerk (method default)."),
    order: int = typer.Option(1, "--order", help="Derivative order."),
    q_over_r: float | None = typer.Option(None, "--q-over-r",
                                          help="Kalman: jerk variance / noise variance; required by kalman (e.g. 1e6)."),
    smooth: bool = typer.Option(False, "--smooth", help="Kalman: RTS smoother (non-causal) instead of the filter."),
    steady_state: bool = typer.Option(False, "--steady-state",
                                      help="Kalman: constant-gain filter/smoother (fast, O(T) memory, no NaN)."),
    noise_std: float | None = typer.Option(None, "--noise-std", help="Noise std of the signal (estimated if omitted)."),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw the signal and its derivative (PNG)."),
):
    """Estimate the derivative of a noisy sampled signal and write value, derivative, derivative_std."""
    import pandas as pd

    from ..errors import InputError
    from ..io import read_table, write_table
    from ..signal import derivative

    if method in ("ml", "polyfit") and window is None:
        raise InputError(f"--method {method} needs --window N (past samples per estimate), e.g. --window 45.")
    if method == "kalman" and q_over_r is None:
        raise InputError("--method kalman needs --q-over-r (jerk variance / noise variance), e.g. --q-over-r 1e6.")
    out = check_output_path(output, file)
    png = check_plot_path(plot, file, output)
    frame = read_table(file, required=[column], numeric=[column])
    x = frame[column].to_numpy(dtype=float)
    with console.status(f"differentiating {x.size} samples ({method})..."):
        res = derivative(x, dt, method=method, window=window, degree=degree, order=order, noise_std=noise_std,
                         q_over_r=q_over_r, smooth=True if smooth else None,
                         steady_state=True if steady_state else None)
    write_table(pd.DataFrame({"value": res.value, "derivative": res.derivative,
                              "derivative_std": res.derivative_std}), out)
    console.print(f"wrote {out} ({x.size} samples, method {method}, noise std {res.params['noise_std']:.4g})")
    if plot is not None:
        from ..signal._plot import plot_derivative

        plot_derivative(x, dt, res, label=column).savefig(png, dpi=110)
        console.print(f"wrote {png}")
