"""Simulator of the 7-DOF vertical model, test inputs and the sensors of the three configurations (thesis 003).

* :func:`simulate_vertical` integrates the model (:mod:`._model`) with RK4 from road inputs under
  the four wheels and the manoeuvre accelerations a_x, a_y, psidd.
* :func:`wheel_road_inputs` turns a two-track road profile into the four wheel inputs of a car at speed V
  (rear wheels see the front track delayed by wheelbase / V).
* :func:`bench_sweep_road` is the 4-poster exponential sine sweep of thesis §1.3 (0.5 -> 25 Hz in 35 s at
  constant peak plate velocity: heave 190 mm/s, pitch 157 mm/s, roll 125 mm/s).
* :func:`steering_sine_manoeuvre` is the track test of thesis §4.2 (80 km/h, steering sine with frequency
  increasing 0 -> 2 Hz).
* :func:`measure_vertical` samples the sensors of configuration 1, 2 or 3 with the thesis's quantisation
  (10-bit ADCs) and noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..._jit import njit
from ..._validation import as_float_array, require_positive, uniform_time_step
from ...errors import InputError, ShapeError
from ._checks import check_vertical_accel_means
from ._model import CORNER_NAMES, CX, CY, mr_controlled_force, seven_dof_rhs, skyhook_current, vertical_params_arrays
from ._params import SENSOR_CONFIGS, MRDamperParams, VerticalVehicleParams

#: Largest plausible road-vehicle speed, m/s (360 km/h): above, a unit mistake (km/h given as m/s) or a typo is assumed.
MAX_VEHICLE_SPEED = 100.0


def vehicle_speed(speed) -> float:
    """``speed`` (m/s) checked: finite, > 0 and at most :data:`MAX_VEHICLE_SPEED`."""
    v = require_positive("speed", speed)
    if v > MAX_VEHICLE_SPEED:
        raise InputError(f"speed {v:g} m/s is not a plausible road-vehicle speed (at most {MAX_VEHICLE_SPEED:g} m/s = "
                         f"{3.6 * MAX_VEHICLE_SPEED:g} km/h): km/h given as m/s?")
    return v


__all__ = [
    "DEFLECTION_RANGE",
    "VerticalSimulation",
    "VerticalSensors",
    "simulate_vertical",
    "wheel_road_inputs",
    "bench_sweep_road",
    "steering_sine_manoeuvre",
    "measure_vertical",
    "sensors_to_frame",
    "sensors_from_frame",
    "vertical_test_run",
]


# ------------------------------------------------------------------------------------------------ results


@dataclass(frozen=True, eq=False)
class VerticalSimulation:
    """True motion of the simulated car, sampled every ``dt`` (corner order FL, FR, RL, RR).

    Attributes
    ----------
    time : (T,) ndarray, s
    road : (T, 4) ndarray, m -- road height Z0 under each wheel.
    state : (T, 14) ndarray -- [z, theta, phi, Z1 x4, zdot, thetadot, phidot, Z1dot x4] (m, rad, m/s, rad/s).
    suspension_deflection : (T, 4) ndarray, m -- dZ21 = Z2 - Z1 (positive in extension).
    suspension_velocity : (T, 4) ndarray, m/s -- dZ21 rate (damper velocity).
    tyre_deflection : (T, 4) ndarray, m -- dZ10 = Z1 - Z0 about the static value (negative = more load).
    tyre_force : (T, 4) ndarray, N -- dynamic tyre normal load ``-k_t dZ10`` (positive = more load).
    body_velocity, wheel_velocity : (T, 4) ndarray, m/s -- Z2dot above each wheel, Z1dot.
    body_accel, wheel_accel : (T, 4) ndarray, m/s^2 -- Z2dd, Z1dd.
    ax, ay, yaw_accel : (T,) ndarray -- manoeuvre inputs, m/s^2 and rad/s^2.
    yaw_rate : (T,) ndarray, rad/s -- integral of ``yaw_accel`` from 0.
    dt : float, s
    params : VerticalVehicleParams
    damper_current : (T, 4) ndarray or None, A -- MagneRide car only: the commanded MR current (held over each
        sample); None for the passive (ideal) car.
    actuator_force : (T, 4) ndarray or None, N -- MagneRide car only: the true controlled MR force at each sample
        (lagged current, true damper velocity).
    mr_damper : MRDamperParams or None -- the MR damper of the run (None: passive car).
    """

    time: np.ndarray
    road: np.ndarray
    state: np.ndarray
    suspension_deflection: np.ndarray
    suspension_velocity: np.ndarray
    tyre_deflection: np.ndarray
    tyre_force: np.ndarray
    body_velocity: np.ndarray
    wheel_velocity: np.ndarray
    body_accel: np.ndarray
    wheel_accel: np.ndarray
    ax: np.ndarray
    ay: np.ndarray
    yaw_accel: np.ndarray
    yaw_rate: np.ndarray
    dt: float
    params: VerticalVehicleParams
    damper_current: np.ndarray | None = None
    actuator_force: np.ndarray | None = None
    mr_damper: MRDamperParams | None = None


@dataclass(frozen=True, eq=False)
class VerticalSensors:
    """Sensor signals of one configuration (thesis §4.1), sampled every ``dt``.

    Attributes
    ----------
    config : int -- 1 (displacements), 2 (+ body-corner accelerometers), 3 (+ wheel accelerometers).
    time : (T,) ndarray, s
    displacement : (T, 4) ndarray, m -- suspension displacement sensors dZ21 (10 bit over 0.3 m).
    ax, ay : (T,) ndarray, m/s^2 -- CG accelerometer.
    yaw_rate : (T,) ndarray, rad/s -- ESP yaw-rate gyro.
    body_accel : (T, 4) ndarray or None, m/s^2 -- config 2 only (gravity removed, as mounted on the body).
    wheel_accel : (T, 4) ndarray or None, m/s^2 -- config 3 only.
    dt : float, s
    damper_current : (T, 4) ndarray or None, A -- the logged commanded MR current (MagneRide car; the thesis's
        car logs "4 courants dans les amortisseurs", §3.5.2); None on a passive car.
    """

    config: int
    time: np.ndarray
    displacement: np.ndarray
    ax: np.ndarray
    ay: np.ndarray
    yaw_rate: np.ndarray
    body_accel: np.ndarray | None
    wheel_accel: np.ndarray | None
    dt: float
    damper_current: np.ndarray | None = None


# ------------------------------------------------------------------------------------------------ integrator


@njit(cache=True)
def _mr_rhs(s, r, ax, ay, ps, imposed, ieff, mr, corner, scalars, act, out):
    # actuator = imposed force + controlled MR force at the stage's damper velocity and effective current
    for c in range(4):
        v = s[7] + corner[c, CY] * s[8] - corner[c, CX] * s[9] - s[10 + c]
        act[c] = imposed[c] + mr_controlled_force(ieff[c], v, mr[0], mr[1], mr[2])
    seven_dof_rhs(s, r, ax, ay, ps, act, corner, scalars, out)


@njit(cache=True)
def _rk4_run(state0, road, ax, ay, psidd, imposed, mr, corner, scalars, dt, substeps, out_state, out_acc, out_cmd,
             out_force):
    """RK4 of the 7-DOF model with an imposed actuator force (T, 4) plus the MR damper and its skyhook
    controller in the loop (see simulate_vertical); a passive car is ``mr`` with F_max = 0 (no MR force, 0 A).

    Inputs are linearly interpolated between samples k and k+1 at the RK4 stages. The current command is computed at each sample from the true body-corner and damper velocities and held
    over the sample (1 kHz ECU); the effective current follows it with the exact first-order response
    ``i_eff(t_k + s) = i_cmd + (i_eff(t_k) - i_cmd) exp(-s / tau)`` (tau = 0: no lag).
    """
    n = state0.shape[0]
    T = road.shape[0]
    h = dt / substeps
    s = state0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    r = np.empty(4)
    act = np.empty(4)
    ieff0 = np.zeros(4)
    icmd = np.zeros(4)
    ie = np.empty(4)
    tau = mr[3]
    for k in range(T):
        out_state[k] = s
        for c in range(4):
            x, y = corner[c, CX], corner[c, CY]
            z2d = s[7] + y * s[8] - x * s[9]
            icmd[c] = skyhook_current(z2d, z2d - s[10 + c], mr)
            if tau <= 0.0:
                ieff0[c] = icmd[c]
        out_cmd[k] = icmd
        _mr_rhs(s, road[k], ax[k], ay[k], psidd[k], imposed[k], ieff0, mr, corner, scalars, act, k1)
        out_force[k] = act
        out_acc[k] = k1[7:]
        if k == T - 1:
            break
        for j in range(substeps):
            a0 = j / substeps
            am = (j + 0.5) / substeps
            a1 = (j + 1.0) / substeps
            for c in range(4):
                r[c] = road[k, c] + a0 * (road[k + 1, c] - road[k, c])
                ie[c] = icmd[c] if tau <= 0.0 else icmd[c] + (ieff0[c] - icmd[c]) * math.exp(-a0 * dt / tau)
            axs = ax[k] + a0 * (ax[k + 1] - ax[k])
            ays = ay[k] + a0 * (ay[k + 1] - ay[k])
            ps = psidd[k] + a0 * (psidd[k + 1] - psidd[k])
            _mr_rhs(s, r, axs, ays, ps, imposed[k], ie, mr, corner, scalars, act, k1)
            for c in range(4):
                r[c] = road[k, c] + am * (road[k + 1, c] - road[k, c])
                ie[c] = icmd[c] if tau <= 0.0 else icmd[c] + (ieff0[c] - icmd[c]) * math.exp(-am * dt / tau)
            axs = ax[k] + am * (ax[k + 1] - ax[k])
            ays = ay[k] + am * (ay[k + 1] - ay[k])
            ps = psidd[k] + am * (psidd[k + 1] - psidd[k])
            for i in range(n):
                tmp[i] = s[i] + 0.5 * h * k1[i]
            _mr_rhs(tmp, r, axs, ays, ps, imposed[k], ie, mr, corner, scalars, act, k2)
            for i in range(n):
                tmp[i] = s[i] + 0.5 * h * k2[i]
            _mr_rhs(tmp, r, axs, ays, ps, imposed[k], ie, mr, corner, scalars, act, k3)
            for c in range(4):
                r[c] = road[k, c] + a1 * (road[k + 1, c] - road[k, c])
                ie[c] = icmd[c] if tau <= 0.0 else icmd[c] + (ieff0[c] - icmd[c]) * math.exp(-a1 * dt / tau)
            axs = ax[k] + a1 * (ax[k + 1] - ax[k])
            ays = ay[k] + a1 * (ay[k + 1] - ay[k])
            ps = psidd[k] + a1 * (psidd[k + 1] - psidd[k])
            for i in range(n):
                tmp[i] = s[i] + h * k3[i]
            _mr_rhs(tmp, r, axs, ays, ps, imposed[k], ie, mr, corner, scalars, act, k4)
            for i in range(n):
                s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        if tau > 0.0:
            for c in range(4):
                ieff0[c] = icmd[c] + (ieff0[c] - icmd[c]) * math.exp(-dt / tau)


#: A passive car for the integrator: no MR force, no current.
_PASSIVE = MRDamperParams(max_force=0.0, time_constant=0.0)


def _series(name, value, T, default=0.0):
    if value is None:
        return np.full(T, default)
    arr = as_float_array(name, value, ndim=(0, 1), allow_nan=False)
    if arr.ndim == 0:
        return np.full(T, float(arr))
    if arr.shape[0] != T:
        raise ShapeError(f"{name} must have one value per sample of road ({T}); got {arr.shape[0]}.")
    return np.ascontiguousarray(arr)


def simulate_vertical(road, dt: float, *, params: VerticalVehicleParams | None = None, ax=None, ay=None,
                      yaw_accel=None, actuator_force=None, substeps: int = 4,
                      mr_damper: MRDamperParams | None = None) -> VerticalSimulation:
    """Simulate the 7-DOF vertical car model (thesis 003, §1.1) from rest at static equilibrium.

    Parameters
    ----------
    road : (T, 4) array_like
        Road height under the wheels FL, FR, RL, RR, m (see :func:`wheel_road_inputs`,
        :func:`bench_sweep_road`).
    dt : float
        Sample period, s (the thesis's ECU runs at 1 kHz: dt = 1e-3).
    params : VerticalVehicleParams, optional
        Vehicle parameters (default: the thesis's Audi A8 set).
    ax, ay : (T,) array_like or float, optional
        Longitudinal / lateral acceleration of the car in the road plane, m/s^2 (x forward, y left).
    yaw_accel : (T,) array_like or float, optional
        Yaw acceleration psidd, rad/s^2 (roll/yaw inertia coupling Ixz).
    actuator_force : (T, 4) array_like, optional
        Extra actuator tension force per corner, N (semi-active / active suspension); default 0.
    substeps : int
        RK4 steps per sample (inputs linearly interpolated inside a sample); default 4.
    mr_damper : MRDamperParams, optional
        The "MagneRide car" (thesis §1.2.4): each corner's damper becomes the passive (zero-current) damper
        of ``params`` plus the controlled MR force ``F_mr(i_eff, dZ21dot)`` of :class:`MRDamperParams`, the
        current commanded by a clipped skyhook controller fed with the TRUE body-corner and damper velocities
        (ASSUMPTION: an ideal controller -- only the logged current matters to the estimator), held over each
        sample and lagged by the first-order current-to-force response. Cannot be combined with
        ``actuator_force``. Default None: the passive ("ideal") car.

    Returns
    -------
    VerticalSimulation
        With ``damper_current`` (commanded current, A) and ``actuator_force`` (true MR force, N) for the
        MagneRide car.

    Notes
    -----
    The equations are those of :mod:`longprofile.vehicle.vertical._model` (thesis (1.12)-(1.19) rebuilt);
    states are deviations from the static equilibrium (thesis hypothesis 1: weight not in the equations).
    """
    p = params or VerticalVehicleParams()
    dt = require_positive("dt", dt)
    R = as_float_array("road", road, ndim=2, allow_nan=False)
    if R.shape[1] != 4:
        raise ShapeError(f"road must have shape (T, 4), one column per wheel FL, FR, RL, RR; got {R.shape}.")
    T = R.shape[0]
    if T < 2:
        raise ShapeError(f"road needs at least 2 samples; got {T}.")
    if int(substeps) != substeps or substeps < 1:
        raise InputError(f"substeps must be a positive integer; got {substeps!r}.")
    AX, AY, PS = _series("ax", ax, T), _series("ay", ay, T), _series("yaw_accel", yaw_accel, T)
    if actuator_force is None:
        U = np.zeros((T, 4))
    else:
        U = as_float_array("actuator_force", actuator_force, ndim=2, allow_nan=False)
        if U.shape != (T, 4):
            raise ShapeError(f"actuator_force must have shape (T, 4) = ({T}, 4); got {U.shape}.")
    corner, _coupling, scalars = vertical_params_arrays(p)
    R = np.ascontiguousarray(R)
    state0 = np.zeros(14)
    state0[3:7] = R[0]  # wheels on the road at rest, tyres at static deflection
    state0[0] = 0.0
    # body at rest above the wheels: choose z, theta, phi so that dZ21 = 0 as far as possible (least squares)
    A = np.column_stack([np.ones(4), corner[:, CY], -corner[:, CX]])
    state0[0:3] = np.linalg.lstsq(A, R[0], rcond=None)[0]
    X = np.empty((T, 14))
    acc = np.empty((T, 7))
    if mr_damper is not None:
        if not isinstance(mr_damper, MRDamperParams):
            raise InputError(f"mr_damper must be an MRDamperParams; got {type(mr_damper).__name__}.")
        if actuator_force is not None:
            raise InputError("give either actuator_force (an imposed force) or mr_damper (the MR car), not both.")
    mr = (mr_damper or _PASSIVE).as_array()
    cmd = np.empty((T, 4))
    force = np.empty((T, 4))
    _rk4_run(state0, R, AX, AY, PS, np.ascontiguousarray(U), mr, corner, scalars, dt, int(substeps), X, acc, cmd,
             force)
    if mr_damper is None:
        cmd = force = None
    xs, ys = corner[:, CX], corner[:, CY]
    z2 = X[:, [0]] + ys * X[:, [1]] - xs * X[:, [2]]
    z2d = X[:, [7]] + ys * X[:, [8]] - xs * X[:, [9]]
    z2dd = acc[:, [0]] + ys * acc[:, [1]] - xs * acc[:, [2]]
    dz = z2 - X[:, 3:7]
    tyre = X[:, 3:7] - R
    time = np.arange(T) * dt
    yaw_rate = np.concatenate([[0.0], np.cumsum(0.5 * (PS[1:] + PS[:-1])) * dt])
    return VerticalSimulation(
        time=time, road=R, state=X, suspension_deflection=dz, suspension_velocity=z2d - X[:, 10:14],
        tyre_deflection=tyre, tyre_force=-p.tyre_stiffness * tyre, body_velocity=z2d, wheel_velocity=X[:, 10:14],
        body_accel=z2dd, wheel_accel=acc[:, 3:7], ax=AX, ay=AY, yaw_accel=PS, yaw_rate=yaw_rate, dt=dt, params=p,
        damper_current=cmd, actuator_force=force, mr_damper=mr_damper)


# ------------------------------------------------------------------------------------------------ inputs


def wheel_road_inputs(profile, speed: float, dt: float, *, duration: float | None = None,
                      params: VerticalVehicleParams | None = None, start: float = 0.0) -> np.ndarray:
    """Road heights under the four wheels of a car driving over a profile at constant speed.

    Parameters
    ----------
    profile : longprofile.road.Profile
        Two tracks (columns 0 = left wheel path, 1 = right wheel path) or one track (used for both).
    speed : float
        Vehicle speed, m/s.
    dt : float
        Sample period, s.
    duration : float, optional
        Length of the run, s. Default: as long as the profile allows.
    params : VerticalVehicleParams, optional
        For the wheelbase (default thesis set).
    start : float
        Station of the REAR axle at t = 0, m (the front axle is one wheelbase ahead).

    Returns
    -------
    (T, 4) ndarray
        Road height under FL, FR, RL, RR, m. The rear wheels see the front track delayed by
        ``wheelbase / speed`` (same wheel paths front and rear).

    Raises
    ------
    InputError
        If the profile is too short for the run or has missing samples.
    """
    p = params or VerticalVehicleParams()
    V = vehicle_speed(speed)
    dt = require_positive("dt", dt)
    z = np.asarray(profile.elevation, dtype=float)
    if np.isnan(z).any():
        raise InputError("profile has missing (NaN) elevations; fill or cut them before driving over it.")
    x = np.asarray(profile.distance, dtype=float)
    if z.shape[1] == 1:
        z = np.repeat(z, 2, axis=1)
    L = p.wheelbase
    available = x[-1] - (start + L)
    if duration is None:
        duration = available / V
    duration = require_positive("duration", duration)
    if start < x[0] or start + L + V * duration > x[-1] + 1e-9:
        raise InputError(f"the profile covers {x[0]:g}..{x[-1]:g} m but the run needs {start:g}.."
                         f"{start + L + V * duration:g} m (speed {V:g} m/s for {duration:g} s plus the {L:g} m "
                         "wheelbase); lengthen the profile or shorten the run.")
    T = int(np.floor(duration / dt + 1e-9)) + 1
    s_rear = start + V * dt * np.arange(T)
    s_front = s_rear + L
    out = np.empty((T, 4))
    out[:, 0] = np.interp(s_front, x, z[:, 0])
    out[:, 1] = np.interp(s_front, x, z[:, 1])
    out[:, 2] = np.interp(s_rear, x, z[:, 0])
    out[:, 3] = np.interp(s_rear, x, z[:, 1])
    return out


_SWEEP_MODES = {"heave": ((1, 1, 1, 1), 0.190), "pitch": ((1, 1, -1, -1), 0.157), "roll": ((1, -1, 1, -1), 0.125)}


def bench_sweep_road(dt: float = 1e-3, *, mode: str = "heave", f_start: float = 0.5, f_end: float = 25.0,
                     duration: float = 35.0, peak_velocity: float | None = None) -> np.ndarray:
    """Plate displacements of the thesis's 4-poster exponential sine sweep (thesis §1.3.2).

    ``F_req(t) = f_start exp(K1 t)``, ``K1 = ln(f_end / f_start) / duration``, phase
    ``2 pi F_req(t) / K1``, amplitude ``A(t) = V_max / (2 pi F_req(t))`` (constant peak plate velocity).

    Parameters
    ----------
    dt : float
        Sample period, s.
    mode : {"heave", "pitch", "roll"}
        Plates in phase; front/rear in anti-phase; left/right in anti-phase.
    f_start, f_end : float
        Start and end frequency, Hz (thesis: 0.5 and 25 Hz).
    duration : float
        Sweep duration, s (thesis: 35 s).
    peak_velocity : float, optional
        Peak plate velocity V_max, m/s. Default per mode (thesis): heave 0.190, pitch 0.157, roll 0.125.

    Returns
    -------
    (T, 4) ndarray
        Plate displacement under FL, FR, RL, RR, m, starting from 0.
    """
    if mode not in _SWEEP_MODES:
        raise InputError(f"mode must be one of {list(_SWEEP_MODES)}; got {mode!r}.")
    signs, v_default = _SWEEP_MODES[mode]
    dt = require_positive("dt", dt)
    f1, f2 = require_positive("f_start", f_start), require_positive("f_end", f_end)
    if f2 <= f1:
        raise InputError(f"f_end must exceed f_start; got {f_start} -> {f_end} Hz.")
    if f2 >= 0.5 / dt:
        raise InputError(f"f_end = {f2} Hz is above the Nyquist frequency {0.5 / dt} Hz of dt = {dt} s.")
    duration = require_positive("duration", duration)
    vmax = v_default if peak_velocity is None else require_positive("peak_velocity", peak_velocity)
    t = np.arange(int(np.floor(duration / dt + 1e-9)) + 1) * dt
    K1 = np.log(f2 / f1) / duration
    freq = f1 * np.exp(K1 * t)
    phase = 2 * np.pi * (freq - f1) / K1
    z = vmax / (2 * np.pi * freq) * np.sin(phase)
    return np.outer(z, np.asarray(signs, dtype=float))


def steering_sine_manoeuvre(dt: float = 1e-3, *, duration: float = 20.0, speed: float = 80 / 3.6,
                            f_end: float = 2.0, yaw_rate_amplitude: float = 0.16,
                            yaw_bandwidth: float = 1.5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """a_x, a_y, psidd of the thesis's track test: constant 80 km/h, steering sine, frequency 0 -> ``f_end``.

    The thesis gives the steering (40 deg amplitude, 0 -> 2 Hz, 80 km/h) but no vehicle response;
    ASSUMPTION: the yaw rate is a linear chirp of amplitude ``yaw_rate_amplitude`` (0.16 rad/s: steady
    state of 40 deg at the wheel / ratio 16 for an understeering 2.96 m car at 80 km/h) filtered by a
    2nd-order low-pass at ``yaw_bandwidth`` Hz (damping 0.7) standing for the yaw dynamics;
    ``a_y = V r`` (side-slip rate neglected), ``psidd = dr/dt``, ``a_x = 0``.

    Returns
    -------
    ax, ay, yaw_accel : (T,) ndarrays (m/s^2, m/s^2, rad/s^2)
    """
    from ...statespace import filter_design, sos_filter

    dt = require_positive("dt", dt)
    duration = require_positive("duration", duration)
    V = vehicle_speed(speed)
    t = np.arange(int(np.floor(duration / dt + 1e-9)) + 1) * dt
    phase = 2 * np.pi * 0.5 * (f_end / duration) * t ** 2
    r_cmd = yaw_rate_amplitude * np.sin(phase)
    wn = 2 * np.pi * require_positive("yaw_bandwidth", yaw_bandwidth)
    zpk = filter_design("butter", 2, wn, btype="low", analog=True, output="zpk")
    zpk = filter_design("bilinear_zpk", *zpk, fs=1 / dt)
    r = sos_filter(filter_design("zpk2sos", *zpk), r_cmd)
    psidd = np.gradient(r, dt)
    return np.zeros_like(t), V * r, psidd


# ------------------------------------------------------------------------------------------------ sensors

#: Largest |suspension deflection| a vertical log may hold, m: the deflection sensors' 0.3 m span (thesis §4.3.2).
#: ``read_vertical_log`` refuses more (a log in mm read as m) and ``vehicle vertical simulate`` refuses to write a run
#: that exceeds it (the bump stops of a real car; class H roads at speed), so the two agree (session 40).
DEFLECTION_RANGE = 0.3
_DISP_STEP = 0.3 / 1024            # 10 bit over 0.3 m (thesis §4.3.2): 2.9e-4 m
_BODY_STEP = 4.0 / 1024 / 1.0 * 9.81   # 10 bit over 4 V, 1 V/g -> 0.038 m/s^2
_WHEEL_STEP = 4.0 / 1024 / 0.08 * 9.81  # 10 bit over 4 V, 80 mV/g -> 0.48 m/s^2


def _quantise(x, step):
    return np.round(x / step) * step


def measure_vertical(sim: VerticalSimulation, config: int, *, rng=None, displacement_noise: float = 0.5 * _DISP_STEP,
                     body_accel_noise: float = 0.02, engine_order_amplitude: float = 0.1,
                     engine_order_frequency: float = 35.0, body_accel_misalignment: float = 0.01,
                     wheel_accel_noise: float = 0.25, cg_accel_noise: float = 0.05,
                     yaw_rate_noise: float = 0.005) -> VerticalSensors:
    """Sensor signals of configuration 1, 2 or 3 on a simulated run (thesis §4.1, Table "capteurs").

    Parameters
    ----------
    sim : VerticalSimulation
    config : {1, 2, 3}
        1: four suspension displacement sensors + a_x, a_y, yaw rate; 2: + four body-corner
        accelerometers above the wheels; 3: + four wheel (hub) accelerometers.
    rng : int, Generator or None
        Seed of the noise (same seed -> same signals).
    displacement_noise : float
        Electrical noise std before the ADC, m (default half a step: with the 10-bit / 0.3 m
        quantisation the effective variance is ~3e-8 m^2, the thesis's R).
    body_accel_noise : float
        White noise std of the body accelerometers, m/s^2 (then 10-bit, +-2 g, 1 V/g quantisation).
    engine_order_amplitude, engine_order_frequency : float
        The V6 firing-order vibration seen by the body accelerometers (thesis §4.4.2: 35 Hz at idle),
        amplitude m/s^2 (ASSUMPTION: 0.1 m/s^2, the thesis's Fig. 4.17 is not quantified).
    body_accel_misalignment : float
        Mounting tilt of the body accelerometers, rad: adds ``misalignment * (a_x + a_y)`` (the low-frequency
        error the thesis compensates "proportionally to a_x and a_y"). The body's own pitch/roll tilt is
        always included: ``a_x phi - a_y theta``.
    wheel_accel_noise : float
        Broadband noise std of the wheel accelerometers, m/s^2 (thesis: noise inside a ~1 m/s^2 band),
        then 10-bit, +-25 g, 80 mV/g quantisation (0.48 m/s^2 steps).
    cg_accel_noise, yaw_rate_noise : float
        Noise std of the CG accelerometer (m/s^2) and of the yaw-rate gyro (rad/s).

    Returns
    -------
    VerticalSensors
        With ``damper_current`` = the commanded MR current of a MagneRide run (logged by the ECU: ASSUMPTION
        exact, no noise), None for a passive car.
    """
    if config not in SENSOR_CONFIGS:
        raise InputError(f"config must be 1, 2 or 3 (thesis sensor configurations); got {config!r}.")
    gen = np.random.default_rng(rng)
    T = sim.time.shape[0]
    disp = _quantise(sim.suspension_deflection + displacement_noise * gen.standard_normal((T, 4)), _DISP_STEP)
    ax = sim.ax + cg_accel_noise * gen.standard_normal(T)
    ay = sim.ay + cg_accel_noise * gen.standard_normal(T)
    yaw = sim.yaw_rate + yaw_rate_noise * gen.standard_normal(T)
    body = wheel = None
    if config == 2:
        theta, phi = sim.state[:, 1:2], sim.state[:, 2:3]
        tilt = sim.ax[:, None] * phi - sim.ay[:, None] * theta
        mount = body_accel_misalignment * (sim.ax + sim.ay)[:, None]
        engine = engine_order_amplitude * np.sin(2 * np.pi * engine_order_frequency * sim.time[:, None]
                                                 + gen.uniform(0, 2 * np.pi, 4))
        body = _quantise(sim.body_accel + tilt + mount + engine + body_accel_noise * gen.standard_normal((T, 4)),
                         _BODY_STEP)
    if config == 3:
        wheel = _quantise(sim.wheel_accel + wheel_accel_noise * gen.standard_normal((T, 4)), _WHEEL_STEP)
    current = None if sim.damper_current is None else sim.damper_current.copy()  # logged command, exact
    return VerticalSensors(config=int(config), time=sim.time.copy(), displacement=disp, ax=ax, ay=ay, yaw_rate=yaw,
                           body_accel=body, wheel_accel=wheel, dt=sim.dt, damper_current=current)


# ------------------------------------------------------------------------------------------------ tables

_TRUTH_COLUMNS = {
    "suspension_deflection": "true_dz21", "suspension_velocity": "true_dz21dot", "tyre_force": "true_tyre_force",
    "body_velocity": "true_body_velocity", "wheel_velocity": "true_wheel_velocity",
    "tyre_deflection": "true_dz10", "road": "true_road",
}


def sensors_to_frame(sensors: VerticalSensors, sim: VerticalSimulation | None = None) -> pd.DataFrame:
    """One table (one row per sample) of the sensor signals, plus the true states when ``sim`` is given.

    Columns: ``time, ax, ay, yaw_rate, dz21_FL..RR`` (+ ``body_accel_*`` config 2, ``wheel_accel_*``
    config 3, ``current_*`` (A) on a MagneRide car) and ``true_<quantity>_<corner>`` for the truth (used to
    score estimates).
    """
    cols = {"time": sensors.time, "ax": sensors.ax, "ay": sensors.ay, "yaw_rate": sensors.yaw_rate}
    for c, name in enumerate(CORNER_NAMES):
        cols[f"dz21_{name}"] = sensors.displacement[:, c]
    for attr, prefix in (("body_accel", "body_accel"), ("wheel_accel", "wheel_accel"),
                         ("damper_current", "current")):
        arr = getattr(sensors, attr)
        if arr is not None:
            for c, name in enumerate(CORNER_NAMES):
                cols[f"{prefix}_{name}"] = arr[:, c]
    if sim is not None:
        for attr, prefix in _TRUTH_COLUMNS.items():
            arr = getattr(sim, attr)
            for c, name in enumerate(CORNER_NAMES):
                cols[f"{prefix}_{name}"] = arr[:, c]
    return pd.DataFrame(cols)


def sensors_from_frame(df: pd.DataFrame, config: int, *, source: str = "table") -> VerticalSensors:
    """Rebuild :class:`VerticalSensors` of configuration ``config`` from a table written by :func:`sensors_to_frame`.

    Raises :class:`~longprofile.errors.InputFormatError` naming missing columns, a non-uniform time column
    or non-finite values, :class:`~longprofile.errors.UnitsError` for vertical accelerometers that still include
    gravity (:func:`check_vertical_accel_means`).
    """
    from ...errors import InputFormatError

    if config not in SENSOR_CONFIGS:
        raise InputError(f"config must be 1, 2 or 3 (thesis sensor configurations); got {config!r}.")
    need = ["time", "ax", "ay", "yaw_rate"] + [f"dz21_{n}" for n in CORNER_NAMES]
    if config == 2:
        need += [f"body_accel_{n}" for n in CORNER_NAMES]
    if config == 3:
        need += [f"wheel_accel_{n}" for n in CORNER_NAMES]
    missing = [c for c in need if c not in df.columns]
    if missing:
        raise InputFormatError(f"{source}: configuration {config} needs column(s) {missing}; "
                               f"the table has {list(df.columns)}.")
    arr = {c: pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float) for c in need}
    for c in need:
        if not np.all(np.isfinite(arr[c])):
            i = int(np.argmax(~np.isfinite(arr[c])))
            raise InputFormatError(f"{source}: column {c!r} has a missing or non-numeric value at row {i}.")
    for c in need[4:]:  # a suspension deflection or a vertical accelerometer never holds one value on a moving car
        if arr[c].size > 1 and np.ptp(arr[c]) == 0.0:
            raise InputFormatError(f"{source}: column {c!r} holds one value ({arr[c][0]:g}) through the whole log: a "
                                   "dead or disconnected sensor? The estimate needs every corner's channel.")
    t = arr["time"]
    if t.shape[0] < 3:
        raise InputFormatError(f"{source}: need at least 3 samples; got {t.shape[0]}.")
    # the rule of the log readers and differentiate (a gap, rounded stamps, jitter refused); the mean step end to end
    dt = uniform_time_step(t, source=source, gap_fix="the filters need a continuous log; cut it at the gap",
                           jitter_fix="the filters use a fixed step: resample it (read_vertical_log(resample=...))")

    def stack(prefix):
        return np.column_stack([arr[f"{prefix}_{n}"] for n in CORNER_NAMES])

    current = None
    cur_cols = [f"current_{n}" for n in CORNER_NAMES]
    if all(c in df.columns for c in cur_cols):  # optional: the logged MR currents of a MagneRide car
        current = np.column_stack([pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float) for c in cur_cols])
        if not np.all(np.isfinite(current)):
            raise InputFormatError(f"{source}: the current_* columns have a missing or non-numeric value.")
    sensors = VerticalSensors(config=int(config), time=t, displacement=stack("dz21"), ax=arr["ax"], ay=arr["ay"],
                              yaw_rate=arr["yaw_rate"], body_accel=stack("body_accel") if config == 2 else None,
                              wheel_accel=stack("wheel_accel") if config == 3 else None, dt=dt,
                              damper_current=current)
    check_vertical_accel_means(sensors, source=source)  # gravity left in the accelerometers (session 38)
    return sensors


_TESTS = ("road", "sweep", "track")


def vertical_test_run(config: int, *, test: str = "road", road_class: str = "C", speed: float = 20.0,
                      duration: float = 20.0, seed: int = 0, dt: float = 1e-3,
                      params: VerticalVehicleParams | None = None,
                      mr_damper: MRDamperParams | None = None) -> tuple[VerticalSimulation, VerticalSensors]:
    """Simulate one of the thesis's tests and measure it with the sensors of ``config``.

    Parameters
    ----------
    config : {1, 2, 3}
        Sensor configuration.
    test : {"road", "sweep", "track"}
        ``"road"``: drive at ``speed`` over an ISO 8608 ``road_class`` road (two independent wheel paths,
        rear wheels delayed by wheelbase / V); ``"sweep"``: the 4-poster heave sweep 0.5 -> 25 Hz (35 s
        in the thesis; here ``duration``, same end frequency); ``"track"``: the 80 km/h steering-sine
        manoeuvre (0 -> 2 Hz) on a road of ``road_class`` at ``speed``.
    road_class : str
        ISO 8608 class "A".."H" of the road (tests "road" and "track").
    speed : float
        Vehicle speed, m/s.
    duration : float
        Length of the run, s.
    seed : int
        Seed of the road and the sensor noise.
    dt : float
        Sample period, s.
    params : VerticalVehicleParams, optional
        The simulated car (default thesis set).
    mr_damper : MRDamperParams, optional
        Simulate the MagneRide car (MR dampers + skyhook, see :func:`simulate_vertical`); the sensors then log
        the commanded currents. Default None: passive car.

    Returns
    -------
    (VerticalSimulation, VerticalSensors)
    """
    from ...road import iso8608_profile

    if test not in _TESTS:
        raise InputError(f"test must be one of {list(_TESTS)}; got {test!r}.")
    if config not in SENSOR_CONFIGS:
        raise InputError(f"config must be 1, 2 or 3 (thesis sensor configurations); got {config!r}.")
    p = params or VerticalVehicleParams()
    duration = require_positive("duration", duration)
    speed = vehicle_speed(speed)
    if test == "sweep":
        sim = simulate_vertical(bench_sweep_road(dt, duration=duration), dt, params=p, mr_damper=mr_damper)
    else:
        length = speed * duration + p.wheelbase + 10.0
        prof = iso8608_profile(length, min(0.05, speed * dt * 10), road_class, rng=seed, tracks=("left", "right"))
        road = wheel_road_inputs(prof, speed, dt, duration=duration, params=p)
        if test == "road":
            sim = simulate_vertical(road, dt, params=p, mr_damper=mr_damper)
        else:
            ax, ay, psidd = steering_sine_manoeuvre(dt, duration=(road.shape[0] - 1) * dt, speed=speed)
            sim = simulate_vertical(road, dt, params=p, ax=ax, ay=ay, yaw_accel=psidd, mr_damper=mr_damper)
    return sim, measure_vertical(sim, config, rng=seed + 1)
