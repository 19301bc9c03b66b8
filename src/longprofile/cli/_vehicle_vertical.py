"""``longprofile vehicle vertical simulate|estimate|tables`` (thesis 003: vertical states from suspension sensors)."""

from __future__ import annotations

from pathlib import Path

import typer

from ._common import TABLE_SUFFIXES, check_output_path, check_plot_path, console, progress

vertical_app = typer.Typer(help="Vertical (suspension) states: 7-DOF car simulator and the per-corner EKFs of "
                                "thesis 003.", no_args_is_help=True)


def _save_figure(fig, path: Path):
    out = check_output_path(path)
    fig.savefig(out, dpi=110)
    console.print(f"wrote {out}")


def _car_damper(car: str):
    from ..errors import InputError
    from ..vehicle._vertical_eval import CARS
    from ..vehicle._vertical_model import MRDamperParams

    if car not in CARS:
        raise InputError(f"--car must be one of {list(CARS)}; got {car!r}.")
    return MRDamperParams() if car == "magneride" else None


_MR_VELOCITY_HELP = ("MagneRide: damper velocity of the filter's MR map -- displacement (causal derivative of the "
                     "measured displacement, a precomputed input; default) or filter (the EKF's own velocity "
                     "state, the map inside the model as in the thesis).")


def _mr_map_velocity(value: str) -> str:
    from ..errors import InputError
    from ..vehicle._vertical_estimate import MR_MAP_VELOCITIES

    if value not in MR_MAP_VELOCITIES:
        raise InputError(f"--mr-map-velocity must be one of {list(MR_MAP_VELOCITIES)}; got {value!r}.")
    return value


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
    seed: int = typer.Option(0, "--seed", help="Seed of the road and the sensor noise."),
    car: str = typer.Option("ideal", "--car", help="ideal (passive dampers) or magneride (MR dampers driven by a "
                                                   "skyhook controller; the log gains current_FL..RR, A)."),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw the true states of the front-left corner (PNG)."),
):
    """Simulate the 7-DOF car on a thesis test and write the sensors of one configuration (plus true_* columns)."""
    from ..io import write_table
    from ..vehicle import sensors_to_frame, vertical_test_run

    out = check_output_path(output, suffixes=TABLE_SUFFIXES)
    check_plot_path(plot)
    mr = _car_damper(car)
    with console.status("simulating the 7-DOF car..."):
        sim, sensors = vertical_test_run(config, test=test, road_class=road_class, speed=speed, duration=duration,
                                         seed=seed, mr_damper=mr)
    frame = sensors_to_frame(sensors, sim)
    write_table(frame, out)
    console.print(f"wrote {out} ({sim.time.size} samples, config {config}, test {test}, car {car})")
    if plot is not None:
        from types import SimpleNamespace

        from ..vehicle import plot_vertical_estimate

        truth_as_estimate = SimpleNamespace(time=sim.time, config=config, method="simulation (truth)",
                                            suspension_deflection=sim.suspension_deflection,
                                            suspension_velocity=sim.suspension_velocity, tyre_force=sim.tyre_force,
                                            body_velocity=sim.body_velocity, wheel_velocity=sim.wheel_velocity)
        _save_figure(plot_vertical_estimate(truth_as_estimate), plot)


@vertical_app.command("estimate")
def estimate(
    log: Path = typer.Argument(..., help="Sensor log (.csv or .parquet): time, ax, ay, yaw_rate, dz21_FL..RR "
                                         "(+ body_accel_* or wheel_accel_*), see docs/vehicle-vertical.md."),
    output: Path = typer.Option(..., "--output", "-o", help="States file to write (.csv or .parquet)."),
    config: int = typer.Option(1, "--config", help="Sensor configuration of the log (1, 2 or 3)."),
    centralised: bool = typer.Option(False, "--centralised/--per-corner",
                                     help="Centralised full-car EKF instead of the thesis's four corner EKFs."),
    mr_map_velocity: str = typer.Option("displacement", "--mr-map-velocity", help=_MR_VELOCITY_HELP),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw the estimated states (PNG); the truth is "
                                                          "overlaid when the log has true_* columns."),
):
    """Estimate damper displacement/velocity, tyre load, body and wheel velocities from a sensor log."""
    from ..io import read_table, write_table
    from ..vehicle import estimate_to_frame, estimate_vertical_states, sensors_from_frame

    out = check_output_path(output, log, suffixes=TABLE_SUFFIXES)
    check_plot_path(plot, log)
    mr_map_velocity = _mr_map_velocity(mr_map_velocity)
    frame = read_table(log)
    sensors = sensors_from_frame(frame, config, source=str(log))
    mr_map = None
    if sensors.damper_current is not None:
        from ..vehicle._vertical_estimate import nominal_mr_map
        from ..vehicle._vertical_model import MRDamperParams

        # MagneRide log: the logged currents through the default nominal map (docs: "MagneRide car")
        mr_map = nominal_mr_map(MRDamperParams())
        console.print(f"log has current_* columns: actuator forces from the nominal MR map, evaluated at the "
                      f"{'filter' if mr_map_velocity == 'filter' else 'displacement'}-derived damper velocity")
    with console.status("running the corner EKFs..."):
        est = estimate_vertical_states(sensors, decentralised=not centralised, mr_map=mr_map,
                                       mr_map_velocity=mr_map_velocity)
    write_table(estimate_to_frame(est), out)
    console.print(f"wrote {out} ({est.time.size} samples, config {config}, {est.method})")
    if plot is not None:
        from ..vehicle import plot_vertical_estimate

        _save_figure(plot_vertical_estimate(est, frame), plot)


@vertical_app.command("tables")
def tables(
    output: Path = typer.Option(..., "--output", "-o", help="Table to write (.csv or .parquet): test, config, "
                                                            "variable, epsilon, epsilon_all_corners, thesis, "
                                                            "reference, car."),
    duration: float = typer.Option(30.0, "--duration", help="Length of each test run, s."),
    seed: int = typer.Option(0, "--seed", help="Seed of the roads and the sensor noises."),
    reference: str = typer.Option("truth", "--reference", help="Score against the simulator's truth, or against "
                                                               "the thesis's references rebuilt from measured "
                                                               "signals (integrated accelerometers): truth|thesis."),
    car: str = typer.Option("ideal", "--car", help="ideal (passive simulated car) or magneride (MR dampers + "
                                                   "skyhook; the filters get the logged currents through a nominal "
                                                   "map with a 12 % force error, no lag)."),
    mr_map_velocity: str = typer.Option("displacement", "--mr-map-velocity", help=_MR_VELOCITY_HELP),
    plot: Path | None = typer.Option(None, "--plot", help="Also draw ours next to the thesis's numbers (PNG)."),
):
    """Reproduce the thesis's result tables 4.4 (bench) and 4.5 (track) on the simulator, configurations 1-3."""
    from ..io import write_table
    from ..vehicle import reproduce_thesis_tables

    out = check_output_path(output, suffixes=TABLE_SUFFIXES)
    check_plot_path(plot)
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
        from ..vehicle._vertical_plot import plot_thesis_tables

        _save_figure(plot_thesis_tables(table), plot)


def register(app: typer.Typer) -> None:
    """Attach the ``vertical`` sub-group to the ``vehicle`` group."""
    app.add_typer(vertical_app, name="vertical")
