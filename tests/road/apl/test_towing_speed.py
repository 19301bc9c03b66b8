"""The towing speed of an APL record (paper 000's model is discretised at ONE speed): read from the file, checked
against --speed, off-speed samples flagged (docs/road-apl.md, "Assumption: constant towing speed")."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.cli.app import main
from longprofile.core import speed_factor
from longprofile.errors import UnitsError
from longprofile.io import find_speed_column, read_apl_speed
from longprofile.road import iso8608_profile
from longprofile.road.apl import (
    TABLE1_CONFIGURATIONS,
    apl_model,
    apl_response,
    check_speed_samples,
    choose_towing_speed,
    detrend_profile,
    reconstruct_profile,
    speed_tolerance,
    trailer_at_speed,
)

FAST = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _record(tmp_path, speed_kmh, *, length=300.0, sim_speed=6.0, name="rec.csv", header="Speed [km/h]"):
    """A `road simulate` recording at ``sim_speed`` with a speed column (km/h: a scalar or one value per row)."""
    plain = tmp_path / f"plain_{name}"
    if not plain.exists():
        assert main(["road", "simulate", "--length", str(length), "--speed", str(sim_speed), "--seed", "1",
                     "-o", str(plain)]) == 0
    df = pd.read_csv(plain)
    df.insert(1, header, speed_kmh)
    df.to_csv(tmp_path / name, index=False)
    return tmp_path / name, plain


def test_speed_units_come_from_the_unit_table():
    assert speed_factor("km/h") * 72.0 == pytest.approx(20.0, rel=1e-12)
    assert speed_factor("kmh") == speed_factor("KPH") == speed_factor("km_h") == speed_factor("km/h")
    assert speed_factor("mph") == pytest.approx(0.44704, rel=1e-12)
    assert speed_factor("m_s") == speed_factor("mps") == 1.0
    with pytest.raises(UnitsError):
        speed_factor("knots")


@pytest.mark.parametrize("name, unit", [("speed_m_s", "m_s"), ("speed_kmh", "kmh"), ("Speed [km/h]", "km/h"),
                                        ("v_kmh", "kmh"), ("Vitesse (km/h)", "km/h"), ("velocity_mps", "mps")])
def test_speed_columns_are_found_with_their_unit(name, unit):
    assert find_speed_column(["distance_m", name, "apl_mm"]) == (name, unit)


@pytest.mark.parametrize("names", [["speed"], ["Speed [knots]"], ["speed_kmh", "v_m_s"]])
def test_a_speed_column_without_a_known_unit_or_twice_is_refused(names):
    with pytest.raises(UnitsError):
        find_speed_column(["distance_m", *names])


def test_without_speed_the_files_speed_column_is_used(tmp_path, capsys):
    """The probe's v21 case: a 6 m/s record with 'Speed [km/h]' = 21.6 read without --speed gave a profile 60 times
    too wrong (the 20 m/s model); now it is the --speed 6 reconstruction, to the last digit."""
    rec, plain = _record(tmp_path, 21.6)
    assert main(["road", "reconstruct", str(rec), "-o", str(tmp_path / "a.csv")]) == 0
    assert "21.6 km/h" in capsys.readouterr().err.replace("\n", " ")
    assert main(["road", "reconstruct", str(plain), "--speed", "6", "-o", str(tmp_path / "b.csv")]) == 0
    a, b = pd.read_csv(tmp_path / "a.csv", comment="#"), pd.read_csv(tmp_path / "b.csv", comment="#")
    pd.testing.assert_frame_equal(a, b)


@FAST
@given(off=st.floats(0.003, 0.8), sign=st.sampled_from([-1.0, 1.0]), base=st.sampled_from([6.0, 20.0]))
def test_a_speed_option_off_the_files_speed_is_refused_in_one_line(tmp_path, capsys, off, sign, base):
    """A --speed off the file's median by more than the tolerance (1 % at 20 m/s, 0.25 % at 6 m/s) is refused,
    naming both speeds; within it, accepted."""
    if off <= speed_tolerance(base) * 1.001:
        return
    file_kmh = 3.6 * base * (1.0 + sign * off)
    rec, _ = _record(tmp_path, file_kmh, name=f"r{base:g}.csv")
    code = main(["road", "reconstruct", str(rec), "--speed", f"{base:g}", "-o", str(tmp_path / "x.csv"),
                 "--overwrite"])
    err = capsys.readouterr().err.replace("\n", " ")
    assert code == 2 and f"--speed is {base:g} m/s" in err and "km/h" in err
    assert err.count("error:") == 1


@FAST
@given(frac=st.floats(-0.99, 0.99), base=st.sampled_from([6.0, 20.0]))
def test_a_file_speed_within_the_tolerance_picks_the_table1_model(frac, base):
    tol = speed_tolerance(base)
    chosen = choose_towing_speed(base * (1 + frac * tol), None, dx=0.05)
    assert chosen.speed == base and chosen.source == "file"


def test_a_file_speed_without_a_calibrated_model_is_refused():
    """The probe's sp_15 (steady 54 km/h) read at the default 20 m/s gave a 5.6 mm error; now it is refused."""
    from longprofile.errors import InputError

    with pytest.raises(InputError, match="towed at 54 km/h.*identify the trailer"):
        choose_towing_speed(15.0, None, dx=0.05, label="sp_15.csv")


