"""Vehicle states and road slope from ABS, steering and IMU signals (paper 001, section IV).

Two estimators share one result type (:class:`SlopeEstimate`):

* ``"cascade"`` -- the paper's scheme: an EKF on the 4-wheel model (eq. (20)) estimates (V_x, V_y, r)
  and the tyre forces, then a Luenberger observer on the longitudinal model (21) estimates the slope;
* ``"joint"`` -- one EKF on the augmented state (V_x, V_y, r, theta_r) with a random-walk slope.

Both run on the state-space engine (:func:`longprofile.statespace.extended_kalman_filter`, whose
compiled loop numba keeps on disk, so a new process does not compile it again,
:func:`longprofile.statespace.luenberger_gain` and :func:`longprofile.statespace.luenberger_observer`);
this module only builds models and maps results.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..._jit import njit
from ..._validation import as_float_array
from ...errors import InputError, ModelError, ShapeError
from ._force_check import ForceScaleFit, force_scale_fit
from ._model import (
    EKFTuning,
    forces_fused,
    planar_ekf_model,
    planar_inputs,
    slope_ekf_model,
    slope_observer_gain,
    slope_observer_matrices,
)
from ._params import GRAVITY, Vehicle, default_vehicle
from ._sensor_calibration import SensorCalibration, calibrate_sensors
from ._simulate import DriveLog
from ._tolerances import describe_tolerances, load_tolerances

__all__ = ["SlopeEstimate", "SlopeUncertainty", "estimate_slope", "nis_inflation"]


# ------------------------------------------------------------------------------------------ results

#: Lowest speed (m/s) accepted by :func:`estimate_slope`.
_MIN_SPEED = 2.0

#: Largest plausible |tan(theta)| (a 10 % grade, issue 13): steeper estimates are flagged (``slope_plausible``).
MAX_PLAUSIBLE_GRADE = 0.10
#: Force-model errors against the accelerometer (|beta|, |c| of :class:`ForceScaleFit`) beyond which
#: :meth:`SlopeEstimate.warnings` warns: 30 % of the force (twice the stated prior std), 3 % of grade.
FORCE_ERROR_WARN = (0.30, 0.03)
#: A gyro offset or a wheel scale error found in the log (:class:`SensorCalibration`) beyond this many times its
#: stated std (``SlopeUncertainty.gyro_bias_std``, ``wheel_radius_rel_std``), and beyond 3 posterior stds, is named
#: by :meth:`SlopeEstimate.warnings`.
SENSOR_ERROR_WARN = 5.0


@dataclass(frozen=True)
class SlopeUncertainty:
    r"""What the printed stds assume beyond the filters' noise models (issue 13; docs/vehicle-slope.md, Calibration).

    The EKF and the observer know only their white noises, so their stds leave out the errors of the vehicle
    parameters, which are biases for a whole drive. :func:`estimate_slope` adds them at these stated relative
    stds (first-order propagation, see Notes), and inflates the filters' variances by their innovation
    consistency (NIS) over a moving window.

    Parameters
    ----------
    mass_rel_std : float
        Relative std of the mass (load, passengers): 0.05.
    force_rel_std : float
        Relative std of the tyre forces (stiffness, adhesion, load transfer): 0.14 (tyre stiffness varies by
        +-20-30 % with wear, pressure and temperature).
    radius_rel_std : float
        Relative std of the common rolling radius against the car file's ``wheels.radius`` (wear, pressure, load,
        tyre make): 0.01 (since 2026-12-06; 0.005 before). Named assumption: the tread of a new tyre (8 mm) wears to
        the legal 1.6 mm, 2.1 % of a 0.30 m radius; the car file's radius is mid-life and the tyre's state unknown
        (uniform over +-1.05 %: std 0.6 %); pressure, load, speed growth and the make add about 0.5 % each way: about
        0.8 %, rounded to 1 %. V_x is not observable at a better scale from the wheel speeds (``vx_std`` holds
        |V_x| x this); state your car's if you know it (a radius measured by a GNSS run: 0.1-0.2 %; on the command
        line: ``radius_rel_std`` in the car file's ``[tolerances]`` table, :meth:`from_car_file`).
    wheel_radius_rel_std : float
        Relative std of each wheel's radius against the others (after an ESC-style relative calibration): 2e-4.
    gyro_bias_std : float
        Std of the gyro's offset, rad/s (5e-4: after a standstill calibration, as ``SensorSpec.yaw_rate_offset``);
        the EKF takes the gyro reading as unbiased, so the offset passes into r.
    nis_window : float
        Length of the moving window of the NIS inflation, s (1 s); 0 turns the inflation off.
    nis_floor : float
        Smallest NIS factor applied to the variances of the yaw rate and of the joint EKF's grade, in (0, 1]
        (0.1): where their innovations (gyro, V_x) are smaller than the filter predicts -- a tuning that states
        more sensor noise than the sensor has -- those variances are scaled down by the windowed NIS, at most
        10x (std 3.2x). 1 gives inflation only (the estimator before 2026-12-05; with ``grade_nis_floor=None``
        or 1 since 2026-12-06, else the joint grade still deflates). V_x, V_y and the cascade's
        slope are only inflated. Chosen among {0.25, 0.1, 0.03} on the calibration benchmark's tuning draws
        (seed 1000). Since 2026-12-06 (afternoon) the joint grade has its own floor, ``grade_nis_floor``; since
        2026-12-07 the yaw rate's variance follows the filter's gain (``yaw_rate_from_gain``), and this floor applies
        to it only with ``yaw_rate_from_gain=False``.
    grade_nis_floor : float or None
        Smallest NIS factor (V_x innovation) applied to the joint EKF's grade variance, in (0, 1] (0.01 since
        2026-12-06; None: ``nis_floor``, as before). The joint's V_x measurement std (0.01 m/s, chosen to filter the
        grade) is far above the wheel speeds' noise, so its windowed NIS is 0.02-0.06 (median per family on the
        calibration benchmark's tuning draws) and the former floor 0.1 held the grade variance at 0.1 x the filter's
        at 60-99 % of the samples (median share per family): a constant, not the innovations. With the force correction the band keeps the
        larger of that variance and the force fit's block scatter (``residual_overlap``), which measures the force
        noise from the data and bounds the band from below, so the floor no longer has to. Chosen among
        {0.1, 0.03, 0.01} on the tuning draws (seeds 1000 and 2000, docs/vehicle-slope.md).
    tracking_lag : bool
        Add the cascade observer's lag to a changing grade, (-1/p1 - 1/p2) |d sin(theta)/dt|, to its slope std.
    accel_gain_std, accel_offset_std : float
        When :func:`estimate_slope` corrects the force model from the accelerometer (``force_correction``): the
        relative std of the accelerometer's scale, body pitch included (1 deg of pitch per g reads as 1.7 %; the
        simulator has neither), 0.02, and the std of its offset, m/s^2 (0.02, as ``SensorSpec.accel_offset``),
        which the corrected slope inherits (offset / g).
    offset_prior_std : float
        Prior std of the force model's constant error, in sin(theta) (0.03; rolling resistance alone, which model
        (21) leaves out, is 0.01-0.015).
    residual_overlap : bool
        With the force correction: the filter's variance of sin(theta) (the joint EKF's grade, the cascade observer's
        stationary value, both NIS-scaled) and the scatter of the force fit's 1 s blocks about its line
        (``ForceScaleFit.residual_std``) both measure the noise of the model's force along the drive; True (default
        since 2026-12-06) keeps the larger of the two, False adds them (counting that noise twice: the joint's grade
        band covered 94.5-98.1 % on the calibration benchmark's stated-tolerance cars with False).
    gyro_offset_prior_std, wheel_scale_prior_std : float
        When :func:`estimate_slope` calibrates the sensors from the log (``sensor_calibration``): the prior stds of
        the gyro's offset, rad/s, and of each wheel speed's relative scale error before that calibration
        (:func:`~longprofile.vehicle.calibrate_sensors`). The gyro offset's posterior std then replaces
        ``gyro_bias_std`` (the stated error left after a calibration done elsewhere); ``wheel_radius_rel_std`` stays
        (the front/rear difference is not corrected). 0 turns the calibration off.
    radius_in_calibration : bool
        True (default since 2026-12-06): the sensor calibration's prior of an axle's mean scale error is
        hypot(``radius_rel_std``, ``wheel_scale_prior_std`` / sqrt(2)), since each wheel's scale error holds the
        common rolling radius error too, which the calibration's yaw term r y_i carries; False:
        ``wheel_scale_prior_std`` alone.
    yaw_rate_from_gain : bool
        True (default since 2026-12-07): the yaw rate's variance is that of the EKF's actual update,
        (1 - K)^2 P_pred + K^2 R (:func:`yaw_rate_variance`): K the filter's gain on the gyro innovation, R the gyro's
        white-noise variance measured in the log (second differences, Gasser et al. 1986), P_pred the variance of
        the prediction error, the windowed mean square of the gyro innovations less R. False: the filter's variance
        scaled by the gyro's windowed NIS (down to ``nis_floor``), the estimator before, which held at 1 kHz only:
        at a coarser step the process noise (``EKFTuning.yaw_accel_psd`` x dt) grows, K tends to 1 and the gyro's
        own noise passes into r, while the NIS scales the variance down as if the gyro noise were overstated too
        (yaw-rate coverage 92.6 / 84.5 / 77.1 / 67.7 % at 1000 / 200 / 100 / 50 Hz, session 38).
    unverified_accel_offset_std, unverified_gyro_offset_std : float or None
        When the sensor calibration finds the gyro or a wheel beyond its stated std (the condition of the sensor
        warnings: beyond ``SENSOR_ERROR_WARN`` x the stated std and 3 posterior stds), the log shows a sensor set
        that was not calibrated, and the stated offsets of the accelerometer and the gyro (which assume a
        calibration done elsewhere) are not trusted either (named assumption, 2026-12-06 evening). Then the
        accelerometer's offset, m/s^2, has this std (0.3: about 30 mg, the order of a MEMS accelerometer's zero-g
        offset tolerance, and in sin(theta) the same as ``offset_prior_std``, so that one drive cannot tell the
        force model's constant from the accelerometer's offset and the slope takes the posterior of the former:
        a share w = s_c^2 / (s_c^2 + s_a^2) of the fitted constant, variance s_c^2 s_a^2 / (s_c^2 + s_a^2)), and the
        gyro is calibrated again with this prior std of its offset, rad/s (1e-3). None: the stated values
        always (the estimator before). Chosen among {0.1, 0.2, 0.3} m/s^2 and {1e-3, 2e-3, 5e-3} rad/s on the
        calibration benchmark's tuning draws (seeds 1000 and 2000; docs/vehicle-slope.md, "Sensors beyond their
        stated offsets").

    Notes
    -----
    The defaults of ``force_rel_std`` and ``wheel_radius_rel_std`` were chosen among {0.07, 0.10, 0.14} x
    {2e-4, 5e-4} on the calibration benchmark's tuning draws (seed 1000, not the reported seed 0).
    With the measured forces right, a mass M' = M (1 + m) shifts the observer's sin(theta) by
    F_res (1/M' - 1/M)/g ~ -m F_res/(M g); a relative force error f shifts it by f F_res/(M g); a common radius
    error r scales the measured speed, hence dV/dt, so sin(theta) moves by -r dV/dt / g (and V_x by r V_x);
    independent wheel-radius errors w_i fake slips w_i - (w_rl + w_rr)/2 whose forces sum to
    C_x0 (w_fl + w_fr - w_rl - w_rr), std 2 C_x0 w, i.e. 2 C_x0 w/(M g) in sin(theta).
    ``SlopeUncertainty.noise_only()`` gives the filters' stds alone (the estimator before issue 13),
    ``SlopeUncertainty.until_2026_12_06()`` the defaults before the radius std and the residual overlap changed,
    ``SlopeUncertainty.until_2026_12_06_pm()`` those of that morning (before ``grade_nis_floor``),
    ``SlopeUncertainty.until_2026_12_06_evening()`` those of that afternoon (before the unverified sensors),
    ``SlopeUncertainty.until_2026_12_07()`` those before the yaw rate's band followed the filter's gain.
    """

    mass_rel_std: float = 0.05
    force_rel_std: float = 0.14
    radius_rel_std: float = 0.01
    wheel_radius_rel_std: float = 2e-4
    gyro_bias_std: float = 5e-4
    nis_window: float = 1.0
    tracking_lag: bool = True
    accel_gain_std: float = 0.02
    accel_offset_std: float = 0.02
    offset_prior_std: float = 0.03
    nis_floor: float = 0.1
    gyro_offset_prior_std: float = 5e-4
    wheel_scale_prior_std: float = 5e-3
    residual_overlap: bool = True
    radius_in_calibration: bool = True
    grade_nis_floor: float | None = 0.01
    unverified_accel_offset_std: float | None = 0.3
    unverified_gyro_offset_std: float | None = 1e-3
    yaw_rate_from_gain: bool = True

    def __post_init__(self):
        for k in ("mass_rel_std", "force_rel_std", "radius_rel_std", "wheel_radius_rel_std", "gyro_bias_std",
                  "nis_window", "accel_gain_std", "accel_offset_std", "offset_prior_std", "gyro_offset_prior_std",
                  "wheel_scale_prior_std"):
            v = getattr(self, k)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise InputError(f"{k} must be a finite number >= 0; got {v!r}.")
        if not (isinstance(self.nis_floor, (int, float)) and 0.0 < self.nis_floor <= 1.0):
            raise InputError(f"nis_floor must be in (0, 1]; got {self.nis_floor!r}.")
        g = self.grade_nis_floor
        if g is not None and not (isinstance(g, (int, float)) and not isinstance(g, bool) and 0.0 < g <= 1.0):
            raise InputError(f"grade_nis_floor must be None or in (0, 1]; got {g!r}.")
        for k in ("unverified_accel_offset_std", "unverified_gyro_offset_std"):
            v = getattr(self, k)
            if v is not None and not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                                      and v > 0):
                raise InputError(f"{k} must be None or a finite number > 0; got {v!r}.")
        for k in ("residual_overlap", "radius_in_calibration", "yaw_rate_from_gain"):
            if not isinstance(getattr(self, k), bool):
                raise InputError(f"{k} must be True or False; got {getattr(self, k)!r}.")

    @classmethod
    def noise_only(cls) -> "SlopeUncertainty":
        """No parameter terms and no NIS inflation: the filters' own stds."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, nis_floor=1.0, tracking_lag=False, accel_gain_std=0.0,
                   accel_offset_std=0.0, gyro_offset_prior_std=0.0, wheel_scale_prior_std=0.0, grade_nis_floor=None,
                   unverified_accel_offset_std=None, unverified_gyro_offset_std=None, yaw_rate_from_gain=False)

    @classmethod
    def until_2026_12_06(cls) -> "SlopeUncertainty":
        """The defaults before 2026-12-06 (issue 13, vehicle bands): ``radius_rel_std`` 0.005 and the filter's slope
        variance added to the force fit's residual variance (``residual_overlap=False``), the sensor calibration's
        prior of an axle's mean scale ``wheel_scale_prior_std`` alone (``radius_in_calibration=False``); reproduces
        that estimator's outputs."""
        return cls(radius_rel_std=0.005, residual_overlap=False, radius_in_calibration=False, grade_nis_floor=None,
                   unverified_accel_offset_std=None, unverified_gyro_offset_std=None, yaw_rate_from_gain=False)

    @classmethod
    def until_2026_12_06_pm(cls) -> "SlopeUncertainty":
        """The defaults of the morning of 2026-12-06 (issue 13, vehicle bands), before the joint grade got its own NIS
        floor: the grade variance floored at ``nis_floor`` (0.1, ``grade_nis_floor=None``); reproduces that
        estimator's outputs."""
        return cls(grade_nis_floor=None, unverified_accel_offset_std=None, unverified_gyro_offset_std=None,
                   yaw_rate_from_gain=False)

    @classmethod
    def until_2026_12_06_evening(cls) -> "SlopeUncertainty":
        """The defaults of the afternoon of 2026-12-06 (issue 13, vehicle bands), before sensors found beyond their
        stated offsets made the accelerometer's and the gyro's offsets unverified (``unverified_accel_offset_std``,
        ``unverified_gyro_offset_std`` None); reproduces that estimator's outputs."""
        return cls(unverified_accel_offset_std=None, unverified_gyro_offset_std=None, yaw_rate_from_gain=False)

    @classmethod
    def until_2026_12_07(cls) -> "SlopeUncertainty":
        """The defaults before 2026-12-07 (session 38): the yaw rate's variance the filter's scaled by the gyro's
        windowed NIS (``yaw_rate_from_gain=False``); reproduces that estimator's outputs."""
        return cls(yaw_rate_from_gain=False)

    @classmethod
    def from_car_file(cls, path) -> "SlopeUncertainty":
        """The stated tolerances of a vehicle description file's ``[tolerances]`` table (what ``vehicle slope
        --vehicle FILE`` assumes): its keys are fields of this class, the stated errors of the car and its sensors
        (``mass_rel_std``, ``force_rel_std``, ``radius_rel_std``, ``wheel_radius_rel_std``, ``gyro_bias_std``,
        ``accel_gain_std``, ``accel_offset_std``, ``gyro_offset_prior_std``, ``wheel_scale_prior_std``); a key
        left out, or the whole table, keeps the default.

        Relative stds are fractions (0.002 for 0.2 %). Raises InputFormatError (one line naming the file and the
        key) for an unknown key, a value that is not a number, negative or not finite, and one beyond a plausible
        bound (a relative std above 10 % for the rolling radius, 50 % for the mass: a percentage written for a
        fraction; a gyro offset above 0.05 rad/s, an accelerometer offset above 2 m/s^2: a unit slip).
        """
        return cls(**load_tolerances(path))

    def describe(self) -> str:
        """The stated tolerances as one line, each field of :meth:`from_car_file` by its name and value, with the
        default beside those that differ from it (``vehicle slope`` prints it after the states file)."""
        return describe_tolerances(self, type(self)())

    @property
    def grade_floor(self) -> float:
        """The NIS floor applied to the joint EKF's grade variance: ``grade_nis_floor``, or ``nis_floor`` if None."""
        return self.nis_floor if self.grade_nis_floor is None else float(self.grade_nis_floor)


