"""Vehicle sensor logs (issue 14): declared units, conversion, resampling, unit/sign plausibility checks."""

import math
import re

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.vehicle import default_vehicle, estimate_slope, simulate_drive
from longprofile.vehicle._logs import (
    UNIT_FACTORS,
    check_drive_log,
    convert_units,
    infer_vertical_config,
    parse_units,
    read_drive_log,
    read_vertical_log,
    resample_log,
)

CAR = default_vehicle()
WHEELS = [f"wheel_speed_{w}" for w in ("fl", "fr", "rl", "rr")]


@pytest.fixture(scope="module")
def paper():
    """12 s of the paper-like drive (sine steering): excites the yaw, lateral and steering checks."""
    return simulate_drive("paper", seed=0).log.to_frame().iloc[:12000].reset_index(drop=True)


@pytest.fixture(scope="module")
def hill():
    """The hill drive (straight, accelerating then braking): excites the a_x check."""
    return simulate_drive("hill", seed=0).log.to_frame()


def test_correct_logs_pass_and_report_which_checks_ran(paper, hill):
    _, checks = read_drive_log(paper, CAR)
    by = {c.name: c for c in checks}
    assert by["yaw_rate_vs_wheels"].ok and abs(by["yaw_rate_vs_wheels"].ratio - 1) < 0.02
    assert by["accel_y_vs_vx_r"].ok and by["steering_vs_yaw_rate"].ok
    assert by["accel_x_vs_dvx"].ok is None  # constant speed: not excited, reported as not checked
    _, checks = read_drive_log(hill, CAR)
    by = {c.name: c for c in checks}
    assert by["accel_x_vs_dvx"].ok and by["yaw_rate_vs_wheels"].ok is None


def _wheels_times(frame, factor):
    g = frame.copy()
    for c in WHEELS:
        g[c] = g[c] * factor
    return g


# (name, transform of the SI log, text the error must contain)
MISTAKES = [
    ("yaw rate in deg/s", lambda f: f.assign(yaw_rate=np.degrees(f.yaw_rate)), "yaw_rate in deg/s"),
    ("SAE frame (z down, y right)", lambda f: f.assign(yaw_rate=-f.yaw_rate, accel_y=-f.accel_y),
     "yaw_rate of opposite sign"),
    ("y to the right (a_y only)", lambda f: f.assign(accel_y=-f.accel_y), "accel_y of opposite sign"),
    ("opposite steering sign", lambda f: f.assign(steering_angle=-f.steering_angle),
     "steering_angle has the opposite sign"),
    ("steering-wheel angle (ratio 15)", lambda f: f.assign(steering_angle=15 * f.steering_angle),
     "steering-WHEEL angle"),
    ("steering in degrees", lambda f: f.assign(steering_angle=np.degrees(f.steering_angle)), "steering_angle"),
    ("wheel speeds in km/h", lambda f: _wheels_times(f, CAR.wheel_radius * 3.6), "wheel speeds in km/h"),
    ("wheel speeds in m/s", lambda f: _wheels_times(f, CAR.wheel_radius), "wheel speeds in m/s"),
    ("wheel speeds in rpm", lambda f: _wheels_times(f, 60 / (2 * math.pi)), "rpm"),
    ("lateral acceleration in g", lambda f: f.assign(accel_y=f.accel_y / 9.80665), "accel_y in g"),
    ("time in ms", lambda f: f.assign(time=1000 * f.time), "time [ms]"),
]


@pytest.mark.parametrize("name,transform,message", MISTAKES, ids=[m[0] for m in MISTAKES])
def test_each_unit_or_sign_mistake_is_a_clear_error_naming_the_channel(paper, name, transform, message):
    with pytest.raises(UnitsError, match="implausible|time") as exc:
        read_drive_log(transform(paper), CAR, source="car.csv")
    assert message in str(exc.value) and str(exc.value).startswith("car.csv: ")


def test_longitudinal_acceleration_in_g_is_caught_on_an_accelerating_drive(hill):
    with pytest.raises(UnitsError, match=r"accel_x in g"):
        read_drive_log(hill.assign(accel_x=hill.accel_x / 9.80665), CAR)


