"""``road ride-number``, ``road straightedge``, ``road profile-index``, ``road faulting`` (session 41): the table the
command writes is the library call's on the file's profile, SI and US; bad input is one line and exit 2; outputs are
checked before any work (no overwrite without --overwrite, never onto an input, two outputs never at one path)."""

import numpy as np
import pandas as pd
import pytest

from longprofile.cli.app import main
from longprofile.io import read_profile, read_report_table
from longprofile.road import (
    faulting_report,
    iso8608_profile,
    profile_index_report,
    ride_number_report,
    straightedge_report,
)


@pytest.fixture(scope="module")
def profile_file(tmp_path_factory):
    """Two tracks at 0.05 m over 250 m, in mm: right an ISO 8608 class B road, left a quarter of another one (a smooth
    concrete slab) with 6 mm faults every 4.5 m from 20 m on."""
    p = iso8608_profile(250.0, 0.05, "B", rng=7, tracks=("left", "right"))
    x, z = p.distance, p.elevation * 1000.0
    z[:, 0] *= 0.25
    z[:, 0] -= 6.0 * np.floor(np.clip(x - 20.0, 0, None) / 4.5 + 1e-9) * (x > 20.0)
    f = tmp_path_factory.mktemp("proval") / "road.csv"
    pd.DataFrame({"distance_m": x, "left_mm": z[:, 0], "right_mm": z[:, 1]}).to_csv(f, index=False)
    return f


CASES = [
    ("ride-number", ride_number_report, [], {}),
    ("ride-number", ride_number_report, ["--units", "us", "--segment", "264"], dict(units="us", segment=264.0)),
    ("straightedge", straightedge_report, ["--threshold", "2"], dict(threshold=2.0)),
    ("straightedge", straightedge_report, ["--units", "us"], dict(units="us")),
    ("profile-index", profile_index_report, ["--blanking-band", "0"], dict(blanking_band=0.0)),
    ("profile-index", profile_index_report, ["--units", "us"], dict(units="us")),
    ("faulting", faulting_report, ["--track", "left"], dict(tracks=["left"])),
    ("faulting", faulting_report, ["--units", "us", "--min-fault", "0.1"], dict(units="us", min_fault=0.1)),
]


@pytest.mark.parametrize(("command", "fn", "args", "kwargs"), CASES, ids=lambda v: " ".join(v) if isinstance(v, list) else None)
def test_the_table_is_the_library_call(profile_file, tmp_path, command, fn, args, kwargs, capsys):
    out = tmp_path / "out.csv"
    assert main(["road", command, str(profile_file), "-o", str(out), *args]) == 0
    err = capsys.readouterr().err
    assert "error" not in err
    frame, meta = read_report_table(out)
    tracks = kwargs.pop("tracks", None)
    want = fn(read_profile(profile_file, tracks=tracks), **kwargs)
    assert len(want.table) > 0
    pd.testing.assert_frame_equal(frame, want.table, check_dtype=False, rtol=1e-12, atol=0)
    assert meta["analysis"] == command and meta["units"] == kwargs.get("units", "si")
    assert want.summary[0] in err  # the summary line printed


def test_faulting_finds_the_faults_in_the_file(profile_file, tmp_path):
    out = tmp_path / "f.parquet"
    assert main(["road", "faulting", str(profile_file), "--track", "left", "-o", str(out)]) == 0
    frame, _ = read_report_table(out)
    near = frame[np.isclose(frame.spacing_m, 4.5, atol=0.06)]
    # each fault is read through the roughness around its joint (0.3 m windows: the step statistic of this slab's
    # roughness alone has a standard deviation of 0.5 mm)
    assert len(near) >= 40 and abs(np.median(near.fault_mm) - 6.0) < 0.5 and np.all(np.abs(near.fault_mm - 6) < 2)


