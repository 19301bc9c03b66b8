"""Declared re-installations and replacements of a site's sensors (the events table of ``rail settle --events``;
docs/rail-service.md, "Re-installed and replaced sensors"): stored, audited, and given to every recompute as
``rail settle --events`` gives them to ``longprofile.rail.site_with_events`` and ``estimate_settlement``."""

from __future__ import annotations

import pandas as pd
from sqlalchemy import select

from ...errors import InputError
from .. import apply_replacements, check_events
from ._db import Database, Sensor, SensorEvent, Site

__all__ = ["put_events", "delete_event", "get_events", "events_of", "events_table", "replacing_ids", "replaced_ids"]

#: Columns of the events table (``rail settle --events``).
EVENT_COLUMNS = ("sensor_id", "date", "event", "new_id")


def _stored(s, site: Site) -> dict:
    """{(sensor_id, date): (event, new_id)} of the site's stored events."""
    return {(e.sensor_id, e.date): (e.event, e.new_id) for e in
            s.scalars(select(SensorEvent).where(SensorEvent.site_id == site.id)
                      .order_by(SensorEvent.date, SensorEvent.sensor_id))}


def events_table(s, site: Site, active=None):
    """The site's events as the table ``rail settle --events`` reads (None when there are none); with ``active``
    (sensor ids), only the events of those sensors (an inactive sensor has no series to re-baseline)."""
    rows = [(sid, d, ev, new) for (sid, d), (ev, new) in _stored(s, site).items() if active is None or sid in active]
    return check_events(pd.DataFrame(rows, columns=list(EVENT_COLUMNS))) if rows else None


def replacing_ids(s, site: Site) -> set:
    """Ids of the sensors that continue another's series (``new_id`` of a replacement): they share its station."""
    return {new for ev, new in _stored(s, site).values() if ev == "replaced_by"}


def replaced_ids(s, site: Site) -> set:
    """Ids of the sensors replaced by another (their readings stop at the replacement: no "no data" alarm)."""
    return {sid for (sid, _), (ev, _) in _stored(s, site).items() if ev == "replaced_by"}


def _checked(s, site: Site, rows) -> pd.DataFrame:
    """The events ``rows`` checked as ``rail settle --events`` checks them (``check_events`` with the site's sensors,
    a replacement by the sensor itself refused by ``apply_replacements``), with their dates as ``YYYY-MM-DD``."""
    from ._core import _refuse_control_times

    rows = list(rows)
    if not rows:
        raise InputError(f"no events given (columns: {', '.join(EVENT_COLUMNS)}).")
    for i, r in enumerate(rows):
        extra = sorted(map(str, set(r) - set(EVENT_COLUMNS))) if isinstance(r, dict) else ["?"]
        if extra:
            raise InputError(f"event row {i}: unknown column(s) {extra[:3]}; expected {list(EVENT_COLUMNS)}.")
    table = pd.DataFrame(rows).astype(object)
    if "date" in table:
        table["date"] = [v if v is None or isinstance(v, str) else str(v) for v in table["date"]]
        _refuse_control_times(table["date"])
    ids = list(s.scalars(select(Sensor.sensor_id).where(Sensor.site_id == site.id)))
    ev = check_events(table, ids)
    empty = pd.DataFrame({"timestamp": pd.Series(dtype=object), "sensor_id": pd.Series(dtype=object)})
    apply_replacements(pd.DataFrame({"sensor_id": ids}), empty, ev)  # its refusals, nothing re-implemented
    if ev[["sensor_id", "date"]].duplicated().any():
        k = int(ev[["sensor_id", "date"]].duplicated().to_numpy().nonzero()[0][0])
        raise InputError(f"events: sensor {ev['sensor_id'][k]} has two events on {ev['date'][k]:%Y-%m-%d}; keep one.")
    return ev.assign(date=ev["date"].dt.strftime("%Y-%m-%d"))


def _changed(site: Site) -> None:
    """An event changes the estimate from its date on but no daily statistic (the day cache): the next run recomputes
    the settlement, reading the cache as it is (as for a control survey)."""
    site.data_version = (site.data_version or 0) + 1
    if site.dirty_from_ts is None:
        site.dirty_from_ts = site.baseline_start_ts or 0


def put_events(db: Database, actor: str, name: str, rows) -> dict:
    """Store declared events (rows of the events table: sensor_id, date, event, new_id): each (sensor, date) in
    ``rows`` is created or replaced, the others kept; one audit entry per change. Returns {"events": n,
    "changed": [sensor_id@date, ...]}."""
    from ._core import _audit, _check_active_stations, _site

    with db.write() as s:
        site = _site(s, name)
        ev = _checked(s, site, rows)
        have = {(e.sensor_id, e.date): e for e in s.scalars(select(SensorEvent).where(SensorEvent.site_id == site.id))}
        changed = []
        for r in ev.itertuples(index=False):
            new = {"event": r.event, "new_id": r.new_id}
            cur = have.get((r.sensor_id, r.date))
            old = None if cur is None else {"event": cur.event, "new_id": cur.new_id}
            if old == new:
                continue
            if cur is None:
                s.add(SensorEvent(site_id=site.id, sensor_id=r.sensor_id, date=r.date, **new))
            else:
                cur.event, cur.new_id = r.event, r.new_id
            _audit(s, actor, site.id, "event", f"{r.sensor_id}@{r.date}", "create" if cur is None else "replace",
                   old, new)
            changed.append(f"{r.sensor_id}@{r.date}")
        if changed:
            s.flush()
            _check_active_stations(s, site)  # a replacement turned into a re-installation: two sensors, one station
            _changed(site)
    return {"events": len(ev), "changed": changed}


def delete_event(db: Database, actor: str, name: str, sensor_id: str, date: str) -> dict:
    """Remove the event of ``sensor_id`` on ``date`` (``YYYY-MM-DD``); audited."""
    from ._core import NotFound, _audit, _check_active_stations, _site

    with db.write() as s:
        site = _site(s, name)
        cur = s.scalar(select(SensorEvent).where(SensorEvent.site_id == site.id, SensorEvent.sensor_id == sensor_id,
                                                 SensorEvent.date == date))
        if cur is None:
            raise NotFound(f"site {name!r} has no event of sensor {str(sensor_id)[:64]!r} on {str(date)[:40]!r}; "
                           "list them with rail site events SITE.")
        _audit(s, actor, site.id, "event", f"{sensor_id}@{date}", "delete", {"event": cur.event,
                                                                             "new_id": cur.new_id}, None)
        s.delete(cur)
        s.flush()
        _check_active_stations(s, site)  # the replacing sensor would stand alone at the replaced one's station
        _changed(site)
    return {"deleted": f"{sensor_id}@{date}"}


def events_of(s, site: Site, sensor_id: str | None = None) -> list[dict]:
    """The site's declared events, by date: [{sensor_id, date, event, new_id}]; with ``sensor_id``, those of that
    sensor (its re-installations, its replacement, and the replacement it continues)."""
    return [{"sensor_id": sid, "date": d, "event": ev, "new_id": new}
            for (sid, d), (ev, new) in _stored(s, site).items() if sensor_id is None or sensor_id in (sid, new)]


def get_events(db: Database, name: str) -> list[dict]:
    """The site's declared events, by date: [{sensor_id, date, event, new_id}]."""
    from ._core import _site

    with db.read() as s:
        return events_of(s, _site(s, name))
