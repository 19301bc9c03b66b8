"""The equations of the planar 4-wheel model (paper 001, eq. (11)-(19)), each written once (numba, inlined).

Every kernel of :mod:`._model` (the simulator's array kernels, the EKF's fused step, its value-only transition and
the tyre forces with their std) is composed from these pieces; numba inlines them (``inline="always"``), so a
kernel runs them with its own floating-point flags and the compiler drops what a kernel does not use. Conventions
(axes, wheel order FL, FR, RL, RR, the parameter vector ``p``) are those of :mod:`._model`.

Two equations have two numerical forms, each written once here, because the kernels that use them have always
rounded differently and their outputs are kept bit for bit:

* the slip angle: :func:`slip_angle` (``delta - atan2``, then ``tan``: the angle itself, for the simulator's log)
  and :func:`tan_slip_angle` (the rational form of tan(alpha), no trigonometry per wheel: the EKF kernels);
* the body sums (12)-(14): :func:`wheel_sums` (the paper's form, the front pair summed before its rotation: the
  simulator and :func:`._model.planar_rates_jac`) and :func:`wheel_body_force` (one wheel rotated into body
  axes, accumulated wheel by wheel: the EKF kernels).
"""

from __future__ import annotations

import math

from ..._jit import njit
from ._dugoff import dugoff_grad
from ._params import (
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
)

#: Floor of the slip denominator max(R omega, V) of eq. (18), m/s: the model is not meant for standstill.
V_MIN = 0.5


# ------------------------------------------------------------------------------ eq. (19): geometry, normal loads

@njit(cache=True, inline="always")
def _axle(p, front):
    """(track, rolling radius, C_x0, C_y0) of the front (``front`` True) or the rear axle."""
    if front:
        return p[P_TRACK_F], p[P_R_F], p[P_CX0_F], p[P_CY0_F]
    return p[P_TRACK_R], p[P_R_R], p[P_CX0_R], p[P_CY0_R]


@njit(cache=True, inline="always")
def wheel_geometry(p, i):
    """Wheel i (FL, FR, RL, RR): ``(x_i, y_i, track, lever, R, C_x0, C_y0)``.

    (x_i, y_i) is the wheel centre in body axes (x_i = l_f front, -l_r rear; y_i = +-track/2, left positive),
    ``lever`` the axle's share of the static load (l_r front, l_f rear); the track, rolling radius and
    stiffnesses are those of the wheel's axle.
    """
    front = i < 2
    sb, R, cx0, cy0 = _axle(p, front)
    hb = 0.5 * sb
    xi = p[P_LF] if front else -p[P_LR]
    yi = hb if (i % 2) == 0 else -hb
    lever = p[P_LR] if front else p[P_LF]
    return xi, yi, sb, lever, R, cx0, cy0


@njit(cache=True, inline="always")
def load_terms(p, ax, slope):
    """The per-vehicle terms of eq. (19): ``(L, w, dxl)`` = wheelbase, M g cos(theta), H M a_x / (2 L)."""
    m = p[P_MASS]
    L = p[P_LF] + p[P_LR]
    return L, m * p[P_G] * math.cos(slope), p[P_H] * m * ax / (2.0 * L)


@njit(cache=True, inline="always")
def wheel_normal_load(p, i, sb, lever, L, w, dxl, ay):
    """Eq. (19) at wheel i: the static share lever w / (2 L), minus (front) or plus (rear) the longitudinal
    transfer ``dxl``, minus (left) or plus (right) the lateral transfer lever H M a_y / (track L) of its axle."""
    lat = lever * p[P_H] * p[P_MASS] * ay / (sb * L)
    fn = lever * w / (2.0 * L)
    fn = fn - dxl if i < 2 else fn + dxl
    return fn - lat if (i % 2) == 0 else fn + lat


# ------------------------------------------------------------------------------ eq. (18): wheel kinematics, slips

@njit(cache=True, inline="always")
def wheel_velocity(vx, vy, r, xi, yi, c, s):
    """Wheel-centre velocity (v_xi, v_yi) = (V_x - r y_i, V_y + r x_i), its component v_w along the wheel plane
    (steering angle with cosine ``c``, sine ``s``) and dv_w/dr; dv_w/d(V_x, V_y) = (c, s)."""
    vxi = vx - r * yi
    vyi = vy + r * xi
    return vxi, vyi, vxi * c + vyi * s, -yi * c + xi * s


