"""Scoring of vertical state estimates and the reproduction of the thesis's result tables 4.4 and 4.5.

The thesis's figure of merit (§4.2, digest §6.2) is ``eps = 100 (1 - sum e^2 / sum ref^2)`` per variable
(100 = perfect, 0 = errors as large as the signal). Its references were measured signals. Two reference sets
here: ``"truth"`` -- the simulator's true states, the absolute velocities high-passed at 0.2 Hz with a
zero-phase filter as the thesis's integrated-accelerometer references were; ``"thesis"`` -- the references
rebuilt from simulated MEASURED signals with the thesis's processing (:func:`thesis_references`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from ..._validation import as_float_array, require_positive
from ...errors import InputError, ShapeError
from ...statespace import filter_design, sos_filtfilt
from ._estimate import MR_MAP_FORCE_ERROR, VerticalStateEstimate, estimate_vertical_states, nominal_mr_map
from ._model import MR_MAP_VELOCITIES
from ._params import MRDamperParams, VerticalVehicleParams
from ._simulate import (
    VerticalSimulation,
    measure_vertical,
    simulate_vertical,
    steering_sine_manoeuvre,
    wheel_road_inputs,
)

__all__ = ["epsilon_score", "score_vertical_estimate", "THESIS_BENCH_TABLE", "THESIS_TRACK_TABLE",
           "reproduce_thesis_tables", "thesis_references", "VERTICAL_VARIABLES", "REFERENCES", "CARS"]

VERTICAL_VARIABLES = ("suspension_deflection", "suspension_velocity", "tyre_force", "body_velocity",
                      "wheel_velocity")

#: Thesis Table 4.4, bench "road input" test, eps (%) per configuration (front-left corner).
THESIS_BENCH_TABLE = {
    1: {"suspension_deflection": 97.46, "suspension_velocity": 67.17, "tyre_force": 47.4, "body_velocity": 18.3,
        "wheel_velocity": 21.8},
    2: {"suspension_deflection": 97.53, "suspension_velocity": 67.7, "tyre_force": 51.93, "body_velocity": 49.48,
        "wheel_velocity": 46.89},
    3: {"suspension_deflection": 96.76, "suspension_velocity": 81.03, "tyre_force": 69.66, "body_velocity": 43.23,
        "wheel_velocity": 65.22},
}
#: Thesis Table 4.5, track "driver manoeuvre" test (no tyre-force reference on the track).
THESIS_TRACK_TABLE = {
    1: {"suspension_deflection": 98.2, "suspension_velocity": 20.3, "body_velocity": 7.5, "wheel_velocity": 14.4},
    2: {"suspension_deflection": 98.44, "suspension_velocity": 24.33, "body_velocity": 27.66, "wheel_velocity": 30.37},
    3: {"suspension_deflection": 98.24, "suspension_velocity": 51.15, "body_velocity": 22.73, "wheel_velocity": 57.54},
}


def epsilon_score(reference, estimate, *, axis: int = 0) -> np.ndarray | float:
    """The thesis's criterion ``100 (1 - sum (ref - est)^2 / sum ref^2)`` along ``axis`` (thesis §4.2).

    Parameters
    ----------
    reference, estimate : array_like, same shape
        Reference and estimated signals (any unit, the same for both).
    axis : int
        Sample axis (default 0).

    Returns
    -------
    float or ndarray
        eps in %, one per remaining index (100 = perfect; negative when the error exceeds the signal).

    Raises
    ------
    ShapeError
        If the shapes differ.
    InputError
        If the reference is identically zero or contains non-finite values.
    """
    r = as_float_array("reference", reference, allow_nan=False)
    e = as_float_array("estimate", estimate, allow_nan=False)
    if r.shape != e.shape:
        raise ShapeError(f"reference and estimate must have the same shape; got {r.shape} and {e.shape}.")
    den = np.sum(r ** 2, axis=axis)
    if np.any(den == 0):
        raise InputError("the reference is identically zero along the sample axis; eps is undefined.")
    out = 100.0 * (1.0 - np.sum((r - e) ** 2, axis=axis) / den)
    return float(out) if np.ndim(out) == 0 else out


#: Reference sets of :func:`reproduce_thesis_tables`.
REFERENCES = ("truth", "thesis")
#: Simulated cars of :func:`reproduce_thesis_tables`: the passive car, or the MR-damper ("MagneRide") car.
CARS = ("ideal", "magneride")


def _zero_phase(x, order, cutoff, btype, dt):
    """Zero-phase Butterworth filtering along time (scipy.signal.sosfiltfilt's default odd pad, bit for bit)."""
    return sos_filtfilt(filter_design("butter", order, cutoff, btype=btype, fs=1.0 / dt, output="sos"), x)


def thesis_references(sim: VerticalSimulation, *, displacement, body_accel, wheel_accel,
                      lowpass: float = 60.0) -> dict:
    """The thesis's evaluation references (§4.2, digest §6.2) rebuilt from MEASURED signals of a simulated run.

    Every reference is post-filtered by a 2nd-order Butterworth low-pass at ``lowpass`` Hz, zero phase
    (thesis: "2nd-order low-pass 60 Hz, zero phase"). Then, per variable:

    * ``suspension_deflection``: the measured (noisy, 10-bit) displacement signal itself;
    * ``suspension_velocity``: trapezoidal integral of (body-corner accelerometer - wheel accelerometer),
      1st-order high-pass 0.3 Hz (thesis: "integral of the accelerometer difference, high-pass 0.3 Hz");
      ASSUMPTION: the high-pass is zero phase, as the other post-processing;
    * ``tyre_force``: the bench plate load cell; ASSUMPTION: exact (the true dynamic tyre load), the thesis
      gives no load-cell error;
    * ``body_velocity``, ``wheel_velocity``: trapezoidal integral of the body-corner / hub accelerometer,
      1st-order high-pass 0.2 Hz, zero phase (thesis Ch. 2, "numerical reference").

    Parameters
    ----------
    sim : VerticalSimulation
        The run (only ``dt`` and ``tyre_force`` are used: the rest comes from the measured signals).
    displacement : (T, 4) array_like
        Measured suspension deflections, m (e.g. ``measure_vertical(sim, c).displacement``).
    body_accel, wheel_accel : (T, 4) array_like
        Measured body-corner and wheel accelerometers, m/s^2 (ASSUMPTION: the very signals configurations 2
        and 3 feed their filters -- the thesis evaluated every configuration offline on ONE measured record,
        so its config-2 filter input and its body-velocity reference were the same sensor).

    Returns
    -------
    dict
        ``{variable: (T, 4) ndarray}`` for the five :data:`VERTICAL_VARIABLES`.
    """
    dt = sim.dt
    T = sim.time.shape[0]
    arrays = {}
    for name, val in (("displacement", displacement), ("body_accel", body_accel), ("wheel_accel", wheel_accel)):
        a = as_float_array(name, val, ndim=2, allow_nan=False)
        if a.shape != (T, 4):
            raise ShapeError(f"{name} must have shape (T, 4) = ({T}, 4) like the simulation; got {a.shape}.")
        arrays[name] = a
    from ._estimate import _integrate

    ba, wa = arrays["body_accel"], arrays["wheel_accel"]
    raw = {"suspension_deflection": arrays["displacement"],
           "suspension_velocity": _zero_phase(_integrate(ba - wa, dt), 1, 0.3, "high", dt),
           "tyre_force": sim.tyre_force,
           "body_velocity": _zero_phase(_integrate(ba, dt), 1, 0.2, "high", dt),
           "wheel_velocity": _zero_phase(_integrate(wa, dt), 1, 0.2, "high", dt)}
    return {k: _zero_phase(v, 2, lowpass, "low", dt) for k, v in raw.items()}


def _reference(sim: VerticalSimulation, name: str):
    val = getattr(sim, name)
    if name in ("body_velocity", "wheel_velocity"):
        sos = filter_design("butter", 1, 0.2, btype="high", fs=1.0 / sim.dt, output="sos")
        val = sos_filtfilt(sos, val)
    return val


def score_vertical_estimate(sim: VerticalSimulation, estimate: VerticalStateEstimate, *,
                            variables=VERTICAL_VARIABLES, skip: float = 1.0, references: dict | None = None) -> dict:
    """eps (%) of each estimated variable against the simulation's truth (or given references), per corner.

    Parameters
    ----------
    sim : VerticalSimulation
    estimate : VerticalStateEstimate
    variables : iterable of str
        Among :data:`VERTICAL_VARIABLES`.
    skip : float
        Initial transient left out of the score, s (filter convergence and high-pass start-up).
    references : dict, optional
        ``{variable: (T, 4) array}`` replacing the truth, e.g. :func:`thesis_references`.

    Returns
    -------
    dict
        ``{variable: (4,) ndarray of eps per corner FL, FR, RL, RR}``.
    """
    if sim.time.shape != estimate.time.shape:
        raise ShapeError(f"simulation ({sim.time.shape[0]} samples) and estimate ({estimate.time.shape[0]}) differ "
                         "in length.")
    k0 = int(round(skip / sim.dt))
    if k0 >= sim.time.shape[0] - 2:
        raise InputError(f"skip = {skip} s leaves no samples of the {sim.time[-1]:g} s record.")
    out = {}
    for v in variables:
        if v not in VERTICAL_VARIABLES:
            raise InputError(f"unknown variable {v!r}; choose among {VERTICAL_VARIABLES}.")
        ref = _reference(sim, v) if references is None or v not in references else references[v]
        out[v] = epsilon_score(np.asarray(ref)[k0:], getattr(estimate, v)[k0:])
    return out


def _bench_run(duration, seed, true_params, dt, mr_damper=None):
    from ...road import iso8608_profile

    p = true_params
    speed = 20.0
    length = speed * duration + p.wheelbase + 10.0
    prof = iso8608_profile(length, 0.05, "C", rng=seed, tracks=("left", "right"))
    road = wheel_road_inputs(prof, speed, dt, duration=duration, params=p)
    return simulate_vertical(road, dt, params=p, mr_damper=mr_damper)


def _track_run(duration, seed, true_params, dt, mr_damper=None):
    from ...road import iso8608_profile

    p = true_params
    speed = 80 / 3.6
    length = speed * duration + p.wheelbase + 10.0
    prof = iso8608_profile(length, 0.05, "A", rng=seed, tracks=("left", "right"))
    road = wheel_road_inputs(prof, speed, dt, duration=duration, params=p)
    ax, ay, psidd = steering_sine_manoeuvre(dt, duration=(road.shape[0] - 1) * dt, speed=speed)
    return simulate_vertical(road, dt, params=p, ax=ax, ay=ay, yaw_accel=psidd, mr_damper=mr_damper)


def reproduce_thesis_tables(*, duration: float = 20.0, seed: int = 0, true_params: VerticalVehicleParams | None = None,
                            filter_params: VerticalVehicleParams | None = None, dt: float = 1e-3,
                            decentralised: bool = True, reference: str = "truth", car: str = "ideal",
                            mr_damper: MRDamperParams | None = None, map_force_error: float = MR_MAP_FORCE_ERROR,
                            mr_map_velocity: str = "displacement", progress=None) -> pd.DataFrame:
    """Re-run the thesis's two evaluation tests on the simulator for configurations 1-3 and score them.

    * bench "road input" test (Table 4.4): a 4-poster replays an ISO 8608 class C road driven at 20 m/s
      (rear plates delayed by wheelbase / V), no driver input;
    * track "driver manoeuvre" test (Table 4.5): 80 km/h, steering sine 0 -> 2 Hz
      (:func:`steering_sine_manoeuvre`) on a smooth class A track.

    Parameters
    ----------
    duration : float
        Length of each test, s.
    seed : int
        Seed of the roads and sensor noises.
    true_params : VerticalVehicleParams, optional
        The simulated car. Default: the thesis set plus 100 N of suspension friction, the unmodelled effect the
        thesis reports (§1.2.2) — without any model error the simulator is far kinder than a real car.
    filter_params : VerticalVehicleParams, optional
        The filter's model (default: the thesis set).
    dt : float
        Sample period, s.
    decentralised : bool
        Thesis per-corner EKFs (True) or the centralised full-car EKF (False).
    reference : {"truth", "thesis"}
        What the estimates are scored against: the simulator's true states (default), or the references the
        thesis built from measured signals (:func:`thesis_references`: integrated accelerometers, the
        measured displacement, the load cell, 60 Hz zero-phase low-pass). The accelerometers of the
        reference are the very signals the config-2 (body) and config-3 (wheel) filters receive.
    car : {"ideal", "magneride"}
        ``"ideal"`` (default): the passive simulated car above. ``"magneride"``: the same car with an MR damper
        per corner driven by a skyhook controller (``simulate_vertical(mr_damper=...)``, thesis §1.2.4); the
        filters receive the logged currents turned into actuator forces by the filter's NOMINAL map
        (:func:`nominal_mr_map`: static, force scale off by ``map_force_error``) evaluated at the damper velocity
        chosen by ``mr_map_velocity``.
    mr_damper : MRDamperParams, optional
        The true MR damper of the MagneRide car (default :class:`MRDamperParams`()); ignored for ``"ideal"``.
    map_force_error : float
        Relative force-scale error of the filter's map (default :data:`MR_MAP_FORCE_ERROR` = 0.12).
    mr_map_velocity : {"displacement", "filter"}
        MagneRide car: the damper velocity the filter's map is evaluated at -- the causal derivative of the
        measured displacement (default, a precomputed input) or the filter's own velocity state (the map
        inside the model, as the thesis; ``estimate_vertical_states(mr_map_velocity="filter")``).
    progress : callable, optional
        Called as ``progress(done, total)`` after each of the 6 (test, configuration) runs.

    Returns
    -------
    pandas.DataFrame
        Columns ``test`` ("bench"/"track"), ``config``, ``variable``, ``epsilon`` (ours, front-left corner, %),
        ``epsilon_all_corners`` (mean over the four corners), ``thesis`` (Table 4.4/4.5 value, NaN where the
        thesis has none), ``reference``, ``car``.
    """
    if reference not in REFERENCES:
        raise InputError(f"reference must be one of {REFERENCES}; got {reference!r}.")
    if car not in CARS:
        raise InputError(f"car must be one of {CARS}; got {car!r}.")
    if mr_map_velocity not in MR_MAP_VELOCITIES:
        raise InputError(f"mr_map_velocity must be one of {MR_MAP_VELOCITIES}; got {mr_map_velocity!r}.")
    mr = None
    mr_map = None
    if car == "magneride":
        mr = mr_damper if mr_damper is not None else MRDamperParams()
        if not isinstance(mr, MRDamperParams):
            raise InputError(f"mr_damper must be an MRDamperParams; got {type(mr).__name__}.")
        mr_map = nominal_mr_map(mr, force_error=map_force_error)
    duration = require_positive("duration", duration)
    tp = true_params or dataclasses.replace(VerticalVehicleParams(), suspension_friction=100.0)
    rows = []
    done = 0
    for test, runner, table in (("bench", _bench_run, THESIS_BENCH_TABLE), ("track", _track_run, THESIS_TRACK_TABLE)):
        sim = runner(duration, seed, tp, dt, mr)
        sensors = {config: measure_vertical(sim, config, rng=seed + 10 * config) for config in (1, 2, 3)}
        for config in (1, 2, 3):
            sens = sensors[config]
            est = estimate_vertical_states(sens, params=filter_params, decentralised=decentralised,
                                           mr_map=mr_map, mr_map_velocity=mr_map_velocity)
            variables = VERTICAL_VARIABLES if test == "bench" else tuple(v for v in VERTICAL_VARIABLES
                                                                         if v != "tyre_force")
            refs = None
            if reference == "thesis":
                refs = thesis_references(sim, displacement=sens.displacement, body_accel=sensors[2].body_accel,
                                         wheel_accel=sensors[3].wheel_accel)
            scores = score_vertical_estimate(sim, est, variables=variables, references=refs)
            for v in variables:
                rows.append({"test": test, "config": config, "variable": v, "epsilon": float(scores[v][0]),
                             "epsilon_all_corners": float(np.mean(scores[v])),
                             "thesis": table[config].get(v, np.nan), "reference": reference, "car": car})
            done += 1
            if progress is not None:
                progress(done, 6)
    return pd.DataFrame(rows)
