"""The rail estimate's result types (paper 004 and beyond): numpy and pandas only.

A process that only reads or draws a result, such as the figure helper of ``rail settle --plot --report``
(``report/_render.py``), unpickles it without importing scipy or numba (0.35-0.4 s of imports before, when the
classes lived in the modules that compute them). Each class is re-exported, under its name, by the module that
computes it (``_settle``, ``_thermal``, ``_health``, ``_shapes``, ``_rigidity``, ``_temporal``, ``_controls``)
and by :mod:`longprofile.rail`; their methods stay light (no scipy, numba or engine here).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
import pandas as pd

__all__ = ["SettlementResult", "ChangePriorFit", "SensorHealth", "ReversalEvidence", "StepEvidence", "ShapeEvidence",
           "ProfilePosterior", "TemporalSettlement", "DailyAngles", "ControlCheck", "Z90"]


#: Two-sided 90 % normal quantile (the paper rounds it to 1.6).
Z90 = 1.6448536269514722


@dataclass(frozen=True, eq=False)
class ProfilePosterior:
    """Gaussian posterior of (altitude, slope) at the stations, for one or several profiles (days).

    Attributes
    ----------
    x : (N,) ndarray
        Station positions, m.
    z_mean, slope_mean : (N,) or (D, N) ndarray
        Posterior means of the altitude (m) and slope (rad ≈ m/m); one row per profile.
    z_std, slope_std : (N,) or (D, N) ndarray
        Posterior standard deviations.
    station_cov : (N, k, k) or (D, N, k, k) ndarray
        Posterior covariance of (z_i, theta_i) at each station (k = 2), or of (z_i, theta_i, kappa_i)
        with the curvature for ``penalty_order=3`` (k = 3).
    cross_cov : (N-1, k, k) or (D, N-1, k, k) ndarray or None
        Cov((z_i, theta_i), (z_{i+1}, theta_{i+1})): with ``station_cov`` it determines the
        whole joint posterior (the posterior is Markov along the track). None for the dense reference.
    full_cov : (2N, 2N) ndarray or None
        Full covariance of X = (z_1..z_N, theta_1..theta_N), dense reference only.
    log_likelihood : float or (D,) ndarray or None
        Marginal log-likelihood of the observations (engine only; used to estimate sigma and r).
    method : str
        ``"dense"`` (the paper's formula) or ``"state-space"`` (RTS smoother over stations).
    """

    x: np.ndarray
    z_mean: np.ndarray
    slope_mean: np.ndarray
    z_std: np.ndarray
    slope_std: np.ndarray
    station_cov: np.ndarray
    cross_cov: np.ndarray | None
    full_cov: np.ndarray | None
    log_likelihood: float | np.ndarray | None
    method: str

    def z_band(self, level_z: float = Z90) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) altitude band, mean ∓ ``level_z`` std (default: two-sided 90 %)."""
        return self.z_mean - level_z * self.z_std, self.z_mean + level_z * self.z_std


@dataclass(frozen=True, eq=False)
class DailyAngles:
    """Daily angles per sensor after outlier removal and thermal correction.

    Attributes
    ----------
    days : (D,) datetime64[ns] ndarray
        Calendar days covered by the readings.
    sensor_ids : list of str
        Sensors by station (same order as ``SiteData.sensors``).
    angle_deg : (D, N) ndarray
        Daily median of the corrected angles, deg (NaN when a sensor has no reading that day).
    change_deg : (D, N) ndarray
        Angle change since the sensor's first day with readings, deg.
    n_readings : (D, N) int ndarray
        Readings used per day and sensor (after outlier removal).
    n_outliers : (N,) int ndarray
        Readings set aside as outliers per sensor (never silently: reported).
    raw_std_deg : (N,) ndarray
        Robust std of each sensor's raw readings (a dead sensor has ~0).
    raw_day_spread_deg : (D, N) ndarray or None
        Robust within-day spread (1.4826 MAD) of each sensor's raw readings (before outlier removal and
        thermal correction), deg; NaN on days with fewer than 2 readings. A sensor frozen from some day on
        reads the same value all day (the frozen-sensor test of :func:`~longprofile.rail.assess_sensors`).
    temperature_mean_c : (D,) ndarray or None
        Site-mean daily temperature (mean of every finite temperature reading of the day), °C.
    noise_deg : (N,) ndarray
        Robust high-frequency noise std of each sensor (:func:`_noise_std`), deg: the outlier threshold is
        ``OUTLIER_THRESHOLD`` max(noise_deg, 1e-4).
    thermal_coef : (N,) ndarray
        k, deg/°C (0 for ``thermal="none"``).
    thermal_lag_hours : (N,) ndarray
        tau, h (0 for the linear model).
    reference_temp_c : float
        T_ref of the correction, °C.
    thermal : str
        ``"linear"``, ``"lagged"`` or ``"none"`` (the model used; ``thermal="auto"`` gives one of the first two).
    warnings : tuple of str
        Sensors whose thermal coefficient could not be fitted (left uncorrected), reported.
    lag_variance_ratio : float or None
        With ``thermal="auto"``: the median over sensors of :func:`lag_variance_ratio`, which chose the model
        (lagged below ``LAG_AUTO_RATIO``); None otherwise.
    rebaselined : (D, N) int ndarray or None
        0 where a sensor's change refers to its first day, k + 1 from its k-th new reference on (a re-installed or
        replaced sensor, :func:`~longprofile.rail._reinstall.rebaseline_daily`); None: no new reference.
    """

    days: np.ndarray
    sensor_ids: list
    angle_deg: np.ndarray
    change_deg: np.ndarray
    n_readings: np.ndarray
    n_outliers: np.ndarray
    raw_std_deg: np.ndarray
    noise_deg: np.ndarray
    thermal_coef: np.ndarray
    thermal_lag_hours: np.ndarray
    reference_temp_c: float
    thermal: str
    warnings: tuple = ()
    raw_day_spread_deg: np.ndarray | None = None
    temperature_mean_c: np.ndarray | None = None
    lag_variance_ratio: float | None = None
    rebaselined: np.ndarray | None = None
    #: A day holding less than this share of the median day's readings is a partial day (the first such days are left
    #: out by :func:`~longprofile.rail.estimate_settlement`; a partial last day is named by ``rail settle``).
    PARTIAL_DAY_SHARE: ClassVar[float] = 0.5

    def reading_shares(self) -> np.ndarray:
        """(D,) each day's readings (all sensors) over the median day's: below :attr:`PARTIAL_DAY_SHARE`, part of a
        day (a record starting late, installation tests, a day still being recorded)."""
        total = self.n_readings.sum(axis=1).astype(float)
        return total / max(float(np.median(total)), 1.0)

    def select_days(self, mask) -> "DailyAngles":
        """The same angles on the days where ``mask`` (D,) is True; each sensor's changes from its first kept day."""
        m = np.asarray(mask, bool)
        per_day = {f: getattr(self, f)[m] for f in ("days", "angle_deg", "n_readings")}
        per_day["change_deg"] = _changes(per_day["angle_deg"])
        per_day.update({f: getattr(self, f)[m] for f in ("raw_day_spread_deg", "temperature_mean_c", "rebaselined")
                        if getattr(self, f) is not None})
        return replace(self, **per_day)


def _changes(angle: np.ndarray) -> np.ndarray:
    """(D, N) each sensor's daily angle minus its angle on its first day with one (NaN before it and where missing)."""
    change = np.full_like(angle, np.nan)
    for j in range(angle.shape[1]):
        ok = np.nonzero(np.isfinite(angle[:, j]))[0]
        if ok.size:
            change[:, j] = angle[:, j] - angle[ok[0], j]
    return change


@dataclass(frozen=True, eq=False)
class SensorHealth:
    """Health of each sensor.

    Attributes
    ----------
    sensor_ids : list of str
    status : (N,) ndarray of str
        One of :data:`SENSOR_STATUSES`.
    detail : (N,) ndarray of str
        Why (statistic and threshold) — printed in reports.
    excluded : (N,) bool ndarray
        True for every status other than "ok": these sensors do not enter the settlement.
    loo_score : (N,) ndarray
        Mean squared standardised leave-one-out residual over days (≈1 for a healthy sensor);
        NaN for dead sensors.
    reversal_z : (N,) ndarray or None
        Reversal statistic z_rev (:data:`REVERSED_Z`): ~N(0, 1) or very negative for a healthy
        sensor, large and positive when its changes follow minus the neighbours' prediction.
    reversal_llr : (N,) ndarray or None
        Day-to-day reversal log-likelihood ratio (:data:`REVERSED_LLR`): negative for a sensor that
        follows its neighbours, large and positive for a reversed one.
    step_z : (N,) ndarray or None
        Largest day-to-day leave-one-out residual change in robust std of the others (:data:`STEP_Z`).
    reversal_evidence : ReversalEvidence or None
        The all-days log Bayes factor of "reversed" against "healthy" of every sensor
        (:func:`all_days_reversal_evidence`; None when the all-days model did not run).
    step_evidence : StepEvidence or None
        The all-days step log-likelihood ratio of every sensor (:func:`all_days_step_evidence`; None when the
        all-days model did not run or a reversal was flagged on the last pass).
    shape_evidence : ShapeEvidence or None
        The localised-shape evidence of a reversal of the sensors :func:`shape_candidates` chose on the last pass (NaN
        for the others; None when none was or the all-days model did not run).
    anchor_std : float or None
        The end-anchor std (m) of the last pass's leave-one-out prediction (``sigma_z``, or its maximum-likelihood
        value with ``fit_anchor``; docs/rail.md, "Sensor health on settlements that are not a bowl").
    witness : (N,) bool ndarray or None
        With ``witness_rule="steps"``: the kept sensors whose departure from their neighbours grew in separate
        same-sign steps (:func:`step_witness_z`), which the step tests therefore did not flag; None otherwise.
    excluded_witness : (N,) bool ndarray or None
        The sensors :func:`assess_sensors` excluded by the step or leave-one-out tests whose record, when they were
        flagged, was a witness's (the test of ``witness``): the departure grew in separate same-sign steps, as at a
        settling transition (joint, abutment, culvert) the neighbours do not see. ``estimate_settlement`` warns about
        them (docs/rail.md, "Sensor health: an excluded sensor that may be a witness"); None from callers that built
        the health without it.
    reversal_llr_scale : (N,) ndarray or None
        :func:`record_length_factor` of each sensor's number of day-to-day changes on the last pass: the factor on the
        thresholds of ``reversal_llr`` (None: 1).
    """

    sensor_ids: list
    status: np.ndarray
    detail: np.ndarray
    excluded: np.ndarray
    loo_score: np.ndarray
    reversal_z: np.ndarray | None = None
    reversal_llr: np.ndarray | None = None
    step_z: np.ndarray | None = None
    reversal_evidence: "ReversalEvidence | None" = None
    step_evidence: "StepEvidence | None" = None
    shape_evidence: "ShapeEvidence | None" = None
    anchor_std: float | None = None
    witness: np.ndarray | None = None
    excluded_witness: np.ndarray | None = None
    reversal_llr_scale: np.ndarray | None = None

    def flagged(self) -> list[tuple[str, str, str]]:
        """(sensor_id, status, detail) of every excluded sensor."""
        return [(str(s), str(st), str(d)) for s, st, d, e in zip(self.sensor_ids, self.status, self.detail, self.excluded)
                if e]


@dataclass(frozen=True, eq=False)
class ReversalEvidence:
    """Evidence that each sensor is mounted back to front, from all days at once (:func:`all_days_reversal_evidence`).

    Attributes
    ----------
    log_bayes_factor : (N,) ndarray
        log p(data | sensor i reversed) - log p(data | sensor i healthy), the other sensors as they are; NaN for
        excluded sensors. Negative for a sensor that follows its neighbours.
    information : (N,) ndarray
        sum_k mu_ik^2 / v_ik: how much the neighbours predict of the sensor's changes (its squared signal-to-noise
        ratio over all days). Under "healthy" the log Bayes factor has mean -2 information and variance
        4 information; a sensor whose information is below ~2 cannot show a reversal.
    null_shift, null_scale : float
        The site's null taken out by :func:`site_reversal_null` (0 and 1: the model's own).
    """

    log_bayes_factor: np.ndarray
    information: np.ndarray
    null_shift: float = 0.0
    null_scale: float = 1.0


@dataclass(frozen=True, eq=False)
class StepEvidence:
    """Evidence that each sensor's readings jumped once and stayed (:func:`all_days_step_evidence`).

    Attributes
    ----------
    log_likelihood_ratio : (N,) ndarray
        max over the first day d of the step and its size of log p(data | step at d) - log p(data | healthy), sensor
        i's own noise factor fitted under each hypothesis; NaN for excluded sensors.
    day : (N,) ndarray of int
        The maximising d (1..D-1; -1 for excluded sensors).
    size : (N,) ndarray
        The fitted step, rad.
    factor_healthy, factor_step : (N,) ndarray
        The maximising noise factor f under each hypothesis.
    """

    log_likelihood_ratio: np.ndarray
    day: np.ndarray
    size: np.ndarray
    factor_healthy: np.ndarray
    factor_step: np.ndarray


@dataclass(frozen=True, eq=False)
class ShapeEvidence:
    """The localised-shape evidence of a reversal of every sensor (:func:`shape_reversal_evidence`).

    Attributes
    ----------
    log_bayes_factor : (N,) ndarray
        log BF_j of "sensor j reversed" against "healthy" under the dictionary's mixture weighed by the other sensors
        (module docstring); NaN for excluded sensors and sensors not asked for.
    information : (N,) ndarray
        I_j = sum_k mu_jk^2 / v_jk of the shape that fits the other sensors best.
    family : (N,) ndarray of int
        The dictionary family (:data:`DICTIONARY_FAMILIES`) of that shape (-1 where NaN or unknown).
    """

    log_bayes_factor: np.ndarray
    information: np.ndarray
    family: np.ndarray


@dataclass(frozen=True, eq=False)
class TemporalSettlement:
    """Settlement smoothed across days.

    Attributes
    ----------
    mean, std : (D, N) ndarray
        Smoothed altitude change and its std, m.
    rate, rate_std : (D, N) ndarray
        Altitude change per day s_d - s_{d-1} and its std, m/day (NaN on day 0).
    process_std : float
        q, m/day (maximum likelihood on the grid :data:`PROCESS_STD_GRID`).
    """

    mean: np.ndarray
    std: np.ndarray
    rate: np.ndarray
    rate_std: np.ndarray
    process_std: float


@dataclass(frozen=True)
class ControlCheck:
    """Do the control surveys agree with the estimate? (:func:`check_controls`).

    Attributes
    ----------
    n_points : int
        Control points compared (inside the sensors' span and the initial survey's).
    n_outside : int
        Points whose control lies outside the estimate's 90 % band widened by the survey noise.
    chi2 : float
        sum z^2 of the standardised differences.
    p_value : float
        P(chi-squared with ``n_points`` degrees of freedom > ``chi2``).
    disagree : bool
        ``p_value`` below ``CONTROL_CHECK_P``.
    worst : tuple
        (date, x_m, control minus estimate in m, z) of the point of largest |z|.
    offsets : tuple of (date, offset_m, spread_m)
        The surveys whose disagreement is one offset shared by all their points (:func:`common_offsets`): the
        weighted mean of control minus estimate and the RMS of the differences around it, m; empty otherwise.
    """

    n_points: int
    n_outside: int
    chi2: float
    p_value: float
    disagree: bool
    worst: tuple
    offsets: tuple = ()

    def message(self) -> str:
        """The warning printed when the surveys disagree (empty when they agree)."""
        if not self.disagree:
            return ""
        date, x, diff, z = self.worst
        head = (f"the control surveys disagree with the estimate: {self.n_outside} of {self.n_points} control points "
                f"outside the 90 % band (about {max(1, round(0.1 * self.n_points))} expected), chi-squared "
                f"{self.chi2:.3g} on {self.n_points} points (p = {self.p_value:.1e}); the largest difference is "
                f"{1e3 * diff:+.1f} mm at x = {x:g} m on {date} ({z:+.1f} std). ")
        offset = ""
        if self.offsets:
            shown = ", ".join(f"{1e3 * c:+.1f} mm on {d} (spread {1e3 * s:.1f} mm)" for d, c, s in self.offsets[:3])
            more = f" and {len(self.offsets) - 3} more survey(s)" if len(self.offsets) > 3 else ""
            offset = (f"Same offset at every point of a survey: {shown}{more}. Controls levelled on another datum or "
                      "benchmark than the initial survey? Subtract the offset from their z_m (or re-reference them to "
                      "the initial survey's benchmark) and run again; if the benchmark is the same, the whole span "
                      "moved, its ends too. Otherwise, ")
        return (head + offset + ("the" if offset else "The") + " estimate's assumptions do not "
                "hold here: a span end that moved, or a step seen by one or two sensors and excluded as a fault "
                "(docs/rail.md, \"Control surveys\"); trust the controls, look at the report's control figure, and "
                "extend the instrumented span beyond the works or try --end-ambiguity mixture.")


@dataclass(frozen=True)
class ChangePriorFit:
    """Maximum-likelihood choice of the prior of the change profile (:func:`fit_change_prior`).

    Attributes
    ----------
    penalty_order : int
        The order with the larger maximised likelihood (2 = the paper's ||f''||^2, 3 = ||f‴||^2).
    rigidity : float
        Its maximum-likelihood r (m^-2 or m^-4).
    log_likelihood : dict of int -> float
        Maximised log-likelihood (summed over days) of each order tried.
    rigidities : dict of int -> float
        Maximum-likelihood r of each order tried.
    sigma : float
        The fixed slope noise std, rad.
    stiffest_log_likelihood : dict of int -> float
        Log-likelihood of each order at the stiffest r of its grid (no change): the likelihood-ratio test of "no
        settlement" against the fitted prior.
    """

    penalty_order: int
    rigidity: float
    log_likelihood: dict
    rigidities: dict
    sigma: float
    stiffest_log_likelihood: dict = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class SettlementResult:
    """Everything :func:`estimate_settlement` found. Shapes: D days, N sensors (by station).

    Attributes
    ----------
    days : (D,) datetime64[ns] ndarray
    sensor_ids : list of str
    x : (N,) ndarray
        Stations, m.
    dz : (D, N) ndarray
        Daily posterior mean of the altitude change since day 0, m (negative = settlement), at every
        station — excluded sensors' stations are estimated from their neighbours.
    dz_std : (D, N) ndarray
        Posterior std of dz, m, under the fitted change prior (all the model's uncertainty: slope
        noise, smoothing and the track between sensors); the 90 % band is dz ∓ 1.645 dz_std.
    dz_noise_std : (D, N) ndarray
        The part of the error due to the slope noise alone for a fixed true profile, m
        (:func:`~longprofile.rail.measurement_std`): a lower bound, not a band (docs/rail.md).
    slope_change, slope_change_std : (D, N) ndarray
        Posterior slope change, rad.
    smoothed : TemporalSettlement or None
        Settlement smoothed across days with daily rates (None when ``through_time=False``).
    initial : ProfilePosterior
        Initial altitudes and slopes at the sensors from the survey (§4.4).
    integrated : dict of str -> (D, N) ndarray
        Altitude change by the paper's §2 chain integrations (forward, backward, average, convex).
    max_settlement_mean, max_settlement_std : (D,) ndarray
        Monte Carlo mean and std of max_i(-dz_i), m (§4.3).
    max_settlement_lower, max_settlement_upper : (D,) ndarray or None
        The 90 % interval of max_i(-dz_i), m, band-shaped around the posterior mean and holding the maximum of
        98 % of the draws (:func:`~longprofile.rail.max_settlement_interval`, ``interval="draws"``; with
        ``max_settlement_interval="band"`` the simultaneous 90 % band's, as until 2026-12-06; not mean ∓ 1.645 std:
        the maximum is skewed and is 0 on days without change). NaN when the Monte Carlo is skipped.
    health : SensorHealth
    daily : DailyAngles
    sigma : float
        Slope noise std used, rad.
    rigidity : float
        r of the change prior used, m^-2 (penalty_order 2) or m^-4 (penalty_order 3).
    penalty_order : int
        2 = the paper's ||f''||^2 prior on the change profile, 3 = the smoother ||f‴||^2 prior.
    change_prior : ChangePriorFit or None
        The maximum-likelihood fit of the change prior (None when ``rigidity`` was given).
    alarms : DataFrame
        See :func:`~longprofile.rail.settlement_alarms` (with graded ``thresholds``:
        :func:`~longprofile.rail.threshold_alarms`, a ``level`` column more). Empty both when nothing exceeds and
        when no threshold was set: ``settings["thresholds_set"]`` tells them apart.
    controls : DataFrame or None
        Control points compared with the estimate: date, x_m, dz_control_m, dz_estimate_m, std_m, z, inside_90
        (:func:`~longprofile.rail.compare_controls`).
    warnings : tuple of str
        Everything the user must know (input fixes, excluded sensors, affine correction...).
    settings : dict
        The options used (for reports).
    sigma_by_day : (D,) ndarray or None
        Slope-change noise std of each day, rad (``error_model="drift"``: :func:`daily_noise_sigma`;
        ``sigma`` is then its median); constant for ``error_model="white"``.
    sensor_noise_factor : (N,) ndarray or None
        f_i of :func:`sensor_noise_factors`: sensor i's noise std is ``sigma_by_day * f_i`` (all 1 for
        ``error_model="white"`` or ``sensor_noise=False``).
    prior_weights : (N-1,) ndarray or None
        w_i of :func:`segment_prior_weights`: the change prior's r on the segment between stations i and i+1 is
        ``rigidity * w_i`` (all 1 with ``spatial_prior=False`` or a given ``rigidity``).
    increment_rigidity : (D,) ndarray or None
        With the all-days model (``joint_days=True``): r_d of the settlement's increment from day d - 1 to day d
        (:func:`increment_rigidity`; NaN on day 0); ``rigidity`` is then their maximum and ``smoothed`` is the
        all-days posterior itself (its ``process_std`` NaN). None for the per-day model.
    noise_day_cov : (D-1, D-1) ndarray or None
        With the all-days model: the day covariance R of the slope-change error of a sensor of factor 1 over days
        1..D-1, rad^2 (:func:`~longprofile.rail._joint.day_noise_covariance`); sensor i's is f_i^2 R.
    control_check : ControlCheck or None
        Whether the control surveys agree with the estimate (:func:`~longprofile.rail.check_controls`; a warning
        when they do not); None without control points.
    """

    days: np.ndarray
    sensor_ids: list
    x: np.ndarray
    dz: np.ndarray
    dz_std: np.ndarray
    dz_noise_std: np.ndarray
    slope_change: np.ndarray
    slope_change_std: np.ndarray
    smoothed: TemporalSettlement | None
    initial: ProfilePosterior
    integrated: dict
    max_settlement_mean: np.ndarray
    max_settlement_std: np.ndarray
    health: SensorHealth
    daily: DailyAngles
    sigma: float
    rigidity: float
    penalty_order: int
    change_prior: ChangePriorFit | None
    alarms: pd.DataFrame
    controls: pd.DataFrame | None
    warnings: tuple
    settings: dict = field(default_factory=dict)
    sigma_by_day: np.ndarray | None = None
    sensor_noise_factor: np.ndarray | None = None
    prior_weights: np.ndarray | None = None
    max_settlement_lower: np.ndarray | None = None
    max_settlement_upper: np.ndarray | None = None
    increment_rigidity: np.ndarray | None = None
    noise_day_cov: np.ndarray | None = None
    control_check: ControlCheck | None = None

    def measured(self) -> np.ndarray:
        """(D, N) bool: did this sensor's daily angle of this day enter the estimate? False on the days without one
        (a logger outage: the value there is the model's inference from the sensor's other days and its
        neighbours, with a band to match) and on every day of an excluded sensor (its station is estimated from
        its neighbours)."""
        seen = np.isfinite(np.asarray(self.daily.change_deg, float))
        if seen.shape != self.dz.shape:  # daily angles of other days than the result's (not from estimate_settlement)
            return np.broadcast_to(~np.asarray(self.health.excluded, bool), self.dz.shape).copy()
        return seen & ~np.asarray(self.health.excluded, bool)[None, :]

    def to_table(self) -> pd.DataFrame:
        """Long table, one row per day and sensor: date, sensor_id, x_m, status, measured (:meth:`measured`),
        dz_m, dz_std_m (posterior), dz_lower90_m, dz_upper90_m, dz_noise_std_m, smoothed_dz_m, smoothed_std_m,
        rate_m_per_day, rate_std_m_per_day."""
        D, N = self.dz.shape
        out = pd.DataFrame({
            "date": np.repeat(pd.DatetimeIndex(self.days).strftime("%Y-%m-%d").to_numpy(), N),
            "sensor_id": np.tile(self.sensor_ids, D),
            "x_m": np.tile(self.x, D),
            "status": np.tile(self.health.status, D),
            "measured": self.measured().ravel(),
            "dz_m": self.dz.ravel(),
            "dz_std_m": self.dz_std.ravel(),
            "dz_lower90_m": (self.dz - Z90 * self.dz_std).ravel(),
            "dz_upper90_m": (self.dz + Z90 * self.dz_std).ravel(),
            "dz_noise_std_m": self.dz_noise_std.ravel(),
        })
        if self.smoothed is not None:
            out["smoothed_dz_m"] = self.smoothed.mean.ravel()
            out["smoothed_std_m"] = self.smoothed.std.ravel()
            out["rate_m_per_day"] = self.smoothed.rate.ravel()
            out["rate_std_m_per_day"] = self.smoothed.rate_std.ravel()
        return out
