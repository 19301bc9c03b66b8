"""Vertical logs: is each suspension deflection sensor zeroed at the static ride height? (session 37)

``vehicle vertical estimate`` warns when :func:`longprofile.vehicle.vertical.deflection_zero_check` finds an
offset beyond ``DEFLECTION_OFFSET_LIMIT`` (5 mm) on a ``dz21_*`` channel. The limit was chosen on drives of seed 11
(``score(120, seed=11)``: offsets within 2.61 mm on zeroed sensors); ``run`` scores it on seed 12: ISO 8608 classes
A-E, 5-40 m/s, 2-30 s, the road, track and 4-poster sweep tests (the sweep was not in the choice), passive and
MagneRide cars, configurations 1-3, through :func:`estimate_vertical_log` as the command runs it.

Rows:
* false alarms: share of the drives with sensors zeroed at the static ride height that are warned about;
* the largest offset found on those drives, mm (the limit is 5 mm);
* the mean deflection's largest magnitude on those drives, mm: why the mean itself is no test (the asymmetric
  dampers pull the car down on a rough road);
* detected: share of the same drives warned about with a zero offset added to the deflections (+-20 mm and
  +-10 mm on every corner, 8 mm on one corner of either sign), with the channels named right.
* sign (session 38): drives of configurations 2 and 3 whose zeroed, right-signed deflections are called "sign
  inverted?" (false alarms), and the share of them called so, every corner named, with all four deflections negated
  (logged positive in compression), per configuration.
"""

from __future__ import annotations

import numpy as np

from benchmarks._common import BenchRow

AREA = "vertical_zero_check"


def _drive(rng):
    """One random drive: (description, simulation, sensors)."""
    from longprofile.vehicle import MRDamperParams, vertical_test_run

    cls = str(rng.choice(list("ABCDE")))
    speed = float(rng.uniform(5.0, 40.0))
    duration = float(rng.uniform(2.0, 30.0))
    test = str(rng.choice(["road", "road", "track", "sweep"]))
    magneride = bool(rng.integers(0, 2))
    config = int(rng.integers(1, 4))
    seed = int(rng.integers(0, 10 ** 6))
    sim, sensors = vertical_test_run(config, test=test, road_class=cls, speed=speed, duration=duration, seed=seed,
                                     mr_damper=MRDamperParams() if magneride else None)
    what = f"{test} class {cls} {speed:.0f} m/s {duration:.0f} s {'magneride' if magneride else 'passive'}"
    return what, sensors


def score(n: int, seed: int = 12) -> dict:
    """False alarms and detections of the zero check on ``n`` random drives (see the module notes)."""
    from dataclasses import replace

    from longprofile.vehicle import estimate_vertical_log
    from longprofile.vehicle.vertical import DEFLECTION_OFFSET_LIMIT, deflection_zero_check

    rng = np.random.default_rng(seed)
    offsets = {"+20 mm all": (0.02,) * 4, "-20 mm all": (-0.02,) * 4, "+10 mm all": (0.01,) * 4,
               "-10 mm all": (-0.01,) * 4, "8 mm one corner": None}
    alarms, found_clean, worst_mean, worst_what = 0, [], 0.0, ""
    detected = dict.fromkeys(offsets, 0)
    sign = {"false": 0, 2: [0, 0], 3: [0, 0]}  # per config: [drives, inverted logs with every corner named]
    for _ in range(n):
        what, sensors = _drive(rng)
        res = estimate_vertical_log(sensors)
        check = res.deflection_check
        alarms += bool(check.suspect)
        if sensors.config in (2, 3):
            sign["false"] += bool(check.inverted.any())
            # the MR map's force is odd in the damper velocity: the negated log's actuator force is its negative
            flipped = deflection_zero_check(replace(sensors, displacement=-sensors.displacement),
                                            actuator_force=-res.estimate.actuator_force)
            sign[sensors.config][0] += 1
            sign[sensors.config][1] += bool(flipped.inverted.all())
        if not found_clean or np.max(np.abs(check.offset)) > max(found_clean):
            worst_what = what
        found_clean.append(float(np.max(np.abs(check.offset))))
        worst_mean = max(worst_mean, float(np.max(np.abs(check.mean))))
        for name, add in offsets.items():
            if add is None:
                add = np.zeros(4)
                add[int(rng.integers(0, 4))] = 0.008 * float(rng.choice([-1.0, 1.0]))
            add = np.asarray(add)
            found = deflection_zero_check(replace(sensors, displacement=sensors.displacement + add),
                                          actuator_force=res.estimate.actuator_force)
            named = np.abs(found.offset) > DEFLECTION_OFFSET_LIMIT
            detected[name] += bool(np.array_equal(named, add != 0))
    return {"n": n, "alarms": alarms, "found": np.array(found_clean), "worst_what": worst_what,
            "worst_mean": worst_mean, "detected": detected, "sign": sign}


def run(quick: bool = False) -> list[BenchRow]:
    n = 2 if quick else 50
    s = score(n)
    p50, p90 = np.percentile(1e3 * s["found"], [50, 90])
    rows = [
        BenchRow(AREA, "false alarms, sensors zeroed at the static ride height", 100.0 * s["alarms"] / n, "%",
                 target=5.0, higher_is_better=False, detail=f"{s['alarms']} of {n} drives, seed 12"),
        BenchRow(AREA, "largest offset found on those drives", 1e3 * float(s["found"].max()), "mm",
                 detail=f"{s['worst_what']}; per drive median {p50:.2f}, 90 % {p90:.2f} mm"),
        BenchRow(AREA, "largest |mean deflection| on those drives (no test by itself)", 1e3 * s["worst_mean"], "mm"),
    ]
    for name, k in s["detected"].items():
        rows.append(BenchRow(AREA, f"detected and named: {name}", 100.0 * k / n, "%", target=95.0,
                             detail=f"{k} of {n} drives"))
    sign = s["sign"]
    m = sign[2][0] + sign[3][0]
    rows.append(BenchRow(AREA, "sign inverted? on right-signed deflections (configs 2, 3)",
                         100.0 * sign["false"] / max(m, 1), "%", target=5.0, higher_is_better=False,
                         detail=f"{sign['false']} of {m} drives"))
    for config, target in ((2, 95.0), (3, 80.0)):
        k, total = sign[config][1], sign[config][0]
        rows.append(BenchRow(AREA, f"deflections negated: sign inverted? on every corner, config {config}",
                             100.0 * k / max(total, 1), "%", target=target, detail=f"{k} of {total} drives"))
    return rows
