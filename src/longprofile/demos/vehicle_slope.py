"""``make demo`` step: vehicle states and road slope on simulated drives (paper 001)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

__all__ = ["run_demo"]


def run_demo(outdir: Path) -> list[Path]:
    """Simulate the hill and paper drives, estimate states and slope, study the sensitivity to the model.

    Writes under ``outdir/vehicle/``:

    * ``slope_hill.png`` / ``slope_hill.csv`` -- cascade estimate on the hill drive (truth overlaid);
    * ``slope_accuracy.csv`` -- errors of both estimators on the three scenarios, with the paper's
      prototype figures for comparison;
    * ``slope_sensitivity.png`` / ``slope_sensitivity.csv`` -- slope error with a +-10 % mass error and
      with wrong adhesion, on the climbing part of the hill drive;
    * ``slope_speed_measurement.png`` / ``slope_speed_measurement.csv`` -- the paper's V_x measurement
      (mean rear-wheel speed) against the slip-robust one (:func:`speed_reference`, the default), on
      the three scenarios; the figure shows the hill drive, whose braking phase breaks the paper's.
    """
    from ..io import write_table
    from ..report import plot_sensitivity, plot_slope_estimate, plot_speed_measurement
    from ..vehicle.planar import (
        PAPER_PROTOTYPE_ERRORS,
        accuracy_scores,
        default_vehicle,
        drive_scenario,
        estimate_slope,
        sensitivity_study,
        simulate_drive,
        speed_measurement_study,
    )

    out = Path(outdir) / "vehicle"
    out.mkdir(parents=True, exist_ok=True)
    car = default_vehicle()
    written = []

    hill = simulate_drive("hill", car, seed=0)
    est = estimate_slope(hill.log, car, method="cascade")
    fig = plot_slope_estimate(est, hill.truth, title="Hill drive: EKF (20) + Luenberger observer (21), paper 001")
    path = out / "slope_hill.png"
    fig.savefig(path, dpi=110)
    written.append(path)
    frame = pd.concat([est.to_frame(), hill.truth.to_frame()[["true_vx", "true_vy", "true_yaw_rate", "true_slope"]]],
                      axis=1)
    written.append(write_table(frame, out / "slope_hill.csv"))

    rows = []
    for scenario in ("paper", "hill", "low-mu"):
        sim = hill if scenario == "hill" else simulate_drive(scenario, car, seed=0)
        for method in ("cascade", "joint"):
            e = est if (scenario == "hill" and method == "cascade") else estimate_slope(sim.log, car, method=method)
            rows.append({"scenario": scenario, "method": method} | accuracy_scores(sim, e))
    rows.append({"scenario": "paper prototype (V.B)", "method": "EKF + Luenberger",
                 "vx_rel": PAPER_PROTOTYPE_ERRORS["vx"], "vy_rel": PAPER_PROTOTYPE_ERRORS["vy"],
                 "yaw_rate_rel": PAPER_PROTOTYPE_ERRORS["yaw_rate"]})
    written.append(write_table(pd.DataFrame(rows), out / "slope_accuracy.csv"))

    table, runs = speed_measurement_study(car, seed=0)
    written.append(write_table(table, out / "slope_speed_measurement.csv"))
    fig = plot_speed_measurement(*runs["hill"])
    path = out / "slope_speed_measurement.png"
    fig.savefig(path, dpi=110)
    written.append(path)

    # sensitivity on the first 21 s of the hill drive (acceleration up the 6 % grade, then cruise): the
    # braking phase that follows adds the slip-compensation error of the V_x measurement (docs/vehicle-slope.md)
    climb = simulate_drive(drive_scenario("hill", duration=21.0), car, seed=0)
    table, errors = sensitivity_study(climb)
    written.append(write_table(table, out / "slope_sensitivity.csv"))
    fig = plot_sensitivity(climb, errors)
    path = out / "slope_sensitivity.png"
    fig.savefig(path, dpi=110)
    written.append(path)
    return written
