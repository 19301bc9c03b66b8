"""Findings of the user-guide writers (session 37), fixed in session 38: no "no data" alarm for a sensor the user
excluded (an open one withdrawn); a logger registered but never heard from raises a logger alarm after the grace
period of a new sensor; ``rail site audit`` shows the thresholds it records in mm as well as in m."""

from __future__ import annotations

import json

import pytest
import typer
from sqlalchemy import select
from typer.testing import CliRunner

from longprofile.cli._rail_serve import register
from longprofile.rail.service import _core
from longprofile.rail.service._alarms import EXCLUDED_REASON, evaluate_no_data, list_alarms, transition
from longprofile.rail.service._db import Outbox, Site, now_ts

from .conftest import synthetic

NOW = 2_000_000_000
HOUR = 3600


def _pass(db, name="mitt", now=None):
    with db.write() as s:
        return evaluate_no_data(s, s.scalar(select(Site).where(Site.name == name)), now=now)


def _open(db, name="mitt", quantity=None):
    return [a for a in list_alarms(db, name, open_only=True) if quantity is None or a["quantity"] == quantity]


def _ingest(db, rows, name="mitt", logger_id=None):
    for i in range(0, len(rows), 4000):
        _core.ingest(db, name, rows.iloc[i:i + 4000].to_dict("records"), logger_id=logger_id, now=NOW)


def test_a_sensor_the_user_excluded_raises_no_no_data_alarm_and_an_open_one_is_withdrawn(site):
    """S20 never reports, S30 stops after two days: both raise a no-data alarm; excluded in the site's settings, the
    open ones are withdrawn (notified so, with the reason) and a later pass raises none."""
    db, _, r = site
    _core.add_channel(db, "adm", "mitt", "webhook", "http://127.0.0.1:9/hook")
    _ingest(db, r[(r.sensor_id != "S20") & ((r.sensor_id != "S30") | (r.timestamp.str[:10] <= "2019-11-20"))])
    _pass(db, now=now_ts() + 7 * HOUR)  # past S20's grace period
    assert {"S20", "S30"} <= {a["subject"] for a in _open(db, quantity="no_data")}
    _core.update_site(db, "adm", "mitt", settings={"exclude": ["S20", "S30"]})
    events = _pass(db, now=now_ts() + 8 * HOUR)
    assert not {"S20", "S30"} & {a["subject"] for a in _open(db, quantity="no_data")}, events
    ended = [a for a in list_alarms(db, "mitt") if a["quantity"] == "no_data" and a["subject"] in ("S20", "S30")]
    assert len(ended) == 2 and all(a["cleared_reason"] == EXCLUDED_REASON for a in ended)
    with db.read() as s:
        notices = [(o.event, json.loads(o.payload_json)) for o in s.scalars(select(Outbox))]
    assert {p["subject"] for e, p in notices if e == "withdrawn" and p["reason"] == EXCLUDED_REASON} == {"S20", "S30"}
    _pass(db, now=now_ts() + 30 * HOUR)
    assert len([a for a in list_alarms(db, "mitt") if a["subject"] in ("S20", "S30")
                and a["quantity"] == "no_data"]) == 2  # nothing new


@pytest.mark.parametrize("clock", ["wall", "data"])
def test_a_logger_that_never_sent_anything_raises_one_logger_alarm_after_the_grace_period(db, clock):
    """A site set up with its sensors and a logger that never connected: within ``no_data_hours`` of the logger's
    registration nothing; after it one "logger" alert (the wording of a logger that stopped, saying it never sent
    anything) that names the silent sensors instead of one alarm per sensor; cleared when the logger sends
    (the sensors' own rule applies again then)."""
    syn, r = synthetic()
    _core.create_site(db, "t", "new", clock=clock)
    _core.put_sensors(db, "t", "new", syn.sensors.to_dict("records"))
    _core.put_survey(db, "t", "new", syn.survey.to_dict("records"))
    key = _core.add_logger(db, "t", "new", "gw-1")
    assert not _pass(db, "new", now=now_ts() + 60)
    assert not _open(db, "new")
    _pass(db, "new", now=now_ts() + 7 * HOUR)
    (a,) = _open(db, "new")
    assert (a["quantity"], a["subject"], a["level"]) == ("logger", "gw-1", "alert")
    assert a["message"].startswith("no data from logger gw-1 for 7.0 h (limit 6 h, nothing received since it was "
                                   "registered)")
    assert "58 sensor(s)" in a["message"]
    _ingest(db, r, "new", logger_id=_core.authenticate_logger(db, key)[0])
    _pass(db, "new", now=now_ts() + 60)
    assert not _open(db, "new", "logger")
    if clock == "data":  # (on clock=wall the replayed 2019 readings are old: the sensors' own rule says so)
        assert not _open(db, "new", "no_data")


def test_a_site_without_logger_that_never_received_a_reading_alarms_on_a_data_clock_too(db):
    """No logger registered (readings to be loaded by hand) and nothing loaded: the sensors' own no-data alarms after
    their grace period, on clock=data as on clock=wall (on clock=data nothing was raised before)."""
    syn, _ = synthetic()
    _core.create_site(db, "t", "new", clock="data")
    _core.put_sensors(db, "t", "new", syn.sensors.iloc[:5].to_dict("records"))
    _pass(db, "new", now=now_ts() + 7 * HOUR)
    alarms = _open(db, "new")
    assert len(alarms) == 5 and {a["quantity"] for a in alarms} == {"no_data"}
    assert alarms[0]["message"].startswith("no data from sensor")


@pytest.fixture
def cli():
    app = typer.Typer()
    register(app)
    runner = CliRunner()
    return lambda *args: runner.invoke(app, list(args), catch_exceptions=True)


def test_the_audit_trail_shows_thresholds_in_mm(cli, tmp_path):
    url = f"sqlite:///{tmp_path}/t.db"
    assert cli("site", "create", "s1", "--db", url).exit_code == 0
    for args in (("settlement", "alert", "10"), ("rate", "action", "2.3"), ("settlement", "alert", "12"),
                 ("settlement", "alert")):
        assert cli("site", "threshold", "s1", *args, "--db", url).exit_code == 0
    res = cli("site", "audit", "s1", "--db", url)
    assert res.exit_code == 0, res.output
    rows = [(e["key"], e["old_mm"], e["new_mm"], e["unit_mm"]) for e in json.loads(res.stdout)
            if e["entity"] == "threshold"]
    assert rows == [("settlement.alert", 12.0, None, "mm"), ("settlement.alert", 10.0, 12.0, "mm"),
                    ("rate.action", None, 2.3, "mm/day"), ("settlement.alert", None, 10.0, "mm")]
    from longprofile.rail.service._db import Database

    db = Database(url)
    try:  # an open settlement alarm follows a changed threshold: the update's thresholds in mm too
        with db.write() as s:
            st = s.scalar(select(Site).where(Site.name == "s1"))
            transition(s, st, "settlement", "site", "alert", value=-0.0125, threshold=0.012, day="2019-11-20")
            transition(s, st, "settlement", "site", "alert", value=-0.0125, threshold=0.01, day="2019-11-21")
    finally:
        db.dispose()
    (upd,) = [e for e in json.loads(cli("site", "audit", "s1", "--db", url).stdout) if e["entity"] == "alarm"]
    assert (upd["old"]["threshold_mm"], upd["new"]["threshold_mm"], upd["unit_mm"]) == (12.0, 10.0, "mm")
    assert upd["old"]["threshold"] == 0.012  # as stored, in m
