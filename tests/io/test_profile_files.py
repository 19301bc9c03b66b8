"""Profile files: CSV / Parquet / ERD round trips, units never guessed, malformed files name the line."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.io import read_erd, read_profile, write_erd, write_profile
from longprofile.road import Profile, iso8608_profile


def _two_track(std=False):
    p = iso8608_profile(30.0, 0.25, "C", rng=0, tracks=("left", "right"))
    if std:
        return Profile(distance=p.distance + 100.0, elevation=p.elevation, tracks=p.tracks,
                       std=np.abs(p.elevation) * 0.1 + 1e-4, name="x")
    return p


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(units=st.sampled_from(["m", "mm", "in", "ft"]), suffix=st.sampled_from([".csv", ".parquet", ".erd"]),
       with_std=st.booleans())
def test_round_trip(tmp_path, units, suffix, with_std):
    p = _two_track(std=with_std and suffix != ".erd")
    path = write_profile(p, tmp_path / f"p{suffix}", units=units)
    q = read_profile(path)
    np.testing.assert_allclose(q.distance, p.distance, rtol=0, atol=1e-9)
    if suffix == ".erd":  # printed to 1e-7 m (write_erd): within half of it
        np.testing.assert_allclose(q.elevation, p.elevation, rtol=0, atol=5e-8 + 1e-12)
    else:  # CSV / Parquet: the same float64 after the unit conversion both ways
        np.testing.assert_allclose(q.elevation, p.elevation, rtol=4e-16, atol=0)
    assert q.tracks == p.tracks
    if p.std is not None:
        np.testing.assert_allclose(q.std, p.std, rtol=4e-16)


def test_apl_demo_contract_columns(tmp_path):
    f = tmp_path / "reconstructed_profile.csv"
    f.write_text("distance_m,true_m,smoother_m,smoother_std_m,filter_m,double_m\n"
                 "0.0,0.001,0.0011,0.0002,0.0009,0.001\n0.1,0.002,0.0021,0.0002,0.0019,0.002\n")
    p = read_profile(f)
    assert p.tracks == ("true", "smoother", "filter", "double")
    np.testing.assert_allclose(p.std[:, 1], [2e-4, 2e-4])
    assert np.isnan(p.std[:, 0]).all()
    q = read_profile(f, tracks="smoother")
    assert q.tracks == ("smoother",) and q.std.shape == (2, 1)


def test_units_are_never_guessed(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("distance_m,left\n0,1.5\n0.25,1.7\n")
    with pytest.raises(UnitsError, match="pass --elevation-unit m\\|mm"):
        read_profile(f)
    np.testing.assert_allclose(read_profile(f, units="mm").elevation[:, 0], [1.5e-3, 1.7e-3])
    g = tmp_path / "q.csv"
    g.write_text("distance_m,left [mm]\n0,1.5\n0.25,1.7\n")
    with pytest.raises(UnitsError, match="is in 'mm' by its header but the unit 'm'"):
        read_profile(g, units="m")
    h = tmp_path / "r.csv"
    h.write_text("distance,left_mm\n0,1.5\n0.25,1.7\n")
    with pytest.raises(UnitsError, match="does not give its unit"):
        read_profile(h)


def test_units_in_brackets_or_parentheses(tmp_path):
    # "Distance (ft)" / "Elevation (in)": the form spreadsheets and profiler exports write; the same numbers as _m
    f, g = tmp_path / "ft.csv", tmp_path / "m.csv"
    f.write_text("Elevation (in),Distance (ft)\n1.0,0\n2.0,1\n0.5,2\n")
    g.write_text("distance_m,elevation_m\n0,0.0254\n0.3048,0.0508\n0.6096,0.0127\n")
    p, q = read_profile(f), read_profile(g)
    assert p.tracks == ("Elevation",)
    np.testing.assert_allclose(p.distance, q.distance, rtol=1e-15)
    np.testing.assert_allclose(p.elevation, q.elevation, rtol=1e-15)
    b = tmp_path / "b.csv"
    b.write_text("x [m],left [mm]\n0,1\n1,2\n")
    np.testing.assert_allclose(read_profile(b).elevation[:, 0], [1e-3, 2e-3])
    # a parenthesised word that is not a unit is not read as one: the column then names no unit
    h = tmp_path / "h.csv"
    h.write_text("distance (m),elevation (left)\n0,1\n1,2\n")
    with pytest.raises(UnitsError, match="does not give its elevation unit"):
        read_profile(h)


def test_malformed_csv_names_the_line(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("distance_m,left_mm\n0,1.5\n0.25,abc\n0.5,1.0\n")
    with pytest.raises(InputFormatError, match="line 3: column 'left_mm' has a non-numeric value 'abc'"):
        read_profile(f)
    g = tmp_path / "q.csv"
    g.write_text("distance_m,left_mm\n0,1.5\n0.25,1.6\n0.25,1.0\n")
    with pytest.raises(InputFormatError, match="line 4: station 0.25 is not greater"):
        read_profile(g)
    h = tmp_path / "r.csv"
    h.write_text("dist,left_mm\n0,1.5\n")
    with pytest.raises(InputFormatError, match="no station column"):
        read_profile(h)


LTPP_LIKE = """ERDFILEV2.00
      3,   5,     -1,      1,      5,       0.0250,     -1,
