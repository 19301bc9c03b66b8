"""The car as a road profilometer: the road under each wheel from the suspension sensors (issue 7, "beyond").

Road height under a wheel = wheel height - tyre deflection, ``Z0 = Z1 - dZ10``. The wheel height comes
from the wheel accelerometer integrated twice (configuration 3) or from the reconstructed wheel velocity
integrated once (configurations 1, 2); the tyre deflection from the corner EKF. Offline, the integrations
are high-passed with a ZERO-PHASE filter (the profile is computed after the run, unlike the real-time
velocities). Stations are ``V t``: the car must drive at a known constant speed.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from .._validation import require_positive
from ..errors import InputError
from ._vertical_estimate import VerticalStateEstimate
from ._vertical_sim import VerticalSensors

__all__ = ["road_profile_from_suspension"]


def _integrate(a, dt):
    out = np.zeros_like(a)
    out[1:] = np.cumsum(0.5 * (a[1:] + a[:-1]) * dt, axis=0)
    return out


def road_profile_from_suspension(sensors: VerticalSensors, estimate: VerticalStateEstimate, speed: float, *,
                                 highpass: float = 0.2, axle: str = "front", smoothed: bool = True,
                                 params=None):
    """Longitudinal profile of the two wheel paths measured by the car's suspension sensors.

    Parameters
    ----------
    sensors : VerticalSensors
        The sensor record (configuration 3 uses its wheel accelerometers).
    estimate : VerticalStateEstimate
        The corner-EKF estimate of the same record (tyre deflection; wheel velocity for configs 1, 2).
    speed : float
        Constant vehicle speed, m/s (stations = speed * time).
    highpass : float
        Cut-off of the zero-phase 2nd-order Butterworth high-pass applied after each integration, Hz
        (default 0.2 Hz: wavelengths up to V / 0.2 = 100 m at 20 m/s, beyond the IRI's 30 m).
    axle : {"front", "rear"}
        Which pair of wheels gives the two tracks (left, right).
    smoothed : bool
        Use the RTS-smoothed tyre deflection (:func:`smooth_vertical_states`, default True: the profile is an
        offline product, and smoothing cuts the IRI error on smooth roads from ~10 % to ~3 %).
    params : VerticalVehicleParams, optional
        The filter's parameters (for the smoother; default thesis set).

    Returns
    -------
    longprofile.road.Profile
        Tracks ``("left", "right")``, elevations in m relative to a zero mean, stations from 0.

    Notes
    -----
    ``Z0 = HP(integral(HP(integral(a_wheel)))) - dZ10_hat`` (config 3) or ``HP(integral(Z1dot_hat)) - dZ10_hat``.
    Errors: accelerometer quantisation (0.48 m/s^2) integrated twice, tyre-deflection estimation error, and
    the tyre's enveloping of short bumps (the tyre is a point follower in the model).
    """
    from ..road import Profile

    if axle not in ("front", "rear"):
        raise InputError(f"axle must be 'front' or 'rear'; got {axle!r}.")
    V = require_positive("speed", speed)
    fc = require_positive("highpass", highpass)
    dt = sensors.dt
    if sensors.time.shape != estimate.time.shape:
        raise InputError("sensors and estimate must cover the same samples; run the estimate on these sensors.")
    sos = signal.butter(2, fc, btype="high", fs=1.0 / dt, output="sos")
    cols = [0, 1] if axle == "front" else [2, 3]
    if sensors.config == 3:
        v1 = signal.sosfiltfilt(sos, _integrate(signal.sosfiltfilt(sos, sensors.wheel_accel[:, cols], axis=0), dt),
                                axis=0)
    else:
        v1 = estimate.wheel_velocity[:, cols]
    z1 = signal.sosfiltfilt(sos, _integrate(v1, dt), axis=0)
    if smoothed:
        from ._vertical_estimate import smooth_vertical_states

        estimate = smooth_vertical_states(estimate, params=params)
    z0 = z1 - estimate.tyre_deflection[:, cols]
    z0 = z0 - z0.mean(axis=0)
    return Profile(distance=V * (sensors.time - sensors.time[0]), elevation=z0, tracks=("left", "right"),
                   name=f"road from suspension sensors (config {sensors.config}, {axle} axle)")