DECLARED = [
    ("yaw_rate", "deg/s", lambda f: f.assign(yaw_rate=np.degrees(f.yaw_rate))),
    ("time", "ms", lambda f: f.assign(time=1000 * f.time)),
    ("accel_y", "g", lambda f: f.assign(accel_y=f.accel_y / 9.80665)),
    ("steering_angle", "deg", lambda f: f.assign(steering_angle=np.degrees(f.steering_angle))),
]


@pytest.mark.parametrize("col,unit,transform", DECLARED, ids=[d[0] for d in DECLARED])
def test_declared_units_are_converted_back_exactly(paper, col, unit, transform):
    ref, _ = read_drive_log(paper, CAR)
    g = transform(paper)
    via_header, _ = read_drive_log(g.rename(columns={col: f"{col} [{unit}]"}), CAR)
    via_parentheses, _ = read_drive_log(g.rename(columns={col: f"{col} ({unit})"}), CAR)  # as spreadsheets write it
    via_mapping, _ = read_drive_log(g, CAR, units={col: unit})
    via_suffix, _ = read_drive_log(g.rename(columns={col: f"{col}_{unit}"}), CAR)  # time_ms, as rail and differentiate
    for log in (via_header, via_parentheses, via_mapping, via_suffix):
        np.testing.assert_allclose(log.to_frame()[col], ref.to_frame()[col], rtol=1e-12, atol=1e-12)


def test_a_suffix_that_is_not_a_unit_is_not_read_as_one(paper):
    """Only ``<channel>_<unit of its quantity>`` declares a unit: wheel_speed_fl stays a channel, accel_x_mm (a length
    unit on an acceleration) is an unknown column, and time_ms beside time is left alone (two candidates)."""
    from longprofile.vehicle._logs import _PLANAR_QUANTITY, split_unit_headers

    f, declared = split_unit_headers(paper.rename(columns={"accel_x": "accel_x_mm"}), _PLANAR_QUANTITY)
    assert "accel_x_mm" in f.columns and "accel_x" not in declared and "wheel_speed_fl" in f.columns
    f, declared = split_unit_headers(paper.assign(time_ms=1000 * paper.time), _PLANAR_QUANTITY)
    assert {"time", "time_ms"} <= set(f.columns) and "time" not in declared


def test_wheel_speeds_in_kmh_declared_use_the_rolling_radius(paper):
    g = _wheels_times(paper, CAR.wheel_radius * 3.6)
    log, _ = read_drive_log(g, CAR, units=dict.fromkeys(WHEELS, "km/h"))
    np.testing.assert_allclose(log.wheel_speeds, paper[WHEELS].to_numpy(), rtol=1e-12)


@settings(max_examples=30, deadline=None)
@given(q=st.sampled_from(["time", "angle", "rate", "accel", "length"]), data=st.data(),
       values=st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=20))
def test_conversion_multiplies_by_the_documented_factor(q, data, values):
    unit = data.draw(st.sampled_from(sorted(UNIT_FACTORS[q])))
    frame = pd.DataFrame({"c": values})
    out = convert_units(frame, {"c": unit}, {"c": q})
    np.testing.assert_allclose(out["c"], np.asarray(values) * UNIT_FACTORS[q][unit], rtol=1e-15, atol=0)
    assert frame["c"].tolist() == values  # the input is not modified


def test_unknown_unit_or_channel_is_a_units_error(paper):
    with pytest.raises(UnitsError, match=r"unknown unit 'furlong/s'.*rad/s, deg/s, rpm"):
        read_drive_log(paper, CAR, units={"yaw_rate": "furlong/s"})
    with pytest.raises(UnitsError, match="not a channel of this log"):
        read_drive_log(paper, CAR, units={"speed": "km/h"})
    with pytest.raises(InputError, match="column=unit pairs"):
        parse_units("yaw_rate:deg/s")
    assert parse_units("time=ms, yaw_rate = deg/s") == {"time": "ms", "yaw_rate": "deg/s"}


