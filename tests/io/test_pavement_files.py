"""Profile files a pavement engineer's tools write (session 36 probe): ERD with a byte order mark, spelled-out
units and an END after the data; CSV with Excel's trailing empty rows, a title above the header, or its stations
listed backwards; a track asked for twice."""

import numpy as np
import pytest

from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.io import read_erd, read_profile, write_erd, write_profile
from longprofile.road import Profile

ERD = """ERDFILEV2.00
     2,     4,    -1,     1,     5,   0.25,   10.0,
TITLE   probe
SHORTNAMleft    right
UNITSNAM{units}
XUNITS  {xunits}
END
1.0 -1.0
2.0 -2.0
3.0 -3.0
4.0 -4.0
"""


def _erd(tmp_path, *, units="mm      mm      ", xunits="m", tail="", prefix=b"", name="f.erd"):
    path = tmp_path / name
    path.write_bytes(prefix + (ERD.format(units=units, xunits=xunits) + tail).encode())
    return path


def _profile():
    x = np.arange(400) * 0.025
    z = np.column_stack([np.sin(x), np.cos(x)]) * 1e-3
    return Profile(x + 100.0, z, tracks=("left", "right"), name="p")


# --- ERD ---------------------------------------------------------------------------------------------------------

def test_erd_with_a_byte_order_mark_reads_as_without(tmp_path):
    plain = read_erd(_erd(tmp_path))
    bom = read_erd(_erd(tmp_path, prefix=b"\xef\xbb\xbf", name="bom.erd"))
    np.testing.assert_array_equal(bom.elevation, plain.elevation)
    np.testing.assert_array_equal(bom.distance, plain.distance)
    assert bom.tracks == ("left", "right") and bom.name == "probe"


@pytest.mark.parametrize("spelled,short", [("inches", "in"), ("Inch", "in"), ("feet", "ft"), ("FOOT", "ft"),
                                           ("millimeters", "mm"), ("Millimetres", "mm"), ("meters", "m"),
                                           ("METRES", "m"), ("centimetres", "cm")])
def test_erd_units_spelled_out_are_the_short_units(tmp_path, spelled, short):
    field = f"{spelled:<12}"  # longer than 8 characters: blank-separated words
    p = read_erd(_erd(tmp_path, units=f"{field} {field}", xunits=spelled))
    q = read_erd(_erd(tmp_path, units=f"{short:<8}{short:<8}", xunits=short, name="short.erd"))
    np.testing.assert_array_equal(p.elevation, q.elevation)
    np.testing.assert_array_equal(p.distance, q.distance)
    # the option may be given too, spelled or not, and agrees
    assert read_erd(_erd(tmp_path, units=f"{field} {field}", xunits=spelled, name="o.erd"), units=short).tracks


@pytest.mark.parametrize("units,xunits,key", [("furlongs furlongs", "m", "UNITSNAM"), ("mm      mm      ", "yards",
                                                                                      "XUNITS")])
def test_erd_unknown_units_are_refused_with_the_accepted_names(tmp_path, units, xunits, key):
    with pytest.raises(UnitsError, match=rf"{key}: unknown .* use one of .*'mm'.* or spelled out: inch\(es\), "
                                         r"foot/feet, millimeter\(s\)/millimetre\(s\)") as err:
        read_erd(_erd(tmp_path, units=units, xunits=xunits))
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("tail", ["END\n", "end\r\n", "  End  \n\n \n", "END"])
def test_erd_end_line_after_the_data_is_accepted(tmp_path, tail):
    p = read_erd(_erd(tmp_path, tail=tail))
    np.testing.assert_array_equal(p.elevation[:, 0], [1e-3, 2e-3, 3e-3, 4e-3])


def test_erd_text_after_the_data_other_than_end_is_still_refused(tmp_path):
    with pytest.raises(InputFormatError, match=r"line 12: 'STOP' is not a number"):
        read_erd(_erd(tmp_path, tail="STOP\n"))
    with pytest.raises(InputFormatError, match=r"line 12: 'END' is not a number"):
        read_erd(_erd(tmp_path, tail="END\n5.0 -5.0\n"))


# --- CSV ---------------------------------------------------------------------------------------------------------

