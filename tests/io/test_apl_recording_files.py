"""An APL recording is read with the profile reader's checks (session 39, a pavement engineer's trailer files): a
logger's missing-value code, a unit the package does not convert, a signal too small or too large for its unit,
empty / reversed / repeated stations, rows dropped from the grid, vendor column names. Each gives a correct result or
one line naming the file, the line or station, and what to do."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, UnitsError
from longprofile.io import read_apl_recording, read_apl_signal, read_profile

N = 400
DX = 0.05
SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _signal(n: int = N) -> np.ndarray:
    """A signal of a few millimetres (m), as a trailer records on a class C road."""
    x = np.arange(n) * DX
    return 0.004 * np.sin(2 * np.pi * x / 3.1) + 0.002 * np.sin(2 * np.pi * x / 0.7)


def _write(path, columns: dict) -> None:
    pd.DataFrame(columns).to_csv(path, index=False)


def _message(reader, *args, **kw) -> str:
    with pytest.raises((InputError, UnitsError)) as info:
        reader(*args, **kw)
    return str(info.value)


# ---- missing-value codes (issue 1) ------------------------------------------------------------------------------


@SETTINGS
@given(code=st.sampled_from([-999, -9999, 9999, -99999, 999999]), unit=st.sampled_from(["m", "mm", "cm"]),
       start=st.integers(1, N - 30), length=st.integers(1, 25))
def test_a_missing_value_code_is_refused_with_its_stations_and_the_way_out(tmp_path, code, unit, start, length):
    """-9999 (any whole number of 9s) in the signal's own unit is refused as the profile reader refuses it, naming
    the code, the stations and the empty cells that `road reconstruct` bridges; written as empty cells, it is read as
    missing samples."""
    scale = {"m": 1.0, "mm": 1e3, "cm": 1e2}[unit]
    z = _signal() * scale
    coded = z.astype(object)
    coded[start:start + length] = code
    f = tmp_path / "rec.csv"
    _write(f, {"distance_m": np.arange(N) * DX, f"apl_{unit}": coded})
    msg = _message(read_apl_signal, f)
    assert isinstance(msg, str) and f"holds {code:g} {unit} at station {start * DX:.3f} m" in msg
    assert "empty cells" in msg and "road reconstruct" in msg and "RMS" not in msg
    blank = z.astype(object)
    blank[start:start + length] = ""
    _write(f, {"distance_m": np.arange(N) * DX, f"apl_{unit}": blank})
    read = read_apl_signal(f).elevation[:, 0]
    assert np.isnan(read[start:start + length]).all() and np.isfinite(np.delete(read, range(start, start + length))).all()


# ---- units (issues 8, 12) ---------------------------------------------------------------------------------------


@SETTINGS
@given(unit=st.sampled_from(["um", "µm", "μm", "microns", "nm", "mil"]),
       style=st.sampled_from(["apl_{}", "APL [{}]", "APL ({})"]), explicit=st.booleans())
def test_a_unit_the_package_does_not_convert_is_named_never_read_as_metres(tmp_path, unit, style, explicit):
    name = style.format(unit)
    f = tmp_path / "rec.csv"
    _write(f, {"distance_m": np.arange(N) * DX, name: _signal() * 1e6})
    with pytest.raises(UnitsError) as info:
        read_apl_signal(f, **({"column": name} if explicit else {}))
    assert f"is in {unit!r}, a unit this package does not convert" in str(info.value)


@SETTINGS
@given(scale=st.floats(0.3, 3.0), unit=st.sampled_from(["mm", "cm"]))
def test_metres_under_a_smaller_unit_are_refused_below_the_floor(tmp_path, scale, unit):
    """The smoothest road's signal (class A, about 2 mm RMS) written in metres under a mm or cm label reads 1000 or
    100 times too small: refused below 0.1 mm, with the label to use and the bench's way out."""
    from longprofile.road.apl import apl_model, simulate_apl_recording

    rec = simulate_apl_recording("iso8608", apl_model(20.0, DX), length=100.0, road_class="A", rng=1)
    f = tmp_path / "rec.csv"
    _write(f, {"distance_m": rec.distance, f"apl_{unit}": rec.signal * scale})
    with pytest.raises(UnitsError, match="below any APL recording of a road") as info:
        read_apl_signal(f)
    assert "name the column apl_m" in str(info.value) and "reconstruct_recording(Profile" in str(info.value)
    _write(f, {"distance_m": rec.distance, "apl_mm": rec.signal * 1e3 * scale})  # the same signal, rightly labelled
    np.testing.assert_allclose(read_apl_signal(f).elevation[:, 0], rec.signal * scale, rtol=1e-12)