def test_without_a_speed_column_the_default_stays_20_m_s():
    chosen = choose_towing_speed(None, None, dx=0.05)
    assert chosen.speed == 20.0 and chosen.source == "default"


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.5, 30.0, allow_nan=False), min_size=1, max_size=200), st.sampled_from([6.0, 20.0]))
def test_off_speed_ranges_are_exactly_the_samples_off_the_tolerance(v, model_speed):
    v = np.asarray(v)
    x = 0.05 * np.arange(v.size)
    check = check_speed_samples(x, v, model_speed)
    off = np.abs(v / model_speed - 1) > speed_tolerance(model_speed)
    np.testing.assert_array_equal(~check.ok, off)
    assert check.share == pytest.approx(off.mean())
    inside = np.zeros(v.size, bool)
    for a, b in check.ranges:
        inside |= (x >= a) & (x <= b)
    np.testing.assert_array_equal(inside, off)
    assert (check.warning is None) == (not off.any())


def test_stations_without_a_speed_lose_their_std_and_are_named(tmp_path, capsys):
    """A 20 m/s record whose speed column is empty over 100-150 m: std_m and raw_std_m are NaN there only, and the
    warning names the range and the share. (Stations towed off the tolerance are reconstructed at their own speed
    since 2026-12-07: tests/road/apl/test_varying_speed.py.)"""
    rec, plain = _record(tmp_path, 72.0, length=400.0, sim_speed=20.0)
    df = pd.read_csv(rec)
    x = df["distance_m"].to_numpy()
    df["Speed [km/h]"] = np.where((x >= 100) & (x <= 150), np.nan, 72.0)
    df.to_csv(rec, index=False)
    assert main(["road", "reconstruct", str(rec), "-o", str(tmp_path / "a.csv")]) == 0
    out = capsys.readouterr().err.replace("\n", " ")
    assert "100-150 m" in out and "12.5 %" in out
    a = pd.read_csv(tmp_path / "a.csv", comment="#")
    off = (x >= 100) & (x <= 150)
    assert a["std_m"][off].isna().all() and a["raw_std_m"][off].isna().all()
    assert a["std_m"][~off].notna().all()
    assert main(["road", "reconstruct", str(plain), "-o", str(tmp_path / "b.csv")]) == 0
    b = pd.read_csv(tmp_path / "b.csv", comment="#")
    np.testing.assert_array_equal(a["elevation_m"], b["elevation_m"])


def test_the_speed_column_is_read_in_metres_per_second(tmp_path):
    rec, _ = _record(tmp_path, 21.6, header="speed_kmh")
    assert read_apl_speed(rec).values == pytest.approx(6.0, rel=1e-12)


def test_trailer_at_its_own_speed_is_the_table1_model():
    for (v, dx) in TABLE1_CONFIGURATIONS:
        if v == 20.0:
            np.testing.assert_allclose(trailer_at_speed(20.0, dx).poles, apl_model(20.0, dx).poles, rtol=1e-12)
    # the 20 m/s trailer re-discretised at 6 m/s: Table 1's own 6 m/s pendulum modulus (0.9918) to 3e-4
    poles = trailer_at_speed(6.0, 0.05).poles
    pend = np.max(np.abs(poles[np.abs(np.angle(poles)) > 0]))
    assert pend == pytest.approx(0.9918, abs=3e-4)


def test_a_five_percent_speed_mismatch_is_an_error_far_outside_the_printed_std():
    """Why the mismatch is refused: a record towed 5 % faster than the model's 20 m/s, reconstructed with it, is
    wrong by more than twice the printed std (the same record at the right speed: within it)."""
    dx, length = 0.05, 1200.0
    road = iso8608_profile(length, dx, "C", rng=3)
    truth = road.elevation[:, 0]
    truth = np.asarray(detrend_profile(truth - truth[0], dx)).ravel()
    inner = (road.distance > 100) & (road.distance < length - 100)
    ratios = {}
    for towed in (apl_model(20.0, dx), trailer_at_speed(21.0, dx)):
        y = apl_response(road, towed).elevation[:, 0]
        y = y + np.random.default_rng(4).normal(0, 0.02 * np.std(y), y.size)
        rec = reconstruct_profile(y, apl_model(20.0, dx))
        err = rec.profile.elevation[:, 0] - truth
        ratios[towed.speed] = np.sqrt(np.mean(err[inner] ** 2)) / np.median(rec.profile.std[inner, 0])
    assert ratios[20.0] < 1.2 and ratios[21.0] > 2.0


