"""A log that stops (session 38): ``estimate_slope_split`` / ``vehicle slope --stops split``, ``--start/--end``.

Oracle: each moving stretch's estimate is bit for bit that of the stretch given as a log (a file) of its own.
"""

import functools

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from longprofile.cli.app import app, main
from longprofile.errors import InputError
from longprofile.vehicle import (
    MIN_STRETCH_DURATION,
    DriveLog,
    default_vehicle,
    drive_scenario,
    drive_window,
    estimate_slope,
    estimate_slope_split,
    simulate_drive,
)

runner = CliRunner()
ARRAYS = ("vx", "vy", "yaw_rate", "vx_std", "vy_std", "yaw_rate_std", "slope", "slope_std", "fx", "fy_std",
          "resisting_force", "resisting_force_std")


@functools.lru_cache(maxsize=1)
def _base():
    """12 s of the paper drive at 100 Hz (every 10th sample of the 1 kHz simulation)."""
    log = simulate_drive(drive_scenario("paper", duration=12), default_vehicle(), seed=3).log
    return {k: getattr(log, k)[::10].copy() for k in ("time", "steering_angle", "wheel_speeds", "yaw_rate",
                                                       "accel_x", "accel_y")}


def _own(arrays, a, b):
    """Rows a:b as a log of their own."""
    return DriveLog(**{k: v[a:b].copy() for k, v in arrays.items()})


def _with_stops(stops):
    arrays = dict(_base())
    ws = arrays["wheel_speeds"].copy()
    for a, n in stops:
        ws[a:a + n] = 0.0
    arrays["wheel_speeds"] = ws
    return arrays


@settings(max_examples=20, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 1190), st.integers(1, 150)), min_size=1, max_size=4))
def test_each_stretch_is_the_estimate_of_its_own_log(stops):
    arrays = _with_stops(stops)
    moving = 0.5 * default_vehicle().wheel_radii[1] * (arrays["wheel_speeds"][:, 2] + arrays["wheel_speeds"][:, 3]) >= 2
    edges = np.flatnonzero(np.diff(np.concatenate([[0], moving.astype(int), [0]])))
    runs = list(zip(edges[::2], edges[1::2]))
    kept = [(a, b) for a, b in runs if b - a >= round(MIN_STRETCH_DURATION / 0.01)]
    if not kept:
        with pytest.raises(InputError, match="no stretch of the log"):
            estimate_slope_split(DriveLog(**arrays))
        return
    split = estimate_slope_split(DriveLog(**arrays))
    assert list(split.stretches) == kept
    frame = split.to_frame()
    assert len(frame) == arrays["time"].size and np.array_equal(frame["time"], arrays["time"])
    inside = np.zeros(arrays["time"].size, dtype=bool)
    for k, (a, b) in enumerate(kept, start=1):
        own = estimate_slope(_own(arrays, a, b))
        for name in ARRAYS:  # bit for bit, the stretch as its own log
            assert np.array_equal(getattr(split, name)[a:b], getattr(own, name)), name
        pd.testing.assert_frame_equal(frame.iloc[a:b].drop(columns=["stretch", "note"]).reset_index(drop=True),
                                      own.to_frame(), check_dtype=False, check_exact=True)
        assert (frame["stretch"].iloc[a:b] == k).all() and (frame["note"].iloc[a:b] == "").all()
        inside[a:b] = True
    out = frame[~inside]
    assert out["vx"].isna().all() and out["slope_std"].isna().all() and (out["stretch"] == 0).all()
    assert out["note"].str.contains("below 2 m/s|under 2 s").all()
    short = sum(b - a for a, b in runs if (a, b) not in kept) * 0.01
    assert split.left_out[1] == pytest.approx(short)
    assert f"{len(kept)} stretch(es) estimated" in split.warnings()[0]


def test_short_moving_stretch_left_out_with_a_note():
    arrays = _with_stops([(200, 300), (650, 50)])  # moving 5-6.5 s: 1.5 s, under the 2 s minimum
    split = estimate_slope_split(DriveLog(**arrays))
    assert split.stretches == ((0, 200), (700, 1200))
    frame = split.to_frame()
    assert frame["note"].iloc[550] == "moving stretch of 1.5 s, under 2 s"
    assert frame["note"].iloc[300] == "rear-wheel speed below 2 m/s"
    assert split.left_out == pytest.approx((3.5, 1.5))
    assert estimate_slope_split(DriveLog(**arrays), min_duration=1.0).stretches[1] == (500, 650)