@dataclass(frozen=True, eq=False)
class SlopeEstimate:
    """Vehicle states, tyre forces and road slope estimated from a drive log (paper 001).

    All per-sample arrays have T rows; wheel arrays have columns FL, FR, RL, RR; ``*_std`` are
    posterior (or propagated) standard deviations in the same units.

    Attributes
    ----------
    time : (T,) ndarray
        s.
    vx, vy, yaw_rate : (T,) ndarray
        Filtered V_x, V_y (m/s) and r (rad/s).
    vx_std, vy_std, yaw_rate_std : (T,) ndarray
        Their stds from the EKF covariance.
    slope, slope_std : (T,) ndarray
        Road grade angle theta_r and its std, rad.
    fx, fy, fx_std, fy_std : (T, 4) ndarray
        Dugoff tyre forces at the estimate (wheel axes), N, stds by the delta method.
    resisting_force, resisting_force_std : (T,) ndarray
        F_res = sum F_X + M r V_y - C_x V_x|V_x| of eq. (21), N.
    method : str
        ``"cascade"`` (EKF + Luenberger, the paper) or ``"joint"`` (augmented EKF).
    filtered : FilterResult
        The engine's EKF result.
    observer_gain : (2, 1) ndarray or None
        Luenberger gain (cascade only).
    speed_reference : SpeedReference or None
        The V_x measurement the EKF was given, per sample: speed, std (NaN = missing) and source code
        (:data:`~longprofile.vehicle.SPEED_SOURCES`: which wheels were trusted, slip-compensated or missing).
    force_fit : ForceScaleFit or None
        The drive's force-model error against the accelerometer (:func:`force_scale_fit`) that ``slope`` was
        corrected for; None with ``force_correction=False`` or without parameter uncertainty.
    sensor_calibration : SensorCalibration or None
        The gyro offset and relative wheel scale errors found in the log (:func:`calibrate_sensors`); the gyro and
        each axle's left/right difference were corrected before the filters; None with ``sensor_calibration=False``
        or without calibration priors.
    uncertainty : SlopeUncertainty or None
        The stated uncertainties behind the stds (and the warnings' thresholds).
    """

    time: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    yaw_rate: np.ndarray
    vx_std: np.ndarray
    vy_std: np.ndarray
    yaw_rate_std: np.ndarray
    slope: np.ndarray
    slope_std: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    fx_std: np.ndarray
    fy_std: np.ndarray
    resisting_force: np.ndarray
    resisting_force_std: np.ndarray
    method: str
    filtered: object
    observer_gain: np.ndarray | None = None
    speed_reference: object = None
    force_fit: ForceScaleFit | None = None
    sensor_calibration: SensorCalibration | None = None
    uncertainty: SlopeUncertainty | None = None
    sensors_unverified: bool = False

    def to_frame(self):
        """The estimate as a table (columns documented in docs/vehicle-slope.md)."""
        import pandas as pd

        cols = {"time": self.time}
        for k in ("vx", "vy", "yaw_rate", "slope", "resisting_force"):
            cols[k] = getattr(self, k)
            cols[f"{k}_std"] = getattr(self, f"{k}_std")
        for k in ("fx", "fy"):
            for i, w in enumerate(("fl", "fr", "rl", "rr")):
                cols[f"{k}_{w}"] = getattr(self, k)[:, i]
                cols[f"{k}_{w}_std"] = getattr(self, f"{k}_std")[:, i]
        if self.speed_reference is not None:  # the V_x measurement: value, std (NaN = missing), source code
            cols["vx_measured"] = self.speed_reference.speed
            cols["vx_measured_std"] = self.speed_reference.std
            cols["vx_measured_source"] = self.speed_reference.source.astype(np.int8)
        cols["slope_plausible"] = self.slope_plausible()
        return pd.DataFrame(cols)

    def slope_plausible(self, max_grade: float = MAX_PLAUSIBLE_GRADE) -> np.ndarray:
        """(T,) bool: True where the grade |tan(theta)| is at most ``max_grade`` (default 10 %, issue 13).

        Steeper estimates are rare on public roads; on a drive that has none, they point to a wrong mass, adhesion
        or wheel radius (docs/vehicle-slope.md, Measured results)."""
        return np.abs(np.tan(self.slope)) <= max_grade

    def warnings(self, *, max_missing: float = 0.05, max_slope: float = math.atan(MAX_PLAUSIBLE_GRADE)) -> list:
        """Plausibility warnings (strings) about this estimate; empty when none.

        Parameters
        ----------
        max_missing : float
            Largest acceptable share of samples without a V_x measurement (``vx_measured_source`` 0: no
            trustworthy wheel, the EKF only propagates), default 5 %.
        max_slope : float
            Largest plausible |grade angle|, rad (default atan(0.10) = 0.0997 rad = 5.7 deg, a 10 % grade, as
            the ``slope_plausible`` column: steeper than most public roads; on a drive without such hills the
            usual causes are a wrong mass, adhesion or wheel radius).
        """
        out = []
        ref = self.speed_reference
        if ref is not None:
            share = ref.missing_fraction
            if share > max_missing:
                k = int(np.argmax(ref.source == 0))
                out.append(f"V_x measurement missing at {100 * share:.1f} % of the samples (> {100 * max_missing:g} %; "
                           f"first at t = {self.time[k]:.6g} s): no wheel was trustworthy (hard braking or traction "
                           "beyond the tyre model), so the EKF only propagated there; check vehicle.driven_axle and "
                           "the friction, or treat those parts of the estimate as unreliable.")
        s = np.abs(self.slope)
        if np.any(s > max_slope):
            k = int(np.argmax(s > max_slope))
            out.append(f"slope leaves the plausible range |theta| <= {max_slope:.3g} rad ({100 * math.tan(max_slope):.3g} "
                       f"% grade) at {int(np.sum(s > max_slope))} sample(s), first at t = {self.time[k]:.6g} s "
                       f"({self.slope[k]:.3g} rad; column slope_plausible): unless the road is that steep, check the "
                       "vehicle mass, wheels.radius and the friction (see docs/vehicle-slope.md, Measured results).")
        fit = self.force_fit
        if fit is not None and (abs(fit.beta) > FORCE_ERROR_WARN[0] or abs(fit.offset) > FORCE_ERROR_WARN[1]):
            out.append(f"the model's longitudinal force and the accelerometer disagree: relative error "
                       f"{100 * fit.beta:+.1f} % (+- {100 * fit.beta_std:.1f} %), constant {100 * fit.offset:+.2f} % of "
                       "grade; the slope was corrected for both, which holds if the accelerometer is right: check "
                       "the vehicle mass and tyre stiffness, the accelerometer's offset and sign (accel_x forward), "
                       "or run with force_correction=False (CLI --no-force-correction) for the paper's estimate.")
        out += _sensor_warnings(self.sensor_calibration, self.uncertainty)
        if self.sensors_unverified:
            unc = self.uncertainty
            gyro = "" if unc.unverified_gyro_offset_std is None else \
                f" and the gyro was calibrated with a prior of {unc.unverified_gyro_offset_std:g} rad/s"
            out.append(f"sensors unverified: the gyro or a wheel was beyond its stated offset, so the accelerometer's "
                       f"offset is taken as unknown to {unc.unverified_accel_offset_std:g} m/s^2 in the slope band "
                       f"(not the stated {unc.accel_offset_std:g}){gyro}: the slope interval is wide; calibrate the "
                       "IMU's offsets (standstill) and the wheels, or state them (SlopeUncertainty).")
        return out