def test_the_floor_is_below_every_simulated_class_a_recording():
    """The floor (0.1 mm) is under the smallest RMS of the smoothest class at every Table 1 configuration."""
    from longprofile.io._profiles import APL_SIGNAL_RMS_RANGE
    from longprofile.road.apl import TABLE1_CONFIGURATIONS, apl_model, simulate_apl_recording

    for speed, dx in TABLE1_CONFIGURATIONS:
        for seed in range(3):
            s = simulate_apl_recording("iso8608", apl_model(speed, dx), length=100.0, road_class="A", rng=seed).signal
            assert np.sqrt(np.mean(s**2)) > 10 * APL_SIGNAL_RMS_RANGE[0]


# ---- stations: the profile reader's refusals (issue 7) -----------------------------------------------------------


def _same_refusal(tmp_path, stations, values=None):
    """The message of the APL reader and of the profile reader on the same stations (the column renamed)."""
    z = _signal(len(stations)) if values is None else values
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    _write(a, {"distance_m": stations, "apl_m": z})
    _write(b, {"distance_m": stations, "left_m": z})
    return _message(read_apl_signal, a).replace(str(a), "FILE"), _message(read_profile, b).replace(str(b), "FILE")


@SETTINGS
@given(fault=st.sampled_from(["reversed chainage", "rows backwards", "swap", "stop", "rounded km", "blank station"]),
       at=st.integers(5, N - 40))
def test_station_faults_get_the_profile_readers_refusal(tmp_path, fault, at):
    x = np.arange(N) * DX
    z = _signal()
    if fault == "reversed chainage":
        x = x[::-1]
    elif fault == "rows backwards":
        x, z = x[::-1], z[::-1]
    elif fault == "swap":
        x[[at, at + 1]] = x[[at + 1, at]]
    elif fault == "stop":
        x = np.r_[x[:at], np.full(30, x[at]), x[at + 1:]]
        z = np.r_[z[:at], np.full(30, z[at]), z[at + 1:]]
    elif fault == "rounded km":
        x = np.round(12.3 + x / 1000, 4) * 1000
    else:
        x = x.astype(object)
        x[at] = ""
    if fault in ("reversed chainage", "rows backwards"):
        # since session 40 a profile whose stations count down is read as the distance travelled (a southbound
        # lane); an APL recording's encoder counts up: decreasing stations stay refused
        f = tmp_path / "a.csv"
        _write(f, {"distance_m": x, "apl_m": z})
        assert "reverse its rows; if the run was driven the other way" in _message(read_apl_signal, f)
        return
    mine, profile = _same_refusal(tmp_path, x, z)
    assert mine == profile
    expected = {"reversed chainage": "reverse its rows; if the run was driven the other way",
                "rows backwards": "reverse its rows; if the run was driven the other way",
                "swap": f"line {at + 3}: station", "stop": "a stop? the rows logged at a standstill",
                "rounded km": "written with too few decimals", "blank station": f"line {at + 2}: empty station"}
    assert expected[fault] in mine


def test_trailing_empty_rows_are_ignored_and_an_empty_file_is_refused(tmp_path):
    f = tmp_path / "rec.csv"
    _write(f, {"distance_m": np.arange(N) * DX, "apl_m": _signal()})
    clean = read_apl_signal(f)
    f.write_text(f.read_text() + ",\n,\n")  # Excel's trailing rows
    np.testing.assert_array_equal(read_apl_signal(f).elevation, clean.elevation)
    f.write_text("distance_m,apl_m\n")
    assert "has a header (distance_m, apl_m) but no data rows" in _message(read_apl_signal, f)


# ---- rows dropped from the grid (issue 6) ------------------------------------------------------------------------


