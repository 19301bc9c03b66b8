"""The operator's probe of 2026-12-07 (session 36): sensor replacement, deactivation, stale alarms, escalation
notices, sensors outside the survey, sensors files, failed deliveries, channels and users."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sqlalchemy import select

from longprofile.errors import InputError
from longprofile.rail.service import _core
from longprofile.rail.service._alarms import list_alarms
from longprofile.rail.service._db import Outbox, ResultRow, Sensor, Site
from longprofile.rail.service._recompute import recompute

NOW = 2_000_000_000


def _ingest(db, r, upto_day=None, site="mitt"):
    part = r if upto_day is None else r[r["timestamp"].str[:10] <= upto_day]
    for i in range(0, len(part), 4000):
        _core.ingest(db, site, part.iloc[i:i + 4000].to_dict("records"), now=NOW)


def _x(db, sensor_id):
    return next(x["x_m"] for x in _core.get_site(db, "mitt")["sensors"] if x["sensor_id"] == sensor_id)


def _open(db, quantity=None, subject=None):
    return [a for a in list_alarms(db, "mitt", open_only=True)
            if (quantity is None or a["quantity"] == quantity) and (subject is None or a["subject"] == subject)]


def _outbox(db):
    with db.read() as s:
        return [(o.event, json.loads(o.payload_json)) for o in s.scalars(select(Outbox).order_by(Outbox.id))]


def test_a_sensor_is_replaced_at_its_station(site):
    db, _, r = site
    _ingest(db, r, "2019-11-21")
    x37, x41 = (_x(db, sid) for sid in ("S37", "S41"))
    with pytest.raises(InputError, match="both be active at station"):
        _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "S37N", "x_m": x37}])
    out = _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "S37", "x_m": x37, "active": False},
                                                {"sensor_id": "S37N", "x_m": x37}])
    assert out["added"] == 1 and out["changed"] == 1
    # in two requests: the old one made inactive first, then the new one at its station
    _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "S41", "x_m": x41, "active": False}])
    _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "S41N", "x_m": x41}])
    new = r[(r.sensor_id == "S37") & (r.timestamp.str[:10] >= "2019-11-22")].assign(sensor_id="S37N")
    res = _core.ingest(db, "mitt", new.to_dict("records"), now=NOW)
    assert res.counts["accepted"] == len(new) and res.counts["rejected"] == 0
    # reactivating the old sensor while the new one holds the station is refused
    with pytest.raises(InputError, match="both be active"):
        _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "S37", "x_m": x37, "active": True}])
    _ingest(db, r[r.sensor_id != "S37"])
    out = recompute(db, "mitt")
    assert out["status"] == "ok", out["message"]  # the settlement stays computed (validate_site: active sensors)


def test_deactivating_a_sensor_closes_its_open_alarms(site):
    db, _, r = site
    _ingest(db, r[r.sensor_id != "S20"])
    _core.add_channel(db, "adm", "mitt", "webhook", "http://127.0.0.1:9/hook")
    assert recompute(db, "mitt")["status"] == "ok"
    assert _open(db, "no_data", "S20") or _open(db, "health", "S20")
    x = _x(db, "S20")
    out = _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "S20", "x_m": x, "active": False}])
    assert out["alarms_closed"] >= 1
    assert not _open(db, subject="S20")
    closed = [a for a in list_alarms(db, "mitt") if a["subject"] == "S20"]
    assert closed and all(a["cleared_reason"] == "sensor deactivated" for a in closed)
    assert any(e == "withdrawn" and p["reason"] == "sensor deactivated" for e, p in _outbox(db))
    assert any(a["entity"] == "alarm" and a["action"] == "close" and a["actor"] == "eng"
               for a in _core.audit_trail(db, "mitt"))
    assert recompute(db, "mitt", force=True)["status"] == "ok"
    assert not _open(db, subject="S20")


def test_open_alarms_of_a_sensor_deactivated_before_are_closed_by_the_next_pass(site):
    from longprofile.rail.service._alarms import evaluate_no_data

    db, _, r = site
    _ingest(db, r[r.sensor_id != "S20"])
    assert recompute(db, "mitt")["status"] == "ok"
    assert _open(db, subject="S20")
    with db.write() as s:  # as a sensor deactivated by an older version
        s.scalar(select(Sensor).where(Sensor.sensor_id == "S20")).active = False
    with db.write() as s:
        evaluate_no_data(s, s.scalar(select(Site).where(Site.name == "mitt")))
    assert not _open(db, subject="S20")


def test_site_update_refuses_a_rename_in_one_line(site):
    db, _, _ = site
    with pytest.raises(InputError, match="cannot be renamed"):
        _core.update_site(db, "adm", "mitt", name="other")
    with pytest.raises(InputError, match="unknown site field"):
        _core.update_site(db, "adm", "mitt", colour="red")


def _site_with_settlement(db, r):
    """All days ingested, a webhook channel, and the largest |settlement| of the last day (m)."""
    _ingest(db, r)
    _core.add_channel(db, "adm", "mitt", "webhook", "http://127.0.0.1:9/hook")
    out = recompute(db, "mitt")
    assert out["status"] == "ok"
    with db.read() as s:
        last = s.scalar(select(ResultRow.day).where(ResultRow.run_id == out["run_id"]).order_by(ResultRow.day.desc()))
        dz = s.scalars(select(ResultRow.smoothed_dz_m).where(ResultRow.run_id == out["run_id"], ResultRow.day == last))
        return max(abs(v) for v in dz if v is not None)


def test_escalation_and_threshold_removal_are_notified_as_such(site):
    db, _, r = site
    big = _site_with_settlement(db, r)
    _core.set_threshold(db, "eng", "mitt", "settlement", "alert", big * 0.3)
    _core.set_threshold(db, "eng", "mitt", "settlement", "action", big * 10)
    recompute(db, "mitt")
    assert [a["level"] for a in _open(db, "settlement")] == ["alert"]
    _core.set_threshold(db, "eng", "mitt", "settlement", "action", big * 0.4)
    recompute(db, "mitt")
    assert [a["level"] for a in _open(db, "settlement")] == ["action"]
    ended = [(e, p) for e, p in _outbox(db) if p["quantity"] == "settlement" and e != "raised"]
    assert ended[-1][0] == "escalated" and ended[-1][1]["reason"] == "escalated to action"
    _core.set_threshold(db, "eng", "mitt", "settlement", "action", None)  # removed: back to alert
    recompute(db, "mitt")
    ended = [(e, p) for e, p in _outbox(db) if p["quantity"] == "settlement" and e != "raised"]
    assert ended[-1][0] == "withdrawn"
    assert "action threshold of settlement was removed" in ended[-1][1]["reason"]
    assert all(e != "cleared" for e, _ in ended)


def test_open_alarms_follow_the_latest_threshold(site):
    db, _, r = site
    big = _site_with_settlement(db, r)
    _core.set_threshold(db, "eng", "mitt", "settlement", "alert", big * 0.5)
    recompute(db, "mitt")
    (a,) = _open(db, "settlement")
    _core.set_threshold(db, "eng", "mitt", "settlement", "alert", big * 0.3)
    recompute(db, "mitt")
    (b,) = _open(db, "settlement")
    assert b["id"] == a["id"] and b["threshold"] == pytest.approx(big * 0.3)
    assert f"{1e3 * big * 0.3:.1f} mm" in b["message"]
    assert any(e["entity"] == "alarm" and e["action"] == "update" for e in _core.audit_trail(db, "mitt"))


def test_a_sensor_outside_the_survey_is_refused_and_a_failing_run_is_failed(site):
    db, _, r = site
    with pytest.raises(InputError, match="survey table covers x = 0..167.5 m"):
        _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "S99", "x_m": 200.0}])
    with db.write() as s:  # as added by an older version
        s.add(Sensor(site_id=s.scalar(select(Site.id).where(Site.name == "mitt")), sensor_id="S99", x_m=200.0,
                     active=True))
    out = recompute(db, "mitt")  # no readings yet: "waiting" before session 36
    assert out["status"] == "failed" and "survey table covers" in out["message"]
    _ingest(db, r)
    out = recompute(db, "mitt")
    assert out["status"] == "failed" and "survey table covers" in out["message"]


def test_a_sensors_file_with_a_duplicate_id_or_unknown_column_is_refused(site):
    db, _, _ = site
    with pytest.raises(InputError, match="'B' appears more than once"):
        _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "B", "x_m": 3.0}, {"sensor_id": "B", "x_m": 6.0}])
    with pytest.raises(InputError, match=r"unknown column\(s\) \['colour'\]"):
        _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "B", "x_m": 3.0, "colour": "red"}])
    assert "B" not in {x["sensor_id"] for x in _core.get_site(db, "mitt")["sensors"]}


def test_alarm_list_filters_on_state(site):
    db, _, r = site
    _ingest(db, r[r.sensor_id != "S20"])
    recompute(db, "mitt")
    _ingest(db, r[r.sensor_id == "S20"])
    recompute(db, "mitt")
    assert {a["state"] for a in list_alarms(db, "mitt", state="cleared")} == {"cleared"}
    assert all(a["state"] == "raised" for a in list_alarms(db, "mitt", state="raised"))
    with pytest.raises(InputError, match="state must be one of"):
        list_alarms(db, "mitt", state="bogus")


def _viewer(db):
    from fastapi.testclient import TestClient

    from longprofile.rail.service._web import create_app

    from .test_api import login

    _core.add_user(db, "t", "v1", "v1-password", "viewer")
    client = TestClient(create_app(db, background=False))
    login(client, "v1", "v1-password")
    return client


def test_sensor_page_shows_its_own_last_reading_and_inactive_state(site):
    db, _, r = site
    _ingest(db, r[(r.sensor_id != "S20") | (r.timestamp.str[:10] <= "2019-11-22")])
    assert recompute(db, "mitt")["status"] == "ok"
    _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "S30", "x_m": _x(db, "S30"), "active": False}])
    client = _viewer(db)
    page = client.get("/sites/mitt/sensors/S20").text
    last20 = r[(r.sensor_id == "S20") & (r.timestamp.str[:10] <= "2019-11-22")]["timestamp"].max()
    assert f'<b id="last-reading">{last20[:16].replace("T", " ")}' in page
    assert "no data from sensor S20" in page
    assert "inactive since" in client.get("/sites/mitt/sensors/S30").text
    site_page = client.get("/sites/mitt").text
    row = site_page[site_page.index('sensors/S20"'):][:400]
    assert "no data" in row


def test_failed_deliveries_are_shown_and_a_channel_can_be_removed(site):
    from fastapi.testclient import TestClient

    from longprofile.rail.service._alarms import Notifier, deliver_outbox
    from longprofile.rail.service._web import create_app

    from .test_api import login

    db, _, r = site
    _core.add_channel(db, "adm", "mitt", "webhook", "http://127.0.0.1:9/dead")
    _ingest(db, r[r.sensor_id != "S20"])
    recompute(db, "mitt")
    assert deliver_outbox(db, Notifier(timeout_s=0.5), now=NOW + 10**6)["failed"] >= 1
    (ch,) = _core.channel_status(db, "mitt")
    assert ch["failing"] >= 1 and ch["sent"] == 0 and ch["last_error"]
    _core.add_user(db, "t", "adm1", "adm1-password", "admin")
    client = TestClient(create_app(db, background=False))
    login(client, "adm1", "adm1-password")
    assert "failing" in client.get("/sites/mitt").text
    assert client.get("/api/v1/sites/mitt/channels").json()["channels"][0]["failing"] >= 1
    res = client.delete("/api/v1/sites/mitt/channels", params={"kind": "webhook", "target": "http://127.0.0.1:9/dead"},
                        headers={"x-csrf-token": "x"})
    if res.status_code == 403:  # a cookie session needs its CSRF token: use basic auth as an API client does
        res = TestClient(create_app(db, background=False)).delete(
            "/api/v1/sites/mitt/channels", params={"kind": "webhook", "target": "http://127.0.0.1:9/dead"},
            auth=("adm1", "adm1-password"))
    assert res.status_code == 200, res.text
    assert res.json()["removed"] and res.json()["undelivered_dropped"] >= 1
    assert _core.channel_status(db, "mitt") == []
    with db.read() as s:
        assert s.scalar(select(Outbox).where(Outbox.sent_ts.is_(None))) is None
    assert any(a["entity"] == "channel" and a["action"] == "delete" for a in _core.audit_trail(db, "mitt"))
    with pytest.raises(_core.NotFound, match="no webhook channel"):
        _core.remove_channel(db, "adm", "mitt", "webhook", "http://127.0.0.1:9/dead")


def test_user_changes_are_audited_and_a_password_is_reset_only_on_request(site):
    from longprofile.rail.service._auth import verify_password
    from longprofile.rail.service._db import User

    db, _, _ = site
    _core.add_user(db, "adm", "vera", "first-password", "viewer")
    with pytest.raises(InputError, match="already exists"):
        _core.add_user(db, "adm", "vera", "other-password", "viewer")
    out = _core.add_user(db, "adm", "vera", None, "engineer")  # a role change needs no password
    assert out["role"] == "engineer" and not out["password_changed"]
    with db.read() as s:
        assert verify_password("first-password", s.scalar(select(User).where(User.username == "vera")).password_hash)
    assert _core.add_user(db, "adm", "vera", "new-password1", "engineer", reset_password=True)["password_changed"]
    trail = _core.audit_trail(db, None, users=True)
    assert [(a["action"], a["new"]) for a in reversed(trail)] == [
        ("create", {"role": "viewer"}), ("update", {"role": "engineer", "active": True}),
        ("update", {"role": "engineer", "active": True, "password": "changed"})]
    assert "password" not in json.dumps([a["old"] for a in trail])
    assert not any("new-password1" in json.dumps(a) for a in trail)


def test_cli_user_threshold_and_missing_database(tmp_path):
    import typer
    from typer.testing import CliRunner

    from longprofile.cli._rail_serve import register

    app = typer.Typer()
    register(app)
    run = CliRunner()
    url = f"sqlite:///{tmp_path}/c.db"
    res = run.invoke(app, ["site", "list", "--db", f"sqlite:///{tmp_path}/nosuch.db"])
    assert res.exit_code != 0 and "no such database" in str(res.exception)
    assert not (tmp_path / "nosuch.db").exists()
    assert run.invoke(app, ["site", "create", "s1", "--db", url]).exit_code == 0
    assert run.invoke(app, ["site", "user", "vera", "--db", url], input="first-password\n").exit_code == 0
    res = run.invoke(app, ["site", "user", "vera", "--role", "engineer", "--db", url])  # no prompt: a role change
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["password_changed"] is False
    res = run.invoke(app, ["site", "user", "vera", "--role", "engineer", "--reset-password", "--db", url],
                     input="second-password\n")
    assert res.exit_code == 0 and '"password_changed": true' in res.stdout
    res = run.invoke(app, ["site", "audit", "--users", "--db", url])
    assert [a["action"] for a in json.loads(res.stdout)] == ["update", "update", "create"]
    res = run.invoke(app, ["site", "threshold", "s1", "settlement", "alert", "-5", "--db", url])
    assert res.exit_code != 0 and "No such option" not in res.output
    assert isinstance(res.exception, InputError)
    res = run.invoke(app, ["site", "update", "s1", "--set", "name=other", "--db", url])
    assert isinstance(res.exception, InputError) and "cannot be renamed" in str(res.exception)


def test_a_new_sensor_gets_the_no_data_grace_period_from_its_registration(site):
    from longprofile.rail.service._alarms import evaluate_no_data
    from longprofile.rail.service._db import now_ts

    db, _, r = site
    _ingest(db, r)
    _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "S37", "x_m": _x(db, "S37"), "active": False},
                                          {"sensor_id": "S37N", "x_m": _x(db, "S37")}])
    assert recompute(db, "mitt")["status"] == "ok"
    assert not _open(db, "no_data", "S37N")  # registered just now, nothing sent yet: within no_data_hours
    with db.write() as s:
        evaluate_no_data(s, s.scalar(select(Site).where(Site.name == "mitt")), now=now_ts() + 7 * 3600)
    assert _open(db, "no_data", "S37N")  # the grace period (6 h) is over


def test_a_viewer_reads_the_site_audit_trail_as_the_docs_say(site):
    db, _, _ = site
    client = _viewer(db)
    assert client.get("/api/v1/sites/mitt/audit").status_code == 200
    assert client.get("/api/v1/audit").status_code == 403  # the people's trail: admins


def test_a_sensor_added_to_extend_the_span_is_late_at_alert_level_not_dead(site):
    """An extension of the span mid-record: the new sensor was "dead" at action level for ever (the probe's item 2);
    it is "late" (rail health: no angle on the reference day), left out, at alert level."""
    db, _, r = site
    _ingest(db, r, "2019-11-21")
    x01, x02 = _x(db, "S01"), _x(db, "S02")
    _core.put_sensors(db, "eng", "mitt", [{"sensor_id": "S01B", "x_m": 0.5 * (x01 + x02)}])
    new = r[(r.sensor_id == "S01") & (r.timestamp.str[:10] >= "2019-11-22")].assign(sensor_id="S01B")
    _ingest(db, r[r.timestamp.str[:10] >= "2019-11-22"])
    _core.ingest(db, "mitt", new.to_dict("records"), now=NOW)
    out = recompute(db, "mitt")
    assert out["status"] == "ok", out["message"]
    (alarm,) = _open(db, "health", "S01B")
    assert alarm["level"] == "alert" and "S01B late" in alarm["message"] and "dead" not in alarm["message"]


def _survey_z(db, x):
    """The initial survey's altitude at ``x`` (linear between its points)."""
    pts = sorted((p["x_m"], p["z_m"]) for p in _core.get_site(db, "mitt")["survey"])
    return float(np.interp(x, [p[0] for p in pts], [p[1] for p in pts]))


def _controls_like_the_estimate(db, shift_m=0.0):
    """Control rows at five interior sensors on the last day: the estimate's change there plus ``shift_m``."""
    comp = _core.get_controls(db, "mitt")["comparison"]
    got = {(c["date"], c["x_m"]): c for c in comp}
    rows = _core.get_controls(db, "mitt")["controls"]
    return [{"date": c["date"], "x_m": c["x_m"],
             "z_m": c["z_m"] - got[(c["date"], c["x_m"])]["dz_control_m"] + got[(c["date"], c["x_m"])]["dz_estimate_m"]
             + shift_m} for c in rows]


def test_control_surveys_contradicting_the_estimate_raise_an_alert_cleared_when_they_agree(site):
    """Probe item 13: a 20 mm contradiction was a page warning only; now an alert (notified), cleared later."""
    db, _, r = site
    _site_with_settlement(db, r)
    day = r["timestamp"].str[:10].max()
    xs = [_x(db, f"S{i}") for i in (20, 25, 30, 35, 40)]
    z0 = [_survey_z(db, x) for x in xs]
    _core.put_controls(db, "eng", "mitt", [{"date": day, "x_m": x, "z_m": z} for x, z in zip(xs, z0)])
    assert recompute(db, "mitt")["status"] == "ok"  # the controls as levelled: no settlement at all
    rows = _controls_like_the_estimate(db, shift_m=0.020)  # 20 mm above the estimate everywhere
    _core.put_controls(db, "eng", "mitt", rows)
    out = recompute(db, "mitt")
    (a,) = _open(db, "controls")
    assert a["level"] == "alert" and "contradict" in a["message"] and "chi-squared" in a["message"], out
    assert "p = " in a["message"] and "largest difference +20.0 mm" in a["message"]
    assert any(e == "raised" and p["quantity"] == "controls" for e, p in _outbox(db))
    _core.put_controls(db, "eng", "mitt", _controls_like_the_estimate(db))
    out = recompute(db, "mitt")
    assert "controls:cleared" in out["events"] and not _open(db, "controls")


def _two_loggers(db, key):
    """logger-1 (the fixture's) and logger-2: their pks."""
    key2 = _core.add_logger(db, "t", "mitt", "logger-2")
    return _core.authenticate_logger(db, key)[0], _core.authenticate_logger(db, key2)[0]


def _ingest_as(db, rows, logger_pk):
    for i in range(0, len(rows), 4000):
        _core.ingest(db, "mitt", rows.iloc[i:i + 4000].to_dict("records"), logger_id=logger_pk, now=NOW)


def _no_data_pass(db, now=None):
    from longprofile.rail.service._alarms import evaluate_no_data

    with db.write() as s:
        return evaluate_no_data(s, s.scalar(select(Site).where(Site.name == "mitt")), now=now)


def test_a_silent_logger_raises_one_logger_alarm_on_a_data_clock_site(site):
    """Probe item 14: a logger silent for two days on a clock=data site raised nothing (its sensors' alarms were
    one per sensor on clock=wall); now one "logger" alarm naming its sensors, no sensor alarm, cleared on return."""
    db, key, r = site
    pk1, pk2 = _two_loggers(db, key)
    ids = sorted(r.sensor_id.unique())
    mine2 = r.sensor_id.isin(ids[:20])
    early = r.timestamp.str[:10] <= "2019-11-22"
    _ingest_as(db, r[~mine2], pk1)
    _ingest_as(db, r[mine2 & early], pk2)
    events = _no_data_pass(db)
    (a,) = _open(db, "logger")
    assert a["subject"] == "logger-2" and a["level"] == "alert" and "no data from logger logger-2" in a["message"]
    assert "20 sensor(s)" in a["message"] and ids[0] in a["message"]
    assert not _open(db, "no_data"), events  # its sensors are named in the logger's alarm, not alarmed one by one
    _ingest_as(db, r[mine2 & ~early], pk2)
    _no_data_pass(db)
    assert not _open(db, "logger") and not _open(db, "no_data")


def test_a_silent_logger_on_a_wall_clock_site_and_a_sensor_silent_before_it(site):
    """clock=wall: both loggers silent past no_data_hours give two logger alarms, not 58 sensor alarms; a sensor
    that was already silent before its logger fell silent keeps its own alarm."""
    from longprofile.rail.service._db import now_ts

    db, key, r = site
    _core.update_site(db, "adm", "mitt", clock="wall")
    pk1, pk2 = _two_loggers(db, key)
    ids = sorted(r.sensor_id.unique())
    mine2 = r.sensor_id.isin(ids[:20])
    _ingest_as(db, r[~mine2 & (r.sensor_id != "S50")], pk1)
    _ingest_as(db, r[(r.sensor_id == "S50") & (r.timestamp.str[:10] <= "2019-11-20")], pk1)
    _ingest_as(db, r[mine2], pk2)
    _no_data_pass(db, now=now_ts() + 60)  # the batches just arrived: no logger is silent
    assert not _open(db, "logger")
    _no_data_pass(db, now=now_ts() + 7 * 3600)
    assert sorted(a["subject"] for a in _open(db, "logger")) == ["logger-1", "logger-2"]
    assert [a["subject"] for a in _open(db, "no_data")] == ["S50"]


def test_bad_or_empty_days_get_an_html_page_on_pages_and_json_on_the_api(site):
    """Probe item 16: the pages answered a bad day with raw JSON, the same for a malformed date and a day without
    a result."""
    db, _, r = site
    _ingest(db, r)
    assert recompute(db, "mitt")["status"] == "ok"
    client = _viewer(db)
    for path, status, words in (("/sites/mitt?day=garbage", 422, "is not a date"),
                                ("/sites/mitt?day=2019-02-30", 422, "is not a date"),
                                ("/sites/mitt?day=2030-01-01", 404, "no result for 2030-01-01"),
                                ("/sites/mitt/report/2019-11-10", 404, "no result for 2019-11-10"),
                                ("/sites/mitt/report/garbage", 422, "is not a date")):
        res = client.get(path)
        assert res.status_code == status and res.headers["content-type"].startswith("text/html"), (path, res.text)
        assert words in res.text and 'id="back" href="/sites/mitt"' in res.text and "results cover" not in words
    assert "results cover" in client.get("/sites/mitt?day=2030-01-01").text
    api = client.get("/api/v1/sites/mitt/settlement", params={"day": "garbage"})
    assert api.status_code == 422 and "is not a date" in api.json()["detail"]
    api = client.get("/api/v1/sites/mitt/settlement", params={"day": "2030-01-01"})
    assert api.status_code == 404 and "no result for 2030-01-01" in api.json()["detail"]


def test_manual_ingest_and_forced_recomputes_are_audited(site, tmp_path, monkeypatch):
    """Probe item 17: `rail site ingest` had no --actor and neither it nor a forced recompute left an audit entry."""
    import typer
    from typer.testing import CliRunner

    from longprofile.cli import _rail_serve
    from longprofile.cli._rail_serve import register

    db, _, r = site
    monkeypatch.setattr(_rail_serve, "_db", lambda url, **_: db)  # the fixture's engine: no pool left open
    path = tmp_path / "late.csv"
    r[r.timestamp.str[:10] <= "2019-11-21"].to_csv(path, index=False)
    app = typer.Typer()
    register(app)
    res = CliRunner().invoke(app, ["site", "ingest", "mitt", "--file", str(path), "--db", db.url, "--actor", "ops"])
    assert res.exit_code == 0, res.output
    (a,) = [a for a in _core.audit_trail(db, "mitt") if a["entity"] == "readings"]
    assert a["actor"] == "ops" and a["action"] == "ingest" and a["key"] == "late.csv"
    assert a["new"]["accepted"] == int((r.timestamp.str[:10] <= "2019-11-21").sum()) and a["new"]["file"] == "late.csv"
    res = CliRunner().invoke(app, ["site", "recompute", "mitt", "--force", "--db", db.url, "--actor", "ops"])
    assert res.exit_code == 0, res.output
    (f,) = [a for a in _core.audit_trail(db, "mitt") if a["action"] == "recompute"]
    assert f["actor"] == "ops" and f["new"]["forced"] and f["new"]["run_id"] == json.loads(res.stdout)["run_id"]
    assert f["ts"]
    from fastapi.testclient import TestClient

    from longprofile.rail.service._web import create_app

    _core.add_user(db, "t", "eng1", "eng1-password", "engineer")
    res = TestClient(create_app(db, background=False)).post("/api/v1/sites/mitt/recompute",
                                                           auth=("eng1", "eng1-password"))
    assert res.status_code == 200
    assert [a["actor"] for a in _core.audit_trail(db, "mitt") if a["action"] == "recompute"] == ["eng1", "ops"]
    recompute(db, "mitt")  # the worker's own runs are not audited (nobody asked)
    assert len([a for a in _core.audit_trail(db, "mitt") if a["action"] == "recompute"]) == 2


def test_site_names_differing_only_in_case_are_refused(db):
    _core.create_site(db, "adm", "s1")
    with pytest.raises(InputError, match="'s1' already exists and differs from 'S1' only in letter case"):
        _core.create_site(db, "adm", "S1")
    assert _core.list_sites(db) == ["s1"]


def test_a_control_date_with_a_time_of_day_is_refused(site):
    """Probe item 21: 2019-11-22T10:00:00 was stored as 2019-11-22 without a word; midnight is a date."""
    db, _, r = site
    _ingest(db, r)
    x = _x(db, "S30")
    z = _survey_z(db, x)
    with pytest.raises(InputError, match=r"carries a time of day.*give the date only, 2019-11-22"):
        _core.put_controls(db, "eng", "mitt", [{"date": "2019-11-22T10:00:00", "x_m": x, "z_m": z}])
    assert _core.get_controls(db, "mitt")["controls"] == []
    out = _core.put_controls(db, "eng", "mitt", [{"date": "2019-11-22 00:00:00", "x_m": x, "z_m": z}])
    assert out["dates"] == ["2019-11-22"]


def test_removing_a_threshold_that_does_not_exist_is_refused(site):
    """Probe item 20: it exited 0 without a word."""
    db, _, _ = site
    _core.set_threshold(db, "eng", "mitt", "settlement", "alert", 0.010)
    with pytest.raises(_core.NotFound, match=r"no settlement action threshold to remove; its thresholds: "
                                             r"settlement alert 10 mm\."):
        _core.set_threshold(db, "eng", "mitt", "settlement", "action", None)
    _core.set_threshold(db, "eng", "mitt", "settlement", "alert", None)
    with pytest.raises(_core.NotFound, match="its thresholds: none"):
        _core.set_threshold(db, "eng", "mitt", "settlement", "alert", None)
