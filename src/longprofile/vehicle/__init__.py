"""longprofile.vehicle: vehicle models, simulators and state estimators.

Two subpackages that never import each other: ``longprofile.vehicle.planar`` (paper 001) and
``longprofile.vehicle.vertical`` (thesis 003), each laid out as ``_params``, ``_model``, ``_simulate``,
``_estimate``, ``_evaluate``; ``_logs`` (sensor logs) and ``_car`` (the vehicle description file) are shared.
The figures live in :mod:`longprofile.report` (the old names here are deprecated aliases).

Planar states and road slope (paper 001, Sebsadji, Glaser, Mammar)
------------------------------------------------------------------
Vehicle               -- validated vehicle description (TOML via load_vehicle; default_vehicle()).
load_vehicle          -- read a vehicle description (TOML); load_vertical_params reads its [vertical] table.
default_vehicle       -- the documented default car (vehicle/data/default_car.toml).
dugoff_forces         -- Dugoff tyre model, eq. (15)-(17); TyreForces result.
drive_scenario        -- built-in drives ("paper", "hill", "low-mu"); DriveScenario, SCENARIOS; missed_scenario_events
                         (what a shortened drive leaves out).
simulate_drive        -- 4-wheel RK4 simulator: truth and sensor log (PlanarSimulation, DriveLog, DriveTruth).
ackermann_angles      -- front-left / front-right road-wheel angles of an Ackermann linkage (simulate_drive option).
SensorSpec            -- ABS encoder, steering, gyro and accelerometer models of the simulator.
planar_ekf_model      -- EKF model of eq. (20) on (V_x, V_y, r) (NonlinearStateSpaceModel).
slope_ekf_model       -- augmented EKF model on (V_x, V_y, r, theta_r).
slope_observer_matrices / slope_observer_gain -- longitudinal model (21) and its Luenberger gain.
estimate_slope        -- states, tyre forces and slope from a DriveLog ("cascade" or "joint"); SlopeEstimate.
estimate_slope_split  -- estimate_slope on each moving stretch of a log that stops; SplitSlopeEstimate,
                         moving_stretches, drive_window (a time window of a log).
SlopeUncertainty      -- the parameter uncertainty added to the printed stds; nis_inflation (innovation consistency).
force_scale_fit       -- the drive's relative force error (mass, tyres) against the accelerometer; ForceScaleFit.
calibrate_sensors     -- the gyro offset and the wheels' relative scale errors from the log; SensorCalibration,
                         CALIBRATION_MIN_BLOCKS (fewest usable 1 s blocks per part).
EKFTuning             -- EKF noise settings.
speed_reference       -- slip-robust V_x measurement (torque-free / slip-compensated wheels, per-sample std,
                         missing when no wheel is trustworthy); SpeedReference, SPEED_SOURCES.
plot_slope_estimate / plot_drive -- figures.

Vertical states (thesis 003, Plancke: 7-DOF model, per-corner EKFs)
-------------------------------------------------------------------
VerticalVehicleParams -- 7-DOF vertical model parameters (thesis Audi A8 set).
simulate_vertical     -- RK4 simulator of heave/roll/pitch + 4 wheels; VerticalSimulation.
wheel_road_inputs / bench_sweep_road / steering_sine_manoeuvre -- road, 4-poster sweep and track inputs.
measure_vertical      -- sensors of configurations 1-3 (VerticalSensors); sensors_to_frame / sensors_from_frame.
vertical_ekf_model / vertical_ekf_inputs -- corner EKF model (16 stacked states) and its input rows.
estimate_vertical_states -- per-corner EKFs + absolute velocities; VerticalStateEstimate.
CornerFilterSettings / thesis_filter_settings -- Q/R/P0 of the thesis per configuration.
corner_observability  -- SVD observability analysis of the corner models; ObservabilityResult.
epsilon_score / score_vertical_estimate / reproduce_thesis_tables -- the thesis criterion and Tables 4.4/4.5.
thesis_references     -- the thesis's evaluation references rebuilt from measured signals (REFERENCES).
MRDamperParams        -- MagneRide (MR) damper of the "magneride" car (CARS): tanh map, current lag; skyhook_current.
nominal_mr_map / mr_actuator_force / damper_velocity_from_displacement -- the filter's MR map and actuator input
                         (evaluated before the run, or inside the EKF's model: MR_MAP_VELOCITIES).
vertical_test_run     -- simulate a thesis test (road / 4-poster sweep / track) and measure one configuration.
estimate_to_frame / plot_vertical_estimate -- table and figure of a VerticalStateEstimate.
smooth_vertical_states -- offline extended RTS smoothing of the corner-EKF estimate.
vertical_linear_model / estimate_vertical_states_linear -- centralised linear full-car KF / RTS for comparison.
road_profile_from_suspension -- the road under the wheels from the suspension sensors (car as profilometer).
wheel_profiles        -- the road under each of the four wheels on one chainage grid.
profile_run           -- drive the simulated car over a road profile and measure one configuration; VerticalRun.
estimate_vertical_log -- states of a sensor log (+ road and IRI under each wheel); VerticalLogEstimate.

Sensor logs (issue 14)
----------------------
read_drive_log / read_vertical_log -- logs with declared units (header 'name [unit]' or a mapping), conversion
                         to SI, explicit resampling, sample-rate and plausibility checks; UNIT_FACTORS, parse_units.
check_drive_log       -- unit/sign checks from redundant channels (gyro vs wheels, a_y vs V r, steering vs yaw
                         rate, a_x vs dV/dt); LogCheck.
resample_log          -- linear resampling of a jittered log onto a uniform time base (gaps refused).
infer_vertical_config -- thesis sensor configuration from the columns.
"""