def test_second_tables_and_plot(profile_file, tmp_path):
    args = ["road", "straightedge", str(profile_file), "-o", str(tmp_path / "d.csv"), "--trace",
            str(tmp_path / "t.parquet"), "--plot", str(tmp_path / "s.png")]
    assert main(args) == 0
    trace, _ = read_report_table(tmp_path / "t.parquet")
    assert list(trace.columns) == ["station_m", "deviation_left_mm", "deviation_right_mm"]
    assert (tmp_path / "s.png").stat().st_size > 1000
    assert main(["road", "profile-index", str(profile_file), "--bumps", str(tmp_path / "b.csv"), "-o",
                 str(tmp_path / "pi.csv"), "--plot", str(tmp_path / "pi.png")]) == 0
    bumps, _ = read_report_table(tmp_path / "b.csv")
    assert list(bumps.columns) == ["track", "start_m", "end_m", "peak_m", "height_mm"]
    for command in ("ride-number", "faulting"):
        assert main(["road", command, str(profile_file), "-o", str(tmp_path / f"{command}.csv"), "--plot",
                     str(tmp_path / f"{command}.png")]) == 0
        assert (tmp_path / f"{command}.png").stat().st_size > 1000


def _one_error(capsys):
    err = capsys.readouterr().err
    errors = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "Traceback" not in err, err
    return errors[0]


@pytest.mark.parametrize("command", ["ride-number", "straightedge", "profile-index", "faulting"])
def test_outputs_are_never_replaced_without_overwrite(profile_file, tmp_path, command, capsys):
    out = tmp_path / "out.csv"
    out.write_text("mine\n")
    assert main(["road", command, str(profile_file), "-o", str(out)]) == 2
    assert "exists; pass --overwrite" in _one_error(capsys) and out.read_text() == "mine\n"
    before = profile_file.read_bytes()
    assert main(["road", command, str(profile_file), "-o", str(profile_file), "--overwrite"]) == 2
    assert "is also an input" in _one_error(capsys) and profile_file.read_bytes() == before
    assert main(["road", command, str(profile_file), "-o", str(out), "--overwrite"]) == 0
    assert out.read_text() != "mine\n"


def test_two_outputs_at_one_path_are_refused(profile_file, tmp_path, capsys):
    out = tmp_path / "x.csv"
    assert main(["road", "straightedge", str(profile_file), "-o", str(out), "--trace", str(out)]) == 2
    assert "the same file as the -o output" in _one_error(capsys) and not out.exists()


@pytest.mark.parametrize(("args", "match"), [
    (["straightedge", "--length", "10"], "if you meant 10 ft, write 3.048"),
    (["straightedge", "--units", "us", "--threshold", "3"], "if you meant 3 mm, write 0.1181"),
    (["profile-index", "--blanking-band", "0.2"], "if you meant 0.2 in, write 5.08"),
    (["faulting", "--min-fault", "0.04"], "if you meant 0.04 in, write 1.016"),
    (["ride-number", "--segment", "5000000"], "outside the plausible 10-10000 m"),
    (["profile-index", "--segment", "1000"], "shorter than one 1000 m segment; use a shorter --segment"),
    (["ride-number", "--units", "furlong"], "--units must be si or us"),
])
def test_bad_options_are_one_line(profile_file, tmp_path, args, match, capsys):
    out = tmp_path / "o.csv"
    assert main(["road", args[0], str(profile_file), *args[1:], "-o", str(out)]) == 2
    assert match in _one_error(capsys) and not out.exists()


def test_missing_elevations_are_one_line(profile_file, tmp_path, capsys):
    frame = pd.read_csv(profile_file)
    frame.loc[2000, "right_mm"] = np.nan
    f = tmp_path / "nan.csv"
    frame.to_csv(f, index=False)
    for command in ("ride-number", "straightedge", "profile-index", "faulting"):
        assert main(["road", command, str(f), "-o", str(tmp_path / "o.csv")]) == 2
        line = _one_error(capsys)
        assert "track 'right' has a missing (NaN) elevation at station 100.000 m" in line and "cut the profile" in line
    assert not (tmp_path / "o.csv").exists()
