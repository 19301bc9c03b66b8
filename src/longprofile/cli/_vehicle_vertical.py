"""``longprofile vehicle vertical simulate|estimate`` (thesis 003: vertical states from suspension sensors)."""

from __future__ import annotations

from pathlib import Path

import typer

from ._common import check_output_path, check_plot_path, console

vertical_app = typer.Typer(help="Vertical (suspension) states: 7-DOF car simulator and the per-corner EKFs of "
                                "thesis 003.", no_args_is_help=True)


def _save_figure(fig, path: Path):
    out = check_output_path(path)
    fig.savefig(out, dpi=110)
    console.print(f"wrote {out}")


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
    plot: Path | None = typer.Option(None, "--plot", help="Also draw the true states of the front-left corner (PNG)."),
):
    """Simulate the 7-DOF car on a thesis test and write the sensors of one configuration (plus true_* columns)."""
    from ..io import write_table
    from ..vehicle import sensors_to_frame, vertical_test_run

    out = check_output_path(output)
    check_plot_path(plot)
    with console.status("simulating the 7-DOF car..."):
        sim, sensors = vertical_test_run(config, test=test, road_class=road_class, speed=speed, duration=duration,
                                         seed=seed)
    frame = sensors_to_frame(sensors, sim)
    write_table(frame, out)
    console.print(f"wrote {out} ({sim.time.size} samples, config {config}, test {test})")
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
    plot: Path | None = typer.Option(None, "--plot", help="Also draw the estimated states (PNG); the truth is "
                                                          "overlaid when the log has true_* columns."),
):
    """Estimate damper displacement/velocity, tyre load, body and wheel velocities from a sensor log."""
    from ..io import read_table, write_table
    from ..vehicle import estimate_to_frame, estimate_vertical_states, sensors_from_frame

    out = check_output_path(output, log)
    check_plot_path(plot, log)
    frame = read_table(log)
    sensors = sensors_from_frame(frame, config, source=str(log))
    with console.status("running the corner EKFs..."):
        est = estimate_vertical_states(sensors, decentralised=not centralised)
    write_table(estimate_to_frame(est), out)
    console.print(f"wrote {out} ({est.time.size} samples, config {config}, {est.method})")
    if plot is not None:
        from ..vehicle import plot_vertical_estimate

        _save_figure(plot_vertical_estimate(est, frame), plot)


def register(app: typer.Typer) -> None:
    """Attach the ``vertical`` sub-group to the ``vehicle`` group."""
    app.add_typer(vertical_app, name="vertical")
