"""Profile files as profilers and spreadsheets write them (session 40, a pavement engineer's probe).

Oracle: a random profile written in a unit, header style, separator or format variant reads back as the profile
written (to the round-off of the unit conversion); a variant with no single reading is refused naming what to do.
"""

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.core import LENGTH_UNITS
from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.io import read_erd, read_profile, write_erd, write_profile
from longprofile.road import Profile
from longprofile.road.indices._dropouts import dropout_message

SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
#: Header spellings of a unit (the ERD reader's, shared) and the key each one is.
SPELLINGS = {"in": ["in", "inches", "Inch", "IN"], "ft": ["ft", "feet", "Foot"], "mm": ["mm", "millimetres", "MM"],
             "m": ["m", "metres", "Meters"], "cm": ["cm", "centimeters"]}
STYLES = ["{}_{}", "{} [{}]", "{} ({})"]


def _profile(seed: int, n: int, step: float) -> Profile:
    rng = np.random.default_rng(seed)
    z = np.cumsum(rng.normal(0, 1e-3, (n, 2)), axis=0)
    return Profile(distance=np.arange(n) * step, elevation=z, tracks=("LWP", "RWP"))


def _write_text(path, header, rows, sep=",", decimal="."):
    lines = [sep.join(header)] + [sep.join(repr(float(v)).replace(".", decimal) for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


@SETTINGS
@given(seed=st.integers(0, 2**31), xunit=st.sampled_from(["m", "ft"]), zunit=st.sampled_from(sorted(SPELLINGS)),
       data=st.data())
def test_a_unit_spelled_in_a_header_reads_as_its_short_name(tmp_path, seed, xunit, zunit, data):
    p = _profile(seed, 50, 0.25)
    xs, zs = data.draw(st.sampled_from(SPELLINGS[xunit])), data.draw(st.sampled_from(SPELLINGS[zunit]))
    style = data.draw(st.sampled_from(STYLES))
    header = [style.format("Distance", xs), style.format("LWP", zs), style.format("RWP", zs)]
    written = np.column_stack([p.distance / LENGTH_UNITS[xunit], p.elevation / LENGTH_UNITS[zunit]])
    read = read_profile(_write_text(tmp_path / "p.csv", header, written))
    assert read.tracks == ("LWP", "RWP")
    np.testing.assert_allclose(read.distance, written[:, 0] * LENGTH_UNITS[xunit], rtol=0, atol=0)
    np.testing.assert_allclose(read.elevation, written[:, 1:] * LENGTH_UNITS[zunit], rtol=0, atol=0)
    # the same unit given as the option is no contradiction; another one is
    assert read_profile(tmp_path / "p.csv", units=zunit.upper() if zunit != "m" else "m").n_samples == 50
    other = "mm" if zunit != "mm" else "in"
    with pytest.raises(UnitsError, match=f"is in {zunit!r} by its header but the unit {other!r} was given"):
        read_profile(tmp_path / "p.csv", units=other)


@pytest.mark.parametrize(("name", "unit"), [("LWP (µm)", "µm"), ("LWP [um]", "um"), ("LWP_microns", "microns"),
                                            ("LWP (mils)", "mils")])
@pytest.mark.parametrize("units", [None, "mm"])
def test_an_unconverted_unit_in_a_header_is_refused_naming_it(tmp_path, name, unit, units):
    f = _write_text(tmp_path / "p.csv", ["Distance (ft)", name], [[0.0, 1.0], [0.1, 1.1], [0.2, 1.2]])
    with pytest.raises(UnitsError) as info:
        read_profile(f, units=units)
    assert f"is in {unit!r}, a unit this package does not convert" in str(info.value)


@pytest.mark.parametrize("name", ["LWP (furlongs)", "LWP [volts]"])
def test_the_hint_never_keeps_a_suffix_that_is_no_unit(tmp_path, name):
    f = _write_text(tmp_path / "p.csv", ["distance_m", name], [[0.0, 1.0], [0.1, 1.1], [0.2, 1.2]])
    with pytest.raises(UnitsError) as info:
        read_profile(f)
    msg = str(info.value)
    assert "'LWP [mm]'" in msg and not re.search(r"[)\]]_mm", msg)


@SETTINGS
@given(seed=st.integers(0, 2**31), sep=st.sampled_from([";", "\t"]), decimal=st.sampled_from([",", "."]),
       suffix=st.sampled_from([".csv", ".txt"]))
def test_semicolon_and_tab_files_with_one_decimal_mark_read_as_the_comma_file(tmp_path, seed, sep, decimal, suffix):
    p = _profile(seed, 40, 0.025)
    rows = np.column_stack([p.distance, p.elevation * 1e3])
    header = ["distance_m", "left_mm", "right_mm"]
    expected = read_profile(_write_text(tmp_path / "ref.csv", header, rows))
    read = read_profile(_write_text(tmp_path / f"p{suffix}", header, rows, sep=sep, decimal=decimal))
    np.testing.assert_array_equal(read.distance, expected.distance)
    np.testing.assert_array_equal(read.elevation, expected.elevation)


@pytest.mark.parametrize("sep", [";", "\t"])
def test_a_file_holding_both_decimal_marks_is_refused(tmp_path, sep):
    f = tmp_path / "p.csv"
    f.write_text(sep.join(["distance_m", "left_mm"]) + "\n" + "".join(f"{i * 0.25};1,5\n".replace(";", sep)
                                                                     for i in range(20)))
    with pytest.raises(InputFormatError, match="decimal mark cannot be told"):
        read_profile(f)


def test_a_footer_line_is_named_as_a_footer(tmp_path):
    f = _write_text(tmp_path / "p.csv", ["distance_m", "left_mm", "right_mm"],
                    [[i * 0.25, 1.0, 2.0] for i in range(20)])
    f.write_text(f.read_text() + "End of data\n")
    with pytest.raises(InputFormatError) as info:
        read_profile(f)
    assert "line 22 (the last) is text, not data ('End of data'): a footer" in str(info.value)
    assert "cut short" not in str(info.value)


def test_an_erd_body_with_decimal_commas_is_named(tmp_path):
    f = tmp_path / "p.erd"
    f.write_text("ERDFILEV2.00\n2, 3, -1, 1, 5, 0.25, 0,\nSHORTNAMleft    right\nUNITSNAMmm      mm\nXUNITS  m\n"
                 "END\n0,7866 0,3635\n0,7728 0,4268\n0,7553 0,4601\n")
    with pytest.raises(InputFormatError, match=r"line 7: the data are written with decimal commas \('0,7866 0,3635'\)"):
        read_erd(f)


@SETTINGS
@given(seed=st.integers(0, 2**31), n=st.integers(2, 400), step_ft=st.sampled_from([0.082021, 0.25, 1.0, 0.5]),
       x0_ft=st.floats(0, 1e5), units=st.sampled_from(["in", "mm"]), xunit=st.sampled_from(["ft", "m", "mi"]))
def test_a_us_erd_file_reads_back_as_the_profile_written(tmp_path, seed, n, step_ft, x0_ft, units, xunit):
    x = (x0_ft + step_ft * np.arange(n)) * LENGTH_UNITS["ft"]
    z = np.cumsum(np.random.default_rng(seed).normal(0, 1e-3, (n, 2)), axis=0)
    p = Profile(distance=x, elevation=z, tracks=("left", "right"))
    f = write_erd(p, tmp_path / "p.erd", units=units, distance_units=xunit)
    head = f.read_text().split("END\n")[0]
    assert f"XUNITS  {'feet' if xunit == 'ft' else xunit}\n" in head
    assert ("UNITSNAMinches  inches" if units == "in" else "UNITSNAMmm      mm") in head
    back = read_profile(f)
    np.testing.assert_allclose(back.distance, x, rtol=0, atol=1e-9 * max(1.0, float(np.max(np.abs(x))) / 1e3))
    np.testing.assert_allclose(back.elevation, z, rtol=0, atol=5.0001e-8)


def test_a_us_csv_profile_writes_feet_stations(tmp_path):
    p = Profile(distance=np.arange(5) * 0.3048, elevation=np.zeros((5, 1)) + 0.0254, tracks=("left",))
    f = write_profile(p, tmp_path / "p.csv", units="in", distance_units="ft")
    assert f.read_text().splitlines()[:2] == ["distance_ft,left_in", "0.0,1.0"]
    np.testing.assert_allclose(read_profile(f).distance, p.distance, rtol=1e-15)


def test_a_track_name_with_blanks_names_the_rename_option(tmp_path):
    p = Profile(distance=np.arange(5) * 0.25, elevation=np.zeros((5, 1)), tracks=("Left Elevation",))
    with pytest.raises(InputError, match="--rename 'Left Elevation=left'"):
        write_erd(p, tmp_path / "p.erd")


def test_the_dropout_message_gives_a_readable_length():
    msg = dropout_message([("right", 0.0, 2000.0, 0.0032)])
    assert "(2000.0 m)" in msg and "e+0" not in msg


def test_an_unknown_suffix_names_erd_among_the_formats(tmp_path):
    f = tmp_path / "p.dat"
    f.write_text("distance_m,left_mm\n0,1\n0.25,2\n")
    with pytest.raises(InputError, match=r"use \.csv \(\.txt\), \.parquet or \.erd"):
        read_profile(f)


@SETTINGS
@given(seed=st.integers(0, 2**31), n=st.integers(2, 200), first=st.floats(1.0, 1e5), unit=st.sampled_from(["m", "ft"]),
       suffix=st.sampled_from([".csv", ".parquet"]))
def test_stations_counting_down_read_as_the_distance_travelled(tmp_path, seed, n, first, unit, suffix):
    """A southbound run (rows in the direction of travel, stations decreasing) reads in the order of its rows: the
    first row is distance 0 and the elevations keep their order (the IRI runs in the direction of travel)."""
    from longprofile.io import backward_stations

    step = first / n
    stations = first - step * np.arange(n)
    z = np.cumsum(np.random.default_rng(seed).normal(0, 1e-3, (n, 1)), axis=0)
    import pandas as pd

    f = tmp_path / f"p{suffix}"
    frame = pd.DataFrame({f"distance_{unit}": stations, "left_mm": z[:, 0] * 1e3})
    frame.to_csv(f, index=False) if suffix == ".csv" else frame.to_parquet(f)
    p = read_profile(f)
    factor = LENGTH_UNITS[unit]
    np.testing.assert_array_equal(p.distance, stations[0] * factor - stations * factor)
    np.testing.assert_array_equal(p.elevation[:, 0], (z[:, 0] * 1e3) * 1e-3)
    assert backward_stations(f) == (f"distance_{unit}", stations[0], stations[-1])
    frame.iloc[::-1].to_csv(tmp_path / "forward.csv", index=False)
    assert backward_stations(tmp_path / "forward.csv") is None
    # stations that decrease and then do not are still refused at their line
    g = _write_text(tmp_path / "g.csv", ["distance_m", "left_mm"], [[2.0, 1.0], [1.0, 1.0], [1.5, 1.0]])
    with pytest.raises(InputFormatError, match="line 3: station 1 is not greater"):
        read_profile(g)
    assert backward_stations(g) is None
