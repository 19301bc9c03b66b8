"""Run the service (uvicorn) in the foreground or in a thread, and the replay demo."""

from __future__ import annotations

import json
import re
import socket
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from http.cookiejar import CookieJar
from pathlib import Path

from ._alarms import Notifier
from ._db import Database

__all__ = ["serve", "ServerThread", "free_port", "seed_demo_site", "replay_demo", "HttpSession", "alarm_line"]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def serve(db_url: str, *, host: str = "127.0.0.1", port: int = 8000, notifier: Notifier | None = None,
          tick_s: float = 2.0, log_level: str = "warning"):
    """Migrate the database and serve until interrupted (one process: API, pages, recompute worker, outbox)."""
    import uvicorn

    from ._web import create_app

    app = create_app(Database(db_url), notifier=notifier, tick_s=tick_s)
    uvicorn.run(app, host=host, port=port, log_level=log_level, access_log=False)


class ServerThread:
    """The service in a background thread of this process (demo, benchmarks)."""

    def __init__(self, db: Database, *, port: int | None = None, tick_s: float = 1.0, notifier=None,
                 background: bool = True):
        import uvicorn

        from ._web import create_app

        self.port = port or free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.app = create_app(db, tick_s=tick_s, notifier=notifier, background=background)
        self.server = uvicorn.Server(uvicorn.Config(self.app, host="127.0.0.1", port=self.port, log_level="warning",
                                                    access_log=False))
        self.thread = threading.Thread(target=self.server.run, daemon=True)

    def __enter__(self):
        self.thread.start()
        for _ in range(200):
            if self.server.started:
                return self
            time.sleep(0.05)
        raise RuntimeError("the service did not start")

    def __exit__(self, *exc):
        self.server.should_exit = True
        self.thread.join(timeout=30)


class HttpSession:
    """A tiny cookie-keeping HTTP client (standard library) for the demo and the CLI-free scripts."""

    def __init__(self, base: str):
        self.base = base
        self.opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(CookieJar()))

    def request(self, method, path, data=None, headers=None, timeout=60):
        req = urllib.request.Request(self.base + path, data=data, method=method, headers=headers or {})
        try:
            with self.opener.open(req, timeout=timeout) as r:
                return r.status, r.read()
        except urllib.error.HTTPError as e:
            return e.code, e.read()

    def login(self, user, password):
        status, page = self.request("GET", "/login")
        tok = re.search(rb'name="csrf" value="([^"]+)"', page).group(1).decode()
        body = urllib.parse.urlencode({"username": user, "password": password, "csrf": tok, "next": "/"}).encode()
        status, _ = self.request("POST", "/login", body, {"Content-Type": "application/x-www-form-urlencoded"})
        return status


DEMO_USER, DEMO_PASSWORD = "demo", "demo-password"


def seed_demo_site(db: Database, *, n_days: int = 14, sampling_minutes: float = 20.0, name: str = "demo-site"):
    """Create the demo site (mittersheim-like synthetic preset), its thresholds, a logger and demo users.

    Returns (api_key, readings DataFrame with ISO timestamps, truth days).
    """
    import pandas as pd

    from .. import simulate_site
    from . import _core as core

    syn = simulate_site("mittersheim-like", seed=0, sampling_minutes=sampling_minutes, n_days=n_days)
    core.add_user(db, "demo", DEMO_USER, DEMO_PASSWORD, "engineer")
    core.create_site(db, "demo", name, title="Synthetic mittersheim-like site (paper 004)", clock="data",
                     baseline_start=str(pd.Timestamp(syn.truth.days[0]).date()),
                     baseline_end=str(pd.Timestamp(syn.truth.days[0]).date() + pd.Timedelta(days=7)))
    core.put_sensors(db, "demo", name, syn.sensors.to_dict("records"))
    core.put_survey(db, "demo", name, syn.survey.to_dict("records"))
    for q, vals in (("settlement", (0.003, 0.008, 0.015)), ("rate", (0.002, 0.004, 0.008)),
                    ("twist", (0.002, 0.004, 0.006))):
        for lv, v in zip(("alert", "action", "alarm"), vals):
            core.set_threshold(db, "demo", name, q, lv, v)
    key = core.add_logger(db, "demo", name, "logger-1")
    r = syn.readings.copy()
    r["timestamp"] = pd.to_datetime(r["timestamp"]).dt.strftime("%Y-%m-%dT%H:%M:%SZ")
    return key, r, syn.truth.days


