"""HTTP API and pages: API keys, logins, roles, CSRF, no data in error bodies, injection and traversal attempts."""

from __future__ import annotations

import base64
import re

import pytest
from fastapi.testclient import TestClient

from longprofile.rail.service import _core
from longprofile.rail.service._web import create_app

from .conftest import count_readings


def basic(user, pw):
    return {"Authorization": "Basic " + base64.b64encode(f"{user}:{pw}".encode()).decode()}


def login(client, user, pw):
    page = client.get("/login")
    tok = re.search(r'name="csrf" value="([^"]+)"', page.text).group(1)
    return client.post("/login", data={"username": user, "password": pw, "csrf": tok, "next": "/"},
                       follow_redirects=False)


@pytest.fixture
def app(site):
    db, key, r = site
    for u, role in (("viewer1", "viewer"), ("eng1", "engineer"), ("admin1", "admin")):
        _core.add_user(db, "tester", u, f"{u}-password", role)
    _core.create_site(db, "tester", "other")
    _core.put_sensors(db, "tester", "other", [{"sensor_id": f"O{i}", "x_m": float(i)} for i in range(5)])
    other_key = _core.add_logger(db, "tester", "other", "lg")
    client = TestClient(create_app(db, background=False))
    return client, db, key, other_key, r


SECRET_WORDS = ("S13", "SELECT", "Traceback", "sqlalchemy", "site.db", "/tmp", "lpk_", "scrypt$", "root:")


def no_leak(resp):
    body = resp.text
    return not any(w in body for w in SECRET_WORDS)


def test_ingestion_needs_the_site_logger_key(app):
    client, db, key, other_key, r = app
    csv = r.iloc[:100].to_csv(index=False)
    h = {"content-type": "text/csv"}
    for headers, code in (({}, 401), ({"x-api-key": "lpk_0000_nope"}, 401), ({"x-api-key": "garbage"}, 401),
                          ({"x-api-key": other_key}, 403)):
        resp = client.post("/api/v1/sites/mitt/readings", content=csv, headers={**h, **headers})
        assert resp.status_code == code and no_leak(resp), (headers, resp.text)
    # a key of another site must not tell whether a site exists
    a = client.post("/api/v1/sites/nosuchsite/readings", content=csv, headers={**h, "x-api-key": other_key})
    assert a.status_code == 403 and a.json() == {"detail": "forbidden"}
    assert count_readings(db) == 0
    ok = client.post("/api/v1/sites/mitt/readings", content=csv, headers={**h, "x-api-key": key})
    assert ok.status_code == 200 and ok.json()["accepted"] == 100
    assert count_readings(db) == 100  # acknowledged == committed


def test_malformed_batches_are_refused_whole_with_a_reason(app):
    client, db, key, _, r = app
    for body, ctype in ((b"{not json", "application/json"), (b"sensor,x\n1,2\n", "text/csv"),
                        (b"\x89PNG", "image/png"), (b'{"readings": {"a": 1}}', "application/json")):
        resp = client.post("/api/v1/sites/mitt/readings", content=body, headers={"content-type": ctype,
                                                                                 "x-api-key": key})
        assert resp.status_code == 422 and "detail" in resp.json() and no_leak(resp)
    assert count_readings(db) == 0


def test_people_need_a_login_and_the_right_role(app):
    client, db, *_ = app
    for path in ("/api/v1/sites", "/api/v1/sites/mitt", "/api/v1/sites/mitt/alarms", "/api/v1/sites/mitt/audit"):
        resp = client.get(path)
        assert resp.status_code == 401 and no_leak(resp)
    assert client.get("/api/v1/sites", headers=basic("viewer1", "wrong-password")).status_code == 401
    assert client.get("/api/v1/sites", headers=basic("viewer1", "viewer1-password")).json()["sites"] == ["mitt",
                                                                                                       "other"]
    put = lambda who: client.put("/api/v1/sites/mitt/thresholds/settlement/alert", json={"value": 0.004},  # noqa
                                 headers=basic(who, f"{who}-password"))
    assert put("viewer1").status_code == 403
    assert put("eng1").status_code == 200
    assert client.post("/api/v1/sites/mitt/loggers", json={"name": "x"},
                       headers=basic("eng1", "eng1-password")).status_code == 403
    audit = client.get("/api/v1/sites/mitt/audit", headers=basic("eng1", "eng1-password")).json()["audit"]
    assert audit[0]["actor"] == "eng1" and audit[0]["key"] == "settlement.alert"
    assert audit[0]["old"] is None and audit[0]["new"] == 0.004
    put2 = client.put("/api/v1/sites/mitt/thresholds/settlement/alert", json={"value": 0.005},
                      headers=basic("eng1", "eng1-password"))
    assert put2.status_code == 200
    audit = client.get("/api/v1/sites/mitt/audit", headers=basic("eng1", "eng1-password")).json()["audit"]
    assert (audit[0]["old"], audit[0]["new"]) == (0.004, 0.005)


