"""``longprofile rail simulate | settle`` in process (CliRunner) and the error contract (exit 2, one line)."""

import pandas as pd
import pytest
from typer.testing import CliRunner

from longprofile.cli.app import app, main

runner = CliRunner()


@pytest.fixture(scope="module")
def site_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    res = runner.invoke(app, ["rail", "simulate", "--preset", "farebersviller-like", "-o", str(out), "--days", "36",
                              "--sampling-minutes", "120", "--seed", "1", "--plot", str(out / "truth.png")])
    assert res.exit_code == 0, res.output
    return out


def test_simulate_writes_the_tables(site_dir):
    for name in ("sensors", "readings", "survey", "controls", "truth", "thresholds"):
        assert (site_dir / f"{name}.csv").exists()
    from longprofile.io import read_rail_thresholds

    assert read_rail_thresholds(site_dir / "thresholds.csv")["settlement"] == {"alert": 0.01, "action": 0.015,
                                                                               "alarm": 0.02}
    assert (site_dir / "truth.png").stat().st_size > 1000
    assert set(pd.read_csv(site_dir / "readings.csv").columns) == {"timestamp", "sensor_id", "angle_deg",
                                                                     "temperature_c"}


def test_settle_writes_table_plot_and_report(site_dir, tmp_path):
    out = tmp_path / "settlement.csv"
    args = ["rail", "settle", "--sensors", str(site_dir / "sensors.csv"), "--readings", str(site_dir / "readings.csv"),
            "--survey", str(site_dir / "survey.csv"), "--controls", str(site_dir / "controls.csv"), "-o", str(out),
            "--plot", str(tmp_path / "s.png"), "--report", str(tmp_path / "report"), "--thermal", "lagged",
            "--settlement-threshold-mm", "5", "--monte-carlo", "50"]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    table = pd.read_csv(out)
    truth = pd.read_csv(site_dir / "truth.csv")
    assert len(table) == len(truth)
    merged = table.merge(truth, on=["date", "sensor_id"])
    assert ((merged.dz_m - merged.dz_true_m) ** 2).mean() ** 0.5 < 3e-3
    assert {"dz_lower90_m", "dz_upper90_m", "rate_m_per_day", "status"} <= set(table.columns)
    html = (tmp_path / "report" / "index.html").read_text()
    for section in ("Flagged sensors", "Alarms", "Control surveys", "Settlement profiles per day",
                    "Chi-squared test of the standardised differences"):
        assert section in html
    assert (tmp_path / "s.png").stat().st_size > 1000
    sensors = pd.read_csv(tmp_path / "report" / "sensors.csv")
    assert {"status", "loo_score", "reversal_z", "reversal_llr", "step_z", "noise_factor"} <= set(sensors.columns)
    assert (sensors.noise_factor > 0).all()
    assert len(sensors) == table.sensor_id.nunique()


def test_per_day_model_is_the_library_per_day_estimate(site_dir, tmp_path):
    # --per-day-model = estimate_settlement(joint_days=False), the live service's model above 40 000 sensor-days; the
    # default differs from it
    from longprofile.io import read_rail_site
    from longprofile.rail import estimate_settlement

    tables = [str(site_dir / f"{n}.csv") for n in ("sensors", "readings", "survey")]
    base = ["rail", "settle", "--sensors", tables[0], "--readings", tables[1], "--survey", tables[2],
            "--monte-carlo", "0"]
    for flag, name in ((["--per-day-model"], "per_day.csv"), ([], "all_days.csv")):
        res = runner.invoke(app, base + flag + ["-o", str(tmp_path / name)])
        assert res.exit_code == 0, res.output
    per_day, all_days = pd.read_csv(tmp_path / "per_day.csv"), pd.read_csv(tmp_path / "all_days.csv")
    ref = estimate_settlement(read_rail_site(*tables), n_monte_carlo=0, joint_days=False).to_table()
    pd.testing.assert_series_equal(per_day.dz_m, ref.dz_m.reset_index(drop=True), check_exact=False, rtol=1e-9,
                                   atol=1e-12)
    assert (per_day.dz_std_m - all_days.dz_std_m).abs().max() > 1e-6


def _settings_seen(monkeypatch, site_dir, tmp_path, attr, runs, monte_carlo="0"):
    """Run ``rail settle`` once per (extra flags, output name) of ``runs``, each must succeed; the value of the
    ``SettlementSettings`` attribute ``attr`` each run handed to the library, and the base arguments."""
    import longprofile.rail as rail

    seen = []
    real = rail.estimate_settlement

    def spy(site, settings=None, **options):
        seen.append(getattr(settings, attr))
        return real(site, settings=settings, **options)

    monkeypatch.setattr(rail, "estimate_settlement", spy)
    tables = [str(site_dir / f"{n}.csv") for n in ("sensors", "readings", "survey")]
    base = ["rail", "settle", "--sensors", tables[0], "--readings", tables[1], "--survey", tables[2],
            "--monte-carlo", monte_carlo]
    for flag, name in runs:
        res = runner.invoke(app, base + flag + ["-o", str(tmp_path / name)])
        assert res.exit_code == 0, res.output
    return seen, base


