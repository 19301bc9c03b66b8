"""ERD files: every honoured header field, both body layouts, errors naming the file line, exact round trip.

Oracles: hand-written ERD text with known stations/elevations (the layout of the LTPP and ProVAL text files)
and, for the round trip, the profile written. The fast (pandas C) and slow (line-by-line) body parsers are
checked to agree on random layouts.
"""

import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.core import LENGTH_UNITS
from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.io import read_erd, read_profile, write_erd
from longprofile.io._erd import _parse_body_fast, _parse_body_slow
from longprofile.road import Profile

HEADER = """ERDFILEV2.00
{line2}
TITLE   {title}
SHORTNAM{names}
UNITSNAM{units}
XUNITS  {xunits}
DATE    11/Apr/1997
END
"""


def _erd(tmp_path, body, *, line2="      2,      4,     -1,      1,      5,       0.0250,      0.0,", title="Run 1",
         names="left    right   ", units="mm      mm      ", xunits="m", name="f.erd", drop=()):
    text = HEADER.format(line2=line2, title=title, names=names, units=units, xunits=xunits)
    text = "".join(ln + "\n" for ln in text.splitlines() if not any(ln.startswith(d) for d in drop))
    path = tmp_path / name
    path.write_bytes((text + body).encode())
    return path


BODY = " 1.0 -1.0\n 2.0 -2.0\n 3.0 -3.0\n 4.0 -4.0\n"  # 4 records x 2 channels, mm


# --- line 2: NCHAN, NPTS, DX, X0 ----------------------------------------------------------------------------

@pytest.mark.parametrize("x0_text,x0", [("0", 0.0), ("100", 100.0), ("100.0", 100.0), ("1.0E+02", 100.0),
                                        ("-1", -1.0), ("-12.5", -12.5), ("2.5e1", 25.0), ("0.000000", 0.0)])
def test_first_station_x0_in_any_notation(tmp_path, x0_text, x0):
    f = _erd(tmp_path, BODY, line2=f"2, 4, -1, 1, 5, 0.25, {x0_text},")
    np.testing.assert_allclose(read_erd(f).distance, x0 + 0.25 * np.arange(4), rtol=0, atol=1e-12)


@pytest.mark.parametrize("dx_text,dx", [("1", 1.0), ("0.025", 0.025), ("2.5E-02", 0.025), ("  0.25  ", 0.25),
                                        ("5.0000000E-02", 0.05)])
def test_station_step_dx_in_any_notation(tmp_path, dx_text, dx):
    f = _erd(tmp_path, BODY, line2=f"2, 4, -1, 1, 5, {dx_text}, 100")  # no trailing comma either
    np.testing.assert_allclose(read_erd(f).distance, 100.0 + dx * np.arange(4), rtol=0, atol=1e-12)


@pytest.mark.parametrize("xunits,factor", [("m", 1.0), ("ft", 0.3048), ("km", 1000.0), ("mi", 1609.344),
                                           ("in", 0.0254)])
def test_xunits_scale_x0_and_dx(tmp_path, xunits, factor):
    f = _erd(tmp_path, BODY, line2="2, 4, -1, 1, 5, 2, 10,", xunits=xunits)
    np.testing.assert_allclose(read_erd(f).distance, (10.0 + 2.0 * np.arange(4)) * factor, rtol=1e-15)


def test_nchan_and_npts_shape_the_records(tmp_path):
    f = _erd(tmp_path, " 1 2 3\n 4 5 6\n", line2="3, 2, -1, 1, 5, 0.1, 0,", names="a       b       c       ",
             units="m       m       m       ")
    p = read_erd(f)
    assert p.tracks == ("a", "b", "c")
    np.testing.assert_array_equal(p.elevation, [[1, 2, 3], [4, 5, 6]])
    # records broken over lines are read in order, NCHAN values each (FORTRAN list-directed text)
    g = _erd(tmp_path, " 1 2\n 3\n 4 5 6\n", line2="3, 2, -1, 1, 5, 0.1, 0,", names="a       b       c       ",
             units="m       m       m       ", name="g.erd")
    np.testing.assert_array_equal(read_erd(g).elevation, [[1, 2, 3], [4, 5, 6]])


