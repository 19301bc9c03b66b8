"""``longprofile road iri`` as agencies report it: --mode, --start, --units si|us, --moving-average, metadata in
the CSV/Parquet outputs, the --units/--elevation-unit transition, and bad input (one red line, exit 2)."""

import json

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from longprofile.cli.app import app, main
from longprofile.io import read_profile, read_report_table, write_profile
from longprofile.road import iri_report, iso8608_profile

FT = 0.3048


@pytest.fixture(scope="module")
def section(tmp_path_factory):
    p = iso8608_profile(300.0, 0.05, "B", rng=21, tracks=("left", "right"))
    f = write_profile(p, tmp_path_factory.mktemp("iri_rep") / "section.csv", units="mm")
    return f, read_profile(f)


def _run(args):
    return CliRunner().invoke(app, args, catch_exceptions=False)


def test_fixed_with_start_writes_metadata_in_csv(tmp_path, section):
    f, prof = section
    out = tmp_path / "iri.csv"
    res = _run(["road", "iri", str(f), "--start", "12.5", "--segment", "50", "-o", str(out)])
    assert res.exit_code == 0, res.output
    want = iri_report(prof, interval=50.0, start=12.5)
    lines = out.read_text().splitlines()
    assert lines[0].startswith("# ") and any(ln.startswith("start_m,end_m,iri_left_m_per_km") for ln in lines)
    frame, meta = read_report_table(out)
    np.testing.assert_allclose(frame["start_m"], 12.5 + 50.0 * np.arange(5))
    np.testing.assert_allclose(frame["iri_left_m_per_km"], want.iri[:, 0], rtol=1e-12)
    np.testing.assert_allclose(frame["hri_m_per_km"], want.hri, rtol=1e-12)
    assert meta["mode"] == "fixed" and meta["start"] == 12.5 and meta["interval"] == 50.0
    assert meta["moving_average_applied"] is True and "k = 5 samples" in meta["moving_average_reason"]
    # the printed summary names the moving-average decision
    assert "moving average: applied" in res.output and "k = 5 samples" in res.output


def test_continuous_us_units_to_parquet_with_plot(tmp_path, section):
    f, prof = section
    out, png = tmp_path / "c.parquet", tmp_path / "c.png"
    res = _run(["road", "iri", str(f), "--mode", "continuous", "--window", "25", "--step", "10", "--units", "us",
                "-o", str(out), "--plot", str(png)])
    assert res.exit_code == 0, res.output
    meta = json.loads(pq.read_schema(out).metadata[b"longprofile"])
    assert meta["mode"] == "continuous" and meta["units"] == "us" and meta["iri_unit"] == "in/mi"
    assert meta["window"] == 25.0 and meta["step"] == 10.0 and meta["length_unit"] == "ft"
    df = pd.read_parquet(out)
    assert list(df.columns)[:3] == ["start_ft", "end_ft", "iri_left_in_per_mi"]
    want = iri_report(prof, mode="continuous", window=25.0, step=10.0, units="us")
    np.testing.assert_allclose(df["iri_right_in_per_mi"], want.iri[:, 1], rtol=1e-12)
    np.testing.assert_allclose(np.diff(df["start_ft"]), 10.0)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "section IRI (in/mi)" in res.output


def test_us_profile_in_feet_default_tenth_mile(tmp_path):
    p = iso8608_profile(500.0, 0.1, "C", rng=5)
    f = tmp_path / "ft.csv"
    frame = pd.DataFrame({"distance_ft": 2000.0 + p.distance / FT, "left_in": p.elevation[:, 0] / 0.0254})
    frame.to_csv(f, index=False)
    out = tmp_path / "us.csv"
    res = _run(["road", "iri", str(f), "--units", "us", "-o", str(out)])
    assert res.exit_code == 0, res.output
    frame, meta = read_report_table(out)
    assert meta["interval"] == 528.0  # the US default: 0.1 mi
    np.testing.assert_allclose(frame["start_ft"], 2000.0 + 528.0 * np.arange(3), atol=1e-9)
    si = iri_report(read_profile(f), interval=528 * FT)
    np.testing.assert_allclose(frame["iri_left_in_per_mi"], si.iri[:, 0] * 63.36, rtol=1e-9)


