"""Logger API keys: revocation and rotation (library, API for admins, CLI), audited, effective at once."""

from __future__ import annotations

import json
import tempfile

import pytest
from fastapi.testclient import TestClient
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import LongprofileError
from longprofile.rail.service import _core
from longprofile.rail.service._web import create_app

from .conftest import count_readings
from .test_api import basic


def post(client, key, rows):
    return client.post("/api/v1/sites/mitt/readings", content=rows.to_csv(index=False),
                       headers={"content-type": "text/csv", "x-api-key": key})


def test_a_revoked_or_rotated_away_key_gets_401_at_once_and_its_readings_stay(site):
    db, key, r = site
    for u, role in (("eng1", "engineer"), ("admin1", "admin")):
        _core.add_user(db, "tester", u, f"{u}-password", role)
    client = TestClient(create_app(db, background=False))
    admin, eng = basic("admin1", "admin1-password"), basic("eng1", "eng1-password")
    assert post(client, key, r.iloc[:100]).status_code == 200
    assert client.post("/api/v1/sites/mitt/loggers/logger-1/revoke", headers=eng).status_code == 403
    assert client.post("/api/v1/sites/mitt/loggers/logger-1/rotate", headers=eng).status_code == 403
    assert client.post("/api/v1/sites/mitt/loggers/logger-1/revoke").status_code == 401
    assert post(client, key, r.iloc[100:200]).status_code == 200  # nothing changed by the refused calls
    rv = client.post("/api/v1/sites/mitt/loggers/logger-1/revoke", headers=admin)
    assert rv.status_code == 200 and rv.json() == {"logger": "logger-1", "active": False}
    refused = post(client, key, r.iloc[200:300])
    assert refused.status_code == 401 and "lpk_" not in refused.text
    assert count_readings(db) == 200  # the acknowledged readings stay
    assert client.get("/api/v1/sites/mitt", headers=admin).json()["revoked_loggers"] == ["logger-1"]
    # rotation re-issues a key (a revoked logger is active again with it); the previous key stays refused
    k2 = client.post("/api/v1/sites/mitt/loggers/logger-1/rotate", headers=admin).json()["api_key"]
    assert k2.startswith("lpk_") and k2 != key
    assert post(client, key, r.iloc[200:300]).status_code == 401
    assert post(client, k2, r.iloc[200:300]).status_code == 200
    k3 = client.post("/api/v1/sites/mitt/loggers/logger-1/rotate", headers=admin).json()["api_key"]
    assert post(client, k2, r.iloc[300:400]).status_code == 401
    assert post(client, k3, r.iloc[300:400]).status_code == 200
    assert count_readings(db) == 400
    assert client.post("/api/v1/sites/mitt/loggers/nope/revoke", headers=admin).status_code == 404
    assert client.post("/api/v1/sites/other/loggers/logger-1/rotate", headers=admin).status_code == 404
    audit = [(a["action"], a["actor"], a["old"], a["new"]) for a in _core.audit_trail(db, "mitt")
             if a["entity"] == "logger" and a["action"] != "create"]
    kid = lambda k: k.split("_")[1]  # noqa: E731
    assert audit == [
        ("rotate", "admin1", {"key_id": kid(k2), "active": True}, {"key_id": kid(k3), "active": True}),
        ("rotate", "admin1", {"key_id": kid(key), "active": False}, {"key_id": kid(k2), "active": True}),
        ("revoke", "admin1", {"key_id": kid(key), "active": True}, {"key_id": kid(key), "active": False})]
    # the whole secret (it may itself hold "_": split once after the key id, as the server does)
    secrets = [k.split("_", 2)[2] for k in (key, k2, k3)]
    assert all(len(s) >= 20 for s in secrets)
    assert not any(s in json.dumps(_core.audit_trail(db, "mitt")) for s in secrets)


@settings(max_examples=20, deadline=None)
@given(st.lists(st.sampled_from(["revoke", "rotate"]), min_size=1, max_size=6))
def test_only_the_newest_key_of_an_active_logger_is_accepted(ops):
    """After any sequence of revocations and rotations, exactly the newest key is accepted, and only while the logger
    was not revoked after it."""
    from longprofile.rail.service._db import Database

    with tempfile.TemporaryDirectory() as tmp:
        db = Database(f"sqlite:///{tmp}/k.db")
        _core.create_site(db, "t", "s")
        keys = [_core.add_logger(db, "t", "s", "lg")]
        active = True
        for op in ops:
            if op == "revoke":
                _core.revoke_logger(db, "t", "s", "lg")
                active = False
            else:
                keys.append(_core.rotate_logger(db, "t", "s", "lg"))
                active = True
        accepted = [_core.authenticate_logger(db, k) is not None for k in keys]
        db.dispose()
    assert accepted == [False] * (len(keys) - 1) + [active]


def test_the_cli_revokes_and_rotates_keys(site, monkeypatch):
    import typer
    from typer.testing import CliRunner

    from longprofile.cli._rail_serve import register

    db, key, _ = site
    monkeypatch.setattr("longprofile.cli._rail_serve._db", lambda url: db)  # one engine (PostgreSQL: closed at the end)
    app = typer.Typer()
    register(app)
    runner = CliRunner()
    res = runner.invoke(app, ["site", "logger-revoke", "mitt", "logger-1", "--db", db.url, "--actor", "ops"])
    assert res.exit_code == 0 and json.loads(res.stdout) == {"logger": "logger-1", "active": False}
    assert _core.authenticate_logger(db, key) is None
    res = runner.invoke(app, ["site", "logger-rotate", "mitt", "logger-1", "--db", db.url])
    new = res.stdout.strip()
    assert res.exit_code == 0 and new.startswith("lpk_") and len(res.stdout.splitlines()) == 1
    assert _core.authenticate_logger(db, new) is not None and _core.authenticate_logger(db, key) is None
    res = runner.invoke(app, ["site", "logger-revoke", "mitt", "nope", "--db", db.url])
    assert isinstance(res.exception, LongprofileError) and "unknown logger" in str(res.exception)
    assert [a["actor"] for a in _core.audit_trail(db, "mitt") if a["action"] == "revoke"] == ["ops"]


@pytest.mark.parametrize("logger", ["../x", "'; DROP TABLE loggers; --", ""])
def test_odd_logger_names_are_unknown_loggers(site, logger):
    db, key, _ = site
    with pytest.raises(_core.NotFound):
        _core.revoke_logger(db, "t", "mitt", logger)
    assert _core.authenticate_logger(db, key) is not None
