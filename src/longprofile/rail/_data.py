"""Rail site data model: long-format sensors / readings / survey / controls tables, validated once.

Tables (CSV or Parquet, one row per item, units in the column names):

- sensors:  ``sensor_id`` (text), ``x_m`` (station along the track, m), optional ``z_m`` (initial altitude, m)
- readings: ``timestamp`` (ISO 8601 date-time), ``sensor_id``, ``angle_deg`` (inclination, degrees),
  ``temperature_c`` (°C)
- survey:   ``x_m``, ``z_m`` — initial altitude survey, any grid (e.g. every 10 m)
- controls: ``date`` (ISO date), ``x_m``, ``z_m`` — later control surveys (optional)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pandas as pd

from .._validation import missing_value_code, time_zone, utc_offset_mix  # the rule shared with road files
from ..core import MAX_ABS_ELEVATION_M, MISSING_TEXT
from ..errors import InputError, InputFormatError, UnitsError

__all__ = ["SiteData", "validate_site", "angle_noise", "missing_value_code", "MISSING_CODE_HINT", "RADIAN_NOISE_THRESHOLD", "SENSOR_COLUMNS", "READING_COLUMNS",
           "SURVEY_COLUMNS", "CONTROL_COLUMNS", "ANGLE_RANGE_DEG", "TEMPERATURE_RANGE_C", "MAX_TRACK_ANGLE_DEG",
           "track_angle", "check_survey", "fill_temperature", "TEMPERATURE_NEIGHBOURS",
           "STUCK_MIN_READINGS", "STUCK_SITE_SPREAD_C", "TEMPERATURE_OFFSET_DAYS", "MISSING_TEXT"]

SENSOR_COLUMNS = ("sensor_id", "x_m")
READING_COLUMNS = ("timestamp", "sensor_id", "angle_deg", "temperature_c")
SURVEY_COLUMNS = ("x_m", "z_m")
CONTROL_COLUMNS = ("date", "x_m", "z_m")

#: Below this robust high-frequency noise (median over sensors, in the given unit) degrees are
#: implausible for MEMS inclinometers (resolution 1e-4 deg, repeatability 2.5e-3 deg, paper 004 §1.3),
#: while the same signal in radians (5e-3 deg = 8.7e-5 rad) falls below it.
RADIAN_NOISE_THRESHOLD = 4e-4
#: :func:`angle_noise` decides only on at least this many first differences (all sensors together): one
#: difference of a healthy degree sensor falls below the threshold about once in ten, so a monitoring batch of
#: two readings was refused as "radians" (found by the ingestion property test).
MIN_NOISE_DIFFERENCES = 10
#: Plausible range of one reading's angle, deg (an inclinometer's angle from level) and temperature, degC (a rail in
#: the sun reaches ~70 degC; loggers are rated -40..85): a reading beyond either is refused, by ``validate_site`` for
#: files and by the monitoring service's ingestion row by row.
ANGLE_RANGE_DEG = (-90.0, 90.0)
TEMPERATURE_RANGE_C = (-80.0, 120.0)
#: A sleeper inclinometer reads within a few degrees of level (track grades <= 5 %, 2.9 deg, plus a mounting offset of
#: a degree or two): the median over sensors of each sensor's median |angle| (:func:`track_angle`) beyond this is
#: another unit -- degrees given as radians (x 57.3), millidegrees under a degree label -- and is refused unless
#: ``check_units=False``.
MAX_TRACK_ANGLE_DEG = 10.0
#: :func:`fill_temperature`: a reading whose angle has no temperature takes the median temperature of this many
#: nearest sensors (by station) that have one in the same minute.
TEMPERATURE_NEIGHBOURS = 4
#: :func:`fill_temperature` works on this many needed minutes at a time (memory: this x the sensors' count floats).
_FILL_CHUNK = 20_000
#: A stuck temperature channel (:func:`fill_temperature`): a sensor-day with at least ``STUCK_MIN_READINGS``
#: temperatures, all the same value, on a day when the sensors' temperatures span at least ``STUCK_SITE_SPREAD_C``
#: (median over the sensors of each one's range that day): a rail in the open never holds one value to the last
#: digit through a day whose temperature moves by a degree.
STUCK_MIN_READINGS = 12
STUCK_SITE_SPREAD_C = 1.0
#: :func:`fill_temperature`: a filled reading takes the sensor's median difference from its neighbours' median over
#: this many calendar days ending on its last own-temperature day before the filled reading's day (a shade offset).
TEMPERATURE_OFFSET_DAYS = 7


@dataclass(frozen=True, eq=False)
class SiteData:
    """A validated inclinometer site.

    Attributes
    ----------
    sensors : DataFrame
        ``sensor_id`` (str), ``x_m`` sorted by station; ``z_m`` if given.
    readings : DataFrame
        ``timestamp`` (datetime64), ``sensor_id`` (str), ``angle_deg``, ``temperature_c``,
        sorted by sensor then time; angles in degrees whatever unit was given.
    survey : DataFrame or None
        ``x_m``, ``z_m`` sorted by x (None when the sensors carry ``z_m``).
    controls : DataFrame or None
        ``date`` (datetime64, day), ``x_m``, ``z_m``.
    warnings : tuple of str
        Everything that was accepted but deserves the user's attention (sorted input,
        sensors without readings, control points outside the sensors...). Reported in every output.
    TABLE_COLUMNS : dict of str -> tuple of str
        Class attribute: the required columns of each table ("sensors", "readings", "survey", "controls"),
        for readers such as :func:`longprofile.io.read_rail_site`.
    """

    TABLE_COLUMNS: ClassVar[dict] = {"sensors": SENSOR_COLUMNS, "readings": READING_COLUMNS,
                                     "survey": SURVEY_COLUMNS, "controls": CONTROL_COLUMNS}

    sensors: pd.DataFrame
    readings: pd.DataFrame
    survey: pd.DataFrame | None
    controls: pd.DataFrame | None
    warnings: tuple[str, ...] = ()

    @property
    def sensor_ids(self) -> list[str]:
        """Sensor ids ordered by station."""
        return list(self.sensors["sensor_id"])

    @property
    def x(self) -> np.ndarray:
        """(N,) station positions, m."""
        return self.sensors["x_m"].to_numpy(float)


def _require_columns(df: pd.DataFrame, cols, what: str):
    missing = [c for c in cols if c not in df.columns]
    if missing:
        raise InputFormatError(f"{what} table: missing column(s) {missing}; it has {list(df.columns)}. "
                               f"Expected columns: {list(cols)}.")


def _numeric(df: pd.DataFrame, col: str, what: str, *, allow_nan: bool = False) -> np.ndarray:
    values = df[col]
    if allow_nan and not pd.api.types.is_numeric_dtype(values):  # a logger's marker for a failed channel is an empty cell
        values = values.mask(values.map(lambda v: isinstance(v, str) and v.strip().lower() in MISSING_TEXT))
    conv = pd.to_numeric(values, errors="coerce")
    bad = conv.isna() & values.notna() if allow_nan else conv.isna()
    if bad.any() or np.isinf(conv).any():
        i = int(np.nonzero((bad | np.isinf(conv)).to_numpy())[0][0])
        raise InputFormatError(f"{what} table, {_row(i)}: column {col!r} must be a finite number; got "
                               f"{str(df[col].iloc[i])!r}.")
    return conv.to_numpy(float)


def _is_number(value) -> bool:
    try:
        float(value)
    except (TypeError, ValueError):
        return False
    return True


def _row(i: int) -> str:
    """A data row's place for a message: its 0-based index and its line in a CSV with one header line."""
    return f"row {i} (CSV line {i + 2})"