def test_max_settlement_band_flag_selects_the_old_interval(site_dir, tmp_path, monkeypatch):
    seen, _ = _settings_seen(monkeypatch, site_dir, tmp_path, "max_settlement_interval",
                             [(["--max-settlement-band"], "band.csv"), ([], "draws.csv")], monte_carlo="20")
    assert seen == ["band", "draws"]


@pytest.mark.parametrize(("attr", "flag", "value", "bad"), [("end_ambiguity", "--end-ambiguity", "mixture", "both"),
                                                        ("witness_rule", "--witness-rule", "steps", "maybe")])
def test_option_flags_reach_the_settings(site_dir, tmp_path, monkeypatch, capsys, attr, flag, value, bad):
    seen, base = _settings_seen(monkeypatch, site_dir, tmp_path, attr,
                                [([flag, value], f"{value}.csv"), ([], "off.csv")])
    assert seen == [value, "off"]
    code = main(base + [flag, bad, "-o", str(tmp_path / "x.csv")])
    err = capsys.readouterr().err
    assert code == 2 and f"{flag} {bad}: not known; use one of off, {value}" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.csv").exists()


def test_bad_input_is_one_line_and_exit_2(site_dir, tmp_path, capsys):
    bad = pd.read_csv(site_dir / "readings.csv")
    bad.loc[0, "sensor_id"] = "ghost"
    bad.to_csv(tmp_path / "bad.csv", index=False)
    code = main(["rail", "settle", "--sensors", str(site_dir / "sensors.csv"), "--readings", str(tmp_path / "bad.csv"),
                 "--survey", str(site_dir / "survey.csv"), "-o", str(tmp_path / "o.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert "ghost" in err and "Traceback" not in err
    code = main(["rail", "simulate", "--preset", "nowhere", "-o", str(tmp_path / "x")])
    assert code == 2
    assert "unknown preset" in capsys.readouterr().err


def test_controls_that_contradict_the_estimate_are_named(site_dir, tmp_path):
    """With the lagged thermal model the simulated site's own control surveys agree with the estimate (no warning);
    the same surveys with the far half of the track 15 mm lower on one date (an end that moved, which the angles
    cannot see) get one warning line naming the disagreement, and the result is still written."""
    base = ["rail", "settle", "--sensors", str(site_dir / "sensors.csv"), "--readings", str(site_dir / "readings.csv"),
            "--survey", str(site_dir / "survey.csv"), "--monte-carlo", "0", "--thermal", "lagged"]
    res = runner.invoke(app, base + ["--controls", str(site_dir / "controls.csv"), "-o", str(tmp_path / "a.csv")])
    assert res.exit_code == 0, res.output
    assert "control surveys disagree" not in res.output
    controls = pd.read_csv(site_dir / "controls.csv")
    last = controls.date == controls.date.max()
    far = controls.x_m > controls.x_m.median()
    controls.loc[last & far, "z_m"] -= 0.015
    controls.to_csv(tmp_path / "moved.csv", index=False)
    res = runner.invoke(app, base + ["--controls", str(tmp_path / "moved.csv"), "-o", str(tmp_path / "b.csv")])
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.output.splitlines() if "control surveys disagree" in ln]
    assert len(lines) == 1 and lines[0].startswith("warning: the control surveys disagree with the estimate")
    assert f"on {controls.date.max()}" in res.output.replace("\n", " ")
    assert (tmp_path / "b.csv").exists()


def test_the_thermal_model_is_chosen_from_the_readings(site_dir, tmp_path):
    """farebersviller-like (thermal lags of 2-6 h): without --thermal the lagged model is chosen and a note says so;
    --thermal linear keeps the paper's model and prints no note."""
    base = ["rail", "settle", "--sensors", str(site_dir / "sensors.csv"), "--readings", str(site_dir / "readings.csv"),
            "--survey", str(site_dir / "survey.csv"), "--monte-carlo", "0"]
    res = runner.invoke(app, base + ["-o", str(tmp_path / "auto.csv")])
    assert res.exit_code == 0, res.output
    assert "note: thermal model lagged, chosen from the readings" in res.output.replace("\n", " ")
    res = runner.invoke(app, base + ["--thermal", "linear", "-o", str(tmp_path / "linear.csv")])
    assert res.exit_code == 0, res.output
    assert "note: thermal model" not in res.output
    truth = pd.read_csv(site_dir / "truth.csv")
    err = {name: pd.read_csv(tmp_path / f"{name}.csv").merge(truth, on=["date", "sensor_id"])
           .eval("dz_m - dz_true_m").pow(2).mean() ** 0.5 for name in ("auto", "linear")}
    assert err["auto"] < 0.5 * err["linear"]
