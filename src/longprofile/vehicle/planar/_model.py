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

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..._jit import njit
from ..._validation import as_float_array, require_positive
from ...errors import InputError, ShapeError
from ._equations import (
    body_rates,
    body_rates_grad,
    load_terms,
    wheel_body_force,
    wheel_forces,
    wheel_geometry,
    wheel_normal_load,
    wheel_sums,
)
from ._params import GRAVITY, P_CXA, P_G, P_LF, P_LR, P_MASS, P_TRACK_F, P_TRACK_R, Vehicle

if TYPE_CHECKING:
    from ._simulate import DriveLog

U_DELTA, U_OMEGA, U_AX, U_AY, U_SLOPE, U_MU, U_DELTA_FR = 0, 1, 5, 6, 7, 8, 12
N_INPUTS = 13

# ------------------------------------------------------------------------------------------ model kernels
#
# Every equation is written once in ._equations; the kernels below only compose it. Two families:
# the simulator's array kernels (normal_loads, tyre_kinematics_forces, body_sums, body_derivative, and
# planar_rates_jac built on them) and the EKF's allocation-free scalar kernels (planar_fused: value and
# derivatives; planar_rates_fast: the same per-wheel function without the derivatives; forces_fused: the
# forces and their std), which share _ekf_wheel.


@njit(cache=True)
def normal_loads(p, ax, ay, slope, out):
    """Eq. (19): static load, longitudinal and lateral load transfer; ``out`` (4,) in N.

    ``ax``, ``ay`` are accelerometer readings (specific force). With them, eq. (19) is exact for a
    rigid body on a grade: the longitudinal transfer is H M a_x / L with a_x = dV_x/dt - r V_y + g sin(theta).
    Each axle carries its share of the lateral force (l_r/L front, l_f/L rear) over its own track.
    """
    L, w, dxl = load_terms(p, ax, slope)
    for i in range(4):
        _, _, sb, lever, _, _, _ = wheel_geometry(p, i)
        out[i] = wheel_normal_load(p, i, sb, lever, L, w, dxl, ay)


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
    for i in range(4):
        xi, yi, _, _, R, cx0, cy0 = wheel_geometry(p, i)
        di = (delta_l if i == 0 else delta_r) if i < 2 else 0.0
        (slip[i], alpha[i], fx[i], fy[i], dfx[i, 0], dfx[i, 1], dfx[i, 2], dfy[i, 0], dfy[i, 1], dfy[i, 2],
         dfn[0, i], dfn[1, i], fxl, fyl, dlw) = wheel_forces(vx, vy, r, xi, yi, math.cos(di), math.sin(di), 0.0, di,
                                                             R, omega[i], fn[i], mu[i], cx0, cy0, True, True)
        dfw[0, i] = fxl * dlw
        dfw[1, i] = fyl * dlw


@njit(cache=True, inline="always")
def body_sums(fx, fy, delta_l, delta_r, p):
    """Eq. (12)-(14): total longitudinal and lateral force (N) and yaw moment (N m) in body axes.

    ``delta_l``, ``delta_r``: front-left and front-right road-wheel angles (rad). The rear wheels are not
    steered (the angle beta of (12)-(13) is zero for the cars modelled here).
    """
    return wheel_sums(fx[0], fx[1], fx[2], fx[3], fy[0], fy[1], fy[2], fy[3], delta_l, delta_r,
                      p[P_LF], p[P_LR], 0.5 * p[P_TRACK_F], 0.5 * p[P_TRACK_R])


@njit(cache=True)
def body_sums_grad(dfx, dfy, delta_l, delta_r, p, out):
    """Gradient (3 sums x 3 states) of :func:`body_sums` given the force gradients (4, 3)."""
    for j in range(3):
        out[0, j], out[1, j], out[2, j] = body_sums(dfx[:, j], dfy[:, j], delta_l, delta_r, p)


