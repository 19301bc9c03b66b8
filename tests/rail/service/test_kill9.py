"""kill -9 the server (uvicorn in a subprocess on 127.0.0.1) during a burst of ingestion and notifications."""

from __future__ import annotations

import http.client
import json
import os
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from sqlalchemy import func, select

from longprofile.rail.service import _core
from longprofile.rail.service._alarms import transition
from longprofile.rail.service._db import Outbox, Reading, Sensor, Site
from longprofile.rail.service._serve import free_port

from .test_outbox import Receiver

SERVER = ("import typer; from longprofile.cli._rail_serve import register; app = typer.Typer(); register(app); "
          "app()")


def start(db_url, log, port=None):
    """The server on ``port`` (a free one when None), and the port: another process may take a port between
    ``free_port`` and the bind (the other xdist worker's server did once, CI 2026-12-07), so a failed bind on a port
    this function chose is retried on a new one (at most 5 times)."""
    for _ in range(5):
        chosen = free_port() if port is None else port
        with open(log, "ab") as err:
            p = subprocess.Popen([sys.executable, "-c", SERVER, "serve", "--db", db_url, "--port", str(chosen),
                                  "--tick", "0.2"], stdout=subprocess.DEVNULL, stderr=err,
                                 env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
        for _ in range(300):
            if p.poll() is not None:
                break
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{chosen}/healthz", timeout=1):
                    return p, chosen
            except OSError:  # not listening yet (or another process's server answering 404: then the bind fails)
                time.sleep(0.1)
        else:
            p.kill()
            raise RuntimeError("server did not start")
        text = Path(log).read_text()[-2000:]
        if port is not None or "address already in use" not in text:
            raise RuntimeError(text)
    raise RuntimeError(f"no free port after 5 tries: {text}")


def post(port, key, rows):
    req = urllib.request.Request(f"http://127.0.0.1:{port}/api/v1/sites/mitt/readings",
                                 data=json.dumps(rows).encode(), method="POST",
                                 headers={"Content-Type": "application/json", "X-API-Key": key})
    with urllib.request.urlopen(req, timeout=30) as r:
        return json.loads(r.read())


@pytest.mark.slow
def test_kill9_loses_no_acknowledged_reading_and_no_notification(site, db_url, tmp_path):
    db, key, r = site
    rows = r.iloc[:8000].to_dict("records")
    batches = [rows[i:i + 200] for i in range(0, len(rows), 200)]
    hook = Receiver()
    _core.add_channel(db, "t", "mitt", "webhook", hook.url)
    with db.write() as s:  # 30 notifications waiting in the outbox
        st = s.scalar(select(Site).where(Site.name == "mitt"))
        for i in range(30):
            transition(s, st, "health", f"S{i + 1}", "action", message="test")
    proc, port = start(db_url, tmp_path / "server.log")
    acked = {}
    lock = threading.Lock()

    def logger(my):
        for b in my:
            try:
                out = post(port, key, b)
            except (OSError, urllib.error.URLError, http.client.HTTPException):
                return  # the kill can cut a response mid-body (IncompleteRead): not acknowledged
            with lock:
                for row, o in zip(b, out["rows"]):
                    assert o["outcome"] in ("accepted", "duplicate")
                    acked[(row["sensor_id"], row["timestamp"])] = row["angle_deg"]

    threads = [threading.Thread(target=logger, args=(batches[k::4],)) for k in range(4)]
    for t in threads:
        t.start()
    while True:  # kill in the middle of the burst
        with lock:
            if len(acked) >= 2000:
                break
        time.sleep(0.01)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    for t in threads:
        t.join()
    n_acked = len(acked)
    assert 2000 <= n_acked < len(rows), "the kill must land mid-burst"
    # restart on the same database: every acknowledged reading is there exactly once
    proc, port = start(db_url, tmp_path / "server.log", port)
    try:
        with db.read() as s:
            stored = {(sid, ts): a for sid, ts, a in s.execute(
                select(Sensor.sensor_id, Reading.ts, Reading.angle_deg).join(Sensor, Sensor.id == Reading.sensor_pk))}
            n_rows = s.scalar(select(func.count()).select_from(Reading))
        assert n_rows == len(stored)  # no duplicate key
        to_ts = lambda t: int(time.mktime(time.strptime(t, "%Y-%m-%dT%H:%M:%SZ")) - time.timezone)  # noqa: E731
        for (sid, t), a in acked.items():
            assert stored[(sid, to_ts(t))] == a
        # the loggers re-send what was not acknowledged: in the end every reading once
        for b in batches:
            out = post(port, key, b)
            assert out["rejected"] == 0 and out["revised"] == 0
        with db.read() as s:
            assert s.scalar(select(func.count()).select_from(Reading)) == len(rows)
        # the outbox drains: every notification delivered, repeats only with the same key
        for _ in range(600):  # the worker recomputes the site (new alarms) and drains the outbox
            with db.read() as s:
                if (s.scalar(select(Site.dirty_from_ts)) is None and
                        s.scalar(select(func.count()).select_from(Outbox).where(Outbox.sent_ts.is_(None))) == 0):
                    break
            time.sleep(0.1)
        with db.read() as s:
            keys = set(s.scalars(select(Outbox.key)))
        got = [k for k, _ in hook.got]
        assert set(got) == keys and len(keys) >= 30
        assert len(got) - len(set(got)) <= 1  # at most the one in flight at the kill
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)
        hook.close()
