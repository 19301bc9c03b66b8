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
functions below, the RK4 simulator in :mod:`._simulate`).

Corner EKF model functions
--------------------------
Compiled transition / observation functions of the thesis-003 corner filters, stacked over the four corners.

State (16,): for corner c = 0..3 (FL, FR, RL, RR) the block ``x[4c:4c+4] = [dZ21dot, dZ21, P, dZ10]``
(thesis §3.5.2: relative velocity m/s, relative displacement m, vehicle disturbance force N, tyre deflection m).
Known input: ``u[0:7] = [a_x, a_y, psidd, U_FL, U_FR, U_RL, U_RR]``, then the in-model MR map (last five
columns, see :func:`longprofile.vehicle.vertical.vertical_ekf_inputs`); the car and the filter settings (dt,
alphas, configuration, Jacobian structure) are the model's ``params`` (:func:`vertical_model_params`).

Transition (thesis (4.7), explicit Euler at Te, digest §6.3)::

    dZ21dot' = dZ21dot + Te * (Z2dd_c - Z1dd_c)
    dZ21'    = dZ21    + Te * dZ21dot
    P'       = alpha_veh   P    (+ (1 - alpha_veh)   B_veh)      alpha = exp(-Te / tau)
    dZ10'    = alpha_route dZ10 (+ (1 - alpha_route) B_route)
    Z2dd_c = -sum_e coupling[c, e] F_e + d_c(a_x, a_y, psidd) + coupling[c, c] P_c
    Z1dd_c = (F_c - k_t dZ10_c + FN_c(a_x, a_y)) / m_w,c

