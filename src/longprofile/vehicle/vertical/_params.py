"""Parameters of the thesis-003 vertical car: the 7-DOF model's :class:`VerticalVehicleParams` (and their
``[vertical]`` table in a vehicle description file) and the MagneRide damper's :class:`MRDamperParams`."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from ...errors import InputError, InputFormatError
from .._car import read_car_file

__all__ = ["VerticalVehicleParams", "MRDamperParams", "THESIS_MR_TIME_CONSTANT", "load_vertical_params",
           "SENSOR_CONFIGS"]

#: The thesis's sensor configurations: 1 displacements, 2 + body accelerometers, 3 + wheel accelerometers.
SENSOR_CONFIGS = (1, 2, 3)


@dataclass(frozen=True)
class VerticalVehicleParams:
    """Parameters of the 7-DOF vertical model; defaults are the thesis-003 Audi A8 set (§3.2 of the digest).

    Attributes (SI units)
    ---------------------
    total_mass : float
        M, kg, body + four wheels (thesis: 2000 kg, 4 wheel scales).
    wheel_mass_front, wheel_mass_rear : float
        Unsprung mass per wheel, kg (thesis: 50 / 45 kg). The sprung mass is
        ``m = M - 2 m_w,front - 2 m_w,rear`` = 1810 kg.
    spring_stiffness_front, spring_stiffness_rear : float
        k, N/m, of the air springs (thesis: 40 000 / 22 000 N/m, decoded).
    spring_beta_front, spring_beta_rear : float
        beta, m^-4, stiffening ``F = k dZ (1 + beta dZ^4)`` (thesis: 61 000 / 16 000, digits uncertain).
    tyre_stiffness : float
        k_pneus, N/m (thesis: 290 000 N/m); the tyre is a vertical spring without damping.
    antiroll_stiffness_front, antiroll_stiffness_rear : float
        Anti-roll bar stiffness expressed at the wheel, N/m (thesis: 15 000 / 5 000). ASSUMPTION:
        the printed values already include the K_ratio^2 = 0.81 / 0.64 factor (the nomenclature
        says "expressed at the wheel").
    roll_lever_arm : float
        H_roul, m, CG above the roll axis (thesis: 0.6 m).
    pitch_lever_arm : float
        H_tang, m, CG above the pitch centre (thesis: 0.5 m).
    cg_height : float
        CG height above ground, m (thesis: 0.91 m = 0.565 + 0.344). The roll and pitch centres are
        ``cg_height - roll_lever_arm`` = 0.31 m and ``cg_height - pitch_lever_arm`` = 0.41 m above ground.
    cg_to_front_axle, cg_to_rear_axle : float
        E1, E2, m (thesis: 1.28 / 1.68 m, decoded from the tilt test).
    track_front, track_rear : float
        V1, V2, m. NOT GIVEN in the thesis; ASSUMPTION: 1.63 / 1.62 m (Audi A8 D3 data sheet order of
        magnitude).
    roll_inertia, pitch_inertia : float
        Ixx, Iyy at the CG, kg m^2 (thesis: 1400 / 2900).
    roll_yaw_product : float
        Ixz, kg m^2 (thesis: 45, CAD value).
    damper_rebound, damper_compression : tuple of 3 floats
        (A, B, C) of the passive damper on each side, ``f(v) = A v + B tanh(v / C)`` (A in N s/m, B in N,
        C in m/s). The thesis's damper function (1.9) is lost; this form is an ASSUMPTION consistent with
        its three parameters per regime and its 4 tanh per corner. Defaults: the thesis's "example passive
        damper" (§1.1.3.6), first column read as rebound (A=1938, B=1237, C=0.075), second as compression
        (A=823.3, B=439.5, C=0.1003); the same damper front and rear.
    damper_transition : float
        tau, s/m, of the tanh activation blending compression (v < 0) and rebound (v > 0) (thesis: 1000).
    suspension_friction : float
        Coulomb friction of each suspension, N, ``f0 tanh(v / 0.005 m/s)`` (default 0). Used by the SIMULATOR
        only, to stand for the unmodelled friction the thesis observed (§1.2.2); the estimation model
        neglects it (the thesis leaves it to the disturbance force P).

    Notes
    -----
    ``dataclasses.replace(params, tyre_stiffness=250e3)`` gives a variant; the object is immutable.
    """

    total_mass: float = 2000.0
    wheel_mass_front: float = 50.0
    wheel_mass_rear: float = 45.0
    spring_stiffness_front: float = 40_000.0
    spring_stiffness_rear: float = 22_000.0
    spring_beta_front: float = 61_000.0
    spring_beta_rear: float = 16_000.0
    tyre_stiffness: float = 290_000.0
    antiroll_stiffness_front: float = 15_000.0
    antiroll_stiffness_rear: float = 5_000.0
    roll_lever_arm: float = 0.6
    pitch_lever_arm: float = 0.5
    cg_height: float = 0.91
    cg_to_front_axle: float = 1.28
    cg_to_rear_axle: float = 1.68
    track_front: float = 1.63
    track_rear: float = 1.62
    roll_inertia: float = 1400.0
    pitch_inertia: float = 2900.0
    roll_yaw_product: float = 45.0
    damper_rebound: tuple = (1938.0, 1237.0, 0.075)
    damper_compression: tuple = (823.3, 439.5, 0.1003)
    damper_transition: float = 1000.0
    suspension_friction: float = 0.0

    def __post_init__(self):
        positive = ("total_mass", "wheel_mass_front", "wheel_mass_rear", "spring_stiffness_front",
                    "spring_stiffness_rear", "tyre_stiffness", "cg_height", "cg_to_front_axle", "cg_to_rear_axle",
                    "track_front", "track_rear", "roll_inertia", "pitch_inertia", "damper_transition")
        nonneg = ("spring_beta_front", "spring_beta_rear", "antiroll_stiffness_front", "antiroll_stiffness_rear",
                  "suspension_friction")
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in ("damper_rebound", "damper_compression"):
                try:
                    t = tuple(float(a) for a in v)
                except (TypeError, ValueError):
                    raise InputError(f"{f.name} must be three numbers (A N s/m, B N, C m/s); got {v!r}.") from None
                if len(t) != 3 or not all(math.isfinite(a) for a in t) or t[2] == 0.0:
                    raise InputError(f"{f.name} must be three finite numbers (A, B, C) with C != 0; got {v!r}.")
                object.__setattr__(self, f.name, t)
                continue
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise InputError(f"{f.name} must be a finite number; got {v!r}.")
            if f.name in positive and v <= 0:
                raise InputError(f"{f.name} must be > 0; got {v!r}.")
            if f.name in nonneg and v < 0:
                raise InputError(f"{f.name} must be >= 0; got {v!r}.")
        if self.sprung_mass <= 0:
            raise InputError(f"total_mass ({self.total_mass} kg) must exceed the four wheel masses "
                             f"({2 * self.wheel_mass_front + 2 * self.wheel_mass_rear} kg).")

    @property
    def sprung_mass(self) -> float:
        """m = M - 2 m_w,front - 2 m_w,rear, kg (thesis §1.2)."""
        return self.total_mass - 2 * self.wheel_mass_front - 2 * self.wheel_mass_rear

    @property
    def wheelbase(self) -> float:
        """E1 + E2, m."""
        return self.cg_to_front_axle + self.cg_to_rear_axle

    @property
    def roll_axis_inertia(self) -> float:
        """Ixx + m Hr^2, kg m^2: roll inertia about the roll axis (Huygens/Koenig transport)."""
        return self.roll_inertia + self.sprung_mass * self.roll_lever_arm ** 2

    @property
    def pitch_axis_inertia(self) -> float:
        """Iyy + m Hp^2, kg m^2: pitch inertia about the pitch centre."""
        return self.pitch_inertia + self.sprung_mass * self.pitch_lever_arm ** 2

    def wheel_hop_frequency(self, axle: int = 0) -> float:
        """Wheel-hop frequency sqrt((k_t + k) / m_w) / 2 pi in Hz of the front (0) or rear (1) axle."""
        k = (self.spring_stiffness_front, self.spring_stiffness_rear)[axle]
        mw = (self.wheel_mass_front, self.wheel_mass_rear)[axle]
        return math.sqrt((self.tyre_stiffness + k) / mw) / (2 * math.pi)


# ----------------------------------------------------------------------------------------------- MR damper
#: Thesis §1.2.4 / Fig. 1.36-1.38: the test car's MagneRide damper has a bandwidth of about 80 Hz, i.e. a
#: first-order current-to-force time constant 1 / (2 pi 80 Hz) = 2.0 ms.
THESIS_MR_TIME_CONSTANT = 1.0 / (2.0 * math.pi * 80.0)


@dataclass(frozen=True)
class MRDamperParams:
    """A magnetorheological (MagneRide-like) damper per corner and its comfort controller (thesis 003 §1.2.4, §1.4.2).

    The damper force is the passive (off-state, zero-current) damper of :class:`VerticalVehicleParams` plus
    the controlled force of the current ``i`` (A) at damper velocity ``v = dZ21dot`` (m/s)::

        F_mr(i, v) = F_y(i) tanh(v / v_y),      F_y(i) = F_max (1 - exp(-i / i_sat))

    (tension sign convention of :mod:`._model`: the force opposes the damper velocity, dissipative
    for every current). This is the hyperbolic-tangent MR model (Kwok et al., Sensors Actuators A 132, 2006;
    Guo et al., J. Intell. Mater. Syst. Struct. 17, 2006) without its pre-yield stiffness and hysteresis
    terms, with a yield force saturating in current (magnetic saturation of the fluid/piston, e.g. Gavin et
    al., US-Japan workshop 2001). The thesis's own map (Delphi's, §1.2.4: ``F_act = mu(i, T, v) v`` with
    ``mu_min <= mu <= mu_max``, mapped on a bench) is proprietary and not printed.

    The force follows the commanded current through a first-order lag: the "effective" current ``i_eff``
    obeys ``di_eff/dt = (i_cmd - i_eff) / time_constant`` (coil inductance and fluid chain formation) and
    ``F = F_mr(i_eff, v)`` (velocity dependence instantaneous).

    Attributes
    ----------
    max_force : float
        F_max, N (default 3000 N). ASSUMPTION: about the passive rebound force at 1 m/s (3175 N) -- MR
        dampers reach a dynamic range of ~10 over their off state (Gavin et al. 2001); the thesis's Fig. 1.36
        compares ranges without numbers.
    saturation_current : float
        i_sat, A (default 2 A: 63 % of F_max at 2 A, 92 % at 5 A). ASSUMPTION (order of magnitude of
        automotive MR coils driven 0-5 A).
    yield_velocity : float
        v_y, m/s, width of the tanh (default 0.03 m/s). ASSUMPTION: "an MR damper delivers large forces at low
        velocity" (thesis §2.2); below the passive damper's 0.05 m/s compression/rebound transition.
    time_constant : float
        Current-to-force first-order time constant, s (default :data:`THESIS_MR_TIME_CONSTANT` = 2.0 ms,
        the thesis's ~80 Hz bandwidth; Koo et al., ASME IDETC 2003, measured 13.9-15.4 ms on an automotive MR
        damper: see the sensitivity in docs/vehicle-vertical.md). 0 = no lag.
    max_current : float
        Current limit, A (default 5 A).
    skyhook_gain : float
        c_sky, N s/m, of the car's comfort controller (default 3000 N s/m). ASSUMPTION: ~0.3 of the critical
        damping of a front body corner (2 sqrt(40 000 x 514) = 9 070 N s/m).
    """

    max_force: float = 3000.0
    saturation_current: float = 2.0
    yield_velocity: float = 0.03
    time_constant: float = THESIS_MR_TIME_CONSTANT
    max_current: float = 5.0
    skyhook_gain: float = 3000.0

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise InputError(f"MRDamperParams.{f.name} must be a finite number; got {v!r}.")
            if f.name == "time_constant" or f.name == "skyhook_gain" or f.name == "max_force":
                if v < 0:
                    raise InputError(f"MRDamperParams.{f.name} must be >= 0; got {v!r}.")
            elif v <= 0:
                raise InputError(f"MRDamperParams.{f.name} must be > 0; got {v!r}.")

    def as_array(self) -> np.ndarray:
        """(6,) array [F_max, i_sat, v_y, time constant, i_max, c_sky] for the compiled kernels."""
        return np.array([self.max_force, self.saturation_current, self.yield_velocity, self.time_constant,
                         self.max_current, self.skyhook_gain])


def load_vertical_params(path):
    """The vertical (7-DOF, thesis 003) parameters of a vehicle description: its optional ``[vertical]`` table.

    The same TOML file describes the car for the planar commands (tables ``[body]``, ``[wheels]``,
    ``[drivetrain]``, paper 001) and for the vertical ones (table ``[vertical]``). Its keys are the fields of
    :class:`~longprofile.vehicle.VerticalVehicleParams`, in SI units (masses kg, stiffnesses N/m, lengths m,
    inertias kg m^2, ``spring_beta_*`` m^-4, ``damper_*`` = [A N s/m, B N, C m/s], ``damper_transition`` s/m,
    ``suspension_friction`` N, simulator only); a key left out keeps the thesis value. A file without
    ``[vertical]`` gives the thesis car (the default of every vertical command).

    Raises
    ------
    InputError
        If the file does not exist.
    InputFormatError
        Invalid TOML, an unknown key in ``[vertical]`` (the valid ones are listed) or an invalid value (named).
    """
    path = Path(path)
    data = read_car_file(path)
    table = data.get("vertical", {})
    if not isinstance(table, dict):
        raise InputFormatError(f"{path}: 'vertical' must be a table ([vertical]).")
    valid = [f.name for f in fields(VerticalVehicleParams)]
    unknown = [k for k in table if k not in valid]
    if unknown:
        raise InputFormatError(f"{path}: unknown key(s) {unknown} in table 'vertical'; expected some of {valid}.")
    try:
        return VerticalVehicleParams(**table)
    except (InputError, TypeError) as exc:
        raise InputFormatError(f"{path}: [vertical]: {exc}") from None
