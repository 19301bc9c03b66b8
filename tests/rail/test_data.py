"""Site tables: reading CSV / Parquet, validation errors and explicit warnings."""

import numpy as np
import pandas as pd
import pytest

from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.io import read_rail_site
from longprofile.rail import simulate_site, validate_site


@pytest.fixture(scope="module")
def small():
    return simulate_site("mittersheim-like", seed=3, sampling_minutes=60, n_days=4)


def test_csv_and_parquet_give_the_same_site(small, tmp_path):
    r = small.readings.copy()
    small.sensors.to_parquet(tmp_path / "s.parquet")
    r.to_parquet(tmp_path / "r.parquet")
    small.survey.to_parquet(tmp_path / "v.parquet")
    small.sensors.to_csv(tmp_path / "s.csv", index=False)
    r["timestamp"] = pd.to_datetime(r["timestamp"]).dt.strftime("%Y-%m-%dT%H:%M:%S")
    r.to_csv(tmp_path / "r.csv", index=False)
    small.survey.to_csv(tmp_path / "v.csv", index=False)
    a = read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv")
    b = read_rail_site(tmp_path / "s.parquet", tmp_path / "r.parquet", tmp_path / "v.parquet")
    assert a.sensor_ids == b.sensor_ids
    assert np.allclose(a.readings["angle_deg"], b.readings["angle_deg"])
    assert (a.readings["timestamp"].to_numpy() == b.readings["timestamp"].to_numpy()).all()
    assert a.warnings == ()
    # the old domain name is a deprecated alias of the io reader (file reading is an edge, issue 12)
    import longprofile.rail as rail

    with pytest.warns(DeprecationWarning, match="read_rail_site"):
        c = rail.read_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv")
    pd.testing.assert_frame_equal(c.readings, a.readings)


def test_unknown_sensor_ids_are_an_error(small):
    r = small.readings.copy()
    r.loc[5, "sensor_id"] = "S99"
    with pytest.raises(InputError, match=r"not in the sensors table, e.g. \['S99'\]"):
        validate_site(small.sensors, r, small.survey)


def test_duplicate_timestamps_are_an_error(small):
    r = pd.concat([small.readings, small.readings.iloc[[10]].assign(angle_deg=lambda d: d.angle_deg + 0.01)],
                  ignore_index=True)
    with pytest.raises(InputError, match="two different readings for sensor") as one:
        validate_site(small.sensors, r, small.survey)
    assert "daylight-saving" not in str(one.value)
    # a logger in local time when the clock goes back: every sensor repeats the hour 02:00-03:00
    ts = pd.to_datetime(small.readings["timestamp"])
    t3 = ts.min().normalize() + pd.Timedelta(days=2, hours=3)
    r = small.readings.assign(timestamp=ts.where(ts < t3, ts - pd.Timedelta(hours=1)))
    with pytest.raises(InputError, match="daylight-saving change"):
        validate_site(small.sensors, r, small.survey)


def test_unsorted_timestamps_are_sorted_with_a_warning(small):
    r = small.readings.iloc[::-1].reset_index(drop=True)
    site = validate_site(small.sensors, r, small.survey)
    assert any("not in time order" in w and "sorted" in w for w in site.warnings)
    ref = validate_site(small.sensors, small.readings, small.survey)
    assert np.array_equal(site.readings["angle_deg"].to_numpy(), ref.readings["angle_deg"].to_numpy())


def test_radians_by_mistake_are_detected(small):
    r = small.readings.copy()
    r["angle_deg"] = np.deg2rad(r["angle_deg"])
    with pytest.raises(UnitsError, match="look like radians.*angle_unit='rad'"):
        validate_site(small.sensors, r, small.survey)
    site = validate_site(small.sensors, r, small.survey, angle_unit="rad")
    ref = validate_site(small.sensors, small.readings, small.survey)
    assert np.allclose(site.readings["angle_deg"], ref.readings["angle_deg"])
    assert validate_site(small.sensors, r, small.survey, check_units=False).readings["angle_deg"].abs().max() < 0.1
    with pytest.raises(UnitsError, match="'deg' or 'rad'"):
        validate_site(small.sensors, small.readings, small.survey, angle_unit="grad")


def test_readings_outside_their_plausible_range_are_refused(small):
    """One reading beyond an angle from level or a rail temperature: refused with the sensor and time (no outlier
    removal of a value no instrument gives)."""
    for col, value, match in (("angle_deg", 1e300, "angle_deg = 1e\\+300, outside the plausible -90..90"),
                              ("temperature_c", 285.0, "temperature_c = 285.*kelvin")):
        r = small.readings.copy()
        r.loc[7, col] = value
        with pytest.raises(UnitsError, match=match):
            validate_site(small.sensors, r, small.survey)