The tensions ``F_e`` of the OTHER corners (and the opposite corner's anti-roll-bar term) are computed from
the other corners' current estimates — the thesis's "forces fed from the other filters" (§3.1, eq. (3.3)).

Jacobians: with ``decentralised=True`` (a model parameter) the transition Jacobian is block-diagonal: each corner
differentiates only its own state, the other corners' forces being known inputs — exactly the thesis's four
per-corner EKFs run in lock-step (block-diagonal Q, R, P0 and H keep the covariance block-diagonal, so the
stacked filter equals the four local filters). With ``decentralised=False`` the full Jacobian (cross-corner
force coupling) gives a centralised full-car EKF on the same model.

Observations: config 1 ``y = dZ21`` (4,); config 2 ``[dZ21, Z2dd]`` (8,); config 3 ``[dZ21, Z1dd]`` (8,).

MR actuator map inside the model (thesis §1.2.4, §3.1: ``F_act = mu(i, T, dZ21dot_hat) dZ21dot_hat``, the
actuator force evaluated at the filter's OWN damper-velocity estimate). Every function takes ``mr`` (5,) =
``[F_y,FL, F_y,FR, F_y,RL, F_y,RR, v_y]``: the map's yield force at the logged current of each corner (N,
``F_max (1 - exp(-i / i_sat))``, computed before the run) and its yield velocity (m/s). With ``v_y > 0`` the
tension of corner c gains ``F_y,c tanh(dZ21dot_c / v_y)`` (on top of the known input ``U_c``) and the damper
slope of every Jacobian gains ``F_y,c / v_y (1 - tanh^2)`` (:func:`mr_map_force`);
``v_y <= 0`` (e.g. :data:`NO_MR`) skips it: the passive / precomputed-input arithmetic is untouched.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..._jit import njit
from ..._validation import require_positive
from ...errors import InputError
from ._params import SENSOR_CONFIGS, VerticalVehicleParams

__all__ = ["vertical_params_arrays", "spring_force", "damper_force", "mr_controlled_force", "mr_map_force",
           "skyhook_current", "CornerFilterSettings", "thesis_filter_settings", "vertical_ekf_model",
           "vertical_linear_model", "MR_MAP_VELOCITIES", "vertical_model_params"]

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


# ----------------------------------------------------------------------------------------------- corner EKF functions

N_STATE = 16
N_INPUT = 7
#: ``mr`` argument meaning "no MR map in the model" (v_y = 0): the passive / precomputed-input path.
NO_MR = np.zeros(5)


@njit(cache=True)
def _forces(x, u, corner, scalars, mr):
    dz = np.empty(4)
    dzd = np.empty(4)
    for c in range(4):
        dzd[c] = x[4 * c]
        dz[c] = x[4 * c + 1]
    F = np.empty(4)
    ks = np.empty(4)
    cd = np.empty(4)
    suspension_tensions(dz, dzd, u[3:7], corner, scalars[STAU], F, ks, cd)
    if mr[4] > 0.0:  # MR map inside the model, at the state's own damper velocity
        for c in range(4):
            fa, ca = mr_map_force(dzd[c], mr[c], mr[4])
            F[c] += fa
            cd[c] += ca
    return F, ks, cd


@njit(cache=True)
def _accels(x, u, corner, coupling, scalars, F):
    """Body-corner and wheel accelerations (4,), (4,) from the stacked state."""
    kt = scalars[SKT]
    ax, ay, ps = u[0], u[1], u[2]
    z2dd = np.empty(4)
    z1dd = np.empty(4)
    for c in range(4):
        acc = corner[c, CDAX] * ax + corner[c, CDAY] * ay + corner[c, CDPSI] * ps + coupling[c, c] * x[4 * c + 2]
        for e in range(4):
            acc -= coupling[c, e] * F[e]
        z2dd[c] = acc
        fn = corner[c, CFNAX] * ax + corner[c, CFNAY] * ay
        z1dd[c] = (F[c] - kt * x[4 * c + 3] + fn) / corner[c, CMW]
    return z2dd, z1dd


@njit(cache=True)
def corner_transition(x, u, corner, coupling, scalars, dt, alpha_veh, alpha_road, mr):
    """Stacked Euler transition x[k] -> x[k+1] (16,) of the four corner models (``mr``: module docstring)."""
    F, ks, cd = _forces(x, u, corner, scalars, mr)
    z2dd, z1dd = _accels(x, u, corner, coupling, scalars, F)
    out = np.empty(16)
    for c in range(4):
        i = 4 * c
        out[i] = x[i] + dt * (z2dd[c] - z1dd[c])
        out[i + 1] = x[i + 1] + dt * x[i]
        out[i + 2] = alpha_veh * x[i + 2]
        out[i + 3] = alpha_road * x[i + 3]
    return out


@njit(cache=True, inline="always")
def _corner_jacobian_block(J, c, corner, coupling, ks, cd, kt, dt, alpha_veh, alpha_road):
    """The 8 structurally non-zero entries of corner c's 4 x 4 block of the decentralised transition Jacobian."""
    i = 4 * c
    inv_mw = 1.0 / corner[c, CMW]
    w = -coupling[c, c] - inv_mw
    J[i, i] = 1.0 + dt * w * cd[c]
    J[i, i + 1] = dt * w * (ks[c] + corner[c, CKBAR])
    _corner_jacobian_rest(J, c, coupling, kt, inv_mw, dt, alpha_veh, alpha_road)


@njit(cache=True, inline="always")
def _corner_jacobian_rest(J, c, coupling, kt, inv_mw, dt, alpha_veh, alpha_road):
    """The entries of corner c's block of the transition Jacobian that no other corner changes: the body force's
    coupling and tyre terms, the displacement's integration and the two disturbances' poles."""
    i = 4 * c
    J[i, i + 2] = dt * coupling[c, c]
    J[i, i + 3] = dt * kt * inv_mw
    J[i + 1, i] = dt
    J[i + 1, i + 1] = 1.0
    J[i + 2, i + 2] = alpha_veh
    J[i + 3, i + 3] = alpha_road


@njit(cache=True)
def corner_transition_jacobian(x, u, corner, coupling, scalars, dt, alpha_veh, alpha_road, decentralised, mr):
    """Jacobian A_d = I + Te A_c (16, 16) of :func:`corner_transition` (analytic spring, damper, MR-map slopes)."""
    F, ks, cd = _forces(x, u, corner, scalars, mr)
    kt = scalars[SKT]
    J = np.zeros((16, 16))
    if decentralised:  # fast path: own corner only (the other corners' forces are inputs)
        for c in range(4):
            _corner_jacobian_block(J, c, corner, coupling, ks, cd, kt, dt, alpha_veh, alpha_road)
        return J
    # dF_g / d dZ_e and dF_g / d dZdot_e
    dF_dz = np.zeros((4, 4))
    dF_dv = np.zeros((4, 4))
    for g in range(4):
        o = g + 1 if g % 2 == 0 else g - 1
        dF_dz[g, g] = ks[g] + corner[g, CKBAR]
        dF_dz[g, o] = -corner[g, CKBAR]
        dF_dv[g, g] = cd[g]
    for c in range(4):
        i = 4 * c
        inv_mw = 1.0 / corner[c, CMW]
        for e in range(4):
            if decentralised and e != c:
                continue
            j = 4 * e
            dv = 0.0
            dz = 0.0
            for g in range(4):
                w = -coupling[c, g] - (inv_mw if g == c else 0.0)
                if decentralised and g != c:
                    continue
                dv += w * dF_dv[g, e]
                dz += w * dF_dz[g, e]
            J[i, j] = dt * dv
            J[i, j + 1] = dt * dz
        J[i, i] += 1.0
        _corner_jacobian_rest(J, c, coupling, kt, inv_mw, dt, alpha_veh, alpha_road)
    return J


@njit(cache=True)
def corner_observation(x, u, corner, coupling, scalars, config, mr):
    """Stacked observation: dZ21 (4,) for config 1; [dZ21, Z2dd] (8,) config 2; [dZ21, Z1dd] (8,) config 3."""
    m = 4 if config == 1 else 8
    y = np.empty(m)
    for c in range(4):
        y[c] = x[4 * c + 1]
    if config != 1:
        F, ks, cd = _forces(x, u, corner, scalars, mr)
        z2dd, z1dd = _accels(x, u, corner, coupling, scalars, F)
        for c in range(4):
            y[4 + c] = z2dd[c] if config == 2 else z1dd[c]
    return y


@njit(cache=True)
def corner_observation_jacobian(x, u, corner, coupling, scalars, config, decentralised, mr):
    """Jacobian C (m, 16) of :func:`corner_observation`."""
    m = 4 if config == 1 else 8
    H = np.zeros((m, 16))
    for c in range(4):
        H[c, 4 * c + 1] = 1.0
    if config == 1:
        return H
    F, ks, cd = _forces(x, u, corner, scalars, mr)
    kt = scalars[SKT]
    for c in range(4):
        row = 4 + c
        o = c + 1 if c % 2 == 0 else c - 1
        if config == 2:
            for g in range(4):
                if decentralised and g != c:
                    continue
                w = -coupling[c, g]
                og = g + 1 if g % 2 == 0 else g - 1
                # dF_g/d dZdot_g, dF_g/d dZ_g and dF_g/d dZ_og
                H[row, 4 * g] += w * cd[g]
                H[row, 4 * g + 1] += w * (ks[g] + corner[g, CKBAR])
                if not decentralised:
                    H[row, 4 * og + 1] += -w * corner[g, CKBAR]
            H[row, 4 * c + 2] = coupling[c, c]
        else:
            inv_mw = 1.0 / corner[c, CMW]
            H[row, 4 * c] = cd[c] * inv_mw
            H[row, 4 * c + 1] = (ks[c] + corner[c, CKBAR]) * inv_mw
            if not decentralised:
                H[row, 4 * o + 1] = -corner[c, CKBAR] * inv_mw
            H[row, 4 * c + 3] = -kt * inv_mw
    return H


# ------------------------------------------------------------------ fused, allocation-free per-corner steps
# The block EKF evaluates f and its Jacobian at the same state x[k|k], and h and its Jacobian at the same
# x[k+1|k]. The "step" functions below compute each pair in one pass (the four suspension tensions, i.e. the
# 12 tanh of the dampers, once per pair instead of twice) and write into the engine's preallocated outputs,
# writing only the structurally non-zero entries of the block-diagonal Jacobians (the other entries are
# never touched and stay zero). Arithmetic is the same, operation by operation, as the functions above.


@njit(cache=True, inline="always")
def _tension(x, u, corner, tau, c, mr):
    """Tension F_c, spring slope and damper slope of corner c from the stacked state (no allocation)."""
    o = c + 1 if c % 2 == 0 else c - 1
    dz = x[4 * c + 1]
    fs, ks = spring_force(dz, corner[c, CK], corner[c, CBETA])
    fd, cd = damper_force(x[4 * c], corner[c, CAR], corner[c, CBR], corner[c, CCR],
                          corner[c, CAC], corner[c, CBC], corner[c, CCC], tau)
    f = fs + fd + u[3 + c] + corner[c, CKBAR] * (dz - x[4 * o + 1])
    if mr[4] > 0.0:  # same operations, same order as _forces
        fa, ca = mr_map_force(x[4 * c], mr[c], mr[4])
        f += fa
        cd += ca
    return f, ks, cd


@njit(cache=True, inline="always")
def _tensions(x, u, corner, scalars, mr):
    tau = scalars[STAU]
    f0, k0, c0 = _tension(x, u, corner, tau, 0, mr)
    f1, k1, c1 = _tension(x, u, corner, tau, 1, mr)
    f2, k2, c2 = _tension(x, u, corner, tau, 2, mr)
    f3, k3, c3 = _tension(x, u, corner, tau, 3, mr)
    return (f0, f1, f2, f3), (k0, k1, k2, k3), (c0, c1, c2, c3)


@njit(cache=True, inline="always")
def _body_accel(x, u, corner, coupling, F, c):
    acc = (corner[c, CDAX] * u[0] + corner[c, CDAY] * u[1] + corner[c, CDPSI] * u[2]
           + coupling[c, c] * x[4 * c + 2])
    for e in range(4):
        acc -= coupling[c, e] * F[e]
    return acc


@njit(cache=True, inline="always")
def _wheel_accel(x, u, corner, kt, F, c):
    fn = corner[c, CFNAX] * u[0] + corner[c, CFNAY] * u[1]
    return (F[c] - kt * x[4 * c + 3] + fn) / corner[c, CMW]


@njit(cache=True)
def corner_transition_step(x, u, corner, coupling, scalars, dt, alpha_veh, alpha_road, mr, out, J):
    """:func:`corner_transition` into ``out`` (16,) and its block-diagonal Jacobian into ``J`` (16, 16), fused.

    Only the 8 structurally non-zero entries of each corner's 4 x 4 block are written
    (``decentralised=True`` Jacobian of :func:`corner_transition_jacobian`); the rest of ``J`` is not touched.
    """
    F, ks, cd = _tensions(x, u, corner, scalars, mr)
    kt = scalars[SKT]
    for c in range(4):
        i = 4 * c
        z2dd = _body_accel(x, u, corner, coupling, F, c)
        z1dd = _wheel_accel(x, u, corner, kt, F, c)
        out[i] = x[i] + dt * (z2dd - z1dd)
        out[i + 1] = x[i + 1] + dt * x[i]
        out[i + 2] = alpha_veh * x[i + 2]
        out[i + 3] = alpha_road * x[i + 3]
        _corner_jacobian_block(J, c, corner, coupling, ks, cd, kt, dt, alpha_veh, alpha_road)


@njit(cache=True)
def corner_observation_step(x, u, corner, coupling, scalars, config, mr, out, H):
    """:func:`corner_observation` into ``out`` (m,) and its block-diagonal Jacobian into ``H`` (m, 16), fused.

    Only the structurally non-zero entries of the decentralised Jacobian are written.
    """
    for c in range(4):
        out[c] = x[4 * c + 1]
        H[c, 4 * c + 1] = 1.0
    if config == 1:
        return
    F, ks, cd = _tensions(x, u, corner, scalars, mr)
    kt = scalars[SKT]
    for c in range(4):
        row = 4 + c
        i = 4 * c
        if config == 2:
            out[row] = _body_accel(x, u, corner, coupling, F, c)
            w = -coupling[c, c]
            H[row, i] = w * cd[c]
            H[row, i + 1] = w * (ks[c] + corner[c, CKBAR])
            H[row, i + 2] = coupling[c, c]
        else:
            out[row] = _wheel_accel(x, u, corner, kt, F, c)
            inv_mw = 1.0 / corner[c, CMW]
            H[row, i] = cd[c] * inv_mw
            H[row, i + 1] = (ks[c] + corner[c, CKBAR]) * inv_mw
            H[row, i + 3] = -kt * inv_mw


# ----------------------------------------------------------------------------------------------- EKF model builders

_DISP_VAR = 3e-8  # thesis (4.2): (6e-4 m)^2 / 12


@dataclass(frozen=True)
class CornerFilterSettings:
    """Noise settings of one corner EKF (the same for the four corners), thesis §4.2-§4.5.

    Attributes
    ----------
    vehicle_var : float
        lambda_veh^2, N^2: variance of the white noise driving the vehicle disturbance P.
    road_var : float
        lambda_route^2, m^2: variance of the white noise driving the tyre deflection dZ10.
    accel_var : float or None
        Variance of the accelerometer measurement noise, (m/s^2)^2 (configs 2 and 3; None for config 1).
    displacement_var : float
        R of the displacement sensor, m^2 (thesis: 3e-8).
    tau_vehicle, tau_road : float
        Time constants of the first-order disturbance models, s (thesis: 0.1 and 0.01 s).
    initial_var : tuple of 4 floats
        Diagonal of P0 per corner for [dZ21dot, dZ21, P, dZ10].
    """

    vehicle_var: float
    road_var: float
    accel_var: float | None = None
    displacement_var: float = _DISP_VAR
    tau_vehicle: float = 0.1
    tau_road: float = 0.01
    initial_var: tuple = ((0.1 / 3) ** 2, 0.05 ** 2, 5e4, 2.5e-7)

    def __post_init__(self):
        for name in ("vehicle_var", "road_var", "displacement_var", "tau_vehicle", "tau_road"):
            require_positive(name, getattr(self, name))
        if self.accel_var is not None:
            require_positive("accel_var", self.accel_var)
        iv = tuple(float(v) for v in self.initial_var)
        if len(iv) != 4 or any(not math.isfinite(v) or v <= 0 for v in iv):
            raise InputError(f"initial_var must be 4 positive variances; got {self.initial_var!r}.")
        object.__setattr__(self, "initial_var", iv)

    def alphas(self, dt: float) -> tuple[float, float]:
        """(alpha_veh, alpha_route) = exp(-dt / tau)."""
        return math.exp(-dt / self.tau_vehicle), math.exp(-dt / self.tau_road)

    def stationary_var(self, dt: float) -> tuple[float, float]:
        """Stationary variances lambda^2 (1 - alpha) / (1 + alpha) of P (N^2) and dZ10 (m^2)."""
        av, ar = self.alphas(dt)
        return self.vehicle_var * (1 - av) / (1 + av), self.road_var * (1 - ar) / (1 + ar)


def thesis_filter_settings(config: int, dt: float = 1e-3) -> CornerFilterSettings:
    """The Q / R / P0 settings of the thesis for configuration 1, 2 or 3 (digest §6.4).

    * config 1: Q = diag(1e7 N^2, 5e-6 m^2), R = 3e-8 m^2 (thesis (4.3), Table 1 optimum); P0 =
      diag((0.1/3)^2, 0.05^2, 5e4, 2.5e-7) (the printed 2.5e-6 for dZ10 is a misprint of the stationary
      variance 2.5e-7 m^2).
    * config 2: Q = diag(5e6, 1e-5) (Table 2 optimum; reproduces the printed stds 150 N / 0.7 mm);
      accelerometer R = 0.05 (m/s^2)^2 (lost in the thesis; ASSUMPTION: quantisation 1.2e-4 plus the
      35 Hz engine order and low-frequency tilt errors, tuned on the simulator).
    * config 3: Q = diag(5e6, 1e-6) (Table 3 optimum; stds 150 N / 0.2 mm); wheel accelerometer
      R = 0.08 (m/s^2)^2 (lost; ASSUMPTION: quantisation 0.48^2/12 = 0.019 plus broadband noise).
    P0 of configs 2, 3: as config 1 for the relative states, stationary values for P and dZ10.
    """
    if config not in SENSOR_CONFIGS:
        raise InputError(f"config must be 1, 2 or 3 (thesis sensor configurations); got {config!r}.")
    v0, d0 = (0.1 / 3) ** 2, 0.05 ** 2
    if config == 1:
        return CornerFilterSettings(vehicle_var=1e7, road_var=5e-6, initial_var=(v0, d0, 5e4, 2.5e-7))
    if config == 2:
        s = CornerFilterSettings(vehicle_var=5e6, road_var=1e-5, accel_var=0.05)
    else:
        s = CornerFilterSettings(vehicle_var=5e6, road_var=1e-6, accel_var=0.08)
    pv, rv = s.stationary_var(dt)
    return CornerFilterSettings(vehicle_var=s.vehicle_var, road_var=s.road_var, accel_var=s.accel_var,
                                initial_var=(v0, d0, pv, rv))


def _engine():
    """The engine's NonlinearStateSpaceModel, extended_kalman_filter and block_extended_kalman_filter."""
    from ...statespace import NonlinearStateSpaceModel, block_extended_kalman_filter, extended_kalman_filter

    return NonlinearStateSpaceModel, extended_kalman_filter, block_extended_kalman_filter


STATE_BLOCKS = np.repeat(np.arange(4), 4)


# Columns of the EKF's known-input row (N_U = 12): the measured manoeuvre inputs, the actuator forces, then the
# MR map evaluated INSIDE the model (``mr_map_velocity="filter"``): the map's yield force at the logged current
# per corner (N) and its yield velocity (m/s; 0 = no in-model map, the passive / precomputed-input path). The
# model functions read the map from the LAST five columns, so a legacy 17-column row (which had dt, alpha_veh,
# alpha_route, config and decentralised in columns 7-11, now model parameters) still gives the same result.
U_AX, U_AY, U_PSIDD, U_ACT = 0, 1, 2, 3
U_MR_FY, U_MR_VY = 7, 11
N_U = 12
#: Where the MR map's velocity comes from (:func:`estimate_vertical_states`).
MR_MAP_VELOCITIES = ("displacement", "filter")

# Layout of the model's params (the engine's f(x, u, k, params)): the corner table (4, N_COL) row by row, the
# coupling matrix (4, 4) row by row, the scalars (N_SCAL,), then the filter settings. Read at run time, so ONE
# compiled set of model functions serves every car, sample period, configuration and Jacobian structure.
PAR_CORNER = 0
PAR_COUPLING = PAR_CORNER + N_CORNERS * N_COL
PAR_SCALARS = PAR_COUPLING + N_CORNERS * N_CORNERS
PAR_DT = PAR_SCALARS + N_SCAL
PAR_ALPHA_VEH, PAR_ALPHA_ROAD, PAR_CONFIG, PAR_DECENTRALISED = PAR_DT + 1, PAR_DT + 2, PAR_DT + 3, PAR_DT + 4
N_PAR = PAR_DT + 5


def vertical_model_params(params: VerticalVehicleParams, config: int, dt: float, alpha_veh: float,
                          alpha_road: float, decentralised: bool) -> np.ndarray:
    """The (N_PAR,) = (96,) ``params`` vector of the corner EKF model functions.

    Offsets: ``[PAR_CORNER:PAR_COUPLING]`` the corner table of :func:`vertical_params_arrays` (4 x 17, row by
    row), ``[PAR_COUPLING:PAR_SCALARS]`` the coupling matrix (4 x 4), ``[PAR_SCALARS:PAR_DT]`` the 7 scalars,
    then dt (s), alpha_veh, alpha_route, config (1, 2, 3) and decentralised (1.0 block-diagonal Jacobians,
    0.0 full) at ``PAR_DT .. PAR_DECENTRALISED``.
    """
    corner, coupling, scalars = vertical_params_arrays(params)
    out = np.empty(N_PAR)
    out[PAR_CORNER:PAR_COUPLING] = corner.ravel()
    out[PAR_COUPLING:PAR_SCALARS] = coupling.ravel()
    out[PAR_SCALARS:PAR_DT] = scalars
    out[PAR_DT:] = (dt, alpha_veh, alpha_road, config, 1.0 if decentralised else 0.0)
    return out


@njit(cache=True, inline="always")
def _unpack(params):
    """Views (corner (4, 17), coupling (4, 4), scalars (7,)) of the model's params (no copy)."""
    corner = params[PAR_CORNER:PAR_COUPLING].reshape((N_CORNERS, N_COL))
    coupling = params[PAR_COUPLING:PAR_SCALARS].reshape((N_CORNERS, N_CORNERS))
    return corner, coupling, params[PAR_SCALARS:PAR_DT]


@njit(cache=True, inline="always")
def _mr(u):
    """The ``mr`` argument (5,) of the corner functions: the last five columns of the input row (a view)."""
    return u[u.shape[0] - 5:]


@njit(cache=True)
def vertical_f(x, u, k, params):
    """Transition of the corner EKF model (:func:`corner_transition`; ``params``: :func:`vertical_model_params`)."""
    corner, coupling, scalars = _unpack(params)
    return corner_transition(x, u, corner, coupling, scalars, params[PAR_DT], params[PAR_ALPHA_VEH],
                             params[PAR_ALPHA_ROAD], _mr(u))


@njit(cache=True)
def vertical_f_jac(x, u, k, params):
    """Transition Jacobian (:func:`corner_transition_jacobian`)."""
    corner, coupling, scalars = _unpack(params)
    return corner_transition_jacobian(x, u, corner, coupling, scalars, params[PAR_DT], params[PAR_ALPHA_VEH],
                                      params[PAR_ALPHA_ROAD], params[PAR_DECENTRALISED] > 0.5, _mr(u))


@njit(cache=True)
def vertical_h(x, u, k, params):
    """Observation (:func:`corner_observation`)."""
    corner, coupling, scalars = _unpack(params)
    return corner_observation(x, u, corner, coupling, scalars, int(params[PAR_CONFIG]), _mr(u))


@njit(cache=True)
def vertical_h_jac(x, u, k, params):
    """Observation Jacobian (:func:`corner_observation_jacobian`)."""
    corner, coupling, scalars = _unpack(params)
    return corner_observation_jacobian(x, u, corner, coupling, scalars, int(params[PAR_CONFIG]),
                                       params[PAR_DECENTRALISED] > 0.5, _mr(u))


@njit(cache=True)
def vertical_f_step(x, u, k, params, out, J):
    """Fused transition and block-diagonal Jacobian (:func:`corner_transition_step`)."""
    corner, coupling, scalars = _unpack(params)
    corner_transition_step(x, u, corner, coupling, scalars, params[PAR_DT], params[PAR_ALPHA_VEH],
                           params[PAR_ALPHA_ROAD], _mr(u), out, J)


@njit(cache=True)
def vertical_h_step(x, u, k, params, out, H):
    """Fused observation and block-diagonal Jacobian (:func:`corner_observation_step`)."""
    corner, coupling, scalars = _unpack(params)
    corner_observation_step(x, u, corner, coupling, scalars, int(params[PAR_CONFIG]), _mr(u), out, H)


def vertical_ekf_model(config: int, dt: float = 1e-3, *, params: VerticalVehicleParams | None = None,
                       settings: CornerFilterSettings | None = None, fused_steps: bool = True,
                       decentralised: bool = True):
    """The thesis's corner EKFs as one :class:`~longprofile.statespace.NonlinearStateSpaceModel` (16 states).

    Run it with :func:`~longprofile.statespace.block_extended_kalman_filter` (one block per corner: the
    thesis's four per-corner EKFs, the other corners' forces entering through their estimates, §3.1) or with
    :func:`~longprofile.statespace.extended_kalman_filter` (centralised full-car EKF, ``decentralised=False``).

    Parameters
    ----------
    config : {1, 2, 3}
        Sensor configuration (observation (4,) displacements, or (8,) displacements + accelerations).
    dt : float
        Sample period Te, s (thesis: 1e-3).
    params : VerticalVehicleParams, optional
        Model parameters used by the filter (default: thesis set).
    settings : CornerFilterSettings, optional
        Noise settings (default :func:`thesis_filter_settings`).
    fused_steps : bool, default True
        Attach the fused, allocation-free model steps (``transition_step``/``observation_step``): each
        evaluates the four suspension tensions once for a function and its Jacobian (same results as the
        separate functions, about 1.3x faster). They write the per-corner (block-diagonal) Jacobians only,
        so they serve :func:`~longprofile.statespace.block_extended_kalman_filter`; build the model with
        ``fused_steps=False`` for the centralised ``extended_kalman_filter`` (which checks the full Jacobian
        and refuses the steps with a ModelError).
    decentralised : bool, default True
        Block-diagonal Jacobians (each corner differentiates its own state only: the thesis's per-corner
        filters) or, False, the full Jacobians of the centralised EKF (needs ``fused_steps=False``). Until
        issue 12 this was the ``decentralised`` column of the input row.

    Returns
    -------
    NonlinearStateSpaceModel
        Transition/observation functions are module-level numba functions called as ``f(x, u, k, params)``
        with ``params`` = :func:`vertical_model_params` (the car, dt, alpha_veh, alpha_route, config and
        ``decentralised``: one compiled set of functions for every car and setting); the known input row
        (12,) is ``[a_x, a_y, psidd, U_FL, U_FR, U_RL, U_RR, F_y,FL, F_y,FR, F_y,RL, F_y,RR, v_y]`` — build
        it with :func:`vertical_ekf_inputs` (the last five: the MR map inside the model, ``v_y = 0`` = none).
        State order per corner c: ``x[4c:4c+4] = [dZ21dot, dZ21, P, dZ10]``.
    """
    NonlinearStateSpaceModel = _engine()[0]
    if config not in SENSOR_CONFIGS:
        raise InputError(f"config must be 1, 2 or 3 (thesis sensor configurations); got {config!r}.")
    dt = require_positive("dt", dt)
    p = params or VerticalVehicleParams()
    s = settings or thesis_filter_settings(config, dt)
    if config != 1 and s.accel_var is None:
        raise InputError(f"configuration {config} has accelerometers: settings.accel_var must be given.")
    if fused_steps and not decentralised:
        raise InputError("the fused model steps write the per-corner (block-diagonal) Jacobians only: build the "
                         "centralised model (decentralised=False) with fused_steps=False.")
    av, ar = s.alphas(dt)
    q = np.zeros(16)
    q[2::4] = (1 - av) ** 2 * s.vehicle_var
    q[3::4] = (1 - ar) ** 2 * s.road_var
    m = 4 if config == 1 else 8
    r = np.full(m, s.displacement_var)
    if config != 1:
        r[4:] = s.accel_var
    return NonlinearStateSpaceModel(
        transition_fn=vertical_f, observation_fn=vertical_h, process_cov=np.diag(q), obs_cov=np.diag(r),
        initial_mean=np.zeros(16), initial_cov=np.diag(np.tile(s.initial_var, 4)),
        transition_jacobian=vertical_f_jac, observation_jacobian=vertical_h_jac,
        transition_step=vertical_f_step if fused_steps else None,
        observation_step=vertical_h_step if fused_steps else None,
        params=vertical_model_params(p, config, dt, av, ar, decentralised))


def vertical_linear_model(config: int, dt: float = 1e-3, *, params: VerticalVehicleParams | None = None,
                          settings: CornerFilterSettings | None = None):
    """Linear-Gaussian full-car model: the corner model linearised at rest with ALL cross-corner couplings.

    ``x[k+1] = F x[k] + B u[k] + w``, ``y = H x + D u + v`` with F, H the full (centralised) Jacobians of
    :func:`vertical_ekf_model` at x = 0, u = 0 and B, D the exact input matrices of a_x, a_y, psidd and the
    four actuator forces (the model is affine in them). The damper is linearised at v = 0, where its slope
    (the mean of the rebound and compression slopes) is far steeper than at working velocities: this is the
    linear comparison point that motivates the thesis's EKF.

    Returns
    -------
    StateSpaceModel
        16 states (as the EKF), 7 inputs ``[a_x, a_y, psidd, U_FL, U_FR, U_RL, U_RR]``.
    """
    from ...statespace import StateSpaceModel

    nl = vertical_ekf_model(config, dt, params=params, settings=settings, fused_steps=False, decentralised=False)
    u0 = np.zeros(N_U)
    x0 = np.zeros(16)
    F = nl.transition_jacobian(*nl.model_args(x0, u0, 0))
    H = nl.observation_jacobian(*nl.model_args(x0, u0, 0))
    B = np.empty((16, 7))
    D = np.empty((H.shape[0], 7))
    f0, h0 = nl.transition_fn(*nl.model_args(x0, u0, 0)), nl.observation_fn(*nl.model_args(x0, u0, 0))
    for j in range(7):
        uj = u0.copy()
        uj[j] = 1.0  # f and h are affine in the inputs: one unit step gives the exact column
        B[:, j] = nl.transition_fn(*nl.model_args(x0, uj, 0)) - f0
        D[:, j] = nl.observation_fn(*nl.model_args(x0, uj, 0)) - h0
    return StateSpaceModel(transition=F, observation=H, process_cov=np.asarray(nl.process_cov),
                           obs_cov=np.asarray(nl.obs_cov), initial_mean=np.zeros(16),
                           initial_cov=np.asarray(nl.initial_cov), input_transition=B, input_observation=D)