def test_pages_are_not_readable_without_login(app):
    client, *_ = app
    for path in ("/", "/sites/mitt", "/sites/mitt/sensors/S1", "/sites/mitt/report/2019-11-20"):
        resp = client.get(path, follow_redirects=False)
        assert resp.status_code == 303 and resp.headers["location"].startswith("/login")
    for path in ("/sites/mitt/profile.png", "/sites/mitt/sensors/S1/series.png"):
        assert client.get(path).status_code == 401
    assert login(client, "viewer1", "nope").status_code == 401
    assert login(client, "viewer1", "viewer1-password").status_code == 303
    assert client.get("/").status_code == 200 and "mitt" in client.get("/").text


def test_cookie_sessions_need_csrf_tokens(app):
    client, db, *_ = app
    login(client, "eng1", "eng1-password")
    # JSON API with the cookie but no X-CSRF-Token header
    resp = client.put("/api/v1/sites/mitt/thresholds/settlement/alert", json={"value": 0.004})
    assert resp.status_code == 403
    # the login form itself: no token, or a token of another browser
    fresh = TestClient(client.app)
    assert fresh.post("/login", data={"username": "eng1", "password": "eng1-password"}).status_code == 403
    assert fresh.post("/logout", data={}).status_code == 403
    # a forged or signed-by-someone-else cookie is nobody
    fresh.cookies.set("lp_session", "eyJ1IjoxfQ.forged.sig")
    assert fresh.get("/api/v1/sites").status_code == 401


INJECTIONS = ["x' OR '1'='1", "mitt'; DROP TABLE readings;--", "../../etc/passwd", "..%2F..%2Fetc%2Fpasswd",
              "%00", "mitt/../other", "\\..\\..\\windows", "a" * 300]


@pytest.mark.parametrize("bad", INJECTIONS)
def test_injection_and_traversal_attempts_change_nothing(app, bad):
    client, db, key, _, r = app
    _core.ingest(db, "mitt", r.iloc[:10].to_dict("records"))
    h = basic("admin1", "admin1-password")
    from urllib.parse import quote

    q = quote(bad, safe="")
    for method, path in (("GET", f"/api/v1/sites/{q}"), ("GET", f"/api/v1/sites/{q}/alarms"),
                         ("GET", f"/api/v1/sites/mitt/settlement?day={q}"), ("GET", f"/sites/{q}"),
                         ("GET", f"/sites/mitt/report/{q}"), ("GET", f"/sites/mitt/sensors/{q}"),
                         ("GET", f"/sites/mitt?day={q}"),
                         ("PUT", f"/api/v1/sites/mitt/thresholds/{q}/alert"),
                         ("PUT", f"/api/v1/sites/mitt/thresholds/settlement/{q}"),
                         ("POST", f"/api/v1/sites/{q}/readings")):
        login(client, "admin1", "admin1-password")
        resp = client.request(method, path, headers={**h, "x-api-key": key}, json={"value": 1.0})
        assert resp.status_code in (401, 403, 404, 422), (path, resp.status_code, resp.text[:200])
        assert no_leak(resp) or resp.status_code == 422, resp.text
        assert "root:" not in resp.text
    client.cookies.clear()
    resp = client.post("/api/v1/sites", json={"name": bad}, headers=h)
    assert resp.status_code == 422
    rows = [{"timestamp": "2019-11-18T00:00:00Z", "sensor_id": bad, "angle_deg": 0.1, "temperature_c": 1.0}]
    out = client.post("/api/v1/sites/mitt/readings", json=rows, headers={"x-api-key": key}).json()
    assert out["rejected"] == 1
    assert count_readings(db) == 10 and _core.list_sites(db) == ["mitt", "other"]