@pytest.mark.parametrize(("scale", "unit", "match"), [(1.0, "rad", "are the angles degrees"),
                                                       (1000.0, "deg", "millidegrees")])
def test_angles_far_from_level_are_another_unit(small, scale, unit, match):
    """Degrees declared as radians (the issue's 14.5 mm of 'settlement' on quiet days), millidegrees under angle_deg:
    the sensors then read a median tens of degrees from level (track_angle); check_units=False lets them through."""
    from longprofile.rail import MAX_TRACK_ANGLE_DEG, track_angle

    r = small.readings.copy()
    assert track_angle(r) < 2.0  # the simulator's sensors: within a degree or two of level
    r["angle_deg"] = scale * r["angle_deg"]
    if scale > 1:  # millidegrees: keep each reading inside the row range, so the site-level test is the one refusing
        r = r[r.groupby("sensor_id")["angle_deg"].transform(lambda a: a.abs().max()) < 90]
    with pytest.raises(UnitsError, match=match):
        validate_site(small.sensors, r, small.survey, angle_unit=unit)
    site = validate_site(small.sensors, r, small.survey, angle_unit=unit, check_units=False)
    assert track_angle(site.readings) > MAX_TRACK_ANGLE_DEG


def test_survey_in_millimetres_is_refused(small):
    """Altitudes beyond any terrain; relative altitudes whose grade is x 1000; stations in mm."""
    sv = small.survey.copy()
    sv["z_m"] *= 1000.0
    with pytest.raises(UnitsError, match="survey table: altitude z_m = .* beyond any terrain"):
        validate_site(small.sensors, small.readings, sv)
    rel = small.survey.copy()
    rel["z_m"] = (rel["z_m"] - rel["z_m"].iloc[0]) * 1000.0  # relative levels, in mm
    with pytest.raises(UnitsError, match="grade.*millimetres"):
        validate_site(small.sensors, small.readings, rel)
    xs = small.survey.copy()
    xs["x_m"] *= 1000.0
    with pytest.raises(UnitsError, match="stations in millimetres"):
        validate_site(small.sensors, small.readings, xs)


def test_a_long_line_survey_around_a_short_site_is_accepted(small):
    """A survey of 20 km every 10 m around the site (points among the sensors): not taken for millimetres."""
    x = small.sensors["x_m"].to_numpy()
    sx = np.arange(-10_000.0, 10_000.0 + x[-1], 10.0)
    sv = pd.DataFrame({"x_m": sx, "z_m": 200.0 + 1e-3 * sx})
    assert validate_site(small.sensors, small.readings, sv).warnings == ()


def test_survey_rows_out_of_order_are_sorted_with_a_warning(small):
    sv = small.survey.iloc[::-1].reset_index(drop=True)
    site = validate_site(small.sensors, small.readings, sv)
    assert any("not in order of x_m" in w and "mistyped station" in w for w in site.warnings)
    ref = validate_site(small.sensors, small.readings, small.survey)
    pd.testing.assert_frame_equal(site.survey, ref.survey)


def _controls(small, change_m):
    x = small.survey["x_m"].to_numpy()[::5]
    z = np.interp(x, small.survey["x_m"], small.survey["z_m"]) + change_m
    return pd.DataFrame({"date": "2019-11-20", "x_m": x, "z_m": z})


def test_controls_in_another_unit_or_datum_are_refused(small):
    ok = _controls(small, -0.03)  # a 30 mm settlement: a plausible control
    assert validate_site(small.sensors, small.readings, small.survey, ok).controls is not None
    mm = ok.assign(z_m=ok["z_m"] * 1000.0)
    with pytest.raises(UnitsError, match="controls table: altitude z_m .* beyond any terrain"):
        validate_site(small.sensors, small.readings, small.survey, mm)
    datum = _controls(small, -210.0)  # relative levels against the survey's absolute ones
    with pytest.raises(UnitsError, match="-210 m from the initial survey.*datum"):
        validate_site(small.sensors, small.readings, small.survey, datum)


def test_survey_must_cover_the_sensors(small):
    sv = small.survey[small.survey["x_m"] < 100]
    with pytest.raises(InputError, match="survey table covers x = 0..9.*lie outside.*extend the survey"):
        validate_site(small.sensors, small.readings, sv)