from .._lazy import lazy_namespace

# Subpackages are imported on first use (PEP 562): ``from longprofile.vehicle import estimate_slope`` loads the
# planar subpackage only, not the vertical estimators and scipy.signal (a CLI call saves ~1 s of imports).
_EXPORTS = {
    ".planar": ("Vehicle", "default_vehicle", "load_vehicle", "SIMULATOR_ONLY", "TyreForces", "dugoff_forces",
                "LOG_COLUMNS", "SCENARIOS", "DriveLog", "DriveScenario", "DriveTruth", "PlanarSimulation", "SensorSpec",
                "drive_scenario", "simulate_drive", "missed_scenario_events", "ackermann_angles", "EKFTuning", "SlopeEstimate", "SlopeUncertainty",
                "nis_inflation", "ForceScaleFit", "force_scale_fit", "SensorCalibration", "calibrate_sensors",
                "CALIBRATION_MIN_BLOCKS", "estimate_slope", "planar_ekf_model", "SplitSlopeEstimate", "estimate_slope_split",
                "moving_stretches", "drive_window", "MIN_STRETCH_DURATION",
                "planar_inputs", "planar_measurements", "slope_ekf_model", "slope_observer_gain",
                "slope_observer_matrices", "SPEED_SOURCES", "SpeedReference", "speed_reference",),
    ".vertical": ("load_vertical_params", "CornerFilterSettings", "VerticalStateEstimate", "estimate_vertical_states",
                  "estimate_vertical_states_linear", "smooth_vertical_states", "thesis_filter_settings",
                  "vertical_ekf_inputs", "vertical_ekf_model", "vertical_linear_model", "nominal_mr_map",
                  "mr_actuator_force", "damper_velocity_from_displacement", "MR_MAP_VELOCITIES", "REFERENCES", "CARS",
                  "THESIS_BENCH_TABLE", "THESIS_TRACK_TABLE", "epsilon_score", "reproduce_thesis_tables",
                  "score_vertical_estimate", "thesis_references", "VerticalVehicleParams", "MRDamperParams",
                  "skyhook_current", "ObservabilityResult", "corner_observability", "estimate_to_frame",
                  "road_profile_from_suspension", "wheel_profiles", "VerticalSensors", "VerticalSimulation",
                  "bench_sweep_road", "measure_vertical", "sensors_from_frame", "sensors_to_frame",
                  "simulate_vertical", "steering_sine_manoeuvre", "vertical_test_run", "wheel_road_inputs",
                  "VerticalRun", "profile_run", "VerticalLogEstimate", "estimate_vertical_log",),
    "._logs": ("LogCheck", "UNIT_FACTORS", "check_drive_log", "infer_vertical_config", "parse_units", "read_drive_log",
               "read_vertical_log", "resample_log",),
    # the figures are drawn by the report edge; deprecated aliases forward to it
    "._deprecated": ("plot_drive", "plot_slope_estimate", "plot_vertical_estimate",),
}


__all__ = [
    "Vehicle", "load_vehicle", "default_vehicle", "load_vertical_params", "SIMULATOR_ONLY",
    "TyreForces", "dugoff_forces",
    "DriveScenario", "drive_scenario", "SCENARIOS", "SensorSpec", "DriveLog", "DriveTruth", "PlanarSimulation",
    "simulate_drive", "missed_scenario_events", "ackermann_angles", "LOG_COLUMNS",
    "EKFTuning", "SlopeEstimate", "SlopeUncertainty", "nis_inflation", "ForceScaleFit", "force_scale_fit",
    "SensorCalibration", "calibrate_sensors", "CALIBRATION_MIN_BLOCKS", "estimate_slope", "planar_ekf_model",
    "SplitSlopeEstimate", "estimate_slope_split", "moving_stretches", "drive_window", "MIN_STRETCH_DURATION",
    "slope_ekf_model", "planar_inputs",
    "planar_measurements", "slope_observer_matrices", "slope_observer_gain",
    "speed_reference", "SpeedReference", "SPEED_SOURCES",
    "plot_slope_estimate", "plot_drive",
    "read_drive_log", "check_drive_log", "LogCheck", "UNIT_FACTORS", "parse_units", "resample_log",
    "read_vertical_log", "infer_vertical_config",
    "VerticalVehicleParams", "simulate_vertical", "VerticalSimulation", "wheel_road_inputs", "bench_sweep_road",
    "steering_sine_manoeuvre", "measure_vertical", "VerticalSensors", "sensors_to_frame", "sensors_from_frame",
    "vertical_ekf_model", "vertical_ekf_inputs", "estimate_vertical_states", "VerticalStateEstimate",
    "CornerFilterSettings", "thesis_filter_settings", "corner_observability", "ObservabilityResult",
    "epsilon_score", "score_vertical_estimate", "reproduce_thesis_tables", "thesis_references", "REFERENCES", "CARS",
    "MRDamperParams", "skyhook_current", "nominal_mr_map", "mr_actuator_force", "damper_velocity_from_displacement",
    "MR_MAP_VELOCITIES",
    "THESIS_BENCH_TABLE",
    "THESIS_TRACK_TABLE", "vertical_test_run", "estimate_to_frame", "plot_vertical_estimate",
    "smooth_vertical_states", "road_profile_from_suspension", "wheel_profiles", "vertical_linear_model",
    "estimate_vertical_states_linear", "VerticalRun", "profile_run", "VerticalLogEstimate", "estimate_vertical_log",
]

__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, __all__)
