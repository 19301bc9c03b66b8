"""``road iri``, ``road report`` and ``batch iri`` on profiles with gaps: refused by default naming ``--gaps restart``;
with it, the IRI over the measured parts, one warning line, the valid length per segment (exit codes, one line)."""

import re

import numpy as np
import pandas as pd
import pytest

from longprofile.batch import EXIT_SOME_FAILED, read_results
from longprofile.cli.app import main
from longprofile.io import read_report_table
from longprofile.road import Profile, iri_report, iso8608_profile


def _lines(text, word):
    return [ln for ln in text.splitlines() if ln.startswith(word)]


@pytest.fixture(scope="module")
def gapped(tmp_path_factory):
    """Two tracks at 0.05 m over 600 m: left missing 100-105 m, right 300-330 m (NaN cells), as CSV in mm."""
    p = iso8608_profile(600.0, 0.05, "C", rng=2, tracks=("left", "right"))
    x, z = p.distance, p.elevation.copy() * 1000.0
    z[(x > 100.0) & (x < 105.0), 0] = np.nan
    z[(x > 300.0) & (x < 330.0), 1] = np.nan
    folder = tmp_path_factory.mktemp("gaps")
    f = folder / "gapped.csv"
    pd.DataFrame({"distance_m": x, "left_mm": z[:, 0], "right_mm": z[:, 1]}).to_csv(f, index=False)
    return f, Profile(distance=x, elevation=z / 1000.0, tracks=("left", "right"))


def test_default_refuses_in_one_line_naming_the_option(gapped, tmp_path, capsys):
    f, _ = gapped
    for args in (["road", "iri", str(f)], ["road", "report", str(f), "-o", str(tmp_path / "rep")]):
        assert main(args) == 2
        err = capsys.readouterr().err
        errors = _lines(err, "error:")
        assert len(errors) == 1 and "Traceback" not in err
        assert "station 100.050 m" in errors[0] and "--gaps restart" in errors[0]
    assert not (tmp_path / "rep").exists()