def test_missing_columns_and_bad_values(small):
    with pytest.raises(InputFormatError, match=r"readings table: missing column\(s\) \['temperature_c'\]"):
        validate_site(small.sensors, small.readings.drop(columns="temperature_c"), small.survey)
    s = small.sensors.copy().astype({"x_m": object})
    s.loc[2, "x_m"] = "abc"
    with pytest.raises(InputFormatError, match=r"sensors table, row 2 \(CSV line 4\): column 'x_m'"):
        validate_site(s, small.readings, small.survey)
    with pytest.raises(InputError, match="no initial altitude"):
        validate_site(small.sensors, small.readings, None)
    s2 = small.sensors.copy()
    s2.loc[1, "x_m"] = s2.loc[0, "x_m"]
    with pytest.raises(InputError, match="same station"):
        validate_site(s2, small.readings, small.survey)


def test_sensors_without_readings_are_reported(small):
    r = small.readings[small.readings["sensor_id"] != "S05"]
    site = validate_site(small.sensors, r, small.survey)
    assert any("no readings at all" in w and "S05" in w for w in site.warnings)


def test_empty_values_and_ignored_columns_are_reported(small):
    r = small.readings.copy()
    r.loc[[3, 4], "temperature_c"] = np.nan
    r.loc[[5], "angle_deg"] = np.nan
    s = small.sensors.assign(z_m=1.0)
    site = validate_site(s, r, small.survey)
    # the two temperatures are filled from the neighbours (test_temperature_fill.py); the empty angle is not used
    assert any("2 reading(s) of" in w and "no usable temperature" in w for w in site.warnings)
    assert any("1 reading(s) have an empty angle or temperature" in w for w in site.warnings)
    kept = validate_site(s, r, small.survey, temperature_fill=False)
    assert any("3 reading(s) have an empty angle or temperature" in w for w in kept.warnings)
    assert any("survey is used" in w for w in site.warnings)
    alone = validate_site(s, small.readings, None)
    assert any("initial profile is the sensors' z_m column" in w for w in alone.warnings)


def test_a_failed_temperature_channel_is_named(small):
    """Without the fill (``temperature_fill=False``) a sensor whose angles all come without a temperature loses every
    reading: the warning names it as a likely failed temperature channel (not only a count), and the health tests
    say why it is dead."""
    from longprofile.rail import estimate_settlement

    r = small.readings.copy()
    r.loc[r["sensor_id"] == "S07", "temperature_c"] = np.nan
    r.loc[[3], "temperature_c"] = np.nan  # one empty value elsewhere is not a failed channel
    site = validate_site(small.sensors, r, small.survey, temperature_fill=False)  # not filled (the default fills)
    msg = [w for w in site.warnings if "empty angle or temperature" in w]
    assert len(msg) == 1 and "never a temperature" in msg[0] and "['S07']" in msg[0]
    res = estimate_settlement(site, n_monte_carlo=0)
    j = res.sensor_ids.index("S07")
    assert res.health.status[j] == "dead" and "angle and a temperature" in res.health.detail[j]
    assert not any("never a temperature" in w for w in validate_site(small.sensors, small.readings,
                                                                      small.survey).warnings)


def test_angle_noise_decides_only_on_enough_differences():
    """One difference of a degree sensor can be below the radian threshold by chance: no decision on it."""
    from longprofile.rail import RADIAN_NOISE_THRESHOLD, angle_noise
    from longprofile.rail._data import MIN_NOISE_DIFFERENCES

    rng = np.random.default_rng(3)
    n = MIN_NOISE_DIFFERENCES
    few = pd.DataFrame({"sensor_id": ["S1", "S1"], "angle_deg": [0.1, 0.1 + 1e-5]})  # 1e-5 deg apart
    assert np.isnan(angle_noise(few))
    deg = pd.DataFrame({"sensor_id": ["S1"] * (n + 1), "angle_deg": 0.1 + 2.5e-3 * rng.standard_normal(n + 1)})
    assert angle_noise(deg) > RADIAN_NOISE_THRESHOLD
    rad = deg.assign(angle_deg=np.deg2rad(deg["angle_deg"]))
    assert angle_noise(rad) < RADIAN_NOISE_THRESHOLD


_DECLARED = {  # canonical column -> (header with another unit, values in that unit from the canonical ones)
    "x_m": [("x_mm", lambda v: v * 1e3), ("X [ft]", lambda v: v / 0.3048)],
    "angle_deg": [("angle_rad", np.deg2rad), ("Angle (mrad)", lambda v: 1e3 * np.deg2rad(v))],
    "temperature_c": [("temperature_f", lambda v: v * 9 / 5 + 32), ("temperature [K]", lambda v: v + 273.15)],
}


