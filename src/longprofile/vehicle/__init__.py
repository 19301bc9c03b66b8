"""longprofile.vehicle: vehicle models, simulators and state estimators.

Planar states and road slope (paper 001, Sebsadji, Glaser, Mammar)
------------------------------------------------------------------
Vehicle               -- validated vehicle description (TOML via load_vehicle; default_vehicle()).
load_vehicle          -- read a vehicle description (TOML).
default_vehicle       -- the documented default car (vehicle/data/default_car.toml).
dugoff_forces         -- Dugoff tyre model, eq. (15)-(17); TyreForces result.
drive_scenario        -- built-in drives ("paper", "hill", "low-mu"); DriveScenario, SCENARIOS.
simulate_drive        -- 4-wheel RK4 simulator: truth and sensor log (PlanarSimulation, DriveLog, DriveTruth).
SensorSpec            -- ABS encoder, steering, gyro and accelerometer models of the simulator.
planar_ekf_model      -- EKF model of eq. (20) on (V_x, V_y, r) (NonlinearStateSpaceModel).
slope_ekf_model       -- augmented EKF model on (V_x, V_y, r, theta_r).
slope_observer_matrices / slope_observer_gain -- longitudinal model (21) and its Luenberger gain.
estimate_slope        -- states, tyre forces and slope from a DriveLog ("cascade" or "joint"); SlopeEstimate.
EKFTuning             -- EKF noise settings.
plot_slope_estimate / plot_drive -- figures.
"""

from ._car import Vehicle, default_vehicle, load_vehicle
from ._dugoff import TyreForces, dugoff_forces
from ._planar_sim import (LOG_COLUMNS, SCENARIOS, DriveLog, DriveScenario, DriveTruth, PlanarSimulation, SensorSpec,
                          drive_scenario, simulate_drive)
from ._slope import (EKFTuning, SlopeEstimate, estimate_slope, planar_ekf_model, planar_inputs, planar_measurements,
                     slope_ekf_model, slope_observer_gain, slope_observer_matrices)
from ._slope_plot import plot_drive, plot_slope_estimate

__all__ = [
    "Vehicle", "load_vehicle", "default_vehicle",
    "TyreForces", "dugoff_forces",
    "DriveScenario", "drive_scenario", "SCENARIOS", "SensorSpec", "DriveLog", "DriveTruth", "PlanarSimulation",
    "simulate_drive", "LOG_COLUMNS",
    "EKFTuning", "SlopeEstimate", "estimate_slope", "planar_ekf_model", "slope_ekf_model", "planar_inputs",
    "planar_measurements", "slope_observer_matrices", "slope_observer_gain",
    "plot_slope_estimate", "plot_drive",
]
