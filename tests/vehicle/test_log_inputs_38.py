"""A vehicle engineer's logs (session 38): the time column's faults named by cause, ISO and datetime64 times, the
500 Hz boundary, loggers' unit spellings, --rename, the resampling rate suggested and --fill hold."""

import math
import re

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile._validation import check_time_order, parse_column_renames, renamed_columns, time_seconds
from longprofile.cli.app import main
from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.vehicle import default_vehicle, read_drive_log, read_vertical_log, resample_log, simulate_drive

CAR = default_vehicle()
WHEELS = [f"wheel_speed_{w}" for w in ("fl", "fr", "rl", "rr")]


@pytest.fixture(scope="module")
def log100():
    """12 s of the paper drive at 100 Hz (every 10th sample of the 1 kHz simulation), SI channel names."""
    return simulate_drive("paper", seed=0).log.to_frame().iloc[:12000:10].reset_index(drop=True)


@pytest.fixture(scope="module")
def vertical_frame():
    from longprofile.vehicle import sensors_to_frame, vertical_test_run

    sim, sensors = vertical_test_run(3, duration=2.0, seed=0)
    return sensors_to_frame(sensors, sim)


def _same_log(a, b):
    np.testing.assert_allclose(a.wheel_speeds, b.wheel_speeds, rtol=1e-12)
    np.testing.assert_allclose(a.yaw_rate, b.yaw_rate, rtol=1e-12)
    assert a.dt == pytest.approx(b.dt, rel=1e-9)


# ------------------------------------------------------------------------------------------ 1. the time column

def _units_row(f):
    units = pd.DataFrame([["s", "rad"] + ["rad/s"] * 5 + ["m/s^2"] * 2], columns=f.columns)
    return pd.concat([units, f.astype(object)], ignore_index=True)


TIME_FAULTS = [
    ("duplicated samples", lambda f: pd.concat([f, f.iloc[[30, 31]]]).sort_index(kind="stable").reset_index(drop=True),
     r"row 31 repeats the time of row 30 \(0\.3 s; 2 row\(s\).*duplicated samples: drop the repeated rows, or "
     r"--resample"),
    ("logger reset", lambda f: f.assign(time=np.where(f.time >= 6.0, f.time - 6.0, f.time)),
     r"the time goes back from 5\.99 s to 0 s at row 600 \(a logger reset\? split the file there"),
    ("rows out of order", lambda f: f.iloc[[*range(50), 51, 50, *range(52, len(f))]].reset_index(drop=True),
     r"the time goes back from 0\.51 s to 0\.5 s at row 51 \(rows out of order: sort the file by time\)"),
    ("units row", _units_row,
     r"row 0 \(the first under the header\) holds text \('s', 'rad', 'rad/s', 'm/s\^2'\): a units row\? declare the "
     r"units in the header \(time \[s\]"),
    ("epoch saved with 6 digits", lambda f: f.assign(time=np.round(1717243200.0 + f.time, -1)),
     r"rounded to 10 s steps \(epoch seconds saved with 6 significant digits.*full precision\)"),
    ("float32 epoch", lambda f: f.assign(time=(1717243200.0 + f.time).astype("float32")),
     r"float32 epoch times lose the samples' timing \(at 1\.717243e\+09 s a float32 steps by 128 s\): write the time "
     r"as float64"),
    ("a text in the time", lambda f: f.assign(time=f.time.astype(object).where(f.index != 200, "12:00:02")),
     r"column 'time' holds '12:00:02' at row 200: neither a number of seconds nor an ISO 8601 date-time"),
    ("a blank time", lambda f: f.assign(time=f.time.where(f.index != 70)),
     r"column 'time' has no time at row 70"),
]


@pytest.mark.parametrize("name,fault,message", TIME_FAULTS, ids=[t[0] for t in TIME_FAULTS])
def test_each_time_fault_is_named_with_its_row_and_cause(log100, name, fault, message):
    """Before: every one of these was ``column 'time' must be finite and strictly increasing`` (no row, no cause)."""
    bad = fault(log100)
    with pytest.raises(InputFormatError, match=message):
        read_drive_log(bad, CAR)


def test_the_vertical_reader_names_the_same_time_faults(vertical_frame):
    f = vertical_frame.iloc[::2].reset_index(drop=True)  # 500 Hz
    reset = f.assign(time=np.where(f.time >= 1.0, f.time - 1.0, f.time))
    with pytest.raises(InputFormatError, match=r"the time goes back from 0\.998 s to 0 s at row 500 \(a logger reset"):
        read_vertical_log(reset)
    dup = pd.concat([f, f.iloc[[10]]]).sort_index(kind="stable").reset_index(drop=True)
    with pytest.raises(InputFormatError, match=r"row 11 repeats the time of row 10"):
        read_vertical_log(dup)


