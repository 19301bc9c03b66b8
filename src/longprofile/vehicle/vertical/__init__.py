"""longprofile.vehicle.vertical: vertical (suspension) states of thesis 003 (Plancke: 7-DOF model, per-corner EKFs).

Modules: ``_params`` (:class:`VerticalVehicleParams`, :class:`MRDamperParams`, the ``[vertical]`` table of a
vehicle description), ``_model`` (7-DOF equations, corner-EKF functions and the EKF / linear model builders),
``_simulate`` (RK4 simulator, thesis tests, sensors), ``_estimate`` (corner EKFs, absolute velocities, RTS,
linear KF), ``_checks`` (gravity in the accelerometers, deflection sign), ``_evaluate`` (epsilon criterion,
thesis Tables 4.4/4.5), ``_observability``, ``_road`` (the car as a profilometer; runs over a road profile). Figures: :mod:`longprofile.report`. Everything here is also exported by
:mod:`longprofile.vehicle`.
"""

from ._bands import (
                      VERTICAL_NIS_WINDOW,
                      VERTICAL_STD_CALIBRATION,
                      VERTICAL_STD_RATE_RANGE,
                      VerticalStateStd,
                      calibrated_vertical_std,
                      innovation_consistency,
)
from ._checks import (
                      BODY_ACCEL_RATIO_RANGE,
                      DEFLECTION_GAIN_RANGE,
                      DEFLECTION_SIGN_LIMIT,
                      ROLL_RATIO_RANGE,
                      SIGN_REFUSAL_LIMIT,
                      VERTICAL_ACCEL_MEAN_LIMIT,
                      VERTICAL_VELOCITY_CHANGE_LIMIT,
                      body_accelerometer_ratio,
                      check_vertical_accel_means,
                      corner_order_problem,
                      deflection_gains,
                      deflection_sign_correlation,
                      hop_correlation_matrix,
                      lateral_roll_ratio,
)
from ._estimate import (
                      MR_MAP_FORCE_ERROR,
                      VerticalStateEstimate,
                      damper_velocity_from_displacement,
                      estimate_to_frame,
                      estimate_vertical_states,
                      estimate_vertical_states_linear,
                      mr_actuator_force,
                      nominal_mr_map,
                      smooth_vertical_states,
                      vertical_ekf_inputs,
                      yaw_acceleration,
)
from ._evaluate import (
                      CARS,
                      REFERENCES,
                      THESIS_BENCH_TABLE,
                      THESIS_TRACK_TABLE,
                      VERTICAL_VARIABLES,
                      epsilon_score,
                      reproduce_thesis_tables,
                      score_vertical_estimate,
                      thesis_references,
)
from ._model import (
                      CORNER_NAMES,
                      MR_MAP_VELOCITIES,
                      STATE_BLOCKS,
                      CornerFilterSettings,
                      skyhook_current,
                      thesis_filter_settings,
                      vertical_ekf_model,
                      vertical_linear_model,
)
from ._observability import ObservabilityResult, corner_observability
from ._params import (
                      SENSOR_CONFIGS,
                      THESIS_MR_TIME_CONSTANT,
                      MRDamperParams,
                      VerticalVehicleParams,
                      load_vertical_params,
)
from ._road import (
                      DEFLECTION_OFFSET_LIMIT,
                      VERTICAL_ACCEPTABLE_CHECKS,
                      WHEEL_ACCEL_RATIO_RANGE,
                      DeflectionZeroCheck,
                      VerticalLogEstimate,
                      VerticalRun,
                      deflection_zero_check,
                      estimate_vertical_log,
                      profile_run,
                      road_profile_from_suspension,
                      wheel_accelerometer_ratio,
                      wheel_profiles,
)
from ._simulate import (
                      DEFLECTION_RANGE,
                      VerticalSensors,
                      VerticalSimulation,
                      bench_sweep_road,
                      measure_vertical,
                      sensors_from_frame,
                      sensors_to_frame,
                      simulate_vertical,
                      steering_sine_manoeuvre,
                      vertical_test_run,
                      wheel_road_inputs,
)

__all__ = [
    "VerticalStateStd", "calibrated_vertical_std", "innovation_consistency", "VERTICAL_NIS_WINDOW",
    "VERTICAL_STD_CALIBRATION", "VERTICAL_STD_RATE_RANGE",
    "VerticalVehicleParams", "MRDamperParams", "THESIS_MR_TIME_CONSTANT", "load_vertical_params", "SENSOR_CONFIGS",
    "CORNER_NAMES", "MR_MAP_VELOCITIES", "STATE_BLOCKS", "CornerFilterSettings", "thesis_filter_settings",
    "vertical_ekf_model",
    "vertical_linear_model", "skyhook_current",
    "VerticalSimulation", "VerticalSensors", "simulate_vertical", "wheel_road_inputs", "bench_sweep_road",
    "steering_sine_manoeuvre", "measure_vertical", "sensors_to_frame", "sensors_from_frame", "vertical_test_run",
    "VerticalStateEstimate", "estimate_vertical_states", "vertical_ekf_inputs", "smooth_vertical_states",
    "estimate_vertical_states_linear", "estimate_to_frame", "yaw_acceleration", "nominal_mr_map", "mr_actuator_force",
    "damper_velocity_from_displacement", "MR_MAP_FORCE_ERROR",
    "epsilon_score", "score_vertical_estimate", "reproduce_thesis_tables", "thesis_references", "REFERENCES", "CARS",
    "THESIS_BENCH_TABLE", "THESIS_TRACK_TABLE", "VERTICAL_VARIABLES",
    "ObservabilityResult", "corner_observability",
    "road_profile_from_suspension", "wheel_profiles", "VerticalRun", "profile_run", "VerticalLogEstimate",
    "estimate_vertical_log", "wheel_accelerometer_ratio", "WHEEL_ACCEL_RATIO_RANGE", "deflection_zero_check",
    "DeflectionZeroCheck", "DEFLECTION_OFFSET_LIMIT",
    "check_vertical_accel_means", "VERTICAL_ACCEL_MEAN_LIMIT", "VERTICAL_VELOCITY_CHANGE_LIMIT",
    "deflection_sign_correlation", "DEFLECTION_SIGN_LIMIT", "DEFLECTION_RANGE",
    "SIGN_REFUSAL_LIMIT", "hop_correlation_matrix", "corner_order_problem", "lateral_roll_ratio", "ROLL_RATIO_RANGE",
    "VERTICAL_ACCEPTABLE_CHECKS", "body_accelerometer_ratio", "BODY_ACCEL_RATIO_RANGE", "deflection_gains",
    "DEFLECTION_GAIN_RANGE",
]
