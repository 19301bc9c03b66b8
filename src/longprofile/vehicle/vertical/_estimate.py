"""Vertical state estimation of thesis 003: four per-corner EKFs + absolute-velocity reconstruction.

:func:`vertical_ekf_model` builds the filter model (a :class:`longprofile.statespace.NonlinearStateSpaceModel`
over the 16 stacked corner states, see :mod:`._model`), :func:`estimate_vertical_states` runs it
with the engine's :func:`~longprofile.statespace.extended_kalman_filter` on the sensors of one configuration
and rebuilds the absolute body and wheel velocities as the thesis does (§4.3.4.4, §4.4.3.4, §4.5.3.4).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..._jit import njit
from ..._validation import as_float_array, require_positive
from ...errors import InputError, ShapeError
from ...statespace import filter_design, sos_filter
from ._bands import (
    VERTICAL_NIS_WINDOW,
    VerticalStateStd,
    calibrated_vertical_std,
    innovation_consistency,
    rate_is_calibrated,
)
from ._model import (
    CORNER_NAMES,
    MR_MAP_VELOCITIES,
    N_U,
    STATE_BLOCKS,
    U_ACT,
    U_AX,
    U_AY,
    U_MR_FY,
    U_MR_VY,
    U_PSIDD,
    CornerFilterSettings,
    _engine,
    suspension_tensions,
    thesis_filter_settings,
    vertical_ekf_model,
    vertical_linear_model,
    vertical_params_arrays,
)
from ._params import MRDamperParams, VerticalVehicleParams
from ._simulate import VerticalSensors

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["vertical_ekf_inputs", "VerticalStateEstimate", "estimate_vertical_states", "smooth_vertical_states",
           "yaw_acceleration", "estimate_vertical_states_linear", "mr_actuator_force",
           "nominal_mr_map", "damper_velocity_from_displacement", "MR_MAP_FORCE_ERROR", "estimate_to_frame"]

def yaw_acceleration(yaw_rate, dt: float, *, cutoff: float = 5.0) -> np.ndarray:
    """Yaw acceleration psidd from a measured yaw rate: backward difference + causal 2nd-order low-pass.

    The thesis differentiates the ESP yaw rate and low-pass filters it (§1.1.4); ASSUMPTION: Butterworth
    at ``cutoff`` Hz (default 5 Hz, above the driver's <= 3 Hz), causal so the estimator stays real-time.
    """
    r = as_float_array("yaw_rate", yaw_rate, ndim=1, allow_nan=False)
    dt = require_positive("dt", dt)
    d = np.empty_like(r)
    d[1:] = np.diff(r) / dt
    d[0] = 0.0 if r.shape[0] < 2 else d[1]
    return sos_filter(_sos(2, require_positive("cutoff", cutoff), "low", dt), d)


# ------------------------------------------------------------------------------------------------ MR actuator

#: Default calibration error of the filter's MR map: its force scale is 12 % ABOVE the true damper's.
#: ASSUMPTION (rationale, no measured source): the thesis's Delphi map depends on the damper temperature
#: (§1.2.4, "the force grows as the temperature drops"), which the car estimates rather than measures in the
#: MR fluid; a map calibrated on the bench at a cooler fluid than on the road over-predicts the force. 12 % is
#: the middle of the 10-15 % range chosen for this study; see the sensitivity (0/10/20 %) in the docs.
MR_MAP_FORCE_ERROR = 0.12


def nominal_mr_map(mr: MRDamperParams, *, force_error: float = MR_MAP_FORCE_ERROR) -> MRDamperParams:
    """The filter's knowledge of an MR damper: the same map with the force scaled by ``1 + force_error``, no lag.

    The thesis's filter computes the actuator force from the measured current with Delphi's static map
    (§1.2.4, §3.1); the current-to-force dynamics are not in it (ASSUMPTION: the map is static, so the
    first-order lag of the real damper is an unmodelled error of the filter).
    """
    if not isinstance(mr, MRDamperParams):
        raise InputError(f"mr must be an MRDamperParams; got {type(mr).__name__}.")
    if not math.isfinite(force_error) or force_error <= -1.0:
        raise InputError(f"force_error must be a finite number > -1 (a relative error); got {force_error!r}.")
    return replace(mr, max_force=mr.max_force * (1.0 + force_error), time_constant=0.0)


def damper_velocity_from_displacement(displacement, dt: float, *, cutoff: float = 20.0) -> np.ndarray:
    """Causal damper velocity from the measured suspension displacement: backward difference + 2nd-order low-pass.

    The thesis's filter feeds its actuator map with the damper velocities ESTIMATED at the previous step
    (§3.1, Fig. 3.2) -- ``mr_map_velocity="filter"`` of :func:`estimate_vertical_states` does that, the map
    inside the model; the default precomputes the actuator force as a known input row with a causal stand-in:
    the backward difference of the measured (10-bit) displacement, Butterworth low-pass at ``cutoff`` Hz
    (default 20 Hz: the quantisation steps of 0.29 mm differentiate to 0.29 m/s jumps at 1 kHz; ASSUMPTION,
    not tuned). Returns (T, 4) m/s.
    """
    d = as_float_array("displacement", displacement, ndim=2, allow_nan=False)
    dt = require_positive("dt", dt)
    v = np.zeros_like(d)
    v[1:] = np.diff(d, axis=0) / dt
    return sos_filter(_sos(2, require_positive("cutoff", cutoff), "low", dt), v)


def mr_actuator_force(current, damper_velocity, mr: MRDamperParams | None = None) -> np.ndarray:
    """Actuator (controlled MR) force of the filter's map, ``F_y(i) tanh(v / v_y)``, N, for every sample and corner.

    Parameters
    ----------
    current : (T, 4) array_like
        Logged damper currents, A (:attr:`VerticalSensors.damper_current`); negative values count as 0.
    damper_velocity : (T, 4) array_like
        Damper velocity the map is evaluated at, m/s (e.g. :func:`damper_velocity_from_displacement`).
    mr : MRDamperParams, optional
        The map's parameters -- the FILTER's knowledge, e.g. :func:`nominal_mr_map` of the true damper (default:
        ``nominal_mr_map(MRDamperParams())``). Its ``time_constant`` is ignored: the map is static.

    Returns
    -------
    (T, 4) ndarray
        The ``actuator_force`` argument of :func:`estimate_vertical_states` (model of :class:`MRDamperParams`).
    """
    m = mr if mr is not None else nominal_mr_map(MRDamperParams())
    if not isinstance(m, MRDamperParams):
        raise InputError(f"mr must be an MRDamperParams; got {type(m).__name__}.")
    i = as_float_array("current", current, ndim=2, allow_nan=False)
    v = as_float_array("damper_velocity", damper_velocity, ndim=2, allow_nan=False)
    if i.shape != v.shape or i.shape[1] != 4:
        raise ShapeError(f"current and damper_velocity must both have shape (T, 4); got {i.shape} and {v.shape}.")
    return _mr_yield_force(i, m) * np.tanh(v / m.yield_velocity)


def _mr_yield_force(current, mr: MRDamperParams) -> np.ndarray:
    """Yield force of the map at the current, ``F_max (1 - exp(-max(i, 0) / i_sat))``, N (same shape)."""
    return mr.max_force * (1.0 - np.exp(-np.maximum(current, 0.0) / mr.saturation_current))


# ------------------------------------------------------------------------------------------------ results


@dataclass(frozen=True, eq=False)
class VerticalStateEstimate:
    """Estimated vertical states per corner (FL, FR, RL, RR), one row per sample.

    Attributes
    ----------
    time : (T,) ndarray, s
    suspension_deflection : (T, 4) ndarray, m -- estimated dZ21.
    suspension_velocity : (T, 4) ndarray, m/s -- estimated damper velocity dZ21dot.
    vehicle_disturbance : (T, 4) ndarray, N -- estimated disturbance force P.
    tyre_deflection : (T, 4) ndarray, m -- estimated dZ10.
    tyre_force : (T, 4) ndarray, N -- dynamic tyre normal load ``-k_t dZ10`` (positive = more load).
    body_velocity, wheel_velocity : (T, 4) ndarray, m/s -- reconstructed Z2dot, Z1dot (thesis §6.5 chains).
    state_std : (T, 16) ndarray -- the filter's MODEL standard deviations of the stacked state, NOT calibrated:
        on clean simulated road logs (session 40, classes B-D) the ±1.645 std band held the truth on 17-31 % of the
        samples for the damper velocity, 18-44 % for the deflection and 19-32 % for the tyre deflection where 90 %
        was meant (docs/vehicle-vertical.md); do not use them as error bars: use ``calibrated_std``.
    config : int
    method : str -- "corner-ekf" (thesis, decentralised) or "full-ekf" (centralised).
    filtered : FilterResult -- the engine's output (stacked 16 states).
    actuator_force : (T, 4) ndarray or None, N -- the actuator forces the filter used at each step: the known
        input plus, with ``mr_map_velocity="filter"``, the in-model MR map at the filtered velocity
        ``F_y(i[k]) tanh(dZ21dot[k|k] / v_y)`` (the force the transition from step k applied).
    calibrated_std : VerticalStateStd or None -- the calibrated stds of the deflection, damper velocity, tyre
        deflection and tyre force (:func:`calibrated_vertical_std`: the model stds inflated from the windowed NIS;
        session 41); None for the centralised filter and the smoothers (no calibration fitted for them) and for
        sample rates outside ``VERTICAL_STD_RATE_RANGE`` (500-2000 Hz, the rates it was fitted on).
    """

    time: np.ndarray
    suspension_deflection: np.ndarray
    suspension_velocity: np.ndarray
    vehicle_disturbance: np.ndarray
    tyre_deflection: np.ndarray
    tyre_force: np.ndarray
    body_velocity: np.ndarray
    wheel_velocity: np.ndarray
    state_std: np.ndarray
    config: int
    method: str
    filtered: object
    actuator_force: np.ndarray | None = None
    calibrated_std: VerticalStateStd | None = None


def vertical_ekf_inputs(sensors: VerticalSensors, *, settings: CornerFilterSettings | None = None,
                        decentralised: bool | None = None, actuator_force=None, yaw_cutoff: float = 5.0,
                        mr_map: MRDamperParams | None = None, mr_map_velocity: str = "displacement",
                        mr_velocity_cutoff: float = 20.0) -> np.ndarray:
    """The (T, 12) known-input rows of :func:`vertical_ekf_model` for a sensor record.

    Columns: a_x, a_y (measured), psidd (:func:`yaw_acceleration` of the measured yaw rate), the four actuator
    forces (default 0), then the in-model MR map: yield force per corner and yield velocity (0 unless
    ``mr_map_velocity="filter"``).

    Deprecated (issue 12): dt, alpha_veh, alpha_route, config and decentralised are no longer columns of the
    row (they were columns 7-11 of a 17-column row) but parameters of the model
    (:func:`vertical_ekf_model`, ``decentralised=``). ``settings`` and ``decentralised`` are accepted and
    ignored, with a DeprecationWarning; pass them to :func:`vertical_ekf_model`.

    With ``mr_map`` (the filter's MR map, e.g. :func:`nominal_mr_map`; needs ``sensors.damper_current``):
    ``mr_map_velocity="displacement"`` adds :func:`mr_actuator_force` at
    :func:`damper_velocity_from_displacement` (low-pass ``mr_velocity_cutoff`` Hz) to the actuator-force
    columns (precomputed input); ``"filter"`` writes the map's yield force at the logged current,
    ``F_max (1 - exp(-i / i_sat))``, and ``v_y`` into the last five columns: the model evaluates
    ``F_y tanh(dZ21dot / v_y)`` at its own velocity state (thesis §3.1).
    """
    for name, value in (("settings", settings), ("decentralised", decentralised)):
        if value is not None:
            warnings.warn(f"vertical_ekf_inputs({name}=...) is deprecated and ignored: {name} is a parameter of "
                          f"the model since issue 12; pass it to vertical_ekf_model(..., {name}=...).",
                          DeprecationWarning, stacklevel=2)
    T = sensors.time.shape[0]
    u = np.zeros((T, N_U))
    u[:, U_AX] = sensors.ax
    u[:, U_AY] = sensors.ay
    u[:, U_PSIDD] = yaw_acceleration(sensors.yaw_rate, sensors.dt, cutoff=yaw_cutoff)
    if actuator_force is not None:
        U = as_float_array("actuator_force", actuator_force, ndim=2, allow_nan=False)
        if U.shape != (T, 4):
            raise ShapeError(f"actuator_force must have shape (T, 4) = ({T}, 4); got {U.shape}.")
        u[:, U_ACT:U_ACT + 4] = U
    if mr_map_velocity not in MR_MAP_VELOCITIES:
        raise InputError(f"mr_map_velocity must be one of {MR_MAP_VELOCITIES}; got {mr_map_velocity!r}.")
    if mr_map is not None:
        if not isinstance(mr_map, MRDamperParams):
            raise InputError(f"mr_map must be an MRDamperParams (e.g. nominal_mr_map(...)); "
                             f"got {type(mr_map).__name__}.")
        if sensors.damper_current is None:
            raise InputError("mr_map needs the logged damper currents (sensors.damper_current, columns "
                             "current_FL..RR of a MagneRide log); this record has none.")
        if mr_map_velocity == "displacement":
            vel = damper_velocity_from_displacement(sensors.displacement, sensors.dt, cutoff=mr_velocity_cutoff)
            act = mr_actuator_force(sensors.damper_current, vel, mr_map)
            u[:, U_ACT:U_ACT + 4] = act if actuator_force is None else u[:, U_ACT:U_ACT + 4] + act
        else:
            u[:, U_MR_FY:U_MR_FY + 4] = _mr_yield_force(np.asarray(sensors.damper_current, float), mr_map)
            u[:, U_MR_VY] = mr_map.yield_velocity
    return u


def estimate_vertical_states(sensors: VerticalSensors, *, params: VerticalVehicleParams | None = None,
                             settings: CornerFilterSettings | None = None, decentralised: bool = True,
                             actuator_force=None, yaw_cutoff: float = 5.0,
                             accel_compensation: tuple[float, float] = (0.0, 0.0),
                             mr_map: MRDamperParams | None = None,
                             mr_map_velocity: str = "displacement",
                             store_covariances: bool = True) -> VerticalStateEstimate:
    """Estimate damper displacement/velocity, tyre deflection/force, body and wheel velocities (thesis 003).

    Parameters
    ----------
    sensors : VerticalSensors
        Signals of configuration 1, 2 or 3 (:func:`measure_vertical` or :func:`sensors_from_frame`).
    params : VerticalVehicleParams, optional
        Model parameters of the filter (default: thesis set).
    settings : CornerFilterSettings, optional
        Noise settings (default :func:`thesis_filter_settings` of the configuration).
    decentralised : bool
        True: the thesis's four per-corner EKFs; False: the centralised full-car EKF.
    actuator_force : (T, 4) array_like, optional
        Known actuator forces (semi-active command), N; default 0 (passive car).
    yaw_cutoff : float
        Low-pass cut-off of the yaw-rate derivative, Hz.
    accel_compensation : (float, float)
        Gains (1) subtracted as ``g_x a_x + g_y a_y`` from the vertical accelerometers before they are
        integrated (thesis Figs. 4.18, 4.32; gains not given there, default 0).
    mr_map : MRDamperParams, optional
        The filter's MR map (e.g. :func:`nominal_mr_map` of the car's damper) for a MagneRide record
        (``sensors.damper_current`` needed): the actuator force is the map at the logged current, added to
        ``actuator_force``.
    mr_map_velocity : {"displacement", "filter"}
        Damper velocity the map is evaluated at. ``"displacement"`` (default): the causal derivative of the
        measured displacement (:func:`damper_velocity_from_displacement`, a precomputed input; DEVIATION from
        the thesis). ``"filter"``: the filter's own velocity state, the map being part of the model's
        transition and observation functions with its analytic slope in the Jacobians (thesis §1.2.4, §3.1;
        see docs/vehicle-vertical.md, "MagneRide car", for its stability).
    store_covariances : bool
        True (default): ``filtered`` keeps the engine's covariance and Jacobian histories, which
        :func:`smooth_vertical_states` needs (~7.7 kB per sample in configurations 2 and 3: an hour at 1 kHz
        is 28 GB). False: ``filtered`` keeps the filtered means only (no predictions, innovations or
        covariances; ~0.13 kB per sample) and ``state_std`` comes from the filtered variances the engine keeps
        alone (``store_covariances="variances"``); every estimated number is the same.

    Returns
    -------
    VerticalStateEstimate
        Its ``state_std`` is the filter's model std, NOT calibrated: the ±1.645 std band covered 17-31 % of the
        true damper velocities on clean simulated roads where 90 % was meant (session 40; docs/vehicle-vertical.md).
        Its ``calibrated_std`` (corner EKFs only) inflates them from the innovations' windowed NIS
        (:func:`calibrated_vertical_std`; measured coverage in docs/vehicle-vertical.md, "Calibrated stds").

    Notes
    -----
    The EKF is the engine's :func:`~longprofile.statespace.extended_kalman_filter` on
    :func:`vertical_ekf_model`. Absolute velocities (thesis §6.5), all causal:

    * config 1: a "handling" 7-DOF model driven by a_x, a_y, psidd on a flat road plus a leaky "comfort"
      body model driven by the road-induced suspension forces ``F(estimate) - F(handling)``, the relative
      velocity being a causal blend of d/dt of the estimated deflection (< 20 Hz) and the EKF's velocity
      (> 20 Hz); sum, high-pass 0.2 Hz and 2nd-order low-pass 3 Hz / damping 0.4. Wheel:
      ``Z1dot = Z1dot_handling + Z2dot_comfort - dZ21dot_road``, high-pass 0.3 Hz, low-pass 100 Hz
      (deviations from the thesis named in :func:`absolute_velocities`).
    * config 2: body accelerometer -> high-pass 0.3 Hz -> integral -> high-pass 0.1 Hz; wheel
      ``Z2dot - dZ21dot`` -> high-pass 0.5 Hz, low-pass 100 Hz.
    * config 3: wheel accelerometer -> high-pass 0.1 Hz -> integral -> high-pass 0.1 Hz; body
      ``Z1dot + dZ21dot`` -> low-pass 7 Hz.
    """
    _, extended_kalman_filter, block_extended_kalman_filter = _engine()
    if not isinstance(sensors, VerticalSensors):
        raise InputError(f"sensors must be a VerticalSensors (from measure_vertical or sensors_from_frame); "
                         f"got {type(sensors).__name__}.")
    p = params or VerticalVehicleParams()
    config = sensors.config
    s = settings or thesis_filter_settings(config, sensors.dt)
    model = vertical_ekf_model(config, sensors.dt, params=p, settings=s, fused_steps=decentralised,
                               decentralised=decentralised)
    u = vertical_ekf_inputs(sensors, actuator_force=actuator_force, yaw_cutoff=yaw_cutoff, mr_map=mr_map,
                            mr_map_velocity=mr_map_velocity)
    y = sensors.displacement
    if config == 2:
        y = np.hstack([y, sensors.body_accel])
    elif config == 3:
        y = np.hstack([y, sensors.wheel_accel])
    store = True if store_covariances else "variances"
    if decentralised:
        res = block_extended_kalman_filter(model, np.ascontiguousarray(y), u=u, state_blocks=STATE_BLOCKS,
                                           obs_blocks=np.tile(np.arange(4), y.shape[1] // 4), store_covariances=store)
    else:
        res = extended_kalman_filter(model, np.ascontiguousarray(y), u=u, store_covariances=store)
    del y
    x = res.mean
    vel, disp = x[:, 0::4], x[:, 1::4]
    dist, tyre = x[:, 2::4], x[:, 3::4]
    body, wheel = absolute_velocities(sensors, disp, vel, u, params=p, accel_compensation=accel_compensation)
    var = np.diagonal(res.cov, axis1=1, axis2=2) if res.cov is not None else res.variance
    std = np.sqrt(np.maximum(var, 0.0))
    bands = None
    if decentralised and rate_is_calibrated(sensors.dt):
        ivar = res.innovation_variance if res.innovation_cov is None else np.diagonal(res.innovation_cov, axis1=1,
                                                                                        axis2=2)
        nis = innovation_consistency(res.innovation, ivar, round(VERTICAL_NIS_WINDOW / sensors.dt))
        bands = calibrated_vertical_std(std, nis, config, p.tyre_stiffness, sensors.dt)
    if not store_covariances:  # means only: what the states are views of (an hour at 1 kHz: 0.7 GB less)
        res = replace(res, pred_mean=None, innovation=None, log_likelihood_steps=None, variance=None,
                      innovation_variance=None)
    del var
    return VerticalStateEstimate(
        time=sensors.time.copy(), suspension_deflection=disp, suspension_velocity=vel, vehicle_disturbance=dist,
        tyre_deflection=tyre, tyre_force=-p.tyre_stiffness * tyre, body_velocity=body, wheel_velocity=wheel,
        state_std=std, config=config, method="corner-ekf" if decentralised else "full-ekf", filtered=res,
        actuator_force=_actuator_forces(u, vel), calibrated_std=bands)


def _actuator_forces(u, damper_velocity):
    """Actuator forces (T, 4) of the input rows: the known input plus the in-model MR map at ``damper_velocity``."""
    act = u[:, U_ACT:U_ACT + 4].copy()
    vy = u[:, U_MR_VY:U_MR_VY + 1]
    if np.any(vy > 0.0):
        act += np.where(vy > 0.0, u[:, U_MR_FY:U_MR_FY + 4] * np.tanh(damper_velocity / np.where(vy > 0.0, vy, 1.0)),
                        0.0)
    return act


# ------------------------------------------------------------------------------------------------ velocities


def _sos(order, cutoff, btype, dt):
    """Butterworth sections (scipy.signal.butter, through the engine's design cache)."""
    return filter_design("butter", order, cutoff, btype=btype, fs=1.0 / dt, output="sos")


def _second_order_lowpass(f0, zeta, dt):
    """Sections of w0^2 / (s^2 + 2 zeta w0 s + w0^2) by the bilinear transform (scipy's, through the design cache)."""
    w0 = 2 * np.pi * f0
    b, a = filter_design("bilinear", [w0 ** 2], [1.0, 2 * zeta * w0, w0 ** 2], fs=1.0 / dt)
    return filter_design("tf2sos", b, a)


def _integrate(a, dt):
    out = np.zeros_like(a)
    out[1:] = np.cumsum(0.5 * (a[1:] + a[:-1]) * dt, axis=0)
    return out


def _handling_response(u, params, dt):
    """Handling model: the 7-DOF model on a flat road driven only by the measured a_x, a_y, psidd.

    The thesis's handling model (4.9) holds the wheels fixed; ASSUMPTION/deviation: we keep the wheels and
    tyres (the same compiled model as the simulator), whose compliance shifts the roll and pitch modes
    by ~8 %, enough to spoil the comfort/handling superposition in 1-2 Hz manoeuvres.
    Returns the body-corner velocities, suspension deflections, suspension velocities and wheel velocities,
    each (T, 4).
    """
    from ._simulate import simulate_vertical

    sim = simulate_vertical(np.zeros((u.shape[0], 4)), dt, params=params, ax=u[:, 0], ay=u[:, 1],
                            yaw_accel=u[:, 2], substeps=1)
    return sim.body_velocity, sim.suspension_deflection, sim.suspension_velocity, sim.wheel_velocity


#: Config-1 chain constants (see :func:`absolute_velocities`): the crossover between the derivative of the
#: filtered suspension deflection (below) and the EKF's velocity state (above), and the leak of the comfort
#: model's integrator, Hz.
CONFIG1_CROSSOVER_HZ = 20.0
CONFIG1_COMFORT_LEAK_HZ = 0.2


@njit(cache=True)
def _comfort_model(dz, dzd, dz_h, dzd_h, act, corner, coupling, scalars, dt, leak):
    """Thesis comfort model (4.10): body-corner velocity driven by the road-induced suspension forces.

    The road-induced force is ``F(estimated relative motion) - F(handling-model relative motion)`` (the
    exact superposition of the forces; the thesis feeds the difference of the motions into F, which the
    strongly non-linear damper at low speed does not tolerate). The integration is LEAKY,
    ``v[k] = leak v[k-1] + dt a[k]`` with ``leak = exp(-2 pi f_leak dt)`` (DEVIATION: the thesis's model is a
    pure integrator; an open-loop integral of a force error of a few tens of N drifts by tenths of m/s,
    the leak bounds it and removes only what the 0.2 Hz output high-pass removes anyway). ``act`` (T, 4) are
    the known actuator forces (the EKF's input, 0 on a passive car): they act on the body and enter the
    estimated-motion forces (ASSUMPTION: all of the command is "comfort"; the handling model stays passive).
    Returns (T, 4) velocities.
    """
    T = dz.shape[0]
    z2d = np.zeros(4)
    vel = np.zeros((T, 4))
    F = np.empty(4)
    Fh = np.empty(4)
    ks = np.empty(4)
    cd = np.empty(4)
    zero = np.zeros(4)
    for k in range(T):
        suspension_tensions(dz[k], dzd[k], act[k], corner, scalars[1], F, ks, cd)
        suspension_tensions(dz_h[k], dzd_h[k], zero, corner, scalars[1], Fh, ks, cd)
        for c in range(4):
            acc = 0.0
            for e in range(4):
                acc -= coupling[c, e] * (F[e] - Fh[e])
            z2d[c] = leak * z2d[c] + dt * acc
            vel[k, c] = z2d[c]
    return vel


def _blended_relative_velocity(suspension_deflection, suspension_velocity, dt, crossover):
    """Causal complementary blend: ``LP(d/dt dZ21_hat) + HP(dZ21dot_hat)``, first-order filters at ``crossover``.

    The backward difference of the EKF's (measured, ~99.9 %) deflection carries the low frequencies; the EKF's
    velocity state the high ones. Exact (the identity) when the two are consistent.
    """
    d = np.zeros_like(suspension_deflection)
    d[1:] = np.diff(suspension_deflection, axis=0) / dt
    return (sos_filter(_sos(1, crossover, "low", dt), d)
            + sos_filter(_sos(1, crossover, "high", dt), suspension_velocity))


def absolute_velocities(sensors: VerticalSensors, suspension_deflection, suspension_velocity, u, *,
                        params: VerticalVehicleParams, accel_compensation=(0.0, 0.0)):
    """Body and wheel vertical velocities (T, 4) rebuilt outside the EKF per configuration (thesis §6.5).

    All chains are causal (real time). Config 1 (displacement sensors only; DEVIATIONS from the thesis's
    §4.3.4.4 named): the actuator forces of the comfort model are the known inputs ``u[:, U_ACT:U_ACT+4]``
    plus, when the model carries the MR map (``mr_map_velocity="filter"``), that map at the causal
    displacement-derivative velocity (:func:`damper_velocity_from_displacement`; at the EKF's or the blended
    velocity the track-test body velocity collapses, docs "MagneRide car"); the relative velocity fed to the
    chain is :func:`_blended_relative_velocity` (crossover :data:`CONFIG1_CROSSOVER_HZ`): in driver manoeuvres
    the config-1 EKF's velocity state departs from the derivative of its own deflection in the 0-3 Hz band
    (track test: eps 25 % vs 99.9 % after a 3 Hz low-pass), and the damper slope (~2e4 N s/m near 0) turns
    that into body forces; the comfort model integrates with a 0.2 Hz leak (:data:`CONFIG1_COMFORT_LEAK_HZ`);
    the wheel velocity is ``Z1dot_handling + Z2dot_comfort - dZ21dot_road`` (the thesis keeps the road-induced
    relative velocity only; the handling term adds the manoeuvre load-transfer motion of the wheel).
    """
    dt = sensors.dt
    config = sensors.config
    gx, gy = (float(g) for g in accel_compensation)
    comp = gx * sensors.ax[:, None] + gy * sensors.ay[:, None]
    if config == 1:
        corner, coupling, scalars = vertical_params_arrays(params)
        hv, hdz, hdzd, hw = _handling_response(u, params, dt)
        vel = _blended_relative_velocity(np.asarray(suspension_deflection, float),
                                         np.asarray(suspension_velocity, float), dt, CONFIG1_CROSSOVER_HZ)
        leak = math.exp(-2 * math.pi * CONFIG1_COMFORT_LEAK_HZ * dt)
        # known actuator input + the in-model MR map (mr_map_velocity="filter") evaluated, for this open-loop
        # chain, at the displacement-derivative velocity (docs: "MagneRide car", in-filter map)
        u = np.asarray(u, dtype=float)
        act = u[:, U_ACT:U_ACT + 4]
        if np.any(u[:, U_MR_VY] > 0.0):
            act = _actuator_forces(u, damper_velocity_from_displacement(sensors.displacement, dt))
        act = np.ascontiguousarray(act)
        cv = _comfort_model(np.ascontiguousarray(suspension_deflection, dtype=float), np.ascontiguousarray(vel),
                            hdz, hdzd, act, corner, coupling, scalars, dt, leak)
        road_dzd = vel - hdzd
        body = sos_filter(_sos(1, 0.2, "high", dt), hv + cv)
        body = sos_filter(_second_order_lowpass(3.0, 0.4, dt), body)
        wheel = sos_filter(_sos(1, 0.3, "high", dt), hw + cv - road_dzd)
        wheel = sos_filter(_sos(1, 100.0, "low", dt), wheel)
    elif config == 2:
        a = sensors.body_accel - comp
        a = sos_filter(_sos(1, 0.3, "high", dt), a)
        body = sos_filter(_sos(1, 0.1, "high", dt), _integrate(a, dt))
        wheel = sos_filter(_sos(1, 0.5, "high", dt), body - suspension_velocity)
        wheel = sos_filter(_sos(1, 100.0, "low", dt), wheel)
    else:
        a = sensors.wheel_accel - comp
        a = sos_filter(_sos(1, 0.1, "high", dt), a)
        wheel = sos_filter(_sos(1, 0.1, "high", dt), _integrate(a, dt))
        body = sos_filter(_sos(1, 7.0, "low", dt), wheel + suspension_velocity)
    return body, wheel


def smooth_vertical_states(estimate: VerticalStateEstimate, *, params: VerticalVehicleParams | None = None,
                           settings: CornerFilterSettings | None = None) -> VerticalStateEstimate:
    """Offline (fixed-interval) counterpart of :func:`estimate_vertical_states`: extended RTS smoothing.

    Runs the engine's :func:`~longprofile.statespace.extended_rts_smoother` on the filter output (with the
    linearisations the filter used; block-diagonal for the per-corner filters, so the smoother is per corner
    too). Relative states, disturbance and tyre deflection/force are smoothed; the absolute velocities are
    those of the real-time chains (copied).

    Parameters
    ----------
    estimate : VerticalStateEstimate
        Output of :func:`estimate_vertical_states` (its ``filtered`` field must hold covariances).
    params, settings
        The ones the filter ran with (defaults: thesis values).

    Returns
    -------
    VerticalStateEstimate
        ``method`` gains the suffix ``"+rts"``; ``filtered`` is the engine's SmootherResult.
    """
    from ...statespace import extended_rts_smoother

    if not isinstance(estimate, VerticalStateEstimate):
        raise InputError(f"estimate must be a VerticalStateEstimate; got {type(estimate).__name__}.")
    if getattr(estimate.filtered, "cov", None) is None:
        raise InputError("smooth_vertical_states needs the filter's covariance histories; this estimate was made "
                         "without them (estimate_vertical_log, or store_covariances=False): run "
                         "estimate_vertical_states(..., store_covariances=True).")
    p = params or VerticalVehicleParams()
    dt = float(estimate.time[1] - estimate.time[0])
    model = vertical_ekf_model(estimate.config, dt, params=p, settings=settings)
    sm = extended_rts_smoother(model, estimate.filtered)
    x = sm.mean
    std = np.sqrt(np.maximum(np.diagonal(sm.cov, axis1=1, axis2=2), 0.0))
    return VerticalStateEstimate(
        time=estimate.time, suspension_deflection=x[:, 1::4], suspension_velocity=x[:, 0::4],
        vehicle_disturbance=x[:, 2::4], tyre_deflection=x[:, 3::4], tyre_force=-p.tyre_stiffness * x[:, 3::4],
        body_velocity=estimate.body_velocity, wheel_velocity=estimate.wheel_velocity, state_std=std,
        config=estimate.config, method=estimate.method + "+rts", filtered=sm, actuator_force=estimate.actuator_force)


def estimate_vertical_states_linear(sensors: VerticalSensors, *, params: VerticalVehicleParams | None = None,
                                    settings: CornerFilterSettings | None = None, smooth: bool = False,
                                    yaw_cutoff: float = 5.0) -> VerticalStateEstimate:
    """Centralised full-car LINEAR Kalman filter (or RTS smoother) on :func:`vertical_linear_model`.

    The comparison point of the thesis's EKF: same states, sensors and noise settings, but the spring and
    damper linearised at rest and all corners estimated jointly by the engine's
    :func:`~longprofile.statespace.kalman_filter` (``smooth=True``: :func:`~longprofile.statespace.rts_smoother`,
    offline). Absolute velocities are rebuilt with the same chains as :func:`estimate_vertical_states`.

    Returns
    -------
    VerticalStateEstimate
        ``method`` = ``"linear-kf"`` or ``"linear-rts"``.
    """
    from ...statespace import kalman_filter, rts_smoother

    if not isinstance(sensors, VerticalSensors):
        raise InputError(f"sensors must be a VerticalSensors; got {type(sensors).__name__}.")
    p = params or VerticalVehicleParams()
    config = sensors.config
    model = vertical_linear_model(config, sensors.dt, params=p, settings=settings)
    u = vertical_ekf_inputs(sensors, yaw_cutoff=yaw_cutoff)
    y = sensors.displacement
    if config == 2:
        y = np.hstack([y, sensors.body_accel])
    elif config == 3:
        y = np.hstack([y, sensors.wheel_accel])
    res = kalman_filter(model, y, u=u[:, :7])
    out = rts_smoother(model, res) if smooth else res
    x = out.mean
    vel, disp = x[:, 0::4], x[:, 1::4]
    body, wheel = absolute_velocities(sensors, disp, vel, u, params=p)
    std = np.sqrt(np.maximum(np.diagonal(out.cov, axis1=1, axis2=2), 0.0))
    return VerticalStateEstimate(
        time=sensors.time.copy(), suspension_deflection=disp, suspension_velocity=vel, vehicle_disturbance=x[:, 2::4],
        tyre_deflection=x[:, 3::4], tyre_force=-p.tyre_stiffness * x[:, 3::4], body_velocity=body,
        wheel_velocity=wheel, state_std=std, config=config, method="linear-rts" if smooth else "linear-kf",
        filtered=out)


_FIELDS = (("suspension_deflection", "dz21", "m"), ("suspension_velocity", "dz21dot", "m/s"),
           ("vehicle_disturbance", "disturbance", "N"), ("tyre_deflection", "dz10", "m"),
           ("tyre_force", "tyre_force", "N"), ("body_velocity", "body_velocity", "m/s"),
           ("wheel_velocity", "wheel_velocity", "m/s"))


def estimate_to_frame(estimate: VerticalStateEstimate) -> pd.DataFrame:
    """One row per sample: ``time`` and ``<quantity>_<corner>`` for the seven estimated quantities (SI units).

    With ``estimate.calibrated_std`` (the corner EKFs), also ``<quantity>_<corner>_std`` for the deflection, damper
    velocity, tyre deflection and tyre force: the calibrated stds (:func:`calibrated_vertical_std`; a 90 % band is
    +-1.645 std). The disturbance and the body and wheel velocities have none (docs/vehicle-vertical.md).
    """
    import pandas as pd

    cols = {"time": estimate.time}
    bands = estimate.calibrated_std
    for attr, prefix, _unit in _FIELDS:
        arr = getattr(estimate, attr)
        for c, name in enumerate(CORNER_NAMES):
            cols[f"{prefix}_{name}"] = arr[:, c]
        std = getattr(bands, attr, None) if bands is not None else None
        if std is not None:
            for c, name in enumerate(CORNER_NAMES):
                cols[f"{prefix}_{name}_std"] = std[:, c]
    return pd.DataFrame(cols)
