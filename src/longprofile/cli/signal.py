"""``longprofile differentiate``: derivative of a noisy sampled signal (paper 002)."""

from __future__ import annotations

import re
from pathlib import Path

import typer

from ._common import OVERWRITE, TABLE_SUFFIXES, check_output_path, check_plot_path, console, save_plot
from ._vehicle_planar import RENAME_COLUMNS

#: Time columns whose step is checked against --dt: t or time, in seconds unless a unit follows (t_ms, time [ms],
#: Time (us)); any letter case.
_TIME_NAME = re.compile(r"^(?:t|time)(?:_(?P<u1>s|ms|us)|\s*\[(?P<u2>s|ms|us)\]|\s*\((?P<u3>s|ms|us)\))?$", re.IGNORECASE)
_TIME_UNITS = {None: 1.0, "s": 1.0, "ms": 1e-3, "us": 1e-6}


def _time_scale(name) -> float | None:
    """Seconds per unit of a time column's name, None when the name is not a time column."""
    m = _TIME_NAME.match(str(name).strip())
    return None if m is None else _TIME_UNITS[(m.group("u1") or m.group("u2") or m.group("u3") or "s").lower()]


def _time_axis(file: Path, frame, column: str):
    """``(name, seconds)`` of the file's time column (the first column named as one, not the signal), or None."""
    from .._validation import time_seconds

    for name in frame.columns:
        scale = _time_scale(name)
        if scale is None or name == column:
            continue
        seconds, start = time_seconds(frame, name, source=str(file))  # numbers, ISO 8601 texts or datetime64
        return name, seconds * (1.0 if start is not None else scale)
    return None


def _sample_interval(file: Path, axis, dt: float | None) -> float:
    """The sample interval, s: ``dt`` checked against the file's own time column ``axis`` (:func:`_time_axis`; a
    wrong dt scales the derivative silently), or, without ``dt``, the step of that column when it is uniform (within
    0.1 % of its median)."""
    import numpy as np

    from .._validation import check_time_order, time_resolution
    from ..errors import InputFormatError, UnitsError

    if axis is not None:
        name, t = axis
        rows = np.flatnonzero(np.isfinite(t))
        step = np.diff(t[rows])
        increasing = step.size > 0 and bool(np.all(step > 0))
        if not increasing and step.size:  # which: duplicated samples, a logger reset, rows out of order, rounding
            check_time_order(t[rows], source=str(file), column=name, rows=rows)
        if not increasing:  # no two finite times
            if dt is None:
                raise InputFormatError(f"{file}: column {name!r} has fewer than two finite times; the sample interval "
                                       "cannot be taken from it: pass --dt SECONDS.")
            return dt
        # the mean step end to end: Unix time stamps (1.7e9 s) round each step by up to +-2.4e-7 s, the ends barely
        mean = float((t[rows[-1]] - t[rows[0]]) / (rows.size - 1))
        if dt is None:
            if np.max(np.abs(step - mean)) > 1e-3 * mean + time_resolution(t[rows]):
                raise InputFormatError(f"{file}: column {name!r} is not uniformly sampled (steps {step.min():g} to "
                                       f"{step.max():g} s); the estimators need a constant interval: resample the "
                                       "signal, or pass --dt SECONDS if the jitter is the logger's, not the signal's.")
            return float(f"{mean:.12g}")  # the decimal step the file was written with (0.001, not 0.0010000000000000009)
        if abs(mean - dt) > 1e-3 * dt:
            raise UnitsError(f"{file}: column {name!r} steps by {mean:g} s but --dt is {dt:g} s; the derivative "
                             f"would be off by a factor {mean / dt:g}. Pass --dt {mean:g}.")
        return dt
    if dt is None:
        raise InputFormatError(f"{file}: no time column (t or time, in s unless named with its unit: t_ms, "
                               "time [ms], time (us)) to take the sample interval from; pass --dt SECONDS.")
    return dt