def test_exactly_repeated_rows_are_dropped_by_resampling_and_the_log_reads_as_the_clean_one(log100):
    dup = pd.concat([log100, log100.iloc[[30, 31, 500]]]).sort_index(kind="stable").reset_index(drop=True)
    got, _ = read_drive_log(dup, CAR, resample=100.0)
    ref, _ = read_drive_log(log100, CAR)
    _same_log(got, ref)
    other = dup.copy()
    other.loc[31, "yaw_rate"] += 0.01  # same time, another value: which one is right cannot be known
    with pytest.raises(InputFormatError, match=r"rows 30 and 31 have the same time \(0\.3 s\) but other values"):
        read_drive_log(other, CAR, resample=100.0)


@settings(max_examples=20, deadline=None)
@given(start=st.datetimes(min_value=pd.Timestamp("1990-01-01").to_pydatetime(),
                          max_value=pd.Timestamp("2090-01-01").to_pydatetime()),
       zone=st.sampled_from(["", "Z", "+02:00"]), sep=st.sampled_from(["T", " "]))
def test_iso_8601_times_read_as_seconds_from_the_first_sample(start, zone, sep):
    """Oracle: the ISO texts written by pandas from a known start and known offsets read back as those offsets."""
    offsets = np.arange(0, 2.0, 0.01)
    stamps = pd.Timestamp(start) + pd.to_timedelta(np.round(offsets * 1e9).astype("int64"), unit="ns")
    text = stamps.strftime(f"%Y-%m-%d{sep}%H:%M:%S.%f") + zone
    t, first = time_seconds(pd.DataFrame({"time": text}), "time")
    np.testing.assert_allclose(t, offsets, rtol=0, atol=1e-9)
    assert first == text[0]
    t64, _ = time_seconds(pd.DataFrame({"time": stamps}), "time")  # a Parquet datetime64 column
    np.testing.assert_allclose(t64, offsets, rtol=0, atol=1e-9)


def test_iso_and_datetime64_logs_give_the_relative_time_log(log100, tmp_path):
    ref, _ = read_drive_log(log100, CAR)
    start = pd.Timestamp("2024-06-01T12:00:00")
    stamps = start + pd.to_timedelta(log100.time * 1e9, unit="ns").dt.round("1ms")
    iso, _ = read_drive_log(log100.assign(time=stamps.dt.strftime("%Y-%m-%dT%H:%M:%S.%f")), CAR)
    _same_log(iso, ref)
    path = tmp_path / "dt.parquet"
    log100.assign(time=stamps).to_parquet(path)  # before: "median step 1.00001e+07 s ... milliseconds?"
    got, _ = read_drive_log(pd.read_parquet(path), CAR)
    _same_log(got, ref)
    mixed = log100.assign(time=stamps.dt.strftime("%Y-%m-%dT%H:%M:%S.%f"))
    mixed.loc[5, "time"] += "Z"
    with pytest.raises(InputFormatError, match="mixes date-times with a UTC offset"):
        read_drive_log(mixed, CAR)
    with pytest.raises(UnitsError, match="holds date-times .* the unit 'ms' declared for it does not apply"):
        read_drive_log(log100.assign(time=stamps), CAR, units={"time": "ms"})


def test_differentiate_names_the_time_fault_and_reads_iso_times(tmp_path, capsys):
    t = np.arange(500) * 0.01
    x = np.sin(t)
    pd.DataFrame({"time": np.r_[t[:100], t[99:]], "x": np.r_[x[:100], x[99:]]}).to_csv(tmp_path / "d.csv", index=False)
    assert main(["differentiate", str(tmp_path / "d.csv"), "-c", "x", "-w", "45", "-o", str(tmp_path / "o.csv")]) == 2
    assert "row 100 repeats the time of row 99 (0.99 s" in capsys.readouterr().err
    iso = (pd.Timestamp("2024-06-01") + pd.to_timedelta(t, unit="s")).strftime("%Y-%m-%dT%H:%M:%S.%f")
    pd.DataFrame({"time": iso, "x": x}).to_csv(tmp_path / "iso.csv", index=False)
    assert main(["differentiate", str(tmp_path / "iso.csv"), "-c", "x", "-w", "45", "-o", str(tmp_path / "i.csv")]) == 0
    assert "sample interval 0.01 s" in "".join(capsys.readouterr())


