"""Road commands on a pavement engineer's files (session 36 probe): a track named twice in ``--track``, ``road
convert --spacing``, and the one-line refusals of the profile readers."""

import numpy as np
import pytest

from longprofile.cli.app import main
from longprofile.io import read_erd, read_profile, write_profile
from longprofile.road import Profile, iri, iso8608_profile, resample_profile


def _err(capsys):
    return " ".join(capsys.readouterr().err.split())


@pytest.fixture(scope="module")
def profile_csv(tmp_path_factory):
    p = iso8608_profile(120.0, 0.025, "C", rng=4, tracks=("left", "right"))
    return write_profile(p, tmp_path_factory.mktemp("pave") / "p.csv", units="mm")


@pytest.mark.parametrize("command", [
    ["road", "iri", "{f}", "--track", "left,left"],
    ["road", "report", "{f}", "-o", "{d}/rep", "--track", "left, Left"],
    ["road", "acceptance", "{f}", "-o", "{d}/acc", "--track", "right,left,right"],
    ["road", "compare", "{f}", "{f}", "-o", "{d}/cmp", "--track", "left,left"],
    ["road", "convert", "{f}", "{d}/c.erd", "--track", "left,left"],
    ["batch", "iri", "{f}", "-o", "{d}/batch", "--track", "left,left"],
])
def test_a_track_named_twice_is_refused_by_every_road_command(profile_csv, tmp_path, capsys, command):
    args = [a.format(f=profile_csv, d=tmp_path) for a in command]
    assert main(args) == 2
    err = _err(capsys)
    assert err.count("error:") == 1  # `road report` draws its progress line first
    assert "twice" in err and "give each track once" in err
    assert not any(tmp_path.iterdir())


def test_convert_spacing_resamples_irregular_stations_for_erd(tmp_path, capsys):
    p = iso8608_profile(60.0, 0.025, "C", rng=5, tracks=("left", "right"))
    rounded = Profile(np.round(p.distance + 0.0049, 2), p.elevation, tracks=p.tracks)  # stations written to 1 cm
    src = write_profile(rounded, tmp_path / "r.csv", units="mm")
    assert main(["road", "convert", str(src), str(tmp_path / "r.erd")]) == 2
    err = _err(capsys)
    assert err.count("error:") == 1 and "irregular" in err and "road convert --spacing" in err
    assert main(["road", "convert", str(src), str(tmp_path / "r.erd"), "--spacing", "0.025"]) == 0, _err(capsys)
    assert "resampled" in _err(capsys)
    erd = read_erd(tmp_path / "r.erd")
    expected = resample_profile(read_profile(src), 0.025)
    assert erd.spacing == pytest.approx(0.025)
    np.testing.assert_allclose(erd.distance, expected.distance, rtol=0, atol=1e-9)
    np.testing.assert_allclose(erd.elevation, expected.elevation, rtol=0, atol=5e-8 + 1e-15)
    np.testing.assert_allclose(iri(erd, segment_length=50.0).iri, iri(rounded, segment_length=50.0).iri, rtol=0.01)
    assert main(["road", "convert", str(src), str(tmp_path / "s.csv"), "--spacing", "-1"]) == 2
    assert _err(capsys).count("error:") == 1


@pytest.mark.parametrize("content,match", [
    (b"Project: I-95 resurfacing\ndistance_m,left_mm,right_mm\n0,1,2\n0.025,1,2\n",
     "line 1 looks like a title, not a header ('Project: I-95 resurfacing'): the column names seem to be on line 2"),
    # stations decreasing throughout are read since session 40 (a southbound lane: tests/cli/test_profile_file_probe.py);
    # a step back among increasing ones is still refused at its line
    (b"distance_m,left_mm\n0.05,1\n0.075,2\n0.06,3\n", "line 4: station 0.06 is not greater than the previous one"),
])
def test_csv_refusals_are_one_line(tmp_path, capsys, content, match):
    f = tmp_path / "x.csv"
    f.write_bytes(content)
    assert main(["road", "iri", str(f)]) == 2
    err = _err(capsys)
    assert err.startswith("error:") and err.count("error:") == 1 and match in err


def test_erd_from_proval_style_writers_is_read(tmp_path, capsys):
    text = ("ERDFILEV2.00\n2, 5, -1, 1, 5, 0.1, 0.0,\nTITLE   t\nSHORTNAMleft    right\nUNITSNAMInches  Inches\n"
            "XUNITS  Feet\nEND\n" + "".join(f"{0.01 * k} {-0.01 * k}\n" for k in range(5)) + "End\n\n")
    f = tmp_path / "p.erd"
    f.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert main(["road", "convert", str(f), str(tmp_path / "p.csv")]) == 0, _err(capsys)
    p = read_profile(tmp_path / "p.csv")
    np.testing.assert_allclose(p.distance, np.arange(5) * 0.1 * 0.3048, rtol=0, atol=1e-12)
    np.testing.assert_allclose(p.elevation[:, 0], np.arange(5) * 0.01 * 0.0254, rtol=0, atol=1e-15)
