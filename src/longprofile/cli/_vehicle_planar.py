"""``longprofile vehicle simulate`` and ``longprofile vehicle slope`` (paper 001: planar states and road slope)."""

from __future__ import annotations

from pathlib import Path

import typer

from ._common import OVERWRITE, TABLE_SUFFIXES, check_output_path, check_plot_path, console, save_plot


def _parse_poles(text: str):
    from ..errors import InputError

    try:
        poles = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--poles must be two comma-separated numbers in 1/s, e.g. '-4,-6'; got {text!r}.") from None
    if len(poles) != 2 or any(not p < 0 for p in poles):
        raise InputError(f"--poles must be two negative numbers (continuous-time observer poles, 1/s), "
                         f"e.g. '-5,-7'; got {text!r}.")
    return poles


#: ``--rename`` of ``vehicle slope``, ``vehicle vertical estimate`` and ``differentiate`` (the syntax of ``road
#: convert --rename``, for columns; also repeatable).
RENAME_COLUMNS = typer.Option(None, "--rename", help="Rename the file's columns, OLD=NEW[,OLD=NEW...] or the option "
                              "repeated (e.g. --rename YawRate_degps=yaw_rate_degps --rename "
                              "WhlSpd_FL_kph=wheel_speed_fl_kph): applied right after reading, before the units are "
                              "read from the names (a new name may carry one: wheel_speed_fl_kph, 'yaw_rate "
                              "\\[deg/s]'); an old name matches in any letter case (differentiate's --column takes the "
                              "new name).")
#: ``--fill`` of the vehicle readers.
FILL = typer.Option(None, "--fill", help="hold: a blank cell of a channel takes the channel's last sample (a "
                    "multi-rate export: wheel speeds at 50 Hz blank between the 100 Hz IMU rows); blanks of up to "
                    "0.1 s, the first rows before every channel has a sample are dropped. Default: blanks refused.")


def _vehicle(path: Path | None):
    from ..vehicle import default_vehicle, load_vehicle

    return default_vehicle() if path is None else load_vehicle(path)


