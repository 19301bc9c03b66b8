"""Wide logger exports (one row per time, one column per sensor, or an angle and a temperature column per sensor) read
by ``rail settle --readings`` as the long table they hold, then checked as a long one: a site written long and wide
(any column order, any supported unit spellings) gives the same SiteData and the same settlement; ambiguous layouts
get one clear line (a track engineer's probe, session 39)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.cli.app import main
from longprofile.errors import InputFormatError, UnitsError
from longprofile.io import read_rail_site
from longprofile.rail import simulate_site

#: unit -> degrees to that unit, from the units' definitions (not from the reader's table)
ANGLE_FROM_DEG = {"deg": lambda a: a, "rad": np.deg2rad, "mrad": lambda a: 1e3 * np.deg2rad(a),
                  "µrad": lambda a: 1e6 * np.deg2rad(a), "arcsec": lambda a: 3600.0 * a, "arcmin": lambda a: 60.0 * a,
                  "mdeg": lambda a: 1e3 * a, "mm/m": lambda a: 1e3 * np.tan(np.deg2rad(a)),
                  "%": lambda a: 1e2 * np.tan(np.deg2rad(a)), "°": lambda a: a}
TEMPERATURE_FROM_C = {"c": lambda t: t, "°C": lambda t: t, "degC": lambda t: t, "f": lambda t: 32.0 + 1.8 * t,
                      "°F": lambda t: 32.0 + 1.8 * t, "K": lambda t: t + 273.15}
ANGLE_NAMES = ("{s}_angle_{u}", "{s} Angle [{u}]", "{s} tilt ({u})", "{s}-inclination_{u}")
TEMPERATURE_NAMES = ("{s}_temperature_{u}", "{s} Temp [{u}]", "{s}.temp ({u})")


@pytest.fixture(scope="module")
def syn():
    return simulate_site("mittersheim-like", seed=7, sampling_minutes=120, n_days=5)


def _wide(readings, sensor_ids, rng, *, temperatures=True, drop=0.0):
    """The readings as a wide table: per sensor an angle column and a temperature column in random units and
    spellings (a plain ``S01`` / ``S01_temp`` now and then), in random column order, ``drop`` of the sensors' readings
    left empty (the long table's rows removed likewise). Returns (wide, long)."""
    r = readings.copy()
    if drop:
        r = r[rng.random(len(r)) >= drop].reset_index(drop=True)
    a = r.pivot(index="timestamp", columns="sensor_id", values="angle_deg")
    t = r.pivot(index="timestamp", columns="sensor_id", values="temperature_c")
    cols = {}
    for sid in sensor_ids:
        if rng.random() < 0.2:
            cols[sid] = a[sid].to_numpy()
        else:
            u = rng.choice(list(ANGLE_FROM_DEG))
            cols[rng.choice(ANGLE_NAMES).format(s=sid, u=u)] = ANGLE_FROM_DEG[u](a[sid].to_numpy())
        if not temperatures:
            continue
        if rng.random() < 0.2:
            cols[f"{sid}_temp"] = t[sid].to_numpy()
        else:
            u = rng.choice(list(TEMPERATURE_FROM_C))
            cols[rng.choice(TEMPERATURE_NAMES).format(s=sid, u=u)] = TEMPERATURE_FROM_C[u](t[sid].to_numpy())
    names = list(cols)
    rng.shuffle(names)
    wide = pd.DataFrame({"Timestamp": a.index, **{n: cols[n] for n in names}})
    order = rng.permutation(wide.shape[1])
    return wide.iloc[:, order], r


def _write(tmp_path, syn):
    syn.sensors.to_csv(tmp_path / "s.csv", index=False)
    syn.survey.to_csv(tmp_path / "v.csv", index=False)


def _assert_same_site(a, b):
    assert list(a.sensor_ids) == list(b.sensor_ids) and a.warnings == b.warnings
    ra, rb = a.readings, b.readings
    assert list(ra.columns) == list(rb.columns) and len(ra) == len(rb)
    np.testing.assert_array_equal(ra["timestamp"].to_numpy(), rb["timestamp"].to_numpy())
    np.testing.assert_array_equal(ra["sensor_id"].to_numpy(), rb["sensor_id"].to_numpy())
    for c in ("angle_deg", "temperature_c"):  # the unit conversions' rounding only
        np.testing.assert_allclose(ra[c].to_numpy(float), rb[c].to_numpy(float), rtol=1e-12, atol=1e-12)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1), drop=st.sampled_from([0.0, 0.03]))
def test_a_site_written_long_and_wide_gives_the_same_site(syn, tmp_path, seed, drop):
    rng = np.random.default_rng(seed)
    _write(tmp_path, syn)
    wide, long = _wide(syn.readings, list(syn.sensors["sensor_id"]), rng, drop=drop)
    wide.to_csv(tmp_path / "w.csv", index=False)
    long.to_csv(tmp_path / "r.csv", index=False)
    _assert_same_site(read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv"),
                      read_rail_site(tmp_path / "s.csv", tmp_path / "w.csv", tmp_path / "v.csv"))