@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_check_time_order_accepts_exactly_the_strictly_increasing_times(data):
    """Property: no error iff every step is positive; an error names a row whose time is not after the one before."""
    steps = data.draw(st.lists(st.sampled_from([-5.0, -0.01, 0.0, 0.01, 0.01, 0.01, 0.02]), min_size=2, max_size=40))
    t = np.r_[0.0, np.cumsum(steps)]
    if all(s > 0 for s in steps):
        check_time_order(t)
        return
    with pytest.raises(InputFormatError, match=r"row (\d+)|distinct time") as exc:
        check_time_order(t)
    rows = [int(r) for r in re.findall(r"row (\d+)", str(exc.value))]
    if rows:
        assert t[rows[0]] <= t[rows[0] - 1]
    else:  # rounded time stamps: many repeats
        assert np.sum(np.diff(t) == 0) >= 0.3 * len(steps)


# ------------------------------------------------------------------------------------------ 2. 500 Hz exactly

def test_a_clean_500_hz_vertical_log_is_accepted_in_seconds_and_in_integer_milliseconds(vertical_frame):
    """Before: 'sample rate 500 Hz is below the 500 Hz' (1 / 0.0020000000000000018 < 500)."""
    f = vertical_frame.iloc[::2].reset_index(drop=True)
    f = f.assign(time=np.arange(len(f)) / 500.0)
    assert 1.0 / np.median(np.diff(f.time.to_numpy())) < 500.0  # the float step that was refused
    sensors, _ = read_vertical_log(f)
    assert sensors.dt == pytest.approx(0.002, rel=1e-12)
    ms, _ = read_vertical_log(f.assign(time=np.arange(len(f)) * 2).rename(columns={"time": "time_ms"}))
    assert ms.dt == pytest.approx(0.002, rel=1e-12)
    with pytest.raises(InputError, match="below the 500 Hz"):  # 499 Hz still refused
        read_vertical_log(f.assign(time=np.arange(len(f)) / 499.0))


# ------------------------------------------------------------------------------------------ 3. unit spellings

SPELLINGS = [
    # (column, header the logger writes, factor from SI to the logged value); [km/h], [rpm], _deg were read before
    ("wheel_speed_fl", "wheel_speed_fl_kph", 3.6 * CAR.wheel_radius_of_each[0]),
    ("wheel_speed_fl", "wheel_speed_fl_kmh", 3.6 * CAR.wheel_radius_of_each[0]),
    ("wheel_speed_fl", "wheel_speed_fl [kph]", 3.6 * CAR.wheel_radius_of_each[0]),
    ("wheel_speed_fl", "wheel_speed_fl [1/min]", 60 / (2 * math.pi)),
    ("yaw_rate", "yaw_rate_degps", 180 / math.pi),
    ("yaw_rate", "yaw_rate_deg_s", 180 / math.pi),
    ("yaw_rate", "yaw_rate [dps]", 180 / math.pi),
    ("yaw_rate", "yaw_rate [°/s]", 180 / math.pi),
    ("steering_angle", "steering_angle [°]", 180 / math.pi),
    ("accel_x", "accel_x_mps2", 1.0),
]


@pytest.mark.parametrize("column,header,factor", SPELLINGS, ids=[s[1] for s in SPELLINGS])
def test_loggers_unit_spellings_are_read_and_converted_back_exactly(log100, column, header, factor):
    ref, _ = read_drive_log(log100, CAR)
    got, _ = read_drive_log(log100.assign(**{column: log100[column] * factor}).rename(columns={column: header}), CAR)
    np.testing.assert_allclose(got.to_frame()[column], ref.to_frame()[column], rtol=1e-12, atol=1e-15)


def test_a_channel_with_an_unknown_unit_suffix_is_named_and_the_columns_listed(log100):
    bad = log100.rename(columns={"wheel_speed_fl": "wheel_speed_fl_kmph"})
    with pytest.raises(InputFormatError) as exc:
        read_drive_log(bad, CAR)
    text = str(exc.value)
    assert "missing channel(s) wheel_speed_fl (rad/s)" in text
    assert "column 'wheel_speed_fl_kmph' looks like wheel_speed_fl with the unit suffix 'kmph'" in text
    assert f"the file has {list(bad.columns)}" in text


# ------------------------------------------------------------------------------------------ 4. --rename