def _times_with_offsets(series: pd.Series, what: str, col: str):
    """Times some of which carry a UTC offset (pandas refuses offsets that differ, e.g. across a DST change): all
    with one, converted to UTC; a mix of times with and without one refused (which zone would the others be in?);
    None when no value carries one."""
    mix = utc_offset_mix(series)
    if mix is not None:
        j, i = mix
        raise InputFormatError(f"{what} table: column {col!r} mixes times with a UTC offset ({_row(j)}: "
                               f"{series.iloc[j]!r}) and without one ({_row(i)}: {series.iloc[i]!r}); write them all in "
                               "UTC, or all with their offset.")
    try:
        return pd.to_datetime(series, format="ISO8601", utc=True)
    except (ValueError, TypeError):
        return None


def _times(values, what: str, col: str, *, timezone: str | None = None, groups=None) -> pd.Series:
    """Naive UTC times of a column of ISO 8601 texts: times with a UTC offset converted; times without one are UTC,
    or local times of ``timezone`` (:func:`_local_times`, ``groups``: each row's sensor)."""
    series = pd.Series(values)
    try:
        t = pd.to_datetime(series, format="ISO8601")
    except (ValueError, TypeError):
        t = _times_with_offsets(series, what, col) if pd.api.types.is_string_dtype(series) else None
    if t is None:
        parsed = pd.to_datetime(series, format="ISO8601", errors="coerce", utc=True)
        bad = np.nonzero((parsed.isna() & series.notna()).to_numpy())[0]
        value = series.iloc[int(bad[0])] if bad.size else None
        where, got = (f", {_row(int(bad[0]))}", f"; got {str(value)!r}") if bad.size else ("", "")
        hint = (" (is it day/month or month/day? write year-month-day)" if "/" in got else
                " (a number: seconds since 1970, or days? write the dates)" if _is_number(value) else "")
        raise InputFormatError(f"{what} table{where}: column {col!r} must hold ISO 8601 dates/times "
                               f"(e.g. 2019-11-18T08:10:00){got}{hint}.") from None
    if t.isna().any():
        i = int(np.nonzero(t.isna().to_numpy())[0][0])
        raise InputFormatError(f"{what} table, {_row(i)}: column {col!r} is empty.")
    if getattr(t.dt, "tz", None) is not None:
        t = t.dt.tz_convert("UTC").dt.tz_localize(None)
    elif timezone is not None and timezone != "UTC":
        t = _local_times(t, timezone, groups, what, col)
    return t


def _local_times(t: pd.Series, timezone: str, groups, what: str, col: str) -> pd.Series:
    """Naive UTC times of the naive local times ``t`` of ``timezone`` (an IANA name).

    A local time the clock shows twice (the hour before it goes back at the end of daylight-saving time) is the
    second of the two when an earlier row of the same group (sensor), in the table's order, shows the same or a later
    local time of that hour: the logger's clock went back (the monitoring service's rule, where the earlier readings
    are those already stored). A local time the clock skips in spring is refused."""
    timezone = time_zone(timezone).key
    first = t.dt.tz_localize(timezone, ambiguous=np.ones(len(t), bool), nonexistent="NaT")
    skipped = first.isna().to_numpy() & t.notna().to_numpy()
    if skipped.any():
        i = int(np.flatnonzero(skipped)[0])
        raise InputFormatError(f"{what} table, {_row(i)}: {col} {t.iloc[i]} does not exist in {timezone} (the clock "
                               "skips that hour when it goes forward); is the logger's clock on that zone?")
    second = t.dt.tz_localize(timezone, ambiguous=np.zeros(len(t), bool), nonexistent="NaT")
    twice = (first != second).to_numpy()
    if twice.any():
        g = pd.DataFrame({"g": np.asarray(groups)[twice], "day": t[twice].dt.normalize().to_numpy(),
                          "t": t[twice].to_numpy()})
        before = g.groupby(["g", "day"], sort=False)["t"].cummax().groupby([g["g"], g["day"]], sort=False).shift()
        later = np.zeros(len(t), bool)
        later[np.flatnonzero(twice)] = (before >= g["t"]).to_numpy()
        first = first.where(~later, second)
    return first.dt.tz_convert("UTC").dt.tz_localize(None)


def angle_noise(readings: pd.DataFrame) -> float:
    """High-frequency noise of inclinometer angles: the median over sensors of the robust std of first differences
    divided by sqrt(2), in the unit of ``angle_deg``.

    ``readings`` needs ``sensor_id`` and ``angle_deg`` columns, each sensor's rows in time order. Below
    :data:`RADIAN_NOISE_THRESHOLD` the angles are implausible as degrees for MEMS inclinometers (paper 004 §1.3) and
    look like radians: :func:`validate_site` refuses them, and so does the monitoring service's ingestion.
    Returns NaN when fewer than :data:`MIN_NOISE_DIFFERENCES` first differences exist (too few to decide) or
    no sensor has two distinct readings.
    """
    d = readings.groupby("sensor_id", sort=False)["angle_deg"].diff().abs()
    if int(np.isfinite(d.to_numpy(dtype=float)).sum()) < MIN_NOISE_DIFFERENCES:
        return float("nan")
    per = d.groupby(readings["sensor_id"], sort=False).median() / (0.6745 * np.sqrt(2.0))
    per = per[np.isfinite(per) & (per > 0)]
    return float(per.median()) if len(per) else float("nan")