def test_overlapping_and_moving_average_option(tmp_path, section):
    f, prof = section
    out = tmp_path / "o.csv"
    res = _run(["road", "iri", str(f), "--mode", "overlapping", "--window", "100", "--step", "40",
                "--moving-average", "off", "-o", str(out)])
    assert res.exit_code == 0, res.output
    frame, meta = read_report_table(out)
    assert meta["moving_average_applied"] is False and "forced off" in meta["moving_average_reason"]
    np.testing.assert_allclose(frame["start_m"], [0.0, 40.0, 80.0, 120.0, 160.0, 200.0])
    want = iri_report(prof, mode="overlapping", window=100.0, step=40.0, moving_average="off")
    np.testing.assert_allclose(frame["mri_m_per_km"], want.mri, rtol=1e-12)
    assert "moving average: not applied (forced off" in res.output


def test_stdout_csv_carries_the_metadata(section):
    f, _ = section
    res = _run(["road", "iri", str(f), "--track", "left"])
    assert res.exit_code == 0, res.output
    assert "# mode: \"fixed\"" in res.stdout and "# moving_average_applied: true" in res.stdout
    rows = [ln for ln in res.stdout.splitlines() if ln and ln[0].isdigit()]
    assert len(rows) == 3


def test_elevation_unit_and_deprecated_units(tmp_path, capsys):
    f = tmp_path / "nounits.csv"
    p = iso8608_profile(60.0, 0.25, "C", rng=1)
    pd.DataFrame({"distance_m": p.distance, "left": p.elevation[:, 0] * 1000}).to_csv(f, index=False)
    new, old = tmp_path / "new.csv", tmp_path / "old.csv"
    assert main(["road", "iri", str(f), "--elevation-unit", "mm", "--segment", "20", "-o", str(new)]) == 0
    assert "deprecated" not in capsys.readouterr().err
    assert main(["road", "iri", str(f), "--units", "mm", "--segment", "20", "-o", str(old)]) == 0
    err = capsys.readouterr().err
    assert "--units mm as the elevation unit is deprecated; use --elevation-unit mm" in err
    pd.testing.assert_frame_equal(read_report_table(new)[0], read_report_table(old)[0])
    assert main(["road", "iri", str(f), "--units", "mm", "--elevation-unit", "m"]) == 2
    assert "contradicts --elevation-unit" in capsys.readouterr().err
    # road report: the same rename
    assert main(["road", "report", str(f), "--elevation-unit", "mm", "--segment", "20", "-o",
                 str(tmp_path / "rep")]) == 0
    assert (tmp_path / "rep" / "index.html").exists()
    capsys.readouterr()
    assert main(["road", "report", str(f), "--units", "us", "-o", str(tmp_path / "rep2")]) == 2
    assert "SI units only" in capsys.readouterr().err


@pytest.mark.parametrize("args,message", [
    (["--mode", "continuous", "--window", "1000"], "window (1000 m) is longer than the profile"),
    (["--mode", "continuous", "--step", "0"], "step (m) must be finite and > 0"),
    (["--mode", "overlapping", "--window", "50", "--step", "-2"], "step (m) must be finite and > 0"),
    (["--mode", "overlapping", "--window", "50", "--step", "60"], "overlapping windows need step < window"),
    (["--start", "-10"], "start must lie within the profile (0.000 .. 300.000 m)"),
    (["--start", "2000", "--units", "us"], "start must lie within the profile (0.000 .. 984.252 ft)"),
    (["--mode", "sliding"], "unknown mode 'sliding'"),
    (["--units", "metric"], "--units must be si or us"),
    (["--moving-average", "yes"], "moving_average must be 'auto', 'on' or 'off'"),
    (["--segment", "-5"], "interval (m) must be finite and > 0"),
])
def test_bad_input_one_line_exit_2(tmp_path, capsys, section, args, message):
    f, _ = section
    out = tmp_path / "never.csv"
    assert main(["road", "iri", str(f), *args, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert len([ln for ln in err.splitlines() if ln.strip().startswith("error:")]) == 1
    assert not out.exists()


def test_output_format_checked_before_any_work(tmp_path, capsys):
    # the input does not even exist: the unwritable format is reported first, before reading anything
    assert main(["road", "iri", str(tmp_path / "missing.csv"), "-o", str(tmp_path / "iri.xlsx")]) == 2
    err = capsys.readouterr().err
    assert "unknown format '.xlsx'; use one of .csv, .parquet" in err and "no such file" not in err