@njit(cache=True, inline="always")
def slip_ratio(rw, vw, R):
    """Longitudinal slip of eq. (18) and its derivatives: ``(lambda, d lambda/d v_w, d lambda/d omega)``.

    ``rw`` = R omega (m/s), ``vw`` the wheel-plane speed (m/s). Driving (R omega >= v_w): (R omega - v_w)/(R omega);
    braking: R omega / v_w - 1; below :data:`V_MIN` the denominator is held at V_MIN (the model is not meant for
    standstill).
    """
    if rw >= vw and rw >= V_MIN:
        return (rw - vw) / rw, -1.0 / rw, R * vw / (rw * rw)
    if vw >= V_MIN:
        return rw / vw - 1.0, -rw / (vw * vw), R / vw
    return (rw - vw) / V_MIN, -1.0 / V_MIN, R / V_MIN


@njit(cache=True, inline="always")
def slip_angle(vxi, vyi, xi, yi, delta):
    """Slip angle alpha = delta - atan2(v_yi, v_xi) (rad), t = tan(alpha) and dt/d(V_x, V_y, r):
    ``(alpha, t, dt/dV_x, dt/dV_y, dt/dr)`` (the trigonometric form; the simulator logs alpha)."""
    a = delta - math.atan2(vyi, vxi)
    t = math.tan(a)
    # d(beta) = (vxi d(vyi) - vyi d(vxi)) / q ; d(alpha) = -d(beta) ; d(t) = (1 + t^2) d(alpha)
    k = -(1.0 + t * t) / (vxi * vxi + vyi * vyi)
    return a, t, k * (-vyi), k * vxi, k * (vxi * xi + vyi * yi)


@njit(cache=True, inline="always")
def tan_slip_angle(vxi, vyi, xi, yi, td, grad):
    """tan(alpha) = tan(delta - atan(v_yi / v_xi)) = (td v_xi - v_yi) / (v_xi + td v_yi), td = tan(delta), without
    trigonometry; ``(t, dt/dV_x, dt/dV_y, dt/dr)``, the derivatives zero unless ``grad`` (a compile-time constant)."""
    num = td * vxi - vyi
    den = vxi + td * vyi
    t = num / den
    if not grad:
        return t, 0.0, 0.0, 0.0
    # d t / d(vxi, vyi), then chain to (vx, vy, r): d vxi = (1, 0, -yi), d vyi = (0, 1, xi)
    tx = (td * den - num) / (den * den)
    ty = (-den - num * td) / (den * den)
    return t, tx, ty, -yi * tx + xi * ty


# ------------------------------------------------------------------------------ eq. (15)-(17): tyre forces

@njit(cache=True, inline="always")
def force_partials(fxl, fxt, fyl, fyt, dl, c, s, dvw2, dt0, dt1, dt2):
    """Chain rule from the Dugoff partials (w.r.t. slip and tan(alpha)) to d(F_x, F_y)/d(V_x, V_y, r):
    ``(dFx/dV_x, dFx/dV_y, dFx/dr, dFy/dV_x, dFy/dV_y, dFy/dr)`` with d lambda = dl (c, s, dvw2), dt = (dt0, dt1, dt2)."""
    return (fxl * dl * c + fxt * dt0, fxl * dl * s + fxt * dt1, fxl * dl * dvw2 + fxt * dt2,
            fyl * dl * c + fyt * dt0, fyl * dl * s + fyt * dt1, fyl * dl * dvw2 + fyt * dt2)


