"""Recompute a site's settlement from its stored readings with ``longprofile.rail.estimate_settlement``.

A run reads the site's data version (the watermark), validates the stored tables with ``validate_site`` and
calls ``estimate_settlement_from_daily`` on the cached per-day statistics (``estimate_settlement`` for the lagged
thermal model) — the functions ``rail settle`` calls, with the settlement model of the site's ``model`` setting
(:func:`service_joint_days`: the all-days model up to :data:`ALL_DAYS_MAX_SENSOR_DAYS`) — then stores the daily posterior (90 %
bands), the through-time rates, the sensor health and the alarm transitions in one transaction. Each run
records the code version, a hash of everything that shaped the result (settings, sensors, survey,
thresholds, baseline), the data watermark, "data complete to T" and the earliest changed timestamp.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import replace
from datetime import datetime, timezone

import numpy as np
import pandas as pd
from sqlalchemy import BigInteger, Integer, delete, func, select, update

from ... import __version__
from ...errors import InputError, LongprofileError
from .. import (
    DAY_FIELDS,
    MEDIAN_LINES,
    NOISE_STD_TOLERANCE,
    STUCK_MIN_READINGS,
    STUCK_SITE_SPREAD_C,
    TEMPERATURE_NEIGHBOURS,
    TEMPERATURE_OFFSET_DAYS,
    DayStatistics,
    daily_angles_from_statistics,
    day_statistics,
    estimate_settlement,
    estimate_settlement_from_daily,
    fill_temperature,
    site_with_events,
    statistics_window,
)
from ._alarms import evaluate_no_data, evaluate_result, thresholds_of
from ._db import (
    ControlComparison,
    ControlPoint,
    Database,
    DayCache,
    DayStat,
    HealthRow,
    Reading,
    ResultRow,
    Run,
    Sensor,
    Site,
    SurveyPoint,
    now_ts,
)
from ._events import events_table

__all__ = ["recompute", "check_settings", "latest_run", "load_site_data", "load_site_tables", "controls_table",
           "temperature_channel_days",
           "DEFAULT_SETTINGS", "KEEP_RUNS", "MODELS", "ALL_DAYS_MAX_SENSOR_DAYS", "service_joint_days"]

DEFAULT_SETTINGS = {"thermal": "linear", "n_monte_carlo": 0, "alarm_probability": 0.5, "sigma_deg": None,
                    "rigidity": None, "exclude": [], "model": "auto"}
#: Settlement models of the ``model`` setting: "auto" (:func:`service_joint_days`), "all-days", "per-day".
MODELS = ("auto", "all-days", "per-day")
#: Result rows are kept for this many newest successful runs of a site (run records are kept for ever).
KEEP_RUNS = 3


def check_settings(st: dict) -> dict:
    unknown = sorted(set(st) - set(DEFAULT_SETTINGS))
    if unknown:
        raise InputError(f"unknown setting(s) {unknown}; known: {sorted(DEFAULT_SETTINGS)}.")
    if "thermal" in st and st["thermal"] not in ("linear", "lagged", "none", "auto"):
        raise InputError(f"thermal must be linear, lagged, none or auto; got {st['thermal']!r}.")
    if "n_monte_carlo" in st and not (isinstance(st["n_monte_carlo"], int) and 0 <= st["n_monte_carlo"] <= 10000):
        raise InputError("n_monte_carlo must be an integer in 0..10000.")
    if "alarm_probability" in st and not (0 < float(st["alarm_probability"]) <= 1):
        raise InputError("alarm_probability must be in (0, 1].")
    for k in ("sigma_deg", "rigidity"):
        if st.get(k) is not None and not (math.isfinite(float(st[k])) and float(st[k]) > 0):
            raise InputError(f"{k} must be > 0 or null.")
    if "model" in st and st["model"] not in MODELS:
        raise InputError(f"model must be one of {', '.join(MODELS)}; got {st['model']!r}.")
    if "exclude" in st and not (isinstance(st["exclude"], list) and all(isinstance(v, str) for v in st["exclude"])):
        raise InputError("exclude must be a list of sensor ids.")
    return dict(st)


def _iso(ts):
    return None if ts is None else datetime.fromtimestamp(ts, timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def _float_columns(s, query, n_columns: int, *, chunk: int = 65536, blob: int = 0):
    """(rows, n_columns) float64 array of a query's numeric rows (NULL -> NaN).

    The query is compiled by SQLAlchemy for the session's dialect and run on the raw DBAPI cursor (sqlite3 or
    psycopg), whose plain tuples numpy converts a chunk at a time: SQLAlchemy's ``Row`` processing took a third
    of loading the day cache and the readings (docs/rail-service.md, Measured), and ``np.array`` on ``Row``
    objects probes each for the array protocols (9 of 11.7 s of loading 432 000 readings). With ``blob`` the
    query's last column holds ``blob`` little-endian float64 per row (NULL -> NaN) and the result is
    (array, (rows, blob) array).
    """
    conn = s.connection()
    compiled = query.compile(dialect=conn.dialect, compile_kwargs={"render_postcompile": True})
    params = compiled.construct_params()
    args = tuple(params[k] for k in compiled.positiontup) if compiled.positional else params
    cur = conn.connection.dbapi_connection.cursor()
    parts, blobs = [], []
    nan = np.full(blob, np.nan).astype("<f8").tobytes()
    try:
        cur.execute(str(compiled), args)
        while rows := cur.fetchmany(chunk):
            if blob:
                blobs.append(np.frombuffer(b"".join(nan if r[-1] is None else bytes(r[-1]) for r in rows), "<f8"))
                rows = [r[:-1] for r in rows]
            parts.append(np.array(rows, dtype=float).reshape(-1, n_columns))  # None -> NaN
    finally:
        cur.close()
    arr = np.concatenate(parts) if parts else np.empty((0, n_columns))
    if not blob:
        return arr
    return arr, (np.concatenate(blobs) if blobs else np.empty(0)).reshape(-1, blob).astype(float)


def _sensor_table(sens) -> pd.DataFrame:
    sensors = pd.DataFrame({"sensor_id": [r[1] for r in sens], "x_m": [r[2] for r in sens]})
    if sens and all(r[3] is not None for r in sens):
        sensors["z_m"] = [r[3] for r in sens]
    return sensors


def _survey_table(s, site: Site):
    sv = list(s.execute(select(SurveyPoint.x_m, SurveyPoint.z_m).where(SurveyPoint.site_id == site.id)
                        .order_by(SurveyPoint.x_m)))
    return pd.DataFrame({"x_m": [p[0] for p in sv], "z_m": [p[1] for p in sv]}) if sv else None


def controls_table(s, site: Site, *, upto: str | None = None):
    """The site's control surveys as the ``controls`` table ``rail settle`` reads (date as ``YYYY-MM-DD`` text,
    x_m, z_m; dates up to ``upto``), or None when there are none."""
    q = select(ControlPoint.date, ControlPoint.x_m, ControlPoint.z_m).where(ControlPoint.site_id == site.id)
    if upto is not None:
        q = q.where(ControlPoint.date <= upto)
    rows = list(s.execute(q.order_by(ControlPoint.date, ControlPoint.x_m)))
    return pd.DataFrame(rows, columns=["date", "x_m", "z_m"]) if rows else None


def load_site_tables(s, site: Site):
    """(sensors, survey) tables of a site as a recompute reads them (active sensors, by station)."""
    return _sensor_table(_active_sensors(s, site)), _survey_table(s, site)


def load_site_data(s, site: Site, *, chunk: int = 65536):
    """(sensors, readings, survey) DataFrames of a site in the long format ``validate_site`` reads."""
    sens = _active_sensors(s, site)
    return _sensor_table(sens), _readings_frame(s, site, sens, chunk=chunk), _survey_table(s, site)


_NO_READINGS = "have no readings at all"


def _with_record_warnings(sitedata, stats: DayStatistics):
    """The site validated on the recomputed window, with the "no readings" warning of the whole record."""
    w = [m for m in sitedata.warnings if _NO_READINGS not in m]
    without = [sid for sid, n in zip(stats.sensor_ids, stats.n_raw.sum(axis=0)) if n == 0]
    if without:
        w.append(f"{len(without)} sensor(s) {_NO_READINGS}: {without[:5]}; they are reported as dead.")
    return replace(sitedata, warnings=tuple(w))


#: Reference temperature of the thermal correction in the service (``estimate_settlement``'s default), °C.
REFERENCE_TEMP_C = 5.0
_DAY_S = 86400


def _active_sensors(s, site: Site):
    """[(sensor pk, sensor id, x_m, z_m)] of the site's active sensors, by station."""
    return [tuple(r) for r in s.execute(select(Sensor.id, Sensor.sensor_id, Sensor.x_m, Sensor.z_m)
                                        .where(Sensor.site_id == site.id, Sensor.active.is_(True))
                                        .order_by(Sensor.x_m))]