def _beyond_spec(cal, unc) -> tuple:
    """(gyro, wheels (4,)): whether the gyro offset and each wheel's scale error found in the log are beyond
    SENSOR_ERROR_WARN x their stated stds and 3 posterior stds."""
    b, b_std = cal.gyro_offset, cal.gyro_offset_std
    gyro = abs(b) > max(SENSOR_ERROR_WARN * unc.gyro_bias_std, 3 * b_std)
    far = np.abs(cal.wheel_scale) > np.maximum(SENSOR_ERROR_WARN * unc.wheel_radius_rel_std, 3 * cal.wheel_scale_std)
    return bool(gyro), far


def _sensor_warnings(cal, unc) -> list:
    """The gyro offset and wheel scale errors far beyond their stated stds (SENSOR_ERROR_WARN), as warnings."""
    if cal is None or unc is None:
        return []
    out = []
    gyro, far = _beyond_spec(cal, unc)
    if gyro:
        out.append(f"the gyro reads {cal.gyro_offset:+.2e} rad/s (+- {cal.gyro_offset_std:.1e}) off the wheel speeds' "
                   f"yaw rate, more than {SENSOR_ERROR_WARN:g} x the stated offset std {unc.gyro_bias_std:g} rad/s: it "
                   "was subtracted, but check the gyro's zero (standstill calibration) and mounting.")
    if far.any():
        names = ", ".join(f"{w} {100 * x:+.2f} %" for w, x, f in zip(("FL", "FR", "RL", "RR"), cal.wheel_scale, far)
                          if f)
        out.append(f"wheel speed scale errors beyond {SENSOR_ERROR_WARN:g} x the stated {unc.wheel_radius_rel_std:g} "
                   f"(relative to the rear axle): {names}; left/right differences were corrected, but check the "
                   "tyres (pressure, wear, a spare wheel) and wheels.radius.")
    return out