@njit(cache=True)
def body_derivative(vx, vy, r, sfx, sfy, mz, slope, p, out):
    """Eq. (11) (yaw equation divided by I_z): writes (dV_x/dt, dV_y/dt, dr/dt) into ``out``.

    Aerodynamic drag is written C V|V| (the paper's C V^2 changes sign with V).
    """
    out[0], out[1], out[2] = body_rates(vx, vy, r, sfx, sfy, mz, slope, p)


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
    # slope: the static loads M g cos(theta) of eq. (19) (gravity itself is in body_rates_grad)
    dw = -p[P_MASS] * p[P_G] * math.sin(slope) / (2.0 * (p[P_LF] + p[P_LR]))
    gx = np.empty(4)
    gy = np.empty(4)
    for i in range(4):
        dfn_i = dw * (p[P_LR] if i < 2 else p[P_LF])
        gx[i] = dfn[0, i] * dfn_i
        gy[i] = dfn[1, i] * dfn_i
    s_fx, s_fy, s_mz = body_sums(gx, gy, dl, dr, p)
    (jac[0, 0], jac[0, 1], jac[0, 2], jac[1, 0], jac[1, 1], jac[1, 2], jac[2, 0], jac[2, 1], jac[2, 2],
     dslope[0], dslope[1], dslope[2]) = body_rates_grad(x[0], x[1], x[2], slope, p, g[0, 0], g[0, 1], g[0, 2],
                                                        g[1, 0], g[1, 1], g[1, 2], g[2, 0], g[2, 1], g[2, 2],
                                                        s_fx, s_fy, s_mz)


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
def _ekf_wheel(p, i, vx, vy, r, angles, L, w, dxl, ay, omega, mu, grad):
    """Wheel i of the EKF kernels: eq. (19) load, then :func:`wheel_forces` with the rational slip angle.

    ``angles`` is :func:`_front_angles` (the rear wheels are not steered); ``(L, w, dxl)`` is
    :func:`load_terms`. Returns ``(c, s, x_i, y_i, lever, F_x, F_y, dFx/d(V_x, V_y, r) (3), dFy/d(...) (3),
    dFx/dF_n, dFy/dF_n, dFx/dlambda, dFy/dlambda, dlambda/domega)``; ``grad`` as in :func:`wheel_forces`.
    """
    xi, yi, sb, lever, R, cx0, cy0 = wheel_geometry(p, i)
    fn = wheel_normal_load(p, i, sb, lever, L, w, dxl, ay)
    cdl, sdl, tdl, cdr, sdr, tdr = angles
    if i == 0:
        c, s, td = cdl, sdl, tdl
    elif i == 1:
        c, s, td = cdr, sdr, tdr
    else:
        c, s, td = 1.0, 0.0, 0.0
    _, _, f_x, f_y, a0, a1, a2, b0, b1, b2, fxn, fyn, fxl, fyl, dlw = wheel_forces(
        vx, vy, r, xi, yi, c, s, td, 0.0, R, omega, fn, mu, cx0, cy0, False, grad)
    return c, s, xi, yi, lever, f_x, f_y, a0, a1, a2, b0, b1, b2, fxn, fyn, fxl, fyl, dlw


@njit(cache=True)
def planar_fused(vx, vy, r, u, p, slope):
    """Allocation-free eq. (11)-(19) for the EKF inner loop: rates, Jacobian and slope derivative.

    Same equations as :func:`planar_rates_jac` (the simulator's kernels), composed with scalars only so the
    compiled EKF loop does not allocate (the slip angle in its rational form, the body sums accumulated wheel by
    wheel); tests check it against planar_rates_jac and the Jacobian against finite differences. Returns a
    15-tuple: ``(dvx, dvy, dr, J00, J01, J02, J10, J11, J12, J20, J21, J22, ds0, ds1, ds2)``.
    """
    L, w, dxl = load_terms(p, u[U_AX], slope)
    angles = _front_angles(u[U_DELTA], u[U_DELTA_FR])
    dw = -p[P_MASS] * p[P_G] * math.sin(slope)
    # accumulated body sums and their derivatives w.r.t. (vx, vy, r, slope)
    sfx = 0.0
    sfy = 0.0
    mz = 0.0
    gx0 = gx1 = gx2 = gx3 = 0.0
    gy0 = gy1 = gy2 = gy3 = 0.0
    gm0 = gm1 = gm2 = gm3 = 0.0
    for i in range(4):
        c, s, xi, yi, lever, f_x, f_y, a0, a1, a2, b0, b1, b2, fxn, fyn, _, _, _ = _ekf_wheel(
            p, i, vx, vy, r, angles, L, w, dxl, u[U_AY], u[U_OMEGA + i], u[U_MU + i], True)
        dfn_ds = lever * dw / (2.0 * L)
        bx, by, mzi = wheel_body_force(c, s, xi, yi, f_x, f_y)
        sfx += bx
        sfy += by
        mz += mzi
        bx, by, mzi = wheel_body_force(c, s, xi, yi, a0, b0)
        gx0, gy0, gm0 = gx0 + bx, gy0 + by, gm0 + mzi
        bx, by, mzi = wheel_body_force(c, s, xi, yi, a1, b1)
        gx1, gy1, gm1 = gx1 + bx, gy1 + by, gm1 + mzi
        bx, by, mzi = wheel_body_force(c, s, xi, yi, a2, b2)
        gx2, gy2, gm2 = gx2 + bx, gy2 + by, gm2 + mzi
        bx, by, mzi = wheel_body_force(c, s, xi, yi, fxn * dfn_ds, fyn * dfn_ds)
        gx3, gy3, gm3 = gx3 + bx, gy3 + by, gm3 + mzi
    dvx, dvy, dr = body_rates(vx, vy, r, sfx, sfy, mz, slope, p)
    j00, j01, j02, j10, j11, j12, j20, j21, j22, ds0, ds1, ds2 = body_rates_grad(
        vx, vy, r, slope, p, gx0, gx1, gx2, gy0, gy1, gy2, gm0, gm1, gm2, gx3, gy3, gm3)
    return dvx, dvy, dr, j00, j01, j02, j10, j11, j12, j20, j21, j22, ds0, ds1, ds2


