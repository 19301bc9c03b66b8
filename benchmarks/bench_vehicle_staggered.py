"""Staggered car (issue 14): estimator accuracy with the per-axle description vs the equal-axle (averaged) one.

Truth: the default car with ``wheels.radius = [0.30, 0.33]`` m (rear tyres 10 % larger) and
``wheels.cornering_stiffness = [44000, 55000]`` N/rad (front 20 % lower), every other value the default car's.
Each seed is one ``simulate_drive(drive, car, seed=seed)`` of a built-in drive (parallel steering, default
sensor model); ``estimate_slope`` then runs with

* ``right``    -- the staggered description (the truth's own values);
* ``averaged`` -- the same car described with equal axles, each pair replaced by its mean (radius 0.315 m,
  cornering stiffness 49500 N/rad): what a scalar-only car file would say;
* ``C_y avg``  -- radius right, only the cornering stiffness averaged (full run only).

RMS error of V_x, V_y (m/s) and the slope (deg) after the first 2 s, the mean over the seeds; the detail gives
the seeds' standard deviation and range. The ``averaged / right`` rows are the ratio of the two mean RMS errors
(target >= 1: the right description must be the better one; none for V_y on the straight "hill" drive, where
V_y stays within a few mm/s with either description).

Measured steer angles (full run only): the default car simulated with ``steering_geometry="ackermann"`` on a
20 s "turning" drive (sine steering of 0.12 rad at 0.2 Hz at 10 m/s, up to 0.42 g, flat then a 3 deg grade; road
adhesion 0.8 as the car file, or 0.9 to show a wrong adhesion), seeds 0-4; the cascade estimate from the log's
``steer_fl``/``steer_fr`` against the same log without them (``steering_angle`` only, the bicycle angle).

Run: ``python -m benchmarks vehicle_staggered`` (full: seeds 0-9 of the "paper", "hill" and "low-mu" drives,
cascade and joint EKF, plus the steer rows, ~2 min) or ``--quick`` (seed 0, 10 s of the "paper" drive, cascade).
"""

from __future__ import annotations

import numpy as np

from benchmarks._common import BenchRow

AREA = "vehicle_staggered"
SETTLE = 2.0


def cars():
    """(truth, {label: description}) of the study."""
    from longprofile.vehicle import default_vehicle

    base = default_vehicle()
    truth = base.with_changes(wheel_radius=(0.30, 0.33), cornering_stiffness=(44000.0, 55000.0))
    return truth, {"right": truth, "averaged": base.with_changes(wheel_radius=0.315, cornering_stiffness=49500.0),
                   "C_y avg": truth.with_changes(cornering_stiffness=49500.0)}


def measure(drive: str, method: str, seeds, *, duration: float | None = None, labels=("right", "averaged")):
    """{label: (n_seeds, 3) RMS errors of V_x (m/s), V_y (m/s), slope (deg)}."""
    from longprofile.vehicle import drive_scenario, estimate_slope, simulate_drive

    truth, descriptions = cars()
    out = {k: [] for k in labels}
    for seed in seeds:
        sim = simulate_drive(drive_scenario(drive, duration=duration), truth, seed=seed)
        tr, m = sim.truth, sim.log.time >= SETTLE
        for k in labels:
            est = estimate_slope(sim.log, descriptions[k], method=method)
            rms = [float(np.sqrt(np.mean((est.vx - tr.vx)[m] ** 2))), float(np.sqrt(np.mean((est.vy - tr.vy)[m] ** 2))),
                   float(np.degrees(np.sqrt(np.mean((est.slope - tr.slope)[m] ** 2))))]
            out[k].append(rms)
    return {k: np.array(v) for k, v in out.items()}


