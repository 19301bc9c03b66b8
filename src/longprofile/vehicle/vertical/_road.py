"""The car as a road profilometer: the road under each wheel from the suspension sensors (issue 7, "beyond").

Road height under a wheel = wheel height - tyre deflection, ``Z0 = Z1 - dZ10``. The wheel height comes
from the wheel accelerometer integrated twice (configuration 3) or from the reconstructed wheel velocity
integrated once (configurations 1, 2); the tyre deflection from the corner EKF. Offline, the integrations
are high-passed with a ZERO-PHASE filter (the profile is computed after the run, unlike the real-time
velocities). Stations are ``V t``: the car must drive at a known constant speed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..._jit import njit
from ..._validation import require_positive
from ...errors import InputError
from ...statespace import filter_design, sos_filtfilt
from ._checks import (
    DEFLECTION_SIGN_LIMIT,
    ROLL_RATIO_RANGE,
    SIGN_REFUSAL_LIMIT,
    body_accelerometer_ratio,
    check_vertical_accel_means,
    corner_order_problem,
    deflection_gains,
    deflection_sign_correlation,
    lateral_roll_ratio,
    sensor_scale_problems,
)
from ._estimate import VerticalStateEstimate
from ._model import CKBAR, CORNER_NAMES, OPPOSITE, STAU, suspension_tensions, vertical_params_arrays
from ._simulate import VerticalSensors, VerticalSimulation, vehicle_speed

if TYPE_CHECKING:
    from ...road import IRIResult, Profile
    from ._params import MRDamperParams, VerticalVehicleParams

__all__ = ["road_profile_from_suspension", "wheel_profiles", "VerticalRun", "profile_run", "VerticalLogEstimate",
           "WHEEL_ACCEL_RATIO_RANGE", "wheel_accelerometer_ratio", "DeflectionZeroCheck", "deflection_zero_check",
           "DEFLECTION_OFFSET_LIMIT", "estimate_vertical_log", "VERTICAL_ACCEPTABLE_CHECKS"]


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
    return sos_filtfilt(sos, x, padlen=padlen)


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
    from ...road import Profile

    if axle not in ("front", "rear"):
        raise InputError(f"axle must be 'front' or 'rear'; got {axle!r}.")
    V = vehicle_speed(speed)
    fc = require_positive("highpass", highpass)
    dt = sensors.dt
    if sensors.time.shape != estimate.time.shape:
        raise InputError("sensors and estimate must cover the same samples; run the estimate on these sensors.")
    sos = filter_design("butter", 2, fc, btype="high", fs=1.0 / dt, output="sos")
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
        from ._estimate import smooth_vertical_states

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
    from ...road import Profile
    from ._params import VerticalVehicleParams

    p = params or VerticalVehicleParams()
    V = vehicle_speed(speed)
    if smoothed:  # smooth once for both axles
        from ._estimate import smooth_vertical_states

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


# ------------------------------------------------------------------------------------------ runs on a profile

@dataclass(frozen=True, eq=False)
class VerticalRun:
    """A simulated run of the 7-DOF car and the sensors of one configuration (:func:`profile_run`).

    Attributes
    ----------
    simulation : VerticalSimulation
        True states (time base ``simulation.time``, s).
    sensors : VerticalSensors
        Measured signals of ``sensors.config`` (noise seeded, see :func:`profile_run`).
    front_chainage : (T,) ndarray or None
        Chainage of the front axle at each sample, m: the run starts with the rear axle on the profile's first
        station, so one wheelbase further (what :func:`estimate_vertical_log`'s ``start`` expects at the first sample).
    """

    simulation: VerticalSimulation
    sensors: VerticalSensors
    front_chainage: np.ndarray | None = None


def profile_run(profile: Profile, config: int, speed: float, duration: float, *, seed: int = 0,
                mr_damper: MRDamperParams | None = None, params: VerticalVehicleParams | None = None,
                dt: float = 1e-3, source: str = "profile") -> VerticalRun:
    """Drive the simulated car over a road profile at constant speed and measure one sensor configuration.

    The front axle starts at the profile's first station; the run lasts ``duration`` s or until the rear axle
    would leave the profile, whichever is shorter (:func:`wheel_road_inputs`, :func:`simulate_vertical`,
    :func:`measure_vertical` with ``rng=seed + 1``).

    Parameters
    ----------
    profile : longprofile.road.Profile
        One track (both wheel paths) or two (left, right); stations m, elevations m.
    config : {1, 2, 3}
        Sensor configuration (1 displacements, 2 + body accelerometers, 3 + wheel accelerometers).
    speed : float
        Vehicle speed, m/s.
    duration : float
        Longest run, s.
    seed : int
        Seed of the sensor noise (the generator is seeded with ``seed + 1``).
    mr_damper : MRDamperParams, optional
        MagneRide dampers with their skyhook controller (None: passive dampers).
    params : VerticalVehicleParams, optional
        The simulated car (default: thesis set).
    dt : float
        Sample period, s (default 1e-3, the thesis's).
    source : str
        Name of the profile in error messages.

    Returns
    -------
    VerticalRun
        ``simulation`` (T samples of ``dt``) and ``sensors``.

    Raises
    ------
    InputError
        If the profile has more than two tracks.
    """
    from ._params import VerticalVehicleParams
    from ._simulate import measure_vertical, simulate_vertical, wheel_road_inputs

    if profile.elevation.shape[1] > 2:
        raise InputError(f"{source}: {profile.elevation.shape[1]} tracks; give one (both wheel paths) or two "
                         "(left, right).")
    p = params or VerticalVehicleParams()
    available = (profile.distance[-1] - profile.distance[0] - p.wheelbase) / speed
    inputs = wheel_road_inputs(profile, speed, dt, duration=min(duration, available),
                               start=float(profile.distance[0]), params=p)
    sim = simulate_vertical(inputs, dt, params=p, mr_damper=mr_damper)
    return VerticalRun(simulation=sim, sensors=measure_vertical(sim, config, rng=seed + 1),
                       front_chainage=float(profile.distance[0]) + p.wheelbase + speed * sim.time)


@dataclass(frozen=True, eq=False)
class VerticalLogEstimate:
    """States estimated from a sensor log and, optionally, the road and IRI under each wheel
    (:func:`estimate_vertical_log`).

    Attributes
    ----------
    estimate : VerticalStateEstimate
        The corner-EKF (or centralised EKF) estimate.
    mr_map : MRDamperParams or None
        The nominal MR map the filter used (the log has ``current_*`` columns), else None.
    profile : longprofile.road.Profile or None
        Road under the four wheels (tracks fl, fr, rl, rr; chainage m, elevations m) when a speed was given.
    iri : longprofile.road.IRIResult or None
        IRI of ``profile`` per segment (m/km).
    accelerometer_ratio : float or None
        :func:`wheel_accelerometer_ratio` of the log (configuration 3), else None.
    deflection_check : DeflectionZeroCheck or None
        :func:`deflection_zero_check` of the log (None on a log shorter than ``DEFLECTION_CHECK_MIN_DURATION``).
    corner_order : str or None
        :func:`corner_order_problem` of the log (configuration 3): deflections of swapped corners, else None.
    roll_ratio : float
        :func:`lateral_roll_ratio` of the log (nan without 1 s of turning).
    body_accel_ratio : float or None
        :func:`body_accelerometer_ratio` of the log (configuration 2), else None (session 41).
    deflection_gain : (4,) ndarray or None
        :func:`deflection_gains` of the log (configurations 2 and 3; nan where not judged), else None (session 41).
    """

    estimate: VerticalStateEstimate
    mr_map: MRDamperParams | None = None
    profile: Profile | None = None
    iri: IRIResult | None = None
    accelerometer_ratio: float | None = None
    deflection_check: DeflectionZeroCheck | None = None
    corner_order: str | None = None
    roll_ratio: float = float("nan")
    body_accel_ratio: float | None = None
    deflection_gain: np.ndarray | None = None

    def warnings(self) -> list[str]:
        """What a user should know before trusting this result (strings; empty when nothing).

        Deflection sensors not zeroed at the static ride height (:func:`deflection_zero_check`); wheel accelerometers
        in another unit (:func:`wheel_accelerometer_ratio`). A road profile from configurations 1 and 2 (no wheel
        accelerometers) underestimates the IRI by 8-20 %:
        the wheel motion comes from the reconstructed suspension velocity (docs/vehicle-vertical.md, measured on
        the simulator); configuration 3 is within 3 %.
        """
        out = []
        if self.deflection_check is not None and self.deflection_check.suspect:
            out.append(self.deflection_check.message())
        out.extend(text for _, text in _log_problems(self.accelerometer_ratio, self.corner_order, self.roll_ratio))
        out.extend(text for _, text in sensor_scale_problems(self.body_accel_ratio, self.deflection_gain,
                                                             wheel=self.estimate.config == 3))
        if self.profile is not None and self.estimate.config != 3:
            out.append(f"configuration {self.estimate.config}: the road profile and IRI underestimate the IRI by "
                       "8-20 % (wheel motion from the reconstructed velocity); configuration 3 (wheel "
                       "accelerometers) is within 3 %, see docs/vehicle-vertical.md")
        return out


#: :func:`wheel_accelerometer_ratio` of a log in SI units: ~1 on class C-E roads, 0.17-0.5 per corner (median
#: 0.25-0.3) on a class A road where the deflections' quantisation dominates their second derivative; accelerations
#: in g give ~0.1 (0.02-0.05 on class A). Measured on the simulator, session 35 (docs/vehicle-vertical.md).
WHEEL_ACCEL_RATIO_RANGE = (0.15, 5.0)


def wheel_accelerometer_ratio(sensors: VerticalSensors) -> float | None:
    """Median over the corners of std(wheel accelerometer) / std(d^2/dt^2 suspension deflection) in 8-25 Hz (the
    wheel hop, where the wheel's acceleration is the deflection's): ~1 when both are in SI units. None without wheel
    accelerometers (configurations 1 and 2) or below 60 Hz sampling."""
    if sensors.wheel_accel is None or 1.0 / sensors.dt < 60.0 or sensors.time.size < 64:
        return None
    sos = filter_design("butter", 4, [8.0, 25.0], btype="band", fs=1.0 / sensors.dt, output="sos")
    second = np.gradient(np.gradient(sensors.displacement, sensors.dt, axis=0), sensors.dt, axis=0)
    acc = np.std(sos_filtfilt(sos, sensors.wheel_accel), axis=0)
    dd = np.std(sos_filtfilt(sos, second), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return float(np.median(acc / dd))


#: Largest zero offset of a suspension deflection sensor that :func:`deflection_zero_check` lets pass, m. On the
#: simulator, sensors zeroed at the static ride height gave offsets within 2.6 mm on 120 drives (median 0.42, 99 %
#: 2.42 mm; ``benchmarks/bench_vertical_zero_check.py`` ``score(120, seed=11)``: ISO 8608 classes A-E, 5-40 m/s,
#: 2-30 s, road, track and 4-poster tests, passive and MagneRide cars), and 3.05 mm on the 50 drives of seed 12
#: (no false alarm); 5 mm leaves room for what the simulator lacks. A 5 mm offset raised the front-left tyre-load
#: RMS error of the guide's 5 s configuration-3 log from 218 to 274 N (+26 %), 20 mm to 666 N (session 37).
DEFLECTION_OFFSET_LIMIT = 0.005
#: Shortest log :func:`deflection_zero_check` runs on, s: a mean over less does not average the wheel hop out.
DEFLECTION_CHECK_MIN_DURATION = 2.0
#: Low-pass of the damper velocity the check evaluates the dampers at, Hz (the wheel hop, 13 Hz, passes; the 1 kHz
#: quantisation steps of the deflection do not).
_CHECK_VELOCITY_CUTOFF = 50.0


@dataclass(frozen=True, eq=False)
class DeflectionZeroCheck:
    """Whether the suspension deflection sensors read zero at the static ride height (:func:`deflection_zero_check`).

    Attributes
    ----------
    mean : (4,) ndarray, m
        Mean of each ``dz21_*`` over the log (FL, FR, RL, RR).
    offset : (4,) ndarray, m
        The zero offset of each sensor that the suspension's force balance implies (0 for a sensor zeroed at the
        static ride height, within :data:`DEFLECTION_OFFSET_LIMIT` on the simulator).
    limit : float, m
        The offset beyond which :attr:`suspect` is True.
    sign : (4,) ndarray or None
        :func:`deflection_sign_correlation` of each channel (~+1 positive in extension, ~-1 inverted); None in
        configuration 1 (session 38).
    sign_source : {"wheel", "body"} or None
        The accelerometers :attr:`sign` compares with.
    flipped_offset : (4,) ndarray or None, m
        The offsets the force balance gives with the :attr:`inverted` channels negated (of the negated channels;
        None when no channel is inverted): which
        of the two, deflection or accelerometer, has the wrong sign (:attr:`sign_culprit`).
    """

    mean: np.ndarray
    offset: np.ndarray
    limit: float = DEFLECTION_OFFSET_LIMIT
    sign: np.ndarray | None = None
    sign_source: str | None = None
    flipped_offset: np.ndarray | None = None

    @property
    def sign_culprit(self) -> str | None:
        """Which sensor of the :attr:`inverted` channels has the wrong sign: ``"deflection"`` (the force balance fits
        the negated deflections, not the logged ones), ``"accelerometer"`` (it fits the logged deflections: their
        means agree with it, so the accelerometers moving against them are inverted), ``"either"`` (both or neither
        fit: a smooth road's mean deflection is too small to tell), None when no channel is inverted. The
        deflection's second derivative is the body's minus the wheel's acceleration (dZ21 = Z2 - Z1): the
        correlation only says that one of the two signs is wrong."""
        bad = self.inverted
        if not bad.any():
            return None
        logged = bool(np.all(np.abs(self.offset[bad]) <= self.limit))
        flipped = self.flipped_offset is not None and bool(np.all(np.abs(self.flipped_offset[bad]) <= self.limit))
        if flipped and not logged:
            return "deflection"
        if logged and not flipped:
            return "accelerometer"
        return "either"

    @property
    def inverted(self) -> np.ndarray:
        """(4,) bool: channels whose sign correlation is below ``-DEFLECTION_SIGN_LIMIT`` (sign inverted?)."""
        if self.sign is None:
            return np.zeros(4, dtype=bool)
        return np.asarray(self.sign) < -DEFLECTION_SIGN_LIMIT

    @property
    def expected_mean(self) -> np.ndarray:
        """Mean of each deflection a sensor zeroed at the static ride height would have shown, m."""
        return self.mean - self.offset

    @property
    def suspect(self) -> bool:
        """True when a sensor's offset exceeds :attr:`limit` or its sign looks inverted (:attr:`inverted`)."""
        return bool(np.any(np.abs(self.offset) > self.limit) or np.any(self.inverted))

    def _accelerometer_message(self, bad, mm) -> str:
        """:meth:`message` when the accelerometers are (or may be) the inverted ones."""
        kind = "body_accel" if self.sign_source == "body" else "wheel_accel"
        acc = ", ".join(f"{kind}_{CORNER_NAMES[c]}" for c in bad)
        dz = ", ".join(f"dz21_{CORNER_NAMES[c]}" for c in bad)
        one = bad.size == 1
        how = (f"correlation {', '.join(f'{self.sign[c]:+.2f}' for c in bad)}, +1 when both are right: d²dz21/dt² = "
               "body minus wheel acceleration")
        if self.sign_culprit == "accelerometer":
            return (f"{acc}: sign inverted (z down?)? {dz} move{'s' if one else ''} against {'it' if one else 'them'} "
                    f"({how}), but the deflection mean{'' if one else 's'} {mm(self.mean)} mm agree{'s' if one else ''}"
                    f" with the suspension's force balance ({mm(self.expected_mean)} mm expected), so the "
                    f"deflections are right: negate {acc} (z up)")
        return (f"{dz} or {acc}: one of the two has an inverted sign ({how}); on this log the suspension's force "
                f"balance cannot tell which (zero offset{'' if one else 's'} {mm(self.offset)} mm with the deflections "
                f"as logged, {mm(self.flipped_offset)} mm negated; within {1e3 * self.limit:g} mm fits): check each "
                "sensor's axis (dz21 positive in extension, accelerometers z up) and negate the wrong one")

    def message(self) -> str:
        """One line naming the suspect channels, their means, the means expected and what to do; channels of
        inverted sign are named as such instead (their offset is then the sign's doing)."""
        flipped = self.inverted
        bad = np.flatnonzero(flipped) if flipped.any() else np.flatnonzero(np.abs(self.offset) > self.limit)
        one = bad.size == 1

        def mm(values):
            return ", ".join(f"{1e3 * values[c]:+.1f}" for c in bad)

        if flipped.any() and self.sign_culprit != "deflection":
            return self._accelerometer_message(bad, mm)
        if flipped.any():
            return (f"{', '.join(f'dz21_{CORNER_NAMES[c]}' for c in bad)}: sign inverted? "
                    f"{'it moves' if one else 'they move'} against what the "
                    f"{'body' if self.sign_source == 'body' else 'wheel'} accelerometers imply (correlation "
                    f"{', '.join(f'{self.sign[c]:+.2f}' for c in bad)}; +1 when positive in extension, body minus "
                    f"wheel; mean{'' if one else 's'} {mm(self.mean)} mm over the log, {mm(self.expected_mean)} mm "
                    "expected from the suspension's force balance): negate "
                    f"{'this column' if one else 'these columns'} (dz21 = Z2 - Z1, positive in extension)")
        return (f"{', '.join(f'dz21_{CORNER_NAMES[c]}' for c in bad)} {'does' if one else 'do'} not read zero at the "
                f"static ride height: mean{'' if one else 's'} {mm(self.mean)} mm over the log, {mm(self.expected_mean)} "
                f"mm expected from the suspension's force balance (offset{'' if one else 's'} {mm(self.offset)} mm); "
                f"zero {'the' if one else 'each'} sensor at the static ride height or subtract its static reading (if "
                "zeroed: a car unlike the filter's, --vehicle)")


@njit(cache=True)
def _mean_tensions(dz, dzdot, actuator, corner, tau, shift):
    """Mean over the samples of the four suspension tensions (:func:`suspension_tensions`) at ``dz - shift``, N, and
    of their spring slopes, N/m."""
    total = np.zeros(4)
    slope = np.zeros(4)
    force = np.empty(4)
    ks = np.empty(4)
    cd = np.empty(4)
    for k in range(dz.shape[0]):
        suspension_tensions(dz[k] - shift, dzdot[k], actuator[k], corner, tau, force, ks, cd)
        total += force
        slope += ks
    n = max(dz.shape[0], 1)
    return total / n, slope / n


def deflection_zero_check(sensors: VerticalSensors, *, params: VerticalVehicleParams | None = None,
                          actuator_force=None) -> DeflectionZeroCheck | None:
    """The zero offset of each suspension deflection sensor, from the suspension's force balance over the log.

    The filters of thesis 003 take the deflections ``dz21_*`` from the static ride height (ASSUMPTION, their spring
    force is ``k dZ``): a sensor zeroed elsewhere reads the static load as a force (20 mm is 800 N on the thesis
    car's front spring) and the tyre load comes out wrong. The mean deflection itself is no test: the asymmetric
    dampers (rebound stiffer than compression) pull the car down on a rough road, by -3 to -30 mm on the simulator
    (classes A to E). But the body's vertical, roll and pitch velocities stay bounded, so over a drive the mean
    suspension tensions balance the mean load transfer of a_x, a_y and the yaw acceleration; with the car's
    warp mode at zero mean on a road whose left and right paths average level, each corner's mean tension is the
    load transfer's. So the mean tension of each corner, computed with the model's spring, anti-roll bar and
    damper at the measured deflection and its velocity (derivative low-passed at 50 Hz, ASSUMPTION: passes the
    13 Hz wheel hop, not the quantisation steps), must equal the mean tension of the flat-road handling response to
    the measured a_x, a_y, psidd; the offset that makes them equal (Newton on the progressive springs and the
    anti-roll bars) is each sensor's. On the simulator the offset found on zeroed sensors stayed within 3.05 mm
    (``DEFLECTION_OFFSET_LIMIT``); the mean deflections were -3 to -30 mm.

    Parameters
    ----------
    sensors : VerticalSensors
        The log (:func:`read_vertical_log`).
    params : VerticalVehicleParams, optional
        The car (default: thesis set); a car whose springs or dampers differ from it shows as an offset too.
    actuator_force : (T, 4) array_like, optional
        The actuator forces the filter used (:attr:`VerticalStateEstimate.actuator_force`), N; default 0.

    Returns
    -------
    DeflectionZeroCheck or None
        None for a log shorter than ``DEFLECTION_CHECK_MIN_DURATION`` (2 s).
    """
    from ._estimate import _handling_response, damper_velocity_from_displacement, vertical_ekf_inputs
    from ._params import VerticalVehicleParams

    if sensors.time.size * sensors.dt < DEFLECTION_CHECK_MIN_DURATION:
        return None
    p = params or VerticalVehicleParams()
    corner, _, scalars = vertical_params_arrays(p)
    dz = np.ascontiguousarray(sensors.displacement, dtype=float)
    v = damper_velocity_from_displacement(dz, sensors.dt, cutoff=_CHECK_VELOCITY_CUTOFF)
    act = np.zeros_like(dz) if actuator_force is None else np.ascontiguousarray(actuator_force, dtype=float)
    _, hdz, hdzd, _ = _handling_response(vertical_ekf_inputs(sensors), p, sensors.dt)
    target, _ = _mean_tensions(np.ascontiguousarray(hdz), np.ascontiguousarray(hdzd), np.zeros_like(dz), corner,
                               scalars[STAU], np.zeros(4))
    v = np.ascontiguousarray(v)
    offset = _balance_offset(dz, v, act, corner, scalars[STAU], target)
    sign = deflection_sign_correlation(sensors, params=p, actuator_force=actuator_force)
    source = "wheel" if sensors.wheel_accel is not None else "body" if sensors.body_accel is not None else None
    check = DeflectionZeroCheck(mean=dz.mean(axis=0), offset=offset, sign=sign, sign_source=source)
    if check.inverted.any():  # which sensor is wrong: the force balance of the deflections negated
        flip = np.where(check.inverted, -1.0, 1.0)
        flipped = _balance_offset(np.ascontiguousarray(dz * flip), np.ascontiguousarray(v * flip), act, corner,
                                  scalars[STAU], target)
        check = replace(check, flipped_offset=flipped)
    return check


def _balance_offset(dz, v, act, corner, tau, target) -> np.ndarray:
    """The zero offset of each deflection sensor that makes the mean suspension tensions equal ``target``: Newton on
    the progressive springs (k dZ (1 + beta dZ^4)), which stiffen far from rest, and the anti-roll bars."""
    offset = np.zeros(4)
    for _ in range(3):
        force, slope = _mean_tensions(dz, v, act, corner, tau, offset)
        stiffness = np.diag(slope + corner[:, CKBAR])  # the anti-roll bar couples each left/right pair
        stiffness[np.arange(4), OPPOSITE] = -corner[:, CKBAR]
        offset = offset + np.linalg.solve(stiffness, force - target)
    return offset


#: The checks of a vertical log that ``accept`` (the CLI's ``--accept-check``) turns from refusals into warnings.
VERTICAL_ACCEPTABLE_CHECKS = ("sensor_sign", "wheel_accel_unit", "corner_order", "lateral_axis", "body_accel_unit")


def _log_problems(ratio, swap, roll) -> list[tuple[str, str]]:
    """(check name, one line) of the failed checks that need no filter run: the wheel accelerometers' unit
    (:func:`wheel_accelerometer_ratio`), the corners' order (:func:`corner_order_problem`) and the lateral axis
    (:func:`lateral_roll_ratio`); a ratio above the unit band stays a warning (``""`` name)."""
    out = []
    lo, hi = WHEEL_ACCEL_RATIO_RANGE
    if ratio is not None and not lo <= ratio <= hi:
        out.append(("wheel_accel_unit" if ratio < lo else "",
                    f"the wheel accelerometers' 8-25 Hz content is {ratio:.2g} times the second derivative of the "
                    "suspension deflections (about 1 when both are in SI units, 0.25-1 on a smooth road): "
                    + ("accelerations in g? Declare them: --units 'wheel_accel_*=g'"
                       if ratio < lo else "accelerations or deflections in another unit?")))
    if swap:
        out.append(("corner_order", swap))
    lo, hi = ROLL_RATIO_RANGE
    if not np.isnan(roll) and not lo <= roll <= hi:
        if roll < 0:
            hint = ("a lateral axis to the RIGHT (SAE, z down)? the filters want y to the left: negate ay and "
                    "yaw_rate")
        elif roll > hi and 0.5 * GRAVITY_RATIO <= roll <= 2.0 * GRAVITY_RATIO:
            hint = "ay in g? declare it: --units ay=g (or head the column 'ay [g]')"
        else:
            hint = "ay in another unit, or a car whose roll stiffness is not the filter's (--vehicle)?"
        out.append(("lateral_axis", f"in the turns the measured body roll (dz21 left minus right) is {roll:.3g} times "
                    f"the roll the model gives for the logged ay and yaw_rate (about 1, {lo:g}..{hi:g} passes; y to "
                    f"the left, a left turn rolls the body right): {hint}"))
    return out


#: What a_y logged in g makes :func:`lateral_roll_ratio` (1 / g in m/s² per g).
GRAVITY_RATIO = 9.80665


def _refuse(problems, accept, source: str) -> None:
    """Raise one UnitsError for the problems whose check is not in ``accept`` (each with its opt-out)."""
    from ...errors import UnitsError

    refused = [f"{text} (--accept-check {name} goes on with a warning)" for name, text in problems
               if name and name not in accept]
    if refused:
        raise UnitsError(f"{source}: " + "; ".join(refused) + ".")


def _accepted(accept) -> tuple:
    accept = (accept,) if isinstance(accept, str) else tuple(accept or ())
    unknown = [a for a in accept if a not in VERTICAL_ACCEPTABLE_CHECKS]
    if unknown:
        raise InputError(f"--accept-check names {unknown}; the checks of a vertical log it can accept are "
                         f"{list(VERTICAL_ACCEPTABLE_CHECKS)}.")
    return accept


def estimate_vertical_log(sensors: VerticalSensors, *, params: VerticalVehicleParams | None = None,
                          decentralised: bool = True, mr_map_velocity: str = "displacement",
                          speed: float | None = None, start: float = 0.0,
                          segment_length: float = 100.0, store_covariances: bool = False, accept=(),
                          source: str = "sensors") -> VerticalLogEstimate:
    """Vertical states from a sensor log and (with ``speed``) the road profile and IRI under each wheel.

    A log with damper currents (MagneRide car) gets the actuator forces from the default nominal MR map
    (:func:`nominal_mr_map` of ``MRDamperParams()``). The states are :func:`estimate_vertical_states`; with
    ``speed``, the road is :func:`wheel_profiles` and its IRI :func:`longprofile.road.iri`.

    Parameters
    ----------
    sensors : VerticalSensors
        The log (:func:`read_vertical_log`), T samples of ``sensors.dt`` s.
    params : VerticalVehicleParams, optional
        The filter's car (default: thesis set).
    decentralised : bool
        The thesis's four corner EKFs (True) or one centralised full-car EKF.
    mr_map_velocity : {"displacement", "filter"}
        Where the MR map's damper velocity comes from (:data:`MR_MAP_VELOCITIES`).
    speed : float, optional
        Constant speed of the log, m/s: also compute the road under each wheel (stations = speed x time).
    start : float
        Chainage of the front axle at the first sample, m.
    segment_length : float
        IRI segment length, m.
    store_covariances : bool
        Keep the filter's covariance histories in ``estimate.filtered`` (for :func:`smooth_vertical_states`).
        Default False: a log can be hours long and they take ~7.7 kB per sample (configurations 2 and 3); the
        estimate (``state_std`` included) is the same either way. With ``speed`` they are kept whatever this
        says: the road profile smooths the tyre deflection (:func:`wheel_profiles`).
    accept : iterable of str
        Checks of :data:`VERTICAL_ACCEPTABLE_CHECKS` whose failure is a warning (:meth:`VerticalLogEstimate.warnings`)
        instead of a refusal (the CLI's ``--accept-check``).
    source : str
        Name of the log in the messages.

    Returns
    -------
    VerticalLogEstimate

    Raises
    ------
    UnitsError
        Vertical accelerometers that still include gravity (:func:`check_vertical_accel_means`). Unless accepted:
        wheel accelerometers in g (``wheel_accel_unit``: :func:`wheel_accelerometer_ratio` below
        ``WHEEL_ACCEL_RATIO_RANGE``), deflection columns of swapped corners (``corner_order``), a lateral axis to
        the right or a_y in g (``lateral_axis``), a sign correlation below ``-SIGN_REFUSAL_LIMIT``
        (``sensor_sign``, naming the deflections or the accelerometers, :attr:`DeflectionZeroCheck.sign_culprit`),
        body accelerometers in g (``body_accel_unit``: :func:`body_accelerometer_ratio` below
        ``BODY_ACCEL_RATIO_RANGE``, session 41). A deflection channel of another gain
        (:func:`deflection_gains` outside ``DEFLECTION_GAIN_RANGE``) is a warning.
    """
    from ._estimate import estimate_vertical_states, nominal_mr_map
    from ._params import MRDamperParams

    accept = _accepted(accept)
    check_vertical_accel_means(sensors, source=source)
    ratio, swap = wheel_accelerometer_ratio(sensors), corner_order_problem(sensors)
    roll, _ = lateral_roll_ratio(sensors, params=params)
    _refuse(_log_problems(ratio, swap, roll), accept, source)  # before the filters run
    mr_map = None
    if sensors.damper_current is not None:
        mr_map = nominal_mr_map(MRDamperParams())
    est = estimate_vertical_states(sensors, params=params, decentralised=decentralised, mr_map=mr_map,
                                   mr_map_velocity=mr_map_velocity,
                                   store_covariances=store_covariances or speed is not None)
    zero = deflection_zero_check(sensors, params=params, actuator_force=est.actuator_force)
    if zero is not None and zero.inverted.any() and float(np.min(zero.sign)) < -SIGN_REFUSAL_LIMIT:
        _refuse([("sensor_sign", zero.message())], accept, source)
    body = body_accelerometer_ratio(sensors, params=params, actuator_force=est.actuator_force)
    _refuse(sensor_scale_problems(body, None, wheel=False), accept, source)  # accelerations in g, before the fit
    gains = deflection_gains(sensors, params=params, actuator_force=est.actuator_force)
    if gains is not None and zero is not None and zero.inverted.any():  # named by the sign check, not judged here
        gains = np.where(zero.inverted, np.nan, gains)
    checks = {"accelerometer_ratio": ratio, "deflection_check": zero, "corner_order": swap, "roll_ratio": roll,
              "body_accel_ratio": body, "deflection_gain": gains}
    if speed is None:
        return VerticalLogEstimate(estimate=est, mr_map=mr_map, **checks)
    from ...road import iri

    prof = wheel_profiles(sensors, est, speed, start=start, params=params)
    return VerticalLogEstimate(estimate=est, mr_map=mr_map, profile=prof, iri=iri(prof, segment_length=segment_length),
                               **checks)
