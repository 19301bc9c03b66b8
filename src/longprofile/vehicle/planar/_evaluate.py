"""Accuracy and sensitivity studies of the slope estimators on simulated drives (demo, benchmark, docs)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ._estimate import estimate_slope

__all__ = ["accuracy_scores", "PAPER_PROTOTYPE_ERRORS", "sensitivity_study", "speed_measurement_study"]

#: Relative estimation errors reported on the prototype vehicle (paper 001, section V.B).
PAPER_PROTOTYPE_ERRORS = {"vx": 0.04, "vy": 0.05, "yaw_rate": 0.075}


def accuracy_scores(simulation, estimate, *, settle: float = 2.0) -> dict:
    """Errors of an estimate against the truth after ``settle`` seconds (issue 6 definitions).

    Returns a dict: ``slope_rms_deg`` (RMS error, degrees), ``vx_rel``, ``vy_rel``, ``yaw_rate_rel``
    (RMS error / RMS of the true signal), ``vy_rms`` (m/s), ``slope_max_deg``, ``fx_rms`` (N, all wheels).
    """
    tr = simulation.truth
    m = simulation.log.time >= settle

    def rms(a):
        return float(np.sqrt(np.mean(np.square(a[m]))))

    def rel(key):
        ref = rms(getattr(tr, key))
        return rms(getattr(estimate, key) - getattr(tr, key)) / ref if ref > 0 else float("nan")

    e_slope = np.degrees(estimate.slope - tr.slope)
    return {"slope_rms_deg": rms(e_slope), "slope_max_deg": float(np.abs(e_slope[m]).max()),
            "vx_rel": rel("vx"), "vy_rel": rel("vy"), "yaw_rate_rel": rel("yaw_rate"),
            "vy_rms": rms(estimate.vy - tr.vy), "fx_rms": rms(estimate.fx - tr.fx)}


def sensitivity_study(simulation, *, method: str = "cascade", mass_factors=(0.9, 1.1),
                      friction_values=(0.5, 1.1)) -> tuple[pd.DataFrame, dict]:
    """Slope error when the estimator's mass or adhesion is wrong.

    Runs :func:`estimate_slope` on ``simulation.log`` with the true vehicle, with the mass scaled by
    each of ``mass_factors``, and with the adhesion of all wheels set to each of ``friction_values``.

    Returns
    -------
    table : pandas.DataFrame
        One row per case: ``case``, ``slope_rms_deg``, ``slope_bias_deg``, ``slope_max_deg`` (after 2 s).
    errors : dict
        case -> (T,) slope error in degrees (for plotting).
    """
    car = simulation.vehicle
    tr = simulation.truth
    m = simulation.log.time >= 2.0
    cases = {"nominal": estimate_slope(simulation.log, car, method=method)}
    for f in mass_factors:
        cases[f"mass x{f:g}"] = estimate_slope(simulation.log, car.with_changes(mass=f * car.mass), method=method)
    for mu in friction_values:
        cases[f"mu = {mu:g}"] = estimate_slope(simulation.log, car, method=method, friction=np.full(4, mu))
    errors = {k: np.degrees(v.slope - tr.slope) for k, v in cases.items()}
    rows = [{"case": k, "slope_rms_deg": float(np.sqrt(np.mean(e[m] ** 2))), "slope_bias_deg": float(e[m].mean()),
             "slope_max_deg": float(np.abs(e[m]).max())} for k, e in errors.items()]
    return pd.DataFrame(rows), errors


def speed_measurement_study(vehicle=None, *, scenarios=("paper", "hill", "low-mu"), seed=0,
                            settle: float = 2.0) -> tuple[pd.DataFrame, dict]:
    """Errors of both estimators with the paper's V_x measurement and with the slip-robust one.

    Simulates each scenario with ``vehicle`` (default car) and sensor seed ``seed``, then runs
    :func:`estimate_slope` with ``speed_measurement="rear-mean"`` and ``"robust"`` for the cascade and
    the joint EKF.

    Returns
    -------
    table : pandas.DataFrame
        One row per (scenario, method, speed_measurement): the :func:`accuracy_scores` after
        ``settle`` seconds, plus ``speed_rms`` (m/s, error of the V_x measurement where present),
        ``compensated_fraction`` and ``missing_fraction`` of the samples (see
        :func:`longprofile.vehicle.speed_reference`).
    runs : dict
        scenario -> (simulation, {(method, speed_measurement): SlopeEstimate}) (for plotting).
    """
    from ._params import default_vehicle
    from ._simulate import simulate_drive
    from ._speed_reference import speed_reference

    car = default_vehicle() if vehicle is None else vehicle
    rows = []
    runs = {}
    for scenario in scenarios:
        sim = simulate_drive(scenario, car, seed=seed)
        m = sim.log.time >= settle
        ests = {}
        for sm in ("rear-mean", "robust"):
            ref = speed_reference(sim.log, car, method=sm)
            err = (ref.speed - sim.truth.vx)[m]
            for method in ("cascade", "joint"):
                est = estimate_slope(sim.log, car, method=method, speed_measurement=sm)
                ests[(method, sm)] = est
                rows.append({"scenario": scenario, "method": method, "speed_measurement": sm}
                            | accuracy_scores(sim, est, settle=settle)
                            | {"speed_rms": float(np.sqrt(np.nanmean(err ** 2))),
                               "compensated_fraction": float(np.mean(ref.source[m] == 2)),
                               "missing_fraction": float(np.mean(ref.source[m] == 0))})
        runs[scenario] = (sim, ests)
    return pd.DataFrame(rows), runs