@njit(cache=True)
def _forces_along(mean, cov, u, p, slope, omega_rel_std, fx, fy, fx_std, fy_std, res, res_std):
    T = mean.shape[0]
    for k in range(T):
        res[k], res_std[k] = forces_fused(mean, cov, u, p, slope, omega_rel_std, fx, fy, fx_std, fy_std, k)


def estimate_slope(log: DriveLog, vehicle: Vehicle | None = None, *, method: str = "cascade",
                   poles=(-5.0, -7.0), tuning: EKFTuning | None = None, friction=None,
                   initial_state=None, speed_measurement: str = "robust",
                   uncertainty: SlopeUncertainty | None = None, force_correction: bool = True,
                   sensor_calibration: bool = True) -> SlopeEstimate:
    r"""Estimate V_x, V_y, yaw rate, tyre forces and the road slope from a drive log (paper 001).

    Parameters
    ----------
    log : DriveLog
        Wheel speeds, steering angle, gyro yaw rate and accelerometers, uniformly sampled.
    vehicle : Vehicle, optional
        Model parameters (default :func:`default_vehicle`).
    method : {"cascade", "joint"}
        ``"cascade"``: EKF (20) then the Luenberger observer on (21) (the paper, section IV);
        ``"joint"``: one EKF on (V_x, V_y, r, theta_r) with the paper's measurements.
    poles : (2,) sequence of float
        Continuous-time poles of the Luenberger observer, 1/s (cascade only). Faster poles track
        grade changes with less lag and pass more force noise.
    tuning : EKFTuning, optional
        EKF noise settings (default ``EKFTuning.for_method(method)``).
    friction : (4,) or (T, 4) array_like, optional
        Adhesion mu_i assumed by the estimator (default ``vehicle.friction``).
    initial_state : (3,) array_like, optional
        Prior mean of (V_x, V_y, r) (default: first speed reading, 0, first gyro reading); the grade
        starts at 0 in both methods.
    speed_measurement : {"robust", "rear-mean"}
        The V_x measurement (:func:`longprofile.vehicle.speed_reference`). ``"rear-mean"``: the paper's
        mean rear-wheel speed with the fixed std ``tuning.speed_std``. ``"robust"`` (default): the
        torque-free wheels when there are any, else the slip-compensated four wheels, with a
        per-sample std (time-varying R), and missing samples (the EKF propagates) when no wheel is
        trustworthy. On a front-wheel-drive car that is not braking both are the same measurement.
    uncertainty : SlopeUncertainty, optional
        Stated parameter uncertainty and NIS window added to the printed stds (default ``SlopeUncertainty()``;
        ``SlopeUncertainty.noise_only()`` for the filters' stds alone).
    force_correction : bool
        Correct the slope for the drive's force-model error measured against the accelerometer (Notes; default
        True); ``False``: the paper's estimate with the stated mass, force and wheel-radius terms.
    sensor_calibration : bool
        Estimate the gyro offset and the wheels' relative scale errors from the log
        (:func:`~longprofile.vehicle.calibrate_sensors`) and correct the gyro and the wheel speeds before the filters
        (default True; Notes): the gyro and each axle's left/right difference; the front/rear difference, read
        against the accelerometer, is only reported (the force correction takes the same constant).
        ``False``: the log as it is, with the stated ``gyro_bias_std`` in the yaw-rate std (the estimator before
        2026-12-06, bit for bit).

    Returns
    -------
    SlopeEstimate

    Raises
    ------
    InputError
        For an unknown ``method``, invalid settings, or a log with samples below 2 m/s.
    ModelError
        If the filter fails (non-finite model output: check the log's units and the vehicle).

    Notes
    -----
    Cascade (paper 001, section II and IV): the first observer is the EKF of eq. (20) with
    measurements V_x (the paper's R (omega_rl + omega_rr)/2, or the slip-robust reference speed, see
    ``speed_measurement``) and r. Its model is run with theta_r = 0: section
    II requires the first subsystem S1 not to depend on the second observer's state, whereas eq.
    (20) feeds back theta_r-hat, a loop the convergence proof does not cover. The grade acceleration
    is absorbed by the V_x process noise (``vx_rate_psd``), which keeps V_x-hat, hence the slips and
    the forces, close to the wheel-speed data. The second observer is the Luenberger observer on (21)
    with input F_res-hat and output the measured V_x, discretised exactly, gain by pole placement.
    The slope std of the cascade is the stationary std of the observer error (discrete Lyapunov
    equation with the fixed gain) driven by the EKF's median F_res std and the median std of the speed
    input (the measurement's per-sample std; the EKF's V_x std where it is missing), both treated as
    white. That is the noise part only: while the grade changes at a rate rho (rad/s) the observer also
    lags by about rho (-1/p1 - 1/p2) (0.34 s x rho with the default poles), and model errors (mass,
    adhesion; with ``speed_measurement="rear-mean"`` rear-wheel slip under braking) add biases; the
    calibration below adds both to the printed std (see docs/vehicle-slope.md).

    Joint: the augmented EKF (:func:`slope_ekf_model`); its stds come from its covariance.

    Calibration (issue 13; docs/vehicle-slope.md, Calibration): every printed variance is (a) multiplied by the
    NIS inflation of the innovations that carry it (:func:`nis_inflation`) and (b) increased by the parameter
    terms of :class:`SlopeUncertainty` and the cascade's tracking lag. Force correction (beyond the paper):
    mass, tyre and constant force errors shift sin(theta) by beta F_res/(M g) + c for the whole drive; the
    accelerometer sees F_res/M without the grade, so :func:`force_scale_fit` estimates (beta, c) and
    :func:`_force_corrected` removes them (std: their posterior and the accelerometer's errors; SlopeUncertainty).
    Sensor calibration (beyond the paper; ESC-style, van Zanten SAE 2000-01-1633): :func:`calibrate_sensors`.
    """
    vehicle, tuning, unc = _slope_settings(log, vehicle, method, speed_measurement, tuning, uncertainty)
    log, cal, unverified = _calibrated(log, vehicle, unc, sensor_calibration)
    dt = log.dt
    u, ref, y, filtered = _filtered(log, vehicle, method, tuning, friction, initial_state, speed_measurement)
    mean, cov = filtered.mean, filtered.cov
    fx, fy, fx_std, fy_std, res, res_std = _tyre_forces(mean, cov, u, vehicle, method, tuning)
    var = np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0)
    std = np.sqrt(var)
    n_win = int(round(unc.nis_window / dt))
    # (T, 2): V_x, r; scale may deflate (down to nis_floor; the joint grade down to grade_floor), kappa only inflates
    raw = nis_inflation(filtered.innovation, filtered.innovation_cov, n_win, floor=min(unc.nis_floor, unc.grade_floor))
    scale = np.maximum(raw, unc.nis_floor)
    kappa = np.maximum(scale, 1.0)
    slope, s_var, gain, lag = _uncorrected_slope(vehicle, unc, method, dt, mean, var, std, raw, y, ref, res, res_std,
                                                 poles, n_win)
    slope, s_var, fit = _force_corrected(vehicle, unc, force_correction, log.accel_x, mean, slope, s_var, res,
                                         gain, dt, lag, unverified)
    slope_std = np.sqrt(s_var / np.maximum(np.cos(slope) ** 2, 1e-12))
    gyro_std = unc.gyro_bias_std if cal is None else cal.gyro_offset_std
    r_var = yaw_rate_variance(filtered, log.yaw_rate, n_win) if unc.yaw_rate_from_gain and n_win >= 2 \
        else var[:, 2] * scale[:, 1]
    std = np.sqrt(np.column_stack([var[:, 0] * kappa[:, 0] + (unc.radius_rel_std * mean[:, 0]) ** 2,
                                   var[:, 1] * kappa.max(axis=1), r_var + gyro_std ** 2]))
    return SlopeEstimate(time=log.time, vx=mean[:, 0].copy(), vy=mean[:, 1].copy(), yaw_rate=mean[:, 2].copy(),
                         vx_std=std[:, 0].copy(), vy_std=std[:, 1].copy(), yaw_rate_std=std[:, 2].copy(),
                         slope=slope, slope_std=slope_std, fx=fx, fy=fy, fx_std=fx_std, fy_std=fy_std,
                         resisting_force=res, resisting_force_std=res_std, method=method, filtered=filtered,
                         observer_gain=gain, speed_reference=ref, force_fit=fit, sensor_calibration=cal,
                         uncertainty=unc, sensors_unverified=unverified)


