"""``longprofile differentiate``: derivative of a noisy sampled signal (paper 002)."""

from __future__ import annotations

import re
from pathlib import Path

import typer

from ._common import OVERWRITE, TABLE_SUFFIXES, check_output_path, check_plot_path, console, save_plot

#: Time columns whose step is checked against --dt: t or time, in seconds unless a unit follows (t_ms, time [ms],
#: Time (us), time [min]); any letter case.
_TIME_NAME = re.compile(r"^(?:t|time)(?:_(?P<u1>s|ms|us|min)|\s*\[(?P<u2>s|ms|us|min)\]|\s*\((?P<u3>s|ms|us|min)\))?$",
                        re.IGNORECASE)
_TIME_UNITS = {None: 1.0, "s": 1.0, "ms": 1e-3, "us": 1e-6, "min": 60.0}
#: A step over this many sample intervals is a gap (a dropped sample is one): the estimators assume a constant
#: interval, so the samples on either side would be differentiated as neighbours.
_GAP_STEPS = 1.5
_GAP_FIX = ("cut the record there and differentiate each part (the estimators assume a constant interval and would "
            "take the samples on either side as neighbours)")


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


def _check_dt(dt: float | None) -> None:
    import math

    from ..errors import InputError

    if dt is not None and not (math.isfinite(dt) and dt > 0):
        raise InputError(f"--dt must be > 0 (the sample interval, s); got {dt:g}.")


def _sample_interval(file: Path, axis, dt: float | None) -> float:
    """The sample interval, s: without ``dt``, the step of the file's time column ``axis`` (:func:`_time_axis`) by the
    rule every uniform-time command uses (:func:`longprofile._validation.uniform_time_step`: a gap, rounded stamps or
    jitter refused); with ``dt``, ``dt`` checked against that column (a wrong dt scales the derivative silently, a
    gap joins samples that are not neighbours)."""
    import numpy as np

    from .._validation import uniform_time_step
    from ..errors import InputFormatError

    if axis is None:
        if dt is None:
            raise InputFormatError(f"{file}: no time column (t or time, in s unless named with its unit: t_ms, "
                                   "time [ms], time (us), time [min]) to take the sample interval from; pass --dt "
                                   "SECONDS.")
        return dt
    name, t = axis
    rows = np.flatnonzero(np.isfinite(t))
    if rows.size < 2:
        if dt is None:
            raise InputFormatError(f"{file}: column {name!r} has fewer than two finite times; the sample interval "
                                   "cannot be taken from it: pass --dt SECONDS.")
        return dt
    if dt is None:
        step = uniform_time_step(t[rows], source=str(file), column=name, rows=rows, max_gap_steps=_GAP_STEPS,
                                 gap_fix=_GAP_FIX, rounded_fix="write the time with more digits, or give the "
                                 "logger's own interval with --dt SECONDS (checked against these stamps)",
                                 jitter_fix="resample it with --resample HZ (linear interpolation), or pass --dt "
                                 "SECONDS if the jitter is in the logger's time stamps, not in its sampling")
        return float(f"{step:.12g}")  # the decimal step the file was written with (0.001, not 0.0010000000000000009)
    _check_against_dt(file, name, t[rows], rows, dt)
    return dt


def _check_against_dt(file: Path, name: str, t, rows, dt: float) -> None:
    """Refuse a time column that contradicts ``dt``: not increasing, a step over ``_GAP_STEPS`` dt (plus the stamps'
    rounding step) or a mean step more than 0.1 % from dt. Jitter of the stamps within that is the user's word."""
    import numpy as np

    from .._validation import check_time_order, rounded_time_stamps
    from ..errors import InputFormatError, UnitsError

    quantum = rounded_time_stamps(t)
    if quantum is None:
        check_time_order(t, source=str(file), column=name, rows=rows)
    d = np.diff(t)
    k = int(np.argmax(d))
    if d[k] > _GAP_STEPS * dt + (quantum or 0.0):
        raise InputFormatError(f"{file}: column {name!r} has a gap of {d[k]:.6g} s after t = {t[k]:.6g} s (row "
                               f"{rows[k]}; --dt is {dt:g} s): samples are missing there: {_GAP_FIX}.")
    # the mean step end to end: Unix time stamps (1.7e9 s) round each step by up to +-2.4e-7 s, the ends barely
    mean = float((t[-1] - t[0]) / (t.size - 1))
    if abs(mean - dt) > 1e-3 * dt:
        raise UnitsError(f"{file}: column {name!r} steps by {mean:g} s but --dt is {dt:g} s; the "
                         f"derivative would be off by a factor {mean / dt:g}: leave --dt out (the time column gives "
                         "the interval) or correct it.")


