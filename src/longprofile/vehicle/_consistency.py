"""Two checks of a drive log against the car file (session 39): the steering gain and the order of the axles.

* **Steering gain** (``steering_gain``). On steady, moderate turns the yaw rate of paper 001's model settles at the
  steady-state bicycle-model value: with the forces of (11) and (14) linearised (Dugoff's (15)-(17) below
  saturation, F_y = C_y0 alpha per tyre, the slip angles of (18)) and dV_y/dt = dr/dt = 0,

      r = V_x delta / (L (1 + K_us V_x^2)),  K_us = (M / L^2) (l_r / (2 C_y0,f) - l_f / (2 C_y0,r))

  (the same as Gillespie 1992, ch. 6, eq. 6-11 with K = K_us L). A steering-wheel angle divided by a wrong
  ``body.steering_ratio`` scales delta, and so the measured / predicted yaw rate, by the ratio's error; a car
  file's mass or cornering stiffness off changes K_us, whose effect grows with V_x^2 (the band widens with it).
* **Axle order** (``axle_order``). The driven axle's tyres carry the traction force, so their wheels turn
  faster than the free axle's by the slip F / (2 C_x0) of the linear range of (15)-(17) (eq. (18)):
  v_front / v_rear - 1 grows with the tractive force F = M a_x + C_x V_x^2 (eq. (11): the accelerometer's
  specific force includes the grade) on a front-driven car and falls on a rear-driven one. The slope of that line,
  over the one the car file's C_x0 predicts, is about +1 (the tyres' stiffness tolerance, the radius difference
  only offsets it); about -1 when the front and rear wheel-speed columns are swapped.
"""

from __future__ import annotations

import math

import numpy as np

# ---------------------------------------------------------------------------------------------- steering gain

#: Samples of the steering-gain fit: |a_y| below this, m/s^2 (Dugoff's (15)-(17) stay linear while each tyre's
#: C_y0 |alpha| < mu F_z / 2: about 3.9 m/s^2 at mu = 0.8, 3 m/s^2 on the inner wheels with the load transfer of
#: (19)) ...
GAIN_ACCEL_Y = 3.0
#: ... V_x above this, m/s ...
GAIN_SPEED = 5.0
#: ... the kinematic yaw rate V_x delta / L above this, rad/s (the steering excitation; 1.1 deg/s) ...
GAIN_MIN_YAW = 0.02
#: ... and steady: |d delta/dt| and |dr/dt| below this times |delta| and |r|, 1/s (the yaw rate's lag of about
#: 0.1-0.2 s then biases a sample's ratio by at most 10-20 %, of both signs on a sine, so the median keeps ~1).
GAIN_STEADY = 1.0
#: Seconds of such samples needed; fewer: no check.
GAIN_MIN_TIME = 1.0
#: Warning band: the car file's understeer gradient K_us known within this factor (the mass and the common level of
#: both axles' cornering stiffness within +-20 %: 1.2 / 0.8) ...
UNDERSTEER_SPREAD = 1.5
#: ... widened by this fraction.
GAIN_WARN = 0.15
#: Refusal band: the mass and EACH axle's cornering stiffness anywhere within this fraction (the front/rear balance
#: unknown too) ...
PARAMETER_SPREAD = 0.2
#: ... widened by this fraction.
GAIN_REFUSE = 0.30


def understeer_gradient(vehicle, mass: float = 1.0, front: float = 1.0, rear: float = 1.0) -> float:
    """K_us = (M / L^2) (l_r / C_f - l_f / C_r), s^2/m^2, with each axle's stiffness C = 2 C_y0 (module notes); the
    mass and the axles' stiffnesses times ``mass``, ``front``, ``rear``."""
    cf, cr = (2.0 * c for c in vehicle.cornering_stiffnesses)
    lf, lr = vehicle.cg_to_front_axle, vehicle.cg_to_rear_axle
    L = lf + lr
    return mass * vehicle.mass / (L * L) * (lr / (front * cf) - lf / (rear * cr))


def steady_state_yaw_rate(delta, speed, vehicle):
    """The steady-state bicycle-model yaw rate V delta / (L (1 + K_us V^2)), rad/s (module notes; NaN past an
    oversteering car's critical speed)."""
    d = 1.0 + understeer_gradient(vehicle) * np.square(speed)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(d > 0, speed * delta / (vehicle.wheelbase * d), np.nan)