#: A track's grade between survey points is a few per cent (mainline railways <= 4 %, rack railways up to 48 % over
#: short lengths): a median |dz/dx| above this (25 %) is millimetres under a metre label (x 1000: a 0.025 % grade, or
#: a survey's 2 mm of noise over 3 m, gives 0.6), refused unless ``check_units=False``.
MAX_SURVEY_GRADE = 0.25
#: A survey spanning more than this many times the sensors' span, with fewer than 2 of its points among them (and 3
#: or more outside), has its stations in another unit (millimetres under x_m: 1000 times); a line survey of a few km
#: around a short site keeps points among the sensors.
MAX_SURVEY_EXTENT_RATIO = 100.0
#: A control survey differs from the initial one by the settlement, millimetres to centimetres during works: a
#: difference beyond this, m, is another unit or another datum, never a settlement the tool could follow.
MAX_CONTROL_CHANGE_M = 1.0


def track_angle(readings: pd.DataFrame) -> float:
    """Median over sensors of each sensor's median |angle_deg|, deg (NaN without a finite angle): how far from level
    the sensors read (:data:`MAX_TRACK_ANGLE_DEG`). ``readings`` needs ``sensor_id`` and ``angle_deg``."""
    per = readings["angle_deg"].abs().groupby(readings["sensor_id"], sort=False).median()
    per = per[np.isfinite(per)]
    return float(per.median()) if len(per) else float("nan")


#: What a refusal says of a value that :func:`missing_value_code` takes for a logger's code.
MISSING_CODE_HINT = ("a logger's code for a missing value? Leave such cells empty or write NAN (a missing temperature "
                     "is filled from the neighbouring sensors).")


def _check_reading_ranges(r: pd.DataFrame) -> None:
    """Refuse the first reading whose angle or temperature is outside its plausible range (the service's row checks)."""
    for col, (lo, hi), unit, why in (
            ("angle_deg", ANGLE_RANGE_DEG, "deg", "an angle from level in degrees"),
            ("temperature_c", TEMPERATURE_RANGE_C, "degC", "a rail temperature in degC (kelvin or Fahrenheit?)")):
        v = r[col].to_numpy(float)
        bad = np.isfinite(v) & ((v < lo) | (v > hi))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise UnitsError(f"readings table: sensor {r['sensor_id'].iloc[i]!r} at {r['timestamp'].iloc[i]} reads "
                             f"{col} = {v[i]:.6g}, outside the plausible {lo:g}..{hi:g} {unit} of {why}: "
                             + (MISSING_CODE_HINT if missing_value_code(v[i]) else
                                "check that reading and the column's unit."))


def _clock_change_hint(r: pd.DataFrame, dups) -> str:
    """A hint for the duplicate-reading error when most sensors repeat time stamps within one hour: what a logger
    recording local time writes when the clock goes back at the end of daylight-saving time."""
    ts = r["timestamp"][dups.to_numpy()]
    many = r["sensor_id"][dups.to_numpy()].nunique() > 0.5 * r["sensor_id"].nunique()
    if not many or ts.max() - ts.min() > pd.Timedelta(hours=1):
        return ""
    return (f" Most sensors repeat the time stamps from {ts.min()} to {ts.max()}: a logger in local time at a "
            "daylight-saving change? Give the loggers' zone (timezone='Europe/Paris'; CLI: --timezone), or the time "
            "stamps in UTC.")


def _drop_exact_duplicates(r: pd.DataFrame, warnings: list) -> pd.DataFrame:
    """``r`` without the rows that repeat another exactly (sensor, time, angle and temperature: overlapping downloads
    of a logger), with a warning counting them; readings that differ at one sensor and time are left for the
    caller to refuse."""
    same = r.duplicated(["sensor_id", "timestamp", "angle_deg", "temperature_c"])
    if not same.any():
        return r
    ids = sorted(set(r["sensor_id"][same]))
    warnings.append(f"{int(same.sum())} reading(s) repeated exactly (same sensor, time, angle and temperature: "
                    f"overlapping downloads?) were dropped, on {len(ids)} sensor(s) (e.g. {ids[:3]}).")
    return r[~same.to_numpy()].reset_index(drop=True)


#: :func:`_spring_forward`: a jump of one hour more than a sensor's usual interval, within this tolerance, s.
_SPRING_TOLERANCE_S = 60.0


def _spring_forward(r: pd.DataFrame) -> None:
    """Refuse naive times that look like local times across the spring clock change: more than half of the sensors
    (with readings on both sides) jump by their usual interval plus one hour at the same time, the last reading
    before the jump between 00:00 and 04:00 of a Sunday (the day of the change in Europe, North America and
    Australia). The autumn change shows as repeated times (:func:`_clock_change_hint`)."""
    if len(r) < 3:
        return
    t = r["timestamp"]
    gap = t.groupby(r["sensor_id"], sort=False).diff().dt.total_seconds()
    usual = gap.groupby(r["sensor_id"], sort=False).transform("median")
    jump = (np.abs(gap - usual - 3600.0) <= _SPRING_TOLERANCE_S).to_numpy()
    if not jump.any():
        return
    before = (t - pd.to_timedelta(gap, unit="s"))[jump]
    early = ((before.dt.day_of_week == 6) & (before.dt.hour < 4)).to_numpy()
    if not early.any():
        return
    at = t[jump][early]
    when = at.mode().iloc[0]
    sensors = r["sensor_id"][jump][early][at == when].nunique()
    spans = r.groupby("sensor_id", sort=False)["timestamp"].agg(["min", "max"])
    across = int(((spans["min"] < when) & (spans["max"] >= when)).sum())
    if sensors > 0.5 * across:
        raise InputFormatError(
            f"readings table: {sensors} of {across} sensors jump by one hour more than their interval at {when} (early "
            "on a Sunday: clocks go forward): loggers in local time? Give their zone (timezone='Europe/Paris'; CLI: "
            "--timezone), or the time stamps in UTC (timezone='UTC', --timezone UTC, if they are and the hour is a "
            "gap).")