def _resampled(file: Path, axis, column: str, x, rate: float):
    """``(seconds, x)`` on a uniform time base at ``rate`` Hz: :func:`longprofile.vehicle.resample_log`, the vehicle
    logs' resampling (linear interpolation; a gap over 3 periods, upsampling and two values at one time refused)."""
    import numpy as np
    import pandas as pd

    from ..errors import InputError
    from ..vehicle import resample_log

    if axis is None:
        raise InputError(f"--resample: {file} has no time column (t or time, with its unit: t_ms, time [ms]) to "
                         "resample from.")
    name, t = axis
    keep = np.isfinite(t)
    frame = resample_log(pd.DataFrame({"time": t[keep], "x": np.asarray(x)[keep]}), rate,
                         source=f"{file}: column {name!r}")
    return frame["time"].to_numpy(float), frame["x"].to_numpy(float)


def _check_samples(file: Path, column: str, x, axis, drop_empty: bool) -> None:
    """Refuse a column with no value, or whose values sit on a regular pattern of rows (a slower channel of a
    multi-rate log: every window would hold a blank, and every estimate would be NaN)."""
    import numpy as np

    from ..errors import InputFormatError

    have = np.flatnonzero(np.isfinite(x))
    if have.size == 0:
        raise InputFormatError(f"{file}: column {column!r} has no values (every cell is empty or not a number).")
    if drop_empty or have.size < 3 or have.size > 0.75 * x.size:
        return
    gaps = np.diff(have)
    m = int(np.median(gaps))
    if m >= 2 and np.mean(gaps == m) >= 0.9:
        rate = "" if axis is None else f" (about {1 / (m * float(np.nanmedian(np.diff(axis[1])))):.4g} Hz)"
        raise InputFormatError(f"{file}: column {column!r} has a value on every {m}th row only{rate}, blank "
                               f"between: a slower channel of a multi-rate log; every estimate would span a blank "
                               "and be NaN: differentiate its own rows: --drop-empty (keeps the rows where it has "
                               "a value; their time column gives the interval).")


def _unit_of(name: str) -> str | None:
    """The unit written in a column name ('speed [km/h]', 'x (mm)'), None without one."""
    m = re.search(r"[\[(]\s*([^\])]+?)\s*[\])]\s*$", str(name))
    return None if m is None else m.group(1)


def _output_names(unit: str | None, order: int, *, timed: bool) -> tuple[str, str, str]:
    """The output's value, derivative and derivative_std column names: plain without a unit in the signal's name;
    with one, each carries its unit as the input did (``value [mm]``, ``derivative [mm/s]``, ``(km/h)/s^2``; per
    ``--dt unit`` when the interval is --dt's, whose unit the file does not say), so that the file itself says what its
    numbers are: the values are not converted (session 41)."""
    if unit is None:
        return "value", "derivative", "derivative_std"
    base = f"({unit})" if re.search(r"[/*^ ]", unit) else unit
    per = ("s" if order == 1 else f"s^{order}") if timed else ("--dt unit" if order == 1 else f"(--dt unit)^{order}")
    rate = f"{base}/{per}" if timed else f"{unit} per {per}"
    return f"value [{unit}]", f"derivative [{rate}]", f"derivative_std [{rate}]"


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


#: ``--rename`` of differentiate (the vehicle commands' help speaks of units read from the names; here none are).
_RENAME = typer.Option(None, "--rename", help="Rename the file's columns, OLD=NEW[,OLD=NEW...] or the option repeated "
                       "(e.g. --rename Zeit=time,Signal=x): applied right after reading; an old name matches in any "
                       "letter case; --column takes the new name. Units in a signal's name are not converted: the "
                       "derivative is in the column's own unit per second (a time column's unit is read: time \\[ms]).")


