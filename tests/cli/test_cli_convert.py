"""``longprofile road convert`` and ``road reconstruct -o profile.erd``: profiles between CSV, Parquet and ERD."""

import numpy as np
import pandas as pd
import pytest

from longprofile.cli.app import main
from longprofile.io import read_erd, read_profile, write_profile
from longprofile.road import Profile, iri, iso8608_profile


def _err(capsys):
    return " ".join(capsys.readouterr().err.split())


@pytest.fixture(scope="module")
def reconstructed(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    assert main(["road", "simulate", "-o", str(d / "rec.csv"), "--length", "150", "--seed", "2"]) == 0
    assert main(["road", "reconstruct", str(d / "rec.csv"), "-o", str(d / "p.csv")]) == 0
    assert main(["road", "reconstruct", str(d / "rec.csv"), "-o", str(d / "p.erd")]) == 0
    return d


def test_reconstruct_writes_the_elevation_track_as_erd(reconstructed):
    table = pd.read_csv(reconstructed / "p.csv", comment="#")
    erd = read_erd(reconstructed / "p.erd")
    assert erd.tracks == ("elevation",)
    header = (reconstructed / "p.erd").read_text().splitlines()[:7]
    assert header[4].rstrip() == "UNITSNAMmm" and header[5] == "XUNITS  m"
    np.testing.assert_allclose(erd.distance, table["distance_m"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(erd.elevation[:, 0], table["elevation_m"], rtol=0, atol=5e-8 + 1e-15)
    # the IRI of the ERD is that of the CSV to the printed precision
    a = iri(erd, segment_length=50.0)
    b = iri(read_profile(reconstructed / "p.csv", tracks="elevation"), segment_length=50.0)
    np.testing.assert_allclose(a.iri, b.iri, rtol=1e-4)


def test_convert_round_trips_between_formats(tmp_path, capsys):
    p = iso8608_profile(60.0, 0.025, "C", rng=3, tracks=("left", "right"))
    src = write_profile(Profile(p.distance + 1000.0, p.elevation, tracks=p.tracks, name="A"), tmp_path / "a.csv",
                        units="mm")
    for a, b in [("a.csv", "b.erd"), ("b.erd", "c.parquet"), ("c.parquet", "d.csv"), ("d.csv", "e.erd")]:
        assert main(["road", "convert", str(tmp_path / a), str(tmp_path / b)]) == 0, _err(capsys)
    out = _err(capsys)
    assert "converted 2401 samples x 2 track(s) (left, right; stations 1000 .. 1060 m, dx 0.025 m) in mm" in out
    for name in ("b.erd", "c.parquet", "d.csv", "e.erd"):
        q = read_profile(tmp_path / name)
        assert q.tracks == ("left", "right")
        np.testing.assert_allclose(q.distance, p.distance + 1000.0, rtol=0, atol=1e-9)
        np.testing.assert_allclose(q.elevation, p.elevation, rtol=0, atol=5e-8 + 1e-15)
    # CSV -> Parquet -> CSV after the ERD is exact
    d, b = read_profile(tmp_path / "d.csv"), read_profile(tmp_path / "b.erd")
    np.testing.assert_array_equal(d.elevation, b.elevation)
    assert pd.read_csv(src).columns.tolist() == ["distance_m", "left_mm", "right_mm"]


@pytest.mark.parametrize("tracks", [("LEFT", "RIGHT"), ("LEFTWHEE", "RIGHTWHE", "c"), ("left_wheel_path", "R"),
                                    ("Lw", "LEFTWHEE", "centre_line_1")])
def test_convert_to_erd_and_back_keeps_the_track_names(tmp_path, capsys, tracks):
    """The writer's SHORTNAM (8-character fields, or blank-separated long names) reads back as the same names
    whatever their lengths (names are never cut at column 8 nor glued)."""
    p = iso8608_profile(20.0, 0.25, "C", rng=1, tracks=tracks)
    write_profile(p, tmp_path / "x.csv", units="mm")
    assert main(["road", "convert", str(tmp_path / "x.csv"), str(tmp_path / "x.erd")]) == 0, _err(capsys)
    assert main(["road", "convert", str(tmp_path / "x.erd"), str(tmp_path / "y.csv")]) == 0, _err(capsys)
    q = read_profile(tmp_path / "y.csv")
    assert q.tracks == tracks
    np.testing.assert_allclose(q.elevation, p.elevation, rtol=0, atol=5e-8 + 1e-15)


def test_convert_units_tracks_and_plot(tmp_path, capsys):
    f = tmp_path / "raw.csv"
    f.write_text("distance_m,left,right\n0,1.0,2.0\n0.5,1.5,2.5\n1.0,2.0,3.0\n")
    assert main(["road", "convert", str(f), str(tmp_path / "x.erd")]) == 2
    err = _err(capsys)
    assert err.startswith("error:") and err.count("error:") == 1 and "does not give its elevation unit" in err
    assert not (tmp_path / "x.erd").exists()
    assert main(["road", "convert", str(f), str(tmp_path / "x.erd"), "--elevation-unit", "in", "--units", "mm",
                 "--track", "right", "--plot", str(tmp_path / "x.png")]) == 0, _err(capsys)
    q = read_erd(tmp_path / "x.erd")
    assert q.tracks == ("right",)
    np.testing.assert_allclose(q.elevation[:, 0], np.array([2.0, 2.5, 3.0]) * 0.0254, rtol=0, atol=5e-8)
    assert "UNITSNAMmm" in (tmp_path / "x.erd").read_text()
    assert (tmp_path / "x.png").stat().st_size > 1000
    assert main(["road", "convert", str(tmp_path / "x.erd"), str(tmp_path / "y.csv"), "--units", "in"]) == 0
    assert pd.read_csv(tmp_path / "y.csv").columns.tolist() == ["distance_m", "right_in"]
    assert main(["road", "convert", str(f), str(tmp_path / "w.csv"), "--input-units", "mm"]) == 0  # alias
    np.testing.assert_allclose(read_profile(tmp_path / "w.csv").elevation[0], [1e-3, 2e-3])
    assert main(["road", "convert", str(f), str(tmp_path / "z.csv"), "--units", "furlong"]) == 2
    assert "unknown elevation unit 'furlong'" in _err(capsys)


def test_convert_refuses_irregular_stations_to_erd_and_writes_nothing(tmp_path, capsys):
    f = tmp_path / "irr.csv"
    f.write_text("distance_m,left_mm\n0,1\n0.25,2\n0.6,3\n")
    assert main(["road", "convert", str(f), str(tmp_path / "irr.erd")]) == 2
    err = _err(capsys)
    assert err.startswith("error:") and "irregular" in err and "Write it as CSV or Parquet" in err
    assert not (tmp_path / "irr.erd").exists()
    assert main(["road", "convert", str(f), str(f)]) == 2
    assert "is also an input" in _err(capsys)


def test_convert_of_a_reconstruct_output_takes_its_profile_track(reconstructed, tmp_path, capsys):
    assert main(["road", "convert", str(reconstructed / "p.csv"), str(tmp_path / "p.erd")]) == 0
    err = _err(capsys)
    assert "is a `road reconstruct` output: converting its profile track 'elevation'" in err
    assert read_erd(tmp_path / "p.erd").tracks == ("elevation",)


def test_convert_says_the_std_is_not_written_to_erd(tmp_path, capsys):
    f = tmp_path / "s.csv"
    f.write_text("distance_m,left_mm,left_std_mm\n0,1,0.1\n0.5,2,0.1\n1.0,3,0.1\n")
    assert main(["road", "convert", str(f), str(tmp_path / "s.erd")]) == 0
    assert "standard deviation columns are not written to ERD" in _err(capsys)
    assert main(["road", "convert", str(f), str(tmp_path / "s.parquet")]) == 0
    np.testing.assert_allclose(read_profile(tmp_path / "s.parquet").std[:, 0], 1e-4)