@pytest.mark.parametrize("line2,match", [
    ("2, 4, -1, 1, 5, 0.25", "line 2: expected 7 comma-separated fields"),
    ("two, 4, -1, 1, 5, 0.25, 0,", r"line 2: field 1 \(NCHAN\) is not a number: 'two'"),
    ("2, 4.5, -1, 1, 5, 0.25, 0,", r"field 2 \(NPTS\) must be a whole number"),
    ("2, 4, -1, 1, 5, 0.25, start,", r"field 7 \(X0\) is not a number: 'start'"),
    ("2, 4, -1, 1, 5, nan, 0,", r"field 6 \(DX\) must be finite"),
    ("2, 4, -1, 1, 5, 0, 0,", "need NCHAN >= 1, NPTS >= 2 and DX > 0"),
    ("2, 1, -1, 1, 5, 0.25, 0,", "need NCHAN >= 1, NPTS >= 2 and DX > 0"),
])
def test_bad_line2_is_refused(tmp_path, line2, match):
    with pytest.raises(InputFormatError, match=match):
        read_erd(_erd(tmp_path, BODY, line2=line2))


# --- keyword lines: SHORTNAM, UNITSNAM, XUNITS, TITLE ----------------------------------------------------------

def test_names_and_title(tmp_path):
    p = read_erd(_erd(tmp_path, BODY, names="L elev  R elev  ", title="LTPP section 06B410SF: Run 1"))
    assert p.tracks == ("L elev", "R elev") and p.name == "LTPP section 06B410SF: Run 1"
    q = read_erd(_erd(tmp_path, BODY, drop=("SHORTNAM", "TITLE"), name="run7.erd"))
    assert q.tracks == ("ch1", "ch2") and q.name == "run7"
    r = read_erd(_erd(tmp_path, BODY, names="left_wheel_path right_wheel_path", name="long.erd"))
    assert r.tracks == ("left_wheel_path", "right_wheel_path")
    assert read_erd(_erd(tmp_path, BODY), tracks="right").tracks == ("right",)
    with pytest.raises(InputError, match="no channel 'centre'; the file has"):
        read_erd(_erd(tmp_path, BODY), tracks=["centre"])
    with pytest.raises(InputFormatError, match="line 4: SHORTNAM gives neither 2 blank-separated names nor 2 "):
        read_erd(_erd(tmp_path, BODY, names="left    right   centre  "))


@pytest.mark.parametrize("names,units,tracks", [
    ("  LEFT RIGHT", "  inch inch", ("LEFT", "RIGHT")),      # hand-written, blank-separated (probe 37)
    ("\tLeft\tRight", "\tmm\tmm", ("Left", "Right")),        # tab-separated
    (" LWP     RWP     ", " mm      mm      ", ("LWP", "RWP")),  # one blank after the keyword, then 8-char fields
    ("LEFTWHEERIGHTWHE", "mm      mm      ", ("LEFTWHEE", "RIGHTWHE")),  # 8-char names with no blank between
    ("L elev  R elev  ", "mm      mm      ", ("L elev", "R elev")),  # names holding a blank, fixed fields
    ("  Left       Right", "  mm mm", ("Left", "Right")),        # wider than 16 columns, two words
])
def test_names_and_units_blank_separated_or_in_8_character_fields(tmp_path, names, units, tracks):
    """A name is never cut at column 8 (it gave tracks 'LEFT R', 'IGHT' and the unit 'inch i'): NCHAN words are the
    names, else the 8-character fields of the ERD convention."""
    p = read_erd(_erd(tmp_path, BODY, names=names, units=units))
    assert p.tracks == tracks
    factor = 0.0254 if "inch" in units else 1e-3
    np.testing.assert_allclose(p.elevation[:, 0], np.arange(1, 5) * factor)


@pytest.mark.parametrize("names", ["  LEFT RIGHT CENTRE", "  LEFT RIGHT X", "left    right   centre  "])
def test_names_neither_blank_separated_nor_in_fields_are_refused_naming_the_line(tmp_path, names):
    with pytest.raises(InputFormatError, match=r"line 4: SHORTNAM gives neither 2 blank-separated names nor 2 "
                                               r"8-character fields .*write one name per channel"):
        read_erd(_erd(tmp_path, BODY, names=names))


def test_track_names_in_any_letter_case(tmp_path):
    """``tracks=`` finds a channel in any letter case, as in CSV files (``--track left`` on ``Left``)."""
    path = _erd(tmp_path, BODY, names="Left    RIGHT   ")
    assert read_erd(path, tracks=["left", "right"]).tracks == ("Left", "RIGHT")
    with pytest.raises(InputError, match="2 channels are 'left' in some letter case"):
        read_erd(_erd(tmp_path, BODY, names="Left    LEFT    ", name="two.erd"), tracks="left")


@pytest.mark.parametrize("unit", sorted(LENGTH_UNITS))
def test_unitsnam_is_honoured(tmp_path, unit):
    p = read_erd(_erd(tmp_path, BODY, units=f"{unit:<8}{unit:<8}"))
    np.testing.assert_allclose(p.elevation[:, 0], np.arange(1, 5) * LENGTH_UNITS[unit], rtol=1e-15)


