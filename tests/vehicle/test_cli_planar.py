"""CLI: ``longprofile vehicle simulate`` and ``longprofile vehicle slope`` (paper 001)."""

import pandas as pd
from typer.testing import CliRunner

from longprofile.cli.app import app, main
from longprofile.vehicle import LOG_COLUMNS, default_vehicle

runner = CliRunner()


def test_simulate_then_slope(tmp_path):
    log = tmp_path / "log.csv"
    res = runner.invoke(app, ["vehicle", "simulate", "--scenario", "hill", "--duration", "4", "-o", str(log),
                              "--plot", str(tmp_path / "drive.png")])
    assert res.exit_code == 0, res.output
    frame = pd.read_csv(log)
    assert list(frame.columns[:len(LOG_COLUMNS)]) == list(LOG_COLUMNS)
    assert "true_slope" in frame.columns and len(frame) == 4000
    assert (tmp_path / "drive.png").stat().st_size > 10_000

    car = tmp_path / "car.toml"
    car.write_text(default_vehicle().to_toml())
    states = tmp_path / "states.csv"
    res = runner.invoke(app, ["vehicle", "slope", str(log), "--vehicle", str(car), "-o", str(states),
                              "--plot", str(tmp_path / "states.png")])
    assert res.exit_code == 0, res.output
    out = pd.read_csv(states)
    for col in ("time", "vx", "vx_std", "vy", "yaw_rate", "slope", "slope_std", "fx_fl", "fy_rr_std",
                "resisting_force"):
        assert col in out.columns
    # 4 s of hill drive: flat road, then the start of the acceleration; the estimate follows the truth
    assert (out["slope"] - frame["true_slope"]).abs().max() < 0.01
    assert (tmp_path / "states.png").stat().st_size > 10_000
    # the paper's measurement on request (same numbers here: front-wheel drive, not braking)
    paper = tmp_path / "paper.csv"
    res = runner.invoke(app, ["vehicle", "slope", str(log), "-o", str(paper), "--speed-measurement", "rear-mean"])
    assert res.exit_code == 0 and "speed measurement rear-mean" in res.output
    assert (pd.read_csv(paper)["slope"] - frame["true_slope"]).abs().max() < 0.01


def test_missing_channel_is_a_clear_error_exit_2(tmp_path, capsys):
    log = tmp_path / "log.csv"
    assert main(["vehicle", "simulate", "--duration", "1", "--no-truth", "-o", str(log)]) == 0
    pd.read_csv(log).drop(columns=["yaw_rate"]).to_csv(tmp_path / "bad.csv", index=False)
    code = main(["vehicle", "slope", str(tmp_path / "bad.csv"), "-o", str(tmp_path / "s.csv")])
    assert code == 2
    err = capsys.readouterr().err
    assert "missing channel(s) yaw_rate (rad/s)" in err
    assert not (tmp_path / "s.csv").exists()


def test_bad_options_exit_2(tmp_path, capsys):
    assert main(["vehicle", "simulate", "--scenario", "moon", "-o", str(tmp_path / "x.csv")]) == 2
    assert "unknown scenario 'moon'" in capsys.readouterr().err
    assert main(["vehicle", "simulate", "-o", str(tmp_path / "x.csv"), "--vehicle", str(tmp_path / "no.toml")]) == 2
    assert "no such vehicle description file" in capsys.readouterr().err
    log = tmp_path / "log.csv"
    assert main(["vehicle", "simulate", "--duration", "1", "-o", str(log)]) == 0
    assert main(["vehicle", "slope", str(log), "-o", str(tmp_path / "s.csv"), "--speed-measurement", "gps"]) == 2
    assert "speed_measurement must be 'robust' or 'rear-mean'; got 'gps'" in capsys.readouterr().err
