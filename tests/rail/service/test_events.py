"""Declared re-installations and replacements of sensors in the monitoring service (``rail site events``): stored,
audited, listed and deleted; every recompute gives them to the library as ``rail settle --events`` does, so the
service's settlement is ``rail settle --events``'s on the same site; a bad events file gets one clear line."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import typer
from fastapi.testclient import TestClient
from sqlalchemy import select
from typer.testing import CliRunner

from longprofile.cli._rail_serve import register
from longprofile.cli.app import main
from longprofile.errors import InputError, LongprofileError
from longprofile.rail.service import _core
from longprofile.rail.service._alarms import list_alarms
from longprofile.rail.service._db import ResultRow, Run
from longprofile.rail.service._events import delete_event, get_events, put_events
from longprofile.rail.service._recompute import recompute
from longprofile.rail.service._web import create_app

from .conftest import synthetic
from .test_api import login

NOW = 2_000_000_000


def _maintained():
    """The synthetic site with sensor 20 re-installed on day 4 (its angle 0.3 deg off from then on) and sensor 40
    replaced on day 5 by NEW40 at its station (reading 0.5 deg below it): (sensors with NEW40, readings with naive
    times, the same with ISO UTC times as loggers send them, events table)."""
    syn, _ = synthetic()
    ids = list(syn.sensors["sensor_id"])
    r = syn.readings.copy()
    day = pd.to_datetime(r["timestamp"]).dt.normalize()
    ud = sorted(day.unique())
    moved = (r["sensor_id"] == ids[20]) & (day >= ud[4])
    r.loc[moved, "angle_deg"] += 0.3
    new = (r["sensor_id"] == ids[40]) & (day >= ud[5])
    r.loc[new, "angle_deg"] -= 0.5
    r.loc[new, "sensor_id"] = "NEW40"
    x40 = float(syn.sensors.loc[syn.sensors["sensor_id"] == ids[40], "x_m"].iloc[0])
    sensors = pd.concat([syn.sensors, pd.DataFrame({"sensor_id": ["NEW40"], "x_m": [x40]})], ignore_index=True)
    iso = r.assign(timestamp=pd.to_datetime(r["timestamp"]).dt.strftime("%Y-%m-%dT%H:%M:%SZ"))
    events = pd.DataFrame({"sensor_id": [ids[20], ids[40]], "date": [f"{ud[4]:%Y-%m-%d}", f"{ud[5]:%Y-%m-%d}"],
                           "event": ["reinstalled", "replaced_by"], "new_id": ["", "NEW40"]})
    return sensors, r, iso, events


def _rail_settle(tmp_path, sensors, readings, events) -> pd.DataFrame:
    syn, _ = synthetic()
    sensors.to_csv(tmp_path / "sensors.csv", index=False)
    readings.to_csv(tmp_path / "readings.csv", index=False)
    syn.survey.to_csv(tmp_path / "survey.csv", index=False)
    events.to_csv(tmp_path / "events.csv", index=False)
    out = tmp_path / "settle.csv"
    assert main(["rail", "settle", "--sensors", str(tmp_path / "sensors.csv"), "--readings",
                 str(tmp_path / "readings.csv"), "--survey", str(tmp_path / "survey.csv"), "--events",
                 str(tmp_path / "events.csv"), "--thermal", "linear", "--monte-carlo", "0", "-o", str(out)]) == 0
    return pd.read_csv(out)


def _stored(db, run_id) -> pd.DataFrame:
    with db.read() as s:
        return pd.DataFrame(s.execute(select(ResultRow.day, ResultRow.sensor_id, ResultRow.dz_m, ResultRow.dz_std_m)
                                      .where(ResultRow.run_id == run_id)).all(),
                            columns=["date", "sensor_id", "dz_m", "dz_std_m"])


def _cli(db, monkeypatch):
    monkeypatch.setattr("longprofile.cli._rail_serve._db", lambda url, existing=False: db)
    app = typer.Typer()
    register(app)
    runner = CliRunner()
    return lambda *args: runner.invoke(app, ["site", *args, "--db", db.url])


def test_the_service_settlement_with_events_is_rail_settle_events(site, tmp_path, monkeypatch):
    """The same site and events file: the stored results (two runs, the day cache carried over) are those of
    ``rail settle --events`` to 1e-9; without the events they are not (the offsets read as settlement)."""
    db, _, _ = site
    sensors, naive, iso, events = _maintained()
    ref = _rail_settle(tmp_path, sensors, naive, events)
    cli = _cli(db, monkeypatch)
    res = cli("events", "mitt", "--file", str(tmp_path / "events.csv"), "--actor", "dave")
    assert res.exit_code == 0, res.output
    assert len(json.loads(res.stdout)["changed"]) == 2
    # NEW40 shares the station of the sensor it replaces: taken because the replacement is declared
    _core.put_sensors(db, "tester", "mitt", sensors[sensors["sensor_id"] == "NEW40"].to_dict("records"))
    days = iso["timestamp"].str[:10]
    for upto in (sorted(days.unique())[5], days.max()):
        part = iso[days <= upto]
        for i in range(0, len(part), 5000):
            _core.ingest(db, "mitt", part.iloc[i:i + 5000].to_dict("records"), now=NOW)
        out = recompute(db, "mitt")
        assert out["status"] == "ok", out["message"]
    got = _stored(db, out["run_id"]).merge(ref, on=["date", "sensor_id"], suffixes=("", "_ref"))
    assert len(got) == len(ref) and "NEW40" not in set(ref["sensor_id"])
    for c in ("dz_m", "dz_std_m"):
        np.testing.assert_allclose(got[c], got[c + "_ref"], rtol=1e-9, atol=1e-12)
    with db.read() as s:
        warned = s.get(Run, out["run_id"]).warnings_json
    assert "2 declared re-installation(s) or replacement(s)" in warned and "replaced by NEW40" in warned
    # the replaced sensor, silent since its replacement, raises no "no data" alarm
    assert not [a for a in list_alarms(db, "mitt") if a["quantity"] == "no_data" and a["state"] != "cleared"]
    # listed, and the site page shows them
    assert [e["event"] for e in get_events(db, "mitt")] == ["reinstalled", "replaced_by"]
    assert json.loads(cli("events", "mitt").stdout) == get_events(db, "mitt")
    _core.add_user(db, "tester", "viewer1", "viewer1-password", "viewer")
    client = TestClient(create_app(db, background=False))
    login(client, "viewer1", "viewer1-password")
    page = client.get("/sites/mitt").text
    assert 'id="event-table"' in page and "NEW40" in page
    # without the re-installation the offset is settlement: the numbers change
    sid = events["sensor_id"][0]
    res = cli("events", "mitt", "--delete", sid, "--date", events["date"][0])
    assert res.exit_code == 0 and json.loads(res.stdout)["deleted"] == f"{sid}@{events['date'][0]}"
    out = recompute(db, "mitt")
    other = _stored(db, out["run_id"]).merge(ref, on=["date", "sensor_id"], suffixes=("", "_ref"))
    assert np.abs(other["dz_m"] - other["dz_m_ref"]).max() > 1e-4
    trail = _core.audit_trail(db, "mitt")
    assert {(a["entity"], a["action"]) for a in trail if a["entity"] == "event"} == {("event", "create"),
                                                                                       ("event", "delete")}


def test_a_bad_events_file_or_event_gets_one_clear_line(site, tmp_path, monkeypatch):
    db, _, _ = site
    cli = _cli(db, monkeypatch)
    f = tmp_path / "events.csv"
    for text, msg in [("sensor_id,date,event,new_id\nS01,2019-11-20,moved,\n", "row 2: event 'moved' is not one of"),
                      ("sensor_id,date,event,new_id\nS01,20/13/2019,reinstalled,\n", "is not a date"),
                      ("sensor_id,date,event,new_id\nS01,2019-11-20,replaced_by,\n", "needs new_id"),
                      ("sensor_id,date\nS01,2019-11-20\n", "missing column"),
                      ("sensor_id,date,event,new_id\nZZ9,2019-11-20,reinstalled,\n", "'ZZ9' is not in the sensors"),
                      ("sensor_id,date,event,new_id\nS01,2019-11-20,replaced_by,S01\n", "'replaced_by' itself")]:
        f.write_text(text)
        res = cli("events", "mitt", "--file", str(f))
        assert isinstance(res.exception, LongprofileError), res.output
        assert msg in str(res.exception) and "\n" not in str(res.exception)
    assert get_events(db, "mitt") == []
    with pytest.raises(InputError, match="two events on 2019-11-20"):
        put_events(db, "t", "mitt", [{"sensor_id": "S01", "date": "2019-11-20", "event": "reinstalled"},
                                     {"sensor_id": "S01", "date": "2019-11-20", "event": "reinstalled"}])
    with pytest.raises(InputError, match="carries a time of day"):
        put_events(db, "t", "mitt", [{"sensor_id": "S01", "date": "2019-11-20T08:00", "event": "reinstalled"}])
    with pytest.raises(InputError, match="no event of sensor 'S01'"):
        delete_event(db, "t", "mitt", "S01", "2019-11-20")
    res = cli("events", "mitt", "--delete", "S01")
    assert isinstance(res.exception, LongprofileError) and "--date" in str(res.exception)


def test_the_api_puts_lists_and_deletes_events_as_the_cli_does(site):
    """CSV and JSON bodies store the same events; engineers write, viewers read; one line for a bad row."""
    from .test_api import basic

    db, _, _ = site
    for u, role in (("viewer1", "viewer"), ("eng1", "engineer")):
        _core.add_user(db, "tester", u, f"{u}-password", role)
    client = TestClient(create_app(db, background=False))
    eng, viewer = basic("eng1", "eng1-password"), basic("viewer1", "viewer1-password")
    body = "sensor_id,date,event,new_id\nS05,2019-11-21,reinstalled,\nS07,2019-11-22,replaced_by,S07B\n"
    resp = client.put("/api/v1/sites/mitt/events", content=body, headers={**viewer, "content-type": "text/csv"})
    assert resp.status_code == 403
    resp = client.put("/api/v1/sites/mitt/events", content=body, headers={**eng, "content-type": "text/csv"})
    assert resp.status_code == 200 and resp.json()["changed"] == ["S05@2019-11-21", "S07@2019-11-22"]
    listed = client.get("/api/v1/sites/mitt/events", headers=viewer).json()
    again = client.put("/api/v1/sites/mitt/events", json={"events": listed}, headers=eng)
    assert again.status_code == 200 and again.json()["changed"] == []  # the same events: nothing changes
    bad = client.put("/api/v1/sites/mitt/events", json=[{"sensor_id": "S05", "date": "2019-11-21", "event": "x"}],
                     headers=eng)
    assert bad.status_code == 422 and "is not one of" in bad.json()["detail"]
    assert client.delete("/api/v1/sites/mitt/events/S05/2019-11-21", headers=eng).status_code == 200
    assert client.delete("/api/v1/sites/mitt/events/S05/2019-11-21", headers=eng).status_code == 404
    assert [e["sensor_id"] for e in client.get("/api/v1/sites/mitt/events", headers=viewer).json()] == ["S07"]


def test_a_declared_replacement_lets_the_new_sensor_share_the_station_and_is_kept_while_it_does(site):
    db, _, _ = site
    syn, _ = synthetic()
    x = float(syn.sensors["x_m"][10])
    new = [{"sensor_id": "S11B", "x_m": x}]
    with pytest.raises(InputError, match="would both be active at station"):
        _core.put_sensors(db, "t", "mitt", new)
    put_events(db, "t", "mitt", [{"sensor_id": "S11", "date": "2019-11-21", "event": "replaced_by", "new_id": "S11B"}])
    assert _core.put_sensors(db, "t", "mitt", new)["added"] == 1
    with pytest.raises(InputError, match="would both be active at station"):  # removing it would leave two
        delete_event(db, "t", "mitt", "S11", "2019-11-21")
    with pytest.raises(InputError, match="would both be active at station"):
        put_events(db, "t", "mitt", [{"sensor_id": "S11", "date": "2019-11-21", "event": "reinstalled"}])
    assert [e["event"] for e in get_events(db, "mitt")] == ["replaced_by"]


def test_an_open_no_data_alarm_of_a_sensor_declared_replaced_is_withdrawn_saying_why(site):
    from longprofile.rail.service._alarms import REPLACED_REASON, evaluate_no_data
    from longprofile.rail.service._core import _site

    db, _, r = site
    days = r["timestamp"].str[:10]
    silent = (r["sensor_id"] == "S12") & (days >= sorted(days.unique())[4])
    _core.ingest(db, "mitt", r[~silent].to_dict("records"), now=NOW)
    with db.write() as s:
        evaluate_no_data(s, _site(s, "mitt"))
    assert [a["subject"] for a in list_alarms(db, "mitt") if a["quantity"] == "no_data"] == ["S12"]
    put_events(db, "t", "mitt", [{"sensor_id": "S12", "date": sorted(days.unique())[4], "event": "replaced_by",
                                  "new_id": "S12B"}])
    with db.write() as s:
        evaluate_no_data(s, _site(s, "mitt"))
    (a,) = [a for a in list_alarms(db, "mitt") if a["quantity"] == "no_data"]
    assert a["state"] == "cleared" and a["cleared_reason"] == REPLACED_REASON


def test_site_show_and_the_sensor_page_list_the_declared_events(site, monkeypatch):
    """`rail site show` (and GET /api/v1/sites/{site}) carries the site's events; a sensor's page lists its own
    (its re-installation; a replaced sensor's and its successor's replacement), not the others'."""
    db, _, r = site
    put_events(db, "t", "mitt", [{"sensor_id": "S05", "date": "2019-11-21", "event": "reinstalled"},
                                 {"sensor_id": "S07", "date": "2019-11-22", "event": "replaced_by", "new_id": "S07B"}])
    shown = json.loads(_cli(db, monkeypatch)("show", "mitt").stdout)
    assert shown["events"] == [{"sensor_id": "S05", "date": "2019-11-21", "event": "reinstalled", "new_id": ""},
                               {"sensor_id": "S07", "date": "2019-11-22", "event": "replaced_by", "new_id": "S07B"}]
    _core.ingest(db, "mitt", r.to_dict("records"))
    _core.add_user(db, "t", "v1", "v1-password", "viewer")
    client = TestClient(create_app(db, background=False))
    login(client, "v1", "v1-password")
    page = client.get("/sites/mitt/sensors/S07").text
    assert 'id="event-table"' in page and "S07B" in page and "2019-11-21" not in page
    assert "2019-11-21" in client.get("/sites/mitt/sensors/S05").text
    assert 'id="event-table"' not in client.get("/sites/mitt/sensors/S09").text
