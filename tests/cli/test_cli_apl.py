"""``longprofile road simulate | reconstruct | identify`` (CliRunner, in process)."""

import json

import numpy as np
import pandas as pd
import pytest
from scipy import signal
from typer.testing import CliRunner

from longprofile.cli.app import app, main
from longprofile.road.apl import apl_model

runner = CliRunner()


def _run(args):
    return runner.invoke(app, args, catch_exceptions=True)


def test_simulate_then_reconstruct_three_methods(tmp_path):
    rec = tmp_path / "rec.csv"
    r = _run(["road", "simulate", "-o", str(rec), "--length", "200", "--seed", "1", "--plot", str(tmp_path / "r.png")])
    assert r.exit_code == 0, r.output
    df = pd.read_csv(rec)
    assert list(df.columns) == ["distance_m", "true_m", "apl_m"] and len(df) == 4001
    assert (tmp_path / "r.png").stat().st_size > 1000
    for method in ("smoother", "filter", "double"):
        out = tmp_path / f"{method}.csv"
        args = ["road", "reconstruct", str(rec), "--speed", "20", "--dx", "0.05", "--method", method, "-o", str(out)]
        if method == "smoother":
            args += ["--plot", str(tmp_path / "p.png")]
        if method == "filter":
            args += ["--q", "2e-6", "--r", "1e-8"]
        r = _run(args)
        assert r.exit_code == 0, r.output
        prof = pd.read_csv(out, comment="#")
        assert list(prof.columns) == ["distance_m", "elevation_m", "std_m", "raw_m", "raw_std_m"]
        assert np.isfinite(prof["elevation_m"]).all()
    assert (tmp_path / "p.png").stat().st_size > 1000


def test_reconstruct_bad_inputs_are_one_line_errors(tmp_path, capsys):
    rec = tmp_path / "rec.csv"
    assert _run(["road", "simulate", "-o", str(rec), "--length", "100"]).exit_code == 0
    out = str(tmp_path / "o.csv")
    assert main(["road", "reconstruct", str(rec), "--dx", "0.1", "-o", out]) == 2
    assert "0.05 m apart but --dx is 0.1" in capsys.readouterr().err.replace("\n", " ")
    assert main(["road", "reconstruct", str(rec), "--speed", "15", "-o", out]) == 2
    assert "no Table 1 calibration" in capsys.readouterr().err.replace("\n", " ")
    short = tmp_path / "short.csv"
    pd.read_csv(rec).iloc[:50].to_csv(short, index=False)
    assert main(["road", "reconstruct", str(short), "-o", out]) == 2
    assert "need at least" in capsys.readouterr().err.replace("\n", " ")
    gap = tmp_path / "gap.csv"
    df = pd.read_csv(rec)
    df.loc[100:120, "apl_m"] = np.nan
    df.to_csv(gap, index=False)
    assert main(["road", "reconstruct", str(gap), "--method", "double", "-o", out]) == 2
    assert "missing" in capsys.readouterr().err
    # the Kalman methods bridge the gap (documented), with a larger posterior std there
    assert main(["road", "reconstruct", str(gap), "--q", "2e-6", "--r", "1e-8", "-o", out]) == 0
    prof = pd.read_csv(out, comment="#")
    assert prof["raw_std_m"][110] > prof["raw_std_m"][90]