def _uncorrected_slope(vehicle, unc, method, dt, mean, var, std, raw, y, ref, res, res_std, poles, n_win):
    """(slope, variance of sin(slope), observer gain or None, tracking lag in s) before the force correction: the
    joint EKF's grade (its variance scaled by the V_x NIS down to ``unc.grade_floor``) or the cascade's Luenberger
    observer on eq. (21) driven by the measured V_x (the EKF's where the measurement is missing)."""
    if method != "cascade":
        slope = mean[:, 3].copy()
        grade_scale = np.maximum(raw[:, 0], unc.grade_floor)
        return slope, var[:, 3] * grade_scale * (1.0 - np.sin(slope) ** 2), None, 0.0  # of sin(theta)
    missing = np.isnan(y[:, 0])
    speed = np.where(missing, mean[:, 0], y[:, 0])
    speed_std = float(np.median(np.where(missing, std[:, 0], ref.std)))
    slope, s_var, gain = _cascade_slope(vehicle, dt, speed, speed_std, res, res_std, poles, n_win)
    return slope, s_var, gain, float(sum(-1.0 / p for p in poles)) if unc.tracking_lag else 0.0


def _filtered(log, vehicle, method, tuning, friction, initial_state, speed_measurement):
    """(u, ref, y, filtered): the model inputs, the V_x measurement, the measurements (V_x NaN where missing) and
    the engine's EKF result of the method on ``log``."""
    from ...statespace import extended_kalman_filter
    from ._speed_reference import speed_reference

    u = planar_inputs(log, vehicle, friction=friction)
    ref = speed_reference(log, vehicle, method=speed_measurement, speed_std=tuning.speed_std, friction=friction)
    y = np.column_stack([ref.speed, log.yaw_rate])  # V_x NaN where missing (no trustworthy wheel)
    rear = _rear_speed(log, vehicle)
    model = _slope_filter_model(vehicle, log.dt, method, _slope_initial_state(initial_state, y, rear), tuning, ref, y)
    return u, ref, y, extended_kalman_filter(model, y, u=u)