def _plain(tmp_path, length=300.0):
    plain = tmp_path / "plain.csv"
    assert main(["road", "simulate", "--length", str(length), "--seed", "2", "-o", str(plain)]) == 0
    assert main(["road", "reconstruct", str(plain), "-o", str(tmp_path / "plain_out.csv")]) == 0
    return pd.read_csv(plain), pd.read_csv(tmp_path / "plain_out.csv", comment="#")


def test_a_time_sampled_record_without_distance_is_taken_at_every_dx(tmp_path, capsys):
    """The probe's v20 (time_s, speed_kmh, apl_mm; no distance) was refused for its missing distance_m; its distance is
    now the integral of the speed, and at a constant 72 km/h every 2.5 ms it is the distance-sampled record."""
    df, expected = _plain(tmp_path)
    timed = pd.DataFrame({"time_s": df["distance_m"] / 20.0, "speed_kmh": 72.0, "apl_mm": df["apl_m"] * 1e3})
    timed.to_csv(tmp_path / "timed.csv", index=False)
    assert main(["road", "reconstruct", str(tmp_path / "timed.csv"), "-o", str(tmp_path / "t.csv")]) == 0
    assert "time-sampled record" in capsys.readouterr().err
    got = pd.read_csv(tmp_path / "t.csv", comment="#")
    np.testing.assert_allclose(got["distance_m"], expected["distance_m"], atol=1e-9)
    np.testing.assert_allclose(got["elevation_m"], expected["elevation_m"], rtol=0, atol=1e-9)


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(at=st.integers(500, 5500), rows=st.integers(2, 400))
def test_a_stop_in_a_time_sampled_record_is_removed_and_named(tmp_path, capsys, at, rows):
    """The probe's sp_stop was refused ("distance must be strictly increasing"): the rows logged at a standstill (speed
    0, the same distance) are removed, the stop is named, and the rest is the record without the stop."""
    if not (tmp_path / "plain_out.csv").exists():
        _plain(tmp_path)
    df = pd.read_csv(tmp_path / "plain.csv")
    expected = pd.read_csv(tmp_path / "plain_out.csv", comment="#")
    rec = pd.DataFrame({"Time [s]": df["distance_m"] / 20.0, "Speed [km/h]": 72.0, "Distance [m]": df["distance_m"],
                        "APL [m]": df["apl_m"]})
    stop = pd.concat([rec.iloc[[at]]] * rows, ignore_index=True)
    stop["Speed [km/h]"] = 0.0
    stop["Time [s]"] = rec["Time [s]"][at] + 0.001 * np.arange(1, rows + 1)
    later = rec.iloc[at + 1:].copy()
    later["Time [s]"] += 0.001 * (rows + 1)
    pd.concat([rec.iloc[:at + 1], stop, later]).to_csv(tmp_path / "stop.csv", index=False)
    assert main(["road", "reconstruct", str(tmp_path / "stop.csv"), "--column", "APL [m]", "-o",
                 str(tmp_path / "s.csv"), "--overwrite"]) == 0
    assert f"stop(s) below 3.6 km/h removed (at {df['distance_m'][at]:.1f} m" in capsys.readouterr().err.replace(
        "\n", " ")
    got = pd.read_csv(tmp_path / "s.csv", comment="#")
    np.testing.assert_allclose(got["elevation_m"], expected["elevation_m"], rtol=0, atol=1e-9)


def test_a_time_sampled_record_sampled_coarser_than_dx_is_refused(tmp_path, capsys):
    df, _ = _plain(tmp_path)
    coarse = pd.DataFrame({"time_s": df["distance_m"] / 20.0, "speed_kmh": 72.0, "apl_m": df["apl_m"]}).iloc[::2]
    coarse.to_csv(tmp_path / "coarse.csv", index=False)
    assert main(["road", "reconstruct", str(tmp_path / "coarse.csv"), "-o", str(tmp_path / "c.csv")]) == 2
    assert "1.5 x --dx" in capsys.readouterr().err.replace("\n", " ")
    pd.DataFrame({"time_s": df["distance_m"] / 20.0, "apl_m": df["apl_m"]}).to_csv(tmp_path / "t.csv", index=False)
    assert main(["road", "reconstruct", str(tmp_path / "t.csv"), "-o", str(tmp_path / "c.csv")]) == 2
    assert "without a speed column nor a distance" in capsys.readouterr().err.replace("\n", " ")


