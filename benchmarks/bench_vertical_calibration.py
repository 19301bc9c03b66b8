"""Vertical states: do the calibrated 90 % bands of the corner EKFs cover the truth 90 % of the time? (session 41)

``estimate_vertical_states(...).calibrated_std`` (and the ``*_std`` columns of ``vehicle vertical estimate``) inflate
the filters' model stds from the windowed NIS of each corner's sensors (:func:`calibrated_vertical_std`). The map
was fitted (:func:`fit`) on ``collect(300, seed=1)``; ``run`` scores it on drives of seed 7, never used for the fit.

Drives (:func:`_drive`), one family each in turn, configurations 1-3, the road test (3 of 5), the track test and the
4-poster sweep, ISO 8608 classes A-D, 5-35 m/s, 6-16 s:
* ``nominal``: the thesis car, the simulator's sensors;
* ``car error``: the simulated car's mass, springs, tyre stiffness and wheel masses each x U(0.8, 1.2), the filter
  keeping the thesis car;
* ``sensor noise``: displacement noise x U(0.5, 4), body and wheel accelerometer noise x U(0.5, 5) / U(0.5, 3),
  and an accelerometer offset U(-0.15, 0.15) m/s^2;
* ``sample rate``: 2 kHz or 500 Hz (the filters' settings follow the rate);
* ``magneride``: the MR-damper car, the filter with the nominal map (12 % force error, no lag).

Rows: the share of the samples (after the first second: the filters' start) inside ``estimate +- 1.645 std`` per
configuration and state, target 85-95 %, then per family (all configurations); the model stds' coverage for
comparison (no target).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from benchmarks._common import BenchRow, CoverageScore

AREA = "vertical_calibration"
FAMILIES = ("nominal", "car error", "sensor noise", "sample rate", "magneride")
#: state -> (truth attribute of the simulation, column of the corner state, estimate attribute)
STATES = {"suspension_deflection": ("suspension_deflection", 1), "suspension_velocity": ("suspension_velocity", 0),
          "tyre_deflection": ("tyre_deflection", 3), "tyre_force": ("tyre_force", 3)}
SKIP = 1.0  # s left out at the start of each drive (the filters' initial transient)


def _drive(rng, family: str):
    """One random drive of ``family``: (description dict, simulation, sensors, MR map of the filter or None)."""
    from longprofile.vehicle import MRDamperParams, VerticalVehicleParams, measure_vertical, vertical_test_run
    from longprofile.vehicle.vertical import nominal_mr_map

    config = int(rng.integers(1, 4))
    test = str(rng.choice(["road", "road", "road", "track", "sweep"]))
    cls = str(rng.choice(list("ABCD")))
    speed, duration = float(rng.uniform(5.0, 35.0)), float(rng.uniform(6.0, 16.0))
    car, dt, mr, noise, offset = VerticalVehicleParams(), 1e-3, None, {}, 0.0
    if family == "car error":
        names = ("total_mass", "spring_stiffness_front", "spring_stiffness_rear", "tyre_stiffness",
                 "wheel_mass_front", "wheel_mass_rear")
        car = replace(car, **{k: getattr(car, k) * float(rng.uniform(0.8, 1.2)) for k in names})
    elif family == "sensor noise":
        noise = {"displacement_noise": 1.45e-4 * float(rng.uniform(0.5, 4.0)),
                 "wheel_accel_noise": 0.25 * float(rng.uniform(0.5, 3.0)),
                 "body_accel_noise": 0.02 * float(rng.uniform(0.5, 5.0))}
        offset = float(rng.uniform(-0.15, 0.15))
    elif family == "sample rate":
        dt = float(rng.choice([0.5e-3, 2e-3]))
    elif family == "magneride":
        mr = MRDamperParams()
    seed = int(rng.integers(0, 10 ** 6))
    sim, sensors = vertical_test_run(config, test=test, road_class=cls, speed=speed, duration=duration, seed=seed,
                                     dt=dt, params=car, mr_damper=mr)
    if noise:
        sensors = measure_vertical(sim, config, rng=seed + 1, **noise)
        key = {2: "body_accel", 3: "wheel_accel"}.get(config)
        if key:
            sensors = replace(sensors, **{key: getattr(sensors, key) + offset})
    what = dict(family=family, config=config, test=test, road_class=cls, speed=speed, duration=duration, dt=dt)
    return what, sim, sensors, (nominal_mr_map(mr) if mr is not None else None)


def _errors(rng, family):
    """One drive: (description, {state: (error, model std, calibrated std)} after SKIP s, the windowed NIS there)."""
    from longprofile.vehicle import VerticalVehicleParams, estimate_vertical_states

    what, sim, sensors, mr_map = _drive(rng, family)
    est = estimate_vertical_states(sensors, mr_map=mr_map, store_covariances=False)  # the filter: the thesis car
    k0 = int(round(SKIP / sensors.dt))
    cal = est.calibrated_std
    out = {}
    for name, (truth, col) in STATES.items():
        model_std = est.state_std[k0:, col::4] * (VerticalVehicleParams().tyre_stiffness if name == "tyre_force" else 1)
        out[name] = (getattr(est, name)[k0:] - getattr(sim, truth)[k0:], model_std, getattr(cal, name)[k0:])
    return what, out, cal.nis[k0:]


def collect(n: int, seed: int = 1, *, every: int = 10) -> list:
    """Per drive (families in turn): config, family and, every ``every`` samples, the log NIS of each corner's
    displacement (kd) and accelerometer (ka) and log|error / model std| per state: the data :func:`fit` takes."""
    rng = np.random.default_rng(seed)
    recs = []
    for i in range(n):
        what, out, nis = _errors(rng, FAMILIES[i % len(FAMILIES)])
        lognis = np.log(np.maximum(nis[::every], 1e-3))
        rec = dict(what, kd=lognis[:, :4], ka=lognis[:, 4:] if lognis.shape[1] > 4 else np.zeros_like(lognis))
        for name, (err, model_std, _) in out.items():
            rec[name] = np.log(np.maximum(np.abs(err[::every]) / model_std[::every], 1e-12))
        recs.append(rec)
    return recs


def fit(records: list, coverage: float = 0.9) -> dict:
    """The map of ``VERTICAL_STD_CALIBRATION`` from :func:`collect`'s records: per configuration and state, slopes by
    least squares of log|z| on (log kd, log ka, log(dt / 1 ms)), then the intercept a by bisection so that
    ``coverage`` of the pooled samples satisfy |z| <= 1.645 max(1, exp(a) kd^b_d ka^b_a (dt / 1 ms)^b_r)."""
    from scipy.stats import norm

    zq = float(norm.ppf(0.5 + coverage / 2))
    table = {}
    for config in (1, 2, 3):
        recs = [r for r in records if r["config"] == config]
        table[config] = {}
        if not recs:
            continue
        X = np.concatenate([np.stack([r["kd"].ravel(), r["ka"].ravel(),
                                      np.full(r["kd"].size, np.log(r["dt"] / 1e-3))], 1) for r in recs])
        if config == 1:
            X[:, 1] = 0.0
        used = [0, 1, 2] if config > 1 else [0, 2]
        for name in ("suspension_velocity", "suspension_deflection", "tyre_deflection"):
            lz = np.concatenate([r[name].ravel() for r in recs])
            coef = np.linalg.lstsq(np.c_[np.ones(len(lz)), X[:, used]], lz, rcond=None)[0]
            slopes = np.zeros(3)
            slopes[used] = coef[1:]
            lo, hi = -5.0, 8.0
            for _ in range(60):
                a = 0.5 * (lo + hi)
                inside = np.mean(lz <= np.log(zq) + np.maximum(a + X @ slopes, 0.0))
                lo, hi = (a, hi) if inside < coverage else (lo, a)
            table[config][name] = (round(float(hi), 2),) + tuple(round(float(b), 2) for b in slopes)
    return table


def score(n: int, seed: int = 7) -> dict:
    """CoverageScore of the calibrated and of the model stds per (configuration or family, state) on ``n`` drives."""
    rng = np.random.default_rng(seed)
    scores = {}
    for i in range(n):
        family = FAMILIES[i % len(FAMILIES)]
        what, out, _ = _errors(rng, family)
        for name, (err, model_std, cal_std) in out.items():
            for key in ((f"config {what['config']}", name), (family, name)):
                scores.setdefault(("calibrated",) + key, CoverageScore()).add(err, cal_std)
                scores.setdefault(("model",) + key, CoverageScore()).add(err, model_std)
    return scores


def run(quick: bool = False) -> list[BenchRow]:
    n = 5 if quick else 150
    scores = score(n)
    rows = []
    for (kind, group, name), sc in sorted(scores.items(), key=lambda kv: (kv[0][0] != "calibrated", kv[0][1:])):
        calibrated = kind == "calibrated"
        if not calibrated and not group.startswith("config"):
            continue
        rows.append(BenchRow(AREA, f"{name} 90 % band, {group}{'' if calibrated else ', model std'}",
                             100 * sc.coverage, "%", target=85.0 if calibrated else None,
                             target_max=95.0 if calibrated else None,
                             detail=sc.detail() + f"; RMS error {sc.rms_error:.3g}; {n} drives of seed 7"))
    return rows