def _calibrated(log, vehicle, unc, sensor_calibration):
    """(log, calibration, unverified): the log with the gyro offset and the wheels' left/right scale differences found
    in it corrected (:func:`calibrate_sensors`, its front/rear part left out), or the log as it is and None
    (calibration off, or no calibration prior). ``unverified``: the calibration with the stated priors found the
    gyro or a wheel beyond its stated std (:func:`_beyond_spec`) and ``SlopeUncertainty.unverified_accel_offset_std``
    is set; the gyro is then calibrated again with ``unverified_gyro_offset_std`` (if set) as its prior."""
    if not (sensor_calibration and unc.gyro_offset_prior_std > 0 and unc.wheel_scale_prior_std > 0):
        return log, None, False
    kw = dict(wheel_prior_std=unc.wheel_scale_prior_std, accel_offset_std=unc.accel_offset_std,
              slip_prior_std=max(math.hypot(unc.mass_rel_std, unc.force_rel_std), 1e-6),
              axle_prior_std=math.hypot(unc.radius_rel_std, unc.wheel_scale_prior_std / math.sqrt(2))
              if unc.radius_in_calibration else None)
    cal = calibrate_sensors(log, vehicle, gyro_prior_std=unc.gyro_offset_prior_std, **kw)
    gyro, wheels = _beyond_spec(cal, unc)
    unverified = unc.unverified_accel_offset_std is not None and (gyro or bool(wheels.any()))
    if unverified and unc.unverified_gyro_offset_std is not None:
        cal = calibrate_sensors(log, vehicle, gyro_prior_std=unc.unverified_gyro_offset_std, **kw)
    return cal.corrected(log, front_rear=False), cal, unverified


def _slope_settings(log, vehicle, method, speed_measurement, tuning, uncertainty):
    """estimate_slope's settings checked, with their defaults: (vehicle, EKF tuning, uncertainty)."""
    if method not in ("cascade", "joint"):
        raise InputError(f"method must be 'cascade' or 'joint'; got {method!r}.")
    if speed_measurement not in ("robust", "rear-mean"):
        raise InputError(f"speed_measurement must be 'robust' or 'rear-mean'; got {speed_measurement!r}.")
    if not isinstance(log, DriveLog):
        raise InputError(f"log must be a DriveLog; got {type(log).__name__}.")
    vehicle = default_vehicle() if vehicle is None else vehicle
    tuning = EKFTuning.for_method(method) if tuning is None else tuning
    unc = SlopeUncertainty() if uncertainty is None else uncertainty
    if not isinstance(unc, SlopeUncertainty):
        raise InputError(f"uncertainty must be a SlopeUncertainty; got {type(unc).__name__}.")
    return vehicle, tuning, unc


def rear_wheel_speed(log, vehicle) -> np.ndarray:
    """The mean rear-wheel speed R (omega_rl + omega_rr) / 2, m/s (the speed the standstill limit is tested on)."""
    return 0.5 * vehicle.wheel_radii[1] * (log.wheel_speeds[:, 2] + log.wheel_speeds[:, 3])


def _rear_speed(log, vehicle) -> np.ndarray:
    """:func:`rear_wheel_speed`, checked to stay above _MIN_SPEED."""
    rear = rear_wheel_speed(log, vehicle)
    slow = rear < _MIN_SPEED
    if slow.any():
        k = int(np.argmax(slow))
        raise InputError(f"the rear-wheel speed is below {_MIN_SPEED:g} m/s at {int(slow.sum())} sample(s), first at "
                         f"t = {log.time[k]:g} s ({rear[k]:.3g} m/s); the planar model of paper 001 (slips of eq. "
                         "(18)) is not valid near standstill: cut those parts of the log, or estimate each moving "
                         "stretch on its own (estimate_slope_split; CLI: vehicle slope --stops split).")
    return rear