def _readings_frame(s, site: Site, sens, *, from_ts=None, to_ts=None, pks=None, chunk: int = 65536) -> pd.DataFrame:
    """The stored readings (from ``from_ts``, before ``to_ts``; of the sensors ``pks``) in the long format, each
    sensor's rows in time order (what ``day_statistics`` and ``validate_site`` read)."""
    names = {r[0]: r[1] for r in sens}
    q = select(Reading.sensor_pk, Reading.ts, Reading.angle_deg, Reading.temperature_c).where(
        Reading.site_id == site.id)
    lo = site.baseline_start_ts if from_ts is None else max(from_ts, site.baseline_start_ts or from_ts)
    if lo is not None:
        q = q.where(Reading.ts >= lo)
    if to_ts is not None:
        q = q.where(Reading.ts < int(to_ts))
    if pks is not None:
        q = q.where(Reading.sensor_pk.in_(list(pks)))
    arr = _float_columns(s, q, 4, chunk=chunk)
    pk = arr[:, 0].astype(np.int64)
    keep = np.isin(pk, np.fromiter(names, dtype=np.int64, count=len(names)))
    arr, pk = arr[keep], pk[keep]
    order = np.lexsort((arr[:, 1], pk))
    arr, pk = arr[order], pk[order]
    return pd.DataFrame({"timestamp": pd.to_datetime(arr[:, 1].astype(np.int64), unit="s"),
                         "sensor_id": pd.Series(names).reindex(pk).to_numpy(), "angle_deg": arr[:, 2],
                         "temperature_c": arr[:, 3]})


def _filled(s, site: Site, frame: pd.DataFrame, *, subset: bool = False, from_ts=None) -> pd.DataFrame:
    """``frame`` (the readings of every active sensor from ``from_ts``; with ``subset``, of some of them) with the
    temperatures ``validate_site`` fills
    (:func:`longprofile.rail.fill_temperature`: a reading with an angle but no temperature, or a stuck one, takes
    its nearest sensors' of the same minute plus its own offset from them before), decided and filled from every
    active sensor's readings of the same span and of the earlier days the offsets need
    (:func:`_fill_history`): what the day cache holds is then what ``rail settle`` computes from the same readings.
    The stuck test is decided per sensor and calendar day, and every day it reads is whole. A frame of some of the
    sensors (a stale sensor rebuilt, a sensor's page) is filled from all of them, read again."""
    ids = _sensors_to_fill(frame)
    if not ids:
        return frame
    everyone = _active_sensors(s, site)
    present = frame["sensor_id"].unique() if subset else None
    if subset:
        frame = _readings_frame(s, site, everyone, from_ts=from_ts)
        ids = _sensors_to_fill(frame)
    history = _fill_history(s, site, everyone, frame, from_ts, ids)
    both = frame if history is None else pd.concat([history, frame], ignore_index=True)
    full, filled, stuck = fill_temperature(both, _sensor_table(everyone))  # row order kept: the frame's rows last
    if not filled and not stuck:
        return frame if present is None else frame[frame["sensor_id"].isin(present)].reset_index(drop=True)
    full = full.iloc[both.shape[0] - frame.shape[0]:].reset_index(drop=True)
    return full if present is None else full[full["sensor_id"].isin(present)].reset_index(drop=True)