@SETTINGS
@given(holes=st.lists(st.tuples(st.integers(2, N - 60), st.integers(1, 40)), min_size=1, max_size=3))
def test_rows_dropped_from_the_grid_read_as_the_same_samples_left_empty(tmp_path, holes):
    """Removing rows gives exactly the recording with those cells empty (the smoother bridges both alike)."""
    x, z = np.arange(N) * DX, _signal()
    gone = np.zeros(N, dtype=bool)
    for start, length in holes:
        gone[start:start + length] = True
    gone[[0, -1]] = False
    a, b = tmp_path / "cut.csv", tmp_path / "blank.csv"
    _write(a, {"distance_m": x[~gone], "apl_m": z[~gone]})
    _write(b, {"distance_m": x, "apl_m": np.where(gone, np.nan, z)})
    cut, blank = read_apl_recording(a), read_apl_signal(b)
    np.testing.assert_allclose(cut.signal.distance, blank.distance, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(cut.signal.elevation, blank.elevation)
    assert sum(n for _, _, n in cut.absent) == gone.sum()
    x = x[~gone].copy()
    x[1] += 0.013  # a step that is not a whole multiple: nothing is filled, `road reconstruct` refuses the spacing
    _write(a, {"distance_m": x, "apl_m": z[~gone]})
    uneven = read_apl_recording(a)
    assert uneven.absent == () and uneven.signal.spacing is None


# ---- column names (issue 11) -------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["DIST (m)", "PK [km]", "abscisse_m", "PR_m"])
def test_a_vendor_station_name_gets_the_accepted_names_and_distance_column_reads_it(tmp_path, name):
    f = tmp_path / "rec.csv"
    _write(f, {name: np.arange(N) * DX, "apl_mm": _signal() * 1e3})
    msg = _message(read_apl_signal, f)
    assert "no station column; expected one named distance, station, chainage or x with its unit" in msg
    factor = 1e3 if "km" in name else 1.0
    got = read_apl_signal(f, distance_column=name)
    np.testing.assert_allclose(got.distance, np.arange(N) * DX * factor)


def test_a_unit_on_the_row_under_the_header_is_named(tmp_path):
    f = tmp_path / "rec.csv"
    f.write_text("Distance,APL\nm,mm\n0,1.0\n0.05,1.2\n")
    msg = _message(read_apl_signal, f)
    assert "the row under the header holds 'm'" in msg and "'Distance [m]'" in msg


def test_a_missing_signal_column_names_the_option(tmp_path):
    f = tmp_path / "rec.csv"
    _write(f, {"distance_m": np.arange(N) * DX, "Signal APL (mm)": _signal() * 1e3})
    msg = _message(read_apl_signal, f)
    assert "no signal column 'apl_m'" in msg and "--column NAME" in msg
    assert read_apl_signal(f, column="Signal APL (mm)").n_samples == N


# ---- ERD (issues 13, 14) -----------------------------------------------------------------------------------------


def _erd(path, name: str, values) -> None:
    body = "\n".join(f"{v:.4f}" if isinstance(v, float) else str(v) for v in values)
    path.write_text(f"ERDFILEV2.00\n    1, {len(values)},    -1,     1,     5,  0.05,  0.0,\nTITLE   t\n"
                    f"SHORTNAM{name:<8s}\nUNITSNAMmm      \nXUNITS  m\nEND\n{body}\n")


def test_an_erd_missing_value_code_says_write_nan(tmp_path):
    z = list(_signal() * 1e3)
    z[100:110] = [-9999] * 10
    f = tmp_path / "p.erd"
    _erd(f, "elev", z)
    msg = _message(read_profile, f)
    assert "Write nan in place of each missing value" in msg and "leave the cells empty" not in msg


@pytest.mark.parametrize("name", ["APL", "apl"])
def test_an_erd_apl_track_is_refused_as_a_tables_apl_column_is(tmp_path, name):
    f, g = tmp_path / "v.erd", tmp_path / "v.csv"
    _erd(f, name, list(_signal() * 1e3))
    _write(g, {"distance_m": np.arange(N) * DX, f"{name}_mm": _signal() * 1e3})
    erd, table = _message(read_profile, f), _message(read_profile, g)
    assert "looks like an APL trailer's raw signal" in erd and "looks like an APL trailer's raw signal" in table
    assert f"road convert {f} signal.csv --track {name}" in erd
    assert read_profile(f, tracks=[name]).tracks == (name,)  # --track names a profile called so
