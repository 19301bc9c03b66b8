"""Alarm lifecycle (raise -> acknowledge -> clear, on transitions only) and the notification outbox.

Levels are decided by :func:`longprofile.rail.threshold_alarms` — the function ``rail settle --thresholds`` uses —
on the latest day of a run: a level holds when the exceedance probability of its threshold is >= the site's
``alarm_probability`` (default 0.5) at some station (settlement, rate) or between two neighbouring sensors
(twist: the difference of their altitude changes).

Notifications are rows of the ``outbox`` table written in the SAME transaction as the alarm change, so a
crash cannot lose one; the deliverer marks a row sent after the receiver accepted it, and every delivery
carries the row's idempotency key (HTTP header ``Idempotency-Key``, e-mail ``Message-ID``) so that the one
repeat a crash between "sent" and "marked" can cause is recognisable by the receiver.
"""

from __future__ import annotations

import json
import smtplib
import urllib.request
from dataclasses import dataclass
from email.message import EmailMessage

import numpy as np
import pandas as pd
from sqlalchemy import func, select, update

from .. import CONTROL_CHECK_P, THRESHOLD_LEVELS, THRESHOLD_QUANTITIES, USER_EXCLUDED, threshold_alarms
from ._db import (
    LEVELS,
    Alarm,
    Audit,
    Batch,
    Channel,
    Database,
    Logger,
    Outbox,
    Reading,
    Sensor,
    Site,
    Threshold,
    now_ts,
)

__all__ = ["quantity_levels", "transition", "evaluate_no_data", "acknowledge", "deliver_outbox", "Notifier",
           "list_alarms", "health_level", "HEALTH_LEVELS", "ended_as"]

#: Level of the health alarm of a sensor status (:data:`longprofile.rail.SENSOR_STATUSES`) other than the ones below:
#: "action" (a faulty sensor, or one without usable readings: dead, frozen).
HEALTH_ACTION = "action"
#: ... and of these: none for "ok" and for a sensor the user excluded (the site setting ``exclude``: a decision, not a
#: fault); "alert" for a late sensor (installed after the baseline: left out, not faulty, an alert says so).
HEALTH_LEVELS = {"ok": None, USER_EXCLUDED: None, "late": "alert"}


def health_level(status: str) -> str | None:
    """The level of the health alarm of a sensor of this status (None: no alarm; :data:`HEALTH_LEVELS`)."""
    return HEALTH_LEVELS.get(str(status), HEALTH_ACTION)


def quantity_levels(res, thresholds: dict, *, probability: float = 0.5) -> dict:
    """{quantity: (level or None, value, threshold, where)} on the last day of a SettlementResult: the highest level
    of :func:`longprofile.rail.threshold_alarms` (the function ``rail settle --thresholds`` calls) on that day, and
    its station (or pair of sensors) of largest |value|; the through-time posterior when the result has one."""
    sm = res.smoothed
    mean = (sm.mean if sm is not None else res.dz)[-1:]
    std = (sm.std if sm is not None else res.dz_std)[-1:]
    if sm is None:  # no rate posterior: rate thresholds are not tested
        thresholds = {q: v for q, v in thresholds.items() if q != "rate"}
    a = threshold_alarms(res.days[-1:], list(res.sensor_ids), np.asarray(res.x), mean, std, thresholds,
                         rate=None if sm is None else sm.rate[-1:], rate_std=None if sm is None else sm.rate_std[-1:],
                         min_probability=probability)
    out = {}
    for q in THRESHOLD_QUANTITIES:
        found = (None, None, None, None)
        for lv in THRESHOLD_LEVELS:
            hit = a[(a["kind"] == q) & (a["level"] == lv)]
            if len(hit):
                j = int(np.argmax(np.abs(hit["value"].to_numpy())))
                found = (lv, float(hit["value"].iloc[j]), float(hit["threshold"].iloc[j]), str(hit["sensor_id"].iloc[j]))
        out[q] = found
    return out