def _fill_history(s, site: Site, everyone, frame: pd.DataFrame, from_ts, ids: set) -> pd.DataFrame | None:
    """The readings before ``from_ts`` that :func:`longprofile.rail.fill_temperature`'s offsets read for the frame's
    filled readings (None for a frame of the whole record): the whole day of ``from_ts``; the
    ``TEMPERATURE_OFFSET_DAYS`` before it when a sensor to fill also has temperatures in the frame (an offset window
    may end on a day of the frame); and for each sensor with a reading to fill, the same number of days ending on its
    last own-temperature day before that day (from one aggregate query: :func:`_temperature_days`). Every sensor's
    readings of those days: the stuck test and the neighbours' medians read them all. ``ids``: the frame's sensors to
    fill (:func:`_sensors_to_fill`)."""
    if from_ts is None:
        return None
    first = int(from_ts) // _DAY_S
    t = frame["temperature_c"]
    pks = [r[0] for r in everyone if r[1] in ids]
    spans = [(first, first)]  # the window's first day, whole
    if frame["sensor_id"][t.notna() & frame["sensor_id"].isin(ids)].size:
        # a sensor to fill that also reads its own temperature in the window: an offset may end on a day in it, and
        # its days reach back before the window
        spans.append((first - TEMPERATURE_OFFSET_DAYS, first))
    if pks:
        pk, day, _, n_t, lo, hi = _temperature_days(s, site, pks, before_day=first)
        own = (n_t > 0) & ~((n_t >= STUCK_MIN_READINGS) & (lo == hi))
        ends = pd.Series(day[own]).groupby(pk[own]).max().to_numpy()
        spans += [(int(e) - TEMPERATURE_OFFSET_DAYS + 1, int(e)) for e in np.unique(ends)]
    merged = []
    for a, b in sorted(spans):  # whole days a..b, merged where they touch
        if merged and a <= merged[-1][1] + 1:
            merged[-1][1] = max(merged[-1][1], b)
        else:
            merged.append([a, b])
    parts = [_readings_frame(s, site, everyone, from_ts=a * _DAY_S, to_ts=min((b + 1) * _DAY_S, int(from_ts)))
             for a, b in merged if a * _DAY_S < int(from_ts)]
    return pd.concat(parts, ignore_index=True) if parts else None


def _temperature_days(s, site: Site, pks, *, before_day=None):
    """Per sensor and UTC day of the stored readings with an angle (from the baseline on, before ``before_day``):
    (sensor pk, day, readings, temperatures, lowest, highest) arrays; one aggregate query."""
    day = Reading.ts // _DAY_S
    q = (select(Reading.sensor_pk, day, func.count(), func.count(Reading.temperature_c), func.min(Reading.temperature_c),
                func.max(Reading.temperature_c))
         .where(Reading.sensor_pk.in_([int(p) for p in pks]),  # not site_id: SQLite would scan the site's index
                Reading.angle_deg.is_not(None)).group_by(Reading.sensor_pk, day).order_by(Reading.sensor_pk, day))
    if site.baseline_start_ts is not None:
        q = q.where(Reading.ts >= site.baseline_start_ts)
    if before_day is not None:
        q = q.where(Reading.ts < int(before_day) * _DAY_S)
    rows = s.execute(q).all()
    pk, day, n, n_t = (np.array([r[k] for r in rows], dtype=np.int64) for k in range(4))
    lo, hi = (np.array([np.nan if r[k] is None else r[k] for r in rows], dtype=float) for k in (4, 5))
    return pk, day, n, n_t, lo, hi


def _sensors_to_fill(frame: pd.DataFrame) -> set:
    """The sensors of ``frame`` whose readings ``fill_temperature`` could change, given the other sensors: an angle
    without a temperature, or a sensor-day of at least ``STUCK_MIN_READINGS`` temperatures all the same (stuck if the
    others' move). Empty: nothing to fill."""
    t = frame["temperature_c"]
    ids = set(frame["sensor_id"][t.isna() & frame["angle_deg"].notna()].unique())
    per_day = t.groupby([frame["sensor_id"], frame["timestamp"].dt.normalize()]).agg(["size", "nunique"])
    const = (per_day["size"] >= STUCK_MIN_READINGS) & (per_day["nunique"] == 1)
    return ids | set(per_day.index.get_level_values(0)[const])


