"""The car file's ``[tolerances]`` table: the stated tolerances behind ``vehicle slope``'s stds (session 37).

The first-order propagation of ``SlopeUncertainty`` (docstring, Notes): a common rolling-radius error r scales the
measured speed, so V_x's band holds |V_x| radius_rel_std, vx_std^2 = filter part + (|V_x| radius_rel_std)^2. The
filter part is the band with ``radius_rel_std = 0``; without the sensor calibration (whose axle prior also holds the
radius tolerance) nothing else in the estimate depends on it, so the identity is exact.
"""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.cli.app import main
from longprofile.errors import InputFormatError
from longprofile.vehicle import (
    SlopeUncertainty,
    default_vehicle,
    drive_scenario,
    estimate_slope,
    load_vehicle,
    simulate_drive,
)


def _car_file(path, tolerances: str):
    path.write_text(default_vehicle().to_toml() + f"\n[tolerances]\n{tolerances}\n")
    return path


@pytest.fixture(scope="module")
def drive():
    """A 3 s paper drive (20-25 m/s): the log, and the estimate's filter part (radius tolerance 0)."""
    log = simulate_drive(drive_scenario("paper", duration=3.0), default_vehicle(), seed=0).log
    base = estimate_slope(log, default_vehicle(), uncertainty=SlopeUncertainty(radius_rel_std=0.0),
                          sensor_calibration=False, force_correction=False)
    return log, base


@settings(max_examples=6, deadline=None)
@given(radius=st.floats(0.0, 0.1))
def test_the_car_file_s_radius_tolerance_sets_vx_std_by_the_first_order_propagation(drive, radius, tmp_path_factory):
    log, base = drive
    car = _car_file(tmp_path_factory.mktemp("car") / "car.toml", f"radius_rel_std = {radius!r}")
    unc = SlopeUncertainty.from_car_file(car)
    assert unc == SlopeUncertainty(radius_rel_std=radius)  # the key reaches SlopeUncertainty, nothing else moves
    est = estimate_slope(log, load_vehicle(car), uncertainty=unc, sensor_calibration=False, force_correction=False)
    np.testing.assert_array_equal(est.vx, base.vx)
    np.testing.assert_allclose(est.vx_std ** 2, base.vx_std ** 2 + (np.abs(est.vx) * radius) ** 2, rtol=1e-12)


def test_a_car_file_without_the_table_keeps_the_defaults(tmp_path):
    car = tmp_path / "car.toml"
    car.write_text(default_vehicle().to_toml())
    assert SlopeUncertainty.from_car_file(car) == SlopeUncertainty()
    every = "\n".join(f"{k} = {v!r}" for k, v in [("mass_rel_std", 0.1), ("force_rel_std", 0.2),
                                                    ("radius_rel_std", 0.002), ("wheel_radius_rel_std", 1e-3),
                                                    ("gyro_bias_std", 1e-4), ("accel_gain_std", 0.01),
                                                    ("accel_offset_std", 0.05), ("gyro_offset_prior_std", 2e-4),
                                                    ("wheel_scale_prior_std", 0.01)])
    stated = SlopeUncertainty.from_car_file(_car_file(tmp_path / "every.toml", every))
    assert stated == SlopeUncertainty(mass_rel_std=0.1, force_rel_std=0.2, radius_rel_std=0.002,
                                      wheel_radius_rel_std=1e-3, gyro_bias_std=1e-4, accel_gain_std=0.01,
                                      accel_offset_std=0.05, gyro_offset_prior_std=2e-4, wheel_scale_prior_std=0.01)
    # the car itself reads as before: the other loaders leave the table alone
    assert load_vehicle(tmp_path / "every.toml") == default_vehicle()


@pytest.mark.parametrize("line, words", [
    ("radius_rel_std = 2", "a percentage? write 0.02 for 2 %"),
    ("radius_rel_std = 0.2", "a percentage? write 0.002 for 0.2 %"),
    ("mass_rel_std = 5", "a percentage? write 0.05 for 5 %"),
    ("radius_rel_std = -0.01", "must be finite and >= 0"),
    ("radius_rel_std = nan", "must be finite and >= 0"),
    ("radius_rel_std = inf", "must be finite and >= 0"),
    ("radius_rel_std = '1 %'", "must be a number"),
    ("radius_rel_std = true", "must be a number"),
    ("gyro_bias_std = 0.5", "beyond the plausible 0.05 rad/s"),
    ("accel_offset_std = 9.81", "beyond the plausible 2 m/s^2"),
    ("gyro_offset_prior_std = 0", "use --no-sensor-calibration"),
    ("radius = 0.01", "unknown key 'radius' in table 'tolerances'"),
    ("nis_floor = 0.5", "unknown key 'nis_floor' in table 'tolerances'"),
])
def test_bad_tolerances_are_refused_in_one_line_naming_the_file_and_key(tmp_path, line, words):
    car = _car_file(tmp_path / "car.toml", line)
    with pytest.raises(InputFormatError) as exc:
        SlopeUncertainty.from_car_file(car)
    text = str(exc.value)
    assert words in text and str(car) in text and "\n" not in text


def test_vehicle_slope_reads_the_table_prints_it_and_refuses_a_percentage(tmp_path, capsys):
    log = tmp_path / "log.csv"
    assert main(["vehicle", "simulate", "--duration", "3", "--no-truth", "-o", str(log)]) == 0
    plain, measured = tmp_path / "plain.toml", _car_file(tmp_path / "measured.toml", "radius_rel_std = 0.002")
    plain.write_text(default_vehicle().to_toml())
    out = {}
    for car in (plain, measured):
        capsys.readouterr()
        out[car] = tmp_path / f"{car.stem}.csv"
        assert main(["vehicle", "slope", str(log), "--vehicle", str(car), "-o", str(out[car]),
                     "--no-sensor-calibration"]) == 0
        printed = " ".join(capsys.readouterr().err.split())  # the CLI prints to stderr
    assert "the stds assume (the [tolerances] of" in printed and "radius_rel_std 0.2 % (default 1 %)" in printed
    a, b = pd.read_csv(out[plain]), pd.read_csv(out[measured])
    np.testing.assert_array_equal(a["vx"], b["vx"])  # the estimate is the same, only the band narrows
    np.testing.assert_allclose(a["vx_std"] ** 2 - b["vx_std"] ** 2, a["vx"] ** 2 * (0.01 ** 2 - 0.002 ** 2),
                               rtol=1e-9)
    bad = _car_file(tmp_path / "bad.toml", "radius_rel_std = 2")
    assert main(["vehicle", "slope", str(log), "--vehicle", str(bad), "-o", str(tmp_path / "bad.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err and "write 0.02 for 2 %" in err
    assert not (tmp_path / "bad.csv").exists()
