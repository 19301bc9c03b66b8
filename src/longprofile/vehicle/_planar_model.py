"""The planar 4-wheel vehicle model of paper 001, eq. (11)-(19), as numba kernels on plain float arrays.

Conventions (used by every kernel here):

* body axes x forward, y left, z up; yaw rate r = psi_dot positive counter-clockwise;
* wheel order FL, FR, RL, RR (1..4 in the paper), consistent with the signs of eq. (14) and (19);
* state ``x = (V_x, V_y, r)`` (m/s, m/s, rad/s) — the EKF state of eq. (20);
* input row ``u`` of length :data:`N_INPUTS`:
  ``(delta, omega_fl, omega_fr, omega_rl, omega_rr, a_x, a_y, slope, mu_fl, mu_fr, mu_rl, mu_rr)``
  with delta the front road-wheel steering angle (rad), omega the wheel spin rates (rad/s),
  a_x, a_y the accelerometer readings (specific force, m/s^2), slope the road grade angle (rad).
* ``p`` is ``Vehicle.as_array()``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._car import (P_CX0, P_CXA, P_CY0, P_CYA, P_G, P_H, P_IZ, P_LF, P_LR, P_MASS, P_R, P_TRACK)
from ._dugoff import dugoff_grad

U_DELTA, U_OMEGA, U_AX, U_AY, U_SLOPE, U_MU = 0, 1, 5, 6, 7, 8
N_INPUTS = 12
#: Floor of the slip denominator max(R omega, V) of eq. (18), m/s: the model is not meant for standstill.
V_MIN = 0.5


@njit(cache=True)
def normal_loads(p, ax, ay, slope, out):
    """Eq. (19): static load, longitudinal and lateral load transfer; ``out`` (4,) in N.

    ``ax``, ``ay`` are accelerometer readings (specific force). With them, eq. (19) is exact for a
    rigid body on a grade: the longitudinal transfer is H M a_x / L with a_x = dV_x/dt - r V_y + g sin(theta).
    """
    m = p[P_MASS]
    lf = p[P_LF]
    lr = p[P_LR]
    L = lf + lr
    h = p[P_H]
    sb = p[P_TRACK]
    w = m * p[P_G] * math.cos(slope)
    dx = h * m * ax / (2.0 * L)
    out[0] = lr * w / (2.0 * L) - dx - lr * h * m * ay / (sb * L)
    out[1] = lr * w / (2.0 * L) - dx + lr * h * m * ay / (sb * L)
    out[2] = lf * w / (2.0 * L) + dx - lf * h * m * ay / (sb * L)
    out[3] = lf * w / (2.0 * L) + dx + lf * h * m * ay / (sb * L)


@njit(cache=True)
def tyre_kinematics_forces(vx, vy, r, delta, omega, fn, mu, p, slip, alpha, fx, fy, dfx, dfy, dfn, dfw):
    """Eq. (18) slips and slip angles, then Dugoff forces (15)-(17) of the 4 tyres.

    Writes ``slip``, ``alpha`` (rad), ``fx``, ``fy`` (N, wheel axes) of shape (4,), and the
    derivatives ``dfx``, ``dfy`` (4, 3) of the forces w.r.t. the state (V_x, V_y, r), and in ``dfn``
    (2, 4) the derivatives of (fx, fy) w.r.t. each wheel's normal load, in ``dfw`` (2, 4) those
    w.r.t. each wheel's spin rate.
    The wheel-centre velocity of wheel i at (x_i, y_i) is (V_x - r y_i, V_y + r x_i); the slip uses
    its component along the wheel plane, the slip angle is delta_i - atan(v_y,i / v_x,i).
    """
    lf = p[P_LF]
    lr = p[P_LR]
    hb = 0.5 * p[P_TRACK]
    R = p[P_R]
    cx0 = p[P_CX0]
    cy0 = p[P_CY0]
    for i in range(4):
        xi = lf if i < 2 else -lr
        yi = hb if (i % 2) == 0 else -hb
        di = delta if i < 2 else 0.0
        c = math.cos(di)
        s = math.sin(di)
        vxi = vx - r * yi
        vyi = vy + r * xi
        # derivatives of (vxi, vyi) w.r.t. (vx, vy, r): (1, 0, -yi) and (0, 1, xi)
        vw = vxi * c + vyi * s
        dvw0 = c
        dvw1 = s
        dvw2 = -yi * c + xi * s
        rw = R * omega[i]
        if rw >= vw and rw >= V_MIN:
            lam = (rw - vw) / rw
            dl = -1.0 / rw
            dlw = R * vw / (rw * rw)
        elif vw >= V_MIN:
            lam = rw / vw - 1.0
            dl = -rw / (vw * vw)
            dlw = R / vw
        else:
            lam = (rw - vw) / V_MIN
            dl = -1.0 / V_MIN
            dlw = R / V_MIN
        beta = math.atan2(vyi, vxi)
        a = di - beta
        t = math.tan(a)
        q = vxi * vxi + vyi * vyi
        # d(beta) = (vxi d(vyi) - vyi d(vxi)) / q ; d(alpha) = -d(beta) ; d(t) = (1 + t^2) d(alpha)
        k = -(1.0 + t * t) / q
        dt0 = k * (-vyi)
        dt1 = k * vxi
        dt2 = k * (vxi * xi + vyi * yi)
        f_x, f_y, fxl, fxt, fyl, fyt, fxn, fyn = dugoff_grad(lam, t, fn[i], mu[i], cx0, cy0)
        dfn[0, i] = fxn
        dfn[1, i] = fyn
        dfw[0, i] = fxl * dlw
        dfw[1, i] = fyl * dlw
        slip[i] = lam
        alpha[i] = a
        fx[i] = f_x
        fy[i] = f_y
        dfx[i, 0] = fxl * dl * dvw0 + fxt * dt0
        dfx[i, 1] = fxl * dl * dvw1 + fxt * dt1
        dfx[i, 2] = fxl * dl * dvw2 + fxt * dt2
        dfy[i, 0] = fyl * dl * dvw0 + fyt * dt0
        dfy[i, 1] = fyl * dl * dvw1 + fyt * dt1
        dfy[i, 2] = fyl * dl * dvw2 + fyt * dt2


@njit(cache=True, inline="always")
def body_sums(fx, fy, delta, p):
    """Eq. (12)-(14): total longitudinal and lateral force (N) and yaw moment (N m) in body axes.

    The rear wheels are not steered (the angle beta of (12)-(13) is zero for the cars modelled here).
    """
    lf = p[P_LF]
    lr = p[P_LR]
    hb = 0.5 * p[P_TRACK]
    c = math.cos(delta)
    s = math.sin(delta)
    fxf = fx[0] + fx[1]
    fyf = fy[0] + fy[1]
    sfx = fxf * c - fyf * s + fx[2] + fx[3]
    sfy = fxf * s + fyf * c + fy[2] + fy[3]
    mz = (lf * fxf * s + lf * fyf * c + hb * (fx[1] - fx[0]) * c + hb * (fx[3] - fx[2])
          - hb * (fy[1] - fy[0]) * s - lr * (fy[2] + fy[3]))
    return sfx, sfy, mz


@njit(cache=True)
def body_sums_grad(dfx, dfy, delta, p, out):
    """Gradient (3 sums x 3 states) of :func:`body_sums` given the force gradients (4, 3)."""
    lf = p[P_LF]
    lr = p[P_LR]
    hb = 0.5 * p[P_TRACK]
    c = math.cos(delta)
    s = math.sin(delta)
    for j in range(3):
        fxf = dfx[0, j] + dfx[1, j]
        fyf = dfy[0, j] + dfy[1, j]
        out[0, j] = fxf * c - fyf * s + dfx[2, j] + dfx[3, j]
        out[1, j] = fxf * s + fyf * c + dfy[2, j] + dfy[3, j]
        out[2, j] = (lf * fxf * s + lf * fyf * c + hb * (dfx[1, j] - dfx[0, j]) * c
                     + hb * (dfx[3, j] - dfx[2, j]) - hb * (dfy[1, j] - dfy[0, j]) * s
                     - lr * (dfy[2, j] + dfy[3, j]))


@njit(cache=True)
def body_derivative(vx, vy, r, sfx, sfy, mz, slope, p, out):
    """Eq. (11) (yaw equation divided by I_z): writes (dV_x/dt, dV_y/dt, dr/dt) into ``out``.

    Aerodynamic drag is written C V|V| (the paper's C V^2 changes sign with V).
    """
    m = p[P_MASS]
    out[0] = sfx / m + r * vy - p[P_CXA] * vx * abs(vx) / m - p[P_G] * math.sin(slope)
    out[1] = sfy / m - r * vx - p[P_CYA] * vy * abs(vy) / m
    out[2] = mz / p[P_IZ]


@njit(cache=True)
def planar_rates_jac(x, u, p, slope, xdot, jac, dslope):
    """Continuous-time model ``dx/dt = f(x, u)`` of eq. (11)-(19) and its Jacobian.

    ``slope`` (rad) is used for gravity and the load transfer; ``jac`` (3, 3) receives the
    derivatives w.r.t. (V_x, V_y, r) and ``dslope`` (3,) those w.r.t. the slope.
    """
    fn = np.empty(4)
    normal_loads(p, u[U_AX], u[U_AY], slope, fn)
    slip = np.empty(4)
    alpha = np.empty(4)
    fx = np.empty(4)
    fy = np.empty(4)
    dfx = np.empty((4, 3))
    dfy = np.empty((4, 3))
    dfn = np.empty((2, 4))
    dfw = np.empty((2, 4))
    delta = u[U_DELTA]
    tyre_kinematics_forces(x[0], x[1], x[2], delta, u[U_OMEGA:U_OMEGA + 4], fn, u[U_MU:U_MU + 4], p,
                           slip, alpha, fx, fy, dfx, dfy, dfn, dfw)
    sfx, sfy, mz = body_sums(fx, fy, delta, p)
    body_derivative(x[0], x[1], x[2], sfx, sfy, mz, slope, p, xdot)
    g = np.empty((3, 3))
    body_sums_grad(dfx, dfy, delta, p, g)
    m = p[P_MASS]
    iz = p[P_IZ]
    for j in range(3):
        jac[0, j] = g[0, j] / m
        jac[1, j] = g[1, j] / m
        jac[2, j] = g[2, j] / iz
    jac[0, 0] -= 2.0 * p[P_CXA] * abs(x[0]) / m
    jac[0, 1] += x[2]
    jac[0, 2] += x[1]
    jac[1, 0] -= x[2]
    jac[1, 1] -= 2.0 * p[P_CYA] * abs(x[1]) / m
    jac[1, 2] -= x[0]
    # slope: gravity component and the static loads M g cos(theta) of eq. (19)
    L = p[P_LF] + p[P_LR]
    dw = -m * p[P_G] * math.sin(slope) / (2.0 * L)
    gx = np.empty(4)
    gy = np.empty(4)
    for i in range(4):
        dfn_i = dw * (p[P_LR] if i < 2 else p[P_LF])
        gx[i] = dfn[0, i] * dfn_i
        gy[i] = dfn[1, i] * dfn_i
    s_fx, s_fy, s_mz = body_sums(gx, gy, delta, p)
    dslope[0] = s_fx / m - p[P_G] * math.cos(slope)
    dslope[1] = s_fy / m
    dslope[2] = s_mz / iz


@njit(cache=True)
def ekf_step(x, u, p, dt):
    """Eq. (20) (explicit Euler step of (11)) for the state (V_x, V_y, r); returns (x_next, F)."""
    xdot = np.empty(3)
    jac = np.empty((3, 3))
    dslope = np.empty(3)
    planar_rates_jac(x, u, p, u[U_SLOPE], xdot, jac, dslope)
    xn = np.empty(3)
    F = np.empty((3, 3))
    for i in range(3):
        xn[i] = x[i] + dt * xdot[i]
        for j in range(3):
            F[i, j] = dt * jac[i, j]
        F[i, i] += 1.0
    return xn, F


@njit(cache=True)
def forces_and_std(x, cov, u, p, slope, omega_rel_std, fx_out, fy_out, fx_std, fy_std):
    """Tyre forces at the estimate ``x`` and their std by the delta method through (18)->(15)-(17).

    ``cov`` is the (3, 3) covariance of (V_x, V_y, r); ``slope`` (rad) enters the loads (19);
    ``omega_rel_std`` is the relative std of the wheel-speed inputs (independent wheels), whose
    contribution is added to the force variances.

    Returns ``(sum_fx, sum_fx_std, resisting, resisting_std)``; ``resisting`` = F_res of eq. (21):
    sum F_X + M r V_y - C_x V_x |V_x| (N), whose std is also propagated.
    """
    fn = np.empty(4)
    normal_loads(p, u[U_AX], u[U_AY], slope, fn)
    slip = np.empty(4)
    alpha = np.empty(4)
    dfx = np.empty((4, 3))
    dfy = np.empty((4, 3))
    dfn = np.empty((2, 4))
    dfw = np.empty((2, 4))
    tyre_kinematics_forces(x[0], x[1], x[2], u[U_DELTA], u[U_OMEGA:U_OMEGA + 4], fn, u[U_MU:U_MU + 4], p,
                           slip, alpha, fx_out, fy_out, dfx, dfy, dfn, dfw)
    w_var = np.empty(4)
    for i in range(4):
        w_var[i] = (omega_rel_std * u[U_OMEGA + i]) ** 2
    for i in range(4):
        vx_ = dfw[0, i] * dfw[0, i] * w_var[i]
        vy_ = dfw[1, i] * dfw[1, i] * w_var[i]
        for a in range(3):
            for b in range(3):
                vx_ += dfx[i, a] * cov[a, b] * dfx[i, b]
                vy_ += dfy[i, a] * cov[a, b] * dfy[i, b]
        fx_std[i] = math.sqrt(max(vx_, 0.0))
        fy_std[i] = math.sqrt(max(vy_, 0.0))
    sfx, sfy, mz = body_sums(fx_out, fy_out, u[U_DELTA], p)
    g = np.empty((3, 3))
    body_sums_grad(dfx, dfy, u[U_DELTA], p, g)
    m = p[P_MASS]
    res = sfx + m * x[2] * x[1] - p[P_CXA] * x[0] * abs(x[0])
    gr = np.empty(3)
    gr[0] = g[0, 0] - 2.0 * p[P_CXA] * abs(x[0])
    gr[1] = g[0, 1] + m * x[2]
    gr[2] = g[0, 2] + m * x[1]
    # wheel-speed input noise through the body sums (independent wheels)
    c = math.cos(u[U_DELTA])
    sn = math.sin(u[U_DELTA])
    v_res = 0.0
    for i in range(4):
        if i < 2:
            d = dfw[0, i] * c - dfw[1, i] * sn
        else:
            d = dfw[0, i]
        v_res += d * d * w_var[i]
    v_sfx = v_res
    for a in range(3):
        for b in range(3):
            v_res += gr[a] * cov[a, b] * gr[b]
            v_sfx += g[0, a] * cov[a, b] * g[0, b]
    return sfx, math.sqrt(max(v_sfx, 0.0)), res, math.sqrt(max(v_res, 0.0))
