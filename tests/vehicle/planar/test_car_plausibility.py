"""Car-file values in the wrong unit are refused in one line naming the key, the range and the likely slip (session 38).

The probe's car files (one edit each from the default): cornering stiffness in N/deg or per axle, cg height and
track in mm, mass in tonnes, the rolling radius given as the diameter, a yaw inertia 10x, a slip stiffness per %.
"""

from __future__ import annotations

import re
from importlib import resources

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.cli.app import main
from longprofile.errors import InputFormatError
from longprofile.vehicle import default_vehicle, load_vehicle
from longprofile.vehicle.planar._plausibility import CROSS_CHECKS, RANGES, implausible_values

CAR = default_vehicle()
TEXT = CAR.to_toml()

# (line of the default car file, its replacement, what the refusal must say)
SLIPS = {
    "mass in tonnes": ("mass = 1500.0", "mass = 1.5", r"body\.mass = 1\.5 kg .*300\.\.5000 kg.*tonnes\? write 1500"),
    "cg height in mm": ("cg_height = 0.55", "cg_height = 550", r"body\.cg_height = 550 m .*mm\? write 0\.55"),
    "track in mm": ("track = 1.5", "track = 1500", r"body\.track = 1500 m .*mm\? write 1\.5"),
    "cornering stiffness in N/deg": ("cornering_stiffness = 50000.0", "cornering_stiffness = 873.0",
                                     r"wheels\.cornering_stiffness = 873 N/rad .*N/deg\? multiply by 57\.3: write 50019"),
    "cornering stiffness per axle": ("cornering_stiffness = 50000.0", "cornering_stiffness = 100000.0",
                                     r"rear tyre carrying 3112 N .*32\.1 times its load.*per axle.*write 50000"),
    "radius as the diameter": ("radius = 0.3", "radius = 0.6", r"wheels\.radius = 0\.6 m .*diameter\? give the radius: "
                                                             r"write 0\.3"),
    "radius in mm": ("radius = 0.3", "radius = 300", r"wheels\.radius = 300 m .*mm\? write 0\.3"),
    "yaw inertia 10x": ("yaw_inertia = 2500.0", "yaw_inertia = 25000.0",
                        r"yaw_inertia = 25000 kg m\^2 is 10\.1 times m l_f l_r = 2475"),
    "slip stiffness per %": ("longitudinal_stiffness = 60000.0", "longitudinal_stiffness = 600.0",
                             r"N per % of slip\? multiply by 100: write 60000"),
    "cg too high for the track": ("cg_height = 0.55", "cg_height = 1.2", r"rollover_threshold"),
}


def _car(tmp_path, text, name="car.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("case", list(SLIPS))
def test_a_value_in_the_wrong_unit_is_refused_naming_key_range_and_slip(tmp_path, case):
    line, new, expected = SLIPS[case]
    assert line in TEXT
    path = _car(tmp_path, TEXT.replace(line, new))
    with pytest.raises(InputFormatError) as info:
        load_vehicle(path)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{path}: implausible vehicle: ")
    assert re.search(expected, msg), msg
    assert "[checks] accept = [" in msg  # the way on for a real exotic vehicle is named


@pytest.mark.parametrize("case", list(SLIPS))
def test_the_checks_table_lets_an_exotic_vehicle_through(tmp_path, case):
    line, new, _ = SLIPS[case]
    text = TEXT.replace(line, new)
    with pytest.raises(InputFormatError) as info:
        load_vehicle(_car(tmp_path, text))
    names = re.search(r"accept = (\[.*?\])", str(info.value)).group(1)
    car = load_vehicle(_car(tmp_path, text + f"\n[checks]\naccept = {names}\n", "exotic.toml"))
    assert car != CAR


def test_the_checks_table_is_validated(tmp_path):
    with pytest.raises(InputFormatError, match=r"checks\.accept names \['body\.weight'\]"):
        load_vehicle(_car(tmp_path, TEXT + '\n[checks]\naccept = ["body.weight"]\n'))
    with pytest.raises(InputFormatError, match="takes one key, accept"):
        load_vehicle(_car(tmp_path, TEXT + "\n[checks]\nplausibility = false\n"))


def test_the_default_and_every_shipped_car_file_pass():
    assert implausible_values(CAR) == ()
    shipped = [p for p in resources.files("longprofile.vehicle").joinpath("data").iterdir() if p.name.endswith(".toml")]
    assert shipped
    for p in shipped:
        with resources.as_file(p) as path:
            assert implausible_values(load_vehicle(path)) == ()


def test_every_range_and_cross_check_is_named_in_the_docs():
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[3] / "docs" / "vehicle-slope.md").read_text(encoding="utf-8")
    for name in list(RANGES) + list(CROSS_CHECKS):
        assert f"`{name}`" in doc, name


@settings(max_examples=30, deadline=None)
@given(mass=st.floats(1000.0, 3000.0), k=st.floats(6.0, 20.0), h=st.floats(0.4, 0.7))
def test_the_suggested_value_is_the_intended_one_and_loads(tmp_path_factory, mass, k, h):
    """Oracle: the user's intended value. Written in tonnes, N/deg and mm, each is refused and the message's
    "write X" is the intended value (to its 4 digits), which loads."""
    import math

    front_load = mass * 9.80665 * CAR.cg_to_rear_axle / (2 * CAR.wheelbase)
    intended = CAR.with_changes(mass=round(mass), cornering_stiffness=round(k * front_load), cg_height=round(h, 3),
                                yaw_inertia=round(mass * CAR.cg_to_front_axle * CAR.cg_to_rear_axle))
    good = intended.to_toml()
    folder = tmp_path_factory.mktemp("cars")
    for key, value, slipped in (("mass", intended.mass, intended.mass / 1000),
                                ("cornering_stiffness", intended.cornering_stiffness,
                                 intended.cornering_stiffness * math.pi / 180),
                                ("cg_height", intended.cg_height, intended.cg_height * 1000)):
        text = re.sub(rf"^{key} = .*$", f"{key} = {slipped!r}", good, flags=re.M)
        with pytest.raises(InputFormatError) as info:
            load_vehicle(_car(folder, text))
        written = float(re.search(r"write ([0-9]+(?:\.[0-9]+)?)", str(info.value)).group(1))
        assert written == pytest.approx(value, rel=2e-4)
        assert load_vehicle(_car(folder, re.sub(rf"^{key} = .*$", f"{key} = {written!r}", good, flags=re.M))) \
            .with_changes(**{key: value}) == intended


@pytest.mark.parametrize("command", ["simulate", "slope"])
def test_the_cli_refuses_an_implausible_car_in_one_line(tmp_path, capsys, command):
    bad = _car(tmp_path, TEXT.replace("mass = 1500.0", "mass = 1.5"))
    out = tmp_path / "out.csv"
    if command == "simulate":
        argv = ["vehicle", "simulate", "--duration", "3", "--vehicle", str(bad), "-o", str(out)]
    else:
        log = tmp_path / "log.csv"
        assert main(["vehicle", "simulate", "--duration", "3", "--no-truth", "-o", str(log)]) == 0
        capsys.readouterr()
        argv = ["vehicle", "slope", str(log), "--vehicle", str(bad), "-o", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err and "tonnes? write 1500" in err
    assert not out.exists()