def test_excel_trailing_rows_of_empty_cells_are_ignored(tmp_path):
    f = tmp_path / "x.csv"
    f.write_bytes(b'"Distance (m)","Left (mm)","Right (mm)",\r\n0.000,0.814,2.531,\r\n0.025,1.355,3.067,\r\n'
                  b"0.050,1.000,2.000,\r\n,,,\r\n,,,\r\n")
    p = read_profile(f)
    assert p.n_samples == 3 and p.tracks == ("Left", "Right")
    np.testing.assert_allclose(p.elevation[-1], [1e-3, 2e-3])


def test_a_row_of_empty_cells_among_the_data_is_still_refused(tmp_path):
    f = tmp_path / "x.csv"
    f.write_text("distance_m,left_mm,right_mm\n0,1,2\n,,\n0.05,1,2\n0.075,1,2\n,,\n")
    with pytest.raises(InputFormatError, match=r"line 3: empty station"):
        read_profile(f)


def test_a_title_above_the_header_is_named(tmp_path):
    f = tmp_path / "x.csv"
    f.write_text("Profile export\nFile: run1.ppf\nDate: 2024-05-01\n\nDistance (ft),Left (in),Right (in)\n"
                 "0.0000,0.03205,0.09966\n0.0820,0.05334,0.12076\n0.1640,0.05,0.12\n")
    with pytest.raises(InputFormatError, match=r"line 1 looks like a title, not a header \('Profile export'\): the "
                                               r"column names seem to be on line 5 \(Distance \(ft\), Left \(in\), "
                                               r"Right \(in\)\); remove the lines above the header") as err:
        read_profile(f)
    assert "\n" not in str(err.value)
    # the same lines as comments are read
    lines = f.read_text().splitlines()
    f.write_text("".join(f"# {ln}\n" for ln in lines[:4]) + "".join(f"{ln}\n" for ln in lines[4:]))
    assert read_profile(f).n_samples == 3
    # a title holding a comma has fewer fields than the header
    f.write_text("Survey 7, Dec 2026\ndistance_m,left_mm,right_mm\n0,1,2\n0.025,1,2\n")
    with pytest.raises(InputFormatError, match=r"line 1 looks like a title, not a header \('Survey 7, Dec 2026'\): "
                                               r"the column names seem to be on line 2"):
        read_profile(f)


def test_a_one_column_file_and_numbers_are_not_titles(tmp_path):
    # one column throughout; a header with one field less than the data (pandas' index) and numbers on line 2
    f = tmp_path / "one.csv"
    f.write_text("distance_m,left_mm\n0,1\n0.025,2\n0.05,3\n")
    assert read_profile(f).n_samples == 3
    g = tmp_path / "idx.csv"
    g.write_text("distance_m\n0,1,2\n1,2,3\n")
    with pytest.raises(InputFormatError) as err:
        read_profile(g)
    assert "title" not in str(err.value)


def test_stations_counting_down_are_read_as_the_distance_travelled(tmp_path):
    # before session 40 refused ("reverse its rows..."): a southbound lane's stations count down in the direction of
    # travel; the rows are read in their order, the first at distance 0 (tests/io/test_profile_file_variants.py)
    p = _profile()
    f = tmp_path / "back.csv"
    write_profile(p, f, units="mm")
    lines = f.read_text().splitlines()
    f.write_text("\n".join([lines[0], *reversed(lines[1:])]) + "\n")
    back = read_profile(f)
    np.testing.assert_allclose(back.distance, p.distance[-1] - p.distance[::-1], atol=1e-9)
    np.testing.assert_allclose(back.elevation, p.elevation[::-1], atol=1e-12)
    # a single step back is still named by its line
    g = tmp_path / "step.csv"
    g.write_text("distance_m,left_mm\n0,1\n0.025,2\n0.02,3\n0.05,4\n")
    with pytest.raises(InputFormatError, match=r"line 4: station 0.02 is not greater than the previous one 0.025"):
        read_profile(g)


# --- tracks ------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".csv", ".erd"])
def test_a_track_asked_for_twice_is_refused(tmp_path, suffix):
    f = tmp_path / f"p{suffix}"
    (write_erd if suffix == ".erd" else write_profile)(_profile(), f, units="mm")
    for tracks in (["left", "left"], ["left", "LEFT"], ("right", "left", "right")):
        with pytest.raises(InputError, match=r"the track '(LEFT|left|right)' is asked for twice"):
            read_profile(f, tracks=tracks)
    assert read_profile(f, tracks=["right", "left"]).tracks == ("right", "left")
