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
    r = pd.concat([small.readings, small.readings.iloc[[10]]], ignore_index=True)
    with pytest.raises(InputError, match="duplicate reading for sensor"):
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


def test_survey_must_cover_the_sensors(small):
    sv = small.survey[small.survey["x_m"] < 100]
    with pytest.raises(InputError, match="survey table covers x = 0..9.*lie outside.*extend the survey"):
        validate_site(small.sensors, small.readings, sv)


def test_missing_columns_and_bad_values(small):
    with pytest.raises(InputFormatError, match=r"readings table: missing column\(s\) \['temperature_c'\]"):
        validate_site(small.sensors, small.readings.drop(columns="temperature_c"), small.survey)
    s = small.sensors.copy().astype({"x_m": object})
    s.loc[2, "x_m"] = "abc"
    with pytest.raises(InputFormatError, match="sensors table, row 2: column 'x_m'"):
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
    s = small.sensors.assign(z_m=1.0)
    site = validate_site(s, r, small.survey)
    assert any("2 reading(s) have an empty angle or temperature" in w for w in site.warnings)
    assert any("survey is used" in w for w in site.warnings)
    alone = validate_site(s, small.readings, None)
    assert any("initial profile is the sensors' z_m column" in w for w in alone.warnings)


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
