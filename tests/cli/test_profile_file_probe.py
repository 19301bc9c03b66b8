"""A pavement engineer's profile files through the CLI (session 40 probe: US headers, US ERD, a southbound lane)."""

import numpy as np

from longprofile.cli.app import main
from longprofile.io import read_erd, read_profile, write_profile
from longprofile.road import Profile, iso8608_profile


def _err(capsys) -> str:
    captured = capsys.readouterr()
    return captured.out + captured.err


def _road(length=400.0):
    p = iso8608_profile(length, 0.025, road_class="B", rng=np.random.default_rng(3))
    return Profile(distance=p.distance, elevation=np.column_stack([p.elevation[:, 0]] * 2), tracks=("left", "right"))


def test_inches_under_an_mm_option_are_refused_not_read_ten_times_too_small(tmp_path, capsys):
    """The probe: 'LWP (inches)' with --elevation-unit mm (the old hint's way) gave 0.356 m/km on a ~9 m/km road."""
    p = _road()
    f = tmp_path / "us.csv"
    f.write_text("Distance (ft),LWP (inches),RWP (inches)\n" + "".join(
        f"{float(x) / 0.3048!r},{float(z) / 0.0254!r},{float(z) / 0.0254!r}\n" for x, z in zip(p.distance, p.elevation[:, 0])))
    assert main(["road", "iri", str(f), "--elevation-unit", "mm"]) == 2
    err = _err(capsys)
    assert "column 'LWP (inches)' is in 'in' by its header but the unit 'mm' was given" in err and ")_mm" not in err
    assert main(["road", "iri", str(f), "-o", str(tmp_path / "us_iri.csv")]) == 0
    assert main(["road", "iri", str(tmp_path / "si.csv" if write_profile(p, tmp_path / "si.csv") else ""),
                 "-o", str(tmp_path / "si_iri.csv")]) == 0
    import pandas as pd

    us = pd.read_csv(tmp_path / "us_iri.csv", comment="#")
    si = pd.read_csv(tmp_path / "si_iri.csv", comment="#")
    np.testing.assert_allclose(us.iloc[:, 2:].to_numpy(), si.iloc[:, 2:].to_numpy(), rtol=1e-6)


def test_convert_writes_a_us_erd_file_as_proval_does(tmp_path, capsys):
    p = _road(100.0)
    src = tmp_path / "p.csv"
    write_profile(Profile(p.distance, p.elevation, tracks=("Left Elevation", "Right Elevation")), src, units="in")
    out = tmp_path / "us.erd"
    assert main(["road", "convert", str(src), str(out), "--units", "in", "--distance-unit", "ft"]) == 2
    assert "--rename 'Left Elevation=left'" in _err(capsys)
    assert main(["road", "convert", str(src), str(out), "--units", "in", "--distance-unit", "ft", "--rename",
                 "Left Elevation=left,Right Elevation=right"]) == 0, _err(capsys)
    head = out.read_text().split("END\n")[0]
    assert "UNITSNAMinches  inches" in head and "XUNITS  feet" in head
    back = read_erd(out)
    np.testing.assert_allclose(back.distance, p.distance, rtol=0, atol=1e-9)
    np.testing.assert_allclose(back.elevation, p.elevation, rtol=0, atol=5.0001e-8)


def test_a_southbound_run_is_read_in_the_direction_of_travel_with_a_warning(tmp_path, capsys):
    p = _road()
    f = tmp_path / "sb.csv"
    stations = 5000.0 - p.distance  # stations counting down as the lane is driven
    f.write_text("distance_m,left_mm,right_mm\n" + "".join(
        f"{float(x)!r},{float(z) * 1e3!r},{float(z) * 1e3!r}\n" for x, z in zip(stations, p.elevation[:, 0])))
    assert main(["road", "iri", str(f), "-o", str(tmp_path / "sb_iri.csv")]) == 0
    err = _err(capsys)
    assert "warning: " in err and "decrease (5000 .. 4600)" in err and "distance travelled from station 5000" in err
    assert read_profile(f).distance[-1] == stations[0] - stations[-1]