def test_units_per_channel_and_checks(tmp_path):
    p = read_erd(_erd(tmp_path, BODY, units="mm      in      "))
    np.testing.assert_allclose(p.elevation[1], [2e-3, -2 * 0.0254], rtol=1e-15)
    with pytest.raises(UnitsError, match=r"gives units \['mm', 'mm'\] but units='m'"):
        read_erd(_erd(tmp_path, BODY), units="m")
    assert read_erd(_erd(tmp_path, BODY), units="MM").elevation[0, 0] == pytest.approx(1e-3)
    f = _erd(tmp_path, BODY, drop=("UNITSNAM",), name="nounits.erd")
    with pytest.raises(UnitsError, match="no UNITSNAM line; pass --elevation-unit"):
        read_erd(f)
    assert read_erd(f, units="in").elevation[0, 0] == pytest.approx(0.0254)
    with pytest.raises(UnitsError, match="UNITSNAM: unknown elevation unit 'furlong'"):
        read_erd(_erd(tmp_path, BODY, units="furlong mm      "))
    # a channel that is not a length (a time, a speed) does not stop reading the others
    t = read_erd(_erd(tmp_path, BODY, units="mm      s       ", name="time.erd"), tracks="left")
    np.testing.assert_allclose(t.elevation[:, 0], np.arange(1, 5) * 1e-3)


def test_xunits_checks(tmp_path):
    f = _erd(tmp_path, BODY, drop=("XUNITS",))
    with pytest.raises(UnitsError, match="no XUNITS line"):
        read_erd(f)
    np.testing.assert_allclose(read_erd(f, distance_units="ft").distance[1], 0.025 * 0.3048)
    with pytest.raises(UnitsError, match="XUNITS is 'm' but distance_units='ft'"):
        read_erd(_erd(tmp_path, BODY), distance_units="ft")
    with pytest.raises(UnitsError, match="XUNITS: unknown distance unit 'parsec'"):
        read_erd(_erd(tmp_path, BODY, xunits="parsec"))


# --- body layouts --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("body", [
    BODY,
    "1.0,-1.0\n2.0,-2.0\n3.0,-3.0\n4.0,-4.0\n",
    " 1.0, -1.0,\n 2.0, -2.0,\n 3.0, -3.0,\n 4.0, -4.0,\n",  # trailing commas
    "1.0\t-1.0\r\n2.0\t-2.0\r\n3.0\t-3.0\r\n4.0\t-4.0\r\n",  # tabs, CRLF
    "\n1.0 -1.0\n\n2.0 -2.0\n3.0 -3.0\n4.0 -4.0",  # blank lines, no final newline
    "1e0 -1E+0\n+2 -2.\n.3e1 -3.0\n4 -4\n",
])
def test_blank_and_comma_separated_bodies(tmp_path, body):
    np.testing.assert_array_equal(read_erd(_erd(tmp_path, body)).elevation * 1e3,
                                  [[1, -1], [2, -2], [3, -3], [4, -4]])


def test_missing_samples_are_nan(tmp_path):
    p = read_erd(_erd(tmp_path, " 1.0 nan\n NaN -2.0\n 3.0 -3.0\n 4.0 -4.0\n"))
    assert np.isnan(p.elevation[0, 1]) and np.isnan(p.elevation[1, 0]) and p.elevation[2, 0] == 3e-3


@pytest.mark.parametrize("name,prefix", [("f.txt", b""), ("F.TXT", b"\xef\xbb\xbf"), ("f.dat", b""), ("f", b"  ")])
def test_an_erd_file_under_another_suffix_is_read_as_erd(tmp_path, name, prefix):
    """ERD files are also distributed as .txt (read as CSV before: "header (ERDFILEV2.00) but no data rows")."""
    f = _erd(tmp_path, BODY, name=name)
    f.write_bytes(prefix + f.read_bytes())
    p = read_profile(f)
    assert p.tracks == ("left", "right")
    np.testing.assert_array_equal(p.elevation * 1e3, [[1, -1], [2, -2], [3, -3], [4, -4]])


def test_a_csv_named_txt_is_still_a_table(tmp_path):
    f = tmp_path / "t.txt"
    f.write_text("distance_m,left_mm\n0,1\n0.25,2\n0.5,3\n")
    assert read_profile(f).tracks == ("left",)


def test_crlf_header(tmp_path):
    f = _erd(tmp_path, BODY)
    f.write_bytes(f.read_bytes().replace(b"\n", b"\r\n"))
    p = read_erd(f)
    assert p.tracks == ("left", "right") and p.elevation.shape == (4, 2)