def test_jitter_is_refused_with_the_resample_hint_and_resampling_recovers_the_estimate(paper):
    rng = np.random.default_rng(0)
    g = paper.assign(time=paper.time + rng.uniform(-2e-4, 2e-4, len(paper)))  # 0.2 ms timestamp jitter
    with pytest.raises(InputFormatError, match=r"not uniformly sampled.*--resample 1000 "):
        read_drive_log(g, CAR)
    log, _ = read_drive_log(g, CAR, resample=1000.0)
    assert log.dt == pytest.approx(1e-3, rel=1e-9)
    ref, _ = read_drive_log(paper, CAR)
    a, b = estimate_slope(log, CAR), estimate_slope(ref, CAR)
    n = min(a.time.size, b.time.size)
    err = np.degrees(np.sqrt(np.mean((a.slope[2000:n] - b.slope[2000:n]) ** 2)))
    assert err < 0.01  # degrees; measured 0.0006 on the 40 s drive


def test_unix_time_stamps_are_not_jitter(paper):
    """A logger's Unix time stamps (1.7e9 s at 1 kHz): float64 rounding alone moves each step by up to +-2.4e-7 s,
    which the uniformity check refused as jitter. Accepted now, and the slope is the relative-time log's; a real
    jitter of 0.2 ms on top is still refused."""
    unix = paper.assign(time=paper.time + 1.7e9)
    assert np.ptp(np.diff(unix.time.to_numpy())) > 1e-7  # the rounding is there
    log, _ = read_drive_log(unix, CAR)
    ref, _ = read_drive_log(paper, CAR)
    a, b = estimate_slope(log, CAR), estimate_slope(ref, CAR)
    np.testing.assert_allclose(a.slope, b.slope, rtol=0, atol=1e-6)  # rad; dt from rounded steps: 1e-4 relative
    rng = np.random.default_rng(0)
    with pytest.raises(InputFormatError, match="not uniformly sampled"):
        read_drive_log(unix.assign(time=unix.time + rng.uniform(-2e-4, 2e-4, len(unix))), CAR)


def test_resampling_refuses_gaps():
    t = np.r_[np.arange(0, 1, 1e-3), np.arange(1.1, 2, 1e-3)]
    with pytest.raises(InputFormatError, match=r"gap of 0.1.* at t = 0.999"):
        resample_log(pd.DataFrame({"time": t, "x": t}), 1000.0)
    with pytest.raises(InputError, match="positive number of Hz"):
        resample_log(pd.DataFrame({"time": t, "x": t}), 0.0)


def test_check_can_return_instead_of_raising(paper):
    from longprofile.vehicle import DriveLog

    bad = DriveLog.from_frame(paper.assign(steering_angle=-paper.steering_angle))
    checks = check_drive_log(bad, CAR, raise_on_error=False)
    assert {c.name: c.ok for c in checks}["steering_vs_yaw_rate"] is False


# ------------------------------------------------------------------------------------------ vertical logs

@pytest.fixture(scope="module")
def vertical_frame():
    from longprofile.vehicle import sensors_to_frame, vertical_test_run

    sim, sensors = vertical_test_run(3, duration=3.0, seed=0)
    return sensors_to_frame(sensors, sim)


def test_vertical_config_is_inferred_from_the_columns(vertical_frame):
    assert infer_vertical_config(vertical_frame.columns) == 3
    body = vertical_frame.rename(columns=lambda c: c.replace("wheel_accel", "body_accel"))
    assert infer_vertical_config(body.columns) == 2
    assert infer_vertical_config(vertical_frame.drop(columns=[c for c in vertical_frame if "accel_" in c])) == 1
    both = pd.concat([vertical_frame, body.filter(like="body_accel")], axis=1)
    with pytest.raises(InputError, match="both body_accel"):
        infer_vertical_config(both.columns)
    sensors, config = read_vertical_log(vertical_frame)
    assert config == 3 and sensors.wheel_accel is not None


def test_vertical_log_in_mm_is_refused_unless_declared(vertical_frame):
    dz = [f"dz21_{c}" for c in ("FL", "FR", "RL", "RR")]
    g = vertical_frame.copy()
    g[dz] = 1000 * g[dz]
    with pytest.raises(UnitsError, match=r"dz21_\*.*in mm"):
        read_vertical_log(g)
    sensors, _ = read_vertical_log(g, units=dict.fromkeys(dz, "mm"))
    np.testing.assert_allclose(sensors.displacement, vertical_frame[dz].to_numpy(), rtol=1e-12)


