"""A newcomer's first hour (session 36, a probe with the README only): what misled or stopped them."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from longprofile.cli.app import app, main


def test_help_keeps_the_unit_in_brackets():
    """``time [ms]`` was shown as ``time )`` (rich markup took ``[ms]`` for a tag)."""
    out = CliRunner().invoke(app, ["differentiate", "--help"], terminal_width=200).output
    assert "time [ms])" in out


def test_identify_names_the_option_of_a_missing_column(tmp_path, capsys):
    pd.DataFrame({"u": np.zeros(50)}).to_csv(tmp_path / "u.csv", index=False)
    pd.DataFrame({"y": np.zeros(50)}).to_csv(tmp_path / "y.csv", index=False)
    code = main(["road", "identify", "--input", str(tmp_path / "u.csv"), "--output", str(tmp_path / "y.csv"),
                 "--input-column", "zz", "-o", str(tmp_path / "m.json")])
    assert code == 2 and "choose the column with --input-column NAME" in capsys.readouterr().err


def test_the_rail_reports_alarms_carry_their_unit(tmp_path):
    """``value, threshold`` were metres (m/day for a rate) beside thresholds given in mm, unlabelled."""
    from longprofile.rail import SettlementSettings, estimate_settlement, simulate_site, validate_site
    from longprofile.report import write_rail_report

    syn = simulate_site("mittersheim-like", seed=0, sampling_minutes=60.0, n_days=10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = estimate_settlement(validate_site(syn.sensors, syn.readings, syn.survey),
                                  settings=SettlementSettings(settlement_threshold_m=0.005,
                                                              rate_threshold_m_per_day=0.002, n_monte_carlo=200))
    write_rail_report(res, tmp_path / "rep")
    alarms = pd.read_csv(tmp_path / "rep" / "alarms.csv")
    assert {"settlement", "rate"} <= set(alarms["kind"])
    assert (alarms["unit"] == np.where(alarms["kind"] == "rate", "m/day", "m")).all()


def test_a_drive_over_part_of_a_road_says_how_much(tmp_path, capsys):
    """``--road`` drove the first 400 m of a 10 km road without a word (the default 20 s at 20 m/s)."""
    x = np.arange(0.0, 2000.0, 0.05)
    z = 1e-3 * np.sin(2 * np.pi * x / 17.0)
    pd.DataFrame({"distance_m": x, "elevation_m": z}).to_csv(tmp_path / "road.csv", index=False)
    code = main(["vehicle", "vertical", "simulate", "--road", str(tmp_path / "road.csv"), "--config", "3",
                 "--speed", "20", "--duration", "5", "-o", str(tmp_path / "log.csv")])
    out = " ".join(capsys.readouterr().err.split())
    assert code == 0 and "of its 0..1999.95 m at 20 m/s: --duration sets how far" in out


def test_the_derivative_figure_names_the_std_it_draws():
    """The figure said "band = noise only, not bias" under the default std, which is the total (session 36)."""
    from longprofile.report import plot_derivative
    from longprofile.signal import derivative

    x = np.sin(np.arange(400) * 0.02)
    for std, words in (("total", "noise and the model's bias and lag (std total)"), ("noise", "noise only")):
        res = derivative(x, 0.01, method="ml", window=45, degree=2, std=std)
        assert words in plot_derivative(x, 0.01, res)._suptitle.get_text()
