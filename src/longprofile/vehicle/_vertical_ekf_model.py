"""Compiled transition / observation functions of the thesis-003 corner filters, stacked over the four corners.

State (16,): for corner c = 0..3 (FL, FR, RL, RR) the block ``x[4c:4c+4] = [dZ21dot, dZ21, P, dZ10]``
(thesis §3.5.2: relative velocity m/s, relative displacement m, vehicle disturbance force N, tyre deflection m).
Known input: ``u[0:7] = [a_x, a_y, psidd, U_FL, U_FR, U_RL, U_RR]`` (further columns carry filter settings,
see :func:`longprofile.vehicle._vertical_estimate.vertical_ekf_inputs`).

Transition (thesis (4.7), explicit Euler at Te, digest §6.3)::

    dZ21dot' = dZ21dot + Te * (Z2dd_c - Z1dd_c)
    dZ21'    = dZ21    + Te * dZ21dot
    P'       = alpha_veh   P    (+ (1 - alpha_veh)   B_veh)      alpha = exp(-Te / tau)
    dZ10'    = alpha_route dZ10 (+ (1 - alpha_route) B_route)
    Z2dd_c = -sum_e coupling[c, e] F_e + d_c(a_x, a_y, psidd) + coupling[c, c] P_c
    Z1dd_c = (F_c - k_t dZ10_c + FN_c(a_x, a_y)) / m_w,c

The tensions ``F_e`` of the OTHER corners (and the opposite corner's anti-roll-bar term) are computed from
the other corners' current estimates — the thesis's "forces fed from the other filters" (§3.1, eq. (3.3)).

Jacobians: with ``decentralised=True`` the transition Jacobian is block-diagonal: each corner
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
slope of every Jacobian gains ``F_y,c / v_y (1 - tanh^2)`` (:func:`._vertical_model.mr_map_force`);
``v_y <= 0`` (e.g. :data:`NO_MR`) skips it: the passive / precomputed-input arithmetic is untouched.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._vertical_model import (CAC, CAR, CBC, CBETA, CBR, CCC, CCR, CDAX, CDAY, CDPSI, CFNAX, CFNAY, CK, CKBAR,
                              CMW, SKT, STAU, damper_force, mr_map_force, spring_force, suspension_tensions)

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


@njit(cache=True)
def corner_transition_jacobian(x, u, corner, coupling, scalars, dt, alpha_veh, alpha_road, decentralised, mr):
    """Jacobian A_d = I + Te A_c (16, 16) of :func:`corner_transition` (analytic spring, damper, MR-map slopes)."""
    F, ks, cd = _forces(x, u, corner, scalars, mr)
    kt = scalars[SKT]
    J = np.zeros((16, 16))
    if decentralised:  # fast path: own corner only (the other corners' forces are inputs)
        for c in range(4):
            i = 4 * c
            inv_mw = 1.0 / corner[c, CMW]
            w = -coupling[c, c] - inv_mw
            J[i, i] = 1.0 + dt * w * cd[c]
            J[i, i + 1] = dt * w * (ks[c] + corner[c, CKBAR])
            J[i, i + 2] = dt * coupling[c, c]
            J[i, i + 3] = dt * kt * inv_mw
            J[i + 1, i] = dt
            J[i + 1, i + 1] = 1.0
            J[i + 2, i + 2] = alpha_veh
            J[i + 3, i + 3] = alpha_road
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
        J[i, i + 2] = dt * coupling[c, c]
        J[i, i + 3] = dt * kt * inv_mw
        J[i + 1, i] = dt
        J[i + 1, i + 1] = 1.0
        J[i + 2, i + 2] = alpha_veh
        J[i + 3, i + 3] = alpha_road
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
        inv_mw = 1.0 / corner[c, CMW]
        w = -coupling[c, c] - inv_mw
        J[i, i] = 1.0 + dt * w * cd[c]
        J[i, i + 1] = dt * w * (ks[c] + corner[c, CKBAR])
        J[i, i + 2] = dt * coupling[c, c]
        J[i, i + 3] = dt * kt * inv_mw
        J[i + 1, i] = dt
        J[i + 1, i + 1] = 1.0
        J[i + 2, i + 2] = alpha_veh
        J[i + 3, i + 3] = alpha_road


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
