"""Plausibility of a vehicle description's values: a value in the wrong unit is refused, not estimated with.

A car file in the wrong unit (cornering stiffness in N/deg, a mass in tonnes, a height in mm, a rolling radius
given as the diameter) used to load and give wrong states silently. Each key of the car file has a plausible range
for passenger cars and light trucks (:data:`RANGES`), and the cross-key checks (:data:`CROSS_CHECKS`) catch what a
single value cannot tell: a tyre stiffness per axle instead of per tyre, a yaw inertia off the car's size, a
centre of gravity too high for the track. A value outside is refused in one line naming the key, its value, the
range and the likely slip. An exotic vehicle (a race car, a heavy truck) goes on with an explicit ``[checks]``
table: ``accept = ["body.mass", "cornering_stiffness_per_load"]`` names the keys and cross checks to skip.

Sources of the ranges (docs/vehicle-slope.md, "Plausible values"): the vehicle classes M1 and N1 (passenger cars and
light commercial vehicles up to 3.5 t, EU 2018/858) with margins; Gillespie, *Fundamentals of Vehicle Dynamics*
(1992), ch. 6 (cornering stiffness about 0.1-0.3 of the load per degree), ch. 9 (static stability factor); Pacejka,
*Tire and Vehicle Dynamics* (3rd ed. 2012), ch. 4 (Magic Formula: cornering stiffness K_y = p_Ky1 F_z0
sin(2 atan(F_z / (p_Ky2 F_z0))), at most 2 p_Ky1 / p_Ky2 ~ 20-30 times the load per rad; longitudinal slip
stiffness ~ 15-30 times the load); Milliken & Milliken, *Race Car Vehicle Dynamics* (1995), ch. 5 (dynamic index
I_z / (m l_f l_r) ~ 0.8-1.2); NHTSA rollover ratings (static stability factor T / 2h: SUVs 1.0-1.3, cars 1.3-1.7).
"""

from __future__ import annotations

import math

from ...errors import InputFormatError

__all__ = ["RANGES", "CROSS_CHECKS", "implausible_values", "check_plausible", "accepted_checks"]

#: TOML key -> (Vehicle attribute, unit, lowest plausible, highest plausible, reason).
RANGES = {
    "body.mass": ("mass", "kg", 300.0, 5000.0, "a microcar to a loaded 3.5 t van or pickup"),
    "body.yaw_inertia": ("yaw_inertia", "kg m^2", 100.0, 30000.0, "about m l_f l_r, the check yaw_inertia_ratio"),
    "body.cg_to_front_axle": ("cg_to_front_axle", "m", 0.3, 3.0, "a share of a 1.5-4.5 m wheelbase"),
    "body.cg_to_rear_axle": ("cg_to_rear_axle", "m", 0.3, 3.0, "a share of a 1.5-4.5 m wheelbase"),
    "body.track": ("track", "m", 0.9, 2.2, "a city car to a wide pickup"),
    "body.cg_height": ("cg_height", "m", 0.2, 1.5, "a sports car to a loaded high-roof van"),
    "body.aero_longitudinal": ("aero_longitudinal", "N s^2/m^2", 0.0, 2.5,
                               "1/2 rho C_d A: 0.25-0.5 for cars, up to ~1.5 for vans"),
    "body.aero_lateral": ("aero_lateral", "N s^2/m^2", 0.0, 10.0, "the side area's 1/2 rho C_y A"),
    "body.steering_ratio": ("steering_ratio", "", 8.0, 30.0, "steering-wheel angle / road-wheel angle: 12-20 "
                            "for cars, up to ~25 for trucks"),
    "wheels.radius": ("wheel_radius", "m", 0.15, 0.5, "rolling radius of 10-inch to 37-inch tyres"),
    "wheels.inertia": ("wheel_inertia", "kg m^2", 0.1, 10.0, "one wheel with tyre and brake disc"),
    "wheels.longitudinal_stiffness": ("longitudinal_stiffness", "N", 1.0e4, 5.0e5,
                                      "each tyre, N per unit slip (1 = 100 % slip)"),
    "wheels.cornering_stiffness": ("cornering_stiffness", "N/rad", 1.0e4, 2.5e5, "each tyre, N per rad"),
    "drivetrain.engine_brake_torque": ("engine_brake_torque", "N m", 0.0, 5000.0,
                                       "overrun torque at the driven wheels, all gears"),
}