def gain_band(vehicle, speed: float, *, refuse: bool) -> tuple[float, float]:
    """The measured / predicted yaw rate's band at ``speed``: the steady-state gains of the cars within the stated
    spread (:data:`UNDERSTEER_SPREAD` for the warning, :data:`PARAMETER_SPREAD` on the mass and each axle for the
    refusal) over the car file's, widened by :data:`GAIN_WARN` or :data:`GAIN_REFUSE`."""
    v2 = speed * speed
    k = understeer_gradient(vehicle) * v2
    if refuse:
        e = PARAMETER_SPREAD
        ks = [understeer_gradient(vehicle, m, f, r) * v2 for m in (1 - e, 1 + e) for f in (1 - e, 1 + e)
              for r in (1 - e, 1 + e)]
        margin = GAIN_REFUSE
    else:
        ks = [k / UNDERSTEER_SPREAD, k * UNDERSTEER_SPREAD]
        margin = GAIN_WARN
    if min(ks + [k]) <= -1.0:
        return (-math.inf, math.inf)  # an oversteering car near its critical speed: nothing to compare
    ends = [(1.0 + k) / (1.0 + kk) for kk in ks + [k]]
    return (min(ends) * (1.0 - margin), max(ends) * (1.0 + margin))


def steering_gain(delta, r, speed, accel_y, dt: float, vehicle) -> tuple[float, int, float]:
    """The measured yaw rate over the steady-state bicycle model's from the road-wheel angle on steady turns.

    Parameters
    ----------
    delta, r, speed, accel_y : (T,) ndarray
        Road-wheel angle (rad, its offset removed), yaw rate (rad/s), V_x (m/s), a_y (m/s^2), smoothed alike.
    dt : float
        Sample period, s.
    vehicle : Vehicle
        Mass, axle distances and cornering stiffnesses of K_us.

    Returns
    -------
    (float, int, float)
        The gain (median of r / r_ss over the samples: the robust fit of r = g r_ss through the origin), the
        number of samples and their median V_x; NaN gain when they last less than :data:`GAIN_MIN_TIME`.

    Notes
    -----
    Samples: |a_y| < :data:`GAIN_ACCEL_Y`, V_x > :data:`GAIN_SPEED`, |V_x delta / L| > :data:`GAIN_MIN_YAW`,
    |d delta/dt| < :data:`GAIN_STEADY` |delta| and |dr/dt| < :data:`GAIN_STEADY` |r|, r of delta's sign.
    """
    kin = speed * delta / vehicle.wheelbase
    steady = (np.abs(np.gradient(delta, dt)) < GAIN_STEADY * np.abs(delta)) & \
             (np.abs(np.gradient(r, dt)) < GAIN_STEADY * np.abs(r))
    pick = (np.abs(accel_y) < GAIN_ACCEL_Y) & (speed > GAIN_SPEED) & (np.abs(kin) > GAIN_MIN_YAW) & steady
    pred = steady_state_yaw_rate(delta, speed, vehicle)
    pick &= np.isfinite(pred)
    n = int(pick.sum())
    if n * dt < GAIN_MIN_TIME:
        return math.nan, n, math.nan
    return float(np.median(r[pick] / pred[pick])), n, float(np.median(speed[pick]))


def gain_verdict(gain: float, speed: float, vehicle) -> tuple[bool | None, bool, tuple[float, float]]:
    """(ok, warn, warning band): ok False beyond the refusal band, warn beyond the warning band."""
    if math.isnan(gain):
        return None, False, (math.nan, math.nan)
    lo, hi = gain_band(vehicle, speed, refuse=True)
    band = gain_band(vehicle, speed, refuse=False)
    return bool(lo <= gain <= hi), not band[0] <= gain <= band[1], band


def gain_message(gain: float, speed: float, steer_name: str, vehicle, refused: bool) -> str:
    """The one line of a steering gain outside its band: the factor, the likely causes and the ways on."""
    lo, hi = gain_band(vehicle, speed, refuse=refused)
    spread = (f"the mass and each axle's cornering stiffness within {100 * PARAMETER_SPREAD:g} %" if refused else
              f"the car file's understeer within a factor {UNDERSTEER_SPREAD:g}")
    ratio = getattr(vehicle, "steering_ratio", None)
    if ratio is not None:
        cause = f"body.steering_ratio {ratio:g} wrong (this log suggests about {ratio / gain:.3g})? "
    else:
        cause = "a steering angle scaled by a wrong steering ratio (or a steering-wheel angle)? "
    way = ("if the log and car file are right, --accept-check steering_gain goes on" if refused else
           "check them before trusting V_y, the forces and the slope")
    return (f"yaw_rate / (steady-state bicycle-model yaw rate from {steer_name}) = {gain:.3g} on steady turns "
            f"(median V_x {speed:.3g} m/s), outside {lo:.3g}..{hi:.3g} ({spread}; paper 001's (11), (14), (18) in "
            f"steady state): {steer_name} reads {1 / gain:.3g} times the road-wheel angle that explains the yaw rate: "
            f"{cause}or the car file's wheels.cornering_stiffness / body.mass off; {way}")


# ---------------------------------------------------------------------------------------------- axle order

