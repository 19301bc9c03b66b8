"""longprofile.vehicle.planar: planar vehicle states and road slope (paper 001, Sebsadji, Glaser, Mammar).

Modules: ``_params`` (the vehicle description, TOML), ``_dugoff`` (tyre model (15)-(17)), ``_equations`` (each
equation of (11)-(19) once, inlined numba functions), ``_model`` (the model kernels composed from them, the EKF
models of eq. (20) and the slope observer (21)), ``_simulate``
(4-wheel RK4 simulator and sensor log), ``_speed_reference`` (slip-robust V_x measurement), ``_estimate``
(:func:`estimate_slope`), ``_stretches`` (a log that stops: its moving stretches one by one), ``_force_check`` (the drive's force error against the accelerometer),
``_sensor_calibration`` (the gyro offset and relative wheel radii from the log), ``_regression`` (block means,
conjugate regression), ``_evaluate`` (accuracy and sensitivity studies). Figures: :mod:`longprofile.report`.
Everything here is also exported by :mod:`longprofile.vehicle` (except the studies).
"""

from ._dugoff import TyreForces, dugoff_forces
from ._estimate import SlopeEstimate, SlopeUncertainty, estimate_slope, nis_inflation
from ._evaluate import PAPER_PROTOTYPE_ERRORS, accuracy_scores, sensitivity_study, speed_measurement_study
from ._force_check import ForceScaleFit, force_scale_fit
from ._model import (
                        EKFTuning,
                        planar_ekf_model,
                        planar_inputs,
                        planar_measurements,
                        slope_ekf_model,
                        slope_observer_gain,
                        slope_observer_matrices,
)
from ._params import GRAVITY, SIMULATOR_ONLY, WHEELS, Vehicle, default_vehicle, load_vehicle
from ._sensor_calibration import CALIBRATION_MIN_BLOCKS, SensorCalibration, calibrate_sensors
from ._simulate import (
                        LOG_COLUMNS,
                        SCENARIOS,
                        DriveLog,
                        DriveScenario,
                        DriveTruth,
                        PlanarSimulation,
                        SensorSpec,
                        ackermann_angles,
                        drive_scenario,
                        missed_scenario_events,
                        simulate_drive,
)
from ._speed_reference import SPEED_SOURCES, SpeedReference, speed_reference
from ._stretches import MIN_STRETCH_DURATION, SplitSlopeEstimate, drive_window, estimate_slope_split, moving_stretches

__all__ = [
    "Vehicle", "load_vehicle", "default_vehicle", "SIMULATOR_ONLY", "WHEELS", "GRAVITY",
    "TyreForces", "dugoff_forces",
    "DriveScenario", "drive_scenario", "SCENARIOS", "SensorSpec", "DriveLog", "DriveTruth", "PlanarSimulation",
    "simulate_drive", "ackermann_angles", "LOG_COLUMNS", "missed_scenario_events",
    "EKFTuning", "planar_ekf_model", "slope_ekf_model", "planar_inputs", "planar_measurements",
    "slope_observer_matrices", "slope_observer_gain",
    "speed_reference", "SpeedReference", "SPEED_SOURCES",
    "SlopeEstimate", "SlopeUncertainty", "estimate_slope", "nis_inflation",
    "SplitSlopeEstimate", "estimate_slope_split", "moving_stretches", "drive_window", "MIN_STRETCH_DURATION", "ForceScaleFit", "force_scale_fit",
    "SensorCalibration", "calibrate_sensors", "CALIBRATION_MIN_BLOCKS",
    "accuracy_scores", "sensitivity_study", "speed_measurement_study", "PAPER_PROTOTYPE_ERRORS",
]
