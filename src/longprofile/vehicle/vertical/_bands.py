"""Calibrated standard deviations of the corner EKFs' states (session 41, issue 13 §1).

The corner EKFs' own state stds (:attr:`VerticalStateEstimate.state_std`) are the filter's model stds: the thesis's
noise settings (:func:`thesis_filter_settings`) were tuned for one road, so on rougher roads the filter's errors are
3-10 times its stds (session 40: the 90 % band held the truth on 17-44 % of the samples). How much too small they are
shows in the innovations: their normalized squares (NIS, expectation 1 when the filter's noise model holds) grow with
the road's roughness (1-700 from class A to E, session 35). :func:`calibrated_vertical_std` turns the windowed NIS of
each corner's sensors into a per-sample inflation of its states' stds, with a map fitted on simulated drives
(``benchmarks/bench_vertical_calibration.py``; docs/vehicle-vertical.md, "Calibrated stds").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import InputError

__all__ = ["VerticalStateStd", "innovation_consistency", "calibrated_vertical_std", "VERTICAL_NIS_WINDOW",
           "VERTICAL_STD_CALIBRATION", "VERTICAL_STD_RATE_RANGE", "CALIBRATED_STATES", "rate_is_calibrated"]

#: Length of the centred moving window of the NIS, s (as ``SlopeUncertainty.nis_window`` of ``vehicle slope``).
VERTICAL_NIS_WINDOW = 1.0

#: The states that get a calibrated std: name -> column of the corner state [dZ21dot, dZ21, P, dZ10]. The
#: disturbance P (a fictitious force standing for everything the corner model lacks) has no truth to calibrate
#: against; the body and wheel velocities come from chains outside the filter (no covariance).
CALIBRATED_STATES = {"suspension_velocity": 0, "suspension_deflection": 1, "tyre_deflection": 3}

#: The inflation map per sensor configuration and state: ``(a, b_d, b_a, b_r)`` in
#: ``std = state_std * max(1, exp(a) * kd ** b_d * ka ** b_a * (dt / 1 ms) ** b_r)``, kd and ka the windowed NIS of
#: the corner's displacement sensor and accelerometer (configuration 1: no accelerometer, b_a unused), dt the
#: sample period. Fitted by ``benchmarks.bench_vertical_calibration.fit`` on the tuning drives
#: (``collect(300, seed=1)``): slopes by least squares of log|z| on log kd, log ka, log dt, then a by bisection for
#: 90 % pooled coverage (session 41). Not the textbook ``sqrt(NIS)`` (a = 0, b_d = 0.5): at NIS ~ 1 the
#: displacement sensor's 0.29 mm quantisation hides the state errors of a smooth road, so a > 0; and the per-step
#: NIS depends on the rate (b_r -0.5 to -0.8: without it the tuning drives at 2 kHz were covered at 71-85 %, those
#: at 500 Hz at 97-99 %).
VERTICAL_STD_CALIBRATION = {
    1: {"suspension_velocity": (0.85, 0.58, 0.0, -0.55), "suspension_deflection": (0.62, 0.52, 0.0, -0.52),
        "tyre_deflection": (0.54, 0.60, 0.0, -0.54)},
    2: {"suspension_velocity": (0.94, 0.26, 0.33, -0.75), "suspension_deflection": (0.57, 0.38, 0.15, -0.53),
        "tyre_deflection": (0.73, 0.25, 0.35, -0.79)},
    3: {"suspension_velocity": (1.11, 0.21, 0.20, -0.56), "suspension_deflection": (1.10, 0.30, 0.14, -0.57),
        "tyre_deflection": (1.04, 0.21, 0.21, -0.50)},
}

#: Sample rates the map was fitted on, Hz: 500 Hz, 1 kHz and 2 kHz logs. Outside (the reader takes 500 Hz-100 kHz)
#: :func:`estimate_vertical_states` gives no calibrated std (an extrapolation of the rate term is not measured).
VERTICAL_STD_RATE_RANGE = (500.0, 2000.0)

_NIS_FLOOR = 1e-3  # a window of exactly predicted innovations (e.g. a saturated sensor) must not give log(0)


@dataclass(frozen=True, eq=False)
class VerticalStateStd:
    """Calibrated stds per corner (FL, FR, RL, RR), one row per sample, SI units.

    Attributes
    ----------
    suspension_deflection, suspension_velocity, tyre_deflection, tyre_force : (T, 4) ndarray
        m, m/s, m, N (the tyre force's is the tyre deflection's times the filter's tyre stiffness).
    nis : (T, m) ndarray
        The windowed NIS of each sensor channel (the filter's observation order: four displacements, then four
        accelerometers in configurations 2 and 3). The factor applied to a state's model std (>= 1) is its
        calibrated std over :attr:`VerticalStateEstimate.state_std`.
    """

    suspension_deflection: np.ndarray
    suspension_velocity: np.ndarray
    tyre_deflection: np.ndarray
    tyre_force: np.ndarray
    nis: np.ndarray


def innovation_consistency(innovation, innovation_variance, window: int) -> np.ndarray:
    """Windowed normalized innovation squared, (T, m): mean of ``nu**2 / S`` over a centred window of ``window`` samples.

    Its expectation is 1 where the filter's noise model holds (Bar-Shalom, Li & Kirubarajan, *Estimation with
    Applications to Tracking and Navigation*, 2001, §5.4: the NIS test). Missing components count as 1 (no evidence).
    """
    from scipy.ndimage import uniform_filter1d

    nu = np.asarray(innovation, dtype=float)
    s = np.asarray(innovation_variance, dtype=float)
    if nu.shape != s.shape or nu.ndim != 2:
        raise InputError(f"innovation and innovation_variance must both have shape (T, m); got {nu.shape} and "
                         f"{s.shape}.")
    with np.errstate(invalid="ignore", divide="ignore"):
        nis = np.square(nu) / s
    nis = np.where(np.isfinite(nis), nis, 1.0)
    return uniform_filter1d(nis, size=max(int(window), 1), axis=0, mode="nearest")


def rate_is_calibrated(dt: float) -> bool:
    """True if a sample period ``dt`` (s) is within :data:`VERTICAL_STD_RATE_RANGE` (relative tolerance 1e-6)."""
    lo, hi = VERTICAL_STD_RATE_RANGE
    return lo * (1 - 1e-6) <= 1.0 / dt <= hi * (1 + 1e-6)


def calibrated_vertical_std(state_std, nis, config: int, tyre_stiffness: float, dt: float = 1e-3) -> VerticalStateStd:
    """Calibrated stds of the corner EKFs' states from their model stds and the windowed NIS (session 41).

    ``std = state_std * g``, ``g = max(1, exp(a) kd**b_d ka**b_a (dt / 1 ms)**b_r)`` per sample and corner, kd and
    ka the corner's windowed NIS (:func:`innovation_consistency`) of its displacement sensor and accelerometer,
    ``(a, b_d, b_a, b_r)`` of :data:`VERTICAL_STD_CALIBRATION` (a model-error inflation from innovation consistency,
    the map fitted on simulated drives). ASSUMPTION: the log's errors relative to the filter's model are like those
    of the calibration families (ISO 8608 classes A-D, 5-35 m/s, car parameters +-20 %, sensor noise x0.5-4,
    0.5-2 kHz; docs/vehicle-vertical.md); the map does not know a car or a sensor unlike those.

    Parameters
    ----------
    state_std : (T, 16) ndarray
        The filter's model stds of the stacked corner states [dZ21dot, dZ21, P, dZ10] x 4.
    nis : (T, m) ndarray
        Windowed NIS of the filter's observations (m = 4 in configuration 1, 8 in configurations 2 and 3).
    config : {1, 2, 3}
    tyre_stiffness : float
        The filter's k_t, N/m (tyre force = -k_t dZ10).
    dt : float
        Sample period, s (fitted for 0.5-2 ms: :data:`VERTICAL_STD_RATE_RANGE`).
    """
    if config not in VERTICAL_STD_CALIBRATION:
        raise InputError(f"config must be 1, 2 or 3 (thesis sensor configurations); got {config!r}.")
    sd = np.asarray(state_std, dtype=float)
    k = np.asarray(nis, dtype=float)
    if sd.ndim != 2 or sd.shape[1] != 16 or k.shape != (sd.shape[0], 4 if config == 1 else 8):
        raise InputError(f"state_std must be (T, 16) and nis (T, {4 if config == 1 else 8}); got {sd.shape} and "
                         f"{k.shape}.")
    log_d = np.log(np.maximum(k[:, :4], _NIS_FLOOR))
    log_a = np.log(np.maximum(k[:, 4:], _NIS_FLOOR)) if config > 1 else 0.0
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"dt must be a positive sample period, s; got {dt!r}.")
    log_rate = math.log(dt / 1e-3)
    out = {}
    for name, col in CALIBRATED_STATES.items():
        a, b_d, b_a, b_r = VERTICAL_STD_CALIBRATION[config][name]
        out[name] = sd[:, col::4] * np.maximum(np.exp(a + b_r * log_rate + b_d * log_d + b_a * log_a), 1.0)
    if not (math.isfinite(tyre_stiffness) and tyre_stiffness > 0):
        raise InputError(f"tyre_stiffness must be a positive number, N/m; got {tyre_stiffness!r}.")
    return VerticalStateStd(suspension_deflection=out["suspension_deflection"],
                            suspension_velocity=out["suspension_velocity"], tyre_deflection=out["tyre_deflection"],
                            tyre_force=tyre_stiffness * out["tyre_deflection"], nis=k)
