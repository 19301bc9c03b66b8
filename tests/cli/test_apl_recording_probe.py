"""`road reconstruct`, `road convert --spacing` and `road iri` on a pavement engineer's APL trailer files (session 39
probe): rows dropped from the grid, a -9999 dropout, metres under a mm label, a raw APL channel in an ERD file."""

import numpy as np
import pandas as pd
import pytest

from longprofile.cli.app import main


def _err(capsys):
    return " ".join(capsys.readouterr().err.split())


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    folder = tmp_path_factory.mktemp("apl")
    rec = folder / "rec.csv"
    assert main(["road", "simulate", "-o", str(rec), "--length", "300", "--seed", "3"]) == 0
    return rec


def _elevation(path):
    return pd.read_csv(path, comment="#")


def test_rows_dropped_from_the_grid_are_bridged_as_empty_cells_are_with_a_warning(recording, tmp_path, capsys):
    """The same dropout as removed rows or as empty cells gives the same profile and std_m (before: refused as
    "not evenly spaced", and `road convert --spacing` interpolated across it: 9.7 mm error, std_m 0.45 mm)."""
    d = pd.read_csv(recording)
    gone = (d.distance_m >= 120) & (d.distance_m < 122)
    cut, blank = tmp_path / "cut.csv", tmp_path / "blank.csv"
    d[~gone].to_csv(cut, index=False)
    d.assign(apl_m=d.apl_m.where(~gone)).to_csv(blank, index=False)
    capsys.readouterr()
    assert main(["road", "reconstruct", str(cut), "-o", str(tmp_path / "a.csv")]) == 0
    got = capsys.readouterr()
    out = " ".join((got.out + got.err).split())
    assert "warning: 40 station(s) absent from the record's grid (1 gap(s), the first 120.000 .. 121.950 m" in out
    assert main(["road", "reconstruct", str(blank), "-o", str(tmp_path / "b.csv")]) == 0
    a, b = _elevation(tmp_path / "a.csv"), _elevation(tmp_path / "b.csv")
    np.testing.assert_array_equal(a[["elevation_m", "std_m"]].to_numpy(), b[["elevation_m", "std_m"]].to_numpy())
    assert a.std_m[gone.to_numpy()].max() > 3 * a.std_m.median()


def test_convert_spacing_does_not_interpolate_an_apl_dropout(recording, tmp_path, capsys):
    d = pd.read_csv(recording)
    keep = (d.distance_m < 120) | (d.distance_m >= 122)
    cut = tmp_path / "cut.csv"
    d[keep][["distance_m", "apl_m"]].to_csv(cut, index=False)
    assert main(["road", "convert", str(cut), str(tmp_path / "o.csv"), "--track", "apl", "--spacing", "0.05"]) == 2
    assert "--spacing would interpolate the signal across that dropout" in _err(capsys)
    # a profile's track is resampled across the same hole, as documented (linear interpolation)
    d[keep][["distance_m", "true_m"]].to_csv(cut, index=False)
    assert main(["road", "convert", str(cut), str(tmp_path / "p.csv"), "--spacing", "0.05"]) == 0


@pytest.mark.parametrize(("mutate", "phrase"), [
    (lambda d: d.assign(apl_mm=np.where((d.index >= 1000) & (d.index < 1040), -9999, d.apl_m * 1e3)).drop(
        columns=["apl_m", "true_m"]), "holds -9999 mm at station 50.000 m to 51.950 m (40 samples)"),
    (lambda d: d.rename(columns={"apl_m": "apl_mm"}).drop(columns=["true_m"]), "below any APL recording of a road"),
    (lambda d: d.assign(apl_um=d.apl_m * 1e6).drop(columns=["apl_m", "true_m"]), "is in 'um', a unit this package"),
    (lambda d: d.iloc[::-1], "reverse its rows"),
    (lambda d: d.rename(columns={"distance_m": "PR_m"}), "no station column; expected one named distance"),
])
def test_reconstruct_refuses_a_broken_recording_in_one_line(recording, tmp_path, capsys, mutate, phrase):
    f = tmp_path / "bad.csv"
    mutate(pd.read_csv(recording)).to_csv(f, index=False)
    capsys.readouterr()
    assert main(["road", "reconstruct", str(f), "-o", str(tmp_path / "o.csv")]) == 2
    err = _err(capsys)
    assert err.count("error:") == 1 and phrase in err and str(f) in err
    assert not (tmp_path / "o.csv").exists()


def test_iri_refuses_a_raw_apl_channel_in_an_erd_file(recording, tmp_path, capsys):
    d = pd.read_csv(recording)
    body = "\n".join(f"{v:.4f}" for v in d.apl_m * 1e3)
    f = tmp_path / "vendor.erd"
    f.write_text(f"ERDFILEV2.00\n    1, {len(d)},    -1,     1,     5,  0.05,  0.0,\nTITLE   APL run\n"
                 f"SHORTNAMAPL     \nUNITSNAMmm      \nXUNITS  m\nEND\n{body}\n")
    assert main(["road", "iri", str(f)]) == 2
    assert "looks like an APL trailer's raw signal" in _err(capsys)
    # the way out it names: a table, then road reconstruct
    assert main(["road", "convert", str(f), str(tmp_path / "signal.csv"), "--track", "APL"]) == 0
    assert main(["road", "reconstruct", str(tmp_path / "signal.csv"), "-o", str(tmp_path / "p.csv")]) == 0


def test_batch_reconstruct_warns_of_rows_dropped_from_the_grid(recording, tmp_path):
    from longprofile.batch import ReconstructTask

    d = pd.read_csv(recording)
    cut = tmp_path / "cut.csv"
    d[(d.distance_m < 120) | (d.distance_m >= 122)].to_csv(cut, index=False)
    out = ReconstructTask()(cut)
    assert "40 station(s) absent from the record's grid (the first 120.000 .. 121.950 m)" in out.warning
    assert out.metadata["n_missing"] == 40
