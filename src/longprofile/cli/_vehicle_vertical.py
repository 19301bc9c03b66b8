"""``longprofile vehicle vertical simulate|estimate|tables`` (thesis 003: vertical states from suspension sensors)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.markup import escape

from ._common import (
    OVERWRITE,
    TABLE_SUFFIXES,
    check_distinct_outputs,
    check_output_path,
    check_plot_path,
    console,
    progress,
    save_plot,
)
from ._vehicle_planar import FILL, RENAME_COLUMNS

vertical_app = typer.Typer(help="Vertical (suspension) states: 7-DOF car simulator and the per-corner EKFs of "
                                "thesis 003.", no_args_is_help=True)


def _car_damper(car: str):
    from ..errors import InputError
    from ..vehicle import CARS, MRDamperParams

    if car not in CARS:
        raise InputError(f"--car must be one of {list(CARS)}; got {car!r}.")
    return MRDamperParams() if car == "magneride" else None


_MR_VELOCITY_HELP = ("MagneRide: damper velocity of the filter's MR map -- displacement (causal derivative of the "
                     "measured displacement, a precomputed input; default) or filter (the EKF's own velocity "
                     "state, the map inside the model as in the thesis).")


def _mr_map_velocity(value: str) -> str:
    from ..errors import InputError
    from ..vehicle import MR_MAP_VELOCITIES

    if value not in MR_MAP_VELOCITIES:
        raise InputError(f"--mr-map-velocity must be one of {list(MR_MAP_VELOCITIES)}; got {value!r}.")
    return value


def _vertical_params(path: Path | None):
    from ..vehicle import load_vertical_params

    return None if path is None else load_vertical_params(path)


_VEHICLE_HELP = ("Vehicle description (TOML): its \\[vertical] table (fields of VerticalVehicleParams, SI units); "
                 "the thesis car if omitted.")


def _check_simulated_range(sensors, test: str, road_class: str, speed: float, road) -> None:
    """Refuse to write a run whose suspension deflection leaves the sensors' span, which `estimate` refuses (as a log
    in mm read as m): a class H road at speed drives the simulated car through its bump stops (not modelled)."""
    import numpy as np

    from ..errors import InputError
    from ..vehicle.vertical import DEFLECTION_RANGE

    dmax = float(np.max(np.abs(sensors.displacement)))  # what `estimate` reads
    if dmax > DEFLECTION_RANGE:
        what = f"--road {road}" if road is not None else f"test {test}, road class {road_class}"
        raise InputError(f"{what} at {speed:g} m/s drives the suspension to {dmax:.4g} m, beyond the "
                         f"{DEFLECTION_RANGE:g} m span of its deflection sensors (a real car is on its bump stops, "
                         "which the model has not): `estimate` would refuse the log; lower --speed or choose a "
                         "smoother road.")


@vertical_app.command("simulate")
def simulate(
    output: Path = typer.Option(..., "--output", "-o", help="Sensor log to write (.csv or .parquet)."),
    config: int = typer.Option(1, "--config", help="Sensor configuration: 1 displacements, 2 + body "
                                                   "accelerometers, 3 + wheel accelerometers."),
    test: str = typer.Option("road", "--test", help="road (ISO 8608 road at --speed), sweep (4-poster heave sweep "
                                                    "0.5-25 Hz) or track (80 km/h steering sine 0-2 Hz)."),
    road_class: str = typer.Option("C", "--road-class", help="ISO 8608 road class A..H."),
    speed: float = typer.Option(20.0, "--speed", help="Vehicle speed, m/s."),
    duration: float = typer.Option(20.0, "--duration", help="Length of the run, s."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the road and the sensor noise."),
    car: str = typer.Option("ideal", "--car", help="ideal (passive dampers) or magneride (MR dampers driven by a "
                                                   "skyhook controller; the log gains current_FL..RR, A)."),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw the true states of the front-left corner (PNG)."),
    road: Path | None = typer.Option(None, "--road", help="Drive over this road profile (.csv, .parquet with "
                                     "unit-suffixed columns, or .erd; two tracks = left and right wheel paths, one "
                                     "= both) instead of an ISO 8608 road; --duration is then capped by its length."),
    vehicle: Path | None = typer.Option(None, "--vehicle", help=_VEHICLE_HELP),
    overwrite: bool = OVERWRITE,
):
    """Simulate the 7-DOF car on a thesis test and write the sensors of one configuration (plus true_* columns)."""
    from ..io import read_profile, write_table
    from ..vehicle import profile_run, sensors_to_frame, vertical_test_run

    out = check_output_path(output, road, vehicle, suffixes=TABLE_SUFFIXES, overwrite=overwrite)
    check_plot_path(plot, road, vehicle, out, overwrite=overwrite)
    mr = _car_damper(car)
    params = _vertical_params(vehicle)
    with console.status("simulating the 7-DOF car..."):
        if road is not None:
            surface = read_profile(road)
            run = profile_run(surface, config, speed, duration, seed=seed, mr_damper=mr, params=params,
                              source=f"--road {road}")
            sim, sensors = run.simulation, run.sensors
        else:
            sim, sensors = vertical_test_run(config, test=test, road_class=road_class, speed=speed,
                                             duration=duration, seed=seed, mr_damper=mr, params=params)
    _check_simulated_range(sensors, test, road_class, speed, road)
    frame = sensors_to_frame(sensors, sim)
    if road is not None:  # `estimate --profile` places the road under the wheels by it
        frame["chainage_m"] = run.front_chainage
    write_table(frame, out)
    what = f"test {test}" if road is None else (f"road {road}, chainage {run.front_chainage[0]:.6g}.."
                                                 f"{run.front_chainage[-1]:.6g} m of its {surface.distance[0]:.6g}.."
                                                 f"{surface.distance[-1]:.6g} m"
                                                 f" at {speed:g} m/s: --duration sets how far")
    console.print(f"wrote {out} ({sim.time.size} samples, config {config}, {what}, car {car})")
    if plot is not None:
        from ..report import plot_vertical_simulation

        save_plot(plot, plot_vertical_simulation, sim, config, savefig={"dpi": 110}, announce=True)


@vertical_app.command("estimate")
def estimate(
    log: Path = typer.Argument(..., help="Sensor log (.csv or .parquet): time, ax, ay, yaw_rate, dz21_FL..RR "
                                         "(+ body_accel_* or wheel_accel_*), see docs/vehicle-vertical.md."),
    output: Path = typer.Option(..., "--output", "-o", help="States file to write (.csv or .parquet)."),
    config: int | None = typer.Option(None, "--config", help="Sensor configuration of the log (1, 2 or 3); default: "
                                      "inferred from the columns (wheel_accel_* -> 3, body_accel_* -> 2, else 1)."),
    centralised: bool = typer.Option(False, "--centralised/--per-corner",
                                     help="Centralised full-car EKF instead of the thesis's four corner EKFs."),
    mr_map_velocity: str | None = typer.Option(None, "--mr-map-velocity", help=_MR_VELOCITY_HELP),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw the estimated states (PNG); the truth is "
                                                          "overlaid when the log has true_* columns."),
    units: str | None = typer.Option(None, "--units", help="Units of columns that are not SI, e.g. "
                                     "'time=ms,dz21_*=mm,wheel_accel_*=g' (a key with * ? \\[ ] names every channel "
                                     "it matches; an explicit key wins) or in the header: 'dz21_FL (mm)' or "
                                     "'dz21_FL \\[mm]'."),
    resample: float | None = typer.Option(None, "--resample", help="Resample a jittered log onto this rate, Hz "
                                          "(linear interpolation; gaps are refused, and so is a rate above the "
                                          "log's; rows that repeat the one before are dropped)."),
    rename: list[str] | None = RENAME_COLUMNS,
    fill: str | None = FILL,
    profile: Path | None = typer.Option(None, "--profile", help="Also write the road profile under each wheel "
                                        "(fl, fr, rl, rr) with its chainage (.csv, .parquet or .erd); needs --speed."),
    speed: float | None = typer.Option(None, "--speed", help="Constant vehicle speed of the log, m/s (for --profile)."),
    chainage: float = typer.Option(None, "--chainage", help="Chainage of the front axle at the first sample, m "
                                   "(default: the log's chainage_m column, as `vehicle vertical simulate --road` "
                                   "writes it, else 0)."),
    segment: float = typer.Option(100.0, "--segment", help="IRI segment length for --profile, m."),
    vehicle: Path | None = typer.Option(None, "--vehicle", help=_VEHICLE_HELP),
    accept_check: str | None = typer.Option(None, "--accept-check", help="Go on, with a warning, past these checks "
                                            "of the log (comma-separated): sensor_sign (a deflection or accelerometer "
                                            "of inverted sign), wheel_accel_unit (wheel accelerometers in g), "
                                            "body_accel_unit (body accelerometers in g), "
                                            "corner_order (deflections of swapped corners), lateral_axis (ay to the "
                                            "right or in g); docs/vehicle-vertical.md."),
    overwrite: bool = OVERWRITE,
):
    """Estimate damper displacement/velocity, tyre load, body and wheel velocities from a sensor log."""
    from .._validation import parse_column_renames
    from ..errors import InputError
    from ..io import read_table, write_table
    from ..vehicle import estimate_to_frame, estimate_vertical_log, parse_units, read_vertical_log
    from ._common import PROFILE_SUFFIXES

    renames = parse_column_renames(rename)
    iri_path = None if profile is None else Path(profile).with_name(Path(profile).stem + "_iri.csv")
    check_distinct_outputs({"-o": output, "--profile": profile, "--profile's IRI table": iri_path, "--plot": plot})
    out = check_output_path(output, log, vehicle, suffixes=TABLE_SUFFIXES, overwrite=overwrite)
    check_plot_path(plot, log, vehicle, out, overwrite=overwrite)
    params = _vertical_params(vehicle)
    iri_out = None
    if profile is not None:
        check_output_path(profile, log, out, suffixes=PROFILE_SUFFIXES, overwrite=overwrite, what="--profile")
        iri_out = check_output_path(iri_path, log, out,
                                    overwrite=overwrite, what="IRI table")
        if speed is None or not speed > 0:
            raise InputError("--profile needs --speed (the constant speed of the log, m/s): stations are speed x time.")
    elif speed is not None:
        raise InputError("--speed is used with --profile only (the stations of the road under the wheels); the states "
                         "do not need it: drop --speed, or add --profile ROAD.csv.")
    given_map_velocity = mr_map_velocity is not None
    mr_map_velocity = _mr_map_velocity("displacement" if mr_map_velocity is None else mr_map_velocity)
    frame = read_table(log)
    if chainage is None:
        chainage = float(frame["chainage_m"].iloc[0]) if "chainage_m" in frame.columns else 0.0
    notes: list[str] = []
    sensors, config = read_vertical_log(frame, config, units=parse_units(units), resample=resample, rename=renames,
                                        fill=fill, source=str(log), notes=notes)
    if given_map_velocity and sensors.damper_current is None:
        raise InputError(f"--mr-map-velocity sets the MagneRide map's damper velocity; {log} has no current_FL..RR "
                         "columns (a passive car): drop the option.")
    for text in notes:
        console.print(f"[yellow]note: {escape(text)}[/yellow]")
    if plot is None:
        del frame  # only the figure reads the table again (its true_* columns): free it on a long log
    if sensors.damper_current is not None:
        # MagneRide log: the logged currents through the default nominal map (docs: "MagneRide car")
        console.print(f"log has current_* columns: actuator forces from the nominal MR map, evaluated at the "
                      f"{'filter' if mr_map_velocity == 'filter' else 'displacement'}-derived damper velocity")
    with console.status("running the corner EKFs..."):
        result = estimate_vertical_log(sensors, params=params, decentralised=not centralised,
                                       mr_map_velocity=mr_map_velocity, speed=speed if profile is not None else None,
                                       start=chainage, segment_length=segment, source=str(log),
                                       accept=[a.strip() for a in (accept_check or "").split(",") if a.strip()])
    est = result.estimate
    write_table(estimate_to_frame(est), out)
    bands = ("; *_std columns: calibrated stds of dz21, dz21dot, dz10, tyre_force (90 % band +-1.645 std)"
             if est.calibrated_std is not None else
             "; no std columns: calibrated for the per-corner filters at 500-2000 Hz only")
    console.print(f"wrote {out} ({est.time.size} samples, config {config}, {est.method}{bands})")
    for text in result.warnings():
        console.print(f"[yellow]warning: {escape(text)}[/yellow]")
    if profile is not None:
        from ..io import write_profile

        prof, res = result.profile, result.iri
        write_profile(prof, profile)
        write_table(res.to_frame(), iri_out)
        sec = ", ".join(f"{t} {v:.2f}" for t, v in zip(res.tracks, res.section_iri))
        console.print(f"wrote {profile} (chainage {prof.distance[0]:g}..{prof.distance[-1]:.4g} m) and {iri_out} "
                      f"({res.segment_start.size} segments of {segment:g} m); section IRI m/km: {sec}")
        if res.segment_start.size == 0:  # as `road iri`: the table keeps its header, the console says why
            console.print(f"[yellow]note: the {prof.distance[-1] - prof.distance[0]:.4g} m of road under the wheels is "
                          f"too short for one segment of {segment:g} m: {escape(str(iri_out))} has its header only and "
                          "the section IRI is over the whole road; use a shorter --segment or a longer log[/yellow]",
                          soft_wrap=True)  # a path is never folded
    if plot is not None:
        from dataclasses import replace

        from ..report import plot_vertical_estimate

        # the figure draws the per-corner arrays: the engine's output (covariances, 43 MB on a 5 s log) is not sent
        # to the figure helper
        save_plot(plot, plot_vertical_estimate, replace(est, filtered=None), frame, savefig={"dpi": 110},
                  announce=True)


@vertical_app.command("tables")
def tables(
    output: Path = typer.Option(..., "--output", "-o", help="Table to write (.csv or .parquet): test, config, "
                                                            "variable, epsilon, epsilon_all_corners, thesis, "
                                                            "reference, car."),
    duration: float = typer.Option(30.0, "--duration", help="Length of each test run, s."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the roads and the sensor noises."),
    reference: str = typer.Option("truth", "--reference", help="Score against the simulator's truth, or against "
                                                               "the thesis's references rebuilt from measured "
                                                               "signals (integrated accelerometers): truth|thesis."),
    car: str = typer.Option("ideal", "--car", help="ideal (passive simulated car) or magneride (MR dampers + "
                                                   "skyhook; the filters get the logged currents through a nominal "
                                                   "map with a 12 % force error, no lag)."),
    mr_map_velocity: str = typer.Option("displacement", "--mr-map-velocity", help=_MR_VELOCITY_HELP),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw ours next to the thesis's numbers (PNG)."),
    overwrite: bool = OVERWRITE,
):
    """Reproduce the thesis's result tables 4.4 (bench) and 4.5 (track) on the simulator, configurations 1-3."""
    from ..io import write_table
    from ..vehicle import reproduce_thesis_tables

    check_distinct_outputs({"-o": output, "--plot": plot})
    out = check_output_path(output, suffixes=TABLE_SUFFIXES, overwrite=overwrite)
    check_plot_path(plot, out, overwrite=overwrite)
    mr_map_velocity = _mr_map_velocity(mr_map_velocity)
    with progress() as bar:
        task = bar.add_task("bench and track tests, configurations 1-3", total=6)
        table = reproduce_thesis_tables(duration=duration, seed=seed, reference=reference, car=car,
                                        mr_map_velocity=mr_map_velocity,
                                        progress=lambda done, total: bar.update(task, completed=done))
    write_table(table, out)
    mr_note = f", MR map at the {mr_map_velocity} velocity" if car == "magneride" else ""
    console.print(f"wrote {out} ({len(table)} rows, reference {reference}, car {car}{mr_note}, {duration:g} s per "
                  f"test, seed {seed})")
    if plot is not None:
        from ..report import plot_thesis_tables

        save_plot(plot, plot_thesis_tables, table, savefig={"dpi": 110}, announce=True)


def register(app: typer.Typer) -> None:
    """Attach the ``vertical`` sub-group to the ``vehicle`` group."""
    app.add_typer(vertical_app, name="vertical")
