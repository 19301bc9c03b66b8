"""The 7-DOF vertical vehicle model of thesis 003 (Plancke, SUPELEC/Delphi): heave, roll, pitch, four wheels.

Frames and signs (ISO 8855, the convention used everywhere in this module):
x forward, y left, z up. Corner index ``c`` = 0 front-left, 1 front-right,
2 rear-left, 3 rear-right (thesis ij = 11, 12, 21, 22). The corner sits at
``x_c`` (+E1 front, -E2 rear) and ``y_c`` (+V_i/2 left, -V_i/2 right) from the
centre of gravity. Roll ``theta`` is positive left side up, pitch ``phi``
positive nose down, so the body above corner c moves by
``Z2_c = z + y_c theta - x_c phi`` (small angles, thesis hypothesis 2).

Suspension "tension" force of corner c (positive when it pulls the body down
and the wheel up), thesis §2.4::

    F_c = k_c dZ (1 + beta_c dZ^4) + F_damper(dZdot) + U_c + kbar_i (dZ_c - dZ_opposite(c))

with ``dZ = Z2 - Z1`` (thesis ΔZ21), ``dZdot`` its rate and ``U_c`` the
actuator force. The equations of motion (thesis (1.12)-(1.19), lost in the
text, rebuilt from §2.6 of the digest)::

    m zdd                       = -sum F_c
    (Ixx + m Hr^2) thetadd      = -sum y_c F_c + M Hr a_y + Ixz psidd
    (Iyy + m Hp^2) phidd        = +sum x_c F_c - M Hp a_x
    m_w,c Z1dd_c                =  F_c - k_t (Z1_c - Z0_c) + FN_c

``FN_c`` is the geometric (roll/pitch-centre) load transfer that reaches the
tyres directly through the suspension links, ``FN_c = fn_ax_c a_x +
fn_ay_c a_y`` (see :func:`vertical_params_arrays`). The body acceleration
above corner c is then (thesis (3.2), digest §2.6)::

    Z2dd_c = -sum_e coupling[c, e] F_e + d_ax_c a_x + d_ay_c a_y + d_psidd_c psidd
    coupling[c, e] = 1/m + y_c y_e / (Ixx + m Hr^2) + x_c x_e / (Iyy + m Hp^2)

All functions that take ``corner`` / ``scalars`` arrays are numba-jitted with
``cache=True`` and can be called from other jitted code (the EKF model
functions in :mod:`._vertical_ekf`, the RK4 simulator in :mod:`._vertical_sim`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numba import njit

from ..errors import InputError

__all__ = ["VerticalVehicleParams", "vertical_params_arrays", "spring_force", "damper_force", "MRDamperParams",
           "mr_controlled_force", "mr_map_force", "skyhook_current", "THESIS_MR_TIME_CONSTANT"]

N_CORNERS = 4
CORNER_NAMES = ("FL", "FR", "RL", "RR")
OPPOSITE = np.array([1, 0, 3, 2])

# columns of the (4, N_COL) corner table
CX, CY, CMW, CK, CBETA, CKBAR = 0, 1, 2, 3, 4, 5
CAR, CBR, CCR, CAC, CBC, CCC = 6, 7, 8, 9, 10, 11
CFNAX, CFNAY, CDAX, CDAY, CDPSI = 12, 13, 14, 15, 16
N_COL = 17
# entries of the scalar vector
SKT, STAU, SM, SIR, SIP, SMTOT, SFRIC = 0, 1, 2, 3, 4, 5, 6
N_SCAL = 7
_FRICTION_VELOCITY = 0.005  # m/s, width of the smooth Coulomb friction tanh(v / v0)

G = 9.81


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


def vertical_params_arrays(params: VerticalVehicleParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pack the parameters for the compiled kernels.

    Returns
    -------
    corner : (4, 17) ndarray
        Per-corner table: x, y (m), wheel mass, spring k, beta, anti-roll k, damper (A, B, C) rebound,
        damper (A, B, C) compression, geometric load-transfer coefficients fn_ax, fn_ay (N per m/s^2),
        body-corner acceleration per unit a_x, a_y and psidd (d_ax, d_ay in 1, d_psidd in m).
    coupling : (4, 4) ndarray
        ``coupling[c, e]`` = body acceleration above corner c per newton of suspension tension at corner e
        (1/kg), digest §2.6; its diagonal is 1 / M_eq (the thesis's "equivalent mass", §3.4.2).
    scalars : (7,) ndarray
        k_t, damper tau, m, Ixx + m Hr^2, Iyy + m Hp^2, M, suspension friction (simulator only).

    Notes
    -----
    Geometric load transfer (ASSUMPTION, digest §2.1/§2.3 "F_Normal"): the part of the lateral inertia
    force's moment below the roll axis, ``M a_y (h_cg - H_roul)``, goes straight to the tyres, split
    between the axles by static load (front share E2/L); likewise ``M a_x (h_cg - H_tang)`` for pitch.
    With the sprung part ``M a_y H_roul`` carried by springs and bars, the total steady load transfer is
    the textbook ``M a_y h_cg / V``.
    """
    p = params
    m = p.sprung_mass
    Ir, Ip = p.roll_axis_inertia, p.pitch_axis_inertia
    L = p.wheelbase
    M = p.total_mass
    h_rc = p.cg_height - p.roll_lever_arm
    h_pc = p.cg_height - p.pitch_lever_arm
    corner = np.zeros((N_CORNERS, N_COL))
    for c in range(N_CORNERS):
        front = c < 2
        left = c % 2 == 0
        x = p.cg_to_front_axle if front else -p.cg_to_rear_axle
        track = p.track_front if front else p.track_rear
        y = track / 2 if left else -track / 2
        share = (p.cg_to_rear_axle if front else p.cg_to_front_axle) / L
        corner[c, CX], corner[c, CY] = x, y
        corner[c, CMW] = p.wheel_mass_front if front else p.wheel_mass_rear
        corner[c, CK] = p.spring_stiffness_front if front else p.spring_stiffness_rear
        corner[c, CBETA] = p.spring_beta_front if front else p.spring_beta_rear
        corner[c, CKBAR] = p.antiroll_stiffness_front if front else p.antiroll_stiffness_rear
        corner[c, CAR:CCR + 1] = p.damper_rebound
        corner[c, CAC:CCC + 1] = p.damper_compression
        # wheel c is pushed up (less tyre load) by +FN: left wheels in a left turn (a_y > 0),
        # front wheels when accelerating (a_x > 0).
        corner[c, CFNAY] = (1.0 if left else -1.0) * M * h_rc * share / track
        corner[c, CFNAX] = (1.0 if front else -1.0) * M * h_pc / (2 * L)
        corner[c, CDAX] = x * M * p.pitch_lever_arm / Ip
        corner[c, CDAY] = y * M * p.roll_lever_arm / Ir
        corner[c, CDPSI] = y * p.roll_yaw_product / Ir
    xs, ys = corner[:, CX], corner[:, CY]
    coupling = 1.0 / m + np.outer(ys, ys) / Ir + np.outer(xs, xs) / Ip
    scalars = np.array([p.tyre_stiffness, p.damper_transition, m, Ir, Ip, M, p.suspension_friction])
    return corner, coupling, scalars