def simulate(
    output: Path = typer.Option(..., "--output", "-o", help="Log file to write (.csv or .parquet)."),
    scenario: str = typer.Option("paper", "--scenario", "-s",
                                 help="Built-in scenario: paper, hill or low-mu (see docs/vehicle-slope.md)."),
    vehicle: Path | None = typer.Option(None, "--vehicle", help="Vehicle description (TOML); default car if omitted."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the sensor noise."),
    duration: float | None = typer.Option(None, "--duration", help="Length of the drive, s (default: the "
                                          "scenario's, 40 s; low-mu 30 s). The events are placed for the default: a "
                                          "shorter drive leaves out or cuts those after its end (the command names "
                                          "them; e.g. paper at 5 s: no steering, no grade)."),
    truth: bool = typer.Option(True, "--truth/--no-truth", help="Also write the true_* columns."),
    steering_geometry: str = typer.Option("parallel", "--steering-geometry",
                                          help="parallel (both front wheels steer alike, the paper's) or ackermann "
                                               "(each front wheel its own angle; the log gains steer_fl, steer_fr)."),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw an overview figure (PNG)."),
    overwrite: bool = OVERWRITE,
):
    """Simulate a drive with the 4-wheel model and write the sensor log (and the truth)."""
    from ..io import write_table
    from ..vehicle import drive_scenario, missed_scenario_events, simulate_drive

    out = check_output_path(output, vehicle, suffixes=TABLE_SUFFIXES, overwrite=overwrite)
    check_plot_path(plot, vehicle, out, overwrite=overwrite)
    car = _vehicle(vehicle)
    sim = simulate_drive(drive_scenario(scenario, duration=duration), car, seed=seed,
                         steering_geometry=steering_geometry)
    write_table(sim.to_frame() if truth else sim.log.to_frame(), out)
    console.print(f"wrote {out} ({sim.log.time.size} samples, scenario {scenario})")
    missed = () if duration is None else missed_scenario_events(scenario, sim)
    if missed:
        full = drive_scenario(scenario)
        console.print(f"[yellow]scenario {scenario} is laid out for {full.time.size * full.dt:g} s: this {duration:g} s "
                      f"drive ({sim.truth.distance[-1]:.0f} m) leaves out or cuts {'; '.join(missed)}[/yellow]")
    if plot is not None:
        from ..report import plot_drive

        save_plot(plot, plot_drive, sim, savefig={"dpi": 110}, announce=True)


def slope(
    log: Path = typer.Argument(..., help="Drive log (.csv or .parquet) with the channels of docs/vehicle-slope.md."),
    output: Path = typer.Option(..., "--output", "-o", help="States file to write (.csv or .parquet)."),
    vehicle: Path | None = typer.Option(None, "--vehicle", help="Vehicle description (TOML); default car if omitted. "
                                        "Its optional \\[tolerances] table states the tolerances behind the printed "
                                        "stds, e.g. radius_rel_std = 0.002 for a rolling radius known to 0.2 % "
                                        "(docs/vehicle-slope.md)."),
    method: str = typer.Option("cascade", "--method", help="cascade (EKF + Luenberger, paper 001) or joint (one EKF with the grade in the state)."),
    speed_measurement: str = typer.Option("robust", "--speed-measurement", help="V_x measurement: robust (slip-compensated reference speed, missing when no wheel is trustworthy) or rear-mean (the paper's mean rear-wheel speed)."),
    poles: str = typer.Option("-5,-7", "--poles", help="Luenberger observer poles, 1/s (cascade)."),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw the estimated states (PNG)."),
    units: str | None = typer.Option(None, "--units", help="Units of the log's columns when not SI, e.g. "
                                     "'time=ms,yaw_rate=deg/s,wheel_speed_*=km/h,accel_x=g' (a key with * ? \\[ ] "
                                     "names every channel it matches; an explicit key wins) or in the header: "
                                     "'yaw_rate (deg/s)' or 'yaw_rate \\[deg/s]'; see docs/vehicle-slope.md."),
    resample: float | None = typer.Option(None, "--resample", help="Resample a jittered log onto this rate, Hz "
                                          "(linear interpolation; gaps are refused, and so is a rate above the "
                                          "log's; rows that repeat the one before are dropped)."),
    rename: list[str] | None = RENAME_COLUMNS,
    fill: str | None = FILL,
    steering_offset: float = typer.Option(0.0, "--steering-offset", help="Subtract this constant from the road-wheel "
                                          "steering angle, rad (a steering sensor zeroed off-centre, as the "
                                          "steering_offset check measures it on straight driving)."),
    accept_check: str | None = typer.Option(None, "--accept-check", help="Go on, with a warning, past these checks "
                                            "of the log against the car file (comma-separated): steering_gain (the yaw "
                                            "rate against the steering angle and the car's understeer), axle_order "
                                            "(front and rear wheel speeds told apart by the driven axle's slip); "
                                            "docs/vehicle-slope.md."),
    max_missing: float = typer.Option(0.05, "--max-missing", help="Warn when more than this share of the samples "
                                      "has no V_x measurement."),
    max_grade: float = typer.Option(0.10, "--max-grade", help="Warn where the estimated grade |tan(slope)| exceeds "
                                    "this (0.10 = 10 %; the slope_plausible column uses 10 %)."),
    force_correction: bool = typer.Option(True, "--force-correction/--no-force-correction", help="Correct the "
                                          "slope for the drive's force-model error (mass, tyres, rolling resistance) "
                                          "measured against the longitudinal accelerometer (docs/vehicle-slope.md, "
                                          "Calibration); --no-force-correction: the paper's estimate."),
    sensor_calibration: bool = typer.Option(True, "--sensor-calibration/--no-sensor-calibration", help="Estimate "
                                            "the gyro offset and the wheels' relative radii from the log and correct "
                                            "the gyro and each axle's left/right difference before the filters "
                                            "(docs/vehicle-slope.md, Calibration); "
                                            "--no-sensor-calibration: the log as it is."),
    stops: str = typer.Option("refuse", "--stops", help="refuse (default): a log whose rear-wheel speed falls below "
                              "2 m/s is refused; split: estimate each stretch at or above 2 m/s lasting at least 2 s "
                              "on its own (filters restarted; about 1 s of start-up transient each) and leave the "
                              "other rows empty (columns stretch, note; docs/vehicle-slope.md, Logs with stops)."),
    start: float | None = typer.Option(None, "--start", help="Analyse only from this time, s (the log's own time)."),
    end: float | None = typer.Option(None, "--end", help="Analyse only up to this time, s (the log's own time)."),
    overwrite: bool = OVERWRITE,
):
    """Estimate vehicle states, tyre forces and the road slope from a drive log."""
    import math

    from .._validation import parse_column_renames
    from ..errors import InputError
    from ..io import read_table, write_table
    from ..vehicle import (
        SlopeUncertainty,
        drive_window,
        estimate_slope,
        estimate_slope_split,
        parse_units,
        read_drive_log,
    )

    if not (math.isfinite(max_grade) and max_grade > 0):
        raise InputError(f"--max-grade must be a positive grade (0.10 = 10 %); got {max_grade!r}.")
    if stops not in ("refuse", "split"):
        raise InputError(f"--stops must be refuse or split; got {stops!r}.")
    renames = parse_column_renames(rename)
    out = check_output_path(output, log, vehicle, suffixes=TABLE_SUFFIXES, overwrite=overwrite)
    check_plot_path(plot, log, vehicle, out, overwrite=overwrite)
    car = _vehicle(vehicle)
    uncertainty = SlopeUncertainty() if vehicle is None else SlopeUncertainty.from_car_file(vehicle)
    frame = read_table(log)
    drive, checks = read_drive_log(frame, car, units=parse_units(units), resample=resample, rename=renames, fill=fill,
                                   steering_offset=steering_offset, source=str(log),
                                   accept=[a.strip() for a in (accept_check or "").split(",") if a.strip()])
    drive = drive_window(drive, start, end)
    unchecked = [c.name for c in checks if c.ok is None]
    if unchecked:
        console.print(f"[yellow]not excited by this log, so not checked: {', '.join(unchecked)}[/yellow]")
    with console.status("estimating states and slope..."):
        run = estimate_slope if stops == "refuse" else estimate_slope_split
        est = run(drive, car, method=method, poles=_parse_poles(poles), speed_measurement=speed_measurement,
                  force_correction=force_correction, sensor_calibration=sensor_calibration, uncertainty=uncertainty)
    write_table(est.to_frame(), out)
    console.print(f"wrote {out} ({est.time.size} samples, method {method}, speed measurement {speed_measurement})")
    source = "the defaults" if uncertainty == SlopeUncertainty() else f"the \\[tolerances] of {vehicle}"
    console.print(f"the stds assume ({source}): {uncertainty.describe()}")
    if stops == "refuse":
        _print_fits(est, drive.dt)
    else:
        for k, ((a, b), part) in enumerate(zip(est.stretches, est.estimates), start=1):
            _print_fits(part, drive.dt, prefix=f"stretch {k} ({est.time[a]:.6g} to {est.time[b - 1]:.6g} s): ")
    for w in [c.warning for c in checks if c.warning] + list(est.warnings(max_missing=max_missing,
                                                                          max_slope=math.atan(max_grade))):
        console.print(f"[yellow]warning: {w}[/yellow]")
    if plot is not None:
        from ..report import plot_slope_estimate

        # the true_* columns of a simulated log are overlaid; the truth is on the original time base
        overlay = resample is None and fill is None and renames == {} and start is None and end is None
        save_plot(plot, plot_slope_estimate, est, frame if overlay else None, savefig={"dpi": 110},
                  announce=True)


def _print_fits(est, dt: float, prefix: str = "") -> None:
    """Print the force check against the accelerometer and the sensor calibration of one estimate."""
    fit = est.force_fit
    if fit is not None and fit.n_blocks == 0:
        console.print(f"[yellow]{prefix}log too short for the force check against the accelerometer (under 7 s): the "
                      "slope is not corrected and its std uses the stated mass and tyre uncertainty[/yellow]")
    elif fit is not None:
        console.print(f"{prefix}force model vs accelerometer ({fit.n_blocks} blocks of 1 s): relative error "
                      f"{100 * fit.beta:+.1f} +- {100 * fit.beta_std:.1f} %, constant {100 * fit.offset:+.2f} +- "
                      f"{100 * fit.offset_std:.2f} % of grade (the slope is corrected for both)")
    if est.sensor_calibration is not None:
        line = _calibration_line(est.sensor_calibration, est.time[-1] - est.time[0] + dt)
        console.print(line.replace("[yellow]", f"[yellow]{prefix}", 1) if line.startswith("[yellow]") else prefix + line)


def _calibration_line(cal, duration: float) -> str:
    """The printed line of the sensor calibration: what it found and what it corrected (nothing, and why, when no
    part had enough usable blocks)."""
    from ..vehicle import CALIBRATION_MIN_BLOCKS as need

    rear, front, straight = (int(n) for n in cal.n_blocks)
    if rear == 0 and front == 0:
        why = (f"the log is {duration:.3g} s, under the {need + 1} s it needs: the first second and {need} blocks of 1 s"
               if duration < need + 1 else
               f"fewer than {need} of its 1 s blocks had V_x >= 5 m/s, no braking, |a_y| <= 4 m/s^2 and little "
               "traction slip")
        return (f"[yellow]gyro and wheels from the log: nothing corrected ({why}); the gyro offset and the wheel "
                f"scales keep their priors (+- {cal.prior_std[0]:.1e} rad/s, +- {100 * cal.prior_std[1]:.1f} %)"
                "[/yellow]")
    done = ("the gyro and each axle's left/right difference" if rear and front else
            "the gyro and the rear axle's left/right difference" if rear else "the front axle's left/right difference")
    kept = "" if rear and front else (f"; the {'front axle' if rear else 'gyro and the rear axle'} kept the prior: "
                                      f"under {need} usable blocks")
    scales = "/".join(f"{100 * x:+.3f}" for x in cal.wheel_scale)
    stds = "/".join(f"{100 * x:.3f}" for x in cal.wheel_scale_std)
    return (f"gyro and wheels from the log (blocks of 1 s: {rear} rear, {front} front left/right, {straight} straight "
            f"front/rear): gyro offset {cal.gyro_offset:+.2e} +- {cal.gyro_offset_std:.1e} rad/s, wheel scale "
            f"FL/FR/RL/RR {scales} % (+- {stds} %, relative to the rear axle; {done} corrected{kept})")


def register(app: typer.Typer) -> None:
    """Attach this module's commands to app."""
    app.command("simulate")(simulate)
    app.command("slope")(slope)
