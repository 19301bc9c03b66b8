"""A drive log that stops: the moving stretches estimated one by one (paper 001 holds only while moving).

The planar model's slips (eq. (18)) divide by the wheel speeds and are meaningless near standstill, so
:func:`estimate_slope` refuses a log whose rear-wheel speed falls below 2 m/s. :func:`estimate_slope_split` cuts such
a log (a drive that starts, stops and waits at lights) into stretches where the rear-wheel speed stays at or above
2 m/s, runs :func:`estimate_slope` on each stretch of at least :data:`MIN_STRETCH_DURATION` as on a log of its own
(filters, observer, force fit and sensor calibration started afresh) and keeps every row of the log, the rows left
out empty. :func:`drive_window` keeps the rows of a time window.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..._validation import true_runs
from ...errors import InputError
from ._estimate import _MIN_SPEED, estimate_slope, rear_wheel_speed
from ._params import default_vehicle
from ._simulate import DriveLog

__all__ = ["MIN_STRETCH_DURATION", "SplitSlopeEstimate", "drive_window", "estimate_slope_split", "moving_stretches"]

#: Shortest moving stretch (s) that :func:`estimate_slope_split` estimates: the filters' start-up transient lasts
#: about 1 s (docs/vehicle-slope.md, "Logs with stops"), so a shorter stretch would be mostly transient.
MIN_STRETCH_DURATION = 2.0

#: The per-sample arrays of :class:`SlopeEstimate` that :class:`SplitSlopeEstimate` carries (NaN where left out).
_ARRAYS = ("vx", "vy", "yaw_rate", "vx_std", "vy_std", "yaw_rate_std", "slope", "slope_std", "fx", "fy", "fx_std",
           "fy_std", "resisting_force", "resisting_force_std")


def _sub_log(log: DriveLog, i0: int, i1: int) -> DriveLog:
    """The rows i0:i1 of ``log`` as a DriveLog of their own (the same values, as if read from their own file)."""
    steer = None if log.wheel_steering is None else log.wheel_steering[i0:i1]
    return DriveLog(time=log.time[i0:i1], steering_angle=log.steering_angle[i0:i1],
                    wheel_speeds=log.wheel_speeds[i0:i1], yaw_rate=log.yaw_rate[i0:i1], accel_x=log.accel_x[i0:i1],
                    accel_y=log.accel_y[i0:i1], wheel_steering=steer)


def drive_window(log: DriveLog, start: float | None = None, end: float | None = None) -> DriveLog:
    """The rows of ``log`` with ``start <= time <= end`` (s, the log's own time; None: from the first or to the last).

    The log itself when both are None. Raises InputError (one line) for a window that is empty, inverted, not
    finite, or holds fewer than 3 samples.
    """
    if start is None and end is None:
        return log
    t = log.time
    lo = -math.inf if start is None else start
    hi = math.inf if end is None else end
    if math.isnan(lo) or math.isnan(hi) or not lo < hi:
        raise InputError(f"the window must have start < end (s, the log's own time); got start {start!r}, end {end!r}.")
    keep = np.flatnonzero((t >= lo) & (t <= hi))
    if keep.size < 3:
        raise InputError(f"the window {lo:g} to {hi:g} s holds {keep.size} sample(s) of the log (it runs from "
                         f"{t[0]:g} to {t[-1]:g} s): give --start/--end inside the log's time.")
    return _sub_log(log, int(keep[0]), int(keep[-1]) + 1)


def moving_stretches(log: DriveLog, vehicle=None, *, min_duration: float = MIN_STRETCH_DURATION):
    """((start, stop) row ranges of the stretches kept, (start, stop) of the moving ones too short): the runs of rows
    whose mean rear-wheel speed R (omega_rl + omega_rr) / 2 is at least 2 m/s (:func:`estimate_slope`'s limit), kept
    when they last at least ``min_duration`` seconds (rows x dt) and 3 samples."""
    vehicle = default_vehicle() if vehicle is None else vehicle
    if not (isinstance(min_duration, (int, float)) and math.isfinite(min_duration) and min_duration >= 0):
        raise InputError(f"min_duration must be a finite number of seconds >= 0; got {min_duration!r}.")
    runs = [(a, b + 1) for a, b in true_runs(rear_wheel_speed(log, vehicle) >= _MIN_SPEED)]  # stop exclusive
    dt = log.dt
    long_enough = [(a, b) for a, b in runs if b - a >= 3 and (b - a) * dt >= min_duration * (1 - 1e-9)]
    return long_enough, [r for r in runs if r not in long_enough]


@dataclass(frozen=True, eq=False)
class SplitSlopeEstimate:
    """:func:`estimate_slope` run on each moving stretch of a log that stops (:func:`estimate_slope_split`).

    The per-sample arrays of :class:`SlopeEstimate` (``time``, ``vx`` ... ``resisting_force_std``) cover every row
    of the log, NaN where it was left out; ``stretch`` (T,) numbers the stretch of each row (1, 2, ...; 0 = left
    out) and ``note`` (T,) says why a row was left out ("" where estimated).

    Attributes
    ----------
    estimates : tuple of SlopeEstimate
        One per stretch, each exactly the estimate of that stretch as a log of its own.
    stretches : tuple of (int, int)
        The row ranges [start, stop) of the stretches.
    method : str
        The estimator (``"cascade"`` or ``"joint"``).
    min_duration : float
        The shortest stretch estimated, s.
    dt : float
        The log's sampling step, s.
    """

    time: np.ndarray
    stretch: np.ndarray
    note: np.ndarray
    estimates: tuple
    stretches: tuple
    method: str
    min_duration: float
    dt: float

    def __getattr__(self, name):
        if name in _ARRAYS:  # the stretches' arrays laid on the log's rows, NaN between them
            first = getattr(self.estimates[0], name)
            out = np.full((self.time.size,) + first.shape[1:], np.nan)
            for (a, b), est in zip(self.stretches, self.estimates):
                out[a:b] = getattr(est, name)
            return out
        raise AttributeError(name)

    @property
    def left_out(self) -> tuple:
        """(seconds below 2 m/s, seconds in moving stretches too short), rows x dt."""
        short = np.char.startswith(self.note.astype(str), "moving")
        return float(np.sum((self.stretch == 0) & ~short) * self.dt), float(np.sum(short) * self.dt)

    def summary(self) -> str:
        """One line: how many stretches were estimated, and how much of the log was left out and why."""
        slow, short = self.left_out
        total = self.time.size * self.dt
        return (f"log split at its stops (rear-wheel speed below {_MIN_SPEED:g} m/s): {len(self.estimates)} "
                f"stretch(es) estimated, each on its own (the filters restart: about 1 s of start-up transient each); "
                f"{slow + short:.1f} s of the {total:.1f} s left out ({slow:.1f} s below {_MIN_SPEED:g} m/s, "
                f"{short:.1f} s in moving stretches under {self.min_duration:g} s): their rows have empty states "
                "(columns stretch, note)")

    def warnings(self, **kwargs) -> list:
        """:meth:`summary`, then each stretch's :meth:`SlopeEstimate.warnings` (same keywords), prefixed with it."""
        out = [self.summary()]
        for k, ((a, b), est) in enumerate(zip(self.stretches, self.estimates), start=1):
            out += [f"stretch {k} ({self.time[a]:.6g} to {self.time[b - 1]:.6g} s): {w}" for w in est.warnings(**kwargs)]
        return out

    def to_frame(self):
        """Every row of the log: the columns of :meth:`SlopeEstimate.to_frame` (empty where left out), then
        ``stretch`` and ``note`` (docs/vehicle-slope.md, Logs with stops)."""
        import pandas as pd

        parts = []
        for (a, b), est in zip(self.stretches, self.estimates):
            f = est.to_frame()
            f.index = pd.RangeIndex(a, b)
            parts.append(f)
        frame = pd.concat(parts).reindex(pd.RangeIndex(self.time.size))
        frame["time"] = self.time
        for col, dtype in (("vx_measured_source", "Int8"), ("slope_plausible", "boolean")):
            if col in frame.columns:
                frame[col] = frame[col].astype(dtype)
        frame["stretch"] = self.stretch
        frame["note"] = self.note
        return frame


def estimate_slope_split(log: DriveLog, vehicle=None, *, min_duration: float = MIN_STRETCH_DURATION,
                         **kwargs) -> SplitSlopeEstimate:
    """:func:`estimate_slope` on each moving stretch of a log that stops (waits at lights, starts and ends at rest).

    Parameters
    ----------
    log : DriveLog
        The drive; its rows whose rear-wheel speed R (omega_rl + omega_rr) / 2 is below 2 m/s are left out (paper
        001's slips, eq. (18), are not valid near standstill).
    vehicle : Vehicle, optional
        As :func:`estimate_slope` (default car).
    min_duration : float
        Shortest moving stretch estimated, s (:data:`MIN_STRETCH_DURATION`, 2 s); shorter ones are left out.
    **kwargs
        The settings of :func:`estimate_slope` (method, poles, uncertainty, ...), the same for every stretch.

    Returns
    -------
    SplitSlopeEstimate
        Each stretch's estimate is bit for bit :func:`estimate_slope` of that stretch as a log of its own: the EKF
        and the observer start from their initial state (the first speed reading, V_y 0, the first gyro reading;
        the observer's slope 0) and the force fit and the sensor calibration use that stretch alone (Assumption:
        a stretch knows nothing of the others; docs/vehicle-slope.md, Logs with stops).

    Raises
    ------
    InputError
        When no moving stretch lasts ``min_duration``, and as :func:`estimate_slope`.
    """
    if not isinstance(log, DriveLog):
        raise InputError(f"log must be a DriveLog; got {type(log).__name__}.")
    vehicle = default_vehicle() if vehicle is None else vehicle
    kept, short = moving_stretches(log, vehicle, min_duration=min_duration)
    if not kept:
        raise InputError(f"no stretch of the log keeps the rear-wheel speed at or above {_MIN_SPEED:g} m/s for "
                         f"{min_duration:g} s ({len(short)} shorter one(s)): nothing to estimate.")
    stretch = np.zeros(log.time.size, dtype=np.int64)
    note = np.full(log.time.size, f"rear-wheel speed below {_MIN_SPEED:g} m/s", dtype=object)
    for a, b in short:
        note[a:b] = f"moving stretch of {(b - a) * log.dt:.3g} s, under {min_duration:g} s"
    estimates = []
    for k, (a, b) in enumerate(kept, start=1):
        estimates.append(estimate_slope(_sub_log(log, a, b), vehicle, **kwargs))
        stretch[a:b] = k
        note[a:b] = ""
    return SplitSlopeEstimate(time=log.time, stretch=stretch, note=note, estimates=tuple(estimates),
                              stretches=tuple(kept), method=estimates[0].method, min_duration=float(min_duration),
                              dt=log.dt)

