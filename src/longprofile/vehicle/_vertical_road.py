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

__all__ = ["road_profile_from_suspension", "wheel_profiles"]


def _integrate(a, dt):
    out = np.zeros_like(a)
    out[1:] = np.cumsum(0.5 * (a[1:] + a[:-1]) * dt, axis=0)
    return out


def _highpass(sos, x, fc, dt):
    """Zero-phase high-pass with an odd (point-reflected) extension of 3 time constants at each end.

    scipy's default pad (a few samples) leaves the filter's start-up transient, ~1/fc long, in the first and
    last seconds of the record: at 0.2 Hz that is the first 100 m at 20 m/s, where it added +18 to +34 %
    (and on a graded road several times more) to the first segment's IRI (issue 14). Reflecting the record
    about its end points continues its local trend, which the high-pass then removes without a transient.
    """
    n = x.shape[0]
    padlen = min(n - 1, int(round(3.0 / (fc * dt))))
    return signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=padlen)


def _detrend(x, dt, order):
    """Remove the least-squares polynomial of ``order`` in time (the unknown integration constants)."""
    t = (np.arange(x.shape[0]) - 0.5 * (x.shape[0] - 1)) * dt
    A = np.vander(t / max(t[-1], dt), order + 1)
    coef, *_ = np.linalg.lstsq(A, x, rcond=None)
    return x - A @ coef


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
    ``Z0 = HP(D2(integral(integral(a_wheel)))) - dZ10_hat`` (config 3) or ``HP(D1(integral(Z1dot_hat))) -
    dZ10_hat`` (configs 1, 2), with D_n the removal of the least-squares polynomial of degree n in time (the
    unknown integration constants) and HP the zero-phase high-pass with odd (point-reflected) extensions of
    3/highpass seconds at both ends, so that the first and last segments are as good as the middle ones
    (issue 14: before, the first 100 m segment's IRI was 18 to 100 % too high).
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
        # integrate twice, remove the unknown initial height and velocity (and a constant accelerometer bias:
        # a quadratic), then ONE zero-phase high-pass with reflected ends. High-passing between the two
        # integrations (as before issue 14) turned the wheel's initial vertical velocity, a step from the
        # filter's point of view, into a transient ~1/fc long: +90 % on the first 100 m segment's IRI.
        z1 = _highpass(sos, _detrend(_integrate(_integrate(sensors.wheel_accel[:, cols], dt), dt), dt, 2), fc, dt)
    else:
        z1 = _highpass(sos, _detrend(_integrate(estimate.wheel_velocity[:, cols], dt), dt, 1), fc, dt)
    if smoothed:
        from ._vertical_estimate import smooth_vertical_states

        estimate = smooth_vertical_states(estimate, params=params)
    z0 = z1 - estimate.tyre_deflection[:, cols]
    z0 = z0 - z0.mean(axis=0)
    return Profile(distance=V * (sensors.time - sensors.time[0]), elevation=z0, tracks=("left", "right"),
                   name=f"road from suspension sensors (config {sensors.config}, {axle} axle)")


def wheel_profiles(sensors: VerticalSensors, estimate: VerticalStateEstimate, speed: float, *, start: float = 0.0,
                   highpass: float = 0.2, smoothed: bool = True, params=None):
    """The road under each of the four wheels on one chainage grid (issue 14), from the suspension sensors.

    Parameters
    ----------
    sensors, estimate, speed, highpass, smoothed, params
        As :func:`road_profile_from_suspension` (constant speed, m/s).
    start : float
        Chainage of the FRONT axle at the first sample, m.

    Returns
    -------
    longprofile.road.Profile
        Tracks ``("fl", "fr", "rl", "rr")``, stations ``start + V t`` (front axle), m, restricted to the
        chainage that both axles cover: the rear wheels pass a station ``wheelbase / V`` later, so the last
        wheelbase of the front record has no rear counterpart and is cut. Elevations in m, zero mean per
        track (the high-pass removes wavelengths beyond ``V / highpass``).
    """
    from ..road import Profile
    from ._vertical_model import VerticalVehicleParams

    p = params or VerticalVehicleParams()
    V = require_positive("speed", speed)
    if smoothed:  # smooth once for both axles
        from ._vertical_estimate import smooth_vertical_states

        estimate = smooth_vertical_states(estimate, params=params)
    front = road_profile_from_suspension(sensors, estimate, V, highpass=highpass, axle="front", smoothed=False)
    rear = road_profile_from_suspension(sensors, estimate, V, highpass=highpass, axle="rear", smoothed=False)
    L = p.wheelbase
    x = front.distance  # front axle travelled distance; the rear axle is at x - L
    keep = x <= x[-1] - L + 1e-9
    if keep.sum() < 3:
        raise InputError(f"the record ({x[-1]:.3g} m) is shorter than the wheelbase ({L:g} m): no chainage is covered "
                         "by both axles.")
    xs = x[keep]
    z = np.empty((xs.size, 4))
    z[:, :2] = front.elevation[keep]
    for j in range(2):
        z[:, 2 + j] = np.interp(xs + L, rear.distance, rear.elevation[:, j])
    z -= z.mean(axis=0)
    return Profile(distance=start + xs, elevation=z, tracks=("fl", "fr", "rl", "rr"),
                   name=f"road under each wheel from suspension sensors (config {sensors.config})")