def _slope_initial_state(initial_state, y, rear) -> list:
    """The prior mean of (V_x, V_y, r): ``initial_state`` checked, or the first speed reading, 0, the first gyro."""
    if initial_state is None:
        return [float(y[0, 0]) if np.isfinite(y[0, 0]) else float(rear[0]), 0.0, y[0, 1]]
    x0 = as_float_array("initial_state", initial_state, ndim=1, allow_nan=False)
    if x0.shape != (3,):
        raise ShapeError(f"initial_state must be (V_x, V_y, r); got shape {x0.shape}.")
    return x0.tolist()


def _slope_filter_model(vehicle, dt, method, x0, tuning, ref, y):
    """The EKF of the method (eq. (20), or the joint one with the grade), with a per-sample R from the speed
    reference's std when it varies."""
    if method != "cascade":
        model = slope_ekf_model(vehicle, dt, initial_state=x0 + [0.0], tuning=tuning)
    else:
        model = planar_ekf_model(vehicle, dt, initial_state=x0, tuning=tuning)
    if np.any(ref.std != tuning.speed_std):  # per-sample R from the speed std (any value where V_x is missing)
        from dataclasses import replace

        R_t = np.zeros((y.shape[0], 2, 2))
        R_t[:, 0, 0] = np.square(np.where(np.isnan(ref.std), tuning.speed_std, ref.std))
        R_t[:, 1, 1] = tuning.yaw_rate_std ** 2
        model = replace(model, obs_cov=R_t)
    return model


def _tyre_forces(mean, cov, u, vehicle, method, tuning):
    """(fx, fy, fx_std, fy_std, F_res, F_res std) along the estimate (loads at the joint EKF's grade, or level)."""
    T = mean.shape[0]
    p = vehicle.as_array()
    slope_for_loads = mean[:, 3].copy() if method != "cascade" else np.zeros(T)
    fx = np.empty((T, 4))
    fy = np.empty((T, 4))
    fx_std = np.empty((T, 4))
    fy_std = np.empty((T, 4))
    res = np.empty(T)
    res_std = np.empty(T)
    _forces_along(mean, cov, u, p, slope_for_loads, tuning.wheel_speed_rel_std, fx, fy, fx_std, fy_std, res, res_std)
    return fx, fy, fx_std, fy_std, res, res_std


