"""The steering channel of a drive log: a steering-WHEEL angle converted by the car's ratio, and a constant offset.

Paper 001's model steers by the front road-wheel angle. A logger usually records the steering-wheel angle (the CAN
steering-angle sensor): a column ``steering_wheel_angle`` (any declared angle unit) is divided by the car file's
``body.steering_ratio``. A steering sensor zeroed off-centre adds a constant to the angle, which the EKF reads as a
slip angle on every sample (3 deg of road-wheel offset: V_y 90 % band coverage 1.9 % on the paper drive). Driving
straight (yaw rate and lateral acceleration about 0 at speed) the road wheels point straight ahead, so the median
steering angle over those samples is the offset (:func:`straight_steering_offset`).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputFormatError

#: Straight driving: |yaw rate| below this, rad/s (0.57 deg/s) ...
STRAIGHT_YAW_RATE = 0.01
#: ... |a_y| below this, m/s^2 ...
STRAIGHT_ACCEL_Y = 0.3
#: ... at V_x above this, m/s (below, a small yaw rate allows a larger steering angle).
STRAIGHT_SPEED = 8.0
#: Seconds of straight driving needed to measure the offset.
STRAIGHT_MIN_TIME = 1.0
#: A median steering angle on straight driving beyond this (rad, 0.5 deg of road-wheel angle) is refused as an offset.
#: Driving straight on a 2.5 % road crown takes about 0.1 deg (the lateral force m g 0.025 over the four tyres'
#: cornering stiffness), a side wind of 10 m/s less; the sensor and toe tolerances a few hundredths of a degree.
STEERING_OFFSET_LIMIT = math.radians(0.5)
#: Beyond this (rad, 0.05 deg of road-wheel angle, 0.75 deg at the steering wheel of a ratio-15 car) the offset is
#: printed as a warning: 0.25 deg biases V_y by 0.05 m/s on the paper drive (0.0035 m/s without), which its band does
#: not cover. The simulator's steering sensor reads 0.029 deg (its offset of 5e-4 rad) on every drive.
STEERING_OFFSET_WARN = math.radians(0.05)


def steering_from_wheel_angle(frame, vehicle, *, offset: float = 0.0, source: str = "log"):
    """``frame`` with ``steering_angle`` = ``steering_wheel_angle`` / ``vehicle.steering_ratio`` (SI columns), less
    ``offset`` (rad of road-wheel angle, the CLI's ``--steering-offset``) on every steering column.

    A log without ``steering_wheel_angle`` keeps its columns. With both columns, the road-wheel
    ``steering_angle`` is kept and must match the converted wheel angle (0.8..1.25 on turning samples), else the
    ratio is wrong.

    Raises
    ------
    InputFormatError
        A ``steering_wheel_angle`` column and no ``body.steering_ratio`` in the car file; both columns
        disagreeing with the ratio (the ratio they give is named).
    """
    if not math.isfinite(offset):
        raise InputFormatError(f"--steering-offset must be a finite angle in rad; got {offset!r}.")
    frame = _with_wheel_angle(frame, vehicle, source)
    if offset == 0.0:
        return frame
    import pandas as pd

    cols = [c for c in ("steering_angle", "steer_fl", "steer_fr") if c in frame.columns]
    return frame.assign(**{c: pd.to_numeric(frame[c], errors="coerce") - offset for c in cols})


def _with_wheel_angle(frame, vehicle, source):
    if "steering_wheel_angle" not in frame.columns:
        return frame
    ratio = getattr(vehicle, "steering_ratio", None)
    if ratio is None:
        raise InputFormatError(f"{source}: the log has a steering_wheel_angle column but the car file has no "
                               "body.steering_ratio (steering-wheel angle / road-wheel angle, e.g. 15): add your car's "
                               "to its [body] table (--vehicle car.toml), or log the road-wheel angle as "
                               "steering_angle.")
    import pandas as pd

    wheel = pd.to_numeric(frame["steering_wheel_angle"], errors="coerce") / ratio
    if "steering_angle" not in frame.columns:
        return frame.assign(steering_angle=wheel)
    road = pd.to_numeric(frame["steering_angle"], errors="coerce").to_numpy(float)
    w = wheel.to_numpy(float)
    turning = np.isfinite(road) & np.isfinite(w) & (np.abs(road) > 0.01)
    if turning.sum() >= 10:
        k = float(np.dot(w[turning], road[turning]) / np.dot(road[turning], road[turning]))
        if not 0.8 <= k <= 1.25:
            raise InputFormatError(f"{source}: steering_wheel_angle / body.steering_ratio ({ratio:g}) is {k:.3g} times "
                                   f"steering_angle: the two columns give a steering ratio of {k * ratio:.3g}; check "
                                   "body.steering_ratio and the angle units, or drop one of the columns.")
    return frame


def straight_steering_offset(steer, yaw_rate, accel_y, speed, dt) -> tuple[float, int]:
    """The median steering angle while driving straight: the steering sensor's constant offset, rad.

    Parameters
    ----------
    steer, yaw_rate, accel_y, speed : (T,) ndarray
        Road-wheel angle (rad), yaw rate (rad/s), lateral acceleration (m/s^2), V_x (m/s), smoothed alike.
    dt : float
        Sample period, s.

    Returns
    -------
    (float, int)
        The median of ``steer`` over the straight samples (|yaw rate| < :data:`STRAIGHT_YAW_RATE`, |a_y| <
        :data:`STRAIGHT_ACCEL_Y`, V_x > :data:`STRAIGHT_SPEED`) and their number; NaN when they last less than
        :data:`STRAIGHT_MIN_TIME`.

    Notes
    -----
    Steady-state bicycle model (Gillespie 1992, ch. 6): r = V delta / (L + K V^2), so r = 0 needs delta = 0 at
    any speed; the tyres' and the road's side forces when driving straight (crown, wind, conicity) take a few
    hundredths to a tenth of a degree. ASSUMPTION: the log has at least 1 s of straight driving at speed (or of
    the zero crossings of a slalom, where the yaw lag's errors of both signs cancel in the median).
    """
    straight = (np.abs(yaw_rate) < STRAIGHT_YAW_RATE) & (np.abs(accel_y) < STRAIGHT_ACCEL_Y) & (speed > STRAIGHT_SPEED)
    n = int(straight.sum())
    if n * dt < STRAIGHT_MIN_TIME:
        return math.nan, n
    return float(np.median(steer[straight])), n


def offset_problem(offset: float, n: int, dt: float, steer_name: str, ratio: float | None) -> str:
    """The refused steering offset's message: the value, where it was measured and the two ways on."""
    wheel = (f" ({math.degrees(offset * ratio):+.1f} deg of steering-wheel angle at body.steering_ratio {ratio:g})"
             if ratio else "")
    return (f"{steer_name} reads {math.degrees(offset):+.2f} deg ({offset:+.4f} rad){wheel} while the car drives "
            f"straight ({n * dt:.3g} s with |yaw rate| < {STRAIGHT_YAW_RATE:g} rad/s, |a_y| < {STRAIGHT_ACCEL_Y:g} "
            f"m/s^2, V_x > {STRAIGHT_SPEED:g} m/s), more than the {math.degrees(STEERING_OFFSET_LIMIT):g} deg a road "
            "crown or side wind explains: a steering sensor zeroed off-centre; subtract the offset "
            f"(--steering-offset {offset:.4f}, rad of road-wheel angle) or correct the column")


def offset_warning(offset: float, n: int, dt: float, steer_name: str, ratio: float | None) -> str:
    """The warning of an offset between :data:`STEERING_OFFSET_WARN` and :data:`STEERING_OFFSET_LIMIT` ("" below)."""
    if not abs(offset) > STEERING_OFFSET_WARN:
        return ""
    wheel = f" ({math.degrees(offset * ratio):+.2f} deg at the steering wheel)" if ratio else ""
    return (f"{steer_name} reads {math.degrees(offset):+.3f} deg ({offset:+.5f} rad){wheel} while the car drives "
            f"straight ({n * dt:.3g} s): a steering sensor offset biases V_y (about 0.05 m/s per 0.25 deg at 25 m/s) "
            f"and its band does not cover it; unless the road's camber needed it, subtract it: --steering-offset "
            f"{offset:.5f}")


def bicycle_yaw_gain(vehicle, speed: float) -> float:
    """The car file's steady-state yaw gain over the kinematic one, 1 / (1 + K V^2 / L), at ``speed`` (m/s).

    K = (m / L) (l_r / C_f - l_f / C_r) is the understeer gradient (rad per m/s^2) of the linear bicycle model with
    each axle's cornering stiffness C = 2 C_y0 (Gillespie 1992, ch. 6, eq. 6-11); NaN for an oversteering car past
    its critical speed.
    """
    cf, cr = (2.0 * c for c in vehicle.cornering_stiffnesses)
    lf, lr = vehicle.cg_to_front_axle, vehicle.cg_to_rear_axle
    L = lf + lr
    K = vehicle.mass / L * (lr / cf - lf / cr)
    d = 1.0 + K * speed * speed / L
    return 1.0 / d if d > 0 else math.nan


def wheel_angle_hint(steer_name: str, times: float, ratio_seen: float, vehicle) -> str:
    """What to do with a steering angle ``times`` the road-wheel angle: the steering-wheel column and the ratio, with
    the ratio the log suggests as a check of the user's value, not as the value to use."""
    ratio = getattr(vehicle, "steering_ratio", None)
    seen = f"about {ratio_seen:.3g}" if math.isfinite(ratio_seen) else "not measurable here"
    if ratio is not None:
        where = f"the car file's body.steering_ratio is {ratio:g}: is this column already the road-wheel angle?"
    else:
        where = ("rename the column to steering_wheel_angle (its angle unit declared as usual) and set "
                 "body.steering_ratio in the car file to your car's ratio (its data sheet; 12-20 for cars)")
    return (f"{steer_name} is {times:.3g} times the road-wheel angle that explains the yaw rate: a steering-WHEEL "
            f"angle? {where}; with the car file's tyres this log suggests a ratio of {seen}, a check of your value, "
            "not a substitute for it (understeer and compliance are not known well enough); or degrees "
            f"('{steer_name} [deg]')")