@njit(cache=True)
def planar_rates_fast(vx, vy, r, u, p, slope):
    """(dV_x/dt, dV_y/dt, dr/dt) of eq. (11)-(19) without derivatives (the EKF's f): the value part of
    :func:`planar_fused` (same per-wheel function, its derivatives not computed or dropped by the compiler)."""
    L, w, dxl = load_terms(p, u[U_AX], slope)
    angles = _front_angles(u[U_DELTA], u[U_DELTA_FR])
    sfx = 0.0
    sfy = 0.0
    mz = 0.0
    for i in range(4):
        c, s, xi, yi, _, f_x, f_y, _, _, _, _, _, _, _, _, _, _, _ = _ekf_wheel(
            p, i, vx, vy, r, angles, L, w, dxl, u[U_AY], u[U_OMEGA + i], u[U_MU + i], False)
        bx, by, mzi = wheel_body_force(c, s, xi, yi, f_x, f_y)
        sfx += bx
        sfy += by
        mz += mzi
    return body_rates(vx, vy, r, sfx, sfy, mz, slope, p)


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
def _quad3(a0, a1, a2, c00, c01, c02, c11, c12, c22):
    """a' C a for a 3-vector a and the symmetric C given by its upper triangle."""
    return a0 * a0 * c00 + a1 * a1 * c11 + a2 * a2 * c22 + 2.0 * (a0 * a1 * c01 + a0 * a2 * c02 + a1 * a2 * c12)


@njit(cache=True, inline="always")
def forces_fused(mean, cov, u, p, slope, omega_rel_std, fx_out, fy_out, fx_std, fy_std, k):
    """Tyre forces at the estimate ``mean[k]`` and their std by the delta method through (18)->(15)-(17).

    Works on whole arrays at sample ``k`` (indexing them here is cheaper than passing row views):
    ``mean`` (T, n) and ``cov`` (T, n, n) are the state estimate and covariance (their (V_x, V_y, r)
    block is used), ``u`` (T, 12) the inputs, ``slope`` (T,) the grade entering the loads (19) (rad),
    ``omega_rel_std`` the relative std of the wheel-speed inputs (independent wheels), whose
    contribution is added. Writes row k of fx, fy and their stds (T, 4) and returns
    ``(F_res, F_res std)``, F_res = sum F_X + M r V_y - C_x V_x|V_x| of eq. (21) in N. Allocation-free.
    The per-wheel forces and derivatives are those of :func:`planar_fused` (:func:`_ekf_wheel`).
    """
    vx = mean[k, 0]
    vy = mean[k, 1]
    r = mean[k, 2]
    L, w, dxl = load_terms(p, u[k, U_AX], slope[k])
    angles = _front_angles(u[k, U_DELTA], u[k, U_DELTA_FR])
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
        omega = u[k, U_OMEGA + i]
        c, s, xi, yi, _, f_x, f_y, a0, a1, a2, b0, b1, b2, _, _, fxl, fyl, dlw = _ekf_wheel(
            p, i, vx, vy, r, angles, L, w, dxl, u[k, U_AY], omega, u[k, U_MU + i], True)
        wv = (omega_rel_std * omega) ** 2
        fx_out[k, i] = f_x
        fy_out[k, i] = f_y
        qx = _quad3(a0, a1, a2, c00, c01, c02, c11, c12, c22) + fxl * fxl * dlw * dlw * wv
        qy = _quad3(b0, b1, b2, c00, c01, c02, c11, c12, c22) + fyl * fyl * dlw * dlw * wv
        fx_std[k, i] = math.sqrt(max(qx, 0.0))
        fy_std[k, i] = math.sqrt(max(qy, 0.0))
        sfx += wheel_body_force(c, s, xi, yi, f_x, f_y)[0]
        g0 += wheel_body_force(c, s, xi, yi, a0, b0)[0]
        g1 += wheel_body_force(c, s, xi, yi, a1, b1)[0]
        g2 += wheel_body_force(c, s, xi, yi, a2, b2)[0]
        d = wheel_body_force(c, s, xi, yi, fxl, fyl)[0] * dlw
        v_in += d * d * wv
    m = p[P_MASS]
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

