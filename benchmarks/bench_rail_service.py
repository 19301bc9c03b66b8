"""Rail monitoring service (issue 15): ingestion rate over HTTP into SQLite, concurrent loggers, p95 page times,
recompute time after one new day.

Run: ``python -m benchmarks rail_service`` (full) or ``python -m benchmarks --quick rail_service``.
Full size is the issue's site (100 sensors x 365 days of 10-min readings, 5.3 M rows); set
LONGPROFILE_BENCH_SERVICE_DAYS to use fewer days, LONGPROFILE_BENCH_SERVICE_BASELINE_DAYS to give the site a
baseline of that many first days (the thermal fit's quiet days; default 0: no baseline, every day in the fit),
LONGPROFILE_BENCH_SERVICE_ROWS=1 to measure only the recompute and the pages (no ingestion rows).
"""

from __future__ import annotations

import json
import os
import tempfile
import threading
import time
import urllib.request

import numpy as np
import pandas as pd

from benchmarks._common import BenchRow

AREA = "rail_service"


def _site_tables(n_sensors, n_days, minutes, seed=0):
    rng = np.random.default_rng(seed)
    x = np.arange(n_sensors) * 3.0
    sensors = pd.DataFrame({"sensor_id": [f"S{i:03d}" for i in range(n_sensors)], "x_m": x})
    survey = pd.DataFrame({"x_m": x, "z_m": 100.0 + 1e-3 * x})
    t = pd.date_range("2024-01-01", periods=int(n_days * 1440 / minutes), freq=f"{minutes}min")
    temp = 5 + 8 * np.sin(2 * np.pi * (t.hour.to_numpy() + t.minute.to_numpy() / 60) / 24)
    n = len(t)
    ang = 0.05 * rng.standard_normal(n_sensors)[None, :] + 5e-3 * rng.standard_normal((n, n_sensors))
    ang += 2e-3 * temp[:, None] * rng.uniform(-1, 1, n_sensors)[None, :]
    readings = pd.DataFrame({"timestamp": np.repeat(t.strftime("%Y-%m-%dT%H:%M:%SZ").to_numpy(), n_sensors),
                             "sensor_id": np.tile(sensors["sensor_id"].to_numpy(), n),
                             "angle_deg": ang.ravel(), "temperature_c": np.repeat(temp, n_sensors)})
    return sensors, survey, readings


def _post(url, key, body):
    req = urllib.request.Request(url, data=body, method="POST", headers={"Content-Type": "text/csv",
                                                                          "X-API-Key": key})
    with urllib.request.urlopen(req, timeout=120) as r:
        return json.loads(r.read())


def _setup(db, sensors, survey, name="bench"):
    from longprofile.rail.service import _core

    _core.create_site(db, "bench", name, clock="data")
    _core.put_sensors(db, "bench", name, sensors.to_dict("records"))
    _core.put_survey(db, "bench", name, survey.to_dict("records"))
    _core.add_user(db, "bench", "viewer1", "viewer1-password", "viewer")
    _core.set_threshold(db, "bench", name, "settlement", "alert", 0.002)
    return _core.add_logger(db, "bench", name, "lg")