def test_rail_settle_on_a_wide_export_gives_the_long_files_settlement(syn, tmp_path):
    _write(tmp_path, syn)
    wide, long = _wide(syn.readings, list(syn.sensors["sensor_id"]), np.random.default_rng(3))
    wide.to_csv(tmp_path / "w.csv", index=False)
    long.to_csv(tmp_path / "r.csv", index=False)
    out = {}
    for name in ("r", "w"):
        assert main(["rail", "settle", "--sensors", str(tmp_path / "s.csv"), "--readings", str(tmp_path / f"{name}.csv"),
                     "--survey", str(tmp_path / "v.csv"), "--monte-carlo", "0", "-o", str(tmp_path / f"{name}-out.csv")]) == 0
        out[name] = pd.read_csv(tmp_path / f"{name}-out.csv")
    assert out["r"].shape == out["w"].shape
    for c in ("dz_m", "dz_std_m"):
        np.testing.assert_allclose(out["w"][c], out["r"][c], rtol=1e-9, atol=1e-12)


def test_an_angles_only_wide_export_needs_the_temperature_or_thermal_none(syn, tmp_path, capsys):
    _write(tmp_path, syn)
    a = syn.readings.pivot(index="timestamp", columns="sensor_id", values="angle_deg").reset_index()
    a.to_csv(tmp_path / "w.csv", index=False)
    with pytest.raises(InputFormatError, match=r"a wide readings table \(one column per sensor\) with angle columns "
                                               r"only: add each sensor's temperature.*--thermal none"):
        read_rail_site(tmp_path / "s.csv", tmp_path / "w.csv", tmp_path / "v.csv")
    syn.readings.drop(columns="temperature_c").to_csv(tmp_path / "r.csv", index=False)  # the same, long
    _assert_same_site(read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv",
                                     require_temperature=False),
                      read_rail_site(tmp_path / "s.csv", tmp_path / "w.csv", tmp_path / "v.csv",
                                     require_temperature=False))
    base = ["rail", "settle", "--sensors", str(tmp_path / "s.csv"), "--readings", str(tmp_path / "w.csv"), "--survey",
            str(tmp_path / "v.csv"), "--monte-carlo", "0"]
    capsys.readouterr()
    assert main(base + ["-o", str(tmp_path / "o1.csv")]) == 2
    err = capsys.readouterr().err
    assert "angle columns only" in err and "Traceback" not in err
    assert main(base + ["--thermal", "none", "-o", str(tmp_path / "o2.csv")]) == 0


@pytest.mark.parametrize(("rename", "extra", "msg"), [
    ({"S03": "S03_angle_deg"}, {"S03_tilt_rad": 0.0}, r"sensor S03's angle is in two columns, 'S03_angle_deg' and "
                                                     r"'S03_tilt_rad'; keep one"),
    ({}, {"battery_v": 12.0}, r"column\(s\) \['battery_v'\] name no sensor of the sensors table; name each column"),
    ({}, {"S99": 0.1}, r"column\(s\) \['S99'\] name no sensor"),
    ({}, {"time": "x"}, r"needs one time column \(timestamp\); it has \['timestamp', 'time'\]"),
    ({}, {"S04_temperature_c": 5.0, "S04_temperature_f": 41.0}, "sensor S04's temperature is in two columns"),
])
def test_ambiguous_wide_layouts_get_one_line_saying_what_to_do(syn, tmp_path, rename, extra, msg):
    _write(tmp_path, syn)
    r = syn.readings
    w = r.pivot(index="timestamp", columns="sensor_id", values="angle_deg").add_suffix("_angle_deg")
    w = pd.concat([w, r.pivot(index="timestamp", columns="sensor_id", values="temperature_c").add_suffix(
        "_temperature_c").drop(columns=["S04_temperature_c"])], axis=1).reset_index()
    w = w.rename(columns={f"{k}_angle_deg": v for k, v in rename.items()}).assign(**extra)
    w.to_csv(tmp_path / "w.csv", index=False)
    with pytest.raises(InputFormatError, match=msg):
        read_rail_site(tmp_path / "s.csv", tmp_path / "w.csv", tmp_path / "v.csv")


def test_a_wide_export_takes_the_long_readers_unit_checks(syn, tmp_path):
    """The unit parsing is the long reader's: an unknown unit is refused naming the known ones, a declared unit with
    --angle-unit rad is refused, a temperature without an angle is refused."""
    _write(tmp_path, syn)
    r = syn.readings
    a = r.pivot(index="timestamp", columns="sensor_id", values="angle_deg")
    t = r.pivot(index="timestamp", columns="sensor_id", values="temperature_c")
    for cols, err, msg, kw in [
        ({"S01 Angle [gon]": a["S01"]}, UnitsError, r"column 'S01 Angle \[gon\]': unit 'gon' not known; known: deg", {}),
        ({"S01_angle_mrad": a["S01"]}, UnitsError, r"declares its unit \((deg|mrad)\); leave out --angle-unit rad",
         {"angle_unit": "rad"}),
        ({"S01_temperature_c": t["S01"]}, InputFormatError, r"sensor\(s\) \['S01'\] have a temperature column and no "
                                                            r"angle column", {})]:
        w = pd.concat([a.drop(columns=["S01"]).add_suffix("_angle_deg"), t.add_suffix("_temperature_c").drop(
            columns=["S01_temperature_c"]), pd.DataFrame(cols)], axis=1).reset_index()
        w.to_csv(tmp_path / "w.csv", index=False)
        with pytest.raises(err, match=msg):
            read_rail_site(tmp_path / "s.csv", tmp_path / "w.csv", tmp_path / "v.csv", **kw)