def test_refusal_names_the_option_and_window_errors():
    arrays = _with_stops([(0, 100)])
    with pytest.raises(InputError, match="--stops split"):
        estimate_slope(DriveLog(**arrays))
    log = DriveLog(**_base())
    assert drive_window(log) is log
    part = drive_window(log, 2.0, 5.0)
    assert part.time[0] == pytest.approx(2.0) and part.time[-1] == pytest.approx(5.0) and part.time.size == 301
    for start, end in ((5.0, 2.0), (20.0, 30.0), (float("nan"), None)):
        with pytest.raises(InputError, match="window"):
            drive_window(log, start, end)


def _ramped_stop_log(path):
    """The paper drive at 100 Hz with a smooth stop (25 m/s down to rest over 6 s, 2 s standing, up again over 6 s),
    consistent enough for the log's checks (accelerometer and gyro scaled with the speed)."""
    frame = simulate_drive(drive_scenario("paper", duration=24), default_vehicle(), seed=1).to_frame().iloc[::10]
    frame = frame.reset_index(drop=True)
    t = frame["time"].to_numpy()
    ramp = lambda x: 0.5 - 0.5 * np.cos(np.pi * np.clip(x, 0.0, 1.0))  # noqa: E731
    g = np.maximum(ramp((9.0 - t) / 6.0), ramp((t - 11.0) / 6.0))
    wheels = [c for c in frame.columns if c.startswith("wheel_speed")]
    frame[wheels] = frame[wheels].to_numpy() * g[:, None]
    frame["accel_x"] = frame["accel_x"] * g + frame["true_vx"] * np.gradient(g, t)
    frame["yaw_rate"] = frame["yaw_rate"] * g
    frame["accel_y"] = frame["accel_y"] * g ** 2
    frame.drop(columns=[c for c in frame.columns if c.startswith("true_")]).to_csv(path, index=False)
    return t


def test_cli_split_equals_each_stretch_as_its_own_file(tmp_path, capsys):
    log = tmp_path / "stops.csv"
    t = _ramped_stop_log(log)
    assert main(["vehicle", "slope", str(log), "-o", str(tmp_path / "refused.csv")]) == 2
    assert "--stops split" in capsys.readouterr().err
    states = tmp_path / "states.csv"
    res = runner.invoke(app, ["vehicle", "slope", str(log), "-o", str(states), "--stops", "split",
                              "--plot", str(tmp_path / "states.png")])
    assert res.exit_code == 0, res.output
    assert "2 stretch(es) estimated" in " ".join(res.output.split())
    out = pd.read_csv(states, keep_default_na=False, na_values=[""])
    assert len(out) == t.size and {"stretch", "note"} <= set(out.columns)
    assert out.loc[out["stretch"] == 0, "vx"].isna().all() and (out.loc[out["stretch"] == 0, "note"] != "").all()
    assert (tmp_path / "states.png").stat().st_size > 10_000
    frame = pd.read_csv(log)
    for k in (1, 2):
        rows = np.flatnonzero(out["stretch"] == k)
        own = tmp_path / f"own{k}.csv"
        frame.iloc[rows].to_csv(own, index=False)
        assert main(["vehicle", "slope", str(own), "-o", str(tmp_path / f"own{k}_states.csv")]) == 0
        expected = pd.read_csv(tmp_path / f"own{k}_states.csv")
        got = out.iloc[rows].drop(columns=["stretch", "note"]).reset_index(drop=True)
        pd.testing.assert_frame_equal(got, expected, check_dtype=False, check_exact=True)


def test_cli_window_equals_the_window_as_its_own_file(tmp_path, capsys):
    log = tmp_path / "stops.csv"
    t = _ramped_stop_log(log)
    win = tmp_path / "win.csv"
    assert main(["vehicle", "slope", str(log), "-o", str(win), "--start", "14.5", "--end", "19"]) == 0
    frame = pd.read_csv(log)
    rows = (t >= 14.5) & (t <= 19)
    frame[rows].to_csv(tmp_path / "own.csv", index=False)
    assert main(["vehicle", "slope", str(tmp_path / "own.csv"), "-o", str(tmp_path / "own_states.csv")]) == 0
    pd.testing.assert_frame_equal(pd.read_csv(win), pd.read_csv(tmp_path / "own_states.csv"), check_exact=True)
    capsys.readouterr()
    assert main(["vehicle", "slope", str(log), "-o", str(tmp_path / "x.csv"), "--start", "30"]) == 2
    assert "window" in capsys.readouterr().err
    assert main(["vehicle", "slope", str(log), "-o", str(tmp_path / "y.csv"), "--stops", "cut"]) == 2
