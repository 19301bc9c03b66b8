"""Service operations shared by the HTTP API and the ``longprofile rail site`` CLI: sites, sensors, survey,
thresholds, loggers, channels and users, every change written to the audit trail (who, when, old -> new),
and the ingestion of reading batches (idempotent on (sensor, timestamp), revisions kept, per-row outcomes).
"""

from __future__ import annotations

import csv
import hashlib
import hmac
import io
import json
import math
import re
import secrets
from dataclasses import dataclass, field
from datetime import datetime, timezone

import numpy as np
import pandas as pd
from sqlalchemy import func, select, update
from sqlalchemy.exc import IntegrityError

from ..._validation import first_undecodable_line, time_zone, utc_offset_mix
from ...errors import InputError, InputFormatError
from .. import (
    ANGLE_RANGE_DEG,
    MAX_TRACK_ANGLE_DEG,
    MISSING_CODE_HINT,
    MISSING_TEXT,
    RADIAN_NOISE_THRESHOLD,
    READING_COLUMNS,
    TEMPERATURE_RANGE_C,
    SiteData,
    angle_noise,
    check_survey,
    check_thresholds,
    missing_value_code,
    track_angle,
    validate_site,
)
from ._alarms import close_sensor_alarms
from ._db import (
    LEVELS,
    QUANTITIES,
    ROLES,
    Alarm,
    Audit,
    Batch,
    Channel,
    ControlPoint,
    Database,
    Logger,
    Outbox,
    Reading,
    ReadingRevision,
    Sensor,
    Site,
    SurveyPoint,
    Threshold,
    User,
    now_ts,
)
from ._events import events_of

__all__ = ["create_site", "update_site", "get_site", "list_sites", "put_sensors", "put_survey", "put_controls",
           "delete_controls", "get_controls", "set_threshold", "threshold_row", "threshold_rows", "add_logger",
           "revoke_logger", "rotate_logger",
           "authenticate_logger", "add_channel", "remove_channel", "channel_status", "add_user", "user_exists", "audit_trail",
           "ingest", "parse_batch", "IngestResult", "NotFound", "Forbidden", "MAX_FUTURE_SKEW_S"]

NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
#: A sensor id: letters (any script: ``Capteur_é4``, as ``rail settle`` takes it), digits, '_', '.', ':', '-'.
SENSOR_RE = re.compile(r"^[^\W_][\w.:-]{0,63}$")
#: A reading later than the server clock by more than this is refused (clock-skewed logger).
MAX_FUTURE_SKEW_S = 300
MAX_BATCH_ROWS = 50_000
#: How far around a small batch its sensors' stored readings are read for the radian test (:func:`_with_recent`), s.
RECENT_S = 6 * 3600
CONTROL_COLUMNS = SiteData.TABLE_COLUMNS["controls"]  # date, x_m, z_m: the controls table of ``rail settle``


class NotFound(InputError):
    """An unknown site, sensor, alarm or user."""


class Forbidden(InputError):
    """The caller may not do this (wrong API key for the site, role too low)."""


def check_name(name: str, what: str = "site name") -> str:
    if not isinstance(name, str) or not NAME_RE.match(name):
        raise InputError(f"{what} {name!r}: use 1-64 letters, digits, '_', '.', '-' (starting with a letter or digit).")
    return name


def _audit(s, actor, site_id, entity, key, action, old, new):
    s.add(Audit(ts=now_ts(), actor=actor, site_id=site_id, entity=entity, key=str(key), action=action,
                old_json=None if old is None else json.dumps(old, sort_keys=True),
                new_json=None if new is None else json.dumps(new, sort_keys=True)))


def _site(s, name: str, *, lock: bool = False) -> Site:
    q = select(Site).where(Site.name == name)
    site = s.scalar(q.with_for_update() if lock else q) if isinstance(name, str) else None
    if site is None:
        raise NotFound(f"unknown site {name!r}.")
    return site