# Module-level, disk-cached model functions with the engine's parameter convention f(x, u, k, params):
# ``params`` = ``Vehicle.as_array()`` followed by dt (:func:`ekf_params`). The vehicle and the step are read
# at run time, so one compiled function per variant (cascade / joint) serves every vehicle and dt, and the
# engine's disk-cached EKF loop calls them through function pointers: a new process (the CLI) loads
# everything instead of compiling it, whatever the car.

def ekf_params(vehicle: Vehicle, dt: float) -> np.ndarray:
    """``params`` of the vehicle EKF models: ``Vehicle.as_array()`` then ``dt`` as the last entry."""
    return np.append(vehicle.as_array(), float(dt))


@njit(cache=True, inline="always")
def _dt(params):
    """dt, the last entry of the EKF's params (:func:`ekf_params`)."""
    return params[params.shape[0] - 1]


@njit(cache=True)
def ekf_f(x, u, k, params):
    """x[k+1] of eq. (20), state (V_x, V_y, r) (:func:`ekf_next`; ``params`` of :func:`ekf_params`)."""
    return ekf_next(x, u, params, _dt(params))


@njit(cache=True)
def ekf_f_jac(x, u, k, params):
    """Jacobian (3, 3) of :func:`ekf_f`."""
    return ekf_jacobian(x, u, params, _dt(params))


@njit(cache=True)
def ekf_f_step(x, u, k, params, out, F):
    """Fused :func:`ekf_f` and its Jacobian (:func:`ekf_step`)."""
    ekf_step(x, u, params, _dt(params), out, F)


@njit(cache=True)
def joint_f(x, u, k, params):
    """Augmented transition, state (V_x, V_y, r, theta_r) (:func:`joint_next`)."""
    return joint_next(x, u, params, _dt(params))


@njit(cache=True)
def joint_f_jac(x, u, k, params):
    """Jacobian (4, 4) of :func:`joint_f`."""
    return joint_jacobian(x, u, params, _dt(params))


@njit(cache=True)
def joint_f_step(x, u, k, params, out, F):
    """Fused :func:`joint_f` and its Jacobian (:func:`joint_step`)."""
    joint_step(x, u, params, _dt(params), out, F)


@njit(cache=True)
def ekf_h(x, u, k, params):
    """Measurements (V_x, r) of eq. (20), for either state (3 or 4 states)."""
    y = np.empty(2)
    y[0] = x[0]
    y[1] = x[2]
    return y


@njit(cache=True)
def ekf_h_jac(x, u, k, params):
    """Jacobian (2, n) of :func:`ekf_h`."""
    H = np.zeros((2, x.shape[0]))
    H[0, 0] = 1.0
    H[1, 2] = 1.0
    return H


@njit(cache=True)
def ekf_h_step(x, u, k, params, out, H):  # H keeps its content between calls: the two ones are written each time
    """Fused :func:`ekf_h` and its Jacobian."""
    out[0] = x[0]
    out[1] = x[2]
    H[0, 0] = 1.0
    H[1, 2] = 1.0


def _ekf_functions(joint: bool) -> tuple:
    """(f, f_jac, h, h_jac, f_step, h_step) of eq. (20) (``joint``: with the grade as 4th state)."""
    if joint:
        return joint_f, joint_f_jac, ekf_h, ekf_h_jac, joint_f_step, ekf_h_step
    return ekf_f, ekf_f_jac, ekf_h, ekf_h_jac, ekf_f_step, ekf_h_step


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
        step for f and F), called as ``f(x, u, k, params)`` with ``params`` = :func:`ekf_params` (the vehicle
        and dt; the same compiled functions for every vehicle); inputs are rows of :func:`planar_inputs`.

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
    f, f_jac, h, h_jac, f_step, h_step = _ekf_functions(False)
    Q = np.diag([tuning.vx_rate_psd, tuning.vy_rate_psd, tuning.yaw_accel_psd]) * dt
    R = np.diag([tuning.speed_std ** 2, tuning.yaw_rate_std ** 2])
    P0 = np.diag(np.square(tuning.initial_std[:3]))
    return _nonlinear_model_class()(f, h, Q, R, x0, P0, transition_jacobian=f_jac, observation_jacobian=h_jac,
                                     transition_step=f_step, observation_step=h_step, params=ekf_params(vehicle, dt))


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
    f, f_jac, h, h_jac, f_step, h_step = _ekf_functions(True)
    Q = np.diag([tuning.vx_rate_psd, tuning.vy_rate_psd, tuning.yaw_accel_psd, tuning.slope_rate_psd]) * dt
    R = np.diag([tuning.speed_std ** 2, tuning.yaw_rate_std ** 2])
    P0 = np.diag(np.square(tuning.initial_std))
    return _nonlinear_model_class()(f, h, Q, R, x0, P0, transition_jacobian=f_jac, observation_jacobian=h_jac,
                                     transition_step=f_step, observation_step=h_step, params=ekf_params(vehicle, dt))


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