# --- errors name the file line --------------------------------------------------------------------------------

@pytest.mark.parametrize("body,match", [
    (" 1.0 -1.0\n 2.0 x\n 3.0 -3.0\n 4.0 -4.0\n", "line 10: 'x' is not a number"),
    (" 1.0 -1.0\n 2.0 -2.0\n 3.0 -3.0\n 4.0 -4.0\n 5.0 -5.0\n", r"line 13: more values than NCHAN x NPTS = 2 x 4"),
    (" 1.0 -1.0\n 2.0 -2.0\n 3.0 -3.0\n", r"the data have 6 values; line 2 announces NCHAN x NPTS = 2 x 4 = 8"),
    (" 1.0 -1.0\n 2.0\n 3.0 -3.0\n 4.0 -4.0\n", r"the data have 7 values"),
    ("1.0,-1.0\n2.0,,-2.0\n3.0,-3.0\n4.0,-4.0\n", "line 10: empty value between commas"),
    ("1.0,-1.0\n,2.0\n3.0,-3.0\n4.0,-4.0\n", "line 10: empty value between commas"),
    ("", r"the data have 0 values"),
    (" 1.0 -1.0\n 2.0 -2.0\n 3.0 -3.0\n 4.0 \"-4.0\"\n", "line 12: '\"-4.0\"' is not a number"),
])
def test_bad_data_name_the_line(tmp_path, body, match):
    # the header is 8 lines: the first record is on line 9
    with pytest.raises(InputFormatError, match=match):
        read_erd(_erd(tmp_path, body))


def test_bad_value_deep_in_a_long_file_is_found_by_the_diagnostic_pass(tmp_path):
    n = 20_000
    rows = [f"{i * 0.001:.4f} {-i * 0.001:.4f}" for i in range(n)]
    rows[12_345] = "1.0 1.0.0"
    f = _erd(tmp_path, "\n".join(rows) + "\n", line2=f"2, {n}, -1, 1, 5, 0.025, 0,")
    with pytest.raises(InputFormatError, match=r"line 12354: '1\.0\.0' is not a number"):
        read_erd(f)


@pytest.mark.parametrize("content,match", [
    (b"", "empty file"),
    (b"HELLO\n2, 4, -1, 1, 5, 0.25, 0,\nEND\n", "line 1: expected 'ERDFILEV2.00', got 'HELLO'"),
    (b"ERDFILEV2.00\n2, 4, -1, 1, 5, 0.25, 0,\nXUNITS  m\n1 2\n", "no END line"),
    (b"ERDFILEV2.00\nEND\n1 2\n", "line 2: expected"),
    (b"ERDFILEV2.00\n\x00\x01\x02\x03END\n", "not a text file"),
])
def test_not_an_erd_file(tmp_path, content, match):
    f = tmp_path / "x.erd"
    f.write_bytes(content)
    with pytest.raises(InputFormatError, match=match):
        read_erd(f)


def test_binary_data_file_is_refused(tmp_path):
    f = _erd(tmp_path, "", name="run.erd")
    (tmp_path / "run.bin").write_bytes(b"\x00" * 32)
    with pytest.raises(InputFormatError, match="binary file run.bin, which is not supported"):
        read_erd(f)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_erd(tmp_path / "nope.erd")


# --- fast and slow body parsers agree ---------------------------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(data=st.data(), nchan=st.integers(1, 4), npts=st.integers(2, 30), comma=st.booleans(),
       wrap=st.booleans())
def test_fast_and_slow_parsers_agree_on_random_layouts(data, nchan, npts, comma, wrap):
    values = data.draw(st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64),
                                min_size=nchan * npts, max_size=nchan * npts))
    sep = ", " if comma else "  "
    tokens = [repr(v) for v in values]
    if wrap:  # records broken at random places
        cuts = sorted(set(data.draw(st.lists(st.integers(1, len(tokens) - 1), max_size=8)))) if len(tokens) > 1 else []
        lines = [sep.join(tokens[a:b]) for a, b in zip([0] + cuts, cuts + [len(tokens)])]
    else:
        lines = [sep.join(tokens[i * nchan:(i + 1) * nchan]) for i in range(npts)]
    raw = ("\n".join(lines) + "\n").encode()
    slow = _parse_body_slow("x", raw, 0, 1, nchan, npts)
    np.testing.assert_array_equal(slow, values)
    fast = _parse_body_fast(raw, 0, nchan, npts)
    if not wrap:
        assert fast is not None  # a regular body never needs the slow pass
    if fast is not None:
        np.testing.assert_array_equal(fast.ravel(), values)