def _ts(value, what: str) -> int | None:
    if value is None or value == "":
        return None
    try:
        t = pd.Timestamp(value)
    except (ValueError, TypeError):
        raise InputError(f"{what}: {value!r} is not an ISO 8601 date/time.") from None
    if t.tzinfo is not None:
        t = t.tz_convert("UTC").tz_localize(None)
    return int(t.value // 10**9)


SITE_FIELDS = ("title", "baseline_start", "baseline_end", "no_data_hours", "clock", "timezone", "settings")


def _site_dict(site: Site) -> dict:
    iso = (lambda t: None if t is None else datetime.fromtimestamp(t, timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"))
    return {"name": site.name, "title": site.title, "baseline_start": iso(site.baseline_start_ts),
            "baseline_end": iso(site.baseline_end_ts), "no_data_hours": site.no_data_hours, "clock": site.clock,
            "timezone": site.timezone or "UTC", "settings": site.settings}


def _apply_site_fields(site: Site, fields: dict):
    """Set the given site fields, checked; unknown fields (and ``name``: a site is not renamed) refused."""
    if "name" in fields:
        raise InputError("a site cannot be renamed (its name is in its loggers' URLs and the audit trail); create a "
                         f"new site instead. Fields that can change: {list(SITE_FIELDS)}.")
    unknown = sorted(set(fields) - set(SITE_FIELDS))
    if unknown:
        raise InputError(f"unknown site field(s) {unknown}; known: {list(SITE_FIELDS)}.")
    if "title" in fields:
        site.title = str(fields["title"] or "").replace("\x00", "")[:200]
    if "baseline_start" in fields:
        site.baseline_start_ts = _ts(fields["baseline_start"], "baseline_start")
    if "baseline_end" in fields:
        site.baseline_end_ts = _ts(fields["baseline_end"], "baseline_end")
    if site.baseline_start_ts is not None and site.baseline_end_ts is not None \
            and site.baseline_end_ts <= site.baseline_start_ts:
        raise InputError("baseline_end must be after baseline_start.")
    if "no_data_hours" in fields:
        v = float(fields["no_data_hours"])
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"no_data_hours must be > 0; got {fields['no_data_hours']!r}.")
        site.no_data_hours = v
    if "clock" in fields:
        if fields["clock"] not in ("wall", "data"):
            raise InputError(f"clock must be 'wall' or 'data'; got {fields['clock']!r}.")
        site.clock = fields["clock"]
    if "timezone" in fields:
        site.timezone = time_zone(fields["timezone"]).key
    if "settings" in fields:
        st = fields["settings"] or {}
        if not isinstance(st, dict):
            raise InputError("settings must be an object.")
        from ._recompute import check_settings

        site.settings_json = json.dumps(check_settings(st), sort_keys=True)


def create_site(db: Database, actor: str, name: str, /, **fields) -> dict:
    """Create a site (``fields``: title, baseline_start, baseline_end, no_data_hours, clock, timezone, settings)."""
    check_name(name)
    with db.write() as s:
        same = s.scalar(select(Site.name).where(func.lower(Site.name) == name.lower()))
        if same is not None:
            raise InputError(f"site {name!r} already exists." if same == name else
                             f"site {same!r} already exists and differs from {name!r} only in letter case; site "
                             "names are compared ignoring case (they look alike on pages and in e-mails).")
        site = Site(name=name, title="", no_data_hours=6.0, clock="wall", timezone="UTC", settings_json="{}",
                    data_version=0, created_ts=now_ts())
        _apply_site_fields(site, fields)
        s.add(site)
        s.flush()
        new = _site_dict(site)
        _audit(s, actor, site.id, "site", name, "create", None, new)
    return new


def update_site(db: Database, actor: str, name: str, /, **fields) -> dict:
    """Change site fields (audited old -> new; a change marks the whole record for a recompute)."""
    with db.write() as s:
        site = _site(s, name)
        old = _site_dict(site)
        _apply_site_fields(site, fields)
        new = _site_dict(site)
        if new != old:
            site.dirty_from_ts = site.baseline_start_ts or 0  # settings change: recompute everything
            site.data_version = (site.data_version or 0) + 1
            _audit(s, actor, site.id, "site", name, "update", old, new)
    return new


def get_site(db: Database, name: str) -> dict:
    with db.read() as s:
        site = _site(s, name)
        out = _site_dict(site)
        out["sensors"] = [{"sensor_id": x.sensor_id, "x_m": x.x_m, "z_m": x.z_m, "active": x.active}
                          for x in s.scalars(select(Sensor).where(Sensor.site_id == site.id).order_by(Sensor.x_m))]
        out["survey"] = [{"x_m": p.x_m, "z_m": p.z_m} for p in
                         s.scalars(select(SurveyPoint).where(SurveyPoint.site_id == site.id).order_by(SurveyPoint.x_m))]
        rows = sorted(s.scalars(select(Threshold).where(Threshold.site_id == site.id)),
                      key=lambda t: (QUANTITIES.index(t.quantity), LEVELS.index(t.level)))
        out["thresholds"] = {f"{t.quantity}.{t.level}": t.value for t in rows}  # m (rate: m/day)
        out["threshold_rows"] = [threshold_row(t.quantity, t.level, t.value) for t in rows]
        lgs = list(s.scalars(select(Logger).where(Logger.site_id == site.id).order_by(Logger.name)))
        out["loggers"] = [lg.name for lg in lgs]
        out["revoked_loggers"] = [lg.name for lg in lgs if not lg.active]
        out["control_dates"] = list(s.scalars(select(ControlPoint.date).where(ControlPoint.site_id == site.id)
                                              .distinct().order_by(ControlPoint.date)))
        out["channels"] = [{"kind": c.kind, "target": c.target} for c in
                           s.scalars(select(Channel).where(Channel.site_id == site.id))]
        out["events"] = events_of(s, site)
    return out


def list_sites(db: Database) -> list[str]:
    with db.read() as s:
        return list(s.scalars(select(Site.name).order_by(Site.name)))


def _finite(v, what):
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a number; got {v!r}.") from None
    if not math.isfinite(f):
        raise InputError(f"{what} must be finite; got {v!r}.")
    return f


#: Columns of a sensors request or file: the ``rail settle`` sensors table, optional ``z_m``, and ``active``.
SENSOR_FIELDS = (*SiteData.TABLE_COLUMNS["sensors"], "z_m", "active")


def _clean_sensor_rows(rows) -> dict:
    """{sensor_id: {x_m, z_m, active}} of a sensors request; unknown columns and an id given twice refused."""
    clean = {}
    for i, r in enumerate(rows):
        if not isinstance(r, dict) or "sensor_id" not in r or "x_m" not in r:
            raise InputError(f"sensor row {i}: needs sensor_id and x_m.")
        extra = sorted(map(str, set(r) - set(SENSOR_FIELDS)))
        if extra:
            raise InputError(f"sensor row {i}: unknown column(s) {extra[:3]}; expected {list(SENSOR_FIELDS)}.")
        sid = str(r["sensor_id"]).strip()
        if not SENSOR_RE.match(sid):
            raise InputError(f"sensor row {i}: sensor id {sid!r} must be 1-64 letters (any script), digits, '_', '.', "
                             "':', '-', starting with a letter or digit.")
        if sid in clean:
            raise InputError(f"sensors: sensor id {sid!r} appears more than once (row {i}); ids must be unique.")
        z = r.get("z_m")
        clean[sid] = {"x_m": _finite(r["x_m"], f"sensor row {i}: x_m"),
                      "z_m": None if z is None or z == "" or (isinstance(z, float) and math.isnan(z))
                      else _finite(z, f"sensor row {i}: z_m"),
                      "active": bool(r.get("active", True)) if not isinstance(r.get("active"), str)
                      else r["active"].strip().lower() not in ("0", "false", "no")}
    return clean


def _check_active_stations(s, site: Site) -> None:
    """Refuse two active sensors at one station (an inactive sensor does not hold its station: a replacement), and
    active sensors that ``validate_site`` (what every run calls) would refuse with the site's survey."""
    from ._events import replacing_ids
    from ._recompute import load_site_tables

    sensors, survey = load_site_tables(s, site)
    # a sensor declared as replacing another (rail site events) continues its series at its station
    sensors = sensors[~sensors["sensor_id"].isin(replacing_ids(s, site))].reset_index(drop=True)
    x = sensors["x_m"].to_numpy(float)
    same = np.nonzero(np.diff(x) <= 0)[0]
    if same.size:
        i = int(same[0])
        raise InputError(f"sensors {sensors['sensor_id'][i]!r} and {sensors['sensor_id'][i + 1]!r} would both be active "
                         f"at station x = {x[i]:g} m; each active sensor needs its own station (to replace a sensor, "
                         "make the old one inactive, \"active\": false, in the same request or before; or declare the "
                         "replacement first, rail site events, to continue the old one's series).")
    if survey is not None and len(sensors) >= 3:
        empty = pd.DataFrame({c: pd.Series(dtype=object) for c in READING_COLUMNS})
        validate_site(sensors, empty, survey)  # e.g. a sensor outside the survey: every run would fail


def put_sensors(db: Database, actor: str, name: str, rows) -> dict:
    """Add or update sensors (``sensor_id``, ``x_m``, optional ``z_m``, ``active``); returns counts. A sensor made
    inactive has its open alarms closed ("sensor deactivated")."""
    rows = list(rows)
    if not rows:
        raise InputError("no sensors given.")
    clean = _clean_sensor_rows(rows)
    added = changed = 0
    now = now_ts()
    with db.write() as s:
        site = _site(s, name)
        have = {x.sensor_id: x for x in s.scalars(select(Sensor).where(Sensor.site_id == site.id))}
        off = []
        for sid, v in clean.items():
            cur = have.get(sid)
            if cur is None:
                s.add(Sensor(site_id=site.id, sensor_id=sid, created_ts=now,
                             deactivated_ts=None if v["active"] else now, **v))
                _audit(s, actor, site.id, "sensor", sid, "create", None, v)
                added += 1
                continue
            old = {"x_m": cur.x_m, "z_m": cur.z_m, "active": cur.active}
            if old != v:
                if cur.active != v["active"]:
                    cur.deactivated_ts = None if v["active"] else now
                    off += [] if v["active"] else [sid]
                cur.x_m, cur.z_m, cur.active = v["x_m"], v["z_m"], v["active"]
                _audit(s, actor, site.id, "sensor", sid, "update", old, v)
                changed += 1
        s.flush()
        _check_active_stations(s, site)
        closed = close_sensor_alarms(s, site, off, actor=actor)
        if added or changed:
            site.dirty_from_ts = site.baseline_start_ts or 0
            site.data_version = (site.data_version or 0) + 1
    return {"added": added, "changed": changed, **({"alarms_closed": closed} if closed else {})}


def put_survey(db: Database, actor: str, name: str, rows) -> dict:
    """Replace the initial survey (``x_m``, ``z_m`` rows)."""
    pts = []
    for i, r in enumerate(rows):
        if not isinstance(r, dict) or "x_m" not in r or "z_m" not in r:
            has = f"; it has {sorted(map(str, r))[:5]}" if isinstance(r, dict) else ""
            raise InputError(f"survey row {i}: needs x_m and z_m{has}.")
        pts.append((_finite(r.get("x_m"), f"survey row {i}: x_m"), _finite(r.get("z_m"), f"survey row {i}: z_m")))
    if len(pts) < 2:
        raise InputError("a survey needs at least 2 points.")
    if len({p[0] for p in pts}) != len(pts):
        raise InputError("survey: two altitudes at the same x_m.")
    check_survey(pd.DataFrame(sorted(pts), columns=["x_m", "z_m"]), table="survey")  # as rail settle checks a file
    with db.write() as s:
        site = _site(s, name)
        old = [(p.x_m, p.z_m) for p in s.scalars(select(SurveyPoint).where(SurveyPoint.site_id == site.id)
                                                 .order_by(SurveyPoint.x_m))]
        new = sorted(pts)
        if old != new:
            for p in s.scalars(select(SurveyPoint).where(SurveyPoint.site_id == site.id)):
                s.delete(p)
            s.flush()
            s.add_all([SurveyPoint(site_id=site.id, x_m=x, z_m=z) for x, z in new])
            _audit(s, actor, site.id, "survey", name, "replace", old or None, new)
            s.flush()
            _check_active_stations(s, site)  # the sensors must lie within the new survey
            site.dirty_from_ts = site.baseline_start_ts or 0
            site.data_version = (site.data_version or 0) + 1
    return {"points": len(pts)}


def _first_reading_day(s, site: Site) -> str | None:
    """The UTC day of the site's first reading that a recompute uses (from the baseline start on)."""
    q = select(func.min(Reading.ts)).where(Reading.site_id == site.id)
    if site.baseline_start_ts is not None:
        q = q.where(Reading.ts >= site.baseline_start_ts)
    ts = s.scalar(q)
    return None if ts is None else datetime.fromtimestamp(ts, timezone.utc).strftime("%Y-%m-%d")


def _check_controls(s, site: Site, rows, now: int) -> dict:
    """{date: [(x_m, z_m), ...]} of control rows, validated as ``rail settle`` validates a controls table
    (``validate_site``: columns, ISO dates, finite numbers) plus what the service refuses on top: unknown columns,
    duplicate (date, x_m), points outside the span of the site's active sensors (``validate_site`` warns and
    compares none of them), dates before the site's first reading or after today."""
    from ._recompute import load_site_tables

    rows = list(rows)
    if not rows:
        raise InputError("no control points given (columns: date, x_m, z_m).")
    for i, r in enumerate(rows):
        if not isinstance(r, dict):
            raise InputError(f"control row {i}: expected an object with {list(CONTROL_COLUMNS)}.")
        extra = sorted(set(r) - set(CONTROL_COLUMNS))
        if extra:
            raise InputError(f"control row {i}: unknown column(s) {extra[:3]}; expected {list(CONTROL_COLUMNS)}.")
    table = pd.DataFrame(rows).astype(object)  # a missing column is validate_site's error
    if "date" in table:
        table["date"] = [v if v is None or isinstance(v, str) else str(v) for v in table["date"]]
        _refuse_control_times(table["date"])
    sensors, survey = load_site_tables(s, site)
    empty = pd.DataFrame({c: pd.Series(dtype=object) for c in READING_COLUMNS})
    ct = validate_site(sensors, empty, survey, table).controls  # the checks of `rail settle`, nothing re-implemented
    dates = ct["date"].dt.strftime("%Y-%m-%d")
    dup = pd.DataFrame({"d": dates, "x": ct["x_m"]}).duplicated()
    if dup.any():
        i = int(np.nonzero(dup.to_numpy())[0][0])
        raise InputError(f"controls: two altitudes at x = {ct['x_m'][i]:g} m on {dates[i]}; keep one per date and "
                         "position.")
    x = np.sort(sensors["x_m"].to_numpy(float))
    out = (ct["x_m"] < x[0]) | (ct["x_m"] > x[-1])
    if out.any():
        i = int(np.nonzero(out.to_numpy())[0][0])
        raise InputError(f"controls: x = {ct['x_m'][i]:g} m on {dates[i]} lies outside the sensors' span "
                         f"{x[0]:g}..{x[-1]:g} m ({int(out.sum())} point(s)); such points cannot be compared.")
    first, today = _first_reading_day(s, site), datetime.fromtimestamp(now, timezone.utc).strftime("%Y-%m-%d")
    if first is None:
        raise InputError(f"site {site.name!r} has no readings yet: a control survey is compared with the settlement "
                         "since the first reading; load it once readings arrived.")
    for bad, why in ((dates < first, f"before the site's first reading ({first})"),
                     (dates > today, f"in the future (today is {today} UTC)")):
        if bad.any():
            raise InputError(f"controls: date {dates[bad].iloc[0]} is {why}.")
    out_by_date: dict = {}
    for d, xm, zm in zip(dates, ct["x_m"], ct["z_m"]):
        out_by_date.setdefault(d, []).append((float(xm), float(zm)))
    return {d: sorted(v) for d, v in out_by_date.items()}


def _refuse_control_times(dates) -> None:
    """Refuse a control date that carries a time of day other than midnight: a control survey is a day's levelling,
    stored and compared per day, so the time would be dropped without a word (operator's probe, session 36)."""
    for i, v in enumerate(dates):
        try:
            t = pd.Timestamp(v) if isinstance(v, str) and ("T" in v or " " in v.strip()) else None
        except (ValueError, TypeError):
            continue  # not a date at all: validate_site's refusal
        if t is not None and (t.hour, t.minute, t.second, t.microsecond, t.nanosecond) != (0, 0, 0, 0, 0):
            raise InputError(f"control row {i}: date {v[:40]!r} carries a time of day; control surveys are per day "
                             f"(a day's levelling, compared with that day's estimate): give the date only, "
                             f"{t.date().isoformat()}.")


def _control_dates(s, site: Site) -> dict:
    out: dict = {}
    for c in s.scalars(select(ControlPoint).where(ControlPoint.site_id == site.id)
                       .order_by(ControlPoint.date, ControlPoint.x_m)):
        out.setdefault(c.date, []).append((c.x_m, c.z_m))
    return out


def _controls_changed(site: Site, s):
    """A control survey touches no daily statistic, only the comparison: the next run recomputes from the newest
    reading's day (an earlier pending change is kept), not from the first day."""
    if site.dirty_from_ts is None:
        newest = s.scalar(select(func.max(Reading.ts)).where(Reading.site_id == site.id))
        site.dirty_from_ts = newest if newest is not None else (site.baseline_start_ts or 0)
    site.data_version = (site.data_version or 0) + 1


def put_controls(db: Database, actor: str, name: str, rows, *, now: int | None = None) -> dict:
    """Store control surveys (``date``, ``x_m``, ``z_m`` rows): each date in ``rows`` replaces that date's survey;
    other dates are kept. Returns {"dates": [...], "points": n, "changed": [dates changed]}."""
    now = now_ts() if now is None else int(now)
    with db.write() as s:
        site = _site(s, name)
        new = _check_controls(s, site, rows, now)
        have = _control_dates(s, site)
        changed = []
        for d, pts in sorted(new.items()):
            old = have.get(d)
            if old == pts:
                continue
            s.execute(ControlPoint.__table__.delete().where(ControlPoint.site_id == site.id, ControlPoint.date == d))
            s.add_all([ControlPoint(site_id=site.id, date=d, x_m=x, z_m=z) for x, z in pts])
            _audit(s, actor, site.id, "controls", d, "replace" if old else "create", old, pts)
            changed.append(d)
        if changed:
            _controls_changed(site, s)
    return {"dates": sorted(new), "points": sum(len(v) for v in new.values()), "changed": changed}


def delete_controls(db: Database, actor: str, name: str, date: str) -> dict:
    """Remove the control survey of one date (``YYYY-MM-DD``)."""
    with db.write() as s:
        site = _site(s, name)
        old = _control_dates(s, site).get(date) if isinstance(date, str) else None
        if old is None:
            raise NotFound(f"site {name!r} has no control survey on {str(date)[:40]!r}.")
        s.execute(ControlPoint.__table__.delete().where(ControlPoint.site_id == site.id, ControlPoint.date == date))
        _audit(s, actor, site.id, "controls", date, "delete", old, None)
        _controls_changed(site, s)
    return {"deleted": date, "points": len(old)}


def get_controls(db: Database, name: str) -> dict:
    """The stored control surveys and the newest successful run's comparison with them."""
    from ._db import ControlComparison
    from ._recompute import latest_run

    with db.read() as s:
        site = _site(s, name)
        points = [{"date": d, "x_m": x, "z_m": z} for d, pts in _control_dates(s, site).items() for x, z in pts]
        run = latest_run(s, site)
        comp = [] if run is None else [
            {"date": c.date, "x_m": c.x_m, "dz_control_m": c.dz_control_m, "dz_estimate_m": c.dz_estimate_m,
             "std_m": c.std_m, "inside_90": c.inside_90}
            for c in s.scalars(select(ControlComparison).where(ControlComparison.run_id == run.id)
                               .order_by(ControlComparison.date, ControlComparison.x_m))]
    return {"controls": points, "run_id": None if run is None else run.id, "comparison": comp}


def set_threshold(db: Database, actor: str, name: str, quantity: str, level: str, value) -> dict:
    """Set (value > 0) or remove (value None) one of the three levels of a quantity (m, m/day for rate): the site's
    thresholds with that level changed, checked and stored as :func:`replace_thresholds` does."""
    if quantity not in QUANTITIES:
        raise InputError(f"quantity must be one of {list(QUANTITIES)}; got {quantity!r}.")
    if level not in LEVELS:
        raise InputError(f"level must be one of {list(LEVELS)}; got {level!r}.")
    v = None if value is None else _finite(value, "threshold value")
    with db.write() as s:
        site = _site(s, name)
        table = _threshold_rows(s, site)
        levels = {lv: t.value for (q, lv), t in table.items() if q == quantity}
        if v is None:
            if level not in levels:
                raise NotFound(f"site {name!r} has no {quantity} {level} threshold to remove; its thresholds: "
                               f"{_threshold_names(table)}.")
            levels.pop(level)
        else:
            levels[level] = v
        others = {}
        for (q, lv), t in table.items():
            if q != quantity:
                others.setdefault(q, {})[lv] = t.value
        # only the changed quantity is checked: a level stored before a check existed does not block the others
        _store_thresholds(s, actor, site, table, {**others, **check_thresholds({quantity: levels})})
    return threshold_row(quantity, level, v)


def replace_thresholds(db: Database, actor: str, name: str, thresholds: dict) -> dict:
    """Replace all thresholds of a site in one transaction with ``{quantity: {level: value}}`` (m, m/day for the rate;
    checked as a whole by :func:`longprofile.rail.check_thresholds`, so levels can be raised or lowered together):
    the table ``rail settle --thresholds`` reads. Returns the new thresholds."""
    new = check_thresholds(thresholds)
    with db.write() as s:
        site = _site(s, name)
        _store_thresholds(s, actor, site, _threshold_rows(s, site), new)
    return new


#: Unit of each quantity's threshold ``value`` (the library's, the database's and the API's) and of its ``value_mm``
#: (the command line's and the thresholds table's, as the user gives it).
THRESHOLD_UNITS = {"settlement": ("m", "mm"), "rate": ("m/day", "mm/day"), "twist": ("m", "mm")}


def threshold_row(quantity: str, level: str, value) -> dict:
    """One threshold as the CLI and the API show it: ``value`` in m (m/day for the rate) as stored, its ``unit``, and
    ``value_mm``, the same in mm (mm/day for the rate), as the user gave it (``rail site threshold``, the thresholds
    table's ``value_mm`` column); None values for a removed level."""
    unit, unit_mm = THRESHOLD_UNITS[quantity]
    return {"quantity": quantity, "level": level, "value": value, "unit": unit, "value_mm": _mm(value),
            "unit_mm": unit_mm}


def threshold_rows(thresholds: dict) -> list[dict]:
    """:func:`threshold_row` of every level of ``{quantity: {level: value}}`` (m, m/day for the rate), in the order
    of the quantities and levels (what :func:`replace_thresholds` returns, as ``rail site thresholds`` prints it)."""
    return [threshold_row(q, lv, thresholds[q][lv]) for q in QUANTITIES for lv in LEVELS
            if lv in thresholds.get(q, {})]


def _threshold_names(table: dict) -> str:
    """The stored thresholds in words, in the command line's units: "settlement alert 10 mm, rate action 3 mm/day"."""
    nested: dict = {}
    for (q, lv), t in table.items():
        nested.setdefault(q, {})[lv] = t.value
    rows = threshold_rows(nested)
    return ", ".join(f"{r['quantity']} {r['level']} {r['value_mm']:g} {r['unit_mm']}" for r in rows) or "none"


def _threshold_rows(s, site: Site) -> dict:
    """{(quantity, level): Threshold row} of a site."""
    return {(t.quantity, t.level): t for t in s.scalars(select(Threshold).where(Threshold.site_id == site.id))}


def _store_thresholds(s, actor: str, site: Site, cur: dict, new: dict) -> None:
    """Make the site's rows ``cur`` equal the checked thresholds ``new``: one audit entry per changed level, and the
    site marked for a recompute when anything changed."""
    want = {(q, lv): v for q, levels in new.items() for lv, v in levels.items()}
    changed = False
    for key, t in cur.items():
        if key not in want:
            _audit(s, actor, site.id, "threshold", f"{key[0]}.{key[1]}", "set", t.value, None)
            s.delete(t)
            changed = True
    for (q, lv), v in want.items():
        t = cur.get((q, lv))
        if t is not None and t.value == v:
            continue
        _audit(s, actor, site.id, "threshold", f"{q}.{lv}", "set", None if t is None else t.value, v)
        if t is None:
            s.add(Threshold(site_id=site.id, quantity=q, level=lv, value=v))
        else:
            t.value = v
        changed = True
    if changed:
        site.data_version = (site.data_version or 0) + 1
        if site.dirty_from_ts is None:
            site.dirty_from_ts = site.baseline_start_ts or 0


def _key_hash(secret: str) -> str:
    # API keys are 32 random bytes: a plain SHA-256 is enough (no dictionary to attack), and fast per request
    return hashlib.sha256(secret.encode()).hexdigest()


def add_logger(db: Database, actor: str, name: str, logger: str) -> str:
    """Create a logger of a site and return its API key (shown once; only a hash is stored)."""
    check_name(logger, "logger name")
    key_id = secrets.token_hex(8)
    secret = secrets.token_urlsafe(32)
    with db.write() as s:
        site = _site(s, name)
        if s.scalar(select(Logger).where(Logger.site_id == site.id, Logger.name == logger)) is not None:
            raise InputError(f"logger {logger!r} already exists on site {name!r}.")
        s.add(Logger(site_id=site.id, name=logger, key_id=key_id, key_hash=_key_hash(secret), active=True))
        _audit(s, actor, site.id, "logger", logger, "create", None, {"key_id": key_id})
    return f"lpk_{key_id}_{secret}"


def _logger(s, site: Site, logger: str) -> Logger:
    lg = s.scalar(select(Logger).where(Logger.site_id == site.id, Logger.name == logger)) \
        if isinstance(logger, str) else None
    if lg is None:
        raise NotFound(f"unknown logger {str(logger)[:64]!r} on site {site.name!r}.")
    return lg


def revoke_logger(db: Database, actor: str, name: str, logger: str) -> dict:
    """Revoke a logger's API key: its next request gets 401; the readings it sent stay."""
    with db.write() as s:
        site = _site(s, name)
        lg = _logger(s, site, logger)
        if lg.active:
            lg.active = False
            _audit(s, actor, site.id, "logger", logger, "revoke", {"key_id": lg.key_id, "active": True},
                   {"key_id": lg.key_id, "active": False})
    return {"logger": logger, "active": False}


def rotate_logger(db: Database, actor: str, name: str, logger: str) -> str:
    """Give a logger a new API key (returned once, only its hash stored); the old key gets 401 at once. A revoked
    logger is re-activated with the new key."""
    key_id = secrets.token_hex(8)
    secret = secrets.token_urlsafe(32)
    with db.write() as s:
        site = _site(s, name)
        lg = _logger(s, site, logger)
        old = {"key_id": lg.key_id, "active": lg.active}
        lg.key_id, lg.key_hash, lg.active = key_id, _key_hash(secret), True
        _audit(s, actor, site.id, "logger", logger, "rotate", old, {"key_id": key_id, "active": True})
    return f"lpk_{key_id}_{secret}"


def authenticate_logger(db: Database, key: str | None) -> tuple[int, int] | None:
    """(logger id, site id) of an API key, or None."""
    if not key or not isinstance(key, str) or not key.startswith("lpk_") or key.count("_") < 2:
        return None
    _, key_id, secret = key.split("_", 2)
    with db.read() as s:
        lg = s.scalar(select(Logger).where(Logger.key_id == key_id[:32]))
        if lg is None or not lg.active or not hmac.compare_digest(lg.key_hash, _key_hash(secret)):
            return None
        return lg.id, lg.site_id


def add_channel(db: Database, actor: str, name: str, kind: str, target: str) -> dict:
    if kind not in ("webhook", "smtp"):
        raise InputError(f"channel kind must be webhook or smtp; got {kind!r}.")
    target = str(target).strip()
    if kind == "webhook" and not re.match(r"^https?://[^\s]+$", target):
        raise InputError(f"webhook target must be an http(s) URL; got {target!r}.")
    if kind == "smtp" and not re.match(r"^[^@\s,;<>]+@[^@\s,;<>]+$", target):
        raise InputError(f"smtp target must be one e-mail address; got {target!r}.")
    with db.write() as s:
        site = _site(s, name)
        if s.scalar(select(Channel).where(Channel.site_id == site.id, Channel.kind == kind,
                                          Channel.target == target)) is None:
            s.add(Channel(site_id=site.id, kind=kind, target=target))
            _audit(s, actor, site.id, "channel", f"{kind}:{target}", "create", None, {"kind": kind, "target": target})
    return {"kind": kind, "target": target}


def _channel_row(s, site: Site, kind: str, target: str) -> Channel:
    ch = s.scalar(select(Channel).where(Channel.site_id == site.id, Channel.kind == kind, Channel.target == target))
    if ch is None:
        raise NotFound(f"site {site.name!r} has no {kind} channel {str(target)[:300]!r}.")
    return ch


def _site_outbox(s, site: Site):
    """The site's notification rows (through their alarms)."""
    return select(Outbox).where(Outbox.alarm_id.in_(select(Alarm.id).where(Alarm.site_id == site.id)))


def remove_channel(db: Database, actor: str, name: str, kind: str, target: str) -> dict:
    """Remove a notification channel (audited); its notifications not yet delivered are dropped (counted)."""
    with db.write() as s:
        site = _site(s, name)
        ch = _channel_row(s, site, kind, str(target).strip())
        pending = list(s.scalars(_site_outbox(s, site).where(Outbox.kind == ch.kind, Outbox.target == ch.target,
                                                           Outbox.sent_ts.is_(None))))
        for row in pending:
            s.delete(row)
        _audit(s, actor, site.id, "channel", f"{ch.kind}:{ch.target}", "delete", {"kind": ch.kind, "target": ch.target},
               {"undelivered_dropped": len(pending)})
        out = {"kind": ch.kind, "target": ch.target, "removed": True, "undelivered_dropped": len(pending)}
        s.delete(ch)
    return out


def channel_status(db: Database, name: str) -> list[dict]:
    """The site's channels with their delivery state: notifications sent, waiting, failing (tried and not yet
    accepted: retried with back-off) and the last error."""
    with db.read() as s:
        site = _site(s, name)
        rows = list(s.scalars(_site_outbox(s, site).order_by(Outbox.id)))
        out = []
        for ch in s.scalars(select(Channel).where(Channel.site_id == site.id).order_by(Channel.id)):
            mine = [o for o in rows if o.kind == ch.kind and o.target == ch.target]
            failing = [o for o in mine if o.sent_ts is None and o.attempts > 0]
            last = max(failing, key=lambda o: o.id, default=None)
            out.append({"kind": ch.kind, "target": ch.target, "sent": sum(o.sent_ts is not None for o in mine),
                        "waiting": sum(o.sent_ts is None for o in mine), "failing": len(failing),
                        "attempts": max((o.attempts for o in failing), default=0),
                        "last_error": None if last is None else last.last_error,
                        "next_try": None if last is None else _iso_ts(last.next_try_ts)})
    return out


def _iso_ts(ts):
    return None if ts is None else datetime.fromtimestamp(ts, timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def user_exists(db: Database, username: str) -> bool:
    with db.read() as s:
        return s.scalar(select(User.id).where(User.username == str(username))) is not None


def _check_password(password) -> str:
    if not isinstance(password, str) or len(password) < 8:
        raise InputError("a password needs at least 8 characters.")
    return password


def add_user(db: Database, actor: str, username: str, password: str | None, role: str, *,
             reset_password: bool = False) -> dict:
    """Create a person, or change an existing person's role (no password needed) and, only with
    ``reset_password``, their password. Audited: creation, role old -> new, "password changed" (never the
    password). Creating an existing person without ``reset_password`` and with a password is refused."""
    from ._auth import hash_password

    check_name(username, "user name")
    if role not in ROLES:
        raise InputError(f"role must be one of {list(ROLES)}; got {role!r}.")
    with db.write() as s:
        cur = s.scalar(select(User).where(User.username == username))
        if cur is None:
            s.add(User(username=username, password_hash=hash_password(_check_password(password)), role=role,
                       active=True))
            _audit(s, actor, None, "user", username, "create", None, {"role": role})
            return {"username": username, "role": role, "created": True, "password_changed": True}
        if password is not None and not reset_password:
            raise InputError(f"user {username!r} already exists: to change their password say so (--reset-password; "
                             'API "reset_password": true); a role change needs no password.')
        old, new = {"role": cur.role, "active": cur.active}, {"role": role, "active": True}
        changed_pw = reset_password and password is not None
        if changed_pw:
            cur.password_hash = hash_password(_check_password(password))
            new["password"] = "changed"
        cur.role, cur.active = role, True
        if new != old:
            _audit(s, actor, None, "user", username, "update", old, new)
    return {"username": username, "role": role, "created": False, "password_changed": changed_pw}


def audit_trail(db: Database, name: str | None = None, limit: int = 500, *, users: bool = False) -> list[dict]:
    """Audit entries, newest first: of a site, of the people (``users``: creation, role and password changes), or
    all (neither)."""
    with db.read() as s:
        q = select(Audit).order_by(Audit.id.desc()).limit(max(1, min(int(limit), 10_000)))
        if name is not None:
            q = q.where(Audit.site_id == _site(s, name).id)
        if users:
            q = q.where(Audit.site_id.is_(None), Audit.entity == "user")
        rows = [{"ts": datetime.fromtimestamp(a.ts, timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"), "actor": a.actor,
                 "entity": a.entity, "key": a.key, "action": a.action,
                 "old": None if a.old_json is None else json.loads(a.old_json),
                 "new": None if a.new_json is None else json.loads(a.new_json)} for a in s.scalars(q)]
        ids = [int(r["key"]) for r in rows if r["entity"] == "alarm" and r["action"] == "update" and r["key"].isdigit()]
        alarms = dict(s.execute(select(Alarm.id, Alarm.quantity).where(Alarm.id.in_(ids))).all()) if ids else {}
        return [_audit_in_mm(r, alarms) for r in rows]


def _mm(value):
    """A stored value in m (m/day) in mm (mm/day): 0.0023 m -> 2.3 mm, not 2.3000000000000003; None stays None."""
    return None if not isinstance(value, (int, float)) else float(f"{1e3 * value:.12g}")


def _audit_in_mm(row: dict, alarm_quantity: dict) -> dict:
    """An audit entry with its values in m (as stored) also in mm, as the rest of the CLI shows them: a threshold's
    ``old`` / ``new`` (m, m/day for the rate) get ``old_mm``, ``new_mm``, ``unit`` and ``unit_mm``; a settlement,
    rate or twist alarm's update (its threshold followed the site's) gets ``threshold_mm`` in ``old`` and ``new``,
    and the units."""
    if row["entity"] == "threshold" and row["key"].split(".")[0] in THRESHOLD_UNITS:
        unit, unit_mm = THRESHOLD_UNITS[row["key"].split(".")[0]]
        return {**row, "old_mm": _mm(row["old"]), "new_mm": _mm(row["new"]), "unit": unit, "unit_mm": unit_mm}
    q = alarm_quantity.get(int(row["key"])) if row["entity"] == "alarm" and row["key"].isdigit() else None
    if q in THRESHOLD_UNITS and row["action"] == "update":
        unit, unit_mm = THRESHOLD_UNITS[q]
        side = {k: v if not isinstance(v, dict) or "threshold" not in v else {**v, "threshold_mm": _mm(v["threshold"])}
                for k, v in (("old", row["old"]), ("new", row["new"]))}
        return {**row, **side, "unit": unit, "unit_mm": unit_mm}
    return row


# ----------------------------------------------------------------------------------------------- ingestion

@dataclass
class IngestResult:
    """Outcome of one batch: counts and one entry per input row (row index, outcome, reason)."""

    batch_id: int | None
    counts: dict
    rows: list = field(default_factory=list)

    def as_dict(self) -> dict:
        return {"batch_id": self.batch_id, **self.counts, "rows": self.rows}


def parse_batch(body: bytes, content_type: str | None, *, required=("timestamp", "sensor_id"),
                expected=READING_COLUMNS, key: str = "readings") -> list[dict]:
    """Rows of a CSV (header: the ``rail settle`` readings columns, or ``expected``) or JSON (a list, or
    {``key``: [...]}) batch."""
    ct = (content_type or "").split(";")[0].strip().lower()
    if len(body) > 64 * 2**20:
        raise InputFormatError("batch larger than 64 MiB; send smaller batches (e.g. 1 000 readings).")
    text = _batch_text(body, content_type)
    if ct in ("text/csv", "application/csv", "text/plain"):
        reader = csv.DictReader(io.StringIO(text))
        if reader.fieldnames is None:
            raise InputFormatError("empty CSV batch: expected a header line "
                                   f"{','.join(expected)} and one line per row.")
        names = [n.strip() for n in reader.fieldnames]
        missing = [c for c in required if c not in names]
        if missing:
            wide = ("; one column per sensor (a logger's wide export)? The API takes one row per reading (its outcome "
                    "is per row); load a wide file with rail site ingest SITE --file" if key == "readings" else "")
            raise InputFormatError(f"CSV batch: missing column(s) {missing}; expected {list(expected)}{wide}.")
        reader.fieldnames = names
        try:
            rows = [dict(r) for r in reader]
        except csv.Error as exc:  # e.g. a field over the csv module's limit (131 072 characters)
            raise InputFormatError(f"CSV batch, line {reader.line_num}: {exc}.") from None
    elif ct in ("application/json", ""):
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputFormatError(f"the JSON batch does not parse: {exc.msg} at line {exc.lineno} "
                                   f"column {exc.colno}.") from None
        if isinstance(data, dict):
            data = data.get(key)
        if not isinstance(data, list):
            raise InputFormatError(f'JSON batch: expected a list of {key} or {{"{key}": [...]}}.')
        rows = data
    else:
        raise InputFormatError(f"unsupported content type {ct!r}; send text/csv or application/json.")
    if len(rows) > MAX_BATCH_ROWS:
        raise InputFormatError(f"batch of {len(rows)} rows; at most {MAX_BATCH_ROWS} per batch.")
    return rows


def _batch_text(body: bytes, content_type: str | None) -> str:
    """The batch as text: in the ``charset`` its content type declares (default UTF-8, a BOM ignored); a batch that
    is not in it is refused naming its first such line."""
    params = dict(p.strip().split("=", 1) for p in (content_type or "").split(";")[1:] if "=" in p)
    charset = params.get("charset", "utf-8").strip().strip('"').lower()
    codec = "utf-8-sig" if charset in ("utf-8", "utf8") else charset  # a BOM ignored
    try:
        return body.decode(codec)
    except LookupError:
        raise InputFormatError(f"unknown charset {charset!r} in the content type; send UTF-8 text.") from None
    except UnicodeDecodeError:
        bad = first_undecodable_line(body.split(b"\n"), codec)
        where = f": line {bad[0]} ({bad[1][:60]!r}; Latin-1 or Windows-1252 accents?)" if bad else ""
        raise InputFormatError(f"the batch is not {charset} text{where}: send UTF-8, or declare the charset in the "
                               "content type (text/csv; charset=windows-1252).") from None


def _refuse_mixed_zones(rows) -> None:
    """Refuse a batch whose times partly carry a UTC offset (``Z``, ``+01:00``) and partly not, as ``rail settle``
    refuses such a file (:func:`~longprofile._validation.utc_offset_mix`): which zone the others are in cannot be
    known (session 35: the service took them as UTC)."""
    mix = utc_offset_mix([r.get("timestamp") if isinstance(r, dict) else None for r in rows])
    if mix is not None:
        (i, j) = mix
        raise InputFormatError(f"the batch mixes times with a UTC offset (row {i}: {rows[i]['timestamp']!r}) and "
                               f"without one (row {j}: {rows[j]['timestamp']!r}); send them all in UTC (with Z), or "
                               "all with their offset.")


def _parse_time(v, zone=None) -> tuple[int, int | None]:
    """``(ts, second)``: the reading's time in seconds since 1970 UTC, and for a time without a UTC offset that the
    site's clock ``zone`` (a ``ZoneInfo``; None: UTC) shows twice, when it goes back at the end of daylight-saving
    time, the second of the two (``ts`` is then the first; :func:`_resolve_repeated_hour` chooses); else None. A
    local time the clock skips when it goes forward is refused."""
    if not isinstance(v, str) or not v.strip():
        raise ValueError("timestamp is missing or not a string")
    s = v.strip()
    try:
        t = datetime.fromisoformat(s[:-1] + "+00:00" if s.endswith(("Z", "z")) else s)
    except ValueError:
        raise ValueError(f"timestamp {v[:40]!r} is not ISO 8601 (e.g. 2019-11-18T08:10:00Z)") from None
    if t.microsecond:
        raise ValueError("sub-second timestamps are not supported (one reading per sensor and second)")
    if t.tzinfo is None and zone is not None and zone.key != "UTC":
        return _local_seconds(t, zone, v)
    if t.tzinfo is not None:
        try:
            t = t.astimezone(timezone.utc).replace(tzinfo=None)
        except OverflowError:  # 0001-01-01T00:00:00+01:00 is before year 1 in UTC
            raise ValueError(f"timestamp {v[:40]!r} is out of the range of dates") from None
    return _seconds(t), None


def _seconds(t: datetime) -> int:
    """Seconds since 1970 of a naive UTC time."""
    return int((t - datetime(1970, 1, 1)).total_seconds())


def _local_seconds(t: datetime, zone, text: str) -> tuple[int, int | None]:
    """``(first, second)`` UTC seconds of the naive local time ``t`` in ``zone`` (``second`` None unless the clock
    shows ``t`` twice); a time in the hour the clock skips refused."""
    try:
        first, second = (t.replace(tzinfo=zone, fold=f).astimezone(timezone.utc).replace(tzinfo=None) for f in (0, 1))
    except OverflowError:
        raise ValueError(f"timestamp {text[:40]!r} is out of the range of dates") from None
    if first.replace(tzinfo=timezone.utc).astimezone(zone).replace(tzinfo=None) != t:
        raise ValueError(f"timestamp {text[:40]!r} does not exist in {zone.key} (the clock skips that hour when it "
                         "goes forward): is the logger's clock on that zone? (site timezone)")
    return _seconds(first), (_seconds(second) if second != first else None)


def _parse_num(v, what, lo, hi) -> float:
    if isinstance(v, bool) or v is None or (isinstance(v, str) and not v.strip()):
        raise ValueError(f"{what} is missing")
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"{what} {str(v)[:40]!r} is not a number") from None
    if not math.isfinite(f):
        raise ValueError(f"{what} must be finite")
    if not lo <= f <= hi:
        raise ValueError(f"{what} {f:g} is outside the plausible range {lo:g}..{hi:g}"
                         + (f": {MISSING_CODE_HINT}" if missing_value_code(f) else ""))
    return f


def _same(a, b) -> bool:
    return (a is None and b is None) or (a is not None and b is not None and (a == b or (a != a and b != b)))


def ingest(db: Database, name: str, rows, *, logger_id: int | None = None, angle_unit: str = "deg",
           check_units: bool = True, now: int | None = None, actor: str | None = None,
           source: str | None = None) -> IngestResult:
    """Store a batch of readings; returns after the commit (acknowledge only then).

    Per row: ``accepted`` (new key), ``duplicate`` (same key and values: nothing written), ``revised``
    (same key, new values: the old ones are kept in reading_revisions) or ``rejected`` (with the reason).
    Idempotent: sending a batch twice gives ``duplicate`` for every row the second time. ``actor``: a batch loaded
    by hand (``rail site ingest``), audited in the same transaction with its counts and ``source`` (the file name);
    a logger's batches are recorded in the batches table instead.
    """
    if angle_unit not in ("deg", "rad"):
        raise InputError(f"angle_unit must be 'deg' or 'rad'; got {angle_unit!r}.")
    now = now_ts() if now is None else int(now)
    rows = list(rows)
    _refuse_mixed_zones(rows)
    zone = _site_zone(db, name)
    out: list = [None] * len(rows)
    parsed = []  # (i, sensor_id, ts, angle, temp, second): second, the other reading of a time shown twice
    for i, r in enumerate(rows):
        if not isinstance(r, dict):
            out[i] = {"row": i, "outcome": "rejected", "reason": "a reading must be an object with "
                      f"{list(READING_COLUMNS)}"}
            continue
        try:
            if None in r:  # csv.DictReader's key of the fields beyond the header's
                raise ValueError(f"the row has {len(r) - 1 + len(r[None])} fields, more than the header's {len(r) - 1}")
            extra = sorted(map(str, set(r) - set(READING_COLUMNS)))
            if "angle_rad" in r or "angle" in r:
                raise ValueError("angles must be in column angle_deg (degrees); for radians send angle_deg with "
                                 "?angle_unit=rad")
            if extra:
                raise ValueError(f"unknown column(s) {extra[:3]}; expected {list(READING_COLUMNS)}")
            sid = r.get("sensor_id")
            sid = str(sid).strip() if sid is not None else ""
            if not sid:
                raise ValueError("sensor_id is missing")
            ts, second = _parse_time(r.get("timestamp"), zone)
            if ts > now + MAX_FUTURE_SKEW_S:
                raise ValueError(f"timestamp is {(ts - now) / 60:.0f} min in the future of the server clock "
                                 "(logger clock skew?)")
            lim = ANGLE_RANGE_DEG if angle_unit == "deg" else tuple(math.radians(v) for v in ANGLE_RANGE_DEG)
            ang = _parse_num(r.get("angle_deg"), "angle_deg", *lim)
            if angle_unit == "rad":
                ang = math.degrees(ang)
            # a failed temperature channel: the angle is kept (temperature NULL) and the recompute gives it its
            # nearest sensors' temperature of the same minute, as `rail settle` does (rail.fill_temperature)
            t_raw = r.get("temperature_c")
            missing = (t_raw is None or (isinstance(t_raw, str) and t_raw.strip().lower() in MISSING_TEXT | {""})
                       or (isinstance(t_raw, float) and math.isnan(t_raw)))
            tmp = None if missing else _parse_num(t_raw, "temperature_c", *TEMPERATURE_RANGE_C)
        except ValueError as exc:
            out[i] = {"row": i, "outcome": "rejected", "reason": str(exc)}
            continue
        parsed.append((i, sid, ts, ang, tmp, second))
    for attempt in range(5):
        try:
            return _store(db, name, rows, out, parsed, logger_id, angle_unit, check_units, (actor, source))
        except IntegrityError:  # PostgreSQL: a concurrent batch inserted the same key; start again
            if attempt == 4:
                raise
    raise AssertionError("unreachable")


def _site_zone(db: Database, name: str):
    """The ``ZoneInfo`` of the site's logger clocks (None for UTC); an unknown site is refused."""
    with db.read() as s:
        key = _site(s, name).timezone or "UTC"
    return None if key == "UTC" else time_zone(key)


def _existing_readings(s, keys) -> dict:
    """{(sensor_pk, ts): (id, angle_deg, temperature_c, revision, batch_id)} of the stored readings among ``keys``.

    Looked up by index seeks on the (sensor_pk, ts) key: ``sensor_pk IN (...) AND ts IN (...)`` over groups of
    sensors whose timestamps are few (a logger's batch: every sensor at the same few times), so the cross
    product stays within a few times the number of keys; the surplus is filtered here. (A row-value
    ``(sensor_pk, ts) IN (VALUES ...)`` made SQLite scan the site's readings for every batch: the time per batch
    grew with the table, 90 ms to 310 ms over 200 000 readings.) Sensors and site are not re-checked: the
    sensor keys come from this site's sensors.
    """
    by_sensor: dict = {}
    for spk, ts in keys:
        by_sensor.setdefault(spk, set()).add(ts)
    wanted = set(keys)
    groups, group, times = [], [], set()
    for spk in sorted(by_sensor, key=lambda k: (min(by_sensor[k]), len(by_sensor[k]))):
        union = times | by_sensor[spk]
        if group and ((len(group) + 1) * len(union) > 4 * (sum(len(by_sensor[g]) for g in group) + len(by_sensor[spk]))
                      or len(group) + len(union) > 900):
            groups.append((group, times))
            group, union = [], set(by_sensor[spk])
        group.append(spk)
        times = union
    if group:
        groups.append((group, times))
    found = {}
    cols = (Reading.id, Reading.sensor_pk, Reading.ts, Reading.angle_deg, Reading.temperature_c, Reading.revision,
            Reading.batch_id)
    for sensors_, times_ in groups:
        ts_sorted = sorted(times_)
        for c in range(0, len(ts_sorted), 800):  # a sensor with many timestamps: bounded parameter lists
            q = select(*cols).where(Reading.sensor_pk.in_(sensors_), Reading.ts.in_(ts_sorted[c:c + 800]))
            for rid, spk, ts, a, t, rev, bid in s.execute(q):
                if (spk, ts) in wanted:
                    found[(spk, ts)] = (rid, a, t, rev, bid)
    return found


def _with_recent(s, df: pd.DataFrame, good) -> pd.DataFrame:
    """The batch's angles with the stored readings of its sensors within :data:`RECENT_S` of it, for the radian test
    of a batch too small to have a noise of its own (a logger posting each scan: one reading per sensor; session 35,
    a probe: radians sent that way were all accepted, and the settlement came out 57 times too small). Read on every
    such batch, so a few hours, not the site's history: 36 readings per sensor at 10-minute readings."""
    pks = {g[2]: g[1] for g in good}
    lo, hi = int(df["ts"].min()) - RECENT_S, int(df["ts"].max()) + RECENT_S
    names = {pk: sid for sid, pk in pks.items()}
    stored = s.execute(select(Reading.sensor_pk, Reading.ts, Reading.angle_deg).where(
        Reading.sensor_pk.in_(sorted(pks.values())), Reading.ts >= lo, Reading.ts <= hi).limit(20_000)).all()
    old = pd.DataFrame([(names[pk], ts, a) for pk, ts, a in stored], columns=["sensor_id", "ts", "angle_deg"])
    both = pd.concat([df, old]).drop_duplicates(["sensor_id", "ts"], keep="first")
    return both.sort_values(["sensor_id", "ts"], kind="stable")


def _resolve_repeated_hour(s, parsed, sensors) -> tuple[list, dict]:
    """``parsed`` with each local time the clock shows twice (autumn, end of daylight-saving time) given one of its
    two UTC times: the one a stored reading of that sensor has with the same values (a batch sent again), else the
    second when the sensor already has a reading from the first one on, within the hour before the second (stored,
    or earlier in this batch: the logger's clock went back), else the first. Also ``{row: note}`` for such rows."""
    folded = [p for p in parsed if p[5] is not None and p[1] in sensors]
    if not folded:
        return parsed, {}
    pks = sorted({sensors[p[1]][0] for p in folded})
    lo, hi = min(p[2] for p in folded), max(p[5] for p in folded)
    seen: dict = {}
    for spk, ts, ang, tmp in s.execute(select(Reading.sensor_pk, Reading.ts, Reading.angle_deg, Reading.temperature_c)
                                       .where(Reading.sensor_pk.in_(pks), Reading.ts >= lo, Reading.ts <= hi)):
        seen.setdefault(spk, {})[ts] = (ang, tmp)
    resolved, notes = [], {}
    for p in parsed:
        if p[5] is None or p[1] not in sensors:
            resolved.append(p)
            continue
        i, sid, first, ang, tmp, second = p
        mine = seen.setdefault(sensors[sid][0], {})
        same = [t for t in (first, second) if t in mine and _same(mine[t][0], ang) and _same(mine[t][1], tmp)]
        ts = same[0] if same else second if any(first <= t < second for t in mine) else first
        mine.setdefault(ts, (ang, tmp))
        notes[i] = (f"a local time the clock shows twice (it went back): read as the {'first' if ts == first else 'second'}"
                    f", {datetime.fromtimestamp(ts, timezone.utc):%Y-%m-%dT%H:%M:%SZ}")
        resolved.append((i, sid, ts, ang, tmp, None))
    return resolved, notes


def _store(db, name, rows, out, parsed, logger_id, angle_unit, check_units, by=(None, None)) -> IngestResult:
    """Store the parsed rows in one transaction (``by``: (actor, source) of a batch loaded by hand, audited)."""
    out = list(out)
    with db.write() as s:
        site = _site(s, name, lock=True)  # PostgreSQL: concurrent batches of a site update its watermark in turn
        sensors = {x.sensor_id: (x.id, x.active) for x in s.execute(
            select(Sensor.sensor_id, Sensor.id, Sensor.active).where(Sensor.site_id == site.id))}
        good = []
        parsed, notes = _resolve_repeated_hour(s, parsed, sensors)
        for i, sid, ts, ang, tmp, _ in parsed:
            if sid not in sensors:
                out[i] = {"row": i, "outcome": "rejected", "reason": f"unknown sensor {sid[:64]!r} on this site"}
            elif not sensors[sid][1]:
                out[i] = {"row": i, "outcome": "rejected", "reason": f"sensor {sid[:64]!r} is not active"}
            else:
                good.append((i, sensors[sid][0], sid, ts, ang, tmp))
        if good and check_units:  # the same checks validate_site makes on files
            df = pd.DataFrame({"sensor_id": [g[2] for g in good], "ts": [g[3] for g in good],
                               "angle_deg": [g[4] for g in good]}).sort_values(["sensor_id", "ts"])
            noise = angle_noise(df) if angle_unit == "deg" else np.nan
            if angle_unit == "deg" and not np.isfinite(noise):
                noise = angle_noise(_with_recent(s, df, good))
            level = track_angle(df)
            why = ""
            if np.isfinite(noise) and noise < RADIAN_NOISE_THRESHOLD:
                why = (f"the batch's angle noise {noise:.2g} is implausibly small for degrees: the angles look like "
                       "radians (send ?angle_unit=rad)")
            elif level > MAX_TRACK_ANGLE_DEG:
                why = (f"the batch's sensors read a median {level:.3g} deg from level, beyond the few degrees of "
                       f"sleeper inclinometers (<= {MAX_TRACK_ANGLE_DEG:g}): "
                       + ("are the angles degrees? (send them without ?angle_unit=rad)" if angle_unit == "rad" else
                          "another unit under angle_deg?"))
            if why:
                for g in good:
                    out[g[0]] = {"row": g[0], "outcome": "rejected", "reason": why}
                good = []
        # duplicates inside the batch
        first = {}
        uniq = []
        for g in good:
            k = (g[1], g[3])
            if k in first:
                f = first[k]
                if f[4] == g[4] and f[5] == g[5]:
                    out[g[0]] = {"row": g[0], "outcome": "duplicate", "reason": f"same as row {f[0]} of this batch"}
                else:
                    out[g[0]] = {"row": g[0], "outcome": "rejected",
                                 "reason": f"conflicts with row {f[0]} of this batch (same sensor and timestamp)"}
                continue
            first[k] = g
            uniq.append(g)
        existing = _existing_readings(s, [(g[1], g[3]) for g in uniq])
        batch = Batch(site_id=site.id, logger_id=logger_id, received_ts=now_ts(),
                      last_reading_ts=max((g[3] for g in good), default=None))
        s.add(batch)
        s.flush()
        new, revs, changed_ts = [], [], []
        for i, spk, _sid, ts, ang, tmp in uniq:
            e = existing.get((spk, ts))
            if e is None:
                new.append({"site_id": site.id, "sensor_pk": spk, "ts": ts, "angle_deg": ang, "temperature_c": tmp,
                            "revision": 0, "batch_id": batch.id})
                out[i] = {"row": i, "outcome": "accepted"}
                changed_ts.append(ts)
            elif _same(e[1], ang) and _same(e[2], tmp):
                out[i] = {"row": i, "outcome": "duplicate", "reason": "already stored"}
            else:
                revs.append((e, ang, tmp))
                out[i] = {"row": i, "outcome": "revised", "reason": f"revision {e[3] + 1}; previous value kept",
                          "previous": {"angle_deg": e[1], "temperature_c": e[2]}}
                changed_ts.append(ts)
        if new:
            s.execute(Reading.__table__.insert(), new)
        for (rid, a, t, rev, bid), ang, tmp in revs:
            s.add(ReadingRevision(reading_id=rid, revision=rev, angle_deg=a, temperature_c=t, batch_id=bid,
                                  superseded_by_batch_id=batch.id))
            s.execute(update(Reading).where(Reading.id == rid).values(angle_deg=ang, temperature_c=tmp,
                                                                       revision=rev + 1, batch_id=batch.id))
        for i, note in notes.items():
            out[i]["note"] = note
        counts = {k: sum(1 for o in out if o and o["outcome"] == k)
                  for k in ("accepted", "duplicate", "revised", "rejected")}
        batch.n_accepted, batch.n_duplicate = counts["accepted"], counts["duplicate"]
        batch.n_revised, batch.n_rejected = counts["revised"], counts["rejected"]
        if by[0] is not None:  # a manual load changes the data behind the alarms: who, which file, what it did
            _audit(s, by[0], site.id, "readings", (by[1] or f"batch {batch.id}")[-200:], "ingest", None,
                   {"batch_id": batch.id, "file": by[1], **counts})
        if changed_ts:
            lo = min(changed_ts)
            site.dirty_from_ts = lo if site.dirty_from_ts is None else min(site.dirty_from_ts, lo)
            site.data_version = (site.data_version or 0) + 1
        bid = batch.id
    return IngestResult(batch_id=bid, counts=counts, rows=out)


def reading_count(db: Database, name: str) -> int:
    with db.read() as s:
        return int(s.scalar(select(func.count()).select_from(Reading).where(Reading.site_id == _site(s, name).id)))
