"""The ``[tolerances]`` table of a vehicle description file: the stated tolerances behind ``vehicle slope``'s stds.

The table's keys are fields of :class:`~longprofile.vehicle.SlopeUncertainty` (the stated errors of the car and its
sensors, not the filters' tuning); a key left out keeps its default. Relative stds are fractions (0.002 for 0.2 %):
a value that reads as a percentage, a negative one or one beyond a plausible bound is refused in one line.
"""

from __future__ import annotations

import math
from pathlib import Path

from ...errors import InputFormatError
from .._car import read_car_file

#: key -> (what it is, unit: "" for a relative std written as a fraction, largest plausible value, > 0 required).
#: The bounds only catch slips (a percentage, a unit): a rolling radius 10 % off is another tyre, a gyro offset of
#: 0.05 rad/s (3 deg/s) an uncalibrated sensor, an accelerometer offset of 2 m/s^2 (0.2 g) a unit error.
TOLERANCE_KEYS = {
    "mass_rel_std": ("mass", "", 0.5, False),
    "force_rel_std": ("tyre forces", "", 0.5, False),
    "radius_rel_std": ("common rolling radius", "", 0.1, False),
    "wheel_radius_rel_std": ("each wheel's radius against the others", "", 0.05, False),
    "gyro_bias_std": ("gyro offset", "rad/s", 0.05, False),
    "accel_gain_std": ("accelerometer scale", "", 0.2, False),
    "accel_offset_std": ("accelerometer offset", "m/s^2", 2.0, False),
    "gyro_offset_prior_std": ("gyro offset before the sensor calibration", "rad/s", 0.05, True),
    "wheel_scale_prior_std": ("wheel scale before the sensor calibration", "", 0.05, True),
}


def tolerances_from_table(table, source: str) -> dict:
    """The validated ``SlopeUncertainty`` keyword arguments of a ``[tolerances]`` table (a mapping of
    :data:`TOLERANCE_KEYS` to numbers); InputFormatError naming ``source`` and the key otherwise."""
    if not isinstance(table, dict):
        raise InputFormatError(f"{source}: 'tolerances' must be a table ([tolerances] with keys such as "
                               f"radius_rel_std = 0.002); got {table!r}.")
    out = {}
    for key, value in table.items():
        if key not in TOLERANCE_KEYS:
            raise InputFormatError(f"{source}: unknown key {key!r} in table 'tolerances'; expected "
                                   f"{sorted(TOLERANCE_KEYS)} (docs/vehicle-slope.md, \"Stated tolerances\").")
        out[key] = _checked(key, value, source)
    return out


def _checked(key: str, value, source: str) -> float:
    what, unit, top, positive = TOLERANCE_KEYS[key]
    name = f"{source}: tolerances.{key}"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputFormatError(f"{name} must be a number ({_kind(key)}); got {value!r}.")
    v = float(value)
    if not math.isfinite(v) or v < 0 or (positive and v == 0):
        off = "; 0 would turn the sensor calibration off: use --no-sensor-calibration" if positive else ""
        raise InputFormatError(f"{name} must be finite and {'> 0' if positive else '>= 0'} ({_kind(key)}{off}); "
                               f"got {value!r}.")
    if v > top:
        if unit:
            raise InputFormatError(f"{name} = {value!r} {unit} is beyond the plausible {top:g} {unit} for the {what} "
                                   f"(a std in {unit}, SI units); check the unit.")
        raise InputFormatError(f"{name} = {value!r} is too large: a relative std is a fraction, at most {top:g} "
                               f"({100 * top:g} %) for the {what}; a percentage? write {v / 100:g} for {v:g} %.")
    return v


def _kind(key: str) -> str:
    unit = TOLERANCE_KEYS[key][1]
    return f"a std in {unit}" if unit else "a relative std as a fraction: 0.002 for 0.2 %"


def load_tolerances(path) -> dict:
    """The validated ``SlopeUncertainty`` keyword arguments of the ``[tolerances]`` table of the vehicle description
    file ``path`` ({} without the table)."""
    path = Path(path)
    data = read_car_file(path)
    return tolerances_from_table(data["tolerances"], str(path)) if "tolerances" in data else {}


def describe_tolerances(unc, default) -> str:
    """One line: every :data:`TOLERANCE_KEYS` field of ``unc`` (a ``SlopeUncertainty``) by its key and value, those
    that differ from ``default``'s with the default beside them."""
    parts = []
    for key, (_, unit, _, _) in TOLERANCE_KEYS.items():
        v, d = getattr(unc, key), getattr(default, key)
        parts.append(f"{key} {_value(v, unit)}" + ("" if v == d else f" (default {_value(d, unit)})"))
    return ", ".join(parts)


def _value(v: float, unit: str) -> str:
    return f"{100 * v:.3g} %" if not unit else f"{v:.3g} {unit}"