def turning_drive(amp=0.12, speed=10.0, duration=20.0, mu=0.8, dt=1e-3):
    """Sine steering at 0.2 Hz after a 1 s straight (2 s ramp), flat road then a 3 deg grade from 60 m."""
    from longprofile.vehicle import DriveScenario

    t = np.arange(int(round(duration / dt))) * dt
    steer = amp * np.sin(2 * np.pi * 0.2 * (t - 1.0)) * np.clip((t - 1.0) / 2.0, 0.0, 1.0)
    s = np.arange(0.0, 2000.0, 0.5)
    slope = np.radians(3.0) * np.clip((s - 60.0) / 60.0, 0.0, 1.0)
    return DriveScenario("turning", dt, np.full(t.size, speed), steer, s, slope, np.full((s.size, 2), mu), speed)


def measure_steer(scenario, seeds):
    """{"steer_fl/fr": ..., "steering_angle only": ...}: (n_seeds, 3) RMS of V_x, V_y (m/s), slope (deg)."""
    from dataclasses import replace

    from longprofile.vehicle import default_vehicle, estimate_slope, simulate_drive

    car = default_vehicle()
    out = {"steer_fl/fr": [], "steering_angle only": []}
    for seed in seeds:
        sim = simulate_drive(scenario, car, seed=seed, steering_geometry="ackermann")
        tr, m = sim.truth, sim.log.time >= SETTLE
        for k, log in (("steer_fl/fr", sim.log), ("steering_angle only", replace(sim.log, wheel_steering=None))):
            est = estimate_slope(log, car)
            out[k].append([float(np.sqrt(np.mean((est.vx - tr.vx)[m] ** 2))),
                           float(np.sqrt(np.mean((est.vy - tr.vy)[m] ** 2))),
                           float(np.degrees(np.sqrt(np.mean((est.slope - tr.slope)[m] ** 2))))])
    return {k: np.array(v) for k, v in out.items()}


def run(quick: bool) -> list[BenchRow]:
    rows = []
    if quick:
        cases, seeds, duration, labels = [("paper", "cascade")], range(1), 10.0, ("right", "averaged")
    else:
        cases = [(d, m) for d in ("paper", "hill", "low-mu") for m in ("cascade", "joint")]
        seeds, duration, labels = range(10), None, ("right", "averaged", "C_y avg")
    for drive, method in cases:
        res = measure(drive, method, seeds, duration=duration, labels=labels)
        for j, (q, unit) in enumerate((("V_x", "m/s"), ("V_y", "m/s"), ("slope", "deg"))):
            for k in labels:
                a = res[k][:, j]
                sd = float(a.std(ddof=1)) if a.size > 1 else 0.0
                rows.append(BenchRow(AREA, f"{drive} / {method}: {q} RMS error, {k}", float(a.mean()), unit, None, False,
                                     f"{a.size} seed(s): sd {sd:.2g}, range {a.min():.4g}..{a.max():.4g}"))
            ratio = float(res["averaged"][:, j].mean() / res["right"][:, j].mean())
            better = int(np.sum(res["right"][:, j] < res["averaged"][:, j]))
            straight = drive == "hill" and q == "V_y"  # no steering: V_y ~ 1 mm/s either way, no target
            rows.append(BenchRow(AREA, f"{drive} / {method}: {q} RMS averaged / right", ratio, "x",
                                 None if straight else 1.0, True,
                                 f"right better on {better}/{len(res['right'])} seeds"
                                 + ("; straight drive, V_y not excited" if straight else "")))
    if not quick:
        for label, mu in (("turning, Ackermann", 0.8), ("turning, Ackermann, road mu 0.9 (car 0.8)", 0.9)):
            res = measure_steer(turning_drive(mu=mu), range(5))
            for j, (q, unit) in enumerate((("V_x", "m/s"), ("V_y", "m/s"), ("slope", "deg"))):
                for k, a in res.items():
                    a = a[:, j]
                    rows.append(BenchRow(AREA, f"{label}: {q} RMS error, {k}", float(a.mean()), unit, None, False,
                                         f"{a.size} seeds: sd {a.std(ddof=1):.2g}, range {a.min():.4g}..{a.max():.4g}"))
    return rows