def test_vertical_log_at_100_hz_is_refused(vertical_frame):
    with pytest.raises(InputError, match=r"sample rate 100 Hz is below the 500 Hz"):
        read_vertical_log(vertical_frame.iloc[::10].reset_index(drop=True))


_CASES = st.sampled_from([str.upper, str.lower, str.title, str.swapcase, str])


@settings(max_examples=15, deadline=None)
@given(data=st.data())
def test_channel_names_are_read_in_any_letter_case(paper, vertical_frame, data):
    # a spreadsheet that capitalises the header ('Time', 'ACCEL_X', 'dz21_fl', 'Yaw_Rate [deg/s]') reads as the
    # original; before 2026-12-06 every such channel was "missing"
    def recase(frame):
        return frame.rename(columns={c: data.draw(_CASES)(c) for c in frame.columns})

    ref, _ = read_drive_log(paper, CAR)
    g = paper.assign(yaw_rate=np.degrees(paper["yaw_rate"])).rename(columns={"yaw_rate": "yaw_rate [deg/s]"})
    log, _ = read_drive_log(recase(g), CAR)
    np.testing.assert_allclose(log.to_frame().to_numpy(), ref.to_frame().to_numpy(), rtol=1e-12, atol=1e-15)
    vref, config = read_vertical_log(vertical_frame)
    vlog, vconfig = read_vertical_log(recase(vertical_frame))
    assert vconfig == config
    for name in ("time", "displacement", "ax", "ay", "yaw_rate", "body_accel", "wheel_accel"):
        a, b = getattr(vref, name), getattr(vlog, name)
        assert (a is None) == (b is None) and (a is None or np.array_equal(a, b)), name


def test_two_columns_differing_only_in_case_are_not_merged(paper):
    g = paper.assign(TIME=paper["time"]).rename(columns={"time": "Time"})
    with pytest.raises(InputFormatError, match="missing channel"):
        read_drive_log(g, CAR)


def test_a_vertical_log_with_unix_time_stamps_gives_the_relative_time_estimate(vertical_frame):
    """Unix time stamps (1.7e9 s) on a 1 kHz vertical log: accepted (float rounding is not jitter) and, the step being
    the mean step end to end, the corner EKFs give the relative-time log's states exactly (with the median of the
    rounded steps, 7e-5 off, the disturbance estimates moved by up to 30 % of their range)."""
    from longprofile.vehicle import estimate_vertical_log

    frame = vertical_frame
    unix = frame.assign(time=frame["time"] + 1.7e9)
    assert np.ptp(np.diff(unix["time"].to_numpy())) > 1e-7
    a, _ = read_vertical_log(frame, 3)
    b, _ = read_vertical_log(unix, 3)
    assert b.dt == pytest.approx(a.dt, rel=1e-9)
    ea, eb = estimate_vertical_log(a).estimate, estimate_vertical_log(b).estimate
    for f in ("vehicle_disturbance", "tyre_force", "suspension_velocity"):
        np.testing.assert_allclose(getattr(eb, f), getattr(ea, f), rtol=1e-9, atol=1e-9)


# ------------------------------------------------------------------------------------------ unit patterns (session 37)

def test_a_wildcard_units_key_gives_its_unit_to_every_channel_it_matches(paper, vertical_frame):
    g = _wheels_times(paper, CAR.wheel_radius * 3.6).assign(accel_x=paper.accel_x / 9.80665,
                                                            accel_y=paper.accel_y / 9.80665)
    explicit, _ = read_drive_log(g, CAR, units={**dict.fromkeys(WHEELS, "km/h"), "accel_x": "g", "accel_y": "g"})
    for units in (parse_units("wheel_speed_*=km/h,accel_?=g"), parse_units("WHEEL_SPEED_[fr][lr]=km/h,accel_*=g")):
        log, _ = read_drive_log(g, CAR, units=units)
        np.testing.assert_array_equal(log.to_frame().to_numpy(), explicit.to_frame().to_numpy())
    dz = [f"dz21_{c}" for c in ("FL", "FR", "RL", "RR")]
    mm = vertical_frame.assign(**{c: 1000 * vertical_frame[c] for c in dz})
    sensors, _ = read_vertical_log(mm, units=parse_units("dz21_*=mm"))
    np.testing.assert_allclose(sensors.displacement, vertical_frame[dz].to_numpy(), rtol=1e-12)


