"""Papercuts found while writing the rail user guide (session 37): a sensor the user excluded is not a health alarm;
threshold values printed with their unit; a password from a pipe without getpass's warning; the demo's log says
escalated / de-escalated as the API does; a frozen sensor is a health alarm at action level, as a dead one."""

from __future__ import annotations

import base64
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import typer
from fastapi.testclient import TestClient
from sqlalchemy import select
from typer.testing import CliRunner

from longprofile.cli._rail_serve import register
from longprofile.errors import InputError
from longprofile.rail.service import _core, create_app
from longprofile.rail.service._alarms import health_level, list_alarms, transition
from longprofile.rail.service._auth import verify_password
from longprofile.rail.service._db import Database, HealthRow, Outbox, Site, User
from longprofile.rail.service._recompute import recompute
from longprofile.rail.service._serve import alarm_line

NOW = 2_000_000_000


def _health_alarms(db, sid):
    return [a for a in list_alarms(db, "mitt") if a["quantity"] == "health" and a["subject"] == sid]


def test_a_sensor_the_user_excluded_raises_no_health_alarm(site):
    """S13 is the preset's dead sensor: an action alarm; excluded in the site's settings it is "excluded", its alarm
    withdrawn (notified so), and no new one is raised."""
    db, _, r = site
    _core.add_channel(db, "adm", "mitt", "webhook", "http://127.0.0.1:9/hook")
    _core.ingest(db, "mitt", r.to_dict("records"), now=NOW)
    assert recompute(db, "mitt")["status"] == "ok"
    (a,) = _health_alarms(db, "S13")
    assert a["level"] == "action" and a["state"] != "cleared"
    _core.update_site(db, "adm", "mitt", settings={"exclude": ["S13"]})
    out = recompute(db, "mitt")
    assert out["status"] == "ok"
    (a,) = _health_alarms(db, "S13")  # the old one, ended; none raised
    assert a["state"] == "cleared" and a["cleared_reason"].startswith("excluded by the user")
    with db.read() as s:
        status = s.scalar(select(HealthRow.status).where(HealthRow.run_id == out["run_id"],
                                                         HealthRow.sensor_id == "S13"))
        events = [(o.event, json.loads(o.payload_json)["subject"]) for o in s.scalars(select(Outbox))]
    assert status == "excluded"
    assert ("withdrawn", "S13") in events
    _core.ingest(db, "mitt", r.iloc[:50].to_dict("records"), now=NOW)  # another run: still nothing for S13
    recompute(db, "mitt", force=True, actor="t")
    assert len(_health_alarms(db, "S13")) == 1


def test_health_alarm_levels():
    assert health_level("ok") is None and health_level("excluded") is None
    assert health_level("late") == "alert"
    assert {health_level(s) for s in ("dead", "frozen", "reversed", "detached", "drifting", "improbable")} == {"action"}


@pytest.fixture
def cli():
    app = typer.Typer()
    register(app)
    runner = CliRunner()
    return lambda *args, input=None: runner.invoke(app, list(args), input=input, catch_exceptions=True)


def test_threshold_values_are_printed_with_their_unit(cli, tmp_path):
    url = f"sqlite:///{tmp_path}/t.db"
    assert cli("site", "create", "s1", "--db", url).exit_code == 0
    res = cli("site", "threshold", "s1", "rate", "alert", "2.3", "--db", url)
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout) == {"quantity": "rate", "level": "alert", "value": 0.0023, "unit": "m/day",
                                      "value_mm": 2.3, "unit_mm": "mm/day"}
    (tmp_path / "thr.csv").write_text("quantity,level,value_mm\nsettlement,alert,10\nsettlement,action,15\n"
                                      "twist,alert,4\nrate,action,3\n")
    res = cli("site", "thresholds", "s1", "--file", str(tmp_path / "thr.csv"), "--db", url)
    assert res.exit_code == 0, res.output
    rows = json.loads(res.stdout)
    assert [(r["quantity"], r["level"], r["value_mm"], r["unit_mm"]) for r in rows] == [
        ("settlement", "alert", 10.0, "mm"), ("settlement", "action", 15.0, "mm"), ("rate", "action", 3.0, "mm/day"),
        ("twist", "alert", 4.0, "mm")]
    assert all(r["value"] == pytest.approx(1e-3 * r["value_mm"], rel=1e-12) for r in rows)
    show = json.loads(cli("site", "show", "s1", "--db", url).stdout)
    assert show["threshold_rows"] == rows
    assert show["thresholds"] == {"settlement.alert": 0.01, "settlement.action": 0.015, "rate.action": 0.003,
                                  "twist.alert": 0.004}  # m, as before: API clients keep reading it