def _ingest_rows(quick, tmp) -> list[BenchRow]:
    from longprofile.rail.service._core import reading_count
    from longprofile.rail.service._db import Database
    from longprofile.rail.service._serve import ServerThread

    rows = []
    n_sensors, n_days, minutes = (50, 1, 15) if quick else (100, 14, 10)
    sensors, survey, readings = _site_tables(n_sensors, n_days, minutes)
    db = Database(f"sqlite:///{tmp}/ingest.db")
    key = _setup(db, sensors, survey)
    bodies = [readings.iloc[i:i + 1000].to_csv(index=False).encode() for i in range(0, len(readings), 1000)]
    with ServerThread(db, background=False) as srv:
        url = f"{srv.url}/api/v1/sites/bench/readings"
        t0 = time.perf_counter()
        for b in bodies:
            _post(url, key, b)
        dt = time.perf_counter() - t0
        rows.append(BenchRow(AREA, "ingestion, 1 logger, batches of 1 000 (HTTP, SQLite WAL)", len(readings) / dt,
                             "readings/s", target=None if quick else 5000.0, higher_is_better=True,
                             detail=f"{len(readings)} readings, client and server in one process on loopback"))
        # concurrent loggers: each re-sends its share of the batches twice (idempotency under concurrency)
        n_log = 4 if quick else 20
        from longprofile.rail.service import _core

        _core.create_site(db, "bench", "bench2", clock="data")
        _core.put_sensors(db, "bench", "bench2", sensors.to_dict("records"))
        key2 = _core.add_logger(db, "bench", "bench2", "lg")
        url2 = f"{srv.url}/api/v1/sites/bench2/readings"
        r2 = readings
        b2 = bodies
        acked = [0] * n_log

        def logger(k):
            for b in b2[k::n_log] * 2:
                acked[k] += _post(url2, key2, b)["accepted"]

        ths = [threading.Thread(target=logger, args=(k,)) for k in range(n_log)]
        t0 = time.perf_counter()
        for t in ths:
            t.start()
        for t in ths:
            t.join()
        dt = time.perf_counter() - t0
        stored = reading_count(db, "bench2")
        ok = stored == len(r2) == sum(acked)
        rows.append(BenchRow(AREA, f"ingestion, {n_log} concurrent loggers (each batch sent twice)",
                             2 * len(r2) / dt, "readings/s", target=None, higher_is_better=True,
                             detail=f"stored {stored} of {len(r2)} distinct, accepted {sum(acked)}: "
                                    f"{'zero duplicates, zero lost' if ok else 'MISMATCH'}"))
        if not ok:
            raise AssertionError(f"concurrent ingestion lost or duplicated readings: {stored} vs {len(r2)}")
    db.dispose()
    return rows


