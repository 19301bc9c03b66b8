"""Simulator of the planar 4-wheel vehicle (paper 001 model) producing truth and sensor logs.

A physics simulator (RK4 at the log rate) lives in the domain folder by design; it holds no
estimation loop. Sensor models (ABS tone-wheel encoders, steering encoder, gyro, accelerometers)
are applied to the truth afterwards with a seedable generator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..._jit import njit
from ..._validation import as_float_array, require_positive, time_resolution, true_runs
from ...errors import InputError, InputFormatError, ShapeError
from ._model import body_derivative, body_sums, normal_loads, tyre_kinematics_forces
from ._params import P_CXA, P_CYA, P_G, P_IW, P_LF, P_LR, P_MASS, P_R_F, P_R_R, WHEELS, Vehicle, default_vehicle

__all__ = ["DriveScenario", "drive_scenario", "SCENARIOS", "SensorSpec", "DriveLog", "DriveTruth",
           "PlanarSimulation", "simulate_drive", "ackermann_angles", "LOG_COLUMNS", "WHEEL_STEERING_COLUMNS",
           "missed_scenario_events"]

#: Sensor channels of a drive log, in file order (see docs/vehicle-slope.md).
LOG_COLUMNS = ("time", "steering_angle", "wheel_speed_fl", "wheel_speed_fr", "wheel_speed_rl", "wheel_speed_rr",
               "yaw_rate", "accel_x", "accel_y")
#: Optional channels: the measured front-left and front-right road-wheel angles, rad (used by the model when present).
WHEEL_STEERING_COLUMNS = ("steer_fl", "steer_fr")
_LOG_UNITS = {"time": "s", "steering_angle": "rad", "wheel_speed": "rad/s", "yaw_rate": "rad/s",
              "accel_x": "m/s^2", "accel_y": "m/s^2", "steer_fl": "rad", "steer_fr": "rad"}


# ----------------------------------------------------------------------------------------------- scenarios

@dataclass(frozen=True, eq=False)
class DriveScenario:
    """A drive to simulate: driver inputs over time and road attributes along the route.

    Parameters
    ----------
    name : str
        Label.
    dt : float
        Step of the simulation and of the log, s.
    target_speed : (T,) array_like
        Speed the driver's PI speed controller tracks, m/s (its derivative is fed forward).
    steering : (T,) array_like
        Front road-wheel steering angle, rad.
    road_distance : (N,) array_like
        Uniformly spaced stations along the route, m, starting at 0.
    road_slope : (N,) array_like
        Road grade angle theta_r at each station, rad (positive uphill).
    road_friction : (N, 2) array_like
        Available adhesion under the left and right wheels at each station (each wheel reads it at
        its own position, so the front wheels meet a patch before the rear ones).
    initial_speed : float
        V_x at t = 0, m/s (> 1 m/s: the model is not meant for standstill).
    """

    name: str
    dt: float
    target_speed: np.ndarray
    steering: np.ndarray
    road_distance: np.ndarray
    road_slope: np.ndarray
    road_friction: np.ndarray
    initial_speed: float

    def __post_init__(self):
        dt = require_positive("dt", self.dt)
        v = as_float_array("target_speed", self.target_speed, ndim=1, allow_nan=False)
        d = as_float_array("steering", self.steering, ndim=1, allow_nan=False)
        if d.shape != v.shape:
            raise ShapeError(f"steering must have one value per step like target_speed {v.shape}; got {d.shape}.")
        s = as_float_array("road_distance", self.road_distance, ndim=1, allow_nan=False)
        th = as_float_array("road_slope", self.road_slope, ndim=1, allow_nan=False)
        mu = as_float_array("road_friction", self.road_friction, ndim=2, allow_nan=False)
        if s.shape[0] < 2 or th.shape != s.shape or mu.shape != (s.shape[0], 2):
            raise ShapeError(f"road_distance (N,), road_slope (N,) and road_friction (N, 2) must agree with N >= 2; "
                             f"got {s.shape}, {th.shape}, {mu.shape}.")
        ds = np.diff(s)
        if s[0] != 0.0 or np.any(ds <= 0) or np.ptp(ds) > 1e-9 * max(1.0, ds[0]):
            raise InputError("road_distance must start at 0 and be uniformly spaced and increasing.")
        if np.any(np.abs(th) >= np.pi / 4):
            raise InputError(f"road_slope must be within +-45 degrees; got max {np.degrees(np.abs(th).max()):.1f} deg.")
        if np.any(mu <= 0):
            raise InputError(f"road_friction must be > 0; got min {mu.min():g}.")
        v0 = require_positive("initial_speed", self.initial_speed)
        if v0 < 1.0 or np.any(v < 1.0):
            raise InputError("initial_speed and target_speed must be >= 1 m/s (the planar model of paper 001 "
                             "is not valid at standstill).")
        for k, val in (("dt", dt), ("target_speed", v), ("steering", d), ("road_distance", s), ("road_slope", th),
                       ("road_friction", np.ascontiguousarray(mu)), ("initial_speed", v0)):
            object.__setattr__(self, k, val)

    @property
    def time(self) -> np.ndarray:
        """Sample times, s, shape (T,)."""
        return np.arange(self.target_speed.shape[0]) * self.dt


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _ramps(s, points):
    """Piecewise-constant levels joined by smooth (C1) ramps: points = [(s_start, s_end, new_level), ...]."""
    out = np.zeros_like(s)
    level = 0.0
    for s0, s1, new in points:
        out = out + (new - level) * _smoothstep((s - s0) / (s1 - s0))
        level = new
    return out


def _speed_profile(t, v0, segments):
    """Target speed: v0 then linear accelerations [(t_start, t_end, v_end), ...]."""
    v = np.full_like(t, v0)
    cur = v0
    for t0, t1, v1 in segments:
        ramp = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
        v = np.where(t >= t0, cur + (v1 - cur) * ramp, v)
        cur = v1
    return v


def _paper(dt, duration):
    t = np.arange(int(round((duration or 40.0) / dt))) * dt
    env = _smoothstep((t - 3.0) / 2.0) * _smoothstep(((duration or 40.0) - 2.0 - t) / 2.0)
    steering = 0.02 * np.sin(2 * np.pi * 0.25 * (t - 3.0)) * env
    s = np.arange(0.0, 2000.0, 0.5)
    slope = np.radians(_ramps(s, [(150, 300, 4.0), (500, 700, -3.0), (850, 950, 0.0)]))
    mu = np.full((s.size, 2), 0.8)
    return DriveScenario("paper", dt, np.full(t.size, 25.0), steering, s, slope, mu, 25.0)


def _hill(dt, duration):
    t = np.arange(int(round((duration or 40.0) / dt))) * dt
    v = _speed_profile(t, 12.0, [(3.0, 13.0, 27.0), (22.0, 27.0, 12.0)])
    s = np.arange(0.0, 2000.0, 0.5)
    grade = np.degrees(np.arctan(0.06))
    slope = np.radians(_ramps(s, [(80, 180, grade), (420, 560, -grade), (760, 860, 0.0)]))
    mu = np.full((s.size, 2), 0.9)
    return DriveScenario("hill", dt, v, np.zeros(t.size), s, slope, mu, 12.0)


def _low_mu(dt, duration):
    t = np.arange(int(round((duration or 30.0) / dt))) * dt
    v = _speed_profile(t, 20.0, [(9.0, 15.0, 25.0)])
    env = _smoothstep((t - 2.0) / 2.0)
    steering = 0.01 * np.sin(2 * np.pi * 0.2 * (t - 2.0)) * env
    s = np.arange(0.0, 2000.0, 0.5)
    slope = np.radians(_ramps(s, [(50, 150, np.degrees(np.arctan(0.02)))]))
    mu = np.full((s.size, 2), 0.9)
    patch = (s >= 200.0) & (s < 320.0)
    mu[patch] = 0.3
    return DriveScenario("low-mu", dt, v, steering, s, slope, mu, 20.0)


#: Built-in scenarios: name -> one-line description.
SCENARIOS = {
    "paper": "paper 001 V.A: 25 m/s, sine steering 0.02 rad at 0.25 Hz, mu = 0.8, grade 0 -> +4 deg -> -3 deg -> 0 (40 s)",
    "hill": "straight: accelerate 12 -> 27 m/s up a 6 % hill, brake 27 -> 12 m/s down a 6 % hill (40 s)",
    "low-mu": "20 m/s on a 2 % grade, mild sine steering, mu 0.9 with a 120 m mu = 0.3 patch crossed while "
              "accelerating to 25 m/s (30 s)",
}
_BUILDERS = {"paper": _paper, "hill": _hill, "low-mu": _low_mu}


def missed_scenario_events(name: str, simulation: PlanarSimulation) -> tuple[str, ...]:
    """The events of the built-in scenario ``name`` at its default length that a (shortened) simulated drive leaves
    out or cuts.

    The scenarios place their events for their default length (:data:`SCENARIOS`): the steering and the speed
    changes in time, the grade ramps and the friction patches along the road. An event is left out when the drive
    ends before it starts (in time, or in the distance travelled for a road event), cut when it ends inside it; the
    steering is named when the drive's peak steering is under 90 % of the full scenario's (``paper`` fades its
    steering in from 3 s and out over the last 2 s of the drive: none at all in a drive of 7 s or less). Road
    events beyond the full drive's distance (the speed target integrated) are not events of the scenario.

    Parameters
    ----------
    name : {"paper", "hill", "low-mu"}
        The scenario the drive was simulated from.
    simulation : PlanarSimulation
        The drive (:func:`simulate_drive`).

    Returns
    -------
    tuple of str
        One phrase per event left out or cut (empty when the drive holds them all).
    """
    full = drive_scenario(name, dt=simulation.log.dt)
    end_t = float(simulation.log.time[-1] - simulation.log.time[0]) + simulation.log.dt
    end_s = float(simulation.truth.distance[-1])
    full_s = float(np.sum(full.target_speed) * full.dt)
    out = []
    peak = float(np.max(np.abs(full.steering)))
    if peak > 0:
        reached = float(np.max(np.abs(simulation.truth.steering_angle))) / peak
        start = full.time[int(np.argmax(np.abs(full.steering) > 0))]
        if reached < 0.9:
            out.append(f"the steering ({peak:.3g} rad from {start:.3g} s; "
                       + ("none in this drive)" if reached < 0.01 else f"{100 * reached:.0f} % of it in this drive)"))

    def cut(first, last, end, unit):  # None: left out, "": in the drive (to 2 % of its span), else the note
        return None if first >= end else "" if last <= end + 0.02 * (last - first) else f" (cut at {end:.4g} {unit})"

    v, t = full.target_speed, full.time
    for i, j in true_runs(np.abs(np.gradient(v)) > 1e-9):
        note = cut(t[i], t[j], end_t, "s")
        if note != "":
            v0, v1 = v[max(i - 1, 0)], v[min(j + 1, v.size - 1)]
            out.append(f"the {'acceleration' if v1 > v0 else 'braking'} {v0:.3g} -> {v1:.3g} m/s at {t[i]:.3g}-"
                       f"{t[j]:.3g} s{note or ''}")
    d, slope = full.road_distance, full.road_slope
    for i, j in true_runs(np.abs(np.gradient(slope)) > 1e-12):
        note = cut(d[i], d[j], end_s, "m")
        if note != "" and d[i] < full_s:
            to = slope[min(j + 1, d.size - 1)]
            level = f"{math.degrees(to):+.3g} deg ({100 * math.tan(to):+.3g} %)" if to else "level"
            out.append(f"the grade ramp to {level} at {d[i]:.4g}-{d[j]:.4g} m{note or ''}")
    mu = full.road_friction
    for i, j in true_runs(np.any(mu != mu[0], axis=1)):
        note = cut(d[i], d[j], end_s, "m")
        if note != "" and d[i] < full_s:
            out.append(f"the mu {float(np.min(mu[i:j + 1])):.2g} patch at {d[i]:.4g}-{d[j] + d[1]:.4g} m{note or ''}")
    return tuple(out)


def drive_scenario(name: str, *, dt: float = 1e-3, duration: float | None = None) -> DriveScenario:
    """One of the built-in drive scenarios (see :data:`SCENARIOS`).

    Parameters
    ----------
    name : {"paper", "hill", "low-mu"}
        Scenario name.
    dt : float
        Simulation and log step, s (default 1e-3: 1 kHz).
    duration : float, optional
        Length, s (default 40 s, 30 s for "low-mu"); the road is defined over 2 km.

    Raises
    ------
    InputError
        For an unknown name or a non-positive dt/duration.
    """
    if name not in _BUILDERS:
        raise InputError(f"unknown scenario {name!r}; choose one of {sorted(_BUILDERS)}.")
    require_positive("dt", dt)
    if duration is not None:
        require_positive("duration", duration)
        if duration < 10 * dt:
            raise InputError(f"duration must be at least 10 steps ({10 * dt:g} s); got {duration!r}.")
    return _BUILDERS[name](float(dt), None if duration is None else float(duration))


# ----------------------------------------------------------------------------------------------- sensors

@dataclass(frozen=True)
class SensorSpec:
    """Sensor models of the simulated log (defaults: a production ESP/ABS sensor set after calibration).

    Parameters
    ----------
    encoder_teeth : int
        Teeth of each ABS tone wheel (48 is common).
    encoder_clock : float
        Clock that time-stamps the tooth edges, Hz (1 MHz).
    encoder_edges_averaged : int
        The wheel speed is the angle of this many tooth pitches over the time they took (period
        measurement, held until the next edge).
    encoder_jitter : float
        Std of the edge time-stamp jitter (tooth pitch errors, detection), s.
    steering_noise, steering_offset : float
        Road-wheel steering angle noise std and offset, rad; ``steering_resolution`` its quantisation step, rad.
    yaw_rate_noise, yaw_rate_offset : float
        Gyro noise std and bias, rad/s.
    accel_noise, accel_offset : float
        Accelerometer noise std and bias (both axes), m/s^2.
    """

    encoder_teeth: int = 48
    encoder_clock: float = 1e6
    encoder_edges_averaged: int = 4
    encoder_jitter: float = 1e-6
    steering_noise: float = 2e-4
    steering_offset: float = 5e-4
    steering_resolution: float = 1e-4
    yaw_rate_noise: float = 2e-3
    yaw_rate_offset: float = 5e-4
    accel_noise: float = 0.05
    accel_offset: float = 0.02

    def __post_init__(self):
        for k in ("encoder_teeth", "encoder_edges_averaged"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise InputError(f"{k} must be a positive integer; got {v!r}.")
        require_positive("encoder_clock", self.encoder_clock)
        for k in ("encoder_jitter", "steering_noise", "steering_resolution", "yaw_rate_noise", "accel_noise"):
            require_positive(k, getattr(self, k), strict=False)
        for k in ("steering_offset", "yaw_rate_offset", "accel_offset"):
            if not math.isfinite(float(getattr(self, k))):
                raise InputError(f"{k} must be finite; got {getattr(self, k)!r}.")

    @classmethod
    def ideal(cls) -> "SensorSpec":
        """Noise-free, offset-free sensors (encoders still quantise, with a very fast clock)."""
        return cls(encoder_clock=1e12, encoder_jitter=0.0, steering_noise=0.0, steering_offset=0.0,
                   steering_resolution=0.0, yaw_rate_noise=0.0, yaw_rate_offset=0.0, accel_noise=0.0,
                   accel_offset=0.0)


def _encoder_speeds(time, angle, spec: SensorSpec, rng):
    """ABS wheel speed by period measurement on a tone wheel: (T,) rad/s from the wheel angle (T,)."""
    pitch = 2.0 * np.pi / spec.encoder_teeth
    phi = np.maximum.accumulate(angle)  # an ABS encoder does not see the direction of rotation
    first = int(np.floor(phi[0] / pitch))
    last = int(np.floor(phi[-1] / pitch))
    n_avg = spec.encoder_edges_averaged
    if last - first <= n_avg:
        raise InputError("the simulated drive is too short or too slow for the wheel-speed encoders: fewer than "
                         f"{n_avg + 1} tooth edges; lengthen the scenario.")
    edge_angle = np.arange(first + 1, last + 1) * pitch
    k = np.searchsorted(phi, edge_angle, side="left")
    k = np.clip(k, 1, phi.size - 1)
    dphi = phi[k] - phi[k - 1]
    frac = np.where(dphi > 0, (edge_angle - phi[k - 1]) / np.where(dphi > 0, dphi, 1.0), 1.0)
    dt = time[1] - time[0]
    t_edge = time[k - 1] + dt * frac
    if spec.encoder_jitter > 0:
        t_edge = t_edge + rng.normal(0.0, spec.encoder_jitter, t_edge.size)
    t_edge = np.floor(t_edge * spec.encoder_clock) / spec.encoder_clock
    t_edge = np.maximum.accumulate(t_edge)
    idx = np.searchsorted(t_edge, time, side="right") - 1
    valid = idx >= n_avg
    i = np.where(valid, idx, n_avg)
    span = t_edge[i] - t_edge[i - n_avg]
    speed = n_avg * pitch / np.where(span > 0, span, np.inf)
    # before the first n_avg edges the ECU holds its first valid reading
    speed[~valid] = speed[int(np.argmax(valid))]
    return speed


def _steering_sensor(angle, spec: SensorSpec, rng):
    """Measured road-wheel angle: offset, white noise and quantisation of ``spec`` applied to ``angle`` (T,)."""
    steer = angle + spec.steering_offset + rng.normal(0.0, 1.0, angle.size) * spec.steering_noise
    if spec.steering_resolution > 0:
        steer = np.round(steer / spec.steering_resolution) * spec.steering_resolution
    return steer


# ----------------------------------------------------------------------------------------------- results

@dataclass(frozen=True, eq=False)
class DriveLog:
    """Sensor log of a drive: what the estimators read (paper 001: ABS, steering encoder, IMU).

    Parameters
    ----------
    time : (T,) array_like
        Sample times, s, uniformly spaced.
    steering_angle : (T,) array_like
        Front road-wheel steering angle, rad (steering-wheel angle / steering ratio).
    wheel_speeds : (T, 4) array_like
        Wheel spin rates FL, FR, RL, RR, rad/s (>= 0).
    yaw_rate : (T,) array_like
        Gyro yaw rate, rad/s.
    accel_x, accel_y : (T,) array_like
        Body-fixed accelerometer readings (specific force, gravity included), m/s^2.
    wheel_steering : (T, 2) array_like, optional
        Measured front-left and front-right road-wheel angles, rad (log columns ``steer_fl``,
        ``steer_fr``). When given, the model steers each front wheel by its own angle (eq. (12)-(14),
        (18)); ``steering_angle`` is then only used by the log checks. None: both wheels steer by
        ``steering_angle``.

    Raises
    ------
    ShapeError, InputError
        On inconsistent lengths, non-finite values or a non-uniform time base.
    """

    time: np.ndarray
    steering_angle: np.ndarray
    wheel_speeds: np.ndarray
    yaw_rate: np.ndarray
    accel_x: np.ndarray
    accel_y: np.ndarray
    wheel_steering: np.ndarray | None = None

    def __post_init__(self):
        t = as_float_array("time", self.time, ndim=1, allow_nan=False)
        if t.size < 3:
            raise ShapeError(f"a drive log needs at least 3 samples; got {t.size}.")
        d = np.diff(t)
        if np.any(d <= 0) or np.ptp(d) > 1e-6 * d.mean() + 1e-9 + time_resolution(t):
            raise InputError("time must be strictly increasing and uniformly sampled (the EKF of eq. (20) uses a "
                             f"fixed step); got steps from {d.min():g} to {d.max():g} s. Resample the log first.")
        object.__setattr__(self, "time", t)
        for k in ("steering_angle", "yaw_rate", "accel_x", "accel_y"):
            a = as_float_array(k, getattr(self, k), ndim=1, allow_nan=False)
            if a.shape != t.shape:
                raise ShapeError(f"{k} must have one value per sample ({t.size}); got shape {a.shape}.")
            object.__setattr__(self, k, a)
        w = as_float_array("wheel_speeds", self.wheel_speeds, ndim=2, allow_nan=False)
        if w.shape != (t.size, 4):
            raise ShapeError(f"wheel_speeds must have shape (T, 4) = ({t.size}, 4) (FL, FR, RL, RR); got {w.shape}.")
        if np.any(w < 0):
            raise InputError(f"wheel_speeds must be >= 0 rad/s (ABS sensors are unsigned); got min {w.min():g}.")
        object.__setattr__(self, "wheel_speeds", np.ascontiguousarray(w))
        if self.wheel_steering is not None:
            d = as_float_array("wheel_steering", self.wheel_steering, ndim=2, allow_nan=False)
            if d.shape != (t.size, 2):
                raise ShapeError(f"wheel_steering must have shape (T, 2) = ({t.size}, 2) (steer_fl, steer_fr); "
                                 f"got {d.shape}.")
            object.__setattr__(self, "wheel_steering", np.ascontiguousarray(d))

    @property
    def front_steering(self) -> np.ndarray:
        """Road-wheel angles (T, 2) of the front-left and front-right wheels, rad, as the model uses them."""
        if self.wheel_steering is not None:
            return self.wheel_steering
        return np.ascontiguousarray(np.column_stack([self.steering_angle, self.steering_angle]))

    @property
    def dt(self) -> float:
        """Sampling step, s."""
        return float((self.time[-1] - self.time[0]) / (self.time.size - 1))

    def to_frame(self) -> pd.DataFrame:
        """The log as a table with the columns :data:`LOG_COLUMNS` (and ``steer_fl``, ``steer_fr`` if it has them)."""
        cols = {"time": self.time, "steering_angle": self.steering_angle}
        if self.wheel_steering is not None:
            cols["steer_fl"] = self.wheel_steering[:, 0]
            cols["steer_fr"] = self.wheel_steering[:, 1]
        for i, w in enumerate(WHEELS):
            cols[f"wheel_speed_{w}"] = self.wheel_speeds[:, i]
        cols.update(yaw_rate=self.yaw_rate, accel_x=self.accel_x, accel_y=self.accel_y)
        return pd.DataFrame(cols)

    @classmethod
    def from_frame(cls, frame: pd.DataFrame, *, source: str = "table") -> "DriveLog":
        """Build a log from a table holding the columns :data:`LOG_COLUMNS` (extra columns ignored).

        The optional ``steer_fl`` and ``steer_fr`` (both or neither) give :attr:`wheel_steering`; with them,
        ``steering_angle`` may be left out (it is then their mean).

        Raises
        ------
        InputFormatError
            If channels are missing (all are listed, with their units) or hold NaN.
        """
        has = [c in frame.columns for c in WHEEL_STEERING_COLUMNS]
        if any(has) and not all(has):
            absent = WHEEL_STEERING_COLUMNS[has.index(False)]
            raise InputFormatError(f"{source}: {absent!r} is missing: the wheel steering angles come as a pair, "
                                   "steer_fl and steer_fr (rad, positive to the left), or not at all.")
        columns = LOG_COLUMNS + WHEEL_STEERING_COLUMNS if all(has) else LOG_COLUMNS
        if all(has) and "steering_angle" not in frame.columns:
            columns = tuple(c for c in columns if c != "steering_angle")
        missing = [c for c in LOG_COLUMNS if c not in frame.columns and c in columns]
        if missing:
            units = ", ".join(f"{c} ({_LOG_UNITS.get(c, _LOG_UNITS['wheel_speed'])})" for c in missing)
            raise InputFormatError(f"{source}: missing channel(s) {units}; a drive log needs {list(LOG_COLUMNS)} "
                                   "(see docs/vehicle-slope.md).")
        for c in columns:
            col = pd.to_numeric(frame[c], errors="coerce")
            if col.isna().any():
                i = int(np.argmax(col.isna().to_numpy()))
                raise InputFormatError(f"{source}: column {c!r} has a missing or non-numeric value at row {i}; "
                                       "fill or cut the gap (the estimators need every channel at every sample).")
        f = {c: frame[c].to_numpy(dtype=float) for c in columns}
        wheel_steering = np.column_stack([f["steer_fl"], f["steer_fr"]]) if all(has) else None
        steering = f["steering_angle"] if "steering_angle" in f else 0.5 * (f["steer_fl"] + f["steer_fr"])
        try:
            return cls(time=f["time"], steering_angle=steering,
                       wheel_speeds=np.column_stack([f[f"wheel_speed_{w}"] for w in WHEELS]),
                       yaw_rate=f["yaw_rate"], accel_x=f["accel_x"], accel_y=f["accel_y"],
                       wheel_steering=wheel_steering)
        except InputError as exc:
            raise InputFormatError(f"{source}: {exc}") from None


@dataclass(frozen=True, eq=False)
class DriveTruth:
    """True states of a simulated drive (all (T,) or (T, 4) with wheels FL, FR, RL, RR; SI units).

    Attributes
    ----------
    vx, vy, yaw_rate : (T,) ndarray
        Body velocities (m/s) and yaw rate (rad/s) at the centre of gravity.
    slope : (T,) ndarray
        Road grade angle under the centre of gravity, rad.
    distance : (T,) ndarray
        Distance travelled, m.
    wheel_speeds : (T, 4) ndarray
        Wheel spin rates, rad/s.
    fx, fy, normal_force : (T, 4) ndarray
        Tyre longitudinal and lateral forces (wheel axes) and normal loads, N.
    slip, slip_angle : (T, 4) ndarray
        Longitudinal slip (-) and slip angle (rad), eq. (18).
    friction : (T, 4) ndarray
        Available adhesion under each wheel.
    accel_x, accel_y : (T,) ndarray
        True specific force along the body axes, m/s^2 (what a perfect accelerometer reads).
    steering_angle : (T,) ndarray
        True front road-wheel angle, rad (with Ackermann steering, that of the equivalent bicycle wheel).
    wheel_steering : (T, 2) ndarray or None
        True front-left and front-right road-wheel angles, rad, when they differ from ``steering_angle``
        (``simulate_drive(..., steering_geometry="ackermann")``).
    """

    vx: np.ndarray
    vy: np.ndarray
    yaw_rate: np.ndarray
    slope: np.ndarray
    distance: np.ndarray
    wheel_speeds: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    normal_force: np.ndarray
    slip: np.ndarray
    slip_angle: np.ndarray
    friction: np.ndarray
    accel_x: np.ndarray
    accel_y: np.ndarray
    steering_angle: np.ndarray
    wheel_steering: np.ndarray | None = None

    def to_frame(self) -> pd.DataFrame:
        """The truth as a table; every column is prefixed ``true_`` (wheel columns end in _fl, _fr, _rl, _rr)."""
        cols = {}
        for k in ("vx", "vy", "yaw_rate", "slope", "distance", "accel_x", "accel_y", "steering_angle"):
            cols[f"true_{k}"] = getattr(self, k)
        if self.wheel_steering is not None:
            cols["true_steer_fl"] = self.wheel_steering[:, 0]
            cols["true_steer_fr"] = self.wheel_steering[:, 1]
        for k in ("wheel_speeds", "fx", "fy", "normal_force", "slip", "slip_angle", "friction"):
            name = "wheel_speed" if k == "wheel_speeds" else k
            for i, w in enumerate(WHEELS):
                cols[f"true_{name}_{w}"] = getattr(self, k)[:, i]
        return pd.DataFrame(cols)


@dataclass(frozen=True, eq=False)
class PlanarSimulation:
    """Output of :func:`simulate_drive`: the sensor ``log``, the ``truth`` and the ``scenario`` name."""

    log: DriveLog
    truth: DriveTruth
    scenario: str
    vehicle: Vehicle

    def to_frame(self) -> pd.DataFrame:
        """Sensor columns followed by the ``true_*`` columns."""
        return pd.concat([self.log.to_frame(), self.truth.to_frame()], axis=1)


# ----------------------------------------------------------------------------------------------- physics

_NZ = 15  # vx, vy, r, omega x4, s, X, Y, psi, wheel angle x4


@njit(cache=True)
def _road_at(grid, ds, s):
    x = s / ds
    if x <= 0.0:
        return grid[0]
    i = int(x)
    if i >= grid.shape[0] - 1:
        return grid[grid.shape[0] - 1]
    f = x - i
    return grid[i] * (1.0 - f) + grid[i + 1] * f


@njit(cache=True)
def _rates(z, delta_l, delta_r, torque, ax, ay, p, ds, slope_grid, mu_left, mu_right, dz, out_f):
    """Time derivative of the simulator state; ``out_f`` (6, 4) receives fx, fy, fn, slip, alpha, mu."""
    s = z[7]
    slope = _road_at(slope_grid, ds, s)
    fn = np.empty(4)
    normal_loads(p, ax, ay, slope, fn)
    mu = np.empty(4)
    lf = p[P_LF]
    lr = p[P_LR]
    mu[0] = _road_at(mu_left, ds, s + lf)
    mu[1] = _road_at(mu_right, ds, s + lf)
    mu[2] = _road_at(mu_left, ds, s - lr)
    mu[3] = _road_at(mu_right, ds, s - lr)
    slip = np.empty(4)
    alpha = np.empty(4)
    fx = np.empty(4)
    fy = np.empty(4)
    dfx = np.empty((4, 3))
    dfy = np.empty((4, 3))
    dfn = np.empty((2, 4))
    dfw = np.empty((2, 4))
    tyre_kinematics_forces(z[0], z[1], z[2], delta_l, delta_r, z[3:7], fn, mu, p, slip, alpha, fx, fy, dfx, dfy,
                           dfn, dfw)
    sfx, sfy, mz = body_sums(fx, fy, delta_l, delta_r, p)
    body_derivative(z[0], z[1], z[2], sfx, sfy, mz, slope, p, dz[0:3])
    iw = p[P_IW]
    for i in range(4):
        R = p[P_R_F] if i < 2 else p[P_R_R]
        dz[3 + i] = (torque[i] - R * fx[i]) / iw
        dz[11 + i] = z[3 + i]
        out_f[0, i] = fx[i]
        out_f[1, i] = fy[i]
        out_f[2, i] = fn[i]
        out_f[3, i] = slip[i]
        out_f[4, i] = alpha[i]
        out_f[5, i] = mu[i]
    dz[7] = math.sqrt(z[0] * z[0] + z[1] * z[1])
    c = math.cos(z[10])
    sn = math.sin(z[10])
    dz[8] = z[0] * c - z[1] * sn
    dz[9] = z[0] * sn + z[1] * c
    dz[10] = z[2]
    m = p[P_MASS]
    # specific force (non-gravitational forces / M) = accelerometer reading
    return slope, (sfx - p[P_CXA] * z[0] * abs(z[0])) / m, (sfy - p[P_CYA] * z[1] * abs(z[1])) / m


@njit(cache=True)
def _simulate_kernel(p, drive_share, brake_share, engine_brake, drive_radius, dt, v_ref, steer, ds, slope_grid, mu_left,
                     mu_right, z0, kp, ki, states, forces, slope_out, acc_out):
    T = v_ref.shape[0]
    z = z0.copy()
    dz = np.empty(_NZ)
    k1 = np.empty(_NZ)
    k2 = np.empty(_NZ)
    k3 = np.empty(_NZ)
    k4 = np.empty(_NZ)
    zt = np.empty(_NZ)
    fbuf = np.empty((6, 4))
    torque = np.zeros(4)
    m = p[P_MASS]
    R = drive_radius  # rolling radius of the driven wheels: torque = force R
    g = p[P_G]
    integ = 0.0
    # accelerometer state used for the load transfer: start from the steady-state guess
    ax = 0.0
    ay = 0.0
    for _ in range(3):
        sl, ax, ay = _rates(z, steer[0, 0], steer[0, 1], torque, ax, ay, p, ds, slope_grid, mu_left, mu_right, dz,
                            fbuf)
    ax = g * math.sin(sl)
    for k in range(T):
        dl = steer[k, 0]
        dr = steer[k, 1]
        # outputs at step k (loads from the specific force of the previous step: 1-step lag)
        sl, ax_k, ay_k = _rates(z, dl, dr, torque, ax, ay, p, ds, slope_grid, mu_left, mu_right, dz, fbuf)
        for j in range(_NZ):
            states[k, j] = z[j]
        for a in range(6):
            for b in range(4):
                forces[k, a, b] = fbuf[a, b]
        slope_out[k] = sl
        acc_out[k, 0] = ax_k
        acc_out[k, 1] = ay_k
        ax = ax_k
        ay = ay_k
        # driver: PI speed control with feed-forward of grade, drag and reference acceleration
        e = v_ref[k] - z[0]
        integ += e * dt
        dv = (v_ref[k + 1] - v_ref[k]) / dt if k + 1 < T else 0.0
        f_cmd = m * (kp * e + ki * integ + dv) + m * g * math.sin(sl) + p[P_CXA] * z[0] * abs(z[0])
        t_cmd = f_cmd * R
        t_engine = max(t_cmd, -engine_brake)
        t_brake = t_cmd - t_engine
        for i in range(4):
            # drive or overrun torque on the driven axle; service brakes (opposing the spin, smoothly to zero
            # at standstill) for what the engine cannot hold
            torque[i] = t_engine * drive_share[i] + t_brake * brake_share[i] * math.tanh(z[3 + i] / 0.5)
        # RK4 with inputs held over the step
        _rates(z, dl, dr, torque, ax, ay, p, ds, slope_grid, mu_left, mu_right, k1, fbuf)
        for j in range(_NZ):
            zt[j] = z[j] + 0.5 * dt * k1[j]
        _rates(zt, dl, dr, torque, ax, ay, p, ds, slope_grid, mu_left, mu_right, k2, fbuf)
        for j in range(_NZ):
            zt[j] = z[j] + 0.5 * dt * k2[j]
        _rates(zt, dl, dr, torque, ax, ay, p, ds, slope_grid, mu_left, mu_right, k3, fbuf)
        for j in range(_NZ):
            zt[j] = z[j] + dt * k3[j]
        _rates(zt, dl, dr, torque, ax, ay, p, ds, slope_grid, mu_left, mu_right, k4, fbuf)
        for j in range(_NZ):
            z[j] += dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])


def ackermann_angles(steering, vehicle: Vehicle) -> np.ndarray:
    """Front-left and front-right road-wheel angles (T, 2), rad, of an Ackermann steering linkage.

    ``steering`` (rad, positive to the left) is the angle of the equivalent bicycle-model wheel: the
    turn centre lies on the rear axle line at L / tan(delta) from the car's centre line, and each
    front wheel points perpendicular to its own radius: tan(delta_FL) = L tan(delta) / (L - S_f/2 tan(delta)),
    tan(delta_FR) = L tan(delta) / (L + S_f/2 tan(delta)) (the inner wheel steers more), with L the
    wheelbase and S_f the front track.
    """
    d = np.asarray(steering, dtype=float)
    L = vehicle.wheelbase
    hb = 0.5 * vehicle.tracks[0]
    t = np.tan(d)
    return np.column_stack([np.arctan2(L * t, L - hb * t), np.arctan2(L * t, L + hb * t)])


def simulate_drive(scenario: DriveScenario | str, vehicle: Vehicle | None = None, *,
                   sensors: SensorSpec | None = None, seed=None,
                   steering_geometry: str = "parallel") -> PlanarSimulation:
    """Simulate a drive with the planar 4-wheel model and produce the truth and the sensor log.

    Parameters
    ----------
    scenario : DriveScenario or str
        The drive, or the name of a built-in scenario (:data:`SCENARIOS`, at 1 kHz).
    vehicle : Vehicle, optional
        Default :func:`default_vehicle`.
    sensors : SensorSpec, optional
        Sensor models (default ``SensorSpec()``).
    seed : int or numpy.random.Generator, optional
        Seed of the sensor noise (the physics is deterministic).
    steering_geometry : {"parallel", "ackermann"}
        ``"parallel"`` (default): both front wheels steer by the scenario's angle. ``"ackermann"``: the
        scenario's angle is the bicycle-model angle and each front wheel steers by its Ackermann angle
        (:func:`ackermann_angles`); the log then also carries the two measured road-wheel angles
        (``wheel_steering``, columns ``steer_fl``, ``steer_fr``), with the steering sensor model of
        ``sensors`` applied to each, and ``steering_angle`` stays the measured bicycle angle.

    Returns
    -------
    PlanarSimulation
        ``log`` (DriveLog), ``truth`` (DriveTruth), ``scenario`` name and ``vehicle``.

    Notes
    -----
    Body: eq. (11)-(14) of paper 001 (yaw equation with I_z) with Dugoff tyres (15)-(17), slips (18)
    and load transfer (19) driven by the specific force of the previous step (a one-step lag breaks
    the algebraic loop loads -> forces -> accelerations). Wheels: I_w d(omega)/dt = T_i - R F_x,i.
    Driver: a PI speed controller (gains 1 s^-1 and 0.2 s^-2) with feed-forward of grade, drag and
    target acceleration; positive torque goes to the driven axle, negative torque too up to
    ``engine_brake_torque`` (engine braking), the rest is shared between the brakes (``brake_front_share``). Integration: classical RK4 at the scenario step with inputs
    held over the step. Road grade and adhesion are read along the travelled distance; each wheel
    reads the adhesion at its own position.
    """
    if isinstance(scenario, str):
        scenario = drive_scenario(scenario)
    if not isinstance(scenario, DriveScenario):
        raise InputError(f"scenario must be a DriveScenario or a scenario name; got {type(scenario).__name__}.")
    vehicle = default_vehicle() if vehicle is None else vehicle
    if not isinstance(vehicle, Vehicle):
        raise InputError(f"vehicle must be a Vehicle; got {type(vehicle).__name__}.")
    keys = {"wheel_inertia": "wheels.inertia (kg m^2)", "brake_front_share": "drivetrain.brake_front_share (0..1)"}
    missing = [text for attr, text in keys.items() if getattr(vehicle, attr) is None]
    if steering_geometry not in ("parallel", "ackermann"):
        raise InputError(f"steering_geometry must be 'parallel' or 'ackermann'; got {steering_geometry!r}.")
    if missing:
        named = f" {vehicle.name!r}" if vehicle.name else ""
        raise InputError(f"the simulator needs {' and '.join(missing)}, which the vehicle description{named} omits "
                         "(the estimators do not need them); add them to simulate.")
    sensors = SensorSpec() if sensors is None else sensors
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    p = vehicle.as_array()
    T = scenario.target_speed.size
    drive = {"front": [0.5, 0.5, 0.0, 0.0], "rear": [0.0, 0.0, 0.5, 0.5], "all": [0.25] * 4}[vehicle.driven_axle]
    bf = vehicle.brake_front_share
    brake = [bf / 2, bf / 2, (1 - bf) / 2, (1 - bf) / 2]
    z0 = np.zeros(_NZ)
    z0[0] = scenario.initial_speed
    z0[3:7] = scenario.initial_speed / vehicle.wheel_radius_of_each
    radii = vehicle.wheel_radius_of_each
    drive_radius = float(np.dot(drive, radii) / np.sum(drive))  # the driven wheels' radius (their mean)
    if steering_geometry == "ackermann":
        wheel_steering = ackermann_angles(scenario.steering, vehicle)
    else:
        wheel_steering = None
    steer2 = (np.ascontiguousarray(np.column_stack([scenario.steering, scenario.steering]))
              if wheel_steering is None else wheel_steering)
    states = np.empty((T, _NZ))
    forces = np.empty((T, 6, 4))
    slope = np.empty(T)
    acc = np.empty((T, 2))
    ds = float(scenario.road_distance[1] - scenario.road_distance[0])
    _simulate_kernel(p, np.array(drive), np.array(brake), vehicle.engine_brake_torque, drive_radius, scenario.dt,
                     scenario.target_speed, steer2, ds, scenario.road_slope,
                     np.ascontiguousarray(scenario.road_friction[:, 0]), np.ascontiguousarray(scenario.road_friction[:, 1]),
                     z0, 1.0, 0.2, states, forces, slope, acc)
    if not np.all(np.isfinite(states)):
        raise InputError(f"the simulation of scenario {scenario.name!r} diverged; reduce dt or the demands.")
    time = scenario.time
    truth = DriveTruth(vx=states[:, 0], vy=states[:, 1], yaw_rate=states[:, 2], slope=slope, distance=states[:, 7],
                       wheel_speeds=states[:, 3:7].copy(), fx=forces[:, 0], fy=forces[:, 1],
                       normal_force=forces[:, 2], slip=forces[:, 3], slip_angle=forces[:, 4], friction=forces[:, 5],
                       accel_x=acc[:, 0], accel_y=acc[:, 1], steering_angle=scenario.steering,
                       wheel_steering=wheel_steering)
    wheel = np.column_stack([_encoder_speeds(time, states[:, 11 + i], sensors, rng) for i in range(4)])
    steer = _steering_sensor(scenario.steering, sensors, rng)
    yaw = truth.yaw_rate + sensors.yaw_rate_offset + rng.normal(0.0, sensors.yaw_rate_noise, T)
    acc_x = truth.accel_x + sensors.accel_offset + rng.normal(0.0, sensors.accel_noise, T)
    acc_y = truth.accel_y + sensors.accel_offset + rng.normal(0.0, sensors.accel_noise, T)
    measured_wheels = None
    if wheel_steering is not None:  # drawn after the other channels: a parallel-steering log is unchanged
        measured_wheels = np.column_stack([_steering_sensor(wheel_steering[:, j], sensors, rng) for j in range(2)])
    log = DriveLog(time=time, steering_angle=steer, wheel_speeds=wheel, yaw_rate=yaw, accel_x=acc_x, accel_y=acc_y,
                   wheel_steering=measured_wheels)
    return PlanarSimulation(log=log, truth=truth, scenario=scenario.name, vehicle=vehicle)
