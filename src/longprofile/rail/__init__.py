"""Rail track settlement from sleeper inclinometers, with confidence bands (paper 004).

Data
----
SiteData                    -- validated site: sensors, readings, survey, controls, warnings.
validate_site               -- validate the four long-format tables (clear errors, explicit warnings).
READING_COLUMNS             -- the columns of a readings table (timestamp, sensor_id, angle_deg, temperature_c).
angle_noise                 -- robust high-frequency noise of the angles; below RADIAN_NOISE_THRESHOLD degrees
                               are implausible (radians given by mistake).
track_angle                 -- how far from level the sensors read (median |angle|); beyond MAX_TRACK_ANGLE_DEG
                               another unit. ANGLE_RANGE_DEG, TEMPERATURE_RANGE_C: one reading's plausible range.
missing_value_code          -- whether an out-of-range value looks like a logger's missing-value code (-9999);
                               MISSING_CODE_HINT, what a refusal then says.
check_survey                -- refuse a survey in another unit than metres (altitude beyond any terrain, grade).
fill_temperature            -- a reading without a temperature (failed channel), or a stuck one (STUCK_MIN_READINGS,
                               STUCK_SITE_SPREAD_C), takes its nearest sensors' (the median of TEMPERATURE_NEIGHBOURS
                               in the same minute) plus its own offset from them (TEMPERATURE_OFFSET_DAYS before).
                               MISSING_TEXT: the markers ("NAN", "n/a", ...) read as an empty cell.
read_site                   -- deprecated alias of ``longprofile.io.read_rail_site`` (read the CSV / Parquet
                               tables and validate; file reading lives in ``io``).
simulate_site               -- synthetic site with ground truth ("mittersheim-like", "farebersviller-like").
SyntheticSite, SiteTruth    -- its tables and truth.

The paper's methods
-------------------
integrate_angles            -- forward / backward / average / convex chain integration (§2).
bar_angles_from_profile     -- initial bar angles from altitudes (§2).
daily_angles, DailyAngles   -- outlier removal, linear (§3) or lagged thermal correction, daily medians.
day_statistics, DayStatistics -- the per-day stage of daily_angles (linear / none): per (day, sensor)
                               quantities, recomputed one day at a time over a cache (monitoring service).
daily_angles_from_statistics -- its combine stage: DailyAngles from DayStatistics.
statistics_window           -- the days to recompute after a change, and the readings they need.
DAY_FIELDS                  -- the per-day fields of DayStatistics, in storage order.
MEDIAN_LINES                -- readings per day kept next to the median, for exact medians at a new coefficient.
NOISE_STD_TOLERANCE         -- relative drift of a sensor's noise std up to which cached outlier sets are kept.
first_order_response        -- first-order thermal lag of a temperature series.
lag_variance_ratio          -- how much a thermal lag explains of each sensor's within-day residual: thermal="auto"
                               takes the lagged model below LAG_AUTO_RATIO (beyond the paper).
rigidity_cost_matrix        -- the cost matrix C of Lemma 4.1 (§4.2).
rigidity_posterior_dense    -- the paper's dense posterior (reference, O(N^3)).
rigidity_model              -- the same prior as a state-space model (integrated Wiener process);
                               penalty_order=3 gives the smoother ||f'''||^2 prior (beyond the paper).
rigidity_posterior          -- O(N) posterior by RTS smoothing over the stations, batched over days.
ProfilePosterior            -- posterior means, stds, station and cross covariances.
measurement_std             -- std of the posterior mean due to the slope noise alone (a lower bound).
initial_profile_posterior   -- initial altitudes and angles from a survey on any grid (§4.4), O(N).
initial_profile_posterior_dense -- §4.4 dense reference (survey at the sensors).
sample_profiles             -- posterior draws of altitude profiles.
max_settlement_monte_carlo  -- mean and std of the maximum settlement (§4.3).
max_settlement_interval     -- the same with a band-shaped 90 % interval from the draws (beyond §4.3);
                               MaxSettlement is its result.
affine_correction           -- the affine correction of §5.2 (with the paper's warning).
assess_sensors, SensorHealth -- flag dead / reversed / drifting / detached / improbable sensors (§6).
SENSOR_STATUSES             -- every sensor status; UNUSABLE_STATUSES, those whose record cannot enter the estimate
                               (dead, frozen, late); USER_EXCLUDED, the status of a sensor the user excluded.

Beyond the paper
----------------
smooth_through_time         -- settlement smoothed across days per station, daily rates with bands;
                               TemporalSettlement is its result.
settlement_alarms           -- threshold exceedances with station, date and probability.
compare_controls            -- control surveys against the estimate (standardised differences);
check_controls              -- do they agree? chi-squared test at CONTROL_CHECK_P, ControlCheck (a warning when
                               they do not).
check_threshold             -- a plausible alarm threshold (THRESHOLD_FLOORS_M per quantity: 0.5 mm, 0.05 mm/day;
                               THRESHOLD_RANGE_M up to 1 m), else InputError.
threshold_alarms            -- every level (alert, action, alarm) of settlement, rate and twist thresholds tested.
check_thresholds            -- a validated {quantity: {level: value}} (THRESHOLD_QUANTITIES, THRESHOLD_LEVELS).
fit_change_prior            -- maximum-likelihood prior (order and r) of the settlement profile;
                               ChangePriorFit is its result.
segment_prior_weights       -- space-varying prior of the settlement profile (r w_i per segment, EM).
estimate_settlement         -- the whole job, readings to settlement, bands, health and alarms.
estimate_settlement_from_daily -- the same from daily angles already computed (e.g. from cached DayStatistics).
SettlementSettings          -- its options (frozen, validated once): ``estimate_settlement(site, settings=...)``.
SettlementResult            -- its result (``to_table()`` for the long output table).
find_reinstallations        -- sensors resuming after a gap with a new mounting offset; Rebaselines is its result.
check_events                -- the events table (re-installed / replaced sensors), checked.
apply_replacements          -- a replacing sensor's readings merged into the replaced one's series.
site_with_events            -- the site validated with its declared events (rail settle --events, the
                               monitoring service).
"""