def nis_inflation(innovation, innovation_cov, window: int, *, floor: float = 1.0) -> np.ndarray:
    r"""Variance scale factors from innovation consistency, (T, m), each >= ``floor``.

    kappa_j(t) = max(floor, mean over a centred moving window of ``window`` samples of nu_j^2 / S_jj): the
    normalized innovation squared has expectation 1 when the filter's noise model holds, so a windowed mean above 1
    says by how much the filter's variances are too small there. With ``floor`` 1 (default) the factors only
    inflate; below 1 they also deflate where the innovations are smaller than the filter predicts (covariance
    matching, Mehra 1972: a stated sensor noise larger than the sensor's), down to ``floor``. Missing components
    count as 1 (no evidence); a window below 2 samples gives 1 everywhere.
    """
    from scipy.ndimage import uniform_filter1d

    nu = np.asarray(innovation, dtype=float)
    s = np.diagonal(np.asarray(innovation_cov, dtype=float), axis1=1, axis2=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        nis = np.square(nu) / s
    nis = np.where(np.isfinite(nis), nis, 1.0)
    if window < 2:
        return np.ones_like(nis)
    if not (math.isfinite(floor) and 0.0 < floor <= 1.0):
        raise InputError(f"floor must be in (0, 1]; got {floor!r}.")
    # one contiguous series per component (m <= a few): scipy's 1-D filter is fastest on contiguous data
    out = np.column_stack([uniform_filter1d(np.ascontiguousarray(nis[:, j]), size=window, mode="nearest")
                           for j in range(nis.shape[1])])
    return np.maximum(out, floor)


def yaw_rate_variance(filtered, gyro, window: int) -> np.ndarray:
    r"""Variance (T,) of the EKF's yaw rate from its gain and the noise measured in the log (session 38).

    The update r+ = r- + K nu (nu = gyro - r-, K the filter's gain on it, P-_rr / S_rr) leaves the error
    e+ = (1 - K) e- + K v (e- the prediction error, v the gyro's noise), of variance

    .. math::  \sigma_r^2 = (1 - K)^2 P + K^2 R,\qquad P = \max(\overline{\nu^2} - R, 0),

    whatever the filter assumed for them: R, the variance of the gyro's white noise, is measured from the log's
    second differences, mean((y[k-1] - 2 y[k] + y[k+1])^2) / 6 (Gasser, Sroka & Jennen-Steinmetz 1986, Biometrika
    73(3), 625-633: the yaw rate's own curvature over 2 steps is negligible against the noise at 50 Hz or more),
    and E[nu^2] = P + R gives the prediction error's variance P from the innovations' mean square over a centred
    moving window of ``window`` samples (as :func:`nis_inflation`). Scaling the filter's variance by the NIS
    instead assumes the prediction's and the gyro's variances are both off by the innovations' ratio: near enough
    at 1 kHz, where K ~ 0.4 (coverage 89.7-93.8 % there), but at 50-200 Hz the process noise's growth over a step (Q = psd dt) drives K to
    0.6-0.85 and most of the gyro's noise into r, which that scaling missed.

    Parameters
    ----------
    filtered : FilterResult
        The EKF's result (``pred_cov``, ``innovation``, ``innovation_cov``; the yaw rate is state 2 and measurement 1).
    gyro : (T,) ndarray
        The gyro readings the filter was given, rad/s.
    window : int
        Samples of the moving window (>= 2).

    Returns
    -------
    (T,) ndarray
        rad^2/s^2. Assumption: the gyro's noise is white at the log's rate (plain sampling of a white sensor noise,
        or a sensor band-limited to the log's Nyquist frequency), and its offset is left to the calibration's term.
    """
    from scipy.ndimage import uniform_filter1d

    gyro = np.asarray(gyro, dtype=float)
    nu = filtered.innovation[:, 1]
    K = filtered.pred_cov[:, 2, 2] / filtered.innovation_cov[:, 1, 1]
    R = float(np.mean(np.square(np.diff(gyro, 2)))) / 6.0
    ms = uniform_filter1d(np.nan_to_num(np.square(nu)), size=max(int(window), 2), mode="nearest")
    return np.square(1.0 - K) * np.maximum(ms - R, 0.0) + np.square(K) * R


def _force_corrected(vehicle, unc, force_correction, accel_x, mean, slope, s_var, res, gain, dt, lag, unverified):
    """(slope, variance of sin(theta), fit) with the force-model correction and the parameter terms.

    ``fit`` is :func:`force_scale_fit` of the drive (None without ``force_correction`` or without a stated mass
    and force uncertainty). Without a fit (or with too short a log: ``n_blocks`` 0) the slope is unchanged and
    the stated mass, force and wheel-radius terms are added; with one, sin(theta) - beta s - c is returned, s the shift per unit
    relative force error (the cascade observer's response to its force input, observer gain ``gain``; the joint,
    ``gain`` None: F_res averaged / (M g)), and its
    variance is the posterior of (beta, c), the accelerometer's gain and offset errors and the fit's residual
    variance, which replaces the filter's variance where larger (``SlopeUncertainty.residual_overlap``; added to
    it with False) (estimate_slope, Notes). ``unverified``: the accelerometer's offset is as uncertain as the force
    model's constant may be (``SlopeUncertainty.unverified_accel_offset_std``), so only the posterior share w of the
    fitted constant is the force model's (:func:`_offset_share`)."""
    force_var = unc.mass_rel_std ** 2 + unc.force_rel_std ** 2
    fit = None
    if force_correction and force_var > 0:
        fit = force_scale_fit(res, accel_x, mean[:, 2], mean[:, 1], vehicle.mass, dt,
                              beta_prior_std=math.sqrt(force_var), offset_prior_std=unc.offset_prior_std)
    corrected = fit is not None and fit.n_blocks > 0
    if corrected and gain is not None:  # the cascade: the observer is linear, a force error beta F_res moves
        from ...statespace import luenberger_observer  # its sin(theta) by beta times its response to F_res alone

        A, B, C = slope_observer_matrices(vehicle)
        shape = luenberger_observer(A, B, C, gain, np.zeros_like(res), u=res[:, None], x0=np.zeros(2), dt=dt).state[:, 1]
    else:
        shape = _observer_mean(res, dt, lag) / (vehicle.mass * GRAVITY)
    if corrected:
        w, offset_var = _offset_share(unc, unverified)
        slope = np.arcsin(np.clip(np.sin(slope) - fit.beta * shape - w * fit.offset, -1.0, 1.0))
        resid_var = np.nan_to_num(fit.residual_std) ** 2
        if unc.residual_overlap:  # the filter's variance and the blocks' scatter: the same force noise, keep the larger
            s_var = np.maximum(s_var, resid_var) + (fit.cov[0, 0] + unc.accel_gain_std ** 2) * shape ** 2 \
                + 2 * (w * fit.cov[0, 1]) * shape + (w * w) * fit.cov[1, 1] + offset_var
        else:  # until 2026-12-06: added (same expression, same rounding)
            s_var = s_var + (fit.cov[0, 0] + unc.accel_gain_std ** 2) * shape ** 2 + 2 * (w * fit.cov[0, 1]) * shape \
                + (w * w) * fit.cov[1, 1] + offset_var + resid_var
        force_var = 0.0
    s_var = s_var + _parameter_var(vehicle, unc, shape, force_var, mean[:, 0], slope, dt, lag, wheels=not corrected)
    return slope, s_var, fit


def _offset_share(unc, unverified) -> tuple:
    """(w, variance in sin(theta)): the share of the force fit's constant c = c_force - b_a/g taken as the force
    model's, and the variance of the accelerometer's part left in the slope. Calibrated sensors: (1, (s_a/g)^2),
    the stated offset s_a (``accel_offset_std``); unverified (``unverified_accel_offset_std``): with the prior
    stds s_c of c_force (``offset_prior_std``) and s_u of b_a/g, the posterior of c_force given c,
    w = s_c^2 / (s_c^2 + s_u^2) and s_c^2 s_u^2 / (s_c^2 + s_u^2)."""
    if not unverified:
        return 1.0, (unc.accel_offset_std / GRAVITY) ** 2
    s_c2, s_u2 = unc.offset_prior_std ** 2, (unc.unverified_accel_offset_std / GRAVITY) ** 2
    return s_c2 / (s_c2 + s_u2), s_c2 * s_u2 / (s_c2 + s_u2)


def _observer_mean(x, dt, lag):
    """Moving mean of ``x`` over the observer's time constant (``lag``, at least 0.2 s): it low-passes its inputs."""
    from scipy.ndimage import uniform_filter1d

    return uniform_filter1d(x, size=max(int(round(max(lag, 0.2) / dt)), 1), mode="nearest")


def _parameter_var(vehicle, unc, shape, force_var, vx, slope, dt, lag, wheels=True):
    """Variance (T,) of sin(theta) from the parameter errors and the observer lag (SlopeUncertainty Notes).

    ``shape`` is the shift of sin(theta) per unit relative force error (F_res averaged over the observer's time
    constant / (M g), or the cascade observer's response), ``force_var`` the variance of the relative force
    error; ``wheels``: add the fake slips of unequal wheel radii (not when the force correction took them out)."""
    mg = vehicle.mass * GRAVITY
    accel = np.gradient(_observer_mean(vx, dt, lag), dt)
    rate = np.gradient(_observer_mean(np.sin(slope), dt, lag), dt)
    w = sum(vehicle.longitudinal_stiffnesses) * unc.wheel_radius_rel_std / mg if wheels else 0.0
    return force_var * shape ** 2 + w ** 2 \
        + (unc.radius_rel_std * accel / GRAVITY) ** 2 + (lag * rate) ** 2


def _cascade_slope(vehicle, dt, speed, speed_std, res, res_std, poles, n_win):
    """Luenberger observer on (21) run by the engine (exact zero-order-hold integration of its ODE).

    ``speed_std`` (m/s) is the median std of the observer's speed input (the V_x measurement, or the EKF's
    V_x where the measurement is missing). Returns the slope, the variance (T,) of sin(theta) (stationary
    Lyapunov value times the NIS inflation of the observer's output error) and the gain."""
    from scipy.linalg import solve_continuous_lyapunov

    from ...statespace import luenberger_observer

    A, B, C = slope_observer_matrices(vehicle)
    L = slope_observer_gain(vehicle, poles=poles)
    obs = luenberger_observer(A, B, C, L, speed, u=res[:, None], x0=np.array([speed[0], 0.0]), dt=dt)
    state = obs.state
    if not np.all(np.isfinite(state)) or np.any(np.abs(state[:, 1]) > 1.0):
        raise ModelError("the slope observer diverged (|sin(theta_r)| > 1); check the poles, the vehicle mass "
                         "and the units of the log.")
    s = state[:, 1]
    slope = np.arcsin(s)
    # error dynamics de/dt = (A - L C) e + B w_F - L v with white noises of PSD var * dt (sampled at dt)
    var_f = float(np.median(res_std) ** 2)
    M = A - L @ C
    P = solve_continuous_lyapunov(M, -(B @ B.T * var_f + L @ L.T * speed_std ** 2) * dt)
    # output error y - C x_hat = v - e_1: predicted variance P_11 + speed_std^2 (e_1 and v treated as independent)
    e_y = (speed - state[:, 0])[:, None]
    kappa = nis_inflation(e_y, np.full((s.size, 1, 1), P[0, 0] + speed_std ** 2), n_win)[:, 0]
    return slope, max(P[1, 1], 0.0) * kappa, L