def test_road_iri_restart_one_warning_and_valid_lengths(gapped, tmp_path, capsys):
    f, prof = gapped
    out = tmp_path / "iri.csv"
    assert main(["road", "iri", str(f), "--gaps", "restart", "--segment", "50", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    warnings = _lines(err, "warning:")
    assert len(warnings) == 1 and err.count("warning:") == 1, err
    assert "2 gap(s) of missing elevations (track left, right)" in warnings[0]
    assert "2 of 12 segment(s) affected, 1 without IRI" in warnings[0]
    frame, meta = read_report_table(out)
    want = iri_report(prof, interval=50.0, gaps="restart")
    np.testing.assert_allclose(frame["iri_left_m_per_km"], want.iri[:, 0], rtol=1e-9)
    assert np.isnan(frame["iri_right_m_per_km"][6]) and "right 39.8%" in frame["note"][6]  # 300-350 m
    np.testing.assert_allclose(frame["valid_length_left_m"][2], 150.0 - 105.1, atol=1e-9)  # 0.1 m: moving average
    assert meta["gap_count"] == 2 and meta["gaps"] == "restart" and meta["min_valid"] == 0.8


def test_min_valid_and_bad_options(gapped, tmp_path, capsys):
    f, _ = gapped
    out = tmp_path / "iri.csv"
    assert main(["road", "iri", str(f), "--gaps", "restart", "--segment", "50", "--min-valid", "0.3",
                 "-o", str(out)]) == 0
    frame, _ = read_report_table(out)
    assert np.isfinite(frame["iri_right_m_per_km"][6])  # 40 % measured >= 30 %
    capsys.readouterr()
    for args, what in ((["--gaps", "restart", "--min-valid", "80"], "min_valid"),
                       (["--gaps", "interpolate"], "gaps must be")):
        assert main(["road", "iri", str(f), *args]) == 2
        err = capsys.readouterr().err
        assert len(_lines(err, "error:")) == 1 and what in err


def test_road_report_states_the_gaps(gapped, tmp_path, capsys):
    f, _ = gapped
    out = tmp_path / "rep"
    assert main(["road", "report", str(f), "--gaps", "restart", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert err.count("warning:") == 1 and "2 gap(s) of missing elevations" in err
    page = (out / "index.html").read_text()
    assert "Gaps: 2 gap(s) of missing elevations" in page and "restarted after each gap" in page
    seg = pd.read_csv(out / "iri_segments.csv", comment="#")
    assert {"valid_length_left_m", "valid_length_right_m", "valid_fraction", "note"} <= set(seg.columns)
    assert (out / "psd.csv").exists() and not (out / "waveband_energy.csv").exists()


def test_held_values_and_missing_codes_keep_their_checks(gapped, tmp_path, capsys):
    f, _ = gapped
    d = pd.read_csv(f)
    d.loc[(d.distance_m > 400) & (d.distance_m < 403.5), "left_mm"] = 12.0  # a held value beside the gaps
    held = tmp_path / "held.csv"
    d.to_csv(held, index=False)
    assert main(["road", "iri", str(held), "--gaps", "restart", "-o", str(tmp_path / "h.csv")]) == 0
    err = capsys.readouterr().err
    assert err.count("warning:") == 2 and "holds one exact elevation" in err and "gap(s) of missing" in err
    d.loc[1000, "left_mm"] = -9999.0  # a logger's code: refused at read, gaps or not
    code = tmp_path / "code.csv"
    d.to_csv(code, index=False)
    assert main(["road", "iri", str(code), "--gaps", "restart"]) == 2
    err = capsys.readouterr().err
    assert len(_lines(err, "error:")) == 1 and "-9999" in err and "--gaps restart" in err


def test_batch_iri_with_and_without_restart(gapped, tmp_path, capsys):
    f, _ = gapped
    assert main(["batch", "iri", str(f), "-o", str(tmp_path / "a"), "--scheduler", "serial"]) == EXIT_SOME_FAILED
    assert "--gaps restart" in capsys.readouterr().err
    assert main(["batch", "iri", str(f), "-o", str(tmp_path / "b"), "--scheduler", "serial", "--gaps", "restart",
                 "--segment", "50"]) == 0
    res = read_results(tmp_path / "b")
    assert {"valid_length_left_m", "note"} <= set(res.segments.columns) and len(res.segments) == 12
    assert "2 gap(s) of missing elevations" in res.manifest["warning"].iloc[0]


@pytest.fixture(scope="module")
def dead(tmp_path_factory):
    """The network probe's file: two tracks at 0.1 m over 500 m, the right laser dead (every elevation empty), and a
    healthy two-track file beside it, as CSV in mm."""
    folder = tmp_path_factory.mktemp("dead")
    files = []
    for name, seed, kill in (("dead", 4, True), ("good", 5, False)):
        p = iso8608_profile(500.0, 0.1, "C", rng=seed, tracks=("left", "right"))
        z = p.elevation * 1000.0
        pd.DataFrame({"distance_m": p.distance, "left_mm": z[:, 0],
                      "right_mm": np.nan if kill else z[:, 1]}).to_csv(folder / f"{name}.csv", index=False)
        files.append(folder / f"{name}.csv")
    return files


@pytest.mark.parametrize("mode", [[], ["--mode", "continuous"], ["--mode", "overlapping", "--window", "50"],
                                  ["--units", "us"]])
def test_road_iri_reports_a_dead_track_in_one_warning_and_keeps_the_other(dead, mode, tmp_path, capsys):
    f = dead[0]
    out, alone = tmp_path / "iri.csv", tmp_path / "left.csv"
    assert main(["road", "iri", str(f), "--gaps", "restart", *mode, "-o", str(out)]) == 0
    cap = capsys.readouterr()
    warnings = _lines(cap.err, "warning:")
    assert len(warnings) == 1 and cap.err.count("warning:") == 1, cap.err
    assert warnings[0].startswith("warning: track(s) 'right' have no measured run of at least the 11 m lead-in")
    assert "check the sensor" in warnings[0] and "(--track left)" in warnings[0]
    assert "right none; MRI none, HRI none" in cap.err
    assert main(["road", "iri", str(f), "--gaps", "restart", *mode, "--track", "left", "-o", str(alone)]) == 0
    frame, meta = read_report_table(out)
    own, own_meta = read_report_table(alone)
    for c in own.columns:  # the left track's rows: those of the left track processed alone, as written
        if c not in ("valid_fraction", "note"):
            pd.testing.assert_series_equal(frame[c], own[c])
    unit = "in_per_mi" if "us" in mode else "m_per_km"
    assert frame[[f"iri_right_{unit}", f"mri_{unit}", f"hri_{unit}"]].isna().all().all()
    assert (frame["valid_fraction"] == 0).all() and frame["note"].str.contains("right 0.0%").all()
    assert meta["section_iri_left"] == own_meta["section_iri_left"] and meta["gap_dead_tracks"] == "right"


def test_a_file_without_any_usable_track_is_refused_in_one_line(dead, tmp_path, capsys):
    for args in (["road", "iri", str(dead[0]), "--gaps", "restart", "--track", "right"],
                 ["road", "report", str(dead[0]), "--gaps", "restart", "--track", "right", "-o", str(tmp_path / "r")]):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert len(_lines(err, "error:")) == 1 and "Traceback" not in err
        assert "track 'right' has no measured run of at least the 11 m lead-in" in err
    assert main(["road", "iri", str(dead[0])]) == 2  # the default is unchanged: a missing elevation is refused
    err = capsys.readouterr().err
    assert len(_lines(err, "error:")) == 1 and "track 'right' has a missing (NaN) elevation at station 0.000 m" in err


def test_road_report_with_a_dead_track(dead, tmp_path, capsys):
    out = tmp_path / "rep"
    assert main(["road", "report", str(dead[0]), "--gaps", "restart", "-o", str(out)]) == 0
    cap = capsys.readouterr()
    assert cap.err.count("warning:") == 1 and "track(s) 'right' have no measured run" in cap.err
    page = (out / "index.html").read_text()
    assert "IRI right<b>— (no IRI)</b>" in page and "MRI<b>— (no IRI)</b>" in page
    assert not re.search(r"\bnan m/km", page, flags=re.IGNORECASE)  # it read "IRI right nan m/km"
    assert pd.read_csv(out / "iso8608.csv")["track"].tolist() == ["left"]
    assert "psd_left_m3" in pd.read_csv(out / "psd.csv").columns


def test_batch_iri_counts_a_file_with_a_dead_track_as_ok_with_its_warning(dead, tmp_path, capsys):
    assert main(["batch", "iri", *map(str, dead), "-o", str(tmp_path / "r"), "--scheduler", "serial",
                 "--gaps", "restart"]) == 0
    res = read_results(tmp_path / "r")
    m = res.manifest.set_index("route")
    assert (m["status"] == "ok").all()
    assert m.loc["dead", "warning"].startswith("track(s) 'right' have no measured run") and m.loc["good", "warning"] == ""
    seg = res.segments[res.segments.route == "dead"]
    assert seg["iri_left_m_per_km"].notna().all() and seg["mri_m_per_km"].isna().all()