def _interval_source(frame, column: str, dt: float) -> str:
    """Where the sample interval came from, for the summary: a time column in ms under a plain 'time' label (or
    minutes) would make every derivative 1000 (or 1/60) times too small, and only the printed interval shows it."""
    names = [str(n) for n in frame.columns if _time_scale(n) is not None and n != column]
    if not names:
        return "(--dt)"
    bare = _TIME_NAME.match(names[0].strip())
    unit = bare.group("u1") or bare.group("u2") or bare.group("u3")
    return (f"(column {names[0]!r}, {unit})" if unit else
            f"(column {names[0]!r} read in seconds; name it {names[0]}_ms or {names[0]} [ms] if it is not)")


def _numeric(series):
    """Float array of a column, NaN where a cell is not a number."""
    import pandas as pd

    return pd.to_numeric(series, errors="coerce").to_numpy(dtype=float)


def differentiate(
    file: Path = typer.Argument(..., help="Input table (.csv or .parquet) with one row per sample."),
    column: str = typer.Option(..., "--column", "-c", help="Column holding the signal."),
    dt: float | None = typer.Option(None, "--dt", help="Sample interval, s (default: the constant step of the "
                                                          "file's time column: t or time, with a unit t_ms, time \\[ms])."),
    output: Path = typer.Option(..., "--output", "-o", help="Table to write (.csv or .parquet): time_s (when the file "
                                                            "has a time column), value, derivative, derivative_std "
                                                            "(one row per input row; see --std)."),
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
    std: str = typer.Option("total", "--std",
                            help="What derivative_std covers: 'total' (default), the white-noise error plus an "
                                 "estimate of the model (bias, lag) error from a higher-order companion estimate; "
                                 "'noise', the white-noise error only (the std before issue 13). docs/signal.md, "
                                 "Calibration."),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw the signal and its derivative (PNG)."),
    rename: list[str] | None = RENAME_COLUMNS,
    overwrite: bool = OVERWRITE,
):
    """Estimate the derivative of a noisy sampled signal and write value, derivative, derivative_std."""
    import pandas as pd

    from .._validation import parse_column_renames, renamed_columns
    from ..errors import InputError
    from ..io import read_table, write_table
    from ..signal import check_derivative_options, derivative

    options = dict(window=window, degree=degree, noise_std=noise_std, q_over_r=q_over_r,
                   smooth=True if smooth else None, steady_state=True if steady_state else None, std=std)
    check_derivative_options(method, options, flags=True)
    renames = parse_column_renames(rename)
    out = check_output_path(output, file, suffixes=TABLE_SUFFIXES, overwrite=overwrite)
    png = check_plot_path(plot, file, out, overwrite=overwrite)
    # --column names the column after renaming (as road compare's --track names the new tracks)
    gone = next((f"{o}={n}" for o, n in renames.items() if o.casefold() == column.casefold() and n != column), None)
    if gone is not None:
        raise InputError(f"--column {column}: --rename {gone} renames that column; --column takes the new name.")
    read_as = {new: old for old, new in renames.items()}.get(column, column)
    frame = renamed_columns(read_table(file, required=[read_as], numeric=[read_as]), renames, source=str(file))
    x = frame[column].to_numpy(dtype=float)
    axis = _time_axis(file, frame, column)
    dt = _sample_interval(file, axis, dt)
    with console.status(f"differentiating {x.size} samples ({method})..."):
        res = derivative(x, dt, method=method, order=order, **options)
    table = {} if axis is None else {"time_s": axis[1]}  # the file's time, s, beside each row
    write_table(pd.DataFrame({**table, "value": res.value, "derivative": res.derivative,
                              "derivative_std": res.derivative_std}), out)
    console.print(f"wrote {out} ({x.size} samples, method {method}, noise std {res.params['noise_std']:.4g}, "
                  f"derivative_std: {std})")
    source = _interval_source(frame, column, dt)
    console.print(f"sample interval {dt:.6g} s {source}: the derivative is per second" if source != "(--dt)" else
                  f"sample step {dt:.6g} (--dt): the derivative is per unit of that step (per second for a time "
                  "step, per metre for a profile sampled every --dt metres)", markup=False, soft_wrap=True)
    if plot is not None:
        from ..report import plot_derivative

        save_plot(png, plot_derivative, x, dt, res, label=column, savefig={"dpi": 110})
        console.print(f"wrote {png}")