# ----------------------------------------------------------------------------------------------- forces
@njit(cache=True)
def spring_force(dz, k, beta):
    """Air-spring force k dZ (1 + beta dZ^4), N (thesis §1.1.3, F_ress). Returns (force, slope dF/ddZ)."""
    d4 = dz * dz * dz * dz
    return k * dz * (1.0 + beta * d4), k * (1.0 + 5.0 * beta * d4)


@njit(cache=True)
def damper_force(v, a_r, b_r, c_r, a_c, b_c, c_c, tau):
    """Asymmetric passive damper force, N, and its slope dF/dv, N s/m.

    ``F(v) = S(v) (a_r v + b_r tanh(v/c_r)) + (1 - S(v)) (a_c v + b_c tanh(v/c_c))`` with the
    activation ``S(v) = (1 + tanh(tau v)) / 2`` (thesis eq. (1.9), reconstructed: rebound for v > 0,
    compression for v < 0, 3 tanh per evaluation).
    """
    ts = math.tanh(tau * v)
    s = 0.5 * (1.0 + ts)
    tr = math.tanh(v / c_r)
    tc = math.tanh(v / c_c)
    fr = a_r * v + b_r * tr
    fc = a_c * v + b_c * tc
    dfr = a_r + b_r / c_r * (1.0 - tr * tr)
    dfc = a_c + b_c / c_c * (1.0 - tc * tc)
    ds = 0.5 * tau * (1.0 - ts * ts)
    return s * fr + (1.0 - s) * fc, ds * (fr - fc) + s * dfr + (1.0 - s) * dfc


@njit(cache=True)
def suspension_tensions(dz, dzdot, actuator, corner, tau, out_force, out_dspring, out_ddamper):
    """Tension F_c of the four suspensions (spring + damper + actuator + anti-roll bar), N.

    Writes the force into ``out_force`` (4,), the spring slope (without bar) into ``out_dspring`` and
    the damper slope into ``out_ddamper``.
    """
    for c in range(4):
        fs, ks = spring_force(dz[c], corner[c, CK], corner[c, CBETA])
        fd, cd = damper_force(dzdot[c], corner[c, CAR], corner[c, CBR], corner[c, CCR],
                              corner[c, CAC], corner[c, CBC], corner[c, CCC], tau)
        o = c + 1 if c % 2 == 0 else c - 1
        out_force[c] = fs + fd + actuator[c] + corner[c, CKBAR] * (dz[c] - dz[o])
        out_dspring[c] = ks
        out_ddamper[c] = cd