def _constant_temperature(readings: pd.DataFrame, warnings: list) -> pd.DataFrame:
    """``readings`` with one constant temperature (0 degC) when it has no ``temperature_c`` column or an empty one
    (``require_temperature=False``, :func:`validate_site`); unchanged otherwise."""
    if "temperature_c" in readings.columns:
        t = readings["temperature_c"]
        text = t.astype(str).str.strip().str.lower()
        if not (t.isna() | text.isin(["", *MISSING_TEXT])).all():
            return readings
    warnings.append("the readings have no temperature: the angles are used as read (no thermal correction) and the "
                    "noise model has no temperature term.")
    return readings.assign(temperature_c=0.0)


def fill_temperature(readings: pd.DataFrame, sensors: pd.DataFrame, *,
                     neighbours: int = TEMPERATURE_NEIGHBOURS) -> tuple[pd.DataFrame, dict[str, int], dict[str, int]]:
    """Readings whose angle has no temperature, or a stuck one, given the median temperature of their nearest
    sensors' readings, plus the sensor's own offset from that median.

    The thermal correction (paper 004 §3) needs each reading's temperature. Where a sensor's temperature channel has
    failed (all its readings) or drops out (some), its angles would be lost; the rail a few metres away has nearly
    the same temperature. Each such reading takes the median of the temperatures read in the same minute
    (time stamps floored to the minute) by the ``neighbours`` nearest sensors (by ``|x_m|`` distance; the sensor
    itself excluded) that have one. A channel stuck at one value through a day when the others' temperatures move
    (:data:`STUCK_MIN_READINGS`, :data:`STUCK_SITE_SPREAD_C`; decided per sensor and calendar day) is a missing
    temperature on that day.

    A sensor in the shade reads a degree or so below its neighbours. When its channel fails during the record, that
    offset would show in the thermal correction as a step of coefficient x offset from the failure on (a false
    settlement, or a sensor taken for reversed). So a filled reading also takes the sensor's median difference from
    the same neighbours' median over its readings of the :data:`TEMPERATURE_OFFSET_DAYS` calendar days (UTC) that end on its
    last *own-temperature day* before the filled reading's day: a day with a temperature read with an angle and not
    one value all day (at least :data:`STUCK_MIN_READINGS` temperatures, all equal). Causal: a filled reading
    depends on nothing after its day, so a live record gives the same values as the whole one. A channel failed
    from the first day has no offset (0): there it cancels in the settlement, which is a change from the reference
    day. A different daily swing (sun exposure) or lag does not cancel (named in docs/rail.md, "A failed temperature
    channel"). A reading no sensor has a temperature for in that minute keeps its NaN (and is left out, as before),
    and so does a reading of a sensor that is not in ``sensors`` (it has no station).

    Parameters
    ----------
    readings : DataFrame
        ``timestamp``, ``sensor_id``, ``angle_deg``, ``temperature_c`` (the long format; NaN where missing).
    sensors : DataFrame
        ``sensor_id``, ``x_m``: the stations that order the neighbours.
    neighbours : int, default :data:`TEMPERATURE_NEIGHBOURS`
        How many nearest sensors with a temperature enter each median.

    Returns
    -------
    readings : DataFrame
        A copy with the filled temperatures (the same rows, order and index); ``readings`` itself when nothing was
        filled.
    filled : dict of str -> int
        Readings filled per sensor id (only sensors with at least one).
    stuck : dict of str -> int
        Days with a stuck temperature per sensor id (only sensors with at least one).
    """
    if neighbours < 1:
        raise InputError(f"neighbours must be at least 1; got {neighbours!r}.")
    codes, names = pd.factorize(readings["sensor_id"])  # a few names to look up, not a row each
    stuck_rows, stuck = _stuck_temperature(readings, codes, names)
    temp = np.where(stuck_rows, np.nan, readings["temperature_c"].to_numpy(float))
    angle = readings["angle_deg"].notna().to_numpy()
    need = np.isnan(temp) & angle
    if not need.any():
        return readings, {}, stuck
    ids = sensors["sensor_id"].astype(str).to_numpy()
    col = np.where(codes >= 0, pd.Index(ids).get_indexer(pd.Index(names).astype(str))[codes], -1)
    need &= col >= 0  # a sensor without a station has no neighbours: its readings stay as they are
    day = _utc_days(readings["timestamp"])
    pair, window = _offset_windows(readings["temperature_c"].to_numpy(float), temp, angle, need, col, day)
    med = _neighbour_median(temp, readings["timestamp"].dt.floor("min").to_numpy(), col,
                            sensors["x_m"].to_numpy(float), need | pair, neighbours)
    out = temp.copy()
    out[need] = med[need] + _offsets(temp - med, pair, need, col, day, window)
    done = need & np.isfinite(out)
    if not done.any() and not stuck_rows.any():
        return readings, {}, stuck
    r = readings.copy()
    r["temperature_c"] = out  # a stuck reading nothing could fill stays empty: it is not a temperature
    counts = np.bincount(codes[done], minlength=len(names))
    return r, {str(names[i]): int(n) for i, n in enumerate(counts) if n}, stuck


def _utc_days(ts: pd.Series) -> np.ndarray:
    """Days since 1970 (UTC calendar days) of the time stamps: the days of ``validate_site``."""
    if getattr(ts.dt, "tz", None) is not None:
        ts = ts.dt.tz_convert(None)
    return ts.to_numpy().astype("datetime64[D]").astype(np.int64)


def _own_temperature_days(raw: np.ndarray, angle: np.ndarray, group: np.ndarray, day: np.ndarray) -> np.ndarray:
    """Whether each (group, day) of the rows is an own-temperature day (:func:`fill_temperature`), per row."""
    ok = np.isfinite(raw) & angle
    frame = pd.DataFrame({"g": group, "d": day, "t": np.where(ok, raw, np.nan)})
    agg = frame.groupby(["g", "d"], sort=False)["t"].agg(["count", "min", "max"])
    own = (agg["count"] > 0) & ~((agg["count"] >= STUCK_MIN_READINGS) & (agg["min"] == agg["max"]))
    return own.reindex(pd.MultiIndex.from_arrays([group, day])).to_numpy(bool)