def _payload(site: Site, alarm: Alarm, event: str) -> dict:
    return {"site": site.name, "event": event, "alarm_id": alarm.id, "quantity": alarm.quantity,
            "subject": alarm.subject, "level": alarm.level, "value": alarm.value, "threshold": alarm.threshold,
            "day": alarm.day, "message": alarm.message, "state": alarm.state, "reason": alarm.cleared_reason}


def _enqueue(s, site: Site, alarm: Alarm, event: str):
    for ch in s.scalars(select(Channel).where(Channel.site_id == site.id).order_by(Channel.id)):
        key = f"lp-{site.id}-{alarm.id}-{event}-{ch.id}"
        s.add(Outbox(key=key, alarm_id=alarm.id, event=event, kind=ch.kind, target=ch.target,
                     payload_json=json.dumps(_payload(site, alarm, event)), created_ts=now_ts(), attempts=0,
                     next_try_ts=0))


def open_alarms(s, site: Site) -> dict:
    """{open_key: Alarm} of the site's open alarms (one query for a run's many transitions)."""
    return {a.open_key: a for a in s.scalars(select(Alarm).where(Alarm.site_id == site.id,
                                                                 Alarm.open_key.is_not(None)))}


#: Notification events of an alarm: "raised"; for the alarm it ends, "cleared" (back within thresholds),
#: "escalated" / "de-escalated" (a new alarm of another level replaces it), "withdrawn" (its threshold was removed,
#: or its sensor deactivated); the payload's "reason" says why in words.
EVENTS = ("raised", "cleared", "escalated", "de-escalated", "withdrawn")


def ended_as(reason: str | None) -> str:
    """The notification event (:data:`EVENTS`) of an ended alarm from its ``cleared_reason``, as :func:`_end_event`
    wrote it: "escalated", "de-escalated", "cleared" (back within thresholds; also an alarm ended before reasons
    were recorded) or "withdrawn"."""
    for event in ("escalated", "de-escalated"):
        if (reason or "").startswith(f"{event} to "):
            return event
    return "cleared" if reason in (None, "", _BACK_WITHIN) else "withdrawn"


#: The ``cleared_reason`` of an alarm back within its thresholds.
_BACK_WITHIN = "back within thresholds"


def _end_event(cur: Alarm, level: str | None, reason: str | None) -> tuple[str, str]:
    """(event, reason) of the open alarm ``cur`` ended by a move to ``level`` (None: back within thresholds)."""
    if reason is not None:
        return "withdrawn", reason if level is None else f"{reason}; now at {level} level"
    if level is None:
        return "cleared", _BACK_WITHIN
    up = LEVELS.index(level) > LEVELS.index(cur.level) if cur.level in LEVELS and level in LEVELS else True
    return ("escalated", f"escalated to {level}") if up else ("de-escalated", f"de-escalated to {level}")


def _refresh(s, site: Site, cur: Alarm, value, threshold, day, message):
    """An open alarm at the same level follows the latest run: value, day, message; a changed threshold is audited."""
    if threshold != cur.threshold and not (threshold is None and cur.threshold is None):
        from ._core import _audit

        _audit(s, "service", site.id, "alarm", str(cur.id), "update", {"threshold": cur.threshold,
                                                                       "message": cur.message},
               {"threshold": threshold, "message": message})
        cur.threshold = threshold
    cur.value, cur.day = value, day
    if message:
        cur.message = message


