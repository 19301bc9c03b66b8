"""Vehicle description (TOML <-> frozen dataclass) of the planar model, paper 001."""

import dataclasses

import pytest

from longprofile.errors import InputError, InputFormatError
from longprofile.vehicle import Vehicle, default_vehicle, load_vehicle


def test_default_car_is_documented_and_valid():
    car = default_vehicle()
    assert car.mass == 1500.0
    assert car.friction == (0.8, 0.8, 0.8, 0.8)  # paper V.A: mu = 0.8
    assert car.wheelbase == pytest.approx(2.6)
    with pytest.raises(dataclasses.FrozenInstanceError):
        car.mass = 1.0


def test_toml_round_trip(tmp_path):
    car = default_vehicle().with_changes(mass=1650.0, friction=(0.5, 0.6, 0.7, 0.8), driven_axle="rear")
    path = tmp_path / "car.toml"
    path.write_text(car.to_toml())
    assert load_vehicle(path) == car


def test_missing_and_unknown_keys_are_errors(tmp_path):
    text = default_vehicle().to_toml()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("mass = 1500.0", "mas = 1500.0"))
    with pytest.raises(InputFormatError, match="unknown key 'mas' in table 'body'"):
        load_vehicle(bad)
    bad.write_text(text.replace("yaw_inertia = 2500.0  # kg m^2\n", ""))
    with pytest.raises(InputFormatError, match=r"missing body\.yaw_inertia \(kg m\^2\)"):
        load_vehicle(bad)
    bad.write_text(text.replace("[wheels]", "[wheel]"))
    with pytest.raises(InputFormatError, match="unknown key 'wheel'; expected the tables"):
        load_vehicle(bad)
    bad.write_text(text.split("[wheels]")[0])
    with pytest.raises(InputFormatError, match=r"missing table \[wheels\]"):
        load_vehicle(bad)
    bad.write_text("mass = [")
    with pytest.raises(InputFormatError, match="not valid TOML"):
        load_vehicle(bad)
    with pytest.raises(InputError, match="no such vehicle description"):
        load_vehicle(tmp_path / "nope.toml")


@pytest.mark.parametrize("change, message", [
    ({"mass": -1.0}, "mass must be finite and > 0 kg"),
    ({"cg_height": float("nan")}, "cg_height must be finite"),
    ({"friction": (0.8, 0.8, 0.8)}, "friction must be 4"),
    ({"friction": (0.8, 0.8, 0.8, 0.0)}, "friction must be 4"),
    ({"driven_axle": "middle"}, "driven_axle must be"),
    ({"brake_front_share": 1.5}, "brake_front_share must be in"),
    ({"aero_longitudinal": -0.1}, "aero_longitudinal must be finite and >= 0"),
    ({"mass": "heavy"}, "mass must be a number"),
])
def test_invalid_parameters_raise(change, message):
    with pytest.raises(InputError, match=message):
        default_vehicle().with_changes(**change)


def test_invalid_value_in_file_names_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(default_vehicle().to_toml().replace("mass = 1500.0", "mass = -3.0"))
    with pytest.raises(InputFormatError, match="bad.toml: mass must be finite and > 0"):
        load_vehicle(bad)


def test_vehicle_is_a_dataclass_with_all_fields_in_toml():
    names = {f.name for f in dataclasses.fields(Vehicle)}
    text = default_vehicle().to_toml()
    for name in names - {"name", "description", "steering_ratio"}:  # steering_ratio: optional, written when set
        key = {"wheel_radius": "radius", "wheel_inertia": "inertia"}.get(name, name)
        assert f"{key} = " in text, name
    assert "steering_ratio = 15.0" in default_vehicle().with_changes(steering_ratio=15.0).to_toml()


def test_simulator_only_keys_may_be_omitted_for_estimation(tmp_path):
    import re

    import numpy as np

    from longprofile.errors import InputError
    from longprofile.vehicle import estimate_slope, simulate_drive

    text = default_vehicle().to_toml()
    text = re.sub(r"\ninertia = .*", "", text)
    text = re.sub(r"\nbrake_front_share = .*", "", text)
    assert "\ninertia" not in text and "brake_front_share" not in text
    path = tmp_path / "estimation_only.toml"
    path.write_text(text)
    car = load_vehicle(path)
    assert car.wheel_inertia is None and car.brake_front_share is None
    assert "\ninertia" not in car.to_toml()  # written back without them
    log = simulate_drive("hill", default_vehicle(), seed=0).log
    a, b = estimate_slope(log, car), estimate_slope(log, default_vehicle())
    np.testing.assert_array_equal(a.slope, b.slope)  # the estimators never read them
    with pytest.raises(InputError, match=r"simulator needs wheels.inertia \(kg m\^2\) and "
                                         r"drivetrain.brake_front_share"):
        simulate_drive("hill", car)


def test_every_missing_key_is_named_at_once(tmp_path):
    """A car file written by hand with several keys missing gets one refusal naming all of them (the probe needed a
    round trip per key)."""
    text = default_vehicle().to_toml()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("yaw_inertia = 2500.0  # kg m^2\n", "").split("[drivetrain]")[0]
                   .replace("cg_height", "#cg_height"))
    with pytest.raises(InputFormatError) as err:
        load_vehicle(bad)
    message = str(err.value)
    for part in ("body.yaw_inertia (kg m^2)", "body.cg_height (m)", "table [drivetrain] (keys driven_axle"):
        assert part in message
    assert "brake_front_share" not in message  # optional: never asked for