@njit(cache=True)
def seven_dof_rhs(state, road, ax, ay, psidd, actuator, corner, scalars, out):
    """Time derivative of the 14-state vector of the 7-DOF model.

    ``state`` = [z, theta, phi, Z1_0..3, zdot, thetadot, phidot, Z1dot_0..3] (m, rad, m/s, rad/s);
    ``road`` = Z0 under the four wheels (m). Writes d(state)/dt into ``out`` (14,).
    """
    kt, tau, m, Ir, Ip = scalars[SKT], scalars[STAU], scalars[SM], scalars[SIR], scalars[SIP]
    dz = np.empty(4)
    dzd = np.empty(4)
    for c in range(4):
        x, y = corner[c, CX], corner[c, CY]
        dz[c] = state[0] + y * state[1] - x * state[2] - state[3 + c]
        dzd[c] = state[7] + y * state[8] - x * state[9] - state[10 + c]
    F = np.empty(4)
    ks = np.empty(4)
    cd = np.empty(4)
    suspension_tensions(dz, dzd, actuator, corner, tau, F, ks, cd)
    if scalars[SFRIC] > 0.0:
        for c in range(4):
            F[c] += scalars[SFRIC] * math.tanh(dzd[c] / _FRICTION_VELOCITY)
    heave = 0.0
    roll = 0.0
    pitch = 0.0
    for c in range(4):
        heave -= F[c]
        roll -= corner[c, CY] * F[c]
        pitch += corner[c, CX] * F[c]
    for i in range(7):
        out[i] = state[7 + i]
    out[7] = heave / m
    out[8] = (roll + _roll_moment(ay, psidd, corner, scalars)) / Ir
    out[9] = (pitch + _pitch_moment(ax, corner, scalars)) / Ip
    for c in range(4):
        fn = corner[c, CFNAX] * ax + corner[c, CFNAY] * ay
        out[10 + c] = (F[c] - kt * (state[3 + c] - road[c]) + fn) / corner[c, CMW]


@njit(cache=True)
def _roll_moment(ay, psidd, corner, scalars):
    # M Hr a_y + Ixz psidd, recovered from the per-corner coefficients: d_ay = y M Hr / Ir
    y = corner[0, CY]
    return (corner[0, CDAY] * ay + corner[0, CDPSI] * psidd) * scalars[SIR] / y


@njit(cache=True)
def _pitch_moment(ax, corner, scalars):
    # -M Hp a_x ; d_ax = x M Hp / Ip
    x = corner[0, CX]
    return -corner[0, CDAX] * ax * scalars[SIP] / x


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

    (tension sign convention of :mod:`._vertical_model`: the force opposes the damper velocity, dissipative
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


@njit(cache=True)
def mr_controlled_force(current, v, max_force, saturation_current, yield_velocity):
    """Controlled MR force ``F_y(i) tanh(v / v_y)``, N, with ``F_y(i) = F_max (1 - exp(-i / i_sat))`` (i >= 0)."""
    i = current if current > 0.0 else 0.0
    return max_force * (1.0 - math.exp(-i / saturation_current)) * math.tanh(v / yield_velocity)


@njit(cache=True, inline="always")
def mr_map_force(v, yield_force, yield_velocity):
    """MR map at a given yield force: ``F = F_y tanh(v / v_y)`` and its slope ``dF/dv = F_y / v_y (1 - tanh^2)``.

    ``F_y = F_max (1 - exp(-i / i_sat))`` is the yield force of the current (see :func:`mr_controlled_force`);
    the filter's in-model actuator force (``mr_map_velocity="filter"`` of the estimator) evaluates this at its
    own damper-velocity state. Returns (force N, slope N s/m).
    """
    t = math.tanh(v / yield_velocity)
    return yield_force * t, yield_force / yield_velocity * (1.0 - t * t)


@njit(cache=True)
def skyhook_current(body_velocity, damper_velocity, mr):
    """Current (A) of a clipped continuous skyhook (thesis §1.4.2): request ``c_sky Z2dot`` when dissipative.

    When ``Z2dot dZ21dot > 0`` the requested tension ``c_sky Z2dot`` has the sign of the damper velocity and
    the MR map is inverted at the current damper velocity, ``i = -i_sat ln(1 - F / (F_max |tanh(v/v_y)|))``,
    clipped to [0, i_max]; otherwise 0 A (the damper cannot push). ``mr`` = :meth:`MRDamperParams.as_array`.
    """
    if body_velocity * damper_velocity <= 0.0 or mr[0] <= 0.0:
        return 0.0
    want = mr[5] * abs(body_velocity)
    cap = mr[0] * abs(math.tanh(damper_velocity / mr[2]))
    if want >= cap * (1.0 - math.exp(-mr[4] / mr[1])):
        return mr[4]
    return -mr[1] * math.log(1.0 - want / cap)