def _neighbour_median(temp, minute, col, x, targets, neighbours: int) -> np.ndarray:
    """At the ``targets`` rows, the median temperature of the ``neighbours`` nearest other sensors (by ``x``) with
    one in the same minute (NaN elsewhere, and where none has)."""
    have = np.isfinite(temp) & (col >= 0)
    rows = np.flatnonzero(targets)
    keys, key_of = np.unique(minute[rows], return_inverse=True)
    key = np.full(temp.size, -1)
    key[rows] = key_of
    med = np.full(temp.size, np.nan)
    for lo in range(0, keys.size, _FILL_CHUNK):  # a dense minute x sensor table of the needed minutes, in chunks
        ks = keys[lo:lo + _FILL_CHUNK]
        pos = np.searchsorted(ks, minute)
        src = have & (pos < ks.size)
        src[src] = ks[pos[src]] == minute[src]
        table = np.full((ks.size, x.size), np.nan)
        table[pos[src], col[src]] = temp[src]  # several readings of one sensor in a minute: one of them
        mine = rows[(key_of >= lo) & (key_of < lo + ks.size)]
        for j in np.unique(col[mine]):
            at = mine[col[mine] == j]
            order = np.argsort(np.abs(x - x[j]), kind="stable")
            order = order[order != j]
            near = order[:4 * neighbours]  # most minutes: the nearest sensors have a temperature
            short = np.isfinite(table[key[at] - lo][:, near]).sum(axis=1) < neighbours
            for cols, sel in ((near, ~short), (order, short)):
                if sel.any():
                    med[at[sel]] = _first_finite_median(table[key[at[sel]] - lo][:, cols], neighbours)
    return med


def _first_finite_median(vals: np.ndarray, k: int) -> np.ndarray:
    """Per row, the median of the first ``k`` finite values (columns in order of distance); NaN where none."""
    ok = np.isfinite(vals)
    vals[~ok | (np.cumsum(ok, axis=1) > k)] = np.nan
    out = np.full(vals.shape[0], np.nan)
    some = ok.any(axis=1)
    with np.errstate(all="ignore"):
        out[some] = np.nanmedian(vals[some], axis=1)
    return out


def _offset_windows(raw, temp, angle, need, col, day) -> tuple[np.ndarray, np.ndarray]:
    """(rows whose difference from their neighbours enters an offset, each needed row's last own-temperature day
    before its day or -1): :func:`fill_temperature`'s offset windows."""
    end = np.full(raw.size, -1, dtype=np.int64)
    pair = np.zeros(raw.size, bool)
    mine = np.flatnonzero(np.isin(col, np.unique(col[need])))
    mine = mine[np.argsort(col[mine], kind="stable")]  # each sensor's rows together
    own = _own_temperature_days(raw[mine], angle[mine], col[mine], day[mine])
    starts = np.flatnonzero(np.r_[True, col[mine][1:] != col[mine][:-1]])
    for lo, hi in zip(starts, np.r_[starts[1:], mine.size]):
        rows, d = mine[lo:hi], day[mine[lo:hi]]
        own_days = np.unique(d[own[lo:hi]])
        at = need[rows]
        if own_days.size == 0:  # failed from its first reading: no offset
            continue
        k = np.searchsorted(own_days, d[at]) - 1
        end[rows[at]] = e = np.where(k >= 0, own_days[np.maximum(k, 0)], -1)
        used = np.unique(e[e >= 0])
        if used.size:
            w = np.minimum(np.searchsorted(used, d), used.size - 1)  # the first used window end on or after the day
            inside = (used[w] >= d) & (used[w] - d < TEMPERATURE_OFFSET_DAYS)
            pair[rows[inside & np.isfinite(temp[rows]) & angle[rows]]] = True
    return pair, end


def _offsets(diff, pair, need, col, day, end) -> np.ndarray:
    """For the needed rows, the median of ``diff`` over the same sensor's ``pair`` rows of the
    :data:`TEMPERATURE_OFFSET_DAYS` days ending on the row's ``end`` day (0 without any)."""
    use = pair & np.isfinite(diff)
    at = np.flatnonzero(need)
    out = np.zeros(at.size)
    for j in np.unique(col[at]):
        sel = col[at] == j
        rows = np.flatnonzero(use & (col == j))
        for e in np.unique(end[at[sel]]):
            if e < 0:
                continue
            inside = diff[rows[(day[rows] <= e) & (day[rows] > e - TEMPERATURE_OFFSET_DAYS)]]
            if inside.size:
                out[sel & (end[at] == e)] = np.median(inside)
    return out