TITLE   LTPP-style section: Run 1
SHORTNAMleft    right   center
UNITSNAMmm      mm      mm
XUNITS  m
DATE    11/Apr/1997

END
 0.0 0.0 0.0
 1.0 -1.0 0.5
 2.0 -2.0 0.5
 3.0 -3.0 0.5
 4.0 -4.0 0.5
"""


def test_erd_reads_ltpp_style_header(tmp_path):
    f = tmp_path / "run.erd"
    f.write_text(LTPP_LIKE)
    p = read_erd(f)
    assert p.tracks == ("left", "right", "center") and p.name == "LTPP-style section: Run 1"
    # field 7 is X0, the first station, whatever its notation (an integer here): stations -1 + 0.025 i
    np.testing.assert_allclose(p.distance, -1.0 + 0.025 * np.arange(5), rtol=0, atol=1e-12)
    np.testing.assert_allclose(p.elevation[:, 1], -1e-3 * np.arange(5))
    assert read_profile(f, tracks=["right"]).tracks == ("right",)


@pytest.mark.parametrize("edit,match", [
    (lambda s: s.replace("ERDFILEV2.00", "HELLO"), "line 1: expected 'ERDFILEV2.00'"),
    (lambda s: s.replace("     -1,      1,      5,       0.0250,     -1,", ""), "line 2: expected"),
    (lambda s: s.replace(" 2.0 -2.0 0.5", " 2.0 x 0.5"), "line 12: 'x' is not a number"),
    (lambda s: s.replace(" 4.0 -4.0 0.5\n", ""), "announces NCHAN x NPTS = 3 x 5 = 15"),
    (lambda s: s.replace("\nEND\n", "\n"), "no END line"),
])
def test_erd_malformed(tmp_path, edit, match):
    f = tmp_path / "bad.erd"
    f.write_text(edit(LTPP_LIKE))
    with pytest.raises(InputFormatError, match=match):
        read_erd(f)


def test_erd_units(tmp_path):
    f = tmp_path / "nounits.erd"
    f.write_text(LTPP_LIKE.replace("UNITSNAMmm      mm      mm\n", ""))
    with pytest.raises(UnitsError, match="no UNITSNAM line; pass --elevation-unit"):
        read_erd(f)
    assert read_erd(f, units="m").elevation[1, 0] == 1.0
    g = tmp_path / "inch.erd"
    g.write_text(LTPP_LIKE.replace("UNITSNAMmm      mm      mm", "UNITSNAMin      in      in").replace(
        "XUNITS  m", "XUNITS  ft"))
    p = read_erd(g)
    np.testing.assert_allclose(p.elevation[1, 0], 0.0254)
    np.testing.assert_allclose(p.distance[:2], np.array([-1.0, -1.0 + 0.025]) * 0.3048)  # X0, DX in XUNITS


def test_erd_write_refuses_irregular(tmp_path):
    p = Profile(distance=[0.0, 0.1, 0.3], elevation=[0.0, 0.0, 0.0])
    with pytest.raises(InputError, match="constant station step"):
        write_erd(p, tmp_path / "x.erd")
    with pytest.raises(UnitsError, match="unknown elevation unit 'furlong'"):
        write_profile(_two_track(), tmp_path / "x.csv", units="furlong")