#: Samples of the axle-order fit: tractive force F = M a_x + C_x V^2 above -:data:`AXLE_ENGINE_BRAKE` times the
#: car file's engine braking force (the driven axle alone carries F: traction, or the engine's overrun torque before
#: the service brakes), V_x above :data:`GAIN_SPEED`, |a_y| below this, m/s^2 (cornering drag and the front
#: wheels' path) ...
AXLE_ACCEL_Y = 1.0
#: ... and |delta| below this, rad.
AXLE_STEER = 0.03
#: The share of ``drivetrain.engine_brake_torque`` / R taken as the driven axle's alone (a driver who brakes
#: lightly within the engine's overrun adds the front axle's service brakes: a few light brake applications).
AXLE_ENGINE_BRAKE = 0.5
#: Excitation: the std of F over the samples at least this times M g (a_x varying by +-0.2 m/s^2, a grade of
#: +-2 %), over
#: at least :data:`AXLE_MIN_TIME` s; else no check.
AXLE_MIN_FORCE_SPREAD = 0.02
AXLE_MIN_TIME = 2.0
#: The slope over the predicted one below this: the front and rear columns are swapped (about -1 then; +1 with
#: the tyres right, 0.7..1.4 with C_x0 within 30 %).
AXLE_SWAPPED = -0.3


def axle_order(wheel_speeds, accel_x, accel_y, delta, speed, dt: float, vehicle) -> tuple[float, int]:
    """The slope of v_front / v_rear - 1 against the tractive force, over the slope the driven axle's slip predicts.

    Parameters
    ----------
    wheel_speeds : (T, 4) ndarray
        omega FL, FR, RL, RR, rad/s, smoothed.
    accel_x, accel_y, delta, speed : (T,) ndarray
        Specific forces (m/s^2), road-wheel angle (rad), V_x (m/s), smoothed alike.
    dt : float
        Sample period, s.
    vehicle : Vehicle
        Radii, mass, aero, C_x0 and the driven axle.

    Returns
    -------
    (float, int)
        About +1 for the columns in order, -1 swapped; NaN for an all-wheel-driven car, too little traction
        excitation (module notes) or an accelerometer that falls while the wheels speed up (its sign).
    """
    if vehicle.driven_axle not in ("front", "rear"):
        return math.nan, 0
    rf, rr = vehicle.wheel_radii
    vf = rf * 0.5 * (wheel_speeds[:, 0] + wheel_speeds[:, 1])
    vr = rr * 0.5 * (wheel_speeds[:, 2] + wheel_speeds[:, 3])
    force = vehicle.mass * accel_x + vehicle.aero_longitudinal * np.square(speed)
    r_driven = rf if vehicle.driven_axle == "front" else rr
    pick = (force >= -AXLE_ENGINE_BRAKE * vehicle.engine_brake_torque / r_driven) & (speed > GAIN_SPEED) & (np.abs(accel_y) < AXLE_ACCEL_Y) & (np.abs(delta) < AXLE_STEER)
    n = int(pick.sum())
    f = force[pick]
    if n * dt < AXLE_MIN_TIME or np.std(f) < AXLE_MIN_FORCE_SPREAD * vehicle.mass * 9.80665:
        return math.nan, n
    fc = f - f.mean()
    dv = np.gradient(speed, dt)
    fast = np.abs(dv) > 0.5  # as accel_x_vs_dvx: an accel_x of the wrong sign is that check's, not a swap
    if fast.sum() * dt >= 0.5 and np.dot(accel_x[fast], dv[fast]) <= 0:
        return math.nan, n
    d = vf[pick] / vr[pick] - 1.0
    slope = float(np.dot(fc, d - d.mean()) / np.dot(fc, fc))
    cf, cr = vehicle.longitudinal_stiffnesses
    expected = 1.0 / (2.0 * cf) if vehicle.driven_axle == "front" else -1.0 / (2.0 * cr)
    return slope / expected, n


def axle_message(q: float, vehicle) -> str:
    """The one line of swapped front and rear wheel-speed columns."""
    driven = vehicle.driven_axle
    return (f"wheel_speed_fl/fr look like the rear wheels and wheel_speed_rl/rr like the front ones: under traction "
            f"the {'rl/rr' if driven == 'front' else 'fl/fr'} columns turn faster, but the car file's "
            f"drivetrain.driven_axle is {driven} (slip vs tractive force {q:.2g} times the driven axle's "
            f"expected, +1 in order): are the front and rear columns swapped? (--rename "
            "wheel_speed_fl=wheel_speed_rl,wheel_speed_fr=wheel_speed_rr,wheel_speed_rl=wheel_speed_fl,"
            "wheel_speed_rr=wheel_speed_fr); or is the driven axle wrong? if neither, --accept-check axle_order "
            "goes on")
