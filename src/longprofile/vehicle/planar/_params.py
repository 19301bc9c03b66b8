"""Vehicle description for the planar 4-wheel model of paper 001 (TOML file <-> frozen dataclass)."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path

import numpy as np

from ...errors import InputError, InputFormatError
from .._car import read_car_file
from ._plausibility import accepted_checks, check_plausible

__all__ = ["Vehicle", "load_vehicle", "default_vehicle", "WHEELS", "GRAVITY", "SIMULATOR_ONLY", "PER_AXLE"]

#: Wheel order used everywhere (paper 001, eq. (14) and (19)): front-left, front-right, rear-left, rear-right.
WHEELS = ("fl", "fr", "rl", "rr")
#: Standard gravity, m/s^2.
GRAVITY = 9.80665

# index of each parameter in the flat float64 vector handed to the compiled model functions; the per-axle
# values (track, rolling radius, tyre stiffnesses) have a front (_F) and a rear (_R) entry
(P_MASS, P_IZ, P_LF, P_LR, P_TRACK_F, P_H, P_R_F, P_CXA, P_CYA, P_CX0_F, P_CY0_F, P_IW, P_G,
 P_TRACK_R, P_R_R, P_CX0_R, P_CY0_R) = range(17)
N_PARAMS = 17
#: Parameters that may differ between the front and the rear axle: a number (both axles) or (front, rear).
PER_AXLE = ("track", "wheel_radius", "longitudinal_stiffness", "cornering_stiffness")

_TOML_LAYOUT = {
    "body": {
        "mass": "mass", "yaw_inertia": "yaw_inertia", "cg_to_front_axle": "cg_to_front_axle",
        "cg_to_rear_axle": "cg_to_rear_axle", "track": "track", "cg_height": "cg_height",
        "aero_longitudinal": "aero_longitudinal", "aero_lateral": "aero_lateral", "steering_ratio": "steering_ratio",
    },
    "wheels": {
        "radius": "wheel_radius", "inertia": "wheel_inertia",
        "longitudinal_stiffness": "longitudinal_stiffness", "cornering_stiffness": "cornering_stiffness",
        "friction": "friction",
    },
    "drivetrain": {"driven_axle": "driven_axle", "brake_front_share": "brake_front_share",
                   "engine_brake_torque": "engine_brake_torque"},
}
#: Keys only the simulator reads (wheel dynamics, brake balance); a description for estimation may omit them.
SIMULATOR_ONLY = ("wheel_inertia", "brake_front_share")
#: Keys a description may omit: the simulator-only ones and the steering ratio (needed only by a log that has a
#: ``steering_wheel_angle`` column).
_OPTIONAL = SIMULATOR_ONLY + ("steering_ratio",)
_UNITS = {
    "mass": "kg", "yaw_inertia": "kg m^2", "cg_to_front_axle": "m", "cg_to_rear_axle": "m", "track": "m",
    "cg_height": "m", "aero_longitudinal": "N s^2/m^2", "aero_lateral": "N s^2/m^2", "wheel_radius": "m",
    "wheel_inertia": "kg m^2", "longitudinal_stiffness": "N", "cornering_stiffness": "N/rad",
    "engine_brake_torque": "N m", "steering_ratio": "",
}


@dataclass(frozen=True)
class Vehicle:
    """Parameters of the planar 4-wheel vehicle model (paper 001, eq. (11)-(19)), SI units.

    Parameters
    ----------
    mass : float
        M, total mass, kg.
    yaw_inertia : float
        I_z, yaw moment of inertia, kg m^2.
    cg_to_front_axle, cg_to_rear_axle : float
        l_f and l_r, longitudinal distances from the centre of gravity to the axles, m.
    track : float or (float, float)
        S_b, track width, m: one number for both axles or ``(front, rear)``.
    cg_height : float
        H, height of the centre of gravity used by the load transfer (19), m.
    aero_longitudinal, aero_lateral : float
        C_x and C_y of eq. (11), N s^2/m^2 (drag force = C V|V|).
    wheel_radius : float or (float, float)
        R, effective rolling radius, m (eq. (18)): one number or ``(front, rear)`` (staggered tyres).
    wheel_inertia : float or None
        I_w, rotational inertia of one wheel, kg m^2 (simulator wheel dynamics). None (key ``wheels.inertia``
        omitted): the estimators do not need it, :func:`simulate_drive` refuses the car.
    longitudinal_stiffness : float or (float, float)
        C_x0 of the Dugoff model (15)-(17), N per unit slip, of each tyre: one number or ``(front, rear)``.
    cornering_stiffness : float or (float, float)
        C_y0 of the Dugoff model, N/rad, of each tyre: one number or ``(front, rear)``.
    friction : tuple of 4 float
        mu_i, available adhesion of each wheel (FL, FR, RL, RR), dimensionless, in (0, 2].
    driven_axle : {"front", "rear", "all"}
        Where the simulator applies the drive torque.
    brake_front_share : float
        Share of the brake torque on the front axle, in [0, 1] (simulator; None when the key
        ``drivetrain.brake_front_share`` is omitted, which only the simulator refuses).
    engine_brake_torque : float
        Largest overrun (engine-braking) torque, N m in total at the driven wheels; the simulator's
        driver brakes with the engine up to it and with the service brakes beyond.
    name, description : str
        Free labels.
    steering_ratio : float or None
        Steering-wheel angle / road-wheel angle (optional key ``body.steering_ratio``): a log's
        ``steering_wheel_angle`` column is divided by it (:func:`~longprofile.vehicle.read_drive_log`). None: such a
        column is refused.

    Notes
    -----
    A per-axle parameter (:data:`PER_AXLE`) given as a pair with equal values is stored as one number, so a
    car with equal axles compares equal and is written back as before; :attr:`tracks`, :attr:`wheel_radii`,
    :attr:`longitudinal_stiffnesses` and :attr:`cornering_stiffnesses` always give ``(front, rear)``.

    Raises
    ------
    InputError
        If a parameter is not finite and positive (or out of its range); the message names it.

    See Also
    --------
    load_vehicle : read a description from a TOML file.
    default_vehicle : the documented default car (``vehicle/data/default_car.toml``).
    """

    mass: float
    yaw_inertia: float
    cg_to_front_axle: float
    cg_to_rear_axle: float
    track: float | tuple[float, float]
    cg_height: float
    aero_longitudinal: float
    aero_lateral: float
    wheel_radius: float | tuple[float, float]
    wheel_inertia: float | None
    longitudinal_stiffness: float | tuple[float, float]
    cornering_stiffness: float | tuple[float, float]
    friction: tuple[float, float, float, float] = (0.8, 0.8, 0.8, 0.8)
    driven_axle: str = "front"
    brake_front_share: float | None = 0.7
    engine_brake_torque: float = 300.0
    name: str = ""
    description: str = ""
    steering_ratio: float | None = None

    def __post_init__(self):
        for key in PER_AXLE:
            object.__setattr__(self, key, _per_axle(key, getattr(self, key)))
        for key in ("mass", "yaw_inertia", "cg_to_front_axle", "cg_to_rear_axle", "cg_height", "wheel_inertia",
                    "steering_ratio"):
            if key in _OPTIONAL and getattr(self, key) is None:
                continue
            _check_number(key, getattr(self, key), positive=True)
            object.__setattr__(self, key, float(getattr(self, key)))
        for key in ("aero_longitudinal", "aero_lateral"):
            _check_number(key, getattr(self, key), positive=False)
            object.__setattr__(self, key, float(getattr(self, key)))
        try:
            mu = tuple(float(v) for v in self.friction)
        except (TypeError, ValueError):
            raise InputError(f"friction must be 4 numbers (FL, FR, RL, RR); got {self.friction!r}.") from None
        if len(mu) != 4 or not all(math.isfinite(v) and 0.0 < v <= 2.0 for v in mu):
            raise InputError(f"friction must be 4 finite adhesion coefficients in (0, 2] (FL, FR, RL, RR); "
                             f"got {self.friction!r}.")
        object.__setattr__(self, "friction", mu)
        if self.driven_axle not in ("front", "rear", "all"):
            raise InputError(f"driven_axle must be 'front', 'rear' or 'all'; got {self.driven_axle!r}.")
        if self.brake_front_share is not None:
            _check_number("brake_front_share", self.brake_front_share, positive=False)
            if not 0.0 <= float(self.brake_front_share) <= 1.0:
                raise InputError(f"brake_front_share must be in [0, 1]; got {self.brake_front_share!r}.")
            object.__setattr__(self, "brake_front_share", float(self.brake_front_share))
        _check_number("engine_brake_torque", self.engine_brake_torque, positive=False)
        object.__setattr__(self, "engine_brake_torque", float(self.engine_brake_torque))

    @property
    def wheelbase(self) -> float:
        """l_f + l_r, m."""
        return self.cg_to_front_axle + self.cg_to_rear_axle

    @property
    def tracks(self) -> tuple[float, float]:
        """(front, rear) track width S_b, m."""
        return _axles(self.track)

    @property
    def wheel_radii(self) -> tuple[float, float]:
        """(front, rear) rolling radius R, m."""
        return _axles(self.wheel_radius)

    @property
    def longitudinal_stiffnesses(self) -> tuple[float, float]:
        """(front, rear) tyre longitudinal stiffness C_x0, N per unit slip."""
        return _axles(self.longitudinal_stiffness)

    @property
    def cornering_stiffnesses(self) -> tuple[float, float]:
        """(front, rear) tyre cornering stiffness C_y0, N/rad."""
        return _axles(self.cornering_stiffness)

    @property
    def wheel_radius_of_each(self) -> np.ndarray:
        """Rolling radius of each wheel (FL, FR, RL, RR), m, shape (4,)."""
        f, r = self.wheel_radii
        return np.array([f, f, r, r])

    def with_changes(self, **changes) -> "Vehicle":
        """A copy with some parameters changed (validated again), e.g. ``car.with_changes(mass=1650.0)``."""
        return replace(self, **changes)

    def as_array(self) -> np.ndarray:
        """The flat float64 parameter vector read by the compiled model functions (private layout)."""
        p = np.empty(N_PARAMS)
        p[P_MASS] = self.mass
        p[P_IZ] = self.yaw_inertia
        p[P_LF] = self.cg_to_front_axle
        p[P_LR] = self.cg_to_rear_axle
        p[P_TRACK_F], p[P_TRACK_R] = self.tracks
        p[P_H] = self.cg_height
        p[P_R_F], p[P_R_R] = self.wheel_radii
        p[P_CXA] = self.aero_longitudinal
        p[P_CYA] = self.aero_lateral
        p[P_CX0_F], p[P_CX0_R] = self.longitudinal_stiffnesses
        p[P_CY0_F], p[P_CY0_R] = self.cornering_stiffnesses
        p[P_IW] = 0.0 if self.wheel_inertia is None else self.wheel_inertia  # read by the simulator only
        p[P_G] = GRAVITY
        return p

    def to_toml(self) -> str:
        """The description as TOML text (the format :func:`load_vehicle` reads)."""
        lines = [f"name = {_toml_str(self.name)}", f"description = {_toml_str(self.description)}"]
        for section, keys in _TOML_LAYOUT.items():
            lines.append(f"\n[{section}]")
            for key, attr in keys.items():
                value = getattr(self, attr)
                if value is None:  # an omitted simulator-only key stays omitted
                    continue
                if isinstance(value, str):
                    text = _toml_str(value)
                elif isinstance(value, tuple):
                    text = "[" + ", ".join(repr(float(v)) for v in value) + "]"
                else:
                    text = repr(float(value))
                unit = _UNITS.get(attr)
                if unit and attr in PER_AXLE and isinstance(value, tuple):
                    unit += " (front, rear)"
                lines.append(f"{key} = {text}" + (f"  # {unit}" if unit else ""))
        return "\n".join(lines) + "\n"


def _toml_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _axles(value) -> tuple[float, float]:
    return value if isinstance(value, tuple) else (value, value)


def _per_axle(name: str, value):
    """A per-axle parameter: one number (both axles) or a (front, rear) pair, each finite and > 0.

    Returns a float, or a tuple of 2 floats when the axles differ (a pair of equal values becomes one number).
    """
    if isinstance(value, (list, tuple, np.ndarray)):
        items = list(value)
        if len(items) != 2:
            raise InputError(f"{name} must be one number (both axles) or a [front, rear] pair"
                             f" ({_UNITS.get(name, '')}); got {len(items)} value(s) {value!r}.")
        for axle, v in zip(("front", "rear"), items):
            _check_number(f"{name}[{axle}]", v, positive=True, unit=_UNITS.get(name, ""))
        front, rear = float(items[0]), float(items[1])
        return front if front == rear else (front, rear)
    _check_number(name, value, positive=True)
    return float(value)


def _check_number(name: str, value, *, positive: bool, unit: str | None = None) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        pair = " (or a [front, rear] pair)" if name in PER_AXLE else ""
        raise InputError(f"{name} must be a number{pair}; got {value!r}.")
    v = float(value)
    if not math.isfinite(v) or (v <= 0.0 if positive else v < 0.0):
        unit = _UNITS.get(name, "") if unit is None else unit
        raise InputError(f"{name} must be finite and {'> 0' if positive else '>= 0'}"
                         f"{' ' + unit if unit else ''}; got {value!r}.")


def _from_mapping(data: dict, source: str) -> Vehicle:
    kwargs = {}
    for key in data:
        if key not in _TOML_LAYOUT and key not in ("name", "description", "vertical", "tolerances", "checks"):
            raise InputFormatError(f"{source}: unknown key {key!r}; expected the tables "
                                   f"{sorted(_TOML_LAYOUT)}, the optional tables 'tolerances', 'vertical' and "
                                   "'checks' and the keys 'name', 'description'.")
    missing = []  # every missing table and key, named at once (one round trip, not one per key)
    for section, keys in _TOML_LAYOUT.items():
        table = data.get(section)
        if not isinstance(table, dict):
            missing.append(f"table [{section}] (keys {', '.join(k for k, a in keys.items() if a not in _OPTIONAL)})")
            continue
        for key in table:
            if key not in keys:
                raise InputFormatError(f"{source}: unknown key {key!r} in table '{section}'; expected {sorted(keys)}.")
        for key, attr in keys.items():
            if key not in table and attr in _OPTIONAL:
                kwargs[attr] = None
            elif key not in table:
                missing.append(f"{section}.{key} ({_UNITS.get(attr, 'see docs/vehicle-slope.md')})")
            else:
                kwargs[attr] = table[key]
    if missing:
        raise InputFormatError(f"{source}: missing {'; '.join(missing)}; add them (docs/vehicle-slope.md, \"Default car\", "
                               "lists every key with its unit).")
    kwargs["name"] = str(data.get("name", ""))
    kwargs["description"] = str(data.get("description", ""))
    accept = accepted_checks(data["checks"], source) if "checks" in data else ()
    try:
        car = Vehicle(**kwargs)
    except InputError as exc:
        text = str(exc)
        attr = text.split(" ", 1)[0].split("[", 1)[0]
        where = next((f" (key '{section}.{key}')" for section, keys in _TOML_LAYOUT.items()
                      for key, a in keys.items() if a == attr), "")
        raise InputFormatError(f"{source}: {text.rstrip('.')}{where}.") from None
    check_plausible(car, accept=accept, source=source)
    return car


def load_vehicle(path) -> Vehicle:
    """Read a vehicle description from a TOML file.

    Parameters
    ----------
    path : path-like
        TOML file with the tables ``[body]``, ``[wheels]``, ``[drivetrain]`` laid out as in
        ``longprofile/vehicle/data/default_car.toml`` (SI units; every key required except the
        simulator-only ``wheels.inertia`` and ``drivetrain.brake_front_share``, see :data:`SIMULATOR_ONLY`).
        The per-axle keys ``body.track``, ``wheels.radius``, ``wheels.longitudinal_stiffness`` and
        ``wheels.cornering_stiffness`` take one number (both axles) or a ``[front, rear]`` pair. The optional
        tables ``[tolerances]`` (:meth:`~longprofile.vehicle.SlopeUncertainty.from_car_file`) and ``[vertical]``
        (:func:`~longprofile.vehicle.load_vertical_params`) are read by those, not here. ``body.steering_ratio`` is
        optional (a log's ``steering_wheel_angle`` is divided by it). The values must be plausible for a passenger
        car or light truck (:func:`~longprofile.vehicle.planar._plausibility.implausible_values`); the optional table
        ``[checks]`` with ``accept = ["body.mass", ...]`` names the keys and cross checks an exotic vehicle skips.

    Returns
    -------
    Vehicle

    Raises
    ------
    InputError
        If the file does not exist.
    InputFormatError
        If it is not valid TOML, misses a key, has an unknown key, an invalid value or an implausible one (the
        message names the file, table and key; an implausible value also its range and the likely unit slip).

    Examples
    --------
    Read the packaged default car file (the one :func:`default_vehicle` describes):

    >>> from importlib import resources
    >>> from longprofile.vehicle import default_vehicle, load_vehicle
    >>> with resources.as_file(resources.files("longprofile.vehicle") / "data" / "default_car.toml") as path:
    ...     car = load_vehicle(path)
    >>> car.mass
    1500.0
    >>> car == default_vehicle()
    True
    """
    path = Path(path)
    data = read_car_file(path)
    return _from_mapping(data, str(path))


def default_vehicle() -> Vehicle:
    """The documented default car (``longprofile/vehicle/data/default_car.toml``).

    A representative 1.5 t front-wheel-drive C-segment car with textbook parameter values (not the
    paper's prototype, whose parameters are not published); see ``docs/vehicle-slope.md``.
    """
    text = resources.files("longprofile.vehicle").joinpath("data/default_car.toml").read_text(encoding="utf-8")
    return _from_mapping(tomllib.loads(text), "default_car.toml")
