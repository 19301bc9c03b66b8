"""FastAPI application: the ingestion and management API (/api/v1) and the server-rendered dashboard."""

from __future__ import annotations

import base64
import io
import json
import re
import secrets
import tempfile
import threading
from collections import OrderedDict
from contextlib import asynccontextmanager
from datetime import datetime, timezone
from pathlib import Path

import pandas as pd
from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse, RedirectResponse, Response
from jinja2 import Environment, FileSystemLoader, select_autoescape
from sqlalchemy import func, select
from starlette.concurrency import run_in_threadpool
from starlette.requests import ClientDisconnect

from ... import __version__
from ...errors import InputError, LongprofileError
from . import _core as core
from ._alarms import Notifier, acknowledge, deliver_outbox, evaluate_no_data, health_level, list_alarms
from ._auth import PRE_COOKIE, SESSION_COOKIE, SessionSigner, role_at_least
from ._db import LEVELS, Alarm, Database, HealthRow, Reading, ResultRow, Site, Threshold
from ._events import EVENT_COLUMNS, delete_event, events_of, get_events, put_events
from ._recompute import latest_run, recompute, sensor_daily_statistics, temperature_channel_days

__all__ = ["create_app", "ServiceWorker"]

DAY_RE = re.compile(r"^\d{4}-\d{2}-\d{2}$")
TEMPLATES = Path(__file__).with_name("templates")


class HTTPError(Exception):
    def __init__(self, status: int, detail: str):
        self.status, self.detail = status, detail


class BadDay(core.NotFound):
    """A day the site has no page for: not a date at all (status 422) or a date without a result (404)."""

    def __init__(self, message: str, *, status: int, days):
        super().__init__(message)
        self.status, self.days = status, list(days)


def _not_a_date(day: str) -> bool:
    """True for a YYYY-MM-DD string that is no calendar day (2019-02-30)."""
    try:
        datetime.strptime(day, "%Y-%m-%d")
    except ValueError:
        return True
    return False