def transition(s, site: Site, quantity: str, subject: str, level: str | None, *, value=None, threshold=None,
               day=None, message="", run_id=None, opened: dict | None = None, reason: str | None = None) -> str:
    """Move the open alarm of (site, quantity, subject) to ``level`` (None = clear).

    Returns what happened: "none" (same level: de-duplicated, the open alarm's numbers and message updated),
    "raised", "changed" (ended + raised) or "cleared". Notifications go to the outbox in the caller's transaction
    (:data:`EVENTS`). ``opened``: the site's open alarms from :func:`open_alarms` in this transaction (kept up to
    date here) instead of one query per call. ``reason``: why the open alarm ends other than by the values (e.g.
    its threshold was removed).
    """
    key = f"{site.id}:{quantity}:{subject}"
    cur = s.scalar(select(Alarm).where(Alarm.open_key == key)) if opened is None else opened.get(key)
    if cur is not None and cur.level == level:
        _refresh(s, site, cur, value, threshold, day, message)
        return "none"
    if cur is None and level is None:
        return "none"
    what = "raised"
    if cur is not None:
        event, cur.cleared_reason = _end_event(cur, level, reason)
        cur.state, cur.open_key, cur.cleared_ts = "cleared", None, now_ts()
        if opened is not None:
            opened.pop(key, None)
        s.flush()
        _enqueue(s, site, cur, event)
        what = "cleared" if level is None else "changed"
    if level is not None:
        a = Alarm(site_id=site.id, quantity=quantity, subject=subject, level=level, state="raised", open_key=key,
                  value=value, threshold=threshold, day=day, message=message, raised_ts=now_ts(), raised_run_id=run_id)
        s.add(a)
        s.flush()
        if opened is not None:
            opened[key] = a
        _enqueue(s, site, a, "raised")
    return what


def close_sensor_alarms(s, site: Site, sensor_ids, *, actor: str, reason: str = "sensor deactivated") -> int:
    """End the open alarms of these sensors (health, no data) with ``reason``, notified ("withdrawn") and audited;
    returns how many."""
    from ._core import _audit

    sids = [str(x) for x in sensor_ids]
    if not sids:
        return 0
    n = 0
    for a in s.scalars(select(Alarm).where(Alarm.site_id == site.id, Alarm.open_key.is_not(None),
                                           Alarm.subject.in_(sids), Alarm.quantity.in_(("health", "no_data")))):
        a.state, a.open_key, a.cleared_ts, a.cleared_reason = "cleared", None, now_ts(), reason
        s.flush()
        _enqueue(s, site, a, "withdrawn")
        _audit(s, actor, site.id, "alarm", str(a.id), "close", {"state": "open", "level": a.level},
               {"state": "cleared", "reason": reason})
        n += 1
    return n


def thresholds_of(s, site: Site) -> dict:
    out: dict = {}
    for t in s.scalars(select(Threshold).where(Threshold.site_id == site.id)):
        out.setdefault(t.quantity, {})[t.level] = t.value
    return out


def evaluate_result(s, site: Site, res, run_id: int, probability: float) -> list[str]:
    """Alarm transitions after a run: the three quantities and the sensor-health alarms."""
    events = []
    opened = open_alarms(s, site)
    day = pd.Timestamp(res.days[-1]).strftime("%Y-%m-%d")
    unit = {"settlement": "mm", "rate": "mm/day", "twist": "mm"}
    thresholds = thresholds_of(s, site)
    for q, (lv, val, thr, where) in quantity_levels(res, thresholds, probability=probability).items():
        msg = "" if lv is None else (f"{q} {1e3 * val:+.1f} {unit[q]} at {where} on {day} "
                                     f"(|{q}| > {1e3 * thr:.1f} {unit[q]}, {lv} level)")
        cur = opened.get(f"{site.id}:{q}:site")
        removed = None if cur is None or cur.level in thresholds.get(q, {}) else \
            f"the {cur.level} threshold of {q} was removed"
        w = transition(s, site, q, "site", lv, value=val, threshold=thr, day=day, message=msg, run_id=run_id,
                       opened=opened, reason=removed)
        if w != "none":
            events.append(f"{q}:{w}")
    for sid, st, detail in zip(res.health.sensor_ids, res.health.status, res.health.detail):
        lv = health_level(st)  # none for a sensor the user excluded: its open health alarm is withdrawn
        w = transition(s, site, "health", str(sid), lv, day=day, run_id=run_id, opened=opened,
                       message="" if lv is None else f"sensor {sid} {st}: {detail}",
                       reason=EXCLUDED_REASON if st == USER_EXCLUDED else None)
        if w != "none":
            events.append(f"health:{sid}:{w}")
    w = _controls_alarm(s, site, res.control_check, day, run_id, opened)
    if w != "none":
        events.append(f"controls:{w}")
    return events