#: Cross-key check name -> (keys it reads, lowest, highest, what it is).
CROSS_CHECKS = {
    "wheelbase": (("body.cg_to_front_axle", "body.cg_to_rear_axle"), 1.5, 4.5, "l_f + l_r, m"),
    "yaw_inertia_ratio": (("body.yaw_inertia", "body.mass", "body.cg_to_front_axle", "body.cg_to_rear_axle"),
                          0.6, 1.5, "I_z / (m l_f l_r), the dynamic index (0.8-1.2 for most cars)"),
    "rollover_threshold": (("body.track", "body.cg_height"), 0.9, 3.5,
                           "track / (2 cg_height), the static stability factor in g"),
    "cornering_stiffness_per_load": (("wheels.cornering_stiffness", "body.mass", "body.cg_to_front_axle",
                                      "body.cg_to_rear_axle"), 4.0, 30.0,
                                     "each tyre's cornering stiffness / its static load, per rad"),
    "longitudinal_stiffness_per_load": (("wheels.longitudinal_stiffness", "body.mass", "body.cg_to_front_axle",
                                         "body.cg_to_rear_axle"), 4.0, 50.0,
                                        "each tyre's longitudinal stiffness / its static load, per unit slip"),
}

_GRAVITY = 9.80665
_LENGTH_SLIPS = (("mm? write", 1e-3), ("cm? write", 1e-2), ("inches? write", 0.0254))
#: TOML key -> the likely slips (label, factor): the value times the factor lies in the range.
_SLIPS = {
    "body.mass": (("tonnes? write", 1000.0), ("a weight in N? write", 1 / _GRAVITY), ("pounds? write", 0.4536)),
    "body.yaw_inertia": (("t m^2? write", 1000.0),),
    "body.cg_to_front_axle": _LENGTH_SLIPS,
    "body.cg_to_rear_axle": _LENGTH_SLIPS,
    "body.track": _LENGTH_SLIPS,
    "body.cg_height": _LENGTH_SLIPS,
    "body.steering_ratio": (("road-wheel / steering-wheel (the inverse)? write", None),),
    "wheels.radius": (("the diameter? give the radius: write", 0.5), ("mm? write", 1e-3), ("a diameter in mm? "
                      "give the radius: write", 5e-4), ("cm? write", 1e-2), ("inches? write", 0.0254)),
    "wheels.longitudinal_stiffness": (("N per % of slip? multiply by 100: write", 100.0), ("kN? write", 1000.0),
                                      ("per axle (both tyres)? give each tyre's: write", 0.5)),
    "wheels.cornering_stiffness": (("N/deg? multiply by 57.3: write", 180.0 / math.pi), ("kN/rad? write", 1000.0),
                                   ("per axle (both tyres)? give each tyre's: write", 0.5)),
    "drivetrain.engine_brake_torque": (("kN m? write", 1000.0),),
}


def _axles(value) -> tuple:
    return tuple(value) if isinstance(value, tuple) else (value,)


def _fmt(v: float) -> str:
    return f"{v:.0f}" if abs(v) >= 1000 else f"{v:.4g}"


def _slip(key: str, value: float, low: float, high: float) -> str:
    """The likely slip whose factor brings ``value`` into [low, high], as ``"tonnes? write 1500"``; "" if none."""
    for label, factor in _SLIPS.get(key, ()):
        fixed = 1.0 / value if factor is None else value * factor
        if low <= fixed <= high:
            return f"{label} {_fmt(fixed)}"
    return ""


