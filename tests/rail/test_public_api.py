"""The public namespace of longprofile.rail is pinned and documented."""

import longprofile.rail as rail

EXPECTED = {
    "SiteData", "read_site", "validate_site", "READING_COLUMNS", "angle_noise", "missing_value_code",
    "MISSING_CODE_HINT", "RADIAN_NOISE_THRESHOLD",
    "track_angle", "MAX_TRACK_ANGLE_DEG", "ANGLE_RANGE_DEG", "TEMPERATURE_RANGE_C", "check_survey", "fill_temperature",
    "TEMPERATURE_NEIGHBOURS", "STUCK_MIN_READINGS", "STUCK_SITE_SPREAD_C", "TEMPERATURE_OFFSET_DAYS", "MISSING_TEXT", "simulate_site", "SyntheticSite", "SiteTruth",
    "integrate_angles", "bar_angles_from_profile", "daily_angles", "DailyAngles", "first_order_response",
    "rigidity_cost_matrix", "rigidity_posterior_dense", "rigidity_model", "rigidity_posterior", "ProfilePosterior",
    "measurement_std", "initial_profile_posterior", "initial_profile_posterior_dense", "sample_profiles",
    "max_settlement_monte_carlo", "affine_correction", "assess_sensors", "SensorHealth",
    "SENSOR_STATUSES", "UNUSABLE_STATUSES", "USER_EXCLUDED",
    "smooth_through_time", "TemporalSettlement", "settlement_alarms", "estimate_settlement", "SettlementResult",
    "SettlementSettings",
    "fit_change_prior", "ChangePriorFit", "segment_prior_weights", "max_settlement_interval", "MaxSettlement",
    "day_statistics", "DayStatistics", "daily_angles_from_statistics", "estimate_settlement_from_daily",
    "statistics_window", "DAY_FIELDS", "MEDIAN_LINES", "NOISE_STD_TOLERANCE",
    "check_threshold", "THRESHOLD_RANGE_M", "THRESHOLD_FLOORS_M", "THRESHOLD_QUANTITIES", "THRESHOLD_LEVELS", "check_thresholds",
    "threshold_alarms", "compare_controls", "check_controls", "ControlCheck", "CONTROL_CHECK_P",
    "lag_variance_ratio", "LAG_AUTO_RATIO",
    "Rebaselines", "find_reinstallations", "check_events", "apply_replacements", "site_with_events",
}


def test_public_names_are_pinned_and_documented():
    assert set(rail.__all__) == EXPECTED
    for name in rail.__all__:
        obj = getattr(rail, name)
        if name.isupper():  # constants: documented in the module index
            assert name in rail.__doc__, name
            continue
        assert obj.__doc__ and len(obj.__doc__.strip()) > 20, name
        assert name in rail.__doc__, f"{name} missing from the module index"
