"""Recompute a site's settlement from its stored readings with ``longprofile.rail.estimate_settlement``.

A run reads the site's data version (the watermark), validates the stored tables with ``validate_site`` and
calls ``estimate_settlement`` — the functions ``rail settle`` calls — then stores the daily posterior (90 %
bands), the through-time rates, the sensor health and the alarm transitions in one transaction. Each run
records the code version, a hash of everything that shaped the result (settings, sensors, survey,
thresholds, baseline), the data watermark, "data complete to T" and the earliest changed timestamp.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from datetime import datetime, timezone
from itertools import chain

import numpy as np
import pandas as pd
from sqlalchemy import delete, select, update

from ... import __version__
from ...errors import InputError, LongprofileError
from .. import estimate_settlement, validate_site
from ._alarms import evaluate_no_data, evaluate_result, thresholds_of
from ._db import Database, HealthRow, Reading, ResultRow, Run, Sensor, Site, SurveyPoint, now_ts

__all__ = ["recompute", "check_settings", "latest_run", "load_site_data", "DEFAULT_SETTINGS", "KEEP_RUNS"]

DEFAULT_SETTINGS = {"thermal": "linear", "n_monte_carlo": 0, "alarm_probability": 0.5, "sigma_deg": None,
                    "rigidity": None, "exclude": []}
#: Result rows are kept for this many newest successful runs of a site (run records are kept for ever).
KEEP_RUNS = 3


def check_settings(st: dict) -> dict:
    unknown = sorted(set(st) - set(DEFAULT_SETTINGS))
    if unknown:
        raise InputError(f"unknown setting(s) {unknown}; known: {sorted(DEFAULT_SETTINGS)}.")
    if "thermal" in st and st["thermal"] not in ("linear", "lagged", "none"):
        raise InputError(f"thermal must be linear, lagged or none; got {st['thermal']!r}.")
    if "n_monte_carlo" in st and not (isinstance(st["n_monte_carlo"], int) and 0 <= st["n_monte_carlo"] <= 10000):
        raise InputError("n_monte_carlo must be an integer in 0..10000.")
    if "alarm_probability" in st and not (0 < float(st["alarm_probability"]) <= 1):
        raise InputError("alarm_probability must be in (0, 1].")
    for k in ("sigma_deg", "rigidity"):
        if st.get(k) is not None and not (math.isfinite(float(st[k])) and float(st[k]) > 0):
            raise InputError(f"{k} must be > 0 or null.")
    if "exclude" in st and not (isinstance(st["exclude"], list) and all(isinstance(v, str) for v in st["exclude"])):
        raise InputError("exclude must be a list of sensor ids.")
    return dict(st)


def _iso(ts):
    return None if ts is None else datetime.fromtimestamp(ts, timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def _float_columns(s, query, n_columns: int, *, chunk: int = 65536) -> np.ndarray:
    """(rows, n_columns) float64 array of a query's numeric rows (NULL -> NaN).

    The rows are fetched through Core in chunks; each chunk is flattened into one list of Python floats and
    converted at once. ``np.array`` on a list of SQLAlchemy ``Row`` objects probes every row for the array
    protocols (each probe a failed key lookup) and took 9 of the 11.7 s of loading 432 000 readings
    (docs/rail-service.md, Measured).
    """
    result = s.connection().execute(query)
    parts = []
    while rows := result.fetchmany(chunk):
        parts.append(np.array(list(chain.from_iterable(rows)), dtype=float))  # a flat list: None -> NaN
    return (np.concatenate(parts) if parts else np.empty(0)).reshape(-1, n_columns)


def load_site_data(s, site: Site, *, chunk: int = 65536):
    """(sensors, readings, survey) DataFrames of a site in the long format ``validate_site`` reads."""
    sens = list(s.execute(select(Sensor.id, Sensor.sensor_id, Sensor.x_m, Sensor.z_m)
                          .where(Sensor.site_id == site.id, Sensor.active.is_(True)).order_by(Sensor.x_m)))
    sensors = pd.DataFrame({"sensor_id": [r[1] for r in sens], "x_m": [r[2] for r in sens]})
    if sens and all(r[3] is not None for r in sens):
        sensors["z_m"] = [r[3] for r in sens]
    names = {r[0]: r[1] for r in sens}
    q = select(Reading.sensor_pk, Reading.ts, Reading.angle_deg, Reading.temperature_c).where(
        Reading.site_id == site.id)
    if site.baseline_start_ts is not None:
        q = q.where(Reading.ts >= site.baseline_start_ts)
    arr = _float_columns(s, q, 4, chunk=chunk)
    pk = arr[:, 0].astype(np.int64)
    keep = np.isin(pk, np.fromiter(names, dtype=np.int64, count=len(names)))
    arr, pk = arr[keep], pk[keep]
    lut = pd.Series(names)
    readings = pd.DataFrame({"timestamp": pd.to_datetime(arr[:, 1].astype(np.int64), unit="s"),
                             "sensor_id": lut.reindex(pk).to_numpy(), "angle_deg": arr[:, 2],
                             "temperature_c": arr[:, 3]})
    sv = list(s.execute(select(SurveyPoint.x_m, SurveyPoint.z_m).where(SurveyPoint.site_id == site.id)
                        .order_by(SurveyPoint.x_m)))
    survey = pd.DataFrame({"x_m": [p[0] for p in sv], "z_m": [p[1] for p in sv]}) if sv else None
    return sensors, readings, survey


def _settings_hash(site, sensors, survey, thresholds, settings) -> str:
    blob = json.dumps({"settings": settings, "sensors": sensors.to_dict("list"),
                       "survey": None if survey is None else survey.to_dict("list"), "thresholds": thresholds,
                       "baseline": [site.baseline_start_ts, site.baseline_end_ts]}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


def latest_run(s, site: Site, *, ok_only: bool = True) -> Run | None:
    q = select(Run).where(Run.site_id == site.id)
    if ok_only:
        q = q.where(Run.status == "ok")
    return s.scalar(q.order_by(Run.id.desc()).limit(1))


def recompute(db: Database, name: str, *, force: bool = False) -> dict:
    """Recompute a site when its data or settings changed since the last run (``force``: always).

    Returns {"run_id", "status" ("ok", "unchanged", "waiting", "failed"), "message", "events", "seconds"}.
    """
    from ._core import _site

    t0 = time.perf_counter()
    with db.read() as s:
        site = _site(s, name)
        version, dirty_from = site.data_version, site.dirty_from_ts
        settings = {**DEFAULT_SETTINGS, **site.settings}
        thresholds = thresholds_of(s, site)
        sensors, readings, survey = load_site_data(s, site)
        last = latest_run(s, site, ok_only=False)
        site_id = site.id
    shash = _settings_hash(site, sensors, survey, thresholds, settings)
    if (not force and last is not None and last.data_version == version and last.settings_hash == shash
            and last.code_version == __version__):
        return {"run_id": last.id, "status": "unchanged", "message": "", "events": [],
                "seconds": time.perf_counter() - t0}
    complete_to = None if readings.empty else int(readings["timestamp"].max().value // 10**9)
    status, message, res = "ok", "", None
    try:
        sitedata = validate_site(sensors, readings, survey)
        quiet = None
        if site.baseline_end_ts is not None:
            days = readings["timestamp"].dt.normalize()
            lim = pd.Timestamp(site.baseline_end_ts, unit="s")
            quiet = sorted({d.strftime("%Y-%m-%d") for d in days[days < lim].unique()}) or None
        res = estimate_settlement(
            sitedata, thermal=settings["thermal"], quiet_days=quiet,
            sigma=None if settings["sigma_deg"] is None else float(np.deg2rad(settings["sigma_deg"])),
            rigidity=settings["rigidity"], exclude_sensors=tuple(settings["exclude"]),
            n_monte_carlo=int(settings["n_monte_carlo"]), alarm_probability=float(settings["alarm_probability"]))
    except LongprofileError as exc:
        waiting = ("at least 2 days", "too few days", "at least 3 sensors")  # not enough data yet
        status = "waiting" if readings.empty or any(w in str(exc) for w in waiting) else "failed"
        message = str(exc)
    events: list[str] = []
    with db.write() as s:
        site = s.get(Site, site_id)
        run = Run(site_id=site_id, started_ts=now_ts(), code_version=__version__, settings_hash=shash,
                  data_version=version, data_complete_to_ts=complete_to, changed_from_ts=dirty_from,
                  n_readings=int(len(readings)), n_days=0 if res is None else int(res.days.size), status=status,
                  message=message, warnings_json=json.dumps([] if res is None else list(res.warnings)))
        s.add(run)
        s.flush()
        if res is not None:
            tab = res.to_table()
            recs = pd.DataFrame({"run_id": run.id, "day": tab["date"], "sensor_id": tab["sensor_id"],
                                 "x_m": tab["x_m"], "status": tab["status"], "dz_m": tab["dz_m"],
                                 "dz_std_m": tab["dz_std_m"],
                                 "smoothed_dz_m": tab.get("smoothed_dz_m"), "smoothed_std_m": tab.get("smoothed_std_m"),
                                 "rate_m_per_day": tab.get("rate_m_per_day"),
                                 "rate_std_m_per_day": tab.get("rate_std_m_per_day")})
            recs = recs.astype(object).where(recs.notna(), None)
            s.execute(ResultRow.__table__.insert(), recs.to_dict("records"))
            last_ts = readings.groupby("sensor_id")["timestamp"].max()
            s.execute(HealthRow.__table__.insert(), [
                {"run_id": run.id, "sensor_id": sid, "status": str(st), "reason": str(d),
                 "last_reading_ts": int(last_ts[sid].value // 10**9) if sid in last_ts.index else None}
                for sid, st, d in zip(res.health.sensor_ids, res.health.status, res.health.detail)])
            events = evaluate_result(s, site, res, run.id, float(settings["alarm_probability"]))
            old = list(s.scalars(select(Run.id).where(Run.site_id == site_id, Run.status == "ok", Run.id != run.id)
                                 .order_by(Run.id.desc()).offset(KEEP_RUNS - 1)))
            if old:
                s.execute(delete(ResultRow).where(ResultRow.run_id.in_(old)))
                s.execute(delete(HealthRow).where(HealthRow.run_id.in_(old)))
        events += evaluate_no_data(s, site)
        run.finished_ts = now_ts()
        # the site is clean only if nothing arrived meanwhile (compare-and-set on the watermark)
        s.execute(update(Site).where(Site.id == site_id, Site.data_version == version).values(dirty_from_ts=None))
        run_id = run.id
    return {"run_id": run_id, "status": status, "message": message, "events": events,
            "seconds": time.perf_counter() - t0, "data_complete_to": _iso(complete_to)}
