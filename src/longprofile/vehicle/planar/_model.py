"""The planar 4-wheel vehicle model of paper 001, eq. (11)-(19), as numba kernels on plain float arrays.

Conventions (used by every kernel here):

* body axes x forward, y left, z up; yaw rate r = psi_dot positive counter-clockwise;
* wheel order FL, FR, RL, RR (1..4 in the paper), consistent with the signs of eq. (14) and (19);
* state ``x = (V_x, V_y, r)`` (m/s, m/s, rad/s) — the EKF state of eq. (20);
* input row ``u`` of length :data:`N_INPUTS`:
  ``(delta_fl, omega_fl, omega_fr, omega_rl, omega_rr, a_x, a_y, slope, mu_fl, mu_fr, mu_rl, mu_rr, delta_fr)``
  with delta_fl, delta_fr the front-left and front-right road-wheel steering angles (rad; equal without a
  measured left/right angle), omega the wheel spin rates (rad/s), a_x, a_y the accelerometer readings
  (specific force, m/s^2), slope the road grade angle (rad).
* ``p`` is ``Vehicle.as_array()``: the track, rolling radius and tyre stiffnesses of each wheel are those of
  its axle (``P_*_F`` front, ``P_*_R`` rear).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..._jit import njit
from ..._validation import as_float_array, require_positive
from ...errors import InputError, ShapeError
from ._dugoff import dugoff_grad, dugoff_values
from ._params import (
    GRAVITY,
    P_CX0_F,
    P_CX0_R,
    P_CXA,
    P_CY0_F,
    P_CY0_R,
    P_CYA,
    P_G,
    P_H,
    P_IZ,
    P_LF,
    P_LR,
    P_MASS,
    P_R_F,
    P_R_R,
    P_TRACK_F,
    P_TRACK_R,
    Vehicle,
)

if TYPE_CHECKING:
    from ._simulate import DriveLog

U_DELTA, U_OMEGA, U_AX, U_AY, U_SLOPE, U_MU, U_DELTA_FR = 0, 1, 5, 6, 7, 8, 12
N_INPUTS = 13
#: Floor of the slip denominator max(R omega, V) of eq. (18), m/s: the model is not meant for standstill.
V_MIN = 0.5


@njit(cache=True, inline="always")
def slip_ratio(rw, vw, R):
    """Longitudinal slip of eq. (18) and its derivatives: ``(lambda, d lambda/d v_w, d lambda/d omega)``.

    ``rw`` = R omega (m/s), ``vw`` the wheel-plane speed (m/s). Driving (R omega >= v_w): (R omega - v_w)/(R omega);
    braking: R omega / v_w - 1; below :data:`V_MIN` the denominator is held at V_MIN (the model is not meant for
    standstill). The one definition every kernel of this module uses.
    """
    if rw >= vw and rw >= V_MIN:
        return (rw - vw) / rw, -1.0 / rw, R * vw / (rw * rw)
    if vw >= V_MIN:
        return rw / vw - 1.0, -rw / (vw * vw), R / vw
    return (rw - vw) / V_MIN, -1.0 / V_MIN, R / V_MIN


@njit(cache=True)
def normal_loads(p, ax, ay, slope, out):
    """Eq. (19): static load, longitudinal and lateral load transfer; ``out`` (4,) in N.

    ``ax``, ``ay`` are accelerometer readings (specific force). With them, eq. (19) is exact for a
    rigid body on a grade: the longitudinal transfer is H M a_x / L with a_x = dV_x/dt - r V_y + g sin(theta).
    Each axle carries its share of the lateral force (l_r/L front, l_f/L rear) over its own track.
    """
    m = p[P_MASS]
    lf = p[P_LF]
    lr = p[P_LR]
    L = lf + lr
    h = p[P_H]
    sbf = p[P_TRACK_F]
    sbr = p[P_TRACK_R]
    w = m * p[P_G] * math.cos(slope)
    dx = h * m * ax / (2.0 * L)
    out[0] = lr * w / (2.0 * L) - dx - lr * h * m * ay / (sbf * L)
    out[1] = lr * w / (2.0 * L) - dx + lr * h * m * ay / (sbf * L)
    out[2] = lf * w / (2.0 * L) + dx - lf * h * m * ay / (sbr * L)
    out[3] = lf * w / (2.0 * L) + dx + lf * h * m * ay / (sbr * L)


@njit(cache=True)
def tyre_kinematics_forces(vx, vy, r, delta_l, delta_r, omega, fn, mu, p, slip, alpha, fx, fy, dfx, dfy, dfn, dfw):
    """Eq. (18) slips and slip angles, then Dugoff forces (15)-(17) of the 4 tyres.

    Writes ``slip``, ``alpha`` (rad), ``fx``, ``fy`` (N, wheel axes) of shape (4,), and the
    derivatives ``dfx``, ``dfy`` (4, 3) of the forces w.r.t. the state (V_x, V_y, r), and in ``dfn``
    (2, 4) the derivatives of (fx, fy) w.r.t. each wheel's normal load, in ``dfw`` (2, 4) those
    w.r.t. each wheel's spin rate.
    The wheel-centre velocity of wheel i at (x_i, y_i) is (V_x - r y_i, V_y + r x_i); the slip uses
    its component along the wheel plane, the slip angle is delta_i - atan(v_y,i / v_x,i); delta_i is
    ``delta_l`` (FL), ``delta_r`` (FR) or 0 (rear). Track, radius and stiffnesses are those of the wheel's axle.
    """
    lf = p[P_LF]
    lr = p[P_LR]
    for i in range(4):
        front = i < 2
        hb = 0.5 * p[P_TRACK_F] if front else 0.5 * p[P_TRACK_R]
        R = p[P_R_F] if front else p[P_R_R]
        cx0 = p[P_CX0_F] if front else p[P_CX0_R]
        cy0 = p[P_CY0_F] if front else p[P_CY0_R]
        xi = lf if front else -lr
        yi = hb if (i % 2) == 0 else -hb
        di = (delta_l if i == 0 else delta_r) if front else 0.0
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
        lam, dl, dlw = slip_ratio(rw, vw, R)
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
def _wheel_sums(fx0, fx1, fx2, fx3, fy0, fy1, fy2, fy3, delta_l, delta_r, lf, lr, hbf, hbr):
    """Eq. (12)-(14) on 4 wheel-axis force pairs (FL, FR, RL, RR): body-axis sums and yaw moment.

    With one steering angle the front pair is summed before the rotation (the form of the paper); with
    two, each front wheel is rotated by its own angle.
    """
    if delta_l == delta_r:
        c = math.cos(delta_l)
        s = math.sin(delta_l)
        fxf = fx0 + fx1
        fyf = fy0 + fy1
        sfx = fxf * c - fyf * s + fx2 + fx3
        sfy = fxf * s + fyf * c + fy2 + fy3
        mz = (lf * fxf * s + lf * fyf * c + hbf * (fx1 - fx0) * c + hbr * (fx3 - fx2)
              - hbf * (fy1 - fy0) * s - lr * (fy2 + fy3))
        return sfx, sfy, mz
    c0 = math.cos(delta_l)
    s0 = math.sin(delta_l)
    c1 = math.cos(delta_r)
    s1 = math.sin(delta_r)
    bx0 = c0 * fx0 - s0 * fy0
    by0 = s0 * fx0 + c0 * fy0
    bx1 = c1 * fx1 - s1 * fy1
    by1 = s1 * fx1 + c1 * fy1
    sfx = bx0 + bx1 + fx2 + fx3
    sfy = by0 + by1 + fy2 + fy3
    mz = lf * (by0 + by1) + hbf * (bx1 - bx0) + hbr * (fx3 - fx2) - lr * (fy2 + fy3)
    return sfx, sfy, mz


@njit(cache=True, inline="always")
def body_sums(fx, fy, delta_l, delta_r, p):
    """Eq. (12)-(14): total longitudinal and lateral force (N) and yaw moment (N m) in body axes.

    ``delta_l``, ``delta_r``: front-left and front-right road-wheel angles (rad). The rear wheels are not
    steered (the angle beta of (12)-(13) is zero for the cars modelled here).
    """
    return _wheel_sums(fx[0], fx[1], fx[2], fx[3], fy[0], fy[1], fy[2], fy[3], delta_l, delta_r,
                       p[P_LF], p[P_LR], 0.5 * p[P_TRACK_F], 0.5 * p[P_TRACK_R])


@njit(cache=True)
def body_sums_grad(dfx, dfy, delta_l, delta_r, p, out):
    """Gradient (3 sums x 3 states) of :func:`body_sums` given the force gradients (4, 3)."""
    lf = p[P_LF]
    lr = p[P_LR]
    hbf = 0.5 * p[P_TRACK_F]
    hbr = 0.5 * p[P_TRACK_R]
    for j in range(3):
        out[0, j], out[1, j], out[2, j] = _wheel_sums(dfx[0, j], dfx[1, j], dfx[2, j], dfx[3, j], dfy[0, j],
                                                      dfy[1, j], dfy[2, j], dfy[3, j], delta_l, delta_r,
                                                      lf, lr, hbf, hbr)


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
    dl = u[U_DELTA]
    dr = u[U_DELTA_FR]
    tyre_kinematics_forces(x[0], x[1], x[2], dl, dr, u[U_OMEGA:U_OMEGA + 4], fn, u[U_MU:U_MU + 4], p,
                           slip, alpha, fx, fy, dfx, dfy, dfn, dfw)
    sfx, sfy, mz = body_sums(fx, fy, dl, dr, p)
    body_derivative(x[0], x[1], x[2], sfx, sfy, mz, slope, p, xdot)
    g = np.empty((3, 3))
    body_sums_grad(dfx, dfy, dl, dr, p, g)
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
    s_fx, s_fy, s_mz = body_sums(gx, gy, dl, dr, p)
    dslope[0] = s_fx / m - p[P_G] * math.cos(slope)
    dslope[1] = s_fy / m
    dslope[2] = s_mz / iz


@njit(cache=True, inline="always")
def _axle(p, front):
    """(track, rolling radius, C_x0, C_y0) of the front (``front`` True) or the rear axle."""
    if front:
        return p[P_TRACK_F], p[P_R_F], p[P_CX0_F], p[P_CY0_F]
    return p[P_TRACK_R], p[P_R_R], p[P_CX0_R], p[P_CY0_R]


@njit(cache=True, inline="always")
def _front_angles(delta_l, delta_r):
    """(cos, sin, tan) of the front-left then the front-right steering angle (one evaluation when equal)."""
    cdl = math.cos(delta_l)
    sdl = math.sin(delta_l)
    tdl = sdl / cdl
    if delta_r == delta_l:
        return cdl, sdl, tdl, cdl, sdl, tdl
    cdr = math.cos(delta_r)
    sdr = math.sin(delta_r)
    return cdl, sdl, tdl, cdr, sdr, sdr / cdr


@njit(cache=True, inline="always")
def _wheel_angle(i, cdl, sdl, tdl, cdr, sdr, tdr):
    """(cos, sin, tan) of the steering angle of wheel i (FL, FR, RL, RR; the rear wheels are not steered)."""
    if i == 0:
        return cdl, sdl, tdl
    if i == 1:
        return cdr, sdr, tdr
    return 1.0, 0.0, 0.0


@njit(cache=True, inline="always")
def _wheel_geometry(p, i, lf, lr, h, m, L, w, dxl, ay):
    """Wheel i (FL, FR, RL, RR): (rolling radius, C_x0, C_y0, x_i, y_i, lever arm, normal load F_n of eq. (19))
    for the static load ``w`` = M g cos(theta), the longitudinal transfer ``dxl`` and the lateral acceleration."""
    front = i < 2
    left = (i % 2) == 0
    sb, R, cx0, cy0 = _axle(p, front)
    hb = 0.5 * sb
    xi = lf if front else -lr
    yi = hb if left else -hb
    lever = lr if front else lf
    lat = lever * h * m * ay / (sb * L)
    fn = lever * w / (2.0 * L) + (-dxl if front else dxl) + (lat if not left else -lat)
    return R, cx0, cy0, xi, yi, lever, fn


@njit(cache=True)
def planar_fused(vx, vy, r, u, p, slope):
    """Allocation-free eq. (11)-(19) for the EKF inner loop: rates, Jacobian and slope derivative.

    Same mathematics as :func:`planar_rates_jac` (the readable version, also used by the simulator),
    written with scalars only so the compiled EKF loop does not allocate; tests check the EKF step
    against the simulator's physics and the Jacobian against finite differences. Returns a 15-tuple:
    ``(dvx, dvy, dr, J00, J01, J02, J10, J11, J12, J20, J21, J22, ds0, ds1, ds2)``.
    """
    m = p[P_MASS]
    iz = p[P_IZ]
    lf = p[P_LF]
    lr = p[P_LR]
    L = lf + lr
    h = p[P_H]
    grav = p[P_G]
    ax = u[U_AX]
    ay = u[U_AY]
    cdl, sdl, tdl, cdr, sdr, tdr = _front_angles(u[U_DELTA], u[U_DELTA_FR])
    w = m * grav * math.cos(slope)
    dw = -m * grav * math.sin(slope)
    dxl = h * m * ax / (2.0 * L)
    # accumulated body sums and their derivatives w.r.t. (vx, vy, r, slope)
    sfx = 0.0
    sfy = 0.0
    mz = 0.0
    gx0 = gx1 = gx2 = gx3 = 0.0
    gy0 = gy1 = gy2 = gy3 = 0.0
    gm0 = gm1 = gm2 = gm3 = 0.0
    for i in range(4):
        R, cx0, cy0, xi, yi, lever, fn = _wheel_geometry(p, i, lf, lr, h, m, L, w, dxl, ay)
        dfn_ds = lever * dw / (2.0 * L)
        c, s, td = _wheel_angle(i, cdl, sdl, tdl, cdr, sdr, tdr)
        vxi = vx - r * yi
        vyi = vy + r * xi
        vw = vxi * c + vyi * s
        dvw2 = -yi * c + xi * s
        rw = R * u[U_OMEGA + i]
        lam, dl, _ = slip_ratio(rw, vw, R)
        # tan(alpha) = tan(delta_i - atan(vyi / vxi)) = (td vxi - vyi) / (vxi + td vyi), no trig per wheel
        num = td * vxi - vyi
        den = vxi + td * vyi
        t = num / den
        # d t / d(vxi, vyi), then chain to (vx, vy, r): d vxi = (1, 0, -yi), d vyi = (0, 1, xi)
        tx = (td * den - num) / (den * den)
        ty = (-den - num * td) / (den * den)
        dt0 = tx
        dt1 = ty
        dt2 = -yi * tx + xi * ty
        f_x, f_y, fxl, fxt, fyl, fyt, fxn, fyn = dugoff_grad(lam, t, fn, u[U_MU + i], cx0, cy0)
        ax0 = fxl * dl * c + fxt * dt0
        ax1 = fxl * dl * s + fxt * dt1
        ax2 = fxl * dl * dvw2 + fxt * dt2
        ax3 = fxn * dfn_ds
        ay0 = fyl * dl * c + fyt * dt0
        ay1 = fyl * dl * s + fyt * dt1
        ay2 = fyl * dl * dvw2 + fyt * dt2
        ay3 = fyn * dfn_ds
        # eq. (12)-(14): body-axis components and moment arm of this wheel
        bx = c * f_x - s * f_y
        by = s * f_x + c * f_y
        sfx += bx
        sfy += by
        mz += xi * by - yi * bx
        bx0 = c * ax0 - s * ay0
        bx1 = c * ax1 - s * ay1
        bx2 = c * ax2 - s * ay2
        bx3 = c * ax3 - s * ay3
        by0 = s * ax0 + c * ay0
        by1 = s * ax1 + c * ay1
        by2 = s * ax2 + c * ay2
        by3 = s * ax3 + c * ay3
        gx0 += bx0
        gx1 += bx1
        gx2 += bx2
        gx3 += bx3
        gy0 += by0
        gy1 += by1
        gy2 += by2
        gy3 += by3
        gm0 += xi * by0 - yi * bx0
        gm1 += xi * by1 - yi * bx1
        gm2 += xi * by2 - yi * bx2
        gm3 += xi * by3 - yi * bx3
    cxa = p[P_CXA]
    cya = p[P_CYA]
    dvx = sfx / m + r * vy - cxa * vx * abs(vx) / m - grav * math.sin(slope)
    dvy = sfy / m - r * vx - cya * vy * abs(vy) / m
    dr = mz / iz
    return (dvx, dvy, dr,
            gx0 / m - 2.0 * cxa * abs(vx) / m, gx1 / m + r, gx2 / m + vy,
            gy0 / m - r, gy1 / m - 2.0 * cya * abs(vy) / m, gy2 / m - vx,
            gm0 / iz, gm1 / iz, gm2 / iz,
            gx3 / m - grav * math.cos(slope), gy3 / m, gm3 / iz)


@njit(cache=True)
def planar_rates_fast(vx, vy, r, u, p, slope):
    """(dV_x/dt, dV_y/dt, dr/dt) of eq. (11)-(19) without derivatives (the EKF's f); same maths as
    :func:`planar_fused`."""
    m = p[P_MASS]
    lf = p[P_LF]
    lr = p[P_LR]
    L = lf + lr
    h = p[P_H]
    cdl, sdl, tdl, cdr, sdr, tdr = _front_angles(u[U_DELTA], u[U_DELTA_FR])
    w = m * p[P_G] * math.cos(slope)
    dxl = h * m * u[U_AX] / (2.0 * L)
    sfx = 0.0
    sfy = 0.0
    mz = 0.0
    for i in range(4):
        R, cx0, cy0, xi, yi, lever, fn = _wheel_geometry(p, i, lf, lr, h, m, L, w, dxl, u[U_AY])
        c, s, td = _wheel_angle(i, cdl, sdl, tdl, cdr, sdr, tdr)
        vxi = vx - r * yi
        vyi = vy + r * xi
        vw = vxi * c + vyi * s
        rw = R * u[U_OMEGA + i]
        lam = slip_ratio(rw, vw, R)[0]
        t = (td * vxi - vyi) / (vxi + td * vyi)
        f_x, f_y = dugoff_values(lam, t, fn, u[U_MU + i], cx0, cy0)
        bx = c * f_x - s * f_y
        by = s * f_x + c * f_y
        sfx += bx
        sfy += by
        mz += xi * by - yi * bx
    return (sfx / m + r * vy - p[P_CXA] * vx * abs(vx) / m - p[P_G] * math.sin(slope),
            sfy / m - r * vx - p[P_CYA] * vy * abs(vy) / m, mz / p[P_IZ])


@njit(cache=True)
def ekf_next(x, u, p, dt):
    """x[k+1] of eq. (20) (Euler step), allocation of the result only."""
    r = planar_rates_fast(x[0], x[1], x[2], u, p, u[U_SLOPE])
    xn = np.empty(3)
    xn[0] = x[0] + dt * r[0]
    xn[1] = x[1] + dt * r[1]
    xn[2] = x[2] + dt * r[2]
    return xn


@njit(cache=True)
def ekf_jacobian(x, u, p, dt):
    """F = I + dt df/dx of eq. (20)."""
    r = planar_fused(x[0], x[1], x[2], u, p, u[U_SLOPE])
    F = np.empty((3, 3))
    F[0, 0] = 1.0 + dt * r[3]
    F[0, 1] = dt * r[4]
    F[0, 2] = dt * r[5]
    F[1, 0] = dt * r[6]
    F[1, 1] = 1.0 + dt * r[7]
    F[1, 2] = dt * r[8]
    F[2, 0] = dt * r[9]
    F[2, 1] = dt * r[10]
    F[2, 2] = 1.0 + dt * r[11]
    return F


@njit(cache=True)
def joint_next(x, u, p, dt):
    """Augmented transition (V_x, V_y, r, theta_r): eq. (20) with the grade from the state, random-walk grade."""
    r = planar_rates_fast(x[0], x[1], x[2], u, p, x[3])
    xn = np.empty(4)
    xn[0] = x[0] + dt * r[0]
    xn[1] = x[1] + dt * r[1]
    xn[2] = x[2] + dt * r[2]
    xn[3] = x[3]
    return xn


@njit(cache=True)
def joint_jacobian(x, u, p, dt):
    """Jacobian (4, 4) of :func:`joint_next`."""
    r = planar_fused(x[0], x[1], x[2], u, p, x[3])
    F = np.zeros((4, 4))
    for i in range(3):
        for j in range(3):
            F[i, j] = dt * r[3 + 3 * i + j]
        F[i, i] += 1.0
        F[i, 3] = dt * r[12 + i]
    F[3, 3] = 1.0
    return F


@njit(cache=True)
def ekf_step(x, u, p, dt, out, F):
    """Fused, allocation-free :func:`ekf_next` and :func:`ekf_jacobian`: x[k+1] into ``out`` (3,), F into ``F`` (3, 3).

    One evaluation of the tyre forces serves the step and its Jacobian (the engine's fused-step
    convention, :class:`longprofile.statespace.NonlinearStateSpaceModel`).
    """
    r = planar_fused(x[0], x[1], x[2], u, p, u[U_SLOPE])
    for i in range(3):
        out[i] = x[i] + dt * r[i]
        for j in range(3):
            F[i, j] = dt * r[3 + 3 * i + j]
        F[i, i] += 1.0


@njit(cache=True)
def joint_step(x, u, p, dt, out, F):
    """Fused, allocation-free :func:`joint_next` and :func:`joint_jacobian` (state (V_x, V_y, r, theta_r))."""
    r = planar_fused(x[0], x[1], x[2], u, p, x[3])
    for i in range(3):
        out[i] = x[i] + dt * r[i]
        for j in range(3):
            F[i, j] = dt * r[3 + 3 * i + j]
        F[i, i] += 1.0
        F[i, 3] = dt * r[12 + i]
    out[3] = x[3]
    F[3, 3] = 1.0


@njit(cache=True, inline="always")
def forces_fused(mean, cov, u, p, slope, omega_rel_std, fx_out, fy_out, fx_std, fy_std, k):
    """Tyre forces at the estimate ``mean[k]`` and their std by the delta method through (18)->(15)-(17).

    Works on whole arrays at sample ``k`` (indexing them here is cheaper than passing row views):
    ``mean`` (T, n) and ``cov`` (T, n, n) are the state estimate and covariance (their (V_x, V_y, r)
    block is used), ``u`` (T, 12) the inputs, ``slope`` (T,) the grade entering the loads (19) (rad),
    ``omega_rel_std`` the relative std of the wheel-speed inputs (independent wheels), whose
    contribution is added. Writes row k of fx, fy and their stds (T, 4) and returns
    ``(F_res, F_res std)``, F_res = sum F_X + M r V_y - C_x V_x|V_x| of eq. (21) in N. Allocation-free.
    """
    m = p[P_MASS]
    lf = p[P_LF]
    lr = p[P_LR]
    L = lf + lr
    h = p[P_H]
    vx = mean[k, 0]
    vy = mean[k, 1]
    r = mean[k, 2]
    theta = slope[k]
    cdl, sdl, tdl, cdr, sdr, tdr = _front_angles(u[k, U_DELTA], u[k, U_DELTA_FR])
    w = m * p[P_G] * math.cos(theta)
    dxl = h * m * u[k, U_AX] / (2.0 * L)
    c00 = cov[k, 0, 0]
    c01 = cov[k, 0, 1]
    c02 = cov[k, 0, 2]
    c11 = cov[k, 1, 1]
    c12 = cov[k, 1, 2]
    c22 = cov[k, 2, 2]
    sfx = 0.0
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    v_in = 0.0
    for i in range(4):
        R, cx0, cy0, xi, yi, lever, fn = _wheel_geometry(p, i, lf, lr, h, m, L, w, dxl, u[k, U_AY])
        c, s, td = _wheel_angle(i, cdl, sdl, tdl, cdr, sdr, tdr)
        vxi = vx - r * yi
        vyi = vy + r * xi
        vw = vxi * c + vyi * s
        dvw2 = -yi * c + xi * s
        omega = u[k, U_OMEGA + i]
        rw = R * omega
        lam, dl, dlw = slip_ratio(rw, vw, R)
        num = td * vxi - vyi
        den = vxi + td * vyi
        t = num / den
        tx = (td * den - num) / (den * den)
        ty = (-den - num * td) / (den * den)
        dt0 = tx
        dt1 = ty
        dt2 = -yi * tx + xi * ty
        f_x, f_y, fxl, fxt, fyl, fyt, fxn, fyn = dugoff_grad(lam, t, fn, u[k, U_MU + i], cx0, cy0)
        a0 = fxl * dl * c + fxt * dt0
        a1 = fxl * dl * s + fxt * dt1
        a2 = fxl * dl * dvw2 + fxt * dt2
        b0 = fyl * dl * c + fyt * dt0
        b1 = fyl * dl * s + fyt * dt1
        b2 = fyl * dl * dvw2 + fyt * dt2
        wv = (omega_rel_std * omega) ** 2
        fx_out[k, i] = f_x
        fy_out[k, i] = f_y
        qx = (a0 * a0 * c00 + a1 * a1 * c11 + a2 * a2 * c22
              + 2.0 * (a0 * a1 * c01 + a0 * a2 * c02 + a1 * a2 * c12)) + fxl * fxl * dlw * dlw * wv
        qy = (b0 * b0 * c00 + b1 * b1 * c11 + b2 * b2 * c22
              + 2.0 * (b0 * b1 * c01 + b0 * b2 * c02 + b1 * b2 * c12)) + fyl * fyl * dlw * dlw * wv
        fx_std[k, i] = math.sqrt(max(qx, 0.0))
        fy_std[k, i] = math.sqrt(max(qy, 0.0))
        sfx += c * f_x - s * f_y
        g0 += c * a0 - s * b0
        g1 += c * a1 - s * b1
        g2 += c * a2 - s * b2
        d = (c * fxl - s * fyl) * dlw
        v_in += d * d * wv
    cxa = p[P_CXA]
    res = sfx + m * r * vy - cxa * vx * abs(vx)
    g0 -= 2.0 * cxa * abs(vx)
    g1 += m * r
    g2 += m * vy
    v = v_in + g0 * g0 * c00 + g1 * g1 * c11 + g2 * g2 * c22 + 2.0 * (g0 * g1 * c01 + g0 * g2 * c02 + g1 * g2 * c12)
    return res, math.sqrt(max(v, 0.0))


# ------------------------------------------------------------------------------------------ EKF models (eq. (20))

@dataclass(frozen=True)
class EKFTuning:
    """Noise settings of the vehicle EKFs (continuous-time white-noise intensities and sensor stds).

    Parameters
    ----------
    vx_rate_psd : float
        Intensity of the unmodelled longitudinal acceleration, (m/s^2)^2/Hz; Q = psd * dt. In the
        cascade it must absorb the unknown grade acceleration g sin(theta_r) (see Notes of
        :func:`estimate_slope`).
    vy_rate_psd : float
        Same for dV_y/dt, (m/s^2)^2/Hz.
    yaw_accel_psd : float
        Same for dr/dt, (rad/s^2)^2/Hz.
    slope_rate_psd : float
        Random-walk intensity of the grade in the joint EKF, rad^2/s (a grade change of
        sqrt(psd * t) rad is expected over t seconds).
    speed_std : float
        Std of the V_x measurement (mean rear-wheel speed times R), m/s.
    yaw_rate_std : float
        Std of the gyro, rad/s.
    wheel_speed_rel_std : float
        Relative std of each wheel-speed reading (ABS period measurement), used to add the input
        noise to the std of the tyre forces (the EKF treats the inputs as exact).
    initial_std : tuple of 4 float
        Prior std of (V_x, V_y, r, theta_r) around (first speed reading, 0, first gyro reading, 0),
        in m/s, m/s, rad/s, rad.

    Notes
    -----
    The defaults are the cascade's (tuned on the simulated "paper" drive, see docs/vehicle-slope.md).
    :meth:`for_method` gives the defaults of each estimator: the joint EKF models the grade, so its
    V_x process noise is 100 times smaller (and its speed std 0.01 m/s, which filters the grade more).
    """

    @classmethod
    def for_method(cls, method: str) -> "EKFTuning":
        """Default tuning of ``"cascade"`` or ``"joint"``."""
        if method == "joint":
            return cls(vx_rate_psd=1e-4, speed_std=0.01)
        if method == "cascade":
            return cls()
        raise InputError(f"method must be 'cascade' or 'joint'; got {method!r}.")

    vx_rate_psd: float = 0.01
    vy_rate_psd: float = 0.005
    yaw_accel_psd: float = 0.002
    slope_rate_psd: float = 1e-3
    speed_std: float = 0.004
    yaw_rate_std: float = 3e-3
    wheel_speed_rel_std: float = 3e-4
    initial_std: tuple = (0.5, 0.3, 0.05, 0.1)

    def __post_init__(self):
        for k in ("vx_rate_psd", "vy_rate_psd", "yaw_accel_psd", "slope_rate_psd", "speed_std", "yaw_rate_std",
                  "wheel_speed_rel_std"):
            require_positive(k, getattr(self, k))
        init = tuple(float(v) for v in self.initial_std)
        if len(init) != 4 or not all(math.isfinite(v) and v > 0 for v in init):
            raise InputError(f"initial_std must be 4 positive numbers (V_x, V_y, r, theta_r); got {self.initial_std!r}.")
        object.__setattr__(self, "initial_std", init)


# ------------------------------------------------------------------------------------------ model functions

# The closures are cached on disk (numba keys closures on the values they capture: the vehicle
# parameters, dt and the model variant), and the engine's disk-cached EKF loop calls them through
# function pointers, so a new process (the CLI) loads everything instead of compiling it.

@functools.lru_cache(maxsize=32)
def _ekf_functions(params: tuple, dt: float, joint: bool):
    """(f, f_jac, h, h_jac, f_step, h_step) of eq. (20) (``joint``: with the grade as 4th state)."""
    p = np.array(params)
    n = 4 if joint else 3

    @njit(cache=True)
    def f(x, u, k):
        return joint_next(x, u, p, dt) if joint else ekf_next(x, u, p, dt)

    @njit(cache=True)
    def f_jac(x, u, k):
        return joint_jacobian(x, u, p, dt) if joint else ekf_jacobian(x, u, p, dt)

    @njit(cache=True)
    def f_step(x, u, k, out, F):
        if joint:
            joint_step(x, u, p, dt, out, F)
        else:
            ekf_step(x, u, p, dt, out, F)

    @njit(cache=True)
    def h(x, u, k):
        y = np.empty(2)
        y[0] = x[0]
        y[1] = x[2]
        return y

    @njit(cache=True)
    def h_jac(x, u, k):
        H = np.zeros((2, n))
        H[0, 0] = 1.0
        H[1, 2] = 1.0
        return H

    @njit(cache=True)
    def h_step(x, u, k, out, H):  # H keeps its content between calls: the two ones are written each time
        out[0] = x[0]
        out[1] = x[2]
        H[0, 0] = 1.0
        H[1, 2] = 1.0

    return f, f_jac, h, h_jac, f_step, h_step


def _nonlinear_model_class():
    from ...statespace import NonlinearStateSpaceModel

    return NonlinearStateSpaceModel


def planar_ekf_model(vehicle: Vehicle, dt: float, *, initial_state=(20.0, 0.0, 0.0), tuning: EKFTuning | None = None):
    r"""The EKF model of paper 001, eq. (20): state (V_x, V_y, r), measurements (V_x, r).

    Parameters
    ----------
    vehicle : Vehicle
        Model parameters.
    dt : float
        Step ΔT of the discretisation, s.
    initial_state : (3,) array_like
        Prior mean of (V_x, V_y, r) in m/s, m/s, rad/s.
    tuning : EKFTuning, optional
        Noise settings (default ``EKFTuning()``).

    Returns
    -------
    NonlinearStateSpaceModel
        numba-jitted ``f``, ``h``, analytic Jacobians and the fused steps (one tyre-force evaluation per
        step for f and F); inputs are rows of :func:`planar_inputs`.

    Notes
    -----
    x[k+1] = x[k] + ΔT f_c(x[k], u[k]) with f_c eq. (11)-(19); the yaw row is divided by I_z
    (eq. (20) prints M, a misprint: (11) has I_z dr/dt = sum M_Z). The grade used is the input
    column ``slope`` (zero in the cascade: see :func:`estimate_slope`). The Jacobian is analytic
    (chain rule through (18) and the Dugoff model, tested against finite differences).
    Q = diag(psd) ΔT, R = diag(speed_std^2, yaw_rate_std^2).
    """
    tuning = EKFTuning() if tuning is None else tuning
    dt = require_positive("dt", dt)
    x0 = as_float_array("initial_state", initial_state, ndim=1, allow_nan=False)
    if x0.shape != (3,):
        raise ShapeError(f"initial_state must be (V_x, V_y, r); got shape {x0.shape}.")
    f, f_jac, h, h_jac, f_step, h_step = _ekf_functions(tuple(vehicle.as_array().tolist()), dt, False)
    Q = np.diag([tuning.vx_rate_psd, tuning.vy_rate_psd, tuning.yaw_accel_psd]) * dt
    R = np.diag([tuning.speed_std ** 2, tuning.yaw_rate_std ** 2])
    P0 = np.diag(np.square(tuning.initial_std[:3]))
    return _nonlinear_model_class()(f, h, Q, R, x0, P0, transition_jacobian=f_jac, observation_jacobian=h_jac,
                                     transition_step=f_step, observation_step=h_step)


def slope_ekf_model(vehicle: Vehicle, dt: float, *, initial_state=(20.0, 0.0, 0.0, 0.0),
                    tuning: EKFTuning | None = None):
    """The augmented EKF: state (V_x, V_y, r, theta_r) with a random-walk grade; measurements (V_x, r).

    Same parameters as :func:`planar_ekf_model`, with a 4-element ``initial_state``. The grade enters
    the gravity term of (11) and the static loads M g cos(theta_r) of (19); its Jacobian column is
    analytic too. Q = diag(psd) ΔT including ``slope_rate_psd``.
    """
    tuning = EKFTuning() if tuning is None else tuning
    dt = require_positive("dt", dt)
    x0 = as_float_array("initial_state", initial_state, ndim=1, allow_nan=False)
    if x0.shape != (4,):
        raise ShapeError(f"initial_state must be (V_x, V_y, r, theta_r); got shape {x0.shape}.")
    f, f_jac, h, h_jac, f_step, h_step = _ekf_functions(tuple(vehicle.as_array().tolist()), dt, True)
    Q = np.diag([tuning.vx_rate_psd, tuning.vy_rate_psd, tuning.yaw_accel_psd, tuning.slope_rate_psd]) * dt
    R = np.diag([tuning.speed_std ** 2, tuning.yaw_rate_std ** 2])
    P0 = np.diag(np.square(tuning.initial_std))
    return _nonlinear_model_class()(f, h, Q, R, x0, P0, transition_jacobian=f_jac, observation_jacobian=h_jac,
                                     transition_step=f_step, observation_step=h_step)


def planar_inputs(log: DriveLog, vehicle: Vehicle, *, friction=None, slope=None) -> np.ndarray:
    """Input rows ``u`` (T, 13) of the vehicle EKFs from a drive log.

    Columns: front-left steering angle, the 4 wheel speeds, a_x, a_y, grade (``slope``, default 0), the 4
    adhesion coefficients (``friction``: (4,) or (T, 4), default ``vehicle.friction``), front-right steering
    angle. The two angles are the log's ``steer_fl``, ``steer_fr`` when it has them
    (:attr:`DriveLog.front_steering`), else both its ``steering_angle``.
    """
    T = log.time.size
    if slope is None:
        s = np.zeros(T)
    else:
        s = as_float_array("slope", slope, ndim=(0, 1), allow_nan=False)
        if s.ndim == 1 and s.shape[0] != T:
            raise ShapeError(f"slope must be a scalar or have one value per sample ({T}); got {s.shape}.")
        s = np.ascontiguousarray(np.broadcast_to(s, (T,)))
    mu = np.asarray(vehicle.friction) if friction is None else as_float_array("friction", friction, ndim=(1, 2),
                                                                               allow_nan=False)
    if mu.shape not in ((4,), (T, 4)):
        raise ShapeError(f"friction must have shape (4,) or (T, 4) = ({T}, 4) (FL, FR, RL, RR); got {mu.shape}.")
    if np.any(mu <= 0):
        raise InputError(f"friction must be > 0; got min {mu.min():g}.")
    mu = np.ascontiguousarray(np.broadcast_to(mu, (T, 4)), dtype=np.float64)
    u = np.empty((T, N_INPUTS))
    _fill_inputs(log.front_steering, log.wheel_speeds, log.accel_x, log.accel_y, s, mu, u)
    return u


@njit(cache=True)
def _fill_inputs(steer, wheel, ax, ay, slope, mu, u):
    for k in range(u.shape[0]):
        u[k, U_DELTA] = steer[k, 0]
        u[k, U_DELTA_FR] = steer[k, 1]
        for i in range(4):
            u[k, 1 + i] = wheel[k, i]
            u[k, 8 + i] = mu[k, i]
        u[k, 5] = ax[k]
        u[k, 6] = ay[k]
        u[k, U_SLOPE] = slope[k]


def planar_measurements(log: DriveLog, vehicle: Vehicle, *, speed_measurement: str = "rear-mean") -> np.ndarray:
    """Measurements y (T, 2) of eq. (20): V_x (m/s) and the gyro r (rad/s).

    ``speed_measurement="rear-mean"`` (default here, the paper's): V_x is the mean rear-wheel
    translational speed R (omega_RL + omega_RR)/2. ``"robust"``: the slip-robust reference speed of
    :func:`longprofile.vehicle.speed_reference` (NaN where no wheel is trustworthy; its per-sample std
    is ``speed_reference(log, vehicle).std``, which :func:`estimate_slope` gives the EKF as R).
    """
    from ._speed_reference import speed_reference

    ref = speed_reference(log, vehicle, method=speed_measurement)
    return np.column_stack([ref.speed, log.yaw_rate])


# ------------------------------------------------------------------------------------------ slope observer

def slope_observer_matrices(vehicle: Vehicle, dt: float | None = None):
    r"""The longitudinal model (21) as ``(A, B, C)``; discretised exactly (zero-order hold) when ``dt`` is given.

    State (V_x, s) with s = sin(theta_r), input F_res (N), output V_x. Writing the state with
    sin(theta_r) makes (21) exactly linear, so the small-angle step of the paper is not needed:

    .. math::  A = \begin{bmatrix}0 & -g\\ 0 & 0\end{bmatrix},\ B = \begin{bmatrix}1/M\\0\end{bmatrix},\
               C = [1\ 0];\qquad A_d = \begin{bmatrix}1 & -g\,\Delta T\\ 0 & 1\end{bmatrix},\
               B_d = \begin{bmatrix}\Delta T/M\\0\end{bmatrix}.
    """
    g = GRAVITY
    M = vehicle.mass
    C = np.array([[1.0, 0.0]])
    if dt is None:
        return np.array([[0.0, -g], [0.0, 0.0]]), np.array([[1.0 / M], [0.0]]), C
    dt = require_positive("dt", dt)
    return np.array([[1.0, -g * dt], [0.0, 1.0]]), np.array([[dt / M], [0.0]]), C


def slope_observer_gain(vehicle: Vehicle, *, poles=(-5.0, -7.0)) -> np.ndarray:
    """Luenberger gain L (2, 1) of the longitudinal model (21) placing the eigenvalues of A - L C at ``poles``.

    Continuous-time design (paper 001, IV.B: the eigenvalues of A - L C must have negative real
    parts), by the engine's :func:`longprofile.statespace.luenberger_gain` (pole placement). With one
    output the two poles must be distinct.

    Raises
    ------
    InputError
        If the poles are not 2 stable (negative real part) values.
    ModelError
        If they cannot be placed (e.g. a repeated pole).
    """
    from ...statespace import luenberger_gain

    A, _, C = slope_observer_matrices(vehicle)
    return np.asarray(luenberger_gain(A, C, poles), dtype=float)