def _controls_alarm(s, site: Site, check, day: str, run_id: int, opened: dict) -> str:
    """An alert while the run's control check (:attr:`longprofile.rail.SettlementResult.control_check`, the test
    ``rail settle`` warns from) says the control surveys contradict the estimate; cleared when a later run's does not.

    Alert, not action: the check says the estimate cannot be trusted where the controls were levelled, not that the
    track passed a threshold; the controls themselves are the measurement to act on (docs/rail-service.md)."""
    bad = check is not None and bool(check.disagree)
    msg = ""
    if bad:
        date, x, diff, z = check.worst
        msg = (f"the control surveys contradict the estimate: {check.n_outside} of {check.n_points} control points "
               f"outside the 90 % band, chi-squared {check.chi2:.3g} on {check.n_points} points "
               f"(p = {check.p_value:.1e} < {CONTROL_CHECK_P:g}); largest difference {1e3 * diff:+.1f} mm at "
               f"x = {x:g} m on {date} ({z:+.1f} std). Trust the controls; see the site page's control surveys.")
    return transition(s, site, "controls", "site", "alert" if bad else None, value=None if check is None else
                      check.p_value, threshold=CONTROL_CHECK_P, day=day, message=msg, run_id=run_id, opened=opened,
                      reason="no control survey compared in the latest run" if check is None else None)


def _inactive_with_open_alarms(s, site: Site) -> list[str]:
    """Inactive sensors of the site that still have an open health or no-data alarm (deactivated before alarms
    were closed on deactivation)."""
    return list(s.scalars(select(Sensor.sensor_id).where(
        Sensor.site_id == site.id, Sensor.active.is_(False),
        Sensor.sensor_id.in_(select(Alarm.subject).where(Alarm.site_id == site.id, Alarm.open_key.is_not(None),
                                                         Alarm.quantity.in_(("health", "no_data")))))))


#: ``cleared_reason`` of an open health or no-data alarm of a sensor the user excluded (site setting ``exclude``).
EXCLUDED_REASON = "excluded by the user (site setting exclude)"
#: ... and of a no-data alarm of a sensor declared replaced (rail site events): its series goes on under the new id.
REPLACED_REASON = "replaced by another sensor (rail site events): its series goes on under the new id"