def test_an_explicit_units_key_beats_a_wildcard_and_a_pattern_matching_nothing_is_refused(paper):
    g = _wheels_times(paper, CAR.wheel_radius * 3.6).assign(wheel_speed_rr=paper.wheel_speed_rr)
    log, _ = read_drive_log(g, CAR, units={"wheel_speed_*": "km/h", "wheel_speed_rr": "rad/s"})
    np.testing.assert_allclose(log.wheel_speeds, paper[WHEELS].to_numpy(), rtol=1e-12)
    with pytest.raises(UnitsError, match=r"pattern 'speed_\*' matches no channel of this log"):
        read_drive_log(paper, CAR, units={"speed_*": "km/h"})
    with pytest.raises(UnitsError, match=r"'wheel_speed_fl' matches the unit patterns .* declare it explicitly"):
        read_drive_log(paper, CAR, units={"wheel_speed_*": "km/h", "wheel_speed_f?": "m/s"})
    # the header's unit is overridden by --units as before, a pattern included
    log, _ = read_drive_log(_wheels_times(paper, 60 / (2 * math.pi)).rename(columns={"wheel_speed_fl":
                                                                                    "wheel_speed_fl [km/h]"}),
                            CAR, units={"wheel_speed_*": "rpm"})
    np.testing.assert_allclose(log.wheel_speeds, paper[WHEELS].to_numpy(), rtol=1e-12)


#: A declaration a message suggests: ``--units 'key=unit,...'``, ``--units key=unit`` or a header ``'name [unit]'``.
_SUGGESTION = re.compile(r"--units '(?P<quoted>[^']+)'|--units (?P<bare>[^\s']+?)(?=[.;,)]?(?:\s|$))"
                         r"|'(?P<name>[^'\[\]]+?) \[(?P<unit>[^\]]+)\]'")
#: Errors that refuse the declaration itself (as opposed to the log it reads).
_REFUSED = ("unknown unit", "not a channel", "matches no channel", "unit patterns", "column=unit pairs")


def _apply(frame, message, reader):
    """Read ``frame`` with each declaration ``message`` suggests: a list of True (the log then reads) or False (the
    declaration is accepted, the log still fails a check, e.g. a suggestion for another cause)."""
    outcomes = []
    for m in _SUGGESTION.finditer(message):
        try:
            if m["name"]:
                assert m["name"] in frame.columns, f"a header suggested for a column the log lacks: {m[0]!r}"
                reader(frame.rename(columns={m["name"]: f"{m['name']} [{m['unit']}]"}))
            else:
                reader(frame, units=parse_units(m["quoted"] or m["bare"]))
            outcomes.append(True)
        except (UnitsError, InputError) as exc:
            assert not any(r in str(exc) for r in _REFUSED), f"suggested {m[0]!r}, refused: {exc}"
            outcomes.append(False)
    return outcomes


@pytest.mark.parametrize("name,transform,message", MISTAKES, ids=[m[0] for m in MISTAKES])
def test_every_declaration_an_error_suggests_is_accepted(paper, name, transform, message):
    g = transform(paper)
    with pytest.raises(UnitsError) as exc:
        read_drive_log(g, CAR)
    outcomes = _apply(g, str(exc.value), lambda f, **kw: read_drive_log(f, CAR, **kw))
    if " in " in name:  # a unit mistake: one of the declarations suggested reads the log
        assert any(outcomes), f"no working declaration suggested for {name}: {exc.value}"


def test_the_vertical_log_suggestions_are_accepted(vertical_frame):
    from longprofile.vehicle import estimate_vertical_log

    dz = [f"dz21_{c}" for c in ("FL", "FR", "RL", "RR")]
    g = vertical_frame.assign(**{c: 1000 * vertical_frame[c] for c in dz})
    with pytest.raises(UnitsError) as exc:
        read_vertical_log(g)
    assert _apply(g, str(exc.value), lambda f, **kw: read_vertical_log(f, **kw))[0]  # --units 'dz21_*=mm' reads it
    acc = [f"wheel_accel_{c}" for c in ("FL", "FR", "RL", "RR")]
    g = vertical_frame.assign(**{c: vertical_frame[c] / 9.80665 for c in acc})
    with pytest.raises(UnitsError) as exc:  # session 40: refused (the opt-out turns it into the warning)
        estimate_vertical_log(read_vertical_log(g)[0])
    (warning,) = [w for w in estimate_vertical_log(read_vertical_log(g)[0], accept="wheel_accel_unit").warnings()
                  if "in g" in w]
    assert warning in str(exc.value)
    units = re.search(r"--units '([^']+)'", warning)[1]
    sensors, _ = read_vertical_log(g, units=parse_units(units))
    np.testing.assert_allclose(sensors.wheel_accel, vertical_frame[acc].to_numpy(), rtol=1e-12)