@pytest.mark.parametrize(("col", "k"), [(c, k) for c in _DECLARED for k in range(2)])
def test_a_column_declared_in_another_unit_is_converted(small, tmp_path, col, k):
    # x_mm, angle_rad, temperature_f... were "missing column"; converted, the site is the canonical one
    name, to_unit = _DECLARED[col][k]
    tables = {"s": small.sensors.copy(), "r": small.readings.copy(), "v": small.survey}
    key = "s" if col == "x_m" else "r"
    tables[key] = tables[key].assign(**{name: to_unit(tables[key][col].to_numpy(float))}).drop(columns=[col])
    for t, frame in tables.items():
        frame.to_csv(tmp_path / f"{t}.csv", index=False)
    small.sensors.to_csv(tmp_path / "s0.csv", index=False)
    small.readings.to_csv(tmp_path / "r0.csv", index=False)
    got = read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv")
    ref = read_rail_site(tmp_path / "s0.csv", tmp_path / "r0.csv", tmp_path / "v.csv")
    np.testing.assert_allclose(got.x, ref.x, rtol=1e-12)
    for c in ("angle_deg", "temperature_c"):
        np.testing.assert_allclose(got.readings[c], ref.readings[c], rtol=1e-12, atol=1e-12)


def test_an_angle_unit_contradicting_the_header_is_refused(small, tmp_path):
    r = small.readings.assign(angle_mrad=1e3 * np.deg2rad(small.readings["angle_deg"])).drop(columns=["angle_deg"])
    small.sensors.to_csv(tmp_path / "s.csv", index=False)
    r.to_csv(tmp_path / "r.csv", index=False)
    small.survey.to_csv(tmp_path / "v.csv", index=False)
    with pytest.raises(UnitsError, match="'angle_mrad' declares its unit \\(mrad\\); leave out --angle-unit rad"):
        read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv", angle_unit="rad")
    r.assign(angle_rad=1.0).to_csv(tmp_path / "r.csv", index=False)
    with pytest.raises(InputFormatError, match="give the angle once"):
        read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv")


def test_a_wide_readings_table_is_refused_with_how_to_reshape_it(small, tmp_path):
    """A logger's export with one column per sensor whose columns are not the sensors' ids: the refusal says it looks
    wide, how to name its columns and how to make it long (with the sensors' ids and angles only: the temperature is
    asked for, tests/rail/test_wide_readings.py); a long table with a misnamed column keeps the missing-column
    message."""
    small.sensors.to_csv(tmp_path / "s.csv", index=False)
    small.survey.to_csv(tmp_path / "v.csv", index=False)
    small.readings.pivot(index="timestamp", columns="sensor_id", values="angle_deg").add_prefix("ch_").reset_index(
    ).to_csv(tmp_path / "r.csv", index=False)
    with pytest.raises(InputFormatError, match=r"one column per sensor \(a wide table\)\? Name each column after a "
                                               r"sensor id.*melt"):
        read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv")
    small.readings.rename(columns={"sensor_id": "sensor"}).to_csv(tmp_path / "r.csv", index=False)
    with pytest.raises(InputFormatError, match=r"missing column\(s\) \['sensor_id'\]"):
        read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv")


def test_a_loggers_missing_value_marker_is_an_empty_cell(small, tmp_path):
    """"NAN" (Campbell Scientific loggers), "#N/A", "null"... in temperature_c are empty temperatures (filled from the
    neighbours), not a refusal of the whole file; the same marker under an angle is an empty angle; a sentinel such as
    -9999 is refused with a hint that it looks like a missing-value code."""
    r = small.readings.copy()
    r["temperature_c"] = r["temperature_c"].astype(object)
    ids = sorted(r["sensor_id"].unique())
    for sid, marker in zip(ids[1:5], ("NAN", "#N/A", "null", " nan ")):
        r.loc[r["sensor_id"] == sid, "temperature_c"] = marker
    small.sensors.to_csv(tmp_path / "s.csv", index=False)
    small.survey.to_csv(tmp_path / "v.csv", index=False)
    r.to_csv(tmp_path / "r.csv", index=False)
    site = read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv")
    assert any("no usable temperature" in w and "4 sensor(s)" in w for w in site.warnings)
    assert site.readings["temperature_c"].notna().all()  # all filled
    r["angle_deg"] = r["angle_deg"].astype(object)
    r.loc[r.index[:3], "angle_deg"] = "NAN"
    r.to_csv(tmp_path / "r.csv", index=False)
    site = read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv")
    assert any("3 reading(s) have an empty angle or temperature" in w for w in site.warnings)
    r.loc[r.index[:3], "angle_deg"] = small.readings["angle_deg"].iloc[:3]
    r.loc[r["sensor_id"] == ids[1], "temperature_c"] = -9999
    r.to_csv(tmp_path / "r.csv", index=False)
    with pytest.raises(UnitsError, match="a logger's code for a missing value"):
        read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv")