def evaluate_no_data(s, site: Site, now: int | None = None) -> list[str]:
    """"No data from sensor X for N hours": against the clock, or the newest reading of the site (clock="data");
    and "no data from logger L" when none of a logger's batches arrived for as long (:func:`_silent_loggers`), or
    when a logger registered (or given a new key) that long ago has sent nothing at all (:func:`_unheard_loggers`).

    A sensor that has not reported since it was registered gets the same ``no_data_hours`` of grace from its
    registration (against the wall clock) before the alarm; open alarms of inactive sensors are closed. A sensor
    whose newest reading came from a silent logger, and that was reporting when the logger fell silent, gets no
    alarm of its own: the logger's alarm names it (one alarm, not one per sensor); so do the sensors of a site that
    has received no reading at all when a logger of it was never heard from. A sensor the user excluded (site setting
    ``exclude``) is expected to be silent: no alarm, and an open one is withdrawn (:data:`EXCLUDED_REASON`)."""
    swept = _inactive_with_open_alarms(s, site)
    events = [f"withdrawn:{sid}" for sid in swept] if close_sensor_alarms(s, site, swept, actor="service") else []
    # one index seek per sensor on the (sensor_pk, ts) key: a join grouped by sensor scanned every reading of
    # the site (0.67 s at 5.3 M readings, docs/rail-service.md, Measured); and the logger of that newest reading
    newest = select(func.max(Reading.ts)).where(Reading.sensor_pk == Sensor.id).scalar_subquery()
    via = (select(Batch.logger_id).join(Reading, Reading.batch_id == Batch.id).where(Reading.sensor_pk == Sensor.id)
           .order_by(Reading.ts.desc()).limit(1).scalar_subquery())
    rows = s.execute(select(Sensor.sensor_id, newest, Sensor.created_ts, via).where(Sensor.site_id == site.id,
                                                                                    Sensor.active.is_(True))).all()
    replaced = _replaced(s, site)
    excluded = set(site.settings.get("exclude") or []) | replaced
    last = {sid: t for sid, t, _, _ in rows}
    created = {sid: c for sid, _, c, _ in rows}
    seen = [t for t in last.values() if t is not None]
    wall = now_ts() if now is None else int(now)
    ref = max(seen) if site.clock == "data" and seen else wall  # nothing read yet: only registrations to go by
    limit = site.no_data_hours * 3600.0
    opened = open_alarms(s, site)
    # clock=data with no reading of an active sensor: no data time to measure a logger's silence against
    silent = _silent_loggers(s, site, ref, limit) if site.clock != "data" or seen else {}
    silent.update(_unheard_loggers(s, site, wall, limit))
    covered = {sid: silent[lg][0] for sid, t, _, lg in rows
               if lg in silent and t is not None and (silent[lg][2] is None or silent[lg][2] - t <= limit)}
    unheard = sorted(name for name, _, _, heard in silent.values() if not heard)
    if not seen and unheard:  # the site has received nothing: its loggers' alarm says it, not one per sensor
        covered = {sid: ", ".join(unheard) for sid in last}
    covered = {sid: lg for sid, lg in covered.items() if sid not in excluded}
    events += _logger_alarms(s, site, silent, covered, opened)
    for sid, t in sorted(last.items()):
        new = t is None and created[sid] is not None and wall - created[sid] <= limit  # grace after registration
        stale = not new and (t is None or ref - t > limit) and sid not in covered and sid not in excluded
        lv = "alert" if stale else None
        msg = "" if not stale else (f"no data from sensor {sid} for {site.no_data_hours:g} h" if t is None else
                                    f"no data from sensor {sid} for {(ref - t) / 3600:.1f} h "
                                    f"(limit {site.no_data_hours:g} h)")
        reason = (REPLACED_REASON if sid in replaced else EXCLUDED_REASON if sid in excluded else
                  f"its logger {covered[sid]} is silent (logger alarm)" if sid in covered else None)
        w = transition(s, site, "no_data", sid, lv, value=None if t is None else (ref - t) / 3600.0,
                       threshold=site.no_data_hours, message=msg, opened=opened, reason=reason)
        if w != "none":
            events.append(f"no_data:{sid}:{w}")
    return events


def _replaced(s, site: Site) -> set:
    """Sensors replaced by another (rail site events): silent from the replacement on, expected."""
    from ._events import replaced_ids

    return replaced_ids(s, site)


def _silent_loggers(s, site: Site, ref: int, limit: float) -> dict:
    """{logger pk: (name, hours silent, its newest reading's time, True)} of the site's active loggers none of whose
    batches arrived for ``limit`` s before ``ref``: by the batches' arrival (clock="wall", ``ref`` the wall clock), or
    by their newest reading (clock="data", ``ref`` the site's newest reading), as the sensor rule measures. A logger is
    watched here from its first batch; one never heard from is :func:`_unheard_loggers`'."""
    # one index seek per logger (ix_batches_logger_*); a GROUP BY over the batches scanned a year's 157 000 of
    # them on every pass (51 ms, session 36)
    newest = {c: select(func.max(c)).where(Batch.logger_id == Logger.id).scalar_subquery()
              for c in (Batch.received_ts, Batch.last_reading_ts)}
    rows = s.execute(select(Logger.id, Logger.name, *newest.values())
                     .where(Logger.site_id == site.id, Logger.active.is_(True))).all()
    out = {}
    for pk, name, received, newest in rows:
        t = newest if site.clock == "data" else received
        if t is not None and ref - t > limit:
            out[pk] = (name, (ref - t) / 3600.0, newest, True)
    return out


