"""Shared set-up of the vehicle band tests (test_vehicle_bands.py, test_grade_floor.py): the default car, the
hill drive their fingerprints were taken on, and estimate_slope's printed outputs of both methods."""

from longprofile.vehicle import SensorSpec, default_vehicle, drive_scenario, estimate_slope, simulate_drive

CAR = default_vehicle()
Z90 = 1.6448536269514722
KEYS = ("slope", "slope_std", "vx", "vx_std", "vy", "vy_std", "yaw_rate", "yaw_rate_std")


def hill_drive():
    """The 10 s hill drive with a 2e-3 rad/s gyro offset, seed 4 (the drive of the stored fingerprints)."""
    return simulate_drive(drive_scenario("hill", duration=10.0), CAR, sensors=SensorSpec(yaw_rate_offset=2e-3), seed=4)


def slope_outputs(log, unc) -> dict:
    """``{"<method>.<output>": array}`` of estimate_slope with ``uncertainty=unc``, cascade and joint."""
    out = {}
    for method in ("cascade", "joint"):
        est = estimate_slope(log, CAR, method=method, uncertainty=unc)
        out.update({f"{method}.{k}": getattr(est, k) for k in KEYS})
    return out