VECTOR = {"Time [s]": "time", "SteerAng_deg": "steering_angle", "WhlSpd_FL_kph": "wheel_speed_fl",
          "WhlSpd_FR_kph": "wheel_speed_fr", "WhlSpd_RL_kph": "wheel_speed_rl", "WhlSpd_RR_kph": "wheel_speed_rr",
          "YawRate_degps": "yaw_rate", "LongAccel_g": "accel_x", "LatAccel_g": "accel_y"}


def _vector_export(f):
    """The log as a Vector-style export: its own names, logger units, an extra channel."""
    R = CAR.wheel_radius_of_each
    out = pd.DataFrame({"Time [s]": f.time, "SteerAng_deg": np.degrees(f.steering_angle)})
    for w, r in zip(("FL", "FR", "RL", "RR"), R):
        out[f"WhlSpd_{w}_kph"] = f[f"wheel_speed_{w.lower()}"] * r * 3.6
    out["YawRate_degps"] = np.degrees(f.yaw_rate)
    out["LongAccel_g"], out["LatAccel_g"] = f.accel_x / 9.80665, f.accel_y / 9.80665
    out["EngSpd_rpm"] = 2000.0
    return out


def test_rename_maps_a_vector_export_to_the_channels_and_the_slope_is_the_si_logs(log100, tmp_path, capsys):
    _vector_export(log100).to_csv(tmp_path / "vector.csv", index=False)
    log100.to_csv(tmp_path / "si.csv", index=False)
    pairs = [f"{old}={VECTOR[old]}_{old.rsplit('_', 1)[1]}" for old in VECTOR if old != "Time [s]"]
    # the option repeated and comma-separated pairs: one meaning
    argv = ["vehicle", "slope", str(tmp_path / "vector.csv"), "-o", str(tmp_path / "v.csv"),
            "--rename", ",".join(pairs[:4])] + [a for p in pairs[4:] for a in ("--rename", p)]
    assert main(argv) == 0, capsys.readouterr().err
    assert main(["vehicle", "slope", str(tmp_path / "si.csv"), "-o", str(tmp_path / "s.csv")]) == 0
    a, b = pd.read_csv(tmp_path / "v.csv"), pd.read_csv(tmp_path / "s.csv")
    np.testing.assert_allclose(a.slope, b.slope, rtol=0, atol=1e-9)
    # a name the file does not have: refused, the file's columns listed; nothing written
    assert main(["vehicle", "slope", str(tmp_path / "vector.csv"), "-o", str(tmp_path / "x.csv"), "--rename",
                 "VehSpd=speed"]) == 2
    err = capsys.readouterr().err
    assert "--rename VehSpd=speed:" in err and "has no column named 'VehSpd'; its columns are ['Time [s]'" in err
    assert not (tmp_path / "x.csv").exists()


def test_rename_rules_match_road_convert(log100):
    assert parse_column_renames(["a=b,c=d", "e=f"]) == {"a": "b", "c": "d", "e": "f"}
    assert parse_column_renames("a=b") == {"a": "b"} and parse_column_renames(None) == {}
    for bad, message in [("a", "OLD=NEW pairs"), ("a=b,A=c", "names the column 'A' twice"),
                         ("a=x,b=X", "two columns the name")]:
        with pytest.raises(InputError, match=message):
            parse_column_renames(bad)
    f = renamed_columns(log100, {"YAW_RATE": "yaw_rate_degps"})  # any letter case
    assert "yaw_rate_degps" in f.columns
    with pytest.raises(InputError, match="already has a column 'accel_x'"):
        renamed_columns(log100, {"accel_y": "accel_x"})
    swapped = renamed_columns(log100, {"wheel_speed_fl": "wheel_speed_fr", "wheel_speed_fr": "wheel_speed_fl"})
    np.testing.assert_array_equal(swapped.wheel_speed_fl, log100.wheel_speed_fr)


def test_rename_reaches_the_vertical_reader_and_differentiate(vertical_frame, tmp_path, capsys):
    f = vertical_frame.iloc[::2].reset_index(drop=True)
    named = f.rename(columns={f"dz21_{c}": f"SuspDefl_{c}_mm" for c in ("FL", "FR", "RL", "RR")})
    for c in ("FL", "FR", "RL", "RR"):
        named[f"SuspDefl_{c}_mm"] *= 1000.0
    with pytest.raises(InputFormatError, match=r"missing channel\(s\) dz21_FL \(m\).*the file has \['time'"):
        read_vertical_log(named)
    got, _ = read_vertical_log(named, rename={f"SuspDefl_{c}_mm": f"dz21_{c}_mm" for c in ("FL", "FR", "RL", "RR")})
    ref, _ = read_vertical_log(f)
    np.testing.assert_allclose(got.displacement, ref.displacement, rtol=1e-12)
    t = np.arange(300) * 0.002
    pd.DataFrame({"Zeit": t, "Signal": np.sin(t)}).to_csv(tmp_path / "z.csv", index=False)
    assert main(["differentiate", str(tmp_path / "z.csv"), "-c", "x", "-w", "45", "-o", str(tmp_path / "o.csv"),
                 "--rename", "Zeit=time,Signal=x"]) == 0
    assert "sample interval 0.002 s (column 'time'" in "".join(capsys.readouterr())