def _unheard_loggers(s, site: Site, wall: int, limit: float) -> dict:
    """{logger pk: (name, hours since registered, None, False)} of the site's active loggers that never sent a batch
    and were registered, or last given a new key, more than ``limit`` s before the wall clock ``wall``: the grace
    period of a new sensor (:func:`evaluate_no_data`), on either clock. The registration is the audit trail's
    ``logger`` ``create`` or ``rotate`` entry (the logger rows carry no time of their own); without one, the site's
    creation."""
    never = ~select(Batch.id).where(Batch.logger_id == Logger.id).exists()
    rows = s.execute(select(Logger.id, Logger.name).where(Logger.site_id == site.id, Logger.active.is_(True),
                                                          never)).all()
    out = {}
    for pk, name in rows:
        since = s.scalar(select(func.max(Audit.ts)).where(Audit.site_id == site.id, Audit.entity == "logger",
                                                          Audit.key == name, Audit.action.in_(("create", "rotate"))))
        since = site.created_ts if since is None else since
        if since is not None and wall - since > limit:
            out[pk] = (name, (wall - since) / 3600.0, None, False)
    return out


def _logger_alarms(s, site: Site, silent: dict, covered: dict, opened: dict) -> list[str]:
    """Raise, refresh or clear the per-logger no-data alarms (quantity "logger", subject the logger's name): of the
    ``silent`` loggers (:func:`_silent_loggers`, :func:`_unheard_loggers`)."""
    events = []
    names = {name for name, _, _, _ in silent.values()}
    for a in list(opened.values()):
        if a.quantity == "logger" and a.subject not in names:
            active = s.scalar(select(Logger.active).where(Logger.site_id == site.id, Logger.name == a.subject))
            w = transition(s, site, "logger", a.subject, None, opened=opened,
                           reason=None if active else "the logger's key was revoked")
            events.append(f"logger:{a.subject}:{w}")
    for name, hours, _, heard in sorted(silent.values()):
        mine = sorted(sid for sid, lg in covered.items() if name in lg.split(", "))
        said = (f"; its {len(mine)} sensor(s) {', '.join(mine[:8])}{', ...' if len(mine) > 8 else ''} are silent "
                "with it (no alarm of their own)") if mine else ""
        never = "" if heard else ", nothing received since it was registered"
        msg = (f"no data from logger {name} for {hours:.1f} h (limit {site.no_data_hours:g} h{never}){said}: check "
               f"the logger's power and connection{'' if heard else ', and that it was given its API key'}")
        w = transition(s, site, "logger", name, "alert", value=hours, threshold=site.no_data_hours, message=msg,
                       opened=opened)
        if w != "none":
            events.append(f"logger:{name}:{w}")
    return events


def acknowledge(db: Database, alarm_id: int, user: str, comment: str = "", *, site: str | None = None) -> dict:
    """Record who acknowledged an open alarm, when, and why (an alarm is acknowledged once)."""
    from ...errors import InputError
    from ._core import NotFound, _audit

    with db.write() as s:
        a = s.get(Alarm, int(alarm_id))
        st = None if a is None else s.get(Site, a.site_id)
        if a is None or (site is not None and st.name != site):
            raise NotFound(f"unknown alarm {alarm_id!r}.")
        if a.state != "raised":
            raise InputError(f"alarm {alarm_id} is {a.state}; only a raised alarm can be acknowledged.")
        a.state, a.ack_by, a.ack_ts, a.ack_comment = ("acknowledged", user, now_ts(),
                                                      str(comment).replace("\x00", "")[:2000])
        _audit(s, user, a.site_id, "alarm", str(a.id), "acknowledge", {"state": "raised"},
               {"state": "acknowledged", "comment": a.ack_comment})
        return alarm_dict(a)