def _iso(ts):
    return "" if ts is None else datetime.fromtimestamp(ts, timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


class ServiceWorker:
    """Background loop: recompute sites with new data, "no data" alarms, deliver the outbox."""

    def __init__(self, db: Database, notifier: Notifier, *, tick_s: float = 2.0):
        self.db, self.notifier, self.tick_s = db, notifier, tick_s
        self._stop = threading.Event()
        self._thread = None
        self.errors: list[str] = []
        self.after_run = None  # callable(site name): e.g. pre-render the newest profile PNG

    def tick(self):
        with self.db.read() as s:
            sites = list(s.execute(select(Site.name, Site.dirty_from_ts)))
        for name, dirty in sites:
            try:
                if dirty is not None:
                    out = recompute(self.db, name)
                    if out["status"] == "ok" and self.after_run is not None:
                        self.after_run(name)
                else:
                    with self.db.write() as s:
                        evaluate_no_data(s, s.scalar(select(Site).where(Site.name == name)))
            except Exception as exc:  # noqa: BLE001 - keep the loop alive, report on /healthz
                self.errors = (self.errors + [f"{name}: {type(exc).__name__}: {exc}"])[-20:]
        deliver_outbox(self.db, self.notifier)

    def _run(self):
        while not self._stop.wait(self.tick_s):
            try:
                self.tick()
            except Exception as exc:  # noqa: BLE001
                self.errors = (self.errors + [f"{type(exc).__name__}: {exc}"])[-20:]

    def start(self):
        self._thread = threading.Thread(target=self._run, name="longprofile-worker", daemon=True)
        self._thread.start()

    def stop(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=30)


def _sensor_state(s, st: Site, row) -> str:
    """What the sensor page says of a sensor beyond its health: "inactive since ...", or "no data" while its
    no-data alarm is open; "" otherwise."""
    if row is None:
        return ""
    if not row.active:
        return "inactive" + (f" since {_iso(row.deactivated_ts)}" if row.deactivated_ts else "") + \
            ": not in the estimate, its readings are refused"
    a = s.scalar(select(Alarm).where(Alarm.open_key == f"{st.id}:no_data:{row.sensor_id}"))
    return "" if a is None else a.message


def _figure(width, height):
    """A plain Agg figure with fixed margins (constrained layout costs ~0.4 s per page view)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=100)
    FigureCanvasAgg(fig)
    fig.subplots_adjust(left=0.07, right=0.99, bottom=0.15, top=0.92)
    return fig


def _fig_png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()


def profile_png(rows: pd.DataFrame, alarms: list[dict], title: str) -> bytes:
    """Settlement profile of one day: posterior mean, 90 % band, excluded sensors and open alarms marked."""
    z90 = 1.6448536269514722
    fig = _figure(10, 3.8)
    ax = fig.add_subplot()
    x = rows["x_m"].to_numpy(float)
    m = rows["smoothed_dz_m"].fillna(rows["dz_m"]).to_numpy(float) * 1e3
    sd = rows["smoothed_std_m"].fillna(rows["dz_std_m"]).to_numpy(float) * 1e3
    ax.fill_between(x, m - z90 * sd, m + z90 * sd, color="tab:blue", alpha=0.25, label="90 % band")
    ax.plot(x, m, color="tab:blue", lw=1.5, label="altitude change")
    bad = rows["status"].to_numpy() != "ok"
    if bad.any():
        ax.plot(x[bad], m[bad], "x", color="tab:red", label="excluded sensor")
    styles = {"alert": ("gold", ":"), "action": ("orange", "--"), "alarm": ("red", "-")}
    drawn = set()
    for a in alarms:
        if a["quantity"] == "settlement" and a["threshold"] and a["level"] not in drawn:
            c, ls = styles.get(a["level"], ("red", "-"))
            ax.axhline(-1e3 * a["threshold"], color=c, ls=ls, lw=1, label=f"{a['level']} threshold")
            drawn.add(a["level"])
    ax.set_xlabel("station x (m)")
    ax.set_ylabel("altitude change (mm)")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7, loc="lower left")
    return _fig_png(fig)


def sensor_png(rows: pd.DataFrame, daily: pd.DataFrame, title: str, events=()) -> bytes:
    """The sensor page's figure: altitude change with its 90 % band (the run's results), then the day's median
    raw and thermally corrected angle and the mean temperature (``sensor_daily_statistics``), on one time axis;
    ``events`` (``events_of`` rows: the sensor's declared re-installations and replacements) as dashed lines at the
    start of their day."""
    z90 = 1.6448536269514722
    fig = _figure(10, 7.5)
    fig.subplots_adjust(left=0.08, right=0.99, bottom=0.09, top=0.95, hspace=0.12)
    ax, ax_a, ax_t = fig.subplots(3, 1, sharex=True)
    d = pd.to_datetime(rows["day"])
    m = rows["smoothed_dz_m"].fillna(rows["dz_m"]).to_numpy(float) * 1e3
    sd = rows["smoothed_std_m"].fillna(rows["dz_std_m"]).to_numpy(float) * 1e3
    ax.fill_between(d, m - z90 * sd, m + z90 * sd, color="tab:blue", alpha=0.25, label="90 % band")
    ax.plot(d, m, color="tab:blue", label="smoothed altitude change")
    ax.plot(d, rows["dz_m"].to_numpy(float) * 1e3, ".", color="k", ms=3, label="daily posterior")
    ax.set_ylabel("altitude change (mm)")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7)
    dd = pd.to_datetime(daily["day"])
    ax_a.plot(dd, daily["raw_median_deg"].to_numpy(float), ".-", color="tab:gray", ms=3, lw=0.8,
              label="median raw reading of the day")
    if daily["median_deg"].notna().any():
        ax_a.plot(dd, daily["median_deg"].to_numpy(float), ".-", color="tab:purple", ms=3, lw=0.8,
                  label="median thermally corrected angle")
    ax_a.set_ylabel("angle (deg)")
    ax_a.legend(fontsize=7)
    t, half = daily["mean_temp_c"].to_numpy(float), daily["temp_range_c"].to_numpy(float) / 2.0
    ax_t.fill_between(dd, t - half, t + half, color="tab:red", alpha=0.15, label="± half the day's range")
    ax_t.plot(dd, t, ".-", color="tab:red", ms=3, lw=0.8, label="mean temperature of the day")
    lent = ((daily["n_no_temperature"] > 0) | daily["constant_temperature"]).to_numpy(bool)
    if lent.any():  # the estimate gave these days' readings the neighbours' temperature (rail.fill_temperature)
        ax_t.plot(dd[lent], t[lent], "o", mfc="none", mec="k", ms=7,
                  label="own channel empty or constant: the neighbours' (+ its offset)")
    ax_t.set_ylabel("temperature (°C)")
    ax_t.legend(fontsize=7)
    for e in events:
        when = pd.Timestamp(e["date"])
        for a in (ax, ax_a, ax_t):
            a.axvline(when, color="0.3", ls="--", lw=0.9)
        what = "re-installed" if e["event"] == "reinstalled" else f"{e['sensor_id']} replaced by {e['new_id']}"
        ax.annotate(what, (when, 1.0), xycoords=("data", "axes fraction"), xytext=(3, -10),
                    textcoords="offset points", fontsize=7, color="0.3")
    for label in ax_t.get_xticklabels():
        label.set_rotation(30)
        label.set_ha("right")
    return _fig_png(fig)


class _LRU(OrderedDict):
    def __init__(self, n=256):
        super().__init__()
        self.n = n
        self.lock = threading.Lock()

    def get_or(self, key, make):
        with self.lock:
            if key in self:
                self.move_to_end(key)
                return self[key]
        val = make()
        with self.lock:
            self[key] = val
            while len(self) > self.n:
                self.popitem(last=False)
        return val


class _App:
    """What the routes share: the database, session signer, worker, templates, caches and the helpers on them."""

    def __init__(self, db: Database, notifier: Notifier, *, tick_s: float, report_dir, secure_cookies: bool):
        self.db, self.notifier, self.secure_cookies = db, notifier, secure_cookies
        self.signer = SessionSigner(db)
        self.worker = ServiceWorker(db, notifier, tick_s=tick_s)
        self._report_dir = Path(report_dir) if report_dir else None
        self._report_tmp: tempfile.TemporaryDirectory | None = None
        self.env = Environment(loader=FileSystemLoader(str(TEMPLATES)), autoescape=select_autoescape(["html"]))
        self.png_cache = _LRU()
        self.report_lock = threading.Lock()
        self.worker.after_run = self.prerender

    @property
    def report_root(self) -> Path:
        """Folder of the cached day reports: ``report_dir``, or a temporary directory the app owns, made on the
        first report and removed by :meth:`close` (the end of the app's lifespan) or when the app is collected."""
        if self._report_dir is not None:
            return self._report_dir
        if self._report_tmp is None:
            self._report_tmp = tempfile.TemporaryDirectory(prefix="longprofile-reports-")
        return Path(self._report_tmp.name)

    def close(self):
        """Remove the app's temporary report directory (a later report makes a new one)."""
        tmp, self._report_tmp = self._report_tmp, None
        if tmp is not None:
            tmp.cleanup()

    def prerender(self, name):
        """Draw the newest day's profile into the PNG cache, so the first page view after a run is fast."""
        st, run, days = self.run_days(name)
        if days:
            self.profile_bytes(st, run, days[-1])

    # ------------------------------------------------------------------ who is calling
    def person(self, request: Request, needed: str = "viewer", *, api: bool = True) -> tuple[str, str]:
        signer = self.signer
        user = signer.user(request.cookies.get(SESSION_COOKIE))
        via_cookie = user is not None
        auth = request.headers.get("authorization", "")
        if user is None and api and auth.lower().startswith("basic "):
            try:
                name, _, pw = base64.b64decode(auth[6:]).decode().partition(":")
            except Exception:  # noqa: BLE001
                raise HTTPError(401, "authentication required") from None
            cookie = signer.login(name, pw)
            user = signer.user(cookie) if cookie else None
        if user is None:
            raise HTTPError(401, "authentication required")
        if not role_at_least(user[1], needed):
            raise HTTPError(403, "forbidden")
        if api and via_cookie and request.method not in ("GET", "HEAD") and not signer.check_csrf(
                request.cookies.get(SESSION_COOKIE), request.headers.get("x-csrf-token")):
            raise HTTPError(403, "forbidden")
        return user

    @staticmethod
    def site_name(name: str) -> str:
        if not core.NAME_RE.match(name or ""):
            raise core.NotFound("unknown site.")
        return name

    @staticmethod
    async def table_rows(request: Request, expected, required=None, key: str = "readings") -> list:
        """Rows of a CSV or JSON table body (``core.parse_batch``); an empty body is no rows."""
        raw = await request.body()
        return core.parse_batch(raw, request.headers.get("content-type"), required=required or expected,
                                expected=expected, key=key) if raw else []

    @staticmethod
    async def json_body(request: Request):
        try:
            return json.loads(await request.body() or b"null")
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise InputError("the request body is not valid JSON.") from None

    # ------------------------------------------------------------------ data for pages
    def run_days(self, name):
        with self.db.read() as s:
            st = s.scalar(select(Site).where(Site.name == name))
            if st is None:
                raise core.NotFound("unknown site.")
            run = latest_run(s, st)
            days = [] if run is None else list(s.scalars(select(ResultRow.day).where(ResultRow.run_id == run.id)
                                                         .distinct().order_by(ResultRow.day)))
            s.expunge_all()
        return st, run, days

    @staticmethod
    def pick_day(days, day):
        """``day`` if the latest run has a result for it (None: the newest day); else :class:`BadDay`, saying whether
        the day is not a date or a date without a result, and which days have one."""
        if day is None:
            return days[-1] if days else None
        if not DAY_RE.match(day) or _not_a_date(day):
            raise BadDay(f"{day[:40]!r} is not a date: give a day as YYYY-MM-DD.", status=422, days=days)
        if day not in days:
            span = f"results cover {days[0]} to {days[-1]}" if days else "there is no result yet"
            raise BadDay(f"no result for {day}: {span}.", status=404, days=days)
        return day

    def day_rows(self, run, day) -> pd.DataFrame:
        with self.db.read() as s:
            rows = s.execute(select(ResultRow.sensor_id, ResultRow.x_m, ResultRow.status, ResultRow.dz_m,
                                    ResultRow.dz_std_m, ResultRow.smoothed_dz_m, ResultRow.smoothed_std_m,
                                    ResultRow.rate_m_per_day, ResultRow.rate_std_m_per_day)
                             .where(ResultRow.run_id == run.id, ResultRow.day == day).order_by(ResultRow.x_m)).all()
        return pd.DataFrame(rows, columns=["sensor_id", "x_m", "status", "dz_m", "dz_std_m", "smoothed_dz_m",
                                           "smoothed_std_m", "rate_m_per_day", "rate_std_m_per_day"])

    @staticmethod
    def run_info(run):
        if run is None:
            return None
        return {"id": run.id, "code_version": run.code_version, "settings_hash": run.settings_hash,
                "data_version": run.data_version, "data_complete_to": _iso(run.data_complete_to_ts),
                "changed_from": _iso(run.changed_from_ts), "n_readings": run.n_readings, "n_days": run.n_days,
                "finished": _iso(run.finished_ts), "model": run.model}

    def profile_bytes(self, st, run, d):
        alarms = list_alarms(self.db, st.name, open_only=True)

        def make():
            return profile_png(self.day_rows(run, d), alarms, f"{st.name}: altitude change on {d} "
                                                              f"(data complete to {_iso(run.data_complete_to_ts)})")

        key = ("profile", run.id, d, tuple(sorted((a["id"], a["level"]) for a in alarms)))
        return self.png_cache.get_or(key, make)

    # ------------------------------------------------------------------ pages
    def page_user(self, request):
        try:
            return self.person(request, api=False)
        except HTTPError:
            return None

    def csrf_for(self, request):
        return self.signer.csrf(request.cookies.get(SESSION_COOKIE) or request.cookies.get(PRE_COOKIE) or "")

    def render(self, request, name, status=200, **ctx):
        ctx.setdefault("user", self.page_user(request))
        ctx["csrf"] = self.csrf_for(request)
        return HTMLResponse(self.env.get_template(name).render(**ctx), status_code=status)

    @staticmethod
    def to_login(request):
        return RedirectResponse("/login?next=" + request.url.path, status_code=303)

    def check_form_csrf(self, request, form):
        bound = request.cookies.get(SESSION_COOKIE) or request.cookies.get(PRE_COOKIE)
        if not self.signer.check_csrf(bound, form.get("csrf")):
            raise HTTPError(403, "forbidden")


# Route groups are plain ``_add_*(app, ctx)`` functions rather than APIRouters: every route needs the shared
# ``_App`` context anyway, exception handlers cannot live on a router, and one idiom keeps registration order visible.
def _add_error_handlers(app: FastAPI, ctx: _App):
    """JSON error bodies, never internals."""

    @app.exception_handler(HTTPError)
    async def _http_error(request, exc: HTTPError):
        return JSONResponse({"detail": exc.detail}, status_code=exc.status,
                            headers={"WWW-Authenticate": "Basic"} if exc.status == 401 else None)

    @app.exception_handler(core.NotFound)
    async def _nf(request, exc):
        return JSONResponse({"detail": str(exc)}, status_code=404)

    @app.exception_handler(BadDay)
    async def _bad_day(request, exc: BadDay):
        """A page answers with a page that says what is wrong and links back; the API and the figures with JSON."""
        path = request.url.path
        if path.startswith("/api/") or path.endswith(".png"):
            return JSONResponse({"detail": str(exc)}, status_code=exc.status)
        site = request.path_params.get("site", "")
        return ctx.render(request, "bad_day.html", status=exc.status, message=str(exc), site=site,
                          days=exc.days[-10:], n_days=len(exc.days))

    @app.exception_handler(core.Forbidden)
    async def _fb(request, exc):
        return JSONResponse({"detail": "forbidden"}, status_code=403)

    @app.exception_handler(LongprofileError)
    async def _lp(request, exc):
        return JSONResponse({"detail": str(exc)}, status_code=422)

    @app.exception_handler(ClientDisconnect)
    async def _gone(request, exc):
        """The client went away before its request body arrived (a logger stopped mid-batch, the demo's replay at a
        SIGTERM): nothing was read or stored, and there is no one to answer; not an error of the service (the
        catch-all below would log it with a traceback)."""
        return Response(status_code=400)

    @app.exception_handler(Exception)
    async def _any(request, exc):
        return JSONResponse({"detail": "internal error"}, status_code=500)


def _add_event_routes(app: FastAPI, ctx: _App):
    """Declared re-installations and replacements of sensors (``rail site events``): list, put, delete."""
    db, person, site_name = ctx.db, ctx.person, ctx.site_name

    @app.get("/api/v1/sites/{site}/events")
    def api_get_events(site: str, request: Request):
        person(request)
        return get_events(db, site_name(site))

    @app.put("/api/v1/sites/{site}/events")
    async def api_events(site: str, request: Request):
        user = person(request, "engineer")
        rows = await ctx.table_rows(request, EVENT_COLUMNS, required=EVENT_COLUMNS[:3], key="events")
        return await run_in_threadpool(lambda: put_events(db, user[0], site_name(site), rows))

    @app.delete("/api/v1/sites/{site}/events/{sensor}/{date}")
    def api_delete_event(site: str, sensor: str, date: str, request: Request):
        user = person(request, "engineer")
        if not DAY_RE.match(date) or not core.SENSOR_RE.match(sensor):
            raise core.NotFound("no such event.")
        return delete_event(db, user[0], site_name(site), sensor, date)


def _add_site_api_routes(app: FastAPI, ctx: _App):
    """Ingestion and the site configuration API: readings, sites, sensors, survey, thresholds, loggers."""
    db, person, site_name, json_body = ctx.db, ctx.person, ctx.site_name, ctx.json_body

    @app.post("/api/v1/sites/{site}/readings")
    async def post_readings(site: str, request: Request, angle_unit: str = "deg", check_units: bool = True):
        who = await run_in_threadpool(core.authenticate_logger, db, request.headers.get("x-api-key"))
        if who is None:
            raise HTTPError(401, "a valid X-API-Key is required")
        if not core.NAME_RE.match(site):
            raise HTTPError(403, "forbidden")
        logger_id, site_id = who

        def run(body, ctype):
            with db.read() as s:
                st = s.scalar(select(Site).where(Site.name == site))
                if st is None or st.id != site_id:
                    raise core.Forbidden("key not valid for this site")
            rows = core.parse_batch(body, ctype)
            return core.ingest(db, site, rows, logger_id=logger_id, angle_unit=angle_unit, check_units=check_units)

        res = await run_in_threadpool(run, await request.body(), request.headers.get("content-type"))
        # sent only after the commit inside ingest(); json.dumps directly (FastAPI's encoder walks every row)
        return Response(json.dumps(res.as_dict()), media_type="application/json")

    @app.get("/api/v1/sites")
    def api_sites(request: Request):
        person(request)
        return {"sites": core.list_sites(db)}

    @app.post("/api/v1/sites")
    async def api_create_site(request: Request):
        user = person(request, "admin")
        body = await json_body(request)
        if not isinstance(body, dict) or "name" not in body:
            raise InputError('expected {"name": ..., "title": ..., ...}.')
        fields = {k: v for k, v in body.items() if k != "name"}
        return await run_in_threadpool(lambda: core.create_site(db, user[0], body["name"], **fields))

    @app.get("/api/v1/sites/{site}")
    def api_site(site: str, request: Request):
        person(request)
        return core.get_site(db, site_name(site))

    @app.patch("/api/v1/sites/{site}")
    async def api_patch_site(site: str, request: Request):
        user = person(request, "engineer")
        body = await json_body(request)
        if not isinstance(body, dict):
            raise InputError("expected an object of site fields.")
        return await run_in_threadpool(lambda: core.update_site(db, user[0], site_name(site), **body))

    @app.put("/api/v1/sites/{site}/sensors")
    async def api_sensors(site: str, request: Request):
        user = person(request, "engineer")
        rows = await ctx.table_rows(request, ("sensor_id", "x_m", "z_m", "active"), ("sensor_id", "x_m"))
        return await run_in_threadpool(lambda: core.put_sensors(db, user[0], site_name(site), rows))

    @app.put("/api/v1/sites/{site}/survey")
    async def api_survey(site: str, request: Request):
        user = person(request, "engineer")
        rows = await ctx.table_rows(request, ("x_m", "z_m"))
        return await run_in_threadpool(lambda: core.put_survey(db, user[0], site_name(site), rows))

    @app.get("/api/v1/sites/{site}/controls")
    def api_get_controls(site: str, request: Request):
        person(request)
        return core.get_controls(db, site_name(site))

    @app.put("/api/v1/sites/{site}/controls")
    async def api_controls(site: str, request: Request):
        user = person(request, "engineer")
        rows = await ctx.table_rows(request, core.CONTROL_COLUMNS, key="controls")
        return await run_in_threadpool(lambda: core.put_controls(db, user[0], site_name(site), rows))

    @app.delete("/api/v1/sites/{site}/controls/{date}")
    def api_delete_controls(site: str, date: str, request: Request):
        user = person(request, "engineer")
        if not DAY_RE.match(date):
            raise core.NotFound("no control survey on this date.")
        return core.delete_controls(db, user[0], site_name(site), date)

    @app.put("/api/v1/sites/{site}/thresholds/{quantity}/{level}")
    async def api_threshold(site: str, quantity: str, level: str, request: Request):
        user = person(request, "engineer")
        body = await json_body(request)
        if not isinstance(body, dict) or "value" not in body:
            raise InputError('expected {"value": <m or m/day, or null to remove>}.')
        return await run_in_threadpool(
            lambda: core.set_threshold(db, user[0], site_name(site), quantity, level, body["value"]))

    @app.post("/api/v1/sites/{site}/loggers")
    async def api_logger(site: str, request: Request):
        user = person(request, "admin")
        body = await json_body(request)
        if not isinstance(body, dict) or "name" not in body:
            raise InputError('expected {"name": ...}.')
        key = await run_in_threadpool(lambda: core.add_logger(db, user[0], site_name(site), str(body["name"])))
        return {"name": body["name"], "api_key": key}

    @app.post("/api/v1/sites/{site}/loggers/{logger}/revoke")
    def api_logger_revoke(site: str, logger: str, request: Request):
        user = person(request, "admin")
        return core.revoke_logger(db, user[0], site_name(site), logger)

    @app.post("/api/v1/sites/{site}/loggers/{logger}/rotate")
    def api_logger_rotate(site: str, logger: str, request: Request):
        user = person(request, "admin")
        return {"name": logger, "api_key": core.rotate_logger(db, user[0], site_name(site), logger)}


def _add_channel_routes(app: FastAPI, ctx: _App):
    """Notification channels: add (admin), their delivery state (engineer), remove (admin)."""
    db, person, site_name, json_body = ctx.db, ctx.person, ctx.site_name, ctx.json_body

    @app.post("/api/v1/sites/{site}/channels")
    async def api_channel(site: str, request: Request):
        user = person(request, "admin")
        body = await json_body(request)
        if not isinstance(body, dict):
            raise InputError('expected {"kind": "webhook"|"smtp", "target": ...}.')
        return await run_in_threadpool(
            lambda: core.add_channel(db, user[0], site_name(site), body.get("kind"), body.get("target", "")))

    @app.get("/api/v1/sites/{site}/channels")
    def api_channels(site: str, request: Request):
        person(request, "engineer")
        return {"channels": core.channel_status(db, site_name(site))}

    @app.delete("/api/v1/sites/{site}/channels")
    def api_channel_remove(site: str, request: Request, kind: str = "", target: str = ""):
        user = person(request, "admin")
        return core.remove_channel(db, user[0], site_name(site), kind, target)


def _add_result_api_routes(app: FastAPI, ctx: _App):
    """The rest of the API: audit, recompute, alarms, settlement results, users, and /healthz."""
    db, person, site_name, json_body = ctx.db, ctx.person, ctx.site_name, ctx.json_body

    @app.get("/api/v1/sites/{site}/audit")
    def api_audit(site: str, request: Request, limit: int = 500):
        person(request)  # a viewer reads the site's audit trail (docs: "Viewer: read")
        return {"audit": core.audit_trail(db, site_name(site), limit)}

    @app.get("/api/v1/audit")
    def api_user_audit(request: Request, limit: int = 500):
        person(request, "admin")
        return {"audit": core.audit_trail(db, None, limit, users=True)}

    @app.post("/api/v1/sites/{site}/recompute")
    def api_recompute(site: str, request: Request):
        who = person(request, "engineer")
        return recompute(db, site_name(site), force=True, actor=who[0])

    @app.get("/api/v1/sites/{site}/alarms")
    def api_alarms(site: str, request: Request, open_only: bool = False, state: str | None = None):
        person(request)
        return {"alarms": list_alarms(db, site_name(site), open_only=open_only, state=state)}

    @app.post("/api/v1/sites/{site}/alarms/{alarm_id}/ack")
    async def api_ack(site: str, alarm_id: int, request: Request):
        user = person(request, "engineer")
        body = await json_body(request) or {}
        return await run_in_threadpool(lambda: acknowledge(db, alarm_id, user[0], str(body.get("comment", "")),
                                                           site=site_name(site)))

    @app.get("/api/v1/sites/{site}/settlement")
    def api_settlement(site: str, request: Request, day: str | None = None):
        person(request)
        st, run, days = ctx.run_days(site_name(site))
        d = ctx.pick_day(days, day)
        return {"run": ctx.run_info(run), "day": d, "rows": ctx.day_rows(run, d).to_dict("records") if d else []}

    @app.post("/api/v1/users")
    async def api_user(request: Request):
        user = person(request, "admin")
        body = await json_body(request)
        if not isinstance(body, dict):
            raise InputError('expected {"username", "role"[, "password"][, "reset_password": true]}.')
        return await run_in_threadpool(lambda: core.add_user(db, user[0], str(body.get("username", "")),
                                                             body.get("password"), str(body.get("role", "")),
                                                             reset_password=body.get("reset_password") is True))

    @app.get("/healthz")
    def healthz():
        with db.read() as s:
            s.execute(select(1))
        return {"ok": True, "version": __version__, "worker_errors": len(ctx.worker.errors)}


def _add_auth_routes(app: FastAPI, ctx: _App):
    """Login form (CSRF bound to a pre-session cookie), login and logout."""
    signer, env = ctx.signer, ctx.env

    @app.get("/login", response_class=HTMLResponse)
    def login_page(request: Request, next: str = "/"):
        pre = request.cookies.get(PRE_COOKIE) or secrets.token_hex(16)
        nxt = next if next.startswith("/") and not next.startswith("//") else "/"
        resp = HTMLResponse(env.get_template("login.html").render(user=None, csrf=signer.csrf(pre), next=nxt,
                                                                  error=None))
        resp.set_cookie(PRE_COOKIE, pre, httponly=True, samesite="strict", secure=ctx.secure_cookies)
        return resp

    @app.post("/login")
    async def login_post(request: Request):
        form = await request.form()
        pre = request.cookies.get(PRE_COOKIE)
        if not signer.check_csrf(pre, form.get("csrf")):
            raise HTTPError(403, "forbidden")
        cookie = await run_in_threadpool(signer.login, str(form.get("username", "")), str(form.get("password", "")))
        nxt = str(form.get("next") or "/")
        nxt = nxt if nxt.startswith("/") and not nxt.startswith("//") else "/"
        if cookie is None:
            return HTMLResponse(env.get_template("login.html").render(user=None, csrf=signer.csrf(pre), next=nxt,
                                                                      error="unknown user or wrong password"),
                                status_code=401)
        resp = RedirectResponse(nxt, status_code=303)
        resp.set_cookie(SESSION_COOKIE, cookie, httponly=True, samesite="lax", secure=ctx.secure_cookies,
                        max_age=signer.max_age_s)
        return resp

    @app.post("/logout")
    async def logout(request: Request):
        form = await request.form()
        ctx.check_form_csrf(request, form)
        resp = RedirectResponse("/login", status_code=303)
        resp.delete_cookie(SESSION_COOKIE)
        return resp


def _add_page_routes(app: FastAPI, ctx: _App):
    """Server-rendered pages: site list, site, sensor, the alarm acknowledgement form and the day report."""
    db, page_user, to_login, site_name = ctx.db, ctx.page_user, ctx.to_login, ctx.site_name

    @app.get("/", response_class=HTMLResponse)
    def sites_page(request: Request):
        if page_user(request) is None:
            return to_login(request)
        rows = []
        with db.read() as s:
            for st in s.scalars(select(Site).order_by(Site.name)):
                run = latest_run(s, st)
                last_any = latest_run(s, st, ok_only=False)
                open_levels = list(s.scalars(select(Alarm.level).where(Alarm.site_id == st.id,
                                                                       Alarm.state != "cleared")))
                worst = max(open_levels, key=LEVELS.index, default=None)
                rows.append({"name": st.name, "title": st.title, "status": worst or "ok",
                             "n_open": len(open_levels),
                             "complete_to": _iso(run.data_complete_to_ts) if run else "no result yet",
                             "last_status": last_any.status if last_any else "-"})
        return ctx.render(request, "sites.html", sites=rows)

    @app.get("/sites/{site}", response_class=HTMLResponse)
    def site_page(request: Request, site: str, day: str | None = None):
        if page_user(request) is None:
            return to_login(request)
        st, run, days = ctx.run_days(site_name(site))
        d = ctx.pick_day(days, day)
        alarms = list_alarms(db, st.name, limit=200)
        with db.read() as s:
            last_any = latest_run(s, st, ok_only=False)
            silent = set(s.scalars(select(Alarm.subject).where(Alarm.site_id == st.id, Alarm.quantity == "no_data",
                                                               Alarm.open_key.is_not(None))))
            has_thresholds = s.scalar(select(func.count()).select_from(Threshold).where(Threshold.site_id == st.id)) > 0
            health = [] if run is None else [
                {"sensor_id": h.sensor_id, "status": h.status, "reason": h.reason, "level": health_level(h.status),
                 "last": _iso(h.last_reading_ts), "silent": h.sensor_id in silent}
                for h in s.scalars(select(HealthRow).where(HealthRow.run_id == run.id).order_by(HealthRow.id))]
        for a in alarms:
            a["raised"] = _iso(a["raised_ts"])
            a["acked"] = _iso(a["ack_ts"])
        controls = core.get_controls(db, st.name)["comparison"]
        channels = core.channel_status(db, st.name)
        warnings = [] if run is None else json.loads(run.warnings_json or "[]")  # what `rail settle` prints
        return ctx.render(request, "site.html", site=st, run=ctx.run_info(run), last_any=last_any, days=days, day=d,
                          alarms=alarms, health=health, controls=controls, has_thresholds=has_thresholds,
                          warnings=warnings, channels=channels, events=get_events(db, st.name),
                          can_ack=role_at_least(page_user(request)[1], "engineer"))

    @app.get("/sites/{site}/sensors/{sensor}", response_class=HTMLResponse)
    def sensor_page(request: Request, site: str, sensor: str):
        if page_user(request) is None:
            return to_login(request)
        st, run, days = ctx.run_days(site_name(site))
        if not core.SENSOR_RE.match(sensor):
            raise core.NotFound("unknown sensor.")
        with db.read() as s:
            h = None if run is None else s.scalar(select(HealthRow).where(HealthRow.run_id == run.id,
                                                                          HealthRow.sensor_id == sensor))
            row = s.scalar(select(core.Sensor).where(core.Sensor.site_id == st.id, core.Sensor.sensor_id == sensor))
            pk = None if row is None else row.id
            n = 0 if pk is None else s.scalar(select(func.count()).select_from(Reading).where(Reading.sensor_pk == pk))
            last = None if pk is None else s.scalar(select(func.max(Reading.ts)).where(Reading.sensor_pk == pk))
            channel = None if pk is None else temperature_channel_days(s, st, pk)
            state = _sensor_state(s, st, row)
            events = events_of(s, st, sensor)
        if h is None and not n:
            raise core.NotFound("unknown sensor.")
        lent = None
        if channel is not None and (channel["n_no_temperature"].sum() or channel["constant_temperature"].any()):
            lent = dict(empty=int(channel["n_no_temperature"].sum()),
                        empty_days=int((channel["n_no_temperature"] > 0).sum()),
                        constant_days=int(channel["constant_temperature"].sum()))
        return ctx.render(request, "sensor.html", site=st, sensor=sensor, health=h, n_readings=n,
                          run=ctx.run_info(run), lent=lent, last_reading=_iso(last), state=state, events=events)

    @app.post("/sites/{site}/alarms/{alarm_id}/ack")
    async def ack_form(request: Request, site: str, alarm_id: int):
        form = await request.form()
        ctx.check_form_csrf(request, form)
        user = ctx.person(request, "engineer", api=False)
        await run_in_threadpool(lambda: acknowledge(db, alarm_id, user[0], str(form.get("comment", "")),
                                                    site=site_name(site)))
        return RedirectResponse(f"/sites/{site}#alarms", status_code=303)

    @app.get("/sites/{site}/report/{day}", response_class=HTMLResponse)
    def report_page(request: Request, site: str, day: str):
        if page_user(request) is None:
            return to_login(request)
        st, run, days = ctx.run_days(site_name(site))
        ctx.pick_day(days, day)
        folder = ctx.report_root / str(st.id) / str(run.id) / day
        page = folder / "index.html"
        with ctx.report_lock:
            if not page.exists():
                _write_day_report(db, st.name, day, folder)
        return HTMLResponse(page.read_text(encoding="utf-8"),
                            headers={"Content-Disposition": f'inline; filename="{st.name}-{day}.html"'})


def _add_figure_routes(app: FastAPI, ctx: _App):
    """PNG figures (cached per run): the day's settlement profile and one sensor's time series."""

    @app.get("/sites/{site}/profile.png")
    def profile_image(request: Request, site: str, day: str | None = None):
        ctx.person(request, api=False)
        st, run, days = ctx.run_days(ctx.site_name(site))
        d = ctx.pick_day(days, day)
        if d is None:
            raise core.NotFound("no result yet.")
        return Response(ctx.profile_bytes(st, run, d), media_type="image/png")

    @app.get("/sites/{site}/sensors/{sensor}/series.png")
    def sensor_image(request: Request, site: str, sensor: str):
        ctx.person(request, api=False)
        st, run, days = ctx.run_days(ctx.site_name(site))
        if run is None or not core.SENSOR_RE.match(sensor):
            raise core.NotFound("no result yet.")

        def make():
            with ctx.db.read() as s:
                rows = s.execute(select(ResultRow.day, ResultRow.dz_m, ResultRow.dz_std_m, ResultRow.smoothed_dz_m,
                                        ResultRow.smoothed_std_m).where(ResultRow.run_id == run.id,
                                                                        ResultRow.sensor_id == sensor)
                                 .order_by(ResultRow.day)).all()
                if not rows:
                    raise core.NotFound("unknown sensor.")
                daily = sensor_daily_statistics(s, s.get(Site, st.id), sensor)
                events = events_of(s, s.get(Site, st.id), sensor)
            df = pd.DataFrame(rows, columns=["day", "dz_m", "dz_std_m", "smoothed_dz_m", "smoothed_std_m"])
            return sensor_png(df, daily, f"{st.name} / {sensor}: altitude change at the sensor (90 % band), "
                                         "angle and temperature", events)

        return Response(ctx.png_cache.get_or(("sensor", run.id, sensor), make), media_type="image/png")


def create_app(db: Database | str, *, notifier: Notifier | None = None, background: bool = True,
               tick_s: float = 2.0, report_dir: str | Path | None = None, secure_cookies: bool = False) -> FastAPI:
    """The service as an ASGI app (``uvicorn`` runs it; tests use ``TestClient``)."""
    if isinstance(db, str):
        db = Database(db)
    notifier = notifier or Notifier()
    ctx = _App(db, notifier, tick_s=tick_s, report_dir=report_dir, secure_cookies=secure_cookies)

    @asynccontextmanager
    async def lifespan(app):
        if background:
            ctx.worker.start()
        try:
            yield
        finally:
            ctx.worker.stop()
            ctx.close()

    app = FastAPI(title="longprofile rail monitoring", version=__version__, lifespan=lifespan, docs_url=None,
                  redoc_url=None, openapi_url=None)
    app.state.db, app.state.worker, app.state.notifier, app.state.ctx = db, ctx.worker, notifier, ctx
    _add_error_handlers(app, ctx)
    _add_site_api_routes(app, ctx)
    _add_event_routes(app, ctx)
    _add_channel_routes(app, ctx)
    _add_result_api_routes(app, ctx)
    _add_auth_routes(app, ctx)
    _add_page_routes(app, ctx)
    _add_figure_routes(app, ctx)
    return app


def _write_day_report(db: Database, name: str, day: str, folder: Path):
    """The ``rail settle --report`` HTML report of the readings up to the end of ``day``."""
    from ...report import write_rail_report
    from .. import estimate_settlement, validate_site
    from ._alarms import thresholds_of
    from ._recompute import DEFAULT_SETTINGS, controls_table, load_site_data, service_joint_days

    with db.read() as s:
        st = s.scalar(select(Site).where(Site.name == name))
        settings = {**DEFAULT_SETTINGS, **st.settings}
        thr = thresholds_of(s, st)
        sensors, readings, survey = load_site_data(s, st)
        controls = controls_table(s, st, upto=day)
    end = pd.Timestamp(day) + pd.Timedelta(days=1)
    readings = readings[readings["timestamp"] < end]
    n_days = readings["timestamp"].dt.normalize().nunique()
    res = estimate_settlement(validate_site(sensors, readings, survey, controls, check_units=False),  # see _recompute
                              thermal=settings["thermal"],
                              joint_days=service_joint_days(settings, len(sensors), n_days),  # the live model
                              n_monte_carlo=max(int(settings["n_monte_carlo"]), 500),
                              thresholds=thr or None,  # every level of every quantity, as the live alarms
                              alarm_probability=float(settings["alarm_probability"]))
    tmp = folder.with_name(folder.name + ".tmp")
    write_rail_report(res, tmp, title=f"Track settlement report: {name}, data to {day}")
    tmp.replace(folder) if not folder.exists() else None