def test_management_api_round_trip(app):
    client, db, *_ = app
    h = basic("admin1", "admin1-password")
    assert client.post("/api/v1/sites", json={"name": "new-site", "title": "T", "clock": "data"},
                       headers=h).status_code == 200
    assert client.put("/api/v1/sites/new-site/sensors", content="sensor_id,x_m\nA,0\nB,1\nC,2\n",
                      headers={**h, "content-type": "text/csv"}).json() == {"added": 3, "changed": 0}
    assert client.put("/api/v1/sites/new-site/survey", json=[{"x_m": 0, "z_m": 1}, {"x_m": 2, "z_m": 1.5}],
                      headers=h).status_code == 200
    bad = client.put("/api/v1/sites/new-site/thresholds/settlement/action", json={"value": -1}, headers=h)
    assert bad.status_code == 422
    key = client.post("/api/v1/sites/new-site/loggers", json={"name": "lg"}, headers=h).json()["api_key"]
    assert _core.authenticate_logger(db, key) is not None
    got = client.get("/api/v1/sites/new-site", headers=h).json()
    assert [s["sensor_id"] for s in got["sensors"]] == ["A", "B", "C"] and got["loggers"] == ["lg"]
    patched = client.patch("/api/v1/sites/new-site", json={"no_data_hours": 3}, headers=h).json()
    assert patched["no_data_hours"] == 3
    ents = [(a["entity"], a["action"]) for a in client.get("/api/v1/sites/new-site/audit", headers=h).json()["audit"]]
    assert ("site", "update") in ents and ("logger", "create") in ents and ("survey", "replace") in ents


def test_dashboard_pages_and_the_daily_report(app):
    from longprofile.rail.service._recompute import recompute

    client, db, key, _, r = app
    _core.ingest(db, "mitt", r.to_dict("records"))
    recompute(db, "mitt")
    login(client, "viewer1", "viewer1-password")
    page = client.get("/sites/mitt")
    last = r["timestamp"].max()
    assert page.status_code == 200 and f"Data complete to <b>{last[:10]} {last[11:16]} UTC" in page.text
    assert 'class="ack"' not in page.text and "alarm-2" in page.text  # viewers see alarms, cannot acknowledge
    png = client.get("/sites/mitt/profile.png")
    assert png.status_code == 200 and png.content[:4] == b"\x89PNG"
    assert client.get("/sites/mitt/sensors/S20/series.png").content[:4] == b"\x89PNG"
    assert "S20" in client.get("/sites/mitt/sensors/S20").text
    assert client.get("/sites/mitt/sensors/NOPE").status_code == 404
    rep = client.get(f"/sites/mitt/report/{last[:10]}")
    assert rep.status_code == 200 and "Track settlement report: mitt, data to" in rep.text
    assert client.get("/sites/mitt/report/1999-01-01").status_code == 404
    api = client.get("/api/v1/sites/mitt/settlement").json()
    assert api["day"] == last[:10] and len(api["rows"]) == 58 and api["run"]["data_complete_to"]
    # the run's settlement model is shown; a site without thresholds says so instead of a bare "no alarm"
    assert api["run"]["model"] == "all-days" and "all-days model" in page.text
    assert 'id="no-thresholds"' in page.text  # this site has none (its alarms are sensor-health ones)
    _core.replace_thresholds(db, "tester", "mitt", {"settlement": {"alert": 0.01}})
    assert 'id="no-thresholds"' not in client.get("/sites/mitt").text


def test_the_report_folder_of_the_app_is_removed_when_its_lifespan_ends(site, tmp_path, monkeypatch):
    """Without a report_dir the app keeps its day reports in a temporary directory of its own, removed at shutdown
    (test runs and restarts left one longprofile-reports-* folder in /tmp each)."""
    import tempfile

    from longprofile.rail.service._recompute import recompute

    db, _, r = site
    _core.add_user(db, "tester", "viewer1", "viewer1-password", "viewer")
    _core.ingest(db, "mitt", r.to_dict("records"))
    recompute(db, "mitt")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))

    def folders():
        return sorted(p for p in tmp.iterdir() if p.name.startswith("longprofile-reports-"))

    with TestClient(create_app(db, background=False)) as client:
        login(client, "viewer1", "viewer1-password")
        rep = client.get(f"/sites/mitt/report/{r['timestamp'].max()[:10]}")
        assert rep.status_code == 200
        assert len(folders()) == 1 and list(folders()[0].rglob("index.html"))
    assert folders() == []


def test_a_batch_far_from_level_needs_check_units_false(app):
    """Sensors mounted 12 deg from level (beyond MAX_TRACK_ANGLE_DEG): the batch is rejected as another unit, and
    taken with ?check_units=false (as rail settle --no-check-units)."""
    client, db, key, _, r = app
    part = r.iloc[:100].assign(angle_deg=lambda f: f["angle_deg"] + 12.0)
    h = {"content-type": "text/csv", "x-api-key": key}
    resp = client.post("/api/v1/sites/mitt/readings", content=part.to_csv(index=False), headers=h)
    assert resp.status_code == 200 and resp.json()["rejected"] == 100 and count_readings(db) == 0
    resp = client.post("/api/v1/sites/mitt/readings?check_units=false", content=part.to_csv(index=False), headers=h)
    assert resp.status_code == 200 and resp.json()["accepted"] == 100 and count_readings(db) == 100