@pytest.mark.parametrize("column, unit", [("steering_angle", "furlong"), ("yaw_rate", "furlong/s"),
                                          ("accel_x", "gee"), ("time", "h"), ("wheel_speed_fl", "mph")])
def test_the_unknown_unit_message_uses_the_right_article(paper, column, unit):
    with pytest.raises(UnitsError, match="unknown unit") as exc:
        read_drive_log(paper, CAR, units={column: unit})
    article, word = re.search(r"for (an?) (\w+)", str(exc.value)).groups()
    assert (article == "an") == (word[0] in "aeiou"), str(exc.value)


def test_one_export_feeds_both_readers_accelerations_by_either_name(paper, vertical_frame):
    """Session 37: the planar log names the body's accelerations accel_x/accel_y, the vertical log ax/ay; a CAN
    export with one naming had to be renamed by hand for the other command. Each reader now takes the other name
    (with its header unit, or a --units key of either name) when its own is absent."""
    ref, _ = read_drive_log(paper, CAR)
    g = paper.assign(accel_x=paper.accel_x / 9.80665).rename(columns={"accel_x": "ax [g]", "accel_y": "AY"})
    log, _ = read_drive_log(g, CAR)
    np.testing.assert_allclose(log.accel_x, ref.accel_x, rtol=1e-12)
    np.testing.assert_array_equal(log.accel_y, ref.accel_y)
    via_key, _ = read_drive_log(paper.assign(accel_x=paper.accel_x / 9.80665).rename(columns={"accel_x": "ax"}),
                                CAR, units={"accel_x": "g"})
    np.testing.assert_allclose(via_key.accel_x, ref.accel_x, rtol=1e-12)

    sensors_ref, config = read_vertical_log(vertical_frame)
    v = vertical_frame.rename(columns={"ax": "accel_x", "ay": "accel_y"})
    sensors, config2 = read_vertical_log(v.assign(accel_y=v.accel_y / 9.80665), units={"ay": "g"})
    assert config2 == config
    np.testing.assert_array_equal(sensors.ax, sensors_ref.ax)
    np.testing.assert_allclose(sensors.ay, sensors_ref.ay, rtol=1e-12)
    # a log with both names keeps its own channel (the other column is ignored, as any unknown column)
    both, _ = read_vertical_log(vertical_frame.assign(accel_x=vertical_frame.ax + 1.0))
    np.testing.assert_array_equal(both.ax, sensors_ref.ax)


@pytest.mark.parametrize("wheel", WHEELS)
@pytest.mark.parametrize("fault", ["zero", "frozen", "slow"])
def test_a_dead_wheel_speed_sensor_is_named(paper, wheel, fault):
    """A wheel speed sensor that does not turn while the others do is named as such (it was blamed on staggered
    tyres, "the front one is about 0.598 m", or on units)."""
    bad = paper.copy()
    bad[wheel] = {"zero": 0.0, "frozen": float(bad[wheel].iloc[0]), "slow": 0.05 * bad[wheel]}[fault]
    with pytest.raises(InputFormatError, match=rf"{wheel} (stays at|reads below 10 %).*dead, disconnected or frozen"):
        read_drive_log(bad, CAR)


@pytest.mark.parametrize("scenario", ["paper", "hill", "low-mu"])
def test_no_dead_wheel_on_clean_drives(scenario):
    """Braking, wheel spin and locking on the built-in scenarios (low-mu included) are not a dead sensor."""
    for seed in range(3):
        check_drive_log(simulate_drive(scenario, seed=seed).log, CAR, raise_on_error=True)