# ------------------------------------------------------------------------------------------ 5. --resample

def test_the_suggested_rate_is_the_loggers_tick_and_upsampling_is_refused_with_its_reason(log100):
    rng = np.random.default_rng(1)
    keep = np.ones(len(log100), bool)
    keep[rng.choice(np.arange(10, len(log100) - 10), 12, replace=False)] = False  # 1 % of the samples lost
    dropped = log100[keep].reset_index(drop=True)
    assert round((len(dropped) - 1) / (dropped.time.iloc[-1] - dropped.time.iloc[0])) == 99  # the mean rate
    with pytest.raises(InputFormatError, match=r"--resample 100 \(Hz, the logger's tick"):
        read_drive_log(dropped, CAR)
    got, _ = read_drive_log(dropped, CAR, resample=100.0)
    assert got.dt == pytest.approx(0.01, rel=1e-9)
    with pytest.raises(InputError, match=r"--resample 1000 Hz is above the log's own 100 Hz.*upsampling"):
        read_drive_log(log100, CAR, resample=1000.0)
    half = resample_log(log100, 50.0)  # downsampling: a step of 2 input periods is no gap
    assert np.diff(half.time.to_numpy()).max() == pytest.approx(0.02, rel=1e-9)


# ------------------------------------------------------------------------------------------ 6. --fill hold

def _multirate(f):
    """Wheel speeds at 50 Hz blank between their samples (100 Hz rows), a 10 Hz GNSS channel the reader ignores."""
    g = f.copy()
    g.loc[g.index % 2 == 1, WHEELS] = np.nan
    g["gnss_speed"] = np.where(g.index % 10 == 0, 20.0, np.nan)
    return g


def test_fill_hold_reads_a_multi_rate_export_as_the_forward_filled_log(log100):
    mr = _multirate(log100)
    with pytest.raises(InputFormatError, match=r"column 'wheel_speed_fl' has a blank .* at row 1 \(600 of 1200 rows\)"
                                               r": a multi-rate export .*--fill hold"):
        read_drive_log(mr, CAR)
    got, _ = read_drive_log(mr, CAR, fill="hold")
    by_hand, _ = read_drive_log(mr.assign(**{w: mr[w].ffill() for w in WHEELS}), CAR)
    _same_log(got, by_hand)


def test_fill_hold_refuses_a_dropout_text_and_an_unknown_fill(log100):
    gap = log100.copy()
    gap.loc[100:120, "yaw_rate"] = np.nan  # 0.21 s: a dropout, not a slower channel
    with pytest.raises(InputFormatError, match=r"'yaw_rate' is blank for 0\.22 s from row 100.*longer than the 0\.1 s"):
        read_drive_log(gap, CAR, fill="hold")
    text = log100.astype({"yaw_rate": object})
    text.loc[7, "yaw_rate"] = "ERR"
    with pytest.raises(InputFormatError, match=r"'yaw_rate' holds 'ERR' at row 7: not a number; --fill hold fills "
                                               "blank cells only"):
        read_drive_log(text, CAR, fill="hold")
    with pytest.raises(InputError, match="--fill must be one of"):
        read_drive_log(log100, CAR, fill="linear")
    late = log100.copy()
    late.loc[:3, WHEELS] = np.nan  # the wheels start 0.04 s after the first row: those rows are dropped
    got, _ = read_drive_log(late, CAR, fill="hold")
    assert got.time[0] == pytest.approx(0.04) and got.time.size == len(log100) - 4


def test_a_float32_log_with_relative_times_reads_as_the_float64_one(log100):
    """A logger's float32 export of decimal times (0.01 s steps up to 12 s): each value read as the decimal it prints
    as, so the steps are uniform again (before: refused as 'not uniformly sampled', steps 1e-6 s apart)."""
    got, _ = read_drive_log(log100.astype("float32"), CAR)
    ref, _ = read_drive_log(log100, CAR)
    np.testing.assert_allclose(got.time, ref.time, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.yaw_rate, ref.yaw_rate, rtol=1e-6)
