"""``longprofile vehicle vertical tables`` in process (typer CliRunner)."""

import pandas as pd
from typer.testing import CliRunner

from longprofile.cli.app import app, main

runner = CliRunner()


def test_tables_writes_csv_and_plot(tmp_path):
    out = tmp_path / "tables.csv"
    png = tmp_path / "tables.png"
    res = runner.invoke(app, ["vehicle", "vertical", "tables", "--duration", "2", "--seed", "1", "--reference",
                              "thesis", "-o", str(out), "--plot", str(png)])
    assert res.exit_code == 0, res.output
    df = pd.read_csv(out)
    assert len(df) == 27                              # bench 3 x 5 variables + track 3 x 4 (no tyre load)
    assert set(df["reference"]) == {"thesis"}
    assert df["thesis"].notna().all()
    bench = df[(df["test"] == "bench") & (df["variable"] == "suspension_deflection")]
    assert (bench["epsilon"] > 95).all()              # a real score, not a placeholder
    assert png.stat().st_size > 10_000


def test_tables_bad_input_exits_2(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["vehicle", "vertical", "tables", "--reference", "measured", "-o", "t.csv", "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert "reference must be one of" in err and "Traceback" not in err
    assert main(["vehicle", "vertical", "tables", "-o", "t.csv", "--plot", "t.txt", "--duration", "1"]) == 2
    assert "unknown figure format" in capsys.readouterr().err
    (tmp_path / "folder").mkdir()
    assert main(["vehicle", "vertical", "tables", "-o", "folder", "--duration", "1"]) == 2
    assert "existing folder" in capsys.readouterr().err


def test_magneride_car_simulate_estimate_and_tables(tmp_path, monkeypatch, capsys):
    log = tmp_path / "mr.csv"
    res = runner.invoke(app, ["vehicle", "vertical", "simulate", "--car", "magneride", "--config", "3",
                              "--duration", "1", "-o", str(log)])
    assert res.exit_code == 0, res.output
    frame = pd.read_csv(log)
    cur = frame[[f"current_{c}" for c in ("FL", "FR", "RL", "RR")]].to_numpy()
    assert cur.min() >= 0 and cur.max() <= 5 and (cur > 0).any()        # the logged MR currents, 0-5 A
    states = tmp_path / "est.csv"
    res = runner.invoke(app, ["vehicle", "vertical", "estimate", str(log), "--config", "3", "-o", str(states)])
    assert res.exit_code == 0, res.output
    assert "nominal MR map" in res.output
    out = tmp_path / "t.csv"
    res = runner.invoke(app, ["vehicle", "vertical", "tables", "--duration", "2", "--car", "magneride", "-o", str(out)])
    assert res.exit_code == 0, res.output
    df = pd.read_csv(out)
    assert set(df["car"]) == {"magneride"} and len(df) == 27
    monkeypatch.chdir(tmp_path)
    assert main(["vehicle", "vertical", "tables", "--car", "lotus", "-o", "x.csv", "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert "car must be one of" in err and "Traceback" not in err
    assert main(["vehicle", "vertical", "simulate", "--car", "lotus", "-o", "y.csv", "--duration", "1"]) == 2
    assert "--car must be one of" in capsys.readouterr().err