def test_a_time_sampled_record_gets_the_recording_readers_signal_checks(tmp_path, capsys):
    """A time-sampled file is read by its own path: a logger's -9999 in its signal (interpolated as road before the
    mend) and metres under apl_mm are refused as in a distance-sampled recording."""
    df, _ = _plain(tmp_path)
    timed = pd.DataFrame({"time_s": df["distance_m"] / 20.0, "speed_kmh": 72.0, "apl_mm": df["apl_m"] * 1e3})
    timed.loc[100:120, "apl_mm"] = -9999.0
    timed.to_csv(tmp_path / "codes.csv", index=False)
    assert main(["road", "reconstruct", str(tmp_path / "codes.csv"), "-o", str(tmp_path / "c.csv")]) == 2
    assert "-9999" in capsys.readouterr().err
    timed["apl_mm"] = df["apl_m"]  # metres under a millimetre label
    timed.to_csv(tmp_path / "m_as_mm.csv", index=False)
    assert main(["road", "reconstruct", str(tmp_path / "m_as_mm.csv"), "-o", str(tmp_path / "c.csv")]) == 2
    assert "apl_m" in capsys.readouterr().err
    assert not (tmp_path / "c.csv").exists()


def test_the_probes_stop_record_is_right_where_it_is_vouched_for(tmp_path):
    """The probe's simulator (mk_speed.py: the 20 m/s model run at dt = 2.5 ms on the road at x(t)), decelerating at
    2 m/s^2 to a 10 s stop and back: before, dropping the stopped rows gave 6 mm of error over 700-1100 m with no
    sign of it. Session 39 flagged the off-speed samples (no std_m); since 2026-12-07 the record is reconstructed at
    each station's speed (docs/road-apl.md, "Varying towing speed"): std_m everywhere, and the band covers."""
    from longprofile.road.apl import apl_filter

    length, dt, dx = 1000.0, 0.0025, 0.05
    road = iso8608_profile(length + 20, 0.01, "C", rng=5)

    t = np.arange(int(80 / dt)) * dt
    v = np.interp(t, [0, 20, 30, 40, 50, 1e9], [20, 20, 0, 0, 20, 20])  # 2 m/s^2 down, 10 s stopped, up again
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    keep = x < length
    t, v, x = t[keep], v[keep], x[keep]
    y = np.asarray(apl_filter(apl_model(20.0, dx), np.interp(x, road.distance, road.elevation[:, 0])))
    y = y + np.random.default_rng(6).normal(0, 0.02 * np.std(y), y.size)
    pd.DataFrame({"time_s": t, "speed_m_s": v, "apl_m": y}).to_csv(tmp_path / "stop.csv", index=False)
    assert main(["road", "reconstruct", str(tmp_path / "stop.csv"), "-o", str(tmp_path / "o.csv")]) == 0
    out = pd.read_csv(tmp_path / "o.csv", comment="#")
    xo = out["distance_m"].to_numpy()
    tz = np.interp(xo, road.distance, road.elevation[:, 0])
    err = out["elevation_m"].to_numpy() - np.asarray(detrend_profile(tz - tz[0], dx)).ravel()
    inner = (xo > 100) & (xo < xo[-1] - 100)
    assert out["std_m"].notna().all()  # reconstructed at the file's 2.5 ms step, the stop's samples kept
    assert np.mean(np.abs(err[inner]) <= 1.645 * out["std_m"].to_numpy()[inner]) >= 0.85
    assert np.sqrt(np.mean(err[inner] ** 2)) < 0.6e-3


def test_batch_reconstruct_reads_the_speed_column_as_road_reconstruct_does(tmp_path):
    """`batch reconstruct` calls the same library functions (io.read_apl_record, road.apl.towing_speed): a 6 m/s
    record with its speed column is reconstructed at 6 m/s without --speed (it used the 20 m/s model: 60 times the
    error), and a --speed off the file's fails that file."""
    from longprofile.batch import ReconstructTask
    from longprofile.errors import InputError

    rec, plain = _record(tmp_path, 21.6)
    out = ReconstructTask()(rec)
    assert out.metadata["speed_m_per_s"] == pytest.approx(6.0)
    assert main(["road", "reconstruct", str(plain), "--speed", "6", "-o", str(tmp_path / "b.csv")]) == 0
    b = pd.read_csv(tmp_path / "b.csv", comment="#")
    np.testing.assert_array_equal(out.profile["elevation_m"].to_numpy(), b["elevation_m"].to_numpy())
    with pytest.raises(InputError, match="towed at 21.6 km/h"):
        ReconstructTask(speed=20.0)(rec)
    assert ReconstructTask()(plain).metadata["speed_m_per_s"] == 20.0  # no speed column: the default