from .._lazy import lazy_namespace

#: Lazy namespace (PEP 562): ``import longprofile.rail`` loads no submodule until a name is used, so
#: ``rail settle`` does not import the synthetic sites (scipy.signal) and nothing here imports matplotlib.
_EXPORTS = {
    "._controls": ("CONTROL_CHECK_P", "check_controls", "compare_controls"),
    "._data": ("SiteData", "validate_site", "angle_noise", "missing_value_code", "MISSING_CODE_HINT", "RADIAN_NOISE_THRESHOLD", "READING_COLUMNS", "track_angle",
               "MAX_TRACK_ANGLE_DEG", "ANGLE_RANGE_DEG", "TEMPERATURE_RANGE_C", "check_survey",
               "fill_temperature", "TEMPERATURE_NEIGHBOURS", "STUCK_MIN_READINGS", "STUCK_SITE_SPREAD_C",
               "TEMPERATURE_OFFSET_DAYS", "MISSING_TEXT"),
    "._deprecated": ("read_site",),
    "._health": ("assess_sensors", "SENSOR_STATUSES", "UNUSABLE_STATUSES", "USER_EXCLUDED"),
    "._integration": ("bar_angles_from_profile", "integrate_angles"),
    # the result types: numpy and pandas only (unpickled by the figure helper without scipy or numba)
    "._results": ("ChangePriorFit", "ControlCheck", "DailyAngles", "ProfilePosterior", "SensorHealth",
                  "SettlementResult", "TemporalSettlement"),
    "._reinstall": ("Rebaselines", "find_reinstallations", "check_events", "apply_replacements",
                    "site_with_events"),
    "._rigidity": ("initial_profile_posterior", "initial_profile_posterior_dense",
                   "max_settlement_monte_carlo", "max_settlement_interval", "MaxSettlement", "measurement_std", "rigidity_cost_matrix", "rigidity_model",
                   "rigidity_posterior", "rigidity_posterior_dense", "sample_profiles"),
    "._settle": ("SettlementSettings", "affine_correction",
                 "estimate_settlement", "estimate_settlement_from_daily", "fit_change_prior", "segment_prior_weights"),
    "._synthetic": ("SiteTruth", "SyntheticSite", "simulate_site"),
    "._temporal": ("settlement_alarms", "smooth_through_time", "check_threshold",
                   "THRESHOLD_RANGE_M", "THRESHOLD_FLOORS_M"),
    "._thresholds": ("THRESHOLD_QUANTITIES", "THRESHOLD_LEVELS", "check_thresholds", "threshold_alarms"),
    "._thermal": ("DAY_FIELDS", "MEDIAN_LINES", "NOISE_STD_TOLERANCE", "DayStatistics", "daily_angles", "daily_angles_from_statistics",
                  "day_statistics", "first_order_response", "statistics_window", "lag_variance_ratio", "LAG_AUTO_RATIO"),
}


__all__ = [
    "SiteData", "read_site", "validate_site", "READING_COLUMNS", "angle_noise", "missing_value_code", "MISSING_CODE_HINT", "RADIAN_NOISE_THRESHOLD",
    "track_angle", "MAX_TRACK_ANGLE_DEG", "ANGLE_RANGE_DEG", "TEMPERATURE_RANGE_C", "check_survey", "fill_temperature", "TEMPERATURE_NEIGHBOURS",
    "STUCK_MIN_READINGS", "STUCK_SITE_SPREAD_C", "TEMPERATURE_OFFSET_DAYS", "MISSING_TEXT",
    "simulate_site", "SyntheticSite", "SiteTruth",
    "integrate_angles", "bar_angles_from_profile", "daily_angles", "DailyAngles", "first_order_response",
    "rigidity_cost_matrix", "rigidity_posterior_dense", "rigidity_model", "rigidity_posterior", "ProfilePosterior",
    "measurement_std", "initial_profile_posterior", "initial_profile_posterior_dense", "sample_profiles",
    "max_settlement_monte_carlo", "affine_correction", "assess_sensors", "SensorHealth",
    "SENSOR_STATUSES", "UNUSABLE_STATUSES", "USER_EXCLUDED",
    "smooth_through_time", "TemporalSettlement", "settlement_alarms", "check_threshold", "THRESHOLD_RANGE_M",
    "THRESHOLD_FLOORS_M", "THRESHOLD_QUANTITIES", "THRESHOLD_LEVELS", "check_thresholds", "threshold_alarms", "estimate_settlement", "SettlementResult",
    "SettlementSettings", "fit_change_prior", "ChangePriorFit", "segment_prior_weights", "max_settlement_interval",
    "MaxSettlement", "day_statistics", "DayStatistics", "daily_angles_from_statistics", "estimate_settlement_from_daily",
    "statistics_window", "DAY_FIELDS", "MEDIAN_LINES", "NOISE_STD_TOLERANCE",
    "compare_controls", "check_controls", "ControlCheck", "CONTROL_CHECK_P", "lag_variance_ratio", "LAG_AUTO_RATIO",
    "Rebaselines", "find_reinstallations", "check_events", "apply_replacements", "site_with_events",
]

__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, __all__)