def test_the_api_keeps_the_value_in_m_and_adds_the_mm(db):
    _core.add_user(db, "t", "eng", "eng-password", "engineer")
    _core.create_site(db, "t", "s1")
    client = TestClient(create_app(db, background=False))
    h = {"Authorization": "Basic " + base64.b64encode(b"eng:eng-password").decode()}
    put = client.put("/api/v1/sites/s1/thresholds/settlement/alert", json={"value": 0.004}, headers=h)
    assert put.status_code == 200
    body = put.json()
    assert body["value"] == 0.004 and body["unit"] == "m" and body["value_mm"] == 4.0 and body["unit_mm"] == "mm"
    got = client.get("/api/v1/sites/s1", headers=h).json()
    assert got["thresholds"] == {"settlement.alert": 0.004}
    assert got["threshold_rows"] == [body]


def _longprofile():
    return str(Path(sys.executable).parent / "longprofile")


def test_a_password_from_a_pipe_is_read_without_getpass(tmp_path):
    """``echo pw | rail site user alice``: no GetPassWarning, no "Password input may be echoed"; the first line of
    stdin is the password (the person can log in with it). ``start_new_session``: no controlling terminal, so getpass
    could not have read /dev/tty instead."""
    url = f"sqlite:///{tmp_path}/u.db"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    run = subprocess.run([_longprofile(), "rail", "site", "user", "alice", "--role", "engineer", "--db", url],
                         input="alice-password\nignored\n", capture_output=True, text=True, env=env, timeout=120,
                         start_new_session=True)
    assert run.returncode == 0, run.stderr
    assert "GetPassWarning" not in run.stderr and "echoed" not in run.stderr
    assert "password:" not in run.stdout.lower()  # no prompt
    assert json.loads(run.stdout)["created"] is True
    db = Database(url)
    try:
        with db.read() as s:
            stored = s.scalar(select(User.password_hash).where(User.username == "alice"))
    finally:
        db.dispose()
    assert verify_password("alice-password", stored)


def test_an_empty_stdin_is_one_clear_error(cli, tmp_path):
    url = f"sqlite:///{tmp_path}/u.db"
    res = cli("site", "user", "bob", "--db", url, input="")
    assert isinstance(res.exception, InputError) and "no password" in str(res.exception)


def test_the_demo_log_says_escalated_and_de_escalated_as_the_api_does(db):
    """The replay's lines come from the alarms the API lists: a level change is the old alarm "escalated" (or
    "de-escalated") to the new level (its cleared_reason), not "cleared"; back within thresholds is "cleared"."""
    _core.create_site(db, "t", "demo-site")
    with db.write() as s:
        site = s.scalar(select(Site).where(Site.name == "demo-site"))
        for lv in ("alert", "action", "alert", None):
            transition(s, site, "rate", "site", lv, value=0.003, threshold=0.002, day="2019-11-20",
                       message="rate ..." if lv else "")
        transition(s, site, "settlement", "site", "alert", message="settlement ...")
        transition(s, site, "settlement", "site", None, reason="the alert threshold of settlement was removed")
    lines = [alarm_line(a) for a in reversed(list_alarms(db, "demo-site"))]
    assert lines == ["escalated rate (site) from alert to action", "de-escalated rate (site) from action to alert",
                     "cleared alert rate (site)",
                     "withdrawn alert settlement (site): the alert threshold of settlement was removed"]
    raised = dict(list_alarms(db, "demo-site")[0], state="raised")
    assert alarm_line(raised) == "raised alert settlement (site) settlement ..."