def replay_demo(db: Database, base_url: str, key: str, readings, *, name: str = "demo-site", wait_s: float = 60.0,
                echo=print) -> list[dict]:
    """POST the readings day by day (batches of 1 000) and wait for each day's recompute; returns the alarms."""
    from sqlalchemy import select

    from ._db import Run, Site

    http = HttpSession(base_url)
    days = readings["timestamp"].str[:10]
    seen = set()
    alarms = []
    for day in sorted(days.unique()):
        part = readings[days == day]
        for i in range(0, len(part), 1000):
            body = part.iloc[i:i + 1000].to_csv(index=False).encode()
            st, out = http.request("POST", f"/api/v1/sites/{name}/readings", body,
                                   {"Content-Type": "text/csv", "X-API-Key": key})
            if st != 200:
                raise RuntimeError(f"ingestion answered {st}: {out[:200]!r}")
        t0 = time.time()
        while time.time() - t0 < wait_s:  # the service's worker recomputes the site
            with db.read() as s:
                site = s.scalar(select(Site).where(Site.name == name))
                run = s.scalar(select(Run).where(Run.site_id == site.id).order_by(Run.id.desc()).limit(1))
                if site.dirty_from_ts is None and run is not None:
                    break
            time.sleep(0.2)
        from ._alarms import list_alarms

        alarms = list_alarms(db, name)
        for a in reversed(alarms):
            if (a["id"], a["state"] == "cleared") not in seen:
                seen.add((a["id"], a["state"] == "cleared"))
                echo(f"  {day}: {alarm_line(a)}")
        echo(f"  {day}: {len(part)} readings ingested; run {run.id if run else '-'} {run.status if run else ''}")
    return alarms


def alarm_line(a: dict) -> str:
    """What the demo's replay prints of an alarm (:func:`~longprofile.rail.service._alarms.list_alarms` row): raised
    with its message, or how it ended as the API's notification event says it (escalated / de-escalated to another
    level, cleared: back within thresholds, withdrawn) with its reason."""
    from ._alarms import ended_as

    what = f"{a['level']} {a['quantity']} ({a['subject']})"
    if a["state"] != "cleared":
        return f"raised {what} {a['message']}"
    event = ended_as(a.get("cleared_reason"))
    if event in ("escalated", "de-escalated"):  # the reason names the new level: "escalated to action"
        return f"{event} {a['quantity']} ({a['subject']}) from {a['level']} {a['cleared_reason'][len(event) + 1:]}"
    return f"{event} {what}" + (f": {a['cleared_reason']}" if event == "withdrawn" else "")


def run_demo(outdir) -> list[Path]:
    """``make demo`` step: service on a temporary SQLite file, day-by-day replay, a screenshot-ready page."""
    import importlib.util
    import tempfile

    missing = [m for m in ("fastapi", "uvicorn", "sqlalchemy", "alembic", "jinja2", "itsdangerous", "multipart")
               if importlib.util.find_spec(m) is None]
    if missing:
        print(f"  skipped: the monitoring service needs the serve extra (pip install 'longprofile[serve]'); "
              f"missing {missing}")
        return []

    out = Path(outdir) / "rail-service"
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="longprofile-demo-") as tmp:
        db = Database(f"sqlite:///{tmp}/site.db")
        key, readings, _ = seed_demo_site(db)
        with ServerThread(db, tick_s=0.5) as srv:
            print(f"  service on {srv.url} (temporary SQLite database)")
            alarms = replay_demo(db, srv.url, key, readings)
            http = HttpSession(srv.url)
            http.login(DEMO_USER, DEMO_PASSWORD)
            _, page = http.request("GET", "/sites/demo-site")
            _, png = http.request("GET", "/sites/demo-site/profile.png")
        db.dispose()
    html = re.sub(r'src="/sites/demo-site/profile.png[^"]*"', 'src="profile.png"', page.decode())
    files = [out / "site.html", out / "profile.png", out / "alarms.json"]
    files[0].write_text(html, encoding="utf-8")
    files[1].write_bytes(png)
    files[2].write_text(json.dumps(alarms, indent=2), encoding="utf-8")
    return files