@njit(cache=True, inline="always")
def wheel_forces(vx, vy, r, xi, yi, c, s, td, delta, R, omega, fn, mu, cx0, cy0, trig, grad):
    """One tyre: slip (18), slip angle, Dugoff forces (15)-(17) in wheel axes and their partial derivatives.

    The wheel at (x_i, y_i) is steered by ``delta`` (cosine ``c``, sine ``s``, tangent ``td``), spins at ``omega``
    (rad/s) with rolling radius ``R`` and carries the normal load ``fn`` at adhesion ``mu``. ``trig`` (compile-time)
    selects :func:`slip_angle` (uses ``delta``) or :func:`tan_slip_angle` (uses ``td``; alpha is then returned as
    0.0); ``grad`` False skips the slip-angle derivatives there (a value-only kernel). Returns
    ``(lambda, alpha, F_x, F_y, dFx/dV_x, dFx/dV_y, dFx/dr, dFy/dV_x, dFy/dV_y, dFy/dr, dFx/dF_n, dFy/dF_n,
    dFx/dlambda, dFy/dlambda, dlambda/domega)``; a kernel that does not use a partial gets it dropped by the compiler.
    """
    vxi, vyi, vw, dvw2 = wheel_velocity(vx, vy, r, xi, yi, c, s)
    lam, dl, dlw = slip_ratio(R * omega, vw, R)
    if trig:
        a, t, dt0, dt1, dt2 = slip_angle(vxi, vyi, xi, yi, delta)
    else:
        a = 0.0
        t, dt0, dt1, dt2 = tan_slip_angle(vxi, vyi, xi, yi, td, grad)
    f_x, f_y, fxl, fxt, fyl, fyt, fxn, fyn = dugoff_grad(lam, t, fn, mu, cx0, cy0)
    a0, a1, a2, b0, b1, b2 = force_partials(fxl, fxt, fyl, fyt, dl, c, s, dvw2, dt0, dt1, dt2)
    return lam, a, f_x, f_y, a0, a1, a2, b0, b1, b2, fxn, fyn, fxl, fyl, dlw


# ------------------------------------------------------------------------------ eq. (12)-(14): body sums

@njit(cache=True, inline="always")
def wheel_body_force(c, s, xi, yi, fx, fy):
    """Eq. (12)-(14) for one wheel: its wheel-axis pair (fx, fy) rotated into body axes and its yaw moment about
    the centre of gravity: ``(b_x, b_y, x_i b_y - y_i b_x)`` (also applied to force derivatives)."""
    bx = c * fx - s * fy
    by = s * fx + c * fy
    return bx, by, xi * by - yi * bx


@njit(cache=True, inline="always")
def wheel_sums(fx0, fx1, fx2, fx3, fy0, fy1, fy2, fy3, delta_l, delta_r, lf, lr, hbf, hbr):
    """Eq. (12)-(14) on 4 wheel-axis force pairs (FL, FR, RL, RR): body-axis sums and yaw moment (paper's form).

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
    bx0, by0, _ = wheel_body_force(math.cos(delta_l), math.sin(delta_l), 0.0, 0.0, fx0, fy0)
    bx1, by1, _ = wheel_body_force(math.cos(delta_r), math.sin(delta_r), 0.0, 0.0, fx1, fy1)
    sfx = bx0 + bx1 + fx2 + fx3
    sfy = by0 + by1 + fy2 + fy3
    mz = lf * (by0 + by1) + hbf * (bx1 - bx0) + hbr * (fx3 - fx2) - lr * (fy2 + fy3)
    return sfx, sfy, mz


# ------------------------------------------------------------------------------ eq. (11): body derivative

@njit(cache=True, inline="always")
def body_rates(vx, vy, r, sfx, sfy, mz, slope, p):
    """Eq. (11) (yaw equation divided by I_z): ``(dV_x/dt, dV_y/dt, dr/dt)`` from the body sums.

    Aerodynamic drag is written C V|V| (the paper's C V^2 changes sign with V).
    """
    m = p[P_MASS]
    return (sfx / m + r * vy - p[P_CXA] * vx * abs(vx) / m - p[P_G] * math.sin(slope),
            sfy / m - r * vx - p[P_CYA] * vy * abs(vy) / m, mz / p[P_IZ])


@njit(cache=True, inline="always")
def body_rates_grad(vx, vy, r, slope, p, gx0, gx1, gx2, gy0, gy1, gy2, gm0, gm1, gm2, gxs, gys, gms):
    """Derivatives of :func:`body_rates` from those of the body sums (sfx, sfy, mz) w.r.t. (V_x, V_y, r)
    (``g*0..2``) and the slope (``g*s``): the 9 entries of d(rates)/d(V_x, V_y, r) row by row, then the 3 of
    d(rates)/d(slope)."""
    m = p[P_MASS]
    iz = p[P_IZ]
    return (gx0 / m - 2.0 * p[P_CXA] * abs(vx) / m, gx1 / m + r, gx2 / m + vy,
            gy0 / m - r, gy1 / m - 2.0 * p[P_CYA] * abs(vy) / m, gy2 / m - vx,
            gm0 / iz, gm1 / iz, gm2 / iz,
            gxs / m - p[P_G] * math.cos(slope), gys / m, gms / iz)
