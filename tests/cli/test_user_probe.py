"""Messages a user's probe found unclear or misleading (session 35): each names the cause and a way out that the
command line has."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from longprofile.cli.app import main


def _run(argv, capsys):
    code = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return code, " ".join((cap.out + cap.err).split())


def test_stations_in_km_under_a_metre_label_name_the_stations(tmp_path, capsys):
    x = np.arange(0, 2000.0, 0.05)  # 2 km read as 2 m: longer than the 0.25 m moving-average base
    pd.DataFrame({"distance_m": x / 1000.0, "left_mm": 50 * np.sin(x)}).to_csv(tmp_path / "p.csv", index=False)
    code, text = _run(["road", "iri", tmp_path / "p.csv", "-o", tmp_path / "o.csv"], capsys)
    assert code == 2 and "the stations look like kilometres" in text and "distance_km" in text


def test_a_gap_in_a_vehicle_log_is_named_not_sent_to_resample(tmp_path, capsys):
    t = np.r_[np.arange(0, 5, 0.01), np.arange(5.5, 10, 0.01)]
    frame = pd.DataFrame({"time": t, "accel_x": np.sin(t), "accel_y": 0.1 * np.cos(t), "yaw_rate": 0.01 * np.sin(t),
                          "steering_angle": 0.01 * np.sin(t)})
    for w in ("fl", "fr", "rl", "rr"):
        frame[f"wheel_speed_{w}"] = 20.0 + np.sin(t)
    frame.to_csv(tmp_path / "log.csv", index=False)
    code, text = _run(["vehicle", "slope", tmp_path / "log.csv", "-o", tmp_path / "o.csv"], capsys)
    assert code == 2 and "has a gap of 0.51 s after t = 4.99 s" in text and "--resample" not in text


@pytest.mark.parametrize("argv", [["rail", "simulate", "-o", "{d}/s", "--seed", "-1"],
                                  ["rail", "settle", "--sensors", "a", "--readings", "b", "-o", "{d}/o.csv",
                                   "--monte-carlo", "-5"]])
def test_negative_counts_are_usage_errors(tmp_path, capsys, argv):
    code, text = _run([a.format(d=tmp_path) for a in argv], capsys)
    assert code == 2 and "Traceback" not in text and "x>=0" in text


def test_a_site_too_large_to_simulate_is_refused_before_any_work(tmp_path, capsys):
    code, text = _run(["rail", "simulate", "-o", tmp_path / "s", "--days", "100000"], capsys)
    assert code == 2 and "more than 5e+07" in text and not (tmp_path / "s").exists()


def test_differentiate_prints_the_interval_it_used(tmp_path, capsys):
    t = np.arange(500) * 1e-3
    pd.DataFrame({"time": t * 1000, "x": np.sin(t)}).to_csv(tmp_path / "s.csv", index=False)  # ms, unlabelled
    code, text = _run(["differentiate", tmp_path / "s.csv", "-c", "x", "-w", "45", "-o", tmp_path / "d.csv"], capsys)
    assert code == 0 and "sample interval 1 s (column 'time' read in seconds; name it time_ms" in text


def test_sigterm_ends_a_batch_as_ctrl_c_does():
    """SIGTERM (kill, a scheduler's timeout) ended `batch iri` at once: exit 143, the last files missing from the
    manifest, the pool workers left running (session 35, a probe). Inside the batch it is a KeyboardInterrupt, which
    the command turns into its resume hint and exit 130; outside, the previous handler is back."""
    import os
    import signal

    from longprofile.cli.batch import _terminate_as_interrupt

    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt), _terminate_as_interrupt():
        os.kill(os.getpid(), signal.SIGTERM)
    assert signal.getsignal(signal.SIGTERM) is before
