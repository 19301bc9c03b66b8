"""A railway track engineer's own logger exports (session 39, a probe of ``rail settle``): the command line's checks in
its own terms, thresholds in metres under value_mm, angle units of inclinometer vendors (arcsec, mm/m, µrad, %),
temperature headers, thresholds with units and capitals, date and time in two columns, km+m chainages, exact
duplicate rows, local times across the spring clock change, and angles-only loggers with ``--thermal none``."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.cli.app import main
from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.io import read_rail_site, read_rail_table, read_rail_thresholds
from longprofile.rail import THRESHOLD_FLOORS_M, check_threshold, simulate_site, validate_site


@pytest.fixture(scope="module")
def syn():
    return simulate_site("mittersheim-like", seed=4, sampling_minutes=60, n_days=6)


@pytest.fixture(scope="module")
def site_dir(syn, tmp_path_factory):
    d = tmp_path_factory.mktemp("site")
    syn.sensors.to_csv(d / "sensors.csv", index=False)
    syn.readings.to_csv(d / "readings.csv", index=False)
    syn.survey.to_csv(d / "survey.csv", index=False)
    return d


def _settle(site_dir, capsys, *extra, readings=None, out="out.csv"):
    """``rail settle`` on the site (``readings`` replacing its readings file): (exit code, stderr, output path)."""
    path = site_dir.parent / f"{site_dir.name}-{out}"
    if path.exists():
        path.unlink()
    argv = ["rail", "settle", "--sensors", str(site_dir / "sensors.csv"), "--readings",
            str(readings or site_dir / "readings.csv"), "--survey", str(site_dir / "survey.csv"), "--monte-carlo", "0",
            "-o", str(path), *extra]
    capsys.readouterr()
    code = main(argv)
    return code, " ".join(capsys.readouterr().err.split()), path


# ---- 3, 17: the options' checks, in the command line's terms -------------------------------------------------

@pytest.mark.parametrize(("args", "expected"), [
    (["--quiet-day", "08/12/2019"], "--quiet-day 08/12/2019: not a date written YYYY-MM-DD (day/month or month/day?)"),
    (["--quiet-day", "yesterday"], "--quiet-day yesterday: not a date written YYYY-MM-DD"),
    (["--alarm-probability", "50"], "--alarm-probability 50: must be a probability in (0, 1]"),
    (["--settlement-threshold-mm", "-5"], "--settlement-threshold-mm -5: must be a number > 0"),
    (["--settlement-threshold-mm", "0.01"], "--settlement-threshold-mm 0.01: below 0.5 mm"),
    (["--rate-threshold-mm-per-day", "0.003"], "--rate-threshold-mm-per-day 0.003: below 0.05 mm/day"),
    (["--sigma-deg", "-1"], "--sigma-deg -1: must be a number > 0"),
    (["--sigma-z", "0"], "--sigma-z 0: must be a number > 0"),
    (["--thermal", "linaer"], "--thermal linaer: not known; use one of auto, linear, lagged, none"),
])
def test_a_bad_option_is_named_with_its_value_as_typed(site_dir, capsys, args, expected):
    code, err, out = _settle(site_dir, capsys, *args)
    assert code == 2 and expected in err and err.count("error:") == 1 and not out.exists()
    for library in ("min_probability", "quiet_days", "got -0.005", "0.01745", "sigma_z"):
        assert library not in err


def test_a_quiet_day_outside_the_record_is_refused_naming_the_record(site_dir, capsys):
    """It used to switch the thermal correction off without a word (no day of the fit was quiet)."""
    code, err, out = _settle(site_dir, capsys, "--quiet-day", "2018-01-01")
    assert code == 2 and "--quiet-day 2018-01-01: outside the record (2019-11-18 to 2019-11-23" in err
    assert not out.exists()


# ---- 5: thresholds in metres under value_mm --------------------------------------------------------------------

def test_thresholds_in_metres_under_value_mm_are_refused(tmp_path):
    f = tmp_path / "thr.csv"
    f.write_text("quantity,level,value_mm\nsettlement,alert,0.010\nsettlement,action,0.015\nrate,alert,0.003\n")
    with pytest.raises(InputFormatError, match=r"row 1: settlement alert 0.01 mm is below 0.5 mm.*metres under "
                                               r"value_mm\?"):
        read_rail_thresholds(f)
    f.write_text("quantity,level,value_mm\nrate,alert,0.003\n")
    with pytest.raises(InputFormatError, match=r"rate alert 0.003 mm/day is below 0.05 mm/day"):
        read_rail_thresholds(f)


@given(mm=st.floats(0.5, 1000.0), kind=st.sampled_from(["settlement", "twist"]))
def test_every_track_limit_in_mm_is_plausible_and_the_same_in_metres_read_as_mm_is_not(mm, kind):
    """A limit of 0.5 mm to 1 m is taken; the same number of metres read as millimetres (x 1e-3 in m: 0.5 um to 1 mm)
    is refused below 0.5 m (every real limit), so no threshold in metres slips through."""
    assert check_threshold(mm * 1e-3, kind) == mm * 1e-3
    if mm < 500.0:
        with pytest.raises(InputError, match="not plausible"):
            check_threshold(mm * 1e-6, kind)
    assert THRESHOLD_FLOORS_M[kind] == 5e-4


def test_rate_limits_down_to_a_mm_a_fortnight_are_plausible_and_a_hundredth_of_a_mm_a_day_is_not():
    assert check_threshold(1e-3 / 14, "rate") == pytest.approx(1e-3 / 14)
    for v in (3e-6, 2e-5):  # 0.003 m/day read as mm/day; 0.02 mm/day, far below the estimate's resolution
        with pytest.raises(InputError, match="not plausible"):
            check_threshold(v, "rate")


# ---- 14: thresholds with a unit in the value column, capitals ----------------------------------------------------

@pytest.mark.parametrize(("header", "values", "alert_m"), [
    ("quantity,level,value_m", ("0.010", "0.015"), 0.010), ("quantity,level,value_cm", ("1", "1.5"), 0.010),
    ('quantity,level,value (mm)', ("10", "15"), 0.010), ("quantity,level,value_in", ("0.4", "0.6"), 0.4 * 0.0254),
    ("Quantity,Level,Value_mm", ("10", "15"), 0.010)])
def test_thresholds_take_the_value_unit_and_any_letter_case(tmp_path, header, values, alert_m):
    f = tmp_path / "thr.csv"
    f.write_text(f"{header}\nSettlement,Alert,{values[0]}\nSETTLEMENT,action,{values[1]}\n")
    got = read_rail_thresholds(f)
    assert got["settlement"]["alert"] == pytest.approx(alert_m)
    assert got["settlement"]["action"] == pytest.approx(alert_m * 1.5)


def test_a_thresholds_value_without_a_unit_is_refused(tmp_path):
    f = tmp_path / "thr.csv"
    f.write_text("quantity,level,value\nsettlement,alert,10\n")
    with pytest.raises(InputFormatError, match="no value column"):
        read_rail_thresholds(f)


# ---- 7: angle units ---------------------------------------------------------------------------------------------

#: header -> the value a vendor writes for an angle a (deg): the oracle is the unit's definition (math, not our table)
VENDOR_ANGLES = {
    "angle (arcsec)": lambda a: a * 3600.0,
    "angle (mm/m)": lambda a: 1e3 * math.tan(math.radians(a)),
    "tilt_mm_per_m": lambda a: 1e3 * math.tan(math.radians(a)),
    "angle [µrad]": lambda a: 1e6 * math.radians(a),
    "angle (%)": lambda a: 100.0 * math.tan(math.radians(a)),
    "Angle [arcmin]": lambda a: 60.0 * a,
    "angle_mrad": lambda a: 1e3 * math.radians(a),
}


@settings(max_examples=30, deadline=None)
@given(header=st.sampled_from(sorted(VENDOR_ANGLES)), angles=st.lists(st.floats(-10.0, 10.0), min_size=1, max_size=5))
def test_vendor_angle_units_are_read_as_degrees(tmp_path_factory, header, angles):
    f = tmp_path_factory.mktemp("a") / "r.csv"
    pd.DataFrame({"timestamp": "2019-11-18 00:00:00", "sensor_id": [f"S{i}" for i in range(len(angles))],
                  header: [repr(VENDOR_ANGLES[header](a)) for a in angles], "temperature_c": 5.0}).to_csv(f, index=False)
    got = read_rail_table(f, "readings")["angle_deg"].to_numpy()
    assert np.allclose(got, angles, rtol=1e-12, atol=1e-12)


def test_an_unknown_angle_unit_is_named_with_the_known_ones(tmp_path):
    f = tmp_path / "r.csv"
    f.write_text("timestamp,sensor_id,angle (gon),temperature_c\n2019-11-18 00:00,S1,1.0,5\n")
    with pytest.raises(UnitsError, match=r"unit 'gon' not known; known: deg, mdeg, rad, mrad, urad, arcmin, arcsec"):
        read_rail_table(f, "readings")


@pytest.mark.parametrize("axes", [("angle_x", "angle_y"), ("Angle [X]", "Angle [Y]"), ("tilt_1", "tilt_2")])
def test_a_biaxial_loggers_axes_are_named_as_such(tmp_path, axes):
    """A biaxial inclinometer's two axes (angle_x, angle_y) got "unit 'x' not known" only: the message now says what
    they are and which one to keep (the probe's leftover, session 39)."""
    f = tmp_path / "r.csv"
    f.write_text(f"timestamp,sensor_id,{axes[0]},{axes[1]},temperature_c\n2019-11-18 00:00,S1,0.1,0.2,5\n")
    with pytest.raises(UnitsError, match=r"one axis of a biaxial inclinometer: keep the axis along the track"):
        read_rail_table(f, "readings")


# ---- 13: temperature headers; the missing-column message in the file's own words ---------------------------------

@pytest.mark.parametrize(("header", "scale", "offset"), [
    ("Temperature [°C]", 1.0, 0.0), ("temperature [°F]", 1.8, 32.0), ("temperature (degC)", 1.0, 0.0),
    ("Temp_C", 1.0, 0.0), ("temperature_K", 1.0, 273.15)])
def test_temperature_headers_of_loggers_are_read(tmp_path, header, scale, offset):
    f = tmp_path / "r.csv"
    pd.DataFrame({"Timestamp": ["2019-11-18 00:00", "2019-11-18 01:00"], "Sensor ID": ["S1", "S1"],
                  "Angle [deg]": [0.1, 0.2], header: [c * scale + offset for c in (-3.0, 21.5)]}).to_csv(f, index=False)
    r = read_rail_table(f, "readings")
    assert np.allclose(r["temperature_c"], [-3.0, 21.5]) and list(r["sensor_id"]) == ["S1", "S1"]


def test_a_missing_column_is_named_with_the_files_own_headers(tmp_path):
    f = tmp_path / "r.csv"
    f.write_text("Timestamp,Sensor ID,Angle [deg],Celsius\n2019-11-18 00:00,S1,0.1,5\n")
    with pytest.raises(InputFormatError, match=r"missing column\(s\) \['temperature_c'\].*the file's columns are "
                                               r"\['Timestamp', 'Sensor ID', 'Angle \[deg\]', 'Celsius'\]"):
        read_rail_table(f, "readings")


# ---- 18: date and time in two columns ------------------------------------------------------------------------

def test_date_and_time_columns_are_joined(syn, tmp_path):
    t = pd.to_datetime(syn.readings["timestamp"])
    f = tmp_path / "r.csv"
    syn.readings.drop(columns="timestamp").assign(date=t.dt.strftime("%Y-%m-%d"), time=t.dt.strftime("%H:%M:%S")
                                                  ).to_csv(f, index=False)
    got = validate_site(syn.sensors, read_rail_table(f, "readings"), syn.survey)
    ref = validate_site(syn.sensors, syn.readings, syn.survey)
    pd.testing.assert_frame_equal(got.readings, ref.readings)


# ---- 15: km+m chainages ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("column", ["chainage", "x_m", "Station"])
def test_a_km_plus_m_chainage_is_read_in_metres(tmp_path, column):
    f = tmp_path / "s.csv"
    f.write_text(f"sensor_id,{column}\nS1,12+345.600\nS2,12+348.566\nS3,13+000\n")
    assert np.allclose(read_rail_table(f, "sensors")["x_m"], [12345.6, 12348.566, 13000.0])
    f.write_text(f"sensor_id,{column}\nS1,12+345.600\nS2,12348.566\nS3,13+000\n")
    with pytest.raises(InputFormatError, match=r"station '12348.566' is not in km\+m like the other rows"):
        read_rail_table(f, "sensors")


# ---- 11: exact duplicate rows ---------------------------------------------------------------------------------

def test_exact_duplicates_are_dropped_with_a_count_and_conflicting_ones_refused(syn):
    r = syn.readings
    twice = pd.concat([r, r.iloc[100:150]], ignore_index=True)  # two downloads overlapping by 50 readings
    site = validate_site(syn.sensors, twice, syn.survey)
    assert any(w.startswith("50 reading(s) repeated exactly") for w in site.warnings)
    pd.testing.assert_frame_equal(site.readings, validate_site(syn.sensors, r, syn.survey).readings)
    other = pd.concat([r, r.iloc[[7]].assign(temperature_c=lambda d: d.temperature_c + 1.0)], ignore_index=True)
    with pytest.raises(InputError, match=f"two different readings for sensor '{r['sensor_id'][7]}'"):
        validate_site(syn.sensors, other, syn.survey)


# ---- 19: local times across the spring clock change ------------------------------------------------------------

def _spring_local(syn) -> pd.DataFrame:
    """The readings moved to 2020-03-26.. (UTC) and written as Paris local times without an offset."""
    t = pd.to_datetime(syn.readings["timestamp"]) + (pd.Timestamp("2020-03-26") - pd.Timestamp("2019-11-18"))
    local = t.dt.tz_localize("UTC").dt.tz_convert("Europe/Paris").dt.tz_localize(None)
    return syn.readings.assign(timestamp=local.dt.strftime("%Y-%m-%d %H:%M:%S"))


def test_local_times_across_the_spring_change_are_refused_like_the_autumn_ones(syn):
    local = _spring_local(syn)
    with pytest.raises(InputFormatError, match=r"jump by one hour more than their interval at 2020-03-29 03:00:00.*"
                                               r"--timezone"):
        validate_site(syn.sensors, local, syn.survey)
    site = validate_site(syn.sensors, local, syn.survey, timezone="Europe/Paris")
    utc = pd.to_datetime(syn.readings["timestamp"]) + (pd.Timestamp("2020-03-26") - pd.Timestamp("2019-11-18"))
    assert site.readings["timestamp"].min() == utc.min() and site.readings["timestamp"].max() == utc.max()
    validate_site(syn.sensors, local, syn.survey, timezone="UTC")  # the user's word: UTC with a gap


def test_a_gap_on_a_weekday_is_not_a_clock_change(syn):
    """The guard of the test above (no false refusal): an hour missing on a Wednesday night is a logger outage."""
    r = syn.readings
    t = pd.to_datetime(r["timestamp"])
    gap = (t >= pd.Timestamp("2019-11-20 02:00")) & (t < pd.Timestamp("2019-11-20 03:00"))  # a Wednesday
    validate_site(syn.sensors, r[~gap.to_numpy()], syn.survey)


# ---- 9: angles-only loggers with --thermal none -------------------------------------------------------------------

def test_angles_only_readings_with_thermal_none(site_dir, syn, capsys, tmp_path):
    notemp, empty = tmp_path / "notemp.csv", tmp_path / "empty.csv"
    syn.readings.drop(columns="temperature_c").to_csv(notemp, index=False)
    syn.readings.assign(temperature_c="").to_csv(empty, index=False)
    code, err, out = _settle(site_dir, capsys, readings=notemp)
    assert code == 2 and "(an angles-only logger? thermal='none', CLI --thermal none" in err
    code, err, a = _settle(site_dir, capsys, "--thermal", "none", readings=notemp, out="a.csv")
    assert code == 0 and "the readings have no temperature" in err
    code, err, b = _settle(site_dir, capsys, "--thermal", "none", readings=empty, out="b.csv")
    assert code == 0, err
    pd.testing.assert_frame_equal(pd.read_csv(a, comment="#"), pd.read_csv(b, comment="#"))
    # the same as one constant temperature with --thermal none: no temperature is what it reads
    const = tmp_path / "const.csv"
    syn.readings.assign(temperature_c=12.5).to_csv(const, index=False)
    code, err, c = _settle(site_dir, capsys, "--thermal", "none", readings=const, out="c.csv")
    assert code == 0
    pd.testing.assert_frame_equal(pd.read_csv(a, comment="#"), pd.read_csv(c, comment="#"))


def test_read_rail_site_without_temperature_only_when_asked(site_dir, tmp_path):
    r = pd.read_csv(site_dir / "readings.csv").drop(columns="temperature_c")
    r.to_csv(tmp_path / "r.csv", index=False)
    with pytest.raises(InputFormatError, match="missing column"):
        read_rail_site(site_dir / "sensors.csv", tmp_path / "r.csv", site_dir / "survey.csv")
    site = read_rail_site(site_dir / "sensors.csv", tmp_path / "r.csv", site_dir / "survey.csv",
                          require_temperature=False)
    assert (site.readings["temperature_c"] == 0.0).all() and site.readings["angle_deg"].notna().all()


def test_a_sensor_id_header_with_a_blank_keeps_the_ids_as_text(tmp_path):
    f = tmp_path / "s.csv"
    f.write_text("Sensor ID,x_m\n007,0\nNA,1.5\n12,3\n")
    assert list(read_rail_table(f, "sensors")["sensor_id"]) == ["007", "NA", "12"]