def test_identify_writes_a_model_loadable_by_reconstruct(tmp_path):
    m = apl_model(20.0, 0.05)
    n = 5000
    k = np.arange(n)
    u = np.where(((k + 250) // 500) % 2 == 1, 0.01, 0.0)
    y = signal.lfilter(m.numerator, m.denominator, u) + np.random.default_rng(0).normal(0, 2e-5, n)
    pd.DataFrame(dict(u=u)).to_csv(tmp_path / "u.csv", index=False)
    pd.DataFrame(dict(y=y)).to_csv(tmp_path / "y.csv", index=False)
    model = tmp_path / "model.json"
    r = _run(["road", "identify", "--input", str(tmp_path / "u.csv"), "--output", str(tmp_path / "y.csv"),
              "--orders", "5", "6", "0", "-o", str(model), "--plot", str(tmp_path / "id.png")])
    assert r.exit_code == 0, r.output
    data = json.loads(model.read_text())
    assert data["model"]["dx"] == 0.05 and data["model"]["speed"] == 20.0
    assert data["fit"]["converged"] and data["fit"]["stable"]
    rec = tmp_path / "rec.csv"
    assert _run(["road", "simulate", "-o", str(rec), "--length", "100"]).exit_code == 0
    r = _run(["road", "reconstruct", str(rec), "--model", str(model), "--q", "2e-6", "--r", "1e-8",
              "-o", str(tmp_path / "p.csv")])
    assert r.exit_code == 0, r.output
    # a --dx the record's stations do not have is refused (a model of another dx is re-discretised: test_resample_model)
    assert main(["road", "reconstruct", str(rec), "--model", str(model), "--dx", "0.15", "-o",
                 str(tmp_path / "q.csv")]) == 2


def test_an_apl_column_in_millimetres_is_found_and_converted(tmp_path):
    # a recording exported as apl_mm (or "APL [mm]") used to be "missing column apl_m"
    rec = tmp_path / "rec.csv"
    assert _run(["road", "simulate", "-o", str(rec), "--length", "200", "--seed", "2"]).exit_code == 0
    df = pd.read_csv(rec)
    outs = {}
    for name in ("apl_m", "apl_mm", "APL [mm]"):
        src = tmp_path / f"{name.replace(' ', '_').replace('[', '').replace(']', '')}.csv"
        scale = 1.0 if name == "apl_m" else 1000.0
        df[["distance_m"]].assign(**{name: df["apl_m"] * scale}).to_csv(src, index=False)
        out = tmp_path / f"out_{src.stem}.csv"
        r = _run(["road", "reconstruct", str(src), "-o", str(out)])
        assert r.exit_code == 0, r.output
        outs[name] = pd.read_csv(out, comment="#")
    for name in ("apl_mm", "APL [mm]"):  # the same profile to the round-off of the mm conversion
        np.testing.assert_allclose(outs[name]["elevation_m"], outs["apl_m"]["elevation_m"], rtol=0, atol=1e-8)


@pytest.mark.parametrize(("station", "factor"), [("distance_ft", 0.3048), ("station_km", 1000.0),
                                                  ("chainage [m]", 1.0)])
def test_an_apl_recording_takes_its_stations_in_any_length_unit(tmp_path, station, factor):
    """As profiles do: a station column named with its unit (distance_ft used to be "missing column distance_m")."""
    rec = tmp_path / "rec.csv"
    assert _run(["road", "simulate", "-o", str(rec), "--length", "200", "--seed", "2"]).exit_code == 0
    df = pd.read_csv(rec)
    src = tmp_path / "other.csv"
    df[["apl_m"]].assign(**{station: df["distance_m"] / factor})[[station, "apl_m"]].to_csv(src, index=False)
    ref, out = tmp_path / "ref.csv", tmp_path / "out.csv"
    assert _run(["road", "reconstruct", str(rec), "-o", str(ref)]).exit_code == 0
    r = _run(["road", "reconstruct", str(src), "-o", str(out)])
    assert r.exit_code == 0, r.output
    a, b = pd.read_csv(ref, comment="#"), pd.read_csv(out, comment="#")
    np.testing.assert_allclose(b["distance_m"], a["distance_m"], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(b["elevation_m"], a["elevation_m"], rtol=0, atol=1e-9)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_reconstructed_profile_records_how_it_was_made(tmp_path, suffix):
    """Provenance of a `road reconstruct` output (probe finding 10): speed, dx, method, model, q, r, high-pass,
    source as `#` lines / Parquet metadata, as IRI tables carry them; every profile reader reads the file as before."""
    from longprofile.io import read_profile, read_report_table, read_table

    rec = tmp_path / "rec.csv"
    assert _run(["road", "simulate", "-o", str(rec), "--length", "200", "--seed", "2"]).exit_code == 0
    out = tmp_path / f"p{suffix}"
    r = _run(["road", "reconstruct", str(rec), "--method", "fixed-lag", "--r", "1e-8", "--q", "2e-6",
              "--highpass-wavelength", "80", "-o", str(out)])
    assert r.exit_code == 0, r.output
    frame, meta = read_report_table(out)
    assert meta["source"] == str(rec) and meta["column"] == "apl_m" and meta["command"] == "road reconstruct"
    assert meta["speed_m_per_s"] == 20.0 and meta["dx_m"] == 0.05 and meta["method"] == "fixed-lag"
    assert meta["q_m2"] == 2e-6 and meta["r_m2"] == 1e-8 and meta["q_r"] == "given"
    assert meta["highpass_wavelength_m"] == 80.0 and meta["lag_m"] > 0 and meta["model"].startswith("paper 000")
    assert meta["software"].startswith("longprofile ")
    if suffix == ".csv":
        lines = out.read_text().splitlines()
        assert lines[0].startswith("# software: ") and lines[len(meta)] == "distance_m,elevation_m,std_m,raw_m,raw_std_m"
    plain = tmp_path / f"plain{suffix}"
    table = read_table(out)
    table.to_csv(plain, index=False) if suffix == ".csv" else table.to_parquet(plain, index=False)
    assert list(table.columns) == ["distance_m", "elevation_m", "std_m", "raw_m", "raw_std_m"]
    a, b = read_profile(out), read_profile(plain)
    assert a.tracks == ("elevation",) and np.array_equal(a.elevation, b.elevation) and np.array_equal(a.std, b.std)
    iri = [_run(["road", "iri", str(f), "--segment", "50"]) for f in (out, plain)]
    assert iri[0].exit_code == 0 and iri[0].output.splitlines()[-3:] == iri[1].output.splitlines()[-3:]