def differentiate(
    file: Path = typer.Argument(..., help="Input table (.csv or .parquet) with one row per sample."),
    column: str = typer.Option(..., "--column", "-c", help="Column holding the signal."),
    dt: float | None = typer.Option(None, "--dt", help="Sample interval, s (default: the constant step of the "
                                                          "file's time column: t or time, with a unit t_ms, time \\[ms]); "
                                                          "when the file has one, --dt is checked against it."),
    output: Path = typer.Option(..., "--output", "-o", help="Table to write (.csv or .parquet): time_s (when the file "
                                                            "has a time column), value, derivative, derivative_std "
                                                            "(see --std), settled (False where derivative_std is not "
                                                            "settled: the estimator's start-up, the smoother's ends); "
                                                            "one row per input row. A unit in the column's name is "
                                                            "carried, not converted: 'x (mm)' gives 'value \\[mm]', "
                                                            "'derivative \\[mm/s]'."),
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
    resample: float | None = typer.Option(None, "--resample", help="Resample a jittered record onto this rate, Hz, "
                                          "first (linear interpolation, as vehicle vertical estimate --resample; gaps "
                                          "over 3 periods refused); the output has one row per resampled time."),
    drop_empty: bool = typer.Option(False, "--drop-empty", help="Keep only the rows where --column has a value (a "
                                    "slower channel of a multi-rate log); the output has one row per kept row."),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw the signal and its derivative (PNG)."),
    rename: list[str] | None = _RENAME,
    overwrite: bool = OVERWRITE,
):
    """Estimate the derivative of a noisy sampled signal and write value, derivative, derivative_std."""
    import numpy as np
    import pandas as pd

    from .._validation import parse_column_renames, renamed_columns
    from ..errors import InputError
    from ..io import read_table, write_table
    from ..signal import check_derivative_options, derivative

    options = dict(window=window, degree=degree, noise_std=noise_std, q_over_r=q_over_r,
                   smooth=True if smooth else None, steady_state=True if steady_state else None, std=std)
    check_derivative_options(method, options, flags=True)
    _check_dt(dt)
    if resample is not None and dt is not None:
        raise InputError("--resample and --dt: the resampled interval is 1 / --resample; give one of them.")
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
    _check_samples(file, column, x, axis, drop_empty)
    if drop_empty:
        keep = np.isfinite(x)
        x = x[keep]
        axis = None if axis is None else (axis[0], axis[1][keep])
    if resample is not None:
        seconds, x = _resampled(file, axis, column, x, resample)
        axis, dt = (axis[0], seconds), 1.0 / resample
    else:
        dt = _sample_interval(file, axis, dt)
    _check_steady_state(steady_state, x, axis)
    with console.status(f"differentiating {x.size} samples ({method})..."):
        res = derivative(x, dt, method=method, order=order, **options)
    if not np.isfinite(res.derivative).any():
        raise InputError(f"{file}: no estimate: every window of column {column!r} holds a blank or is shorter than "
                         "the estimator needs; nothing written.")
    _warn_model(x, dt, method, res, options)
    table = {} if axis is None else {"time_s": axis[1]}  # the file's time, s, beside each row
    first, stop = res.params["settled"]  # derivative_std before / after: start-up or end, where it under-covers
    settled = (np.arange(x.size) >= first) & (np.arange(x.size) < stop) & np.isfinite(res.derivative)
    unit = _unit_of(column)
    names = _output_names(unit, order, timed=axis is not None or resample is not None)
    write_table(pd.DataFrame({**table, names[0]: res.value, names[1]: res.derivative,
                              names[2]: res.derivative_std, "settled": settled}), out)
    per = "s" if order == 1 else f"s^{order}"
    rate = f"units of {column}/{per}" if unit is None else names[1][len("derivative ["):-1]
    console.print(f"wrote {out} ({x.size} samples, method {method}, noise std {res.params['noise_std']:.4g}, "
                  f"derivative_std: {std}; derivative in {rate}, not converted"
                  f"{'' if unit is None else f': columns {names[0]!r}, {names[1]!r}'})", markup=False, soft_wrap=True)
    source = _interval_source(frame, column, dt) if resample is None else f"(--resample {resample:g} Hz)"
    console.print(f"sample interval {dt:.6g} s {source}: the derivative is per second" if source != "(--dt)" else
                  f"sample step {dt:.6g} (--dt): the derivative is per unit of that step (per second for a time "
                  "step, per metre for a profile sampled every --dt metres)", markup=False, soft_wrap=True)
    if plot is not None:
        from ..report import plot_derivative

        save_plot(png, plot_derivative, x, dt, res, label=column, savefig={"dpi": 110})
        console.print(f"wrote {png}")


def _check_steady_state(steady_state: bool, x, axis) -> None:
    """--steady-state cannot skip a missing sample: name the first one (its time when the file has one)."""
    import numpy as np

    from ..errors import InputError

    blank = np.flatnonzero(~np.isfinite(x))
    if not steady_state or blank.size == 0:
        return
    k = int(blank[0])
    where = f"row {k}" if axis is None else f"t = {axis[1][k]:.6g} s (row {k})"
    raise InputError(f"the signal has {blank.size} missing sample(s), the first at {where}: drop --steady-state "
                     "(missing samples need the time-varying filter).")


def _warn_model(x, dt: float, method: str, res, options: dict) -> None:
    """Warn when the window (or q/r) is too long for the signal (:func:`longprofile.signal.model_check`): the fit's
    residuals far beyond the noise and unexplained by the next-degree companion, so derivative_std misses the bias."""
    from ..signal import model_check

    keys = ("window", "degree", "q_over_r", "smooth", "steady_state")
    check = model_check(x, dt, method=method, noise_std=float(res.params["noise_std"]),
                        skip=int(options.get("window") or 0) + 1, estimate=res,
                        **{k: options[k] for k in keys if k in options})
    if check.adequate:
        return
    fix = "raise --q-over-r" if method == "kalman" else "shorten --window"
    if check.reason == "residuals":
        why = (f"on {check.share:.0%} of the record the fit's residuals reach {check.residual_ratio:.3g} times the "
               "noise std, and the companion estimate that derivative_std takes the bias from explains "
               f"{1 / check.unexplained:.0%} of them")
    else:
        why = (f"the derivative disagrees with the rate of change of the same fit's lower order by "
               f"{check.inconsistency:.3g} times derivative_std (RMS, beyond the noise): the polynomial does not "
               "follow the signal over the window")
    console.print(f"warning: {'q/r too small' if method == 'kalman' else 'window too long'} for this signal: {why}: "
                  f"the derivative is biased beyond derivative_std; {fix} (docs/signal.md, Model check).",
                  markup=False, soft_wrap=True)