def alarm_dict(a: Alarm) -> dict:
    return {"id": a.id, "quantity": a.quantity, "subject": a.subject, "level": a.level, "state": a.state,
            "value": a.value, "threshold": a.threshold, "day": a.day, "message": a.message, "raised_ts": a.raised_ts,
            "ack_by": a.ack_by, "ack_ts": a.ack_ts, "ack_comment": a.ack_comment, "cleared_ts": a.cleared_ts,
            "cleared_reason": a.cleared_reason}


ALARM_STATES = ("raised", "acknowledged", "cleared")


def list_alarms(db: Database, site: str, *, open_only: bool = False, limit: int = 500,
                state: str | None = None) -> list[dict]:
    """The site's alarms, newest first (``open_only``: not cleared; ``state``: only that state)."""
    from ...errors import InputError
    from ._core import _site

    if state is not None and state not in ALARM_STATES:
        raise InputError(f"state must be one of {list(ALARM_STATES)}; got {state!r}.")
    with db.read() as s:
        st = _site(s, site)
        q = select(Alarm).where(Alarm.site_id == st.id)
        if open_only:
            q = q.where(Alarm.state != "cleared")
        if state is not None:
            q = q.where(Alarm.state == state)
        return [alarm_dict(a) for a in s.scalars(q.order_by(Alarm.id.desc()).limit(limit))]


@dataclass
class Notifier:
    """How notifications leave: SMTP server for "smtp" channels, timeouts."""

    smtp_host: str = "127.0.0.1"
    smtp_port: int = 25
    smtp_from: str = "longprofile@localhost"
    timeout_s: float = 10.0

    def send(self, row: Outbox):
        payload = json.loads(row.payload_json)
        if row.kind == "webhook":
            req = urllib.request.Request(row.target, data=json.dumps(payload).encode(), method="POST",
                                         headers={"Content-Type": "application/json", "Idempotency-Key": row.key})
            with urllib.request.urlopen(req, timeout=self.timeout_s) as r:  # noqa: S310 (configured by an admin)
                if not 200 <= r.status < 300:
                    raise OSError(f"webhook answered {r.status}")
        elif row.kind == "smtp":
            msg = EmailMessage()
            msg["From"], msg["To"] = self.smtp_from, row.target
            msg["Subject"] = (f"[{payload['site']}] {payload['level']} {payload['quantity']} {payload['event']}"
                              f" ({payload['subject']})")
            msg["Message-ID"] = f"<{row.key}@longprofile>"
            msg.set_content(json.dumps(payload, indent=2))
            with smtplib.SMTP(self.smtp_host, self.smtp_port, timeout=self.timeout_s) as smtp:
                smtp.send_message(msg)
        else:
            raise OSError(f"unknown channel kind {row.kind!r}")


def deliver_outbox(db: Database, notifier: Notifier, *, limit: int = 100, now: int | None = None,
                   _after_send=None) -> dict:
    """Send pending notifications in order; a failure is retried later with back-off (nothing is dropped)."""
    now = now_ts() if now is None else int(now)
    with db.read() as s:
        pending = list(s.scalars(select(Outbox).where(Outbox.sent_ts.is_(None), Outbox.next_try_ts <= now)
                                 .order_by(Outbox.id).limit(limit)))
    sent = failed = 0
    for row in pending:
        try:
            notifier.send(row)
        except Exception as exc:  # noqa: BLE001 - any delivery failure is recorded and retried
            with db.write() as s:
                att = row.attempts + 1
                s.execute(update(Outbox).where(Outbox.id == row.id).values(
                    attempts=att, last_error=f"{type(exc).__name__}: {exc}"[:500],
                    next_try_ts=now_ts() + min(5 * 2 ** att, 3600)))
            failed += 1
            continue
        if _after_send is not None:
            _after_send(row)  # tests: simulate a crash between sending and marking
        with db.write() as s:
            s.execute(update(Outbox).where(Outbox.id == row.id).values(sent_ts=now_ts(), attempts=row.attempts + 1))
        sent += 1
    return {"sent": sent, "failed": failed}