def _stuck_temperature(readings: pd.DataFrame, codes, names) -> tuple[np.ndarray, dict[str, int]]:
    """(rows whose temperature is stuck, {sensor id: stuck days}): see :func:`fill_temperature` (``codes``,
    ``names``: ``pd.factorize`` of the sensor ids)."""
    t = readings["temperature_c"].to_numpy(float)
    ok = np.isfinite(t)
    if ok.sum() < STUCK_MIN_READINGS:
        return np.zeros(t.size, bool), {}
    day = _utc_days(readings["timestamp"])  # calendar days of UTC, as validate_site gives them
    day = day - day.min()
    n_days = int(day.max()) + 1
    g = codes.astype(np.int64) * n_days + day
    order = np.argsort(g, kind="stable")  # already in order for validated readings (by sensor, then time)
    gs, ts = g[order], np.where(ok, t, np.nan)[order]
    start = np.flatnonzero(np.r_[True, gs[1:] != gs[:-1]])
    with np.errstate(invalid="ignore"):
        spread = np.fmax.reduceat(ts, start) - np.fmin.reduceat(ts, start)
    count = np.add.reduceat(ok[order].astype(np.int64), start)
    full = count >= STUCK_MIN_READINGS
    group_day = gs[start] % n_days
    site = pd.Series(spread[full]).groupby(group_day[full]).median()  # the sensors' median range, per day
    moving = site.reindex(group_day).to_numpy() >= STUCK_SITE_SPREAD_C
    stuck_group = full & (spread == 0) & moving
    rows = np.zeros(t.size, bool)
    rows[order] = np.repeat(stuck_group, np.diff(np.r_[start, gs.size]))
    rows &= ok
    per_sensor = np.bincount((gs[start] // n_days)[stuck_group], minlength=len(names))
    return rows, {str(names[i]): int(n) for i, n in enumerate(per_sensor) if n}


def _filled_warning(filled: dict[str, int]) -> str:
    """The warning of :func:`fill_temperature`'s work, naming the sensors with the most readings filled."""
    top = sorted(filled, key=lambda k: (-filled[k], k))
    return (f"{sum(filled.values())} reading(s) of {len(filled)} sensor(s) had an angle but no usable temperature (a "
            f"failed, intermittent or stuck temperature channel?), most on {[f'{k} ({filled[k]})' for k in top[:5]]}; they take the "
            f"median temperature of their {TEMPERATURE_NEIGHBOURS} nearest sensors in the same minute, plus their own "
            f"median difference from it over the {TEMPERATURE_OFFSET_DAYS} days before (temperature_fill=False, CLI "
            "--no-temperature-fill, leaves them out).")


def _stuck_warning(stuck: dict[str, int]) -> str:
    """The warning for stuck temperature channels (:func:`fill_temperature`)."""
    top = sorted(stuck, key=lambda k: (-stuck[k], k))
    return (f"the temperature of {len(stuck)} sensor(s) holds one value all day while the other sensors' temperatures "
            f"move (a stuck temperature channel?), most on {[f'{k} ({stuck[k]} day(s))' for k in top[:5]]}; "
            "those days' temperatures are taken as missing.")


def _temperature_less(r: pd.DataFrame) -> str:
    """The sensors none of whose angles has a temperature (a failed temperature channel), for the warning of empty
    readings: they lose every reading, and the health tests report them as dead."""
    has_angle = r["angle_deg"].notna()
    usable = (has_angle & r["temperature_c"].notna()).groupby(r["sensor_id"]).sum()
    angles = has_angle.groupby(r["sensor_id"]).sum()
    lost = sorted(usable.index[(usable == 0) & (angles > 0)])
    if not lost:
        return ""
    return (f" {len(lost)} sensor(s) have angles but never a temperature (a failed temperature channel?): {lost[:5]}; "
            "their angles cannot be corrected for temperature, and they are reported as dead.")


def validate_site(sensors: pd.DataFrame, readings: pd.DataFrame, survey: pd.DataFrame | None = None,
                  controls: pd.DataFrame | None = None, *, angle_unit: str = "deg",
                  check_units: bool = True, temperature_fill: bool = True, timezone: str | None = None,
                  require_temperature: bool = True) -> SiteData:
    """Validate the four tables of a site and return a :class:`SiteData`.

    Parameters
    ----------
    sensors, readings, survey, controls : DataFrame
        The long-format tables (module docstring). ``survey`` may be omitted when
        ``sensors`` has a ``z_m`` column; ``controls`` is optional.
    angle_unit : {"deg", "rad"}, default "deg"
        Unit of ``angle_deg`` as given; radians are converted to degrees.
    check_units : bool, default True
        With ``angle_unit="deg"``, refuse angles whose high-frequency noise is
        implausibly small for degrees (typical of radians given by mistake); with either unit, angles a median
        beyond :data:`MAX_TRACK_ANGLE_DEG` from level, and a survey steeper than :data:`MAX_SURVEY_GRADE` (millimetres
        under a metre label). Altitudes beyond any terrain and controls beyond :data:`MAX_CONTROL_CHANGE_M` from the
        survey are refused either way.
    temperature_fill : bool, default True
        A reading with an angle but no temperature (a failed or intermittent temperature channel), or a stuck one,
        takes its neighbours' temperature of the same minute (:func:`fill_temperature`, with a warning naming the
        sensors); False leaves an empty one out, as a reading without an angle is (a sensor without any temperature
        is then dead), and takes a stuck one as read.
    timezone : str, optional
        IANA zone (``Europe/Paris``) of the loggers' clocks: reading times without a UTC offset are local times of
        it, converted to UTC (default: they are UTC). The hour the clock shows twice in autumn is read in each
        sensor's order (:func:`_local_times`); a time it skips in spring is refused. Times with an offset are
        instants whatever this says. Without it, naive times that jump by one hour more than their interval in most
        sensors at once, early on a Sunday (:func:`_spring_forward`), are refused as local times: pass the zone, or
        "UTC" when they really are UTC.
    require_temperature : bool, default True
        False (for ``thermal="none"``, an angles-only logger): a readings table without a ``temperature_c`` column,
        or with that column empty in every row, is taken, its temperature set to one constant (0 °C): the angles are
        used as read and the noise model has no temperature term (docs/rail.md, "Angles-only loggers").

    Returns
    -------
    SiteData

    Raises
    ------
    InputFormatError
        Missing columns, non-numeric values, unreadable dates.
    InputError
        Unknown sensor ids in the readings, duplicate sensor ids or stations, duplicate
        (sensor, timestamp) readings, a survey that does not cover the sensors, no survey at all.
    UnitsError
        Angles that look like radians (see ``check_units``), unknown ``angle_unit``.
    """
    warnings: list[str] = []
    if angle_unit not in ("deg", "rad"):
        raise UnitsError(f"angle_unit must be 'deg' or 'rad'; got {angle_unit!r}.")
    s = _valid_sensors(sensors)
    if not require_temperature:
        readings = _constant_temperature(readings, warnings)
    r = _valid_readings(readings, s, angle_unit, check_units, warnings, temperature_fill, timezone)
    sv = _valid_survey(survey, s, warnings, check_units)
    ct = _valid_controls(controls, s, sv, warnings)
    return SiteData(sensors=s, readings=r, survey=sv, controls=ct, warnings=tuple(warnings))


def _ids(table: pd.DataFrame, what: str) -> np.ndarray:
    """The ``sensor_id`` column as stripped text; an empty cell is refused with its row (not a sensor named "nan")."""
    ids = table["sensor_id"]
    text = ids.astype(str).str.strip()
    empty = ids.isna().to_numpy() | (text == "").to_numpy()
    if empty.any():
        i = int(np.flatnonzero(empty)[0])
        raise InputError(f"{what} table, {_row(i)}: the sensor_id is empty; every row needs its "
                         f"sensor's id ({int(empty.sum())} row(s) without one).")
    return text.to_numpy()


def _valid_sensors(sensors: pd.DataFrame) -> pd.DataFrame:
    """The sensors table: ids stripped and unique, at least 3, sorted by distinct stations."""
    _require_columns(sensors, SENSOR_COLUMNS, "sensors")
    s = pd.DataFrame({"sensor_id": _ids(sensors, "sensors"),
                      "x_m": _numeric(sensors, "x_m", "sensors")})
    if "z_m" in sensors.columns:
        s["z_m"] = _numeric(sensors, "z_m", "sensors", allow_nan=True)
    dup = s["sensor_id"][s["sensor_id"].duplicated()]
    if len(dup):
        raise InputError(f"sensors table: sensor id {dup.iloc[0]!r} appears more than once; ids must be unique.")
    if len(s) < 3:
        raise InputError(f"sensors table: at least 3 sensors are needed; got {len(s)}.")
    s = s.sort_values("x_m", kind="stable").reset_index(drop=True)
    same = np.nonzero(np.diff(s["x_m"].to_numpy()) <= 0)[0]
    if same.size:
        i = int(same[0])
        raise InputError(f"sensors table: sensors {s['sensor_id'][i]!r} and {s['sensor_id'][i + 1]!r} are at the same "
                         f"station x = {s['x_m'][i]} m; each sensor needs its own station.")
    return s


def _valid_readings(readings: pd.DataFrame, s: pd.DataFrame, angle_unit: str, check_units: bool,
                    warnings: list, temperature_fill: bool = True, timezone: str | None = None) -> pd.DataFrame:
    """The readings table: known sensors, one reading per (sensor, time), sorted, angles in degrees."""
    _require_columns(readings, READING_COLUMNS, "readings")
    ids = _ids(readings, "readings")
    r = pd.DataFrame({"timestamp": _times(readings["timestamp"].to_numpy(), "readings", "timestamp",
                                          timezone=timezone, groups=ids),
                      "sensor_id": ids,
                      "angle_deg": _numeric(readings, "angle_deg", "readings", allow_nan=True),
                      "temperature_c": _numeric(readings, "temperature_c", "readings", allow_nan=True)})
    known = set(s["sensor_id"])
    unknown = sorted(set(r["sensor_id"].unique()) - known)
    if unknown:
        raise InputError(f"readings table: {len(unknown)} sensor id(s) not in the sensors table, e.g. "
                         f"{unknown[:5]}; add them to the sensors table (with their station) or remove their readings.")
    r = _drop_exact_duplicates(r, warnings)
    dups = r.duplicated(["sensor_id", "timestamp"])
    if dups.any():
        i = int(np.nonzero(dups.to_numpy())[0][0])
        first = r[(r["sensor_id"] == r["sensor_id"][i]) & (r["timestamp"] == r["timestamp"][i])].iloc[0]
        raise InputError(f"readings table, {_row(i)}: two different readings for sensor {r['sensor_id'][i]!r} at "
                         f"{r['timestamp'][i]} (angle {first['angle_deg']:g} and {r['angle_deg'][i]:g} deg); keep "
                         "one reading per sensor and timestamp." + _clock_change_hint(r, dups))
    if timezone is None:
        _spring_forward(r)
    back = (r.groupby("sensor_id", sort=False)["timestamp"].diff() < pd.Timedelta(0)).to_numpy()
    if back.any():
        bad = sorted(set(r["sensor_id"].to_numpy()[back]))
        warnings.append(f"readings of {len(bad)} sensor(s) were not in time order (e.g. {bad[:3]}); they were sorted.")
    r = r.sort_values(["sensor_id", "timestamp"], kind="stable").reset_index(drop=True)
    if angle_unit == "rad":
        r["angle_deg"] = np.rad2deg(r["angle_deg"])
    _check_reading_ranges(r)
    if check_units and (level := track_angle(r)) > MAX_TRACK_ANGLE_DEG:
        given = "radians converted to degrees" if angle_unit == "rad" else "degrees"
        raise UnitsError(f"readings: the sensors read a median {level:.3g} deg from level (median over sensors of "
                         f"each one's median |angle|, as {given}); sleeper inclinometers read within a few degrees of "
                         f"level (<= {MAX_TRACK_ANGLE_DEG:g} deg): "
                         + ("are the angles degrees? Then drop angle_unit='rad' (CLI: --angle-unit rad). "
                            if angle_unit == "rad" else "are they millidegrees or another unit under angle_deg? ")
                         + "If they really are, pass check_units=False (--no-check-units).")
    if angle_unit == "deg" and check_units:
        noise = angle_noise(r)
        if np.isfinite(noise) and noise < RADIAN_NOISE_THRESHOLD:
            raise UnitsError(f"readings: the angle noise is {noise:.2g} (median over sensors of the robust std of "
                             f"successive differences), implausibly small for degrees (inclinometers: ~1e-3..1e-2 deg); "
                             "the angles look like radians. Pass angle_unit='rad' (CLI: --angle-unit rad), or "
                             "check_units=False (--no-check-units) if they really are degrees.")
    if temperature_fill:
        r, filled, stuck = fill_temperature(r, s)
        if stuck:
            warnings.append(_stuck_warning(stuck))
        if filled:
            warnings.append(_filled_warning(filled))
    empty = int((r["angle_deg"].isna() | r["temperature_c"].isna()).sum())
    if empty:
        warnings.append(f"{empty} reading(s) have an empty angle or temperature and are not used."
                        + _temperature_less(r))
    without = sorted(known - set(r["sensor_id"].unique()))
    if without:
        warnings.append(f"{len(without)} sensor(s) have no readings at all: {without[:5]}; they are reported as dead.")
    return r


def _valid_survey(survey, s: pd.DataFrame, warnings: list, check_units: bool = True):
    """The initial survey covering every sensor (or the sensors' z_m column)."""
    sv = None
    if survey is not None:
        _require_columns(survey, SURVEY_COLUMNS, "survey")
        sv = pd.DataFrame({"x_m": _numeric(survey, "x_m", "survey"), "z_m": _numeric(survey, "z_m", "survey")})
        back = np.flatnonzero(np.diff(sv["x_m"].to_numpy()) < 0)
        if back.size:
            i = int(back[0]) + 1
            warnings.append(f"survey table: the points are not in order of x_m (row {i}: x = {sv['x_m'][i]:g} m after "
                            f"{sv['x_m'][i - 1]:g} m); they were sorted by x_m: check for a mistyped station.")
        sv = sv.sort_values("x_m", kind="stable").reset_index(drop=True)
        if sv["x_m"].duplicated().any():
            raise InputError("survey table: two altitudes at the same x_m; keep one per position.")
        if len(sv) < 2:
            raise InputError(f"survey table: at least 2 points are needed; got {len(sv)}.")
        lo, hi = sv["x_m"].iloc[0], sv["x_m"].iloc[-1]
        x = s["x_m"].to_numpy()
        out = s["sensor_id"][(x < lo - 1e-9) | (x > hi + 1e-9)]
        if "z_m" in s.columns:
            warnings.append("the sensors table has a z_m column and a survey table was given: the survey is used.")
        if len(out):
            raise InputError(f"survey table covers x = {lo:g}..{hi:g} m but {len(out)} sensor(s) lie outside, e.g. "
                             f"{list(out[:5])}; extend the survey to cover every sensor (altitudes are never extrapolated).")
        sx = sv["x_m"].to_numpy()
        n_in = int(((sx >= x[0]) & (sx <= x[-1])).sum())
        if hi - lo > MAX_SURVEY_EXTENT_RATIO * (x[-1] - x[0]) and n_in < 2 and len(sv) - n_in >= 3:
            raise UnitsError(f"survey table: its stations span {lo:g}..{hi:g} m, {(hi - lo) / (x[-1] - x[0]):.0f} times "
                             f"the sensors' {x[0]:g}..{x[-1]:g} m, with {n_in} of its {len(sv)} points among the sensors: "
                             "are its stations in millimetres under x_m? Name the column with its unit (e.g. x_mm) or "
                             "convert it to metres.")
    elif "z_m" in s.columns and s["z_m"].notna().all():
        sv = pd.DataFrame({"x_m": s["x_m"], "z_m": s["z_m"]})
        warnings.append("no survey table: the initial profile is the sensors' z_m column.")
    else:
        raise InputError("no initial altitude: give a survey table (x_m, z_m) or a z_m column in the sensors table.")
    check_survey(sv, check_units=check_units,
                 table="survey table" if survey is not None else "sensors table's z_m column")
    return sv


def check_survey(survey: pd.DataFrame, *, check_units: bool = True, table: str = "survey table") -> None:
    """Refuse a survey (``x_m``, ``z_m``; sorted by ``x_m``, distinct stations) in another unit than metres: an
    altitude beyond any terrain (:data:`~longprofile.core.MAX_ABS_ELEVATION_M`) and, with ``check_units``, a median
    grade beyond :data:`MAX_SURVEY_GRADE`. :func:`validate_site` runs it, and the monitoring service on a new survey.

    Raises
    ------
    UnitsError
        Naming the value or the grade, and the likely unit mix-up.
    """
    _check_altitudes(survey, table)
    x, z = survey["x_m"].to_numpy(float), survey["z_m"].to_numpy(float)
    if check_units and x.size >= 3 and (grade := float(np.median(np.abs(np.diff(z)) / np.diff(x)))) > MAX_SURVEY_GRADE:
        raise UnitsError(f"{table}: the altitudes change by a median {grade:.3g} m per m of track (a {100 * grade:.0f} % "
                         "grade), beyond a railway's: they look like millimetres under a metre label; name the column "
                         "z_mm or convert it to metres (check_units=False, --no-check-units, if the grade is real).")


def _check_altitudes(t: pd.DataFrame, table: str) -> None:
    """Refuse an altitude beyond any terrain (:data:`~longprofile.core.MAX_ABS_ELEVATION_M`): another unit."""
    z = t["z_m"].to_numpy()
    big = np.abs(z) > MAX_ABS_ELEVATION_M
    if big.any():
        i = int(np.flatnonzero(big)[0])
        raise UnitsError(f"{table}: altitude z_m = {z[i]:.6g} m at x = {t['x_m'].iloc[i]:g} m, beyond any terrain "
                         f"(|z| <= {MAX_ABS_ELEVATION_M:g} m): the values look like millimetres (or another unit) "
                         "under a metre label; name the column with its unit (e.g. z_mm) or convert it to metres.")


def _valid_controls(controls, s: pd.DataFrame, sv: pd.DataFrame, warnings: list):
    """The control surveys (None when not given), sorted by date and station; their altitudes in the initial
    survey's unit and datum (within :data:`MAX_CONTROL_CHANGE_M` of it where it covers them)."""
    ct = None
    if controls is not None:
        _require_columns(controls, CONTROL_COLUMNS, "controls")
        ct = pd.DataFrame({"date": _times(controls["date"].to_numpy(), "controls", "date").dt.normalize(),
                           "x_m": _numeric(controls, "x_m", "controls"), "z_m": _numeric(controls, "z_m", "controls")})
        _check_altitudes(ct, "controls table")
        sx, sz = sv["x_m"].to_numpy(), sv["z_m"].to_numpy()
        inside = ((ct["x_m"] >= sx[0]) & (ct["x_m"] <= sx[-1])).to_numpy()
        change = ct["z_m"].to_numpy() - np.interp(ct["x_m"].to_numpy(), sx, sz)
        far = inside & (np.abs(change) > MAX_CONTROL_CHANGE_M)
        if far.any():
            i = int(np.flatnonzero(far)[0])
            raise UnitsError(f"controls table: the altitude at x = {ct['x_m'].iloc[i]:g} m on "
                             f"{ct['date'].iloc[i]:%Y-%m-%d} is {change[i]:+.6g} m from the initial survey there, beyond "
                             f"any settlement (|change| <= {MAX_CONTROL_CHANGE_M:g} m): give the controls in metres "
                             "(or name the column with its unit, e.g. z_mm) and on the initial survey's datum.")
        x = s["x_m"].to_numpy()
        outside = (ct["x_m"] < x[0]) | (ct["x_m"] > x[-1])
        if outside.any():
            warnings.append(f"{int(outside.sum())} control point(s) lie outside the instrumented span "
                            f"{x[0]:g}..{x[-1]:g} m and are not compared.")
        ct = ct.sort_values(["date", "x_m"], kind="stable").reset_index(drop=True)
    return ct