def _cache_key(site: Site, thermal: str) -> str:
    blob = json.dumps({"thermal": thermal, "reference_temp_c": REFERENCE_TEMP_C, "fields": DAY_FIELDS,
                       "median_lines": MEDIAN_LINES, "noise_std_tolerance": NOISE_STD_TOLERANCE,
                       "temperature_neighbours": TEMPERATURE_NEIGHBOURS,
                       "temperature_offset_days": TEMPERATURE_OFFSET_DAYS, "stuck": [STUCK_MIN_READINGS,
                                                                                    STUCK_SITE_SPREAD_C],
                       "baseline_start": site.baseline_start_ts, "code": __version__}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


_CACHE_COLUMNS = ("sensor_pk", "day") + DAY_FIELDS


def _day_cache_rows(s, site: Site, memo: dict | None = None):
    """All ``day_stats`` rows of a site as ((rows, columns) float array, (rows, 2 MEDIAN_LINES) median lines).

    ``memo`` is the process's copy (``Database.memo``) of what the last run of this process stored: it is used
    instead of reading the table when the table's state (``day_cache``: key, data version, update time) and row
    count are still the ones that run committed, i.e. no other process has written the cache since. Both paths
    give the same arrays (the values are float64, integer or NULL, which round-trip the database exactly; tested
    bit for bit in tests/rail/service/test_day_cache_memo.py; a writer that leaves key, version, update second and
    row count as they were would have to store the same data version, i.e. the same rows).
    """
    state = s.get(DayCache, site.id)
    mine = None if memo is None else memo.get(("day_cache", site.id))
    if mine is not None and state is not None and mine[0] == (state.key, state.data_version, state.updated_ts):
        n = s.scalar(select(func.count()).select_from(DayStat).where(DayStat.site_id == site.id))
        if n == mine[1].shape[0]:
            return mine[1], mine[2]
    q = select(*[getattr(DayStat, c) for c in _CACHE_COLUMNS], DayStat.median_lines).where(
        DayStat.site_id == site.id)
    return _float_columns(s, q, len(_CACHE_COLUMNS), blob=2 * MEDIAN_LINES)


def _load_day_cache(s, site: Site, sens, thermal: str, memo: dict | None = None) -> DayStatistics | None:
    """The site's cached per-day statistics of its active sensors (None when there are none)."""
    return _day_cache_statistics(_day_cache_rows(s, site, memo), sens, thermal)


def _day_cache_statistics(rows, sens, thermal: str) -> DayStatistics | None:
    """``DayStatistics`` of the active sensors ``sens`` from the cache's rows (None when none is theirs)."""
    arr, lines = rows
    col = {pk: j for j, (pk, *_) in enumerate(sens)}
    pk = arr[:, 0].astype(np.int64)
    keep = np.isin(pk, np.fromiter(col, dtype=np.int64, count=len(col)))
    arr, pk, lines = arr[keep], pk[keep], lines[keep]
    if arr.shape[0] == 0:
        return None
    dnum = arr[:, 1].astype(np.int64)
    udays = np.unique(dnum)
    di = np.searchsorted(udays, dnum)
    sj = pd.Series(col).reindex(pk).to_numpy()
    D, N = udays.size, len(sens)
    fields = {}
    for k, f in enumerate(DAY_FIELDS):
        integer = isinstance(DayStat.__table__.c[f].type, (Integer, BigInteger))
        v = np.full((D, N), -1 if f == "last_ts" else 0, dtype=np.int64) if integer else np.full((D, N), np.nan)
        if f == "temperature_sum_c":
            v[:] = 0.0
        v[di, sj] = arr[:, 2 + k].astype(np.int64) if integer else arr[:, 2 + k]
        fields[f] = v
    fields["median_lines"] = np.full((D, N, 2 * MEDIAN_LINES), np.nan)
    fields["median_lines"][di, sj] = lines
    nan = np.full(N, np.nan)
    return DayStatistics(days=(udays * _DAY_S * 10**9).astype("datetime64[ns]"), sensor_ids=[r[1] for r in sens],
                         **fields, noise_deg=nan, raw_std_deg=nan, thermal_coef=nan, unfitted=np.zeros(N, bool),
                         thermal=thermal, reference_temp_c=REFERENCE_TEMP_C, exact=False)


#: Columns of :func:`sensor_daily_statistics`.
SENSOR_DAILY_COLUMNS = ("day", "n_raw", "raw_median_deg", "median_deg", "mean_temp_c", "temp_range_c",
                        "n_no_temperature", "constant_temperature")


def temperature_channel_days(s, site: Site, sensor_pk: int) -> pd.DataFrame:
    """What a sensor's own temperature channel sent, per UTC day: ``day`` (``YYYY-MM-DD``), ``n_no_temperature``
    (readings with an angle and no temperature) and ``constant_temperature`` (at least ``STUCK_MIN_READINGS``
    temperatures, all one value). One aggregate query of the stored readings. Such readings take their neighbours'
    temperature in the estimate (``rail.fill_temperature``; a constant day only when the other sensors' temperatures
    move that day), which the sensor page says."""
    _, d, n, n_t, lo, hi = _temperature_days(s, site, [sensor_pk])
    return pd.DataFrame({"day": pd.to_datetime(d * _DAY_S, unit="s").strftime("%Y-%m-%d"), "n_no_temperature": n - n_t,
                         "constant_temperature": (n_t >= STUCK_MIN_READINGS) & (lo == hi)})


def sensor_daily_statistics(s, site: Site, sensor_id: str) -> pd.DataFrame:
    """One sensor's per-day statistics for its time-series page: ``day`` (``YYYY-MM-DD``), readings that day,
    the median raw angle (deg), the median thermally corrected angle (deg; NaN when not cached), the mean
    temperature and the kept readings' temperature range (degC). The definitions are ``rail.day_statistics``'s.

    From the day cache (one indexed read of the sensor's rows) when it is kept for the site's thermal model;
    otherwise (the lagged model, which fits over the whole record) ``day_statistics`` of the sensor's readings
    with the linear model, whose corrected median is then left out (it is not the one the estimate used).
    """
    sens = [r for r in _active_sensors(s, site) if r[1] == sensor_id]
    if not sens:
        raise InputError(f"unknown sensor {sensor_id[:64]!r} on site {site.name!r}.")
    thermal = {**DEFAULT_SETTINGS, **site.settings}["thermal"]
    state = s.get(DayCache, site.id)
    if thermal in ("linear", "none") and state is not None and state.key == _cache_key(site, thermal):
        rows = s.execute(select(DayStat.day, DayStat.n_raw, DayStat.raw_median_deg, DayStat.median_deg,
                                DayStat.temperature_sum_c, DayStat.n_temperature, DayStat.temp_range_c)
                         .where(DayStat.sensor_pk == sens[0][0]).order_by(DayStat.day)).all()
        df = pd.DataFrame(rows, columns=["day", "n_raw", "raw_median_deg", "median_deg", "temperature_sum_c",
                                         "n_temperature", "temp_range_c"])
        day = pd.to_datetime(df["day"].to_numpy(np.int64) * _DAY_S, unit="s")
        fields = {f: df[f].to_numpy(float) for f in ("raw_median_deg", "median_deg", "temperature_sum_c",
                                                     "temp_range_c")}
        n_raw, n_temp = df["n_raw"].to_numpy(np.int64), df["n_temperature"].to_numpy(np.int64)
    else:
        readings = _filled(s, site, _readings_frame(s, site, sens), subset=True)
        if readings.empty:
            return pd.DataFrame(columns=list(SENSOR_DAILY_COLUMNS))
        st = day_statistics(readings, [sensor_id], thermal="linear", reference_temp_c=REFERENCE_TEMP_C)
        day = pd.DatetimeIndex(st.days)
        fields = {f: getattr(st, f)[:, 0].astype(float) for f in ("raw_median_deg", "median_deg",
                                                                  "temperature_sum_c", "temp_range_c")}
        fields["median_deg"] = np.full(day.size, np.nan)
        n_raw, n_temp = st.n_raw[:, 0], st.n_temperature[:, 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_t = np.where(n_temp > 0, fields["temperature_sum_c"] / n_temp, np.nan)
    out = pd.DataFrame({"day": day.strftime("%Y-%m-%d"), "n_raw": n_raw, "raw_median_deg": fields["raw_median_deg"],
                        "median_deg": fields["median_deg"], "mean_temp_c": mean_t,
                        "temp_range_c": fields["temp_range_c"]})
    channel = temperature_channel_days(s, site, sens[0][0])
    out = out.merge(channel, on="day", how="left")
    out["n_no_temperature"] = out["n_no_temperature"].fillna(0).astype(np.int64)
    out["constant_temperature"] = out["constant_temperature"].eq(True)
    return out


def _quiet_days(site: Site, days) -> list | None:
    """Days before the baseline end: the thermal fit's quiet days (None without a baseline end)."""
    if site.baseline_end_ts is None:
        return None
    d = pd.DatetimeIndex(days)
    return sorted(d[d < pd.Timestamp(site.baseline_end_ts, unit="s")].strftime("%Y-%m-%d")) or None


def cached_statistics(s, site: Site, sens, thermal: str, dirty_from, memo: dict | None = None):
    """Per-day statistics of the site: the cache, with the days from the earliest change recomputed from raw.

    Returns (stats, window readings as stored (``validate_site`` of the recompute fills them again, and warns), the
    first recomputed day as days since 1970 or None for a full build,
    the sensor columns rebuilt from all their readings, the cache's rows as read (:func:`_day_cache_rows`) and
    the ``day_cache`` state they were read at, None for a full build). Days before the change come from
    ``day_stats``; the readings from the day before the change (3 readings of running-median context further
    back) are loaded and ``day_statistics(previous=...)`` recomputes those days; sensors it finds stale are
    recomputed from all their readings.
    """
    ids = [r[1] for r in sens]
    state = s.get(DayCache, site.id)
    prev = rows = None
    if state is not None and state.key == _cache_key(site, thermal):
        rows = _day_cache_rows(s, site, memo) + ((state.key, state.data_version, state.updated_ts),)
        prev = _day_cache_statistics(rows[:2], sens, thermal)
    if prev is not None and dirty_from is not None and dirty_from < int(prev.days[0].astype("datetime64[s]")
                                                                         .astype(np.int64)) + _DAY_S:
        prev = None  # a change on the first day (settings, sensors, baseline): build from every reading
    if prev is None:
        readings = _readings_frame(s, site, sens)
        if readings.empty:
            return None, readings, None, None, None
        days = pd.DatetimeIndex(readings["timestamp"].dt.normalize().unique())
        stats = day_statistics(_filled(s, site, readings), ids, thermal=thermal, reference_temp_c=REFERENCE_TEMP_C,
                               quiet_days=_quiet_days(site, days))
        return stats, readings, None, list(range(len(ids))), None
    # no recorded change (a forced run): the newest cached day is recomputed, so the window is never empty
    changed = (pd.Timestamp(prev.days[-1]) if dirty_from is None
               else pd.Timestamp(int(dirty_from), unit="s").normalize())
    first, ctx = statistics_window(prev, changed)
    from_ts = int(pd.Timestamp(ctx).value // 10**9)
    window = _readings_frame(s, site, sens, from_ts=from_ts)
    all_days = pd.DatetimeIndex(np.union1d(prev.days[prev.days < first],
                                           window["timestamp"].dt.normalize().unique()))
    quiet = _quiet_days(site, all_days)
    stats = day_statistics(_filled(s, site, window, from_ts=from_ts), ids, thermal=thermal,
                           reference_temp_c=REFERENCE_TEMP_C, quiet_days=quiet, first_day=first, previous=prev)
    rebuilt = []
    if stats.stale_sensors:
        rebuilt = [j for j, sid in enumerate(ids) if sid in stats.stale_sensors]
        sub = _filled(s, site, _readings_frame(s, site, sens, pks=[sens[j][0] for j in rebuilt]), subset=True)
        stats = stats.replace_sensors(day_statistics(sub, [ids[j] for j in rebuilt], thermal=thermal,
                                                     reference_temp_c=REFERENCE_TEMP_C, quiet_days=quiet))
    return stats, window, int(pd.Timestamp(first).value // (_DAY_S * 10**9)), rebuilt, rows


def _store_day_cache(s, site: Site, sens, stats: DayStatistics, first_day, rebuilt, thermal: str, version: int,
                     rows=None):
    """Replace the cached rows from ``first_day`` on (all days when None) and all rows of ``rebuilt`` sensors.

    Returns the memo entry of what the table now holds: ((key, data version, update time), rows, median lines),
    the arrays :func:`_day_cache_rows` would read back (``rows`` = (rows, median lines, ``day_cache`` state) read
    before this change); None when they cannot be known: an incremental change whose rows were not read, or
    another writer's run committed since they were read (then only the table knows the rows kept).
    """
    dnum = np.asarray(stats.days).astype("datetime64[D]").astype(np.int64)
    pks = np.array([r[0] for r in sens], dtype=np.int64)
    if first_day is None:
        s.execute(delete(DayStat).where(DayStat.site_id == site.id))
        mask = np.ones((dnum.size, pks.size), bool)
    else:
        s.execute(delete(DayStat).where(DayStat.site_id == site.id, DayStat.day >= first_day))
        mask = np.broadcast_to((dnum >= first_day)[:, None], (dnum.size, pks.size)).copy()
        if rebuilt:
            s.execute(delete(DayStat).where(DayStat.site_id == site.id, DayStat.day < first_day,
                                            DayStat.sensor_pk.in_([int(pks[j]) for j in rebuilt])))
            mask[:, rebuilt] = True
    mask &= (stats.n_raw > 0) | (stats.n_temperature > 0)
    di, sj = np.nonzero(mask)
    data = {"site_id": [int(site.id)] * di.size, "sensor_pk": pks[sj].tolist(), "day": dnum[di].tolist()}
    for f in DAY_FIELDS:
        data[f] = _column_values(getattr(stats, f)[di, sj])
    lines = np.ascontiguousarray(stats.median_lines[di, sj], dtype="<f8").tobytes()
    width = 2 * MEDIAN_LINES * 8
    data["median_lines"] = [lines[i:i + width] for i in range(0, len(lines), width)]
    bulk_insert(s, DayStat.__table__, data)
    state = s.get(DayCache, site.id)
    unchanged = rows is not None and state is not None and rows[2] == (state.key, state.data_version,
                                                                       state.updated_ts)
    key, ts = _cache_key(site, thermal), now_ts()
    if state is None:
        s.add(DayCache(site_id=site.id, key=key, data_version=version, updated_ts=ts))
    else:
        state.key, state.data_version, state.updated_ts = key, version, ts
    new = np.column_stack([pks[sj], dnum[di]] + [getattr(stats, f)[di, sj] for f in DAY_FIELDS]).astype(float)
    new_lines = stats.median_lines[di, sj].astype("<f8").astype(float)
    if s.connection().dialect.name == "sqlite":
        new += 0.0  # SQLite stores a REAL with no fraction as an integer: -0.0 reads back as 0.0
    if first_day is not None and unchanged:
        arr, lines, _ = rows
        drop = arr[:, 1] >= first_day
        if rebuilt:
            drop |= np.isin(arr[:, 0], pks[rebuilt].astype(float))
        new, new_lines = np.concatenate([arr[~drop], new]), np.concatenate([lines[~drop], new_lines])
    elif first_day is not None:
        return None
    new.setflags(write=False)
    new_lines.setflags(write=False)
    return (key, version, ts), new, new_lines


#: Columns of ``results`` written by a run, and the column of ``SettlementResult.to_table()`` each comes from.
RESULT_COLUMNS = {"day": "date", "sensor_id": "sensor_id", "x_m": "x_m", "status": "status", "dz_m": "dz_m",
                  "dz_std_m": "dz_std_m", "smoothed_dz_m": "smoothed_dz_m", "smoothed_std_m": "smoothed_std_m",
                  "rate_m_per_day": "rate_m_per_day", "rate_std_m_per_day": "rate_std_m_per_day"}


def _column_values(col) -> list:
    """A table column as Python values for the driver: str as is, numbers as float, NaN (or absent) as NULL."""
    values = col.tolist()
    if col.dtype.kind == "f":
        return [None if v != v else v for v in values]  # NaN != NaN
    return values


def bulk_insert(s, table, columns: dict) -> int:
    """Insert rows given column by column ({name: sequence}, equal lengths) in one DBAPI ``executemany``.

    SQLAlchemy's ``insert()`` with a list of dicts builds and processes one parameter dict per row (with the
    DataFrame's ``to_dict``, 0.55 s of storing 36 500 result rows, docs/rail-service.md, Measured); here the
    rows are plain tuples in the driver's positional style (``?`` for sqlite3, ``%s`` for psycopg).
    """
    names = list(columns)
    rows = list(zip(*columns.values()))
    if rows:
        conn = s.connection()
        mark = "?" if conn.dialect.paramstyle == "qmark" else "%s"
        conn.exec_driver_sql(f"INSERT INTO {table.name} ({', '.join(names)}) VALUES ({', '.join([mark] * len(names))})",
                             rows)
    return len(rows)


def _store_results(s, run_id: int, tab: pd.DataFrame) -> int:
    """The run's result rows (every day and sensor of ``SettlementResult.to_table()``)."""
    n = len(tab)
    cols = {"run_id": [int(run_id)] * n}
    for name, src in RESULT_COLUMNS.items():
        cols[name] = _column_values(tab[src].to_numpy()) if src in tab else [None] * n
    return bulk_insert(s, ResultRow.__table__, cols)


#: Columns of ``control_comparisons``, as in ``SettlementResult.controls``.
CONTROL_RESULT_COLUMNS = ("date", "x_m", "dz_control_m", "dz_estimate_m", "std_m", "inside_90")


def _store_controls(s, run_id: int, controls: pd.DataFrame | None) -> int:
    """The run's comparison with the control surveys (``SettlementResult.controls``; nothing when None)."""
    if controls is None or len(controls) == 0:
        return 0
    cols = {"run_id": [int(run_id)] * len(controls)}
    for c in CONTROL_RESULT_COLUMNS:
        cols[c] = _column_values(controls[c].to_numpy())
    return bulk_insert(s, ControlComparison.__table__, cols)


#: Largest site, kept sensors x days, that the "auto" model runs with the all-days model (docs/rail.md step 10, the
#: default of ``rail settle``); larger sites run the per-day model (step 9), within the recompute's 2 s target.
#: 40 000: a year of 100 sensors (leap years too) with a margin. Measured 2026-12-06 after the batched all-days
#: estimate (docs/rail-service.md, "All days within the 2 s recompute"; ``estimate_settlement_from_daily``, hourly
#: readings, CPU time): 0.79-0.87 s for 100 sensors x 365 days, 1.2 s for 100 x 500, 2.4 s for 100 x 730; the
#: benchmark's recompute of 100 x 365 after one new day 1.18 s at load 5.5 on 2 cores (8.18 s before; the limit
#: was 10 000 sensor-days).
ALL_DAYS_MAX_SENSOR_DAYS = 40_000


def service_joint_days(settings: dict, n_sensors: int, n_days: int) -> bool:
    """Whether a recompute of ``n_sensors`` x ``n_days`` runs the all-days model (``joint_days`` of
    :func:`~longprofile.rail.estimate_settlement`): the site's ``model`` setting, "auto" by size
    (:data:`ALL_DAYS_MAX_SENSOR_DAYS`)."""
    model = {**DEFAULT_SETTINGS, **settings}["model"]
    if model == "auto":
        return int(n_sensors) * int(n_days) <= ALL_DAYS_MAX_SENSOR_DAYS
    return model == "all-days"


def _settings_hash(site, sensors, survey, thresholds, settings, controls=None, events=None) -> str:
    what = {"settings": settings, "sensors": sensors.to_dict("list"),
            "survey": None if survey is None else survey.to_dict("list"), "thresholds": thresholds,
            "baseline": [site.baseline_start_ts, site.baseline_end_ts]}
    if controls is not None:  # absent without controls: the hash of a site without them is unchanged
        what["controls"] = controls.to_dict("list")
    if events is not None:  # likewise
        what["events"] = events.to_dict("list")
    blob = json.dumps(what, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


def _model_name(res) -> str | None:
    """The settlement model a result was computed with (``SettlementResult.settings["joint_days"]``: False also when
    the all-days model did not apply, e.g. fewer than 6 days)."""
    return None if res is None else ("all-days" if res.settings.get("joint_days") else "per-day")


def latest_run(s, site: Site, *, ok_only: bool = True) -> Run | None:
    q = select(Run).where(Run.site_id == site.id)
    if ok_only:
        q = q.where(Run.status == "ok")
    return s.scalar(q.order_by(Run.id.desc()).limit(1))


#: Refusals of ``validate_site`` / ``estimate_settlement`` that only mean "not enough data yet": the run is "waiting".
WAITING_MESSAGES = ("at least 2 days", "too few days", "at least 3 sensors", "the readings table is empty")


def _audit_forced(s, site: Site, run: Run, force: bool, actor: str | None) -> None:
    """Audit a recompute someone forced (CLI ``--force``, the API's recompute): who, when (the entry's time), the run."""
    if force and actor is not None:
        from ._core import _audit

        _audit(s, actor, site.id, "run", str(run.id), "recompute", None,
               {"forced": True, "run_id": run.id, "status": run.status, "message": run.message[:200]})


def _failed_or_waiting(exc: Exception) -> str:
    """"waiting" for a run refused for want of data (:data:`WAITING_MESSAGES`), else "failed" (e.g. a sensor outside
    the survey: the site's tables need a change; with no readings yet this was "waiting" before session 36)."""
    return "waiting" if any(w in str(exc) for w in WAITING_MESSAGES) else "failed"


def _has_replacement(events) -> bool:
    return events is not None and bool((events["event"] == "replaced_by").any())


def _estimate(site: Site, settings: dict, sensors, readings, survey, controls, events, stats):
    """The run's ``SettlementResult``: the tables validated with the declared events
    (:func:`longprofile.rail.site_with_events`, as ``rail settle --events``), then ``estimate_settlement_from_daily``
    on the cached statistics (``stats``), or ``estimate_settlement`` on every reading (the lagged and "auto" thermal
    models, and a site with a declared replacement, whose merged series has no cached statistics)."""
    # the units were checked batch by batch at ingestion (where ?check_units=false may have waived them)
    sitedata, events = site_with_events(sensors, readings, survey, controls, events, check_units=False)
    if _has_replacement(events):
        stats = None
    days = readings["timestamp"].dt.normalize().unique() if stats is None else stats.days
    options = dict(
        thermal=settings["thermal"], quiet_days=_quiet_days(site, days),
        sigma=None if settings["sigma_deg"] is None else float(np.deg2rad(settings["sigma_deg"])),
        rigidity=settings["rigidity"], exclude_sensors=tuple(settings["exclude"]),
        n_monte_carlo=int(settings["n_monte_carlo"]), alarm_probability=float(settings["alarm_probability"]),
        joint_days=service_joint_days(settings, len(sitedata.sensor_ids), len(days)), events=events)
    if stats is not None:
        sitedata = _with_record_warnings(sitedata, stats)
        return estimate_settlement_from_daily(sitedata, daily_angles_from_statistics(stats), **options)
    return estimate_settlement(sitedata, **options)


def recompute(db: Database, name: str, *, force: bool = False, actor: str | None = None) -> dict:
    """Recompute a site when its data or settings changed since the last run (``force``: always; with ``actor``,
    the person who asked, audited with the run's id and outcome).

    Returns {"run_id", "status" ("ok", "unchanged", "waiting", "failed"), "message", "events", "seconds"}.
    """
    from ._core import _site

    t0 = time.perf_counter()
    with db.read() as s:
        site = _site(s, name)
        version, dirty_from = site.data_version, site.dirty_from_ts
        settings = {**DEFAULT_SETTINGS, **site.settings}
        thresholds = thresholds_of(s, site)
        sens = _active_sensors(s, site)
        sensors, survey, controls = _sensor_table(sens), _survey_table(s, site), controls_table(s, site)
        events = events_table(s, site, active={r[1] for r in sens})
        last = latest_run(s, site, ok_only=False)
        site_id = site.id
        shash = _settings_hash(site, sensors, survey, thresholds, settings, controls, events)
        if (not force and last is not None and last.data_version == version and last.settings_hash == shash
                and last.code_version == __version__):
            return {"run_id": last.id, "status": "unchanged", "message": "", "events": [],
                    "seconds": time.perf_counter() - t0}
        # linear / no thermal model: per-day statistics cached in day_stats, only the changed days from raw;
        # the lagged model fits its lag over the whole record, and "auto" (rail settle's default) chooses between
        # the two from it: every reading, every run; so does a site with a declared replacement (the replacing
        # sensor's readings join the replaced one's series before the daily statistics, as in rail settle --events)
        cached = settings["thermal"] in ("linear", "none")
        stats = first_day = rebuilt = cache_rows = None
        if cached:  # the cache follows the raw readings in every case
            stats, readings, first_day, rebuilt, cache_rows = cached_statistics(
                s, site, sens, settings["thermal"], dirty_from, db.memo)
        if not cached or _has_replacement(events):
            _, readings, _ = load_site_data(s, site)
    t_load = time.perf_counter() - t0
    if stats is not None:
        complete_to, n_readings = int(stats.last_ts.max()), int(stats.n_raw.sum())
        last_ts = dict(zip(stats.sensor_ids, stats.last_ts.max(axis=0)))
    else:
        complete_to = None if readings.empty else int(readings["timestamp"].max().value // 10**9)
        n_readings = int(len(readings))
        last_ts = {k: int(v.value // 10**9) for k, v in readings.groupby("sensor_id")["timestamp"].max().items()}
    status, message, res = "ok", "", None
    try:
        res = _estimate(site, settings, sensors, readings, survey, controls, events, stats)
    except LongprofileError as exc:
        status = _failed_or_waiting(exc)
        message = str(exc)
    t_estimate = time.perf_counter() - t0 - t_load
    events: list[str] = []
    with db.write() as s:
        site = s.get(Site, site_id)
        run = Run(site_id=site_id, started_ts=now_ts(), code_version=__version__, settings_hash=shash,
                  data_version=version, data_complete_to_ts=complete_to, changed_from_ts=dirty_from,
                  n_readings=n_readings, n_days=0 if res is None else int(res.days.size), status=status,
                  message=message, warnings_json=json.dumps([] if res is None else list(res.warnings)),
                  model=_model_name(res))
        s.add(run)
        s.flush()
        memo = None
        if stats is not None:  # the cache follows the raw readings whatever the run's outcome
            memo = _store_day_cache(s, site, sens, stats, first_day, rebuilt, settings["thermal"], version,
                                    cache_rows)
        if res is not None:
            _store_results(s, run.id, res.to_table())
            _store_controls(s, run.id, res.controls)
            s.execute(HealthRow.__table__.insert(), [
                {"run_id": run.id, "sensor_id": sid, "status": str(st), "reason": str(d),
                 "last_reading_ts": int(last_ts[sid]) if last_ts.get(sid, -1) >= 0 else None}
                for sid, st, d in zip(res.health.sensor_ids, res.health.status, res.health.detail)])
            events = evaluate_result(s, site, res, run.id, float(settings["alarm_probability"]))
            old = list(s.scalars(select(Run.id).where(Run.site_id == site_id, Run.status == "ok", Run.id != run.id)
                                 .order_by(Run.id.desc()).offset(KEEP_RUNS - 1)))
            if old:
                s.execute(delete(ResultRow).where(ResultRow.run_id.in_(old)))
                s.execute(delete(HealthRow).where(HealthRow.run_id.in_(old)))
                s.execute(delete(ControlComparison).where(ControlComparison.run_id.in_(old)))
        events += evaluate_no_data(s, site)
        run.finished_ts = now_ts()
        _audit_forced(s, site, run, force, actor)
        # the site is clean only if nothing arrived meanwhile (compare-and-set on the watermark)
        s.execute(update(Site).where(Site.id == site_id, Site.data_version == version).values(dirty_from_ts=None))
        run_id = run.id
    # remembered only once committed (a failed transaction leaves the previous entry: it still describes the table)
    db.memo.pop(("day_cache", site_id), None)
    if memo is not None:
        db.memo[("day_cache", site_id)] = memo
    return {"run_id": run_id, "status": status, "message": message, "events": events,
            "seconds": time.perf_counter() - t0, "data_complete_to": _iso(complete_to),
            "timings": {"load": t_load, "estimate": t_estimate,
                        "store": time.perf_counter() - t0 - t_load - t_estimate},
            "model": _model_name(res),
            "recomputed_from_day": None if first_day is None else _iso(first_day * _DAY_S)[:10],
            "rebuilt_sensors": None if rebuilt is None else len(rebuilt)}