# --- write_erd: exact round trip to the printed precision ---------------------------------------------------

_DECIMALS = {u: max(0, math.ceil(math.log10(f / 1e-7) - 1e-9)) for u, f in LENGTH_UNITS.items()}


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(n=st.integers(2, 300), k=st.integers(1, 3), unit=st.sampled_from(sorted(LENGTH_UNITS)),
       x0=st.one_of(st.integers(-1000, 100_000).map(float), st.floats(-1e3, 1e5, allow_nan=False)),
       dx=st.one_of(st.sampled_from([0.025, 0.05, 0.1, 0.25, 1.0, 2.0, 0.3048]), st.floats(1e-3, 10.0)),
       scale=st.sampled_from([1e-4, 1e-2, 1.0, 600.0]), nan=st.booleans(), seed=st.integers(0, 2**32 - 1))
def test_write_read_round_trip(tmp_path, n, k, unit, x0, dx, scale, nan, seed):
    rng = np.random.default_rng(seed)
    z = scale * rng.standard_normal((n, k))
    if nan:
        z[rng.integers(0, n), rng.integers(0, k)] = np.nan
    names = tuple(["left", "right", "centre_line"][:k])
    p = Profile(distance=x0 + dx * np.arange(n), elevation=z, tracks=names, name="run 1")
    path = write_erd(p, tmp_path / "p.erd", units=unit)
    q = read_erd(path)
    assert q.tracks == p.tracks and q.name == "run 1"
    np.testing.assert_allclose(q.distance, p.distance, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(np.isnan(q.elevation), np.isnan(z))
    ok = ~np.isnan(z)
    # half the printed resolution (1e-7 m), plus the float rounding of the unit conversions
    assert np.all(np.abs(q.elevation[ok] - z[ok]) <= 5e-8 * (1 + 1e-9) + 4e-16 * np.abs(z[ok]))
    # the printed precision is what the docstring says: at most _DECIMALS[unit] decimals per value
    body = path.read_text().split("\nEND\n", 1)[1]
    longest = max(len(t.split(".")[1]) if "." in t and "e" not in t else 0 for t in body.split())
    assert longest <= _DECIMALS[unit]


def test_write_refusals(tmp_path):
    with pytest.raises(InputError, match="constant station step; this profile is irregular"):
        write_erd(Profile(distance=[0.0, 0.1, 0.3], elevation=[0.0, 0.0, 0.0]), tmp_path / "x.erd")
    x = 0.025 * np.arange(100)
    x[50] += 2e-6  # off the grid by more than 1e-6 m
    with pytest.raises(InputError, match="is 2e-06 m off the grid"):
        write_erd(Profile(distance=x, elevation=np.zeros(100)), tmp_path / "x.erd")
    with pytest.raises(InputError, match="cannot be an ERD channel name"):
        write_erd(Profile(distance=x[:2], elevation=np.zeros(2), tracks=("left wheel",)), tmp_path / "x.erd")
    with pytest.raises(InputError, match="at least 2 samples"):
        write_erd(Profile(distance=[0.0], elevation=[0.0]), tmp_path / "x.erd")
    with pytest.raises(UnitsError, match="unknown elevation unit"):
        write_erd(Profile(distance=x[:2], elevation=np.zeros(2)), tmp_path / "x.erd", units="furlong")
    assert not (tmp_path / "x.erd").exists()


def test_written_header_is_the_erd_layout(tmp_path):
    p = Profile(distance=100.0 + 0.025 * np.arange(3), elevation=[[1e-3, 2e-3], [3e-3, 4e-3], [5e-3, 6e-3]],
                tracks=("left", "right"), name="section A")
    lines = write_erd(p, tmp_path / "p.erd").read_text().splitlines()
    assert lines[0] == "ERDFILEV2.00"
    assert [f.strip() for f in lines[1].split(",")] == ["2", "3", "-1", "1", "5", "0.025", "100.0", ""]
    assert lines[2:7] == ["TITLE   section A", "SHORTNAMleft    right   ", "UNITSNAMmm      mm      ", "XUNITS  m",
                          "END"]
    assert lines[7:] == ["1 2", "3 4", "5 6"]
    assert read_profile(tmp_path / "p.erd").tracks == ("left", "right")
    assert re.fullmatch(r"SHORTNAMelevation r       ", write_erd(
        Profile(distance=[0.0, 1.0], elevation=[[0.0, 0.0], [0.0, 0.0]], tracks=("elevation", "r")),
        tmp_path / "q.erd").read_text().splitlines()[3])