def _range_problems(vehicle) -> list[tuple[str, str]]:
    out = []
    for key, (attr, unit, low, high, why) in RANGES.items():
        value = getattr(vehicle, attr, None)
        if value is None:
            continue
        values = _axles(value)
        for i, v in enumerate(values):
            if low <= v <= high:
                continue
            name = key if len(values) == 1 else f"{key}[{('front', 'rear')[i]}]"
            u = f" {unit}" if unit else ""
            slip = _slip(key, v, low, high)
            out.append((key, f"{name} = {_fmt(v)}{u} is outside the plausible {_fmt(low)}..{_fmt(high)}{u} of a "
                             f"passenger car or light truck ({why})" + (f": {slip}" if slip else ": check its unit")))
    return out


def _static_loads(vehicle) -> tuple[float, float]:
    """Each front and rear tyre's static vertical load, N: M g l_r / (2 L) and M g l_f / (2 L)."""
    L = vehicle.cg_to_front_axle + vehicle.cg_to_rear_axle
    w = vehicle.mass * _GRAVITY / (2.0 * L)
    return w * vehicle.cg_to_rear_axle, w * vehicle.cg_to_front_axle


def _stiffness_per_load(name, key, stiffnesses, loads, low, high, unit) -> list[tuple[str, str]]:
    out = []
    for axle, c, fz in zip(("front", "rear"), stiffnesses, loads):
        ratio = c / fz
        if low <= ratio <= high:
            continue
        fix = ""
        if ratio > high and low <= ratio / 2 <= high:
            fix = f": per axle (both tyres)? give each tyre's: write {_fmt(c / 2)}"
        elif ratio < low and name.startswith("cornering") and low <= ratio * 180 / math.pi <= high:
            fix = f": N/deg? multiply by 57.3: write {_fmt(c * 180 / math.pi)}"
        elif ratio < low and low <= ratio * 100 <= high:
            fix = f": N per % of slip? multiply by 100: write {_fmt(c * 100)}"
        out.append((name, f"{key} = {_fmt(c)} {unit} on a {axle} tyre carrying {fz:.0f} N (body.mass, l_f, l_r) is "
                          f"{ratio:.3g} times its load, outside the plausible {low:g}..{high:g} ({name})" +
                    (fix or ": check the mass and the stiffness's unit (each tyre, SI)")))
    return out


def _cross_problems(vehicle) -> list[tuple[str, str]]:
    out = []
    lf, lr, m = vehicle.cg_to_front_axle, vehicle.cg_to_rear_axle, vehicle.mass
    L = lf + lr
    low, high = CROSS_CHECKS["wheelbase"][1:3]
    if not low <= L <= high:
        out.append(("wheelbase", f"body.cg_to_front_axle + body.cg_to_rear_axle = {_fmt(L)} m, a wheelbase outside "
                                 f"the plausible {low:g}..{high:g} m (wheelbase): l_f and l_r are the centre of "
                                 "gravity's distances to the axles, in m"))
    low, high = CROSS_CHECKS["yaw_inertia_ratio"][1:3]
    ratio = vehicle.yaw_inertia / (m * lf * lr)
    if not low <= ratio <= high:
        out.append(("yaw_inertia_ratio", f"body.yaw_inertia = {_fmt(vehicle.yaw_inertia)} kg m^2 is {ratio:.3g} "
                                         f"times m l_f l_r = {m * lf * lr:.0f} kg m^2, outside the plausible "
                                         f"{low:g}..{high:g} (yaw_inertia_ratio; 0.8-1.2 for most cars): I_z is about "
                                         f"{m * lf * lr:.0f} kg m^2 for this mass and axle layout"))
    low, high = CROSS_CHECKS["rollover_threshold"][1:3]
    tracks = _axles(vehicle.track)
    ssf = (sum(tracks) / len(tracks)) / (2.0 * vehicle.cg_height)
    if not low <= ssf <= high:
        out.append(("rollover_threshold", f"body.track / (2 body.cg_height) = {ssf:.3g} g, a static rollover "
                                          f"threshold outside the plausible {low:g}..{high:g} (rollover_threshold; "
                                          "SUVs 1.0-1.3, cars 1.3-1.7): cg_height is the centre of gravity's height "
                                          "above the road, track the distance between the tyres' centres, in m"))
    loads = _static_loads(vehicle)
    for name, key, attr, unit in (
            ("cornering_stiffness_per_load", "wheels.cornering_stiffness", "cornering_stiffness", "N/rad"),
            ("longitudinal_stiffness_per_load", "wheels.longitudinal_stiffness", "longitudinal_stiffness", "N")):
        stiff = getattr(vehicle, attr)
        pair = stiff if isinstance(stiff, tuple) else (stiff, stiff)
        low, high = CROSS_CHECKS[name][1:3]
        out.extend(_stiffness_per_load(name, key, pair, loads, low, high, unit))
    return out


