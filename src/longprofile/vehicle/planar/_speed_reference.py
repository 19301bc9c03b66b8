"""Vehicle reference speed V_x from the ABS wheel speeds, robust to wheel slip (the EKF's V_x measurement).

Paper 001 measures V_x as the mean rear-wheel translational speed (section IV.A), which assumes the
rear wheels do not slip. That holds for the undriven rear axle of a front-wheel-drive car while it is
not braked, and fails under braking (every wheel is braked) and on rear- or all-wheel-drive cars.
:func:`speed_reference` builds the measurement as ABS/ESC reference-speed estimators do: it reads the
speed from the wheels that carry no torque when there are some, corrects the others for their slip
when there are none, and marks the sample missing (NaN) when no wheel can be trusted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..._jit import njit
from ..._validation import require_positive
from ...errors import InputError
from ._dugoff import dugoff_grad
from ._model import normal_loads
from ._params import (
    P_CX0_F,
    P_CX0_R,
    P_CXA,
    P_CY0_F,
    P_CY0_R,
    P_LF,
    P_LR,
    P_MASS,
    P_R_F,
    P_R_R,
    P_TRACK_F,
    P_TRACK_R,
    Vehicle,
    default_vehicle,
)
from ._simulate import DriveLog

__all__ = ["SpeedReference", "speed_reference", "SPEED_SOURCES"]

#: Meaning of the codes of :attr:`SpeedReference.source`.
SPEED_SOURCES = {0: "missing (no trustworthy wheel)", 1: "torque-free (undriven, unbraked) wheels",
                 2: "all four wheels, slip-compensated", 3: "mean rear-wheel speed (paper 001)"}

_MISSING, _FREE, _COMPENSATED, _REAR_MEAN = 0, 1, 2, 3


@dataclass(frozen=True, eq=False)
class SpeedReference:
    """Reference longitudinal speed V_x (the EKF's first measurement) with its per-sample std.

    Attributes
    ----------
    speed : (T,) ndarray
        V_x at the centre of gravity, m/s; NaN where no wheel is trustworthy (``source == 0``).
    std : (T,) ndarray
        Standard deviation of ``speed``, m/s (NaN where missing).
    source : (T,) ndarray of int8
        How each sample was obtained (:data:`SPEED_SOURCES`): 0 missing, 1 torque-free wheels,
        2 slip-compensated four-wheel speed, 3 the paper's mean rear-wheel speed.
    wheel_slip : (T, 4) ndarray
        Longitudinal slip of each wheel (FL, FR, RL, RR) implied by ``speed`` (eq. (18)); NaN where
        ``speed`` is missing.
    method : str
        ``"robust"`` or ``"rear-mean"``.
    """

    speed: np.ndarray
    std: np.ndarray
    source: np.ndarray
    wheel_slip: np.ndarray
    method: str

    @property
    def missing_fraction(self) -> float:
        """Fraction of the samples marked missing."""
        return float(np.mean(self.source == _MISSING))


@njit(cache=True)
def _tyre_force(x, fn, mu, c0, cy0):
    """Dugoff force (eq. (15)-(17), no slip angle) of a tyre whose R omega is x times its plane speed v_w.

    Slip of eq. (18): driving (x >= 1) lambda = 1 - 1/x, braking lambda = x - 1. Returns
    (F_x, dF_x/dx).
    """
    if x >= 1.0:
        lam = 1.0 - 1.0 / x
        dl = 1.0 / (x * x)
    else:
        lam = x - 1.0
        dl = 1.0
    f, _, dfl, _, _, _, _, _ = dugoff_grad(lam, 0.0, fn, mu, c0, cy0)
    return f, dfl * dl


@njit(cache=True)
def _wheel_kinematics(omega, steer, gyro, ax, ay, p, kin, f_sum):
    """Per-wheel V_x (T, 4) from R omega_i, and the sum of the tyre forces but the drag (T,) from the accelerometers.

    ``steer`` (T, 2): front-left and front-right road-wheel angles; radius and track are those of each axle.
    """
    lf = p[P_LF]
    lr = p[P_LR]
    L = lf + lr
    hbf = 0.5 * p[P_TRACK_F]
    hbr = 0.5 * p[P_TRACK_R]
    Rf = p[P_R_F]
    Rr = p[P_R_R]
    m = p[P_MASS]
    for k in range(omega.shape[0]):
        r = gyro[k]
        sd_mean = 0.0
        # V_x seen by each wheel from its plane speed R omega: v_w = (V_x - r y_i) cos d_i + (V_y + r x_i) sin d_i
        # with the kinematic V_y = l_r r (no rear slip angle), so V_y + r x_f = r L at the front, 0 at the rear
        for i in range(4):
            if i < 2:
                d = steer[k, i]
                cd = math.cos(d)
                sd = math.sin(d)
                sd_mean += 0.5 * sd
                yi = hbf if i == 0 else -hbf
                kin[k, i] = (Rf * omega[k, i] - r * L * sd) / cd + r * yi
            else:
                yi = hbr if i == 2 else -hbr
                kin[k, i] = Rr * omega[k, i] + r * yi
        # sum of the tyre forces along the wheel planes but the drag (added at V_x later): accelerometer
        # (specific force) plus the part of the front lateral force (about M a_y l_r / L) that steering
        # turns against the x axis
        f_sum[k] = m * ax[k] + m * ay[k] * (lr / L) * sd_mean


@njit(cache=True)
def _robust_kernel(kin_all, force, force_now, force_change, ax, ay, mu, p, free_axle, brake_force, speed_std,
                   accel_std, stiff_rel, max_std, speed, std, source, slip):
    T = kin_all.shape[0]
    m = p[P_MASS]
    cxa = p[P_CXA]
    c0 = 0.5 * (p[P_CX0_F] + p[P_CX0_R])  # the mean tyre stiffness, for the equal-slip start of Newton
    fn = np.empty(4)
    for k in range(T):
        kin = kin_all[k]
        v0 = 0.25 * (kin[0] + kin[1] + kin[2] + kin[3])
        drag0 = cxa * v0 * abs(v0)  # the drag at the mean wheel speed, for the decision and the start
        f_sum = force[k] + drag0
        # brakes on as soon as the current or the averaged force says so (a brake step reaches the wheels
        # within a few ms, before the average)
        if free_axle >= 0 and min(f_sum, force_now[k] + drag0) >= -brake_force:
            # torque-free wheels (undriven axle, brakes off): no slip, their mean is V_x
            j = 2 * free_axle
            v = 0.5 * (kin[j] + kin[j + 1])
            speed[k] = v
            std[k] = speed_std
            source[k] = _FREE
        else:
            # every wheel may carry torque: solve sum_i F_i(kin_i / v) = f_sum for v with the Dugoff forces at the
            # loads of eq. (19) (level road); Newton from the equal-slip linear solution sum kin / (4 + f_sum / C_x0)
            normal_loads(p, ax[k], ay[k], 0.0, fn)
            v = (kin[0] + kin[1] + kin[2] + kin[3]) / (4.0 + f_sum / c0)
            dg = 0.0
            ok = False
            for _ in range(20):
                if not (v > 0.0 and math.isfinite(v)):
                    break
                g = -force[k] - cxa * v * abs(v)
                dg = 0.0
                for i in range(4):
                    x = kin[i] / v
                    if i < 2:
                        f, dfx = _tyre_force(x, fn[i], mu[k, i], p[P_CX0_F], p[P_CY0_F])
                    else:
                        f, dfx = _tyre_force(x, fn[i], mu[k, i], p[P_CX0_R], p[P_CY0_R])
                    g += f
                    dg -= dfx * x / v
                if dg >= 0.0:  # tyre force no longer falls with v: wheels locked or beyond the peak
                    break
                dg -= 2.0 * cxa * abs(v)  # the drag's derivative
                step = g / dg
                v -= step
                if abs(step) <= 1e-10 * abs(v):
                    ok = v > 0.0
                    break
            if ok:
                # dv/d(sum F) = 1 / (d sum F_i / dv); force errors: accelerometer noise M sigma_a (not reduced
                # by the averaging: the averaged error is correlated over the window), the tyre model's
                # relative error eps |sum F| and the recent change of the force (encoder lag)
                sens = 1.0 / dg
                sf2 = (m * accel_std) ** 2 + (stiff_rel * f_sum) ** 2 + force_change[k] ** 2
                s_v = math.sqrt(speed_std * speed_std + sens * sens * sf2)
                ok = s_v <= max_std
            if ok:
                speed[k] = v
                std[k] = s_v
                source[k] = _COMPENSATED
            else:
                speed[k] = np.nan
                std[k] = np.nan
                source[k] = _MISSING
        v = speed[k]
        for i in range(4):
            if math.isfinite(v):
                rw = kin[i]
                slip[k, i] = (rw - v) / max(rw, v, 0.5)
            else:
                slip[k, i] = np.nan


def _driven_radius(vehicle: Vehicle) -> float:
    """Rolling radius of the driven wheels (their mean for all-wheel drive), m."""
    front, rear = vehicle.wheel_radii
    return {"front": front, "rear": rear, "all": 0.5 * (front + rear)}[vehicle.driven_axle]


def speed_reference(log: DriveLog, vehicle: Vehicle | None = None, *, method: str = "robust",
                    speed_std: float = 0.004, accel_std: float = 0.05, tyre_rel_std: float = 0.1,
                    max_std: float = 0.2, force_window: float = 0.01, transient_time: float = 0.02,
                    brake_force: float | None = None, friction=None) -> SpeedReference:
    r"""Reference longitudinal speed V_x from the wheel speeds, with a per-sample std (the EKF's measurement).

    Parameters
    ----------
    log : DriveLog
        Wheel speeds (rad/s), steering angle (rad), gyro yaw rate (rad/s), accelerometers (m/s^2).
    vehicle : Vehicle, optional
        Wheel radius, geometry, mass, drag, tyre stiffness C_x0 and drivetrain (default
        :func:`default_vehicle`).
    method : {"robust", "rear-mean"}
        ``"rear-mean"``: paper 001's V_x = R (omega_RL + omega_RR)/2 with std ``speed_std`` at every
        sample. ``"robust"``: per sample, the torque-free wheels when there are any, otherwise the
        slip-compensated four wheels, otherwise missing (see Notes).
    speed_std : float
        Std of a speed read from torque-free wheels (encoder quantisation and noise), m/s.
    accel_std : float
        Std of the longitudinal accelerometer per sample, m/s^2 (enters the std of compensated samples).
    tyre_rel_std : float
        Relative error of the tyre model's forces (C_x0, mu, loads) at a given slip; enters the std of
        compensated samples as ``tyre_rel_std * |sum F_x|``.
    max_std : float
        Compensated samples whose std exceeds this (m/s) are marked missing.
    force_window : float
        Length of the causal moving average applied to the accelerometer force, s. The ABS period
        measurement averages the wheel speed over the last few tooth pitches (5-15 ms at 10-30 m/s
        with 48 teeth and 4 pitches), so the force is averaged over a similar window.
    transient_time : float
        The change of the averaged force over the last ``transient_time`` seconds is added to the
        force uncertainty: right after the brakes are applied or released the encoders still report
        the previous slip (lag of the period measurement, wheel spin-up).
    brake_force : float, optional
        Total retarding tyre force, N, below which the brakes are assumed on (so the undriven wheels
        are braked too). Default ``vehicle.engine_brake_torque`` over the driven wheels' rolling radius
        (their mean for all-wheel drive): up to that, engine braking alone retards the car, through the
        driven wheels.
    friction : (4,) or (T, 4) array_like, optional
        Adhesion mu_i of the tyre model (default ``vehicle.friction``).

    Returns
    -------
    SpeedReference
        ``speed`` and ``std`` (T,) in m/s (NaN = missing), ``source`` (T,) codes, ``wheel_slip`` (T, 4).

    Raises
    ------
    InputError
        For an unknown ``method``, a negative or non-finite setting, or a bad ``friction``.

    Notes
    -----
    "robust", per sample k (docs/vehicle-slope.md, "The V_x measurement"):

    1. Each wheel's speed is referred to the centre of gravity: v_w,i = (V_x - r y_i) cos d_i +
       (V_y + r x_i) sin d_i (the wheel-plane speed of eq. (18)) is solved for V_x with R omega_i for
       v_w,i, the gyro r, the measured steering d and the kinematic lateral speed V_y = l_r r (rear
       slip angle neglected). For the mean of a left and a right wheel the yaw terms cancel.
    2. The sum of the tyre forces is read from the accelerometer, which measures specific force (no
       gravity term, so no grade is needed): sum F_x = M a_x + C_x V_x|V_x| + M a_y (l_r/L) sin d,
       averaged over ``force_window``.
    3. If the car has an undriven axle and sum F_x >= -``brake_force`` (driving, cruising, or engine
       braking only), the undriven wheels carry no torque and do not slip: V_x is their mean, std
       ``speed_std``. This is the non-driven-wheel reference of traction control; on a front-wheel-drive
       car it is the paper's rear-wheel mean.
    4. Otherwise (brakes on, or all-wheel drive) every wheel slips. Each tyre force is the Dugoff
       force (15)-(17) (no slip angle) of its slip lambda_i(R omega_i / V_x) of eq. (18), at the loads of
       eq. (19) on a level road, whatever the brake balance or torque split. V_x solves
       sum_i F_i(V_x) = sum F_x (Newton, from the equal-slip linear solution
       sum_i kin_i / (4 + sum F_x / C_x0)). Its std adds the accelerometer noise M ``accel_std``, the
       tyre-model error ``tyre_rel_std`` |sum F_x| and the recent force change through
       dV_x/d(sum F_x), which grows as the tyres approach saturation.
    5. If Newton fails (the force no longer falls with V_x: all wheels locked or beyond their peak) or
       the std exceeds ``max_std``, the sample is missing (NaN): the EKF propagates on its model and
       the accelerometer-fed loads instead, as an ABS extrapolates its reference speed while all four
       wheels slip.

    References: the selection of the wheel speeds least affected by slip (non-driven wheels when
    driving, "select-high" when braking, a deceleration-limited extrapolation when all wheels slip) is
    the classic ABS/TCS reference speed, e.g. EP 0 348 072 ("Vehicle speed estimation in
    anti-lock braking systems"), US 5 185 703 (Akebono), van Zanten, "Bosch ESP systems: 5 years of
    experience", SAE 2000-01-1633. The slip compensation with a tyre model and the accelerometer is
    this module's own step (it needs no brake pressure, which a drive log does not have).
    """
    vehicle, (speed_std, accel_std, stiff, max_std, force_window, transient_time, brake_force) = _reference_settings(
        log, vehicle, method, speed_std, accel_std, tyre_rel_std, max_std, force_window, transient_time, brake_force)
    T = log.time.size
    if method == "rear-mean":
        v = 0.5 * vehicle.wheel_radii[1] * (log.wheel_speeds[:, 2] + log.wheel_speeds[:, 3])
        rw = vehicle.wheel_radius_of_each * log.wheel_speeds
        slip = (rw - v[:, None]) / np.maximum(np.maximum(rw, v[:, None]), 0.5)
        return SpeedReference(speed=v, std=np.full(T, speed_std), source=np.full(T, _REAR_MEAN, dtype=np.int8),
                              wheel_slip=slip, method=method)
    mu = _friction_rows(vehicle, friction, T)
    free_axle = {"front": 1, "rear": 0, "all": -1}[vehicle.driven_axle]  # 0 = front wheels free, 1 = rear
    p = vehicle.as_array()
    kin = np.empty((T, 4))
    f_raw = np.empty(T)
    _wheel_kinematics(log.wheel_speeds, log.front_steering, log.yaw_rate, log.accel_x, log.accel_y, p, kin, f_raw)
    force, change = _averaged_force(f_raw, log.dt, force_window, transient_time)
    speed = np.empty(T)
    std = np.empty(T)
    source = np.empty(T, dtype=np.int8)
    slip = np.empty((T, 4))
    _robust_kernel(kin, force, f_raw, change, log.accel_x, log.accel_y, mu, p, free_axle, float(brake_force),
                   speed_std, accel_std, stiff, max_std, speed, std, source, slip)
    return SpeedReference(speed=speed, std=std, source=source, wheel_slip=slip, method=method)


def _reference_settings(log, vehicle, method, speed_std, accel_std, tyre_rel_std, max_std, force_window,
                        transient_time, brake_force):
    """speed_reference's arguments checked: the vehicle (default :func:`default_vehicle`) and the settings
    (speed_std, accel_std, tyre_rel_std, max_std, force_window, transient_time, brake_force) as floats."""
    if method not in ("robust", "rear-mean"):
        raise InputError(f"method must be 'robust' or 'rear-mean'; got {method!r}.")
    if not isinstance(log, DriveLog):
        raise InputError(f"log must be a DriveLog; got {type(log).__name__}.")
    vehicle = default_vehicle() if vehicle is None else vehicle
    if not isinstance(vehicle, Vehicle):
        raise InputError(f"vehicle must be a Vehicle; got {type(vehicle).__name__}.")
    speed_std = require_positive("speed_std", speed_std)
    accel_std = require_positive("accel_std", accel_std, strict=False)
    stiff = require_positive("tyre_rel_std", tyre_rel_std, strict=False)
    max_std = require_positive("max_std", max_std)
    force_window = require_positive("force_window", force_window, strict=False)
    transient_time = require_positive("transient_time", transient_time, strict=False)
    if brake_force is None:
        brake_force = vehicle.engine_brake_torque / _driven_radius(vehicle)
    brake_force = require_positive("brake_force", brake_force, strict=False)
    return vehicle, (speed_std, accel_std, stiff, max_std, force_window, transient_time, brake_force)


def _friction_rows(vehicle, friction, T) -> np.ndarray:
    """The adhesion of each wheel at each sample (T, 4): ``friction`` (default ``vehicle.friction``) checked."""
    mu = np.asarray(vehicle.friction, dtype=float) if friction is None else np.asarray(friction, dtype=float)
    if mu.shape not in ((4,), (T, 4)) or not np.all(np.isfinite(mu)) or np.any(mu <= 0):
        raise InputError(f"friction must be positive finite values of shape (4,) or (T, 4) = ({T}, 4); got shape "
                         f"{mu.shape}.")
    return np.ascontiguousarray(np.broadcast_to(mu, (T, 4)))


def _averaged_force(f_raw, dt, force_window, transient_time):
    """(force, change): the accelerometer force averaged over ``force_window`` (causal) and |its change over the
    last ``transient_time``|, the force uncertainty after a brake apply or release."""
    # the encoders report the mean speed over their last tooth pitches: average the force over a similar
    # window, and count its change over the last transient_time as force uncertainty (brake apply/release)
    T = f_raw.shape[0]
    w = max(1, int(round(force_window / dt)))
    c = np.concatenate(([0.0], np.cumsum(f_raw)))
    idx = np.arange(1, T + 1)
    force = (c[idx] - c[np.maximum(idx - w, 0)]) / np.minimum(idx, w)
    n = max(1, int(round(transient_time / dt)))
    change = np.abs(force - force[np.maximum(np.arange(T) - n, 0)])
    return force, change