def _pages_rows(quick, tmp) -> list[BenchRow]:
    from longprofile.rail.service import _core
    from longprofile.rail.service._db import Database
    from longprofile.rail.service._recompute import recompute
    from longprofile.rail.service._serve import HttpSession, ServerThread

    n_days = 4 if quick else int(os.environ.get("LONGPROFILE_BENCH_SERVICE_DAYS", "365"))
    n_sensors, minutes = (20, 120) if quick else (100, 10)
    sensors, survey, readings = _site_tables(n_sensors, n_days, minutes)
    db = Database(f"sqlite:///{tmp}/pages.db")
    _setup(db, sensors, survey)
    n_base = 0 if quick else int(os.environ.get("LONGPROFILE_BENCH_SERVICE_BASELINE_DAYS", "0"))
    if n_base:
        d0 = pd.Timestamp(readings["timestamp"].iloc[0][:10])
        _core.update_site(db, "bench", "bench", baseline_start=d0.strftime("%Y-%m-%d"),
                          baseline_end=(d0 + pd.Timedelta(days=n_base)).strftime("%Y-%m-%d"))
    day = readings["timestamp"].str[:10]
    last, second_last = day == day.iloc[-1], day == sorted(day.unique())[-2]
    old = readings[~(last | second_last)]
    for i in range(0, len(old), 20_000):
        _core.ingest(db, "bench", old.iloc[i:i + 20_000].to_dict("records"))
    t0 = time.perf_counter()
    recompute(db, "bench")
    t_full = time.perf_counter() - t0
    size = f"{n_sensors} sensors x {n_days} days of {minutes}-min readings ({len(readings)} rows)"
    rows = []
    # the day before last: as the first run of a freshly started process (its memo of the day cache is empty, the
    # cache is read from day_stats); the last day: as the serving process, whose previous run stored the cache
    for new, cold in ((readings[second_last], True), (readings[last], False)):
        for i in range(0, len(new), 20_000):
            _core.ingest(db, "bench", new.iloc[i:i + 20_000].to_dict("records"))
        if cold:
            db.memo.clear()
        t0 = time.perf_counter()
        out = recompute(db, "bench")
        t_day = time.perf_counter() - t0
        assert out["status"] == "ok", out["message"]
        parts = ", ".join(f"{k} {v:.2f} s" for k, v in out.get("timings", {}).items())
        name = ("recompute after one new day, first run of a started process" if cold
                else "recompute after one new day")
        rows.append(BenchRow(AREA, name, t_day, "s", target=None if quick or cold else 2.0, higher_is_better=False,
                             detail=f"{size}; {out.get('model')} model; baseline {n_base} days; first full run "
                                    f"{t_full:.1f} s; {parts}; "
                                    f"recomputed from {out.get('recomputed_from_day')}, "
                                    f"{out.get('rebuilt_sensors')} sensor(s) rebuilt; "
                                    + ("day cache read from the database" if cold else
                                       "day cache from the process's memo of its previous run")))
    rows.append(_failed_channel_row(db, readings, quick, size))
    with ServerThread(db, background=False) as srv:
        http = HttpSession(srv.url)
        http.login("viewer1", "viewer1-password")
        days = sorted(readings["timestamp"].str[:10].unique())
        paths = ["/", "/sites/bench", f"/sites/bench/sensors/S{n_sensors // 2:03d}"]
        # the newest profile (pre-rendered by the worker after a run in the server) and older days and
        # sensor series drawn on their first view (then cached)
        n_png = 2 if quick else 5
        paths += [f"/sites/bench/profile.png?day={d}" for d in days[-n_png:]]
        paths += [f"/sites/bench/sensors/S{k:03d}/series.png" for k in range(0, n_sensors, n_sensors // n_png)]
        http.request("GET", "/sites/bench")  # warm-up (imports)
        times = []
        for _ in range(2 if quick else 10):
            for p in paths:
                t0 = time.perf_counter()
                st, _ = http.request("GET", p)
                times.append(time.perf_counter() - t0)
                assert st == 200, (p, st)
    p95 = float(np.percentile(times, 95))
    rows.append(BenchRow(AREA, "dashboard pages p95 (site list, site, sensor, PNGs)", 1e3 * p95, "ms",
                         target=None if quick else 300.0, higher_is_better=False,
                         detail=f"{size}; {len(times)} requests, median {1e3 * np.median(times):.0f} ms"))
    db.dispose()
    return rows


def _failed_channel_row(db, readings: pd.DataFrame, quick: bool, size: str) -> BenchRow:
    """The recompute after one new day when two sensors' temperature channels failed ``failed_days`` days before:
    each recompute reads again the days their offsets need (the week before the failure, docs/rail.md "The sensor's
    own offset"). The new days are the site's first days again, shifted after its last; the earlier ones are
    recomputed untimed."""
    from longprofile.rail.service import _core
    from longprofile.rail.service._recompute import recompute

    failed_days = 10
    day = readings["timestamp"].str[:10]
    days = sorted(day.unique())
    ids = sorted(readings["sensor_id"].unique())
    for k in range(1, failed_days + 2):
        src = days[(k - 1) % len(days)]
        new = readings[day == src].copy()
        shift = pd.Timestamp(days[-1]) + pd.Timedelta(days=k) - pd.Timestamp(src)
        new["timestamp"] = (pd.to_datetime(new["timestamp"]) + shift).dt.strftime("%Y-%m-%dT%H:%M:%SZ")
        new.loc[new["sensor_id"].isin(ids[len(ids) // 2:len(ids) // 2 + 2]), "temperature_c"] = np.nan
        for i in range(0, len(new), 20_000):
            _core.ingest(db, "bench", new.iloc[i:i + 20_000].to_dict("records"))
        t0 = time.perf_counter()
        out = recompute(db, "bench")
        t_day = time.perf_counter() - t0
        assert out["status"] == "ok", out["message"]
    parts = ", ".join(f"{k} {v:.2f} s" for k, v in out.get("timings", {}).items())
    return BenchRow(AREA, f"recompute after one new day, 2 temperature channels failed {failed_days} days before",
                    t_day, "s", target=None if quick else 2.0, higher_is_better=False,
                    detail=f"{size} + {failed_days + 1} days; {out.get('model')} model; {parts}; recomputed from "
                           f"{out.get('recomputed_from_day')}, {out.get('rebuilt_sensors')} sensor(s) rebuilt")


def run(quick: bool = False) -> list[BenchRow]:
    with tempfile.TemporaryDirectory(prefix="bench-rail-service-") as tmp:
        pages_only = os.environ.get("LONGPROFILE_BENCH_SERVICE_ROWS") == "1"
        return ([] if pages_only else _ingest_rows(quick, tmp)) + _pages_rows(quick, tmp)