def implausible_values(vehicle, accept=()) -> tuple[tuple[str, str], ...]:
    """The implausible values of a :class:`~longprofile.vehicle.Vehicle`: (key or cross check, message) pairs.

    Parameters
    ----------
    vehicle : Vehicle
        The description (SI units).
    accept : iterable of str
        TOML keys (``"body.mass"``) and cross checks (``"rollover_threshold"``) not to check: an exotic vehicle.

    Returns
    -------
    tuple of (str, str)
        Every key out of :data:`RANGES` and cross check out of :data:`CROSS_CHECKS`, with its one-line message (the
        key, the value, the range and the likely slip). A cross check reading a key already out of range is not
        reported (the slip is the key's). Empty for a plausible car.
    """
    accept = set(accept)
    single = [(k, msg) for k, msg in _range_problems(vehicle) if k not in accept]
    bad = {k for k, _ in single}
    cross = [(k, msg) for k, msg in _cross_problems(vehicle)
             if k not in accept and not bad.intersection(CROSS_CHECKS[k][0])]
    return tuple(single + cross)


def accepted_checks(table, source: str) -> tuple[str, ...]:
    """The validated ``accept`` list of a car file's ``[checks]`` table (InputFormatError naming ``source``)."""
    valid = sorted(RANGES) + sorted(CROSS_CHECKS)
    if not isinstance(table, dict) or set(table) - {"accept"}:
        raise InputFormatError(f"{source}: the table 'checks' takes one key, accept = [\"body.mass\", ...]: the car "
                               f"file keys and cross checks not to check for plausibility, among {valid}.")
    accept = table.get("accept", [])
    if not isinstance(accept, list) or not all(isinstance(a, str) for a in accept):
        raise InputFormatError(f"{source}: checks.accept must be a list of names, e.g. accept = [\"body.mass\"]; "
                               f"got {accept!r}.")
    unknown = [a for a in accept if a not in valid]
    if unknown:
        raise InputFormatError(f"{source}: checks.accept names {unknown}, which are not plausibility checks; "
                               f"expected some of {valid}.")
    return tuple(accept)


def check_plausible(vehicle, *, accept=(), source: str = "vehicle") -> None:
    """Refuse an implausible vehicle description in one line (:func:`implausible_values`).

    Raises
    ------
    InputFormatError
        ``"<source>: <key> = <value> <unit> is outside the plausible <low>..<high> <unit> ...: <likely slip>; an
        exotic vehicle? accept = [...] in a [checks] table of the car file"``, every problem of the car joined by
        "; " in one line.
    """
    problems = implausible_values(vehicle, accept)
    if problems:
        # the accept list that lets the vehicle through: the cross checks of an out-of-range key fail as well
        every = [k for k, _ in problems] + [k for k, _ in _cross_problems(vehicle) if k not in accept]
        names = ", ".join(f'"{k}"' for k in dict.fromkeys(every))
        raise InputFormatError(f"{source}: implausible vehicle: " + "; ".join(msg for _, msg in problems) +
                               f". A real vehicle with such values? add [checks] accept = [{names}] to the car file "
                               "(docs/vehicle-slope.md, \"Plausible values\").")
