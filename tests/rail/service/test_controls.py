"""Control surveys: stored, audited, validated, passed to the recompute as ``rail settle`` gets them, and the
comparison ``estimate_settlement`` returns stored and shown (API, site page, CLI)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import select

from longprofile.errors import InputError, LongprofileError
from longprofile.rail import estimate_settlement, validate_site
from longprofile.rail.service import _core
from longprofile.rail.service._db import ControlComparison, Site
from longprofile.rail.service._recompute import KEEP_RUNS, recompute, service_joint_days
from longprofile.rail.service._web import create_app

from .conftest import synthetic
from .test_api import basic, login

NOW = 2_000_000_000
CONTROL_COLUMNS = ["date", "x_m", "z_m", "dz_control_m", "dz_estimate_m", "std_m", "inside_90"]


def control_table(dates=("2019-11-21", "2019-11-24"), drop_mm=(2.0, 4.0), seed=1):
    """Control surveys of the synthetic site: the initial survey plus a settlement bowl and survey noise."""
    syn, _ = synthetic()
    rng = np.random.default_rng(seed)
    cx = np.arange(5.0, 165.0, 10.0)
    z0 = np.interp(cx, syn.survey["x_m"], syn.survey["z_m"])
    bowl = np.exp(-0.5 * ((cx - 80.0) / 20.0) ** 2)
    rows = [pd.DataFrame({"date": d, "x_m": cx, "z_m": np.round(z0 - 1e-3 * mm * bowl + rng.normal(0, 1e-3, cx.size),
                                                               4)})
            for d, mm in zip(dates, drop_mm)]
    return pd.concat(rows, ignore_index=True)


def _service_model(syn) -> bool:
    return service_joint_days({}, syn.sensors.shape[0], pd.to_datetime(syn.readings["timestamp"]).dt.normalize().nunique())


def reference_comparison(controls):
    """What ``rail settle`` computes on the same tables (``validate_site`` + ``estimate_settlement``)."""
    syn, _ = synthetic()
    ref = estimate_settlement(validate_site(syn.sensors, syn.readings, syn.survey, controls), n_monte_carlo=0,
                              joint_days=_service_model(syn))  # the service's model
    return ref.controls.sort_values(["date", "x_m"]).reset_index(drop=True)


def stored_comparison(db):
    got = _core.get_controls(db, "mitt")
    return pd.DataFrame(got["comparison"], columns=["date", "x_m", "dz_control_m", "dz_estimate_m", "std_m",
                                                    "inside_90"])


def assert_same_comparison(got, ref):
    assert len(got) == len(ref) > 0
    assert list(got["date"]) == list(ref["date"])
    for c in ("x_m", "dz_control_m", "dz_estimate_m", "std_m"):
        np.testing.assert_allclose(got[c], ref[c], rtol=1e-9, atol=1e-12)
    assert list(got["inside_90"]) == list(ref["inside_90"])


@pytest.fixture
def loaded(site):
    db, key, r = site
    for i in range(0, len(r), 5000):
        _core.ingest(db, "mitt", r.iloc[i:i + 5000].to_dict("records"), now=NOW)
    assert recompute(db, "mitt")["status"] == "ok"
    return db, key, r


def test_the_stored_comparison_is_that_of_estimate_settlement_and_follows_every_change(loaded):
    db, _, _ = loaded
    ct = control_table()
    out = _core.put_controls(db, "eng", "mitt", ct.to_dict("records"))
    assert out == {"dates": ["2019-11-21", "2019-11-24"], "points": len(ct), "changed": ["2019-11-21", "2019-11-24"]}
    with db.read() as s:
        assert s.scalar(select(Site.dirty_from_ts).where(Site.name == "mitt")) is not None  # the worker runs it
    run = recompute(db, "mitt")  # not forced: the change must be seen
    assert run["status"] == "ok"
    assert_same_comparison(stored_comparison(db), reference_comparison(ct))
    # a corrected survey of one date replaces that date only
    new = control_table(dates=("2019-11-24",), drop_mm=(6.0,), seed=2)
    assert _core.put_controls(db, "eng", "mitt", new.to_dict("records"))["changed"] == ["2019-11-24"]
    assert recompute(db, "mitt")["status"] == "ok"
    both = pd.concat([ct[ct["date"] == "2019-11-21"], new], ignore_index=True)
    assert_same_comparison(stored_comparison(db), reference_comparison(both))
    # deleting a date
    assert _core.delete_controls(db, "eng", "mitt", "2019-11-21") == {"deleted": "2019-11-21", "points": len(new)}
    assert recompute(db, "mitt")["status"] == "ok"
    assert_same_comparison(stored_comparison(db), reference_comparison(new))
    # the comparison rows are pruned with the results of old runs
    with db.read() as s:
        runs = set(s.scalars(select(ControlComparison.run_id)))
    assert len(runs) <= KEEP_RUNS


def test_every_change_is_audited_old_to_new_and_a_resend_changes_nothing(loaded):
    db, _, _ = loaded
    ct = control_table(dates=("2019-11-21",))
    _core.put_controls(db, "alice", "mitt", ct.to_dict("records"))
    recompute(db, "mitt")
    again = _core.put_controls(db, "alice", "mitt", ct.sample(frac=1, random_state=0).to_dict("records"))
    assert again["changed"] == []
    assert recompute(db, "mitt")["status"] == "unchanged"  # nothing new: no run
    moved = ct.copy()
    moved.loc[3, "z_m"] += 0.002
    _core.put_controls(db, "bob", "mitt", moved.to_dict("records"))
    _core.delete_controls(db, "carol", "mitt", "2019-11-21")
    audit = [a for a in _core.audit_trail(db, "mitt") if a["entity"] == "controls"]
    assert [(a["actor"], a["action"], a["key"]) for a in audit] == [
        ("carol", "delete", "2019-11-21"), ("bob", "replace", "2019-11-21"), ("alice", "create", "2019-11-21")]
    pts = [[x, z] for x, z in zip(ct["x_m"], ct["z_m"])]
    pts_moved = [[x, z] for x, z in zip(moved["x_m"], moved["z_m"])]
    assert audit[2]["old"] is None and audit[2]["new"] == pts
    assert audit[1]["old"] == pts and audit[1]["new"] == pts_moved
    assert audit[0]["old"] == pts_moved and audit[0]["new"] is None


def _bad(rows, what):
    return pytest.param(rows, what, id=what.split()[0])


GOOD = {"date": "2019-11-21", "x_m": 50.0, "z_m": 209.9}
BAD_CASES = [
    _bad([{**GOOD, "date": "21/11/2019"}], "ISO 8601"),
    _bad([{**GOOD, "date": "2019-11-17"}], "before the site's first reading (2019-11-18)"),
    _bad([{**GOOD, "date": "2026-12-04"}], "in the future (today is 2026-12-03 UTC)"),
    _bad([{**GOOD, "z_m": float("nan")}], "must be a finite number"),
    _bad([{**GOOD, "z_m": "nan"}], "must be a finite number"),
    _bad([{**GOOD, "x_m": None}], "must be a finite number"),
    _bad([GOOD, {**GOOD, "z_m": 209.8}], "two altitudes at x = 50 m on 2019-11-21"),
    _bad([{**GOOD, "x_m": 170.0}], "outside the sensors' span 0..167.5 m"),
    _bad([{**GOOD, "x_m": -0.5}], "outside the sensors' span"),
    _bad([{"date": "2019-11-21", "x_m": 50.0}], "missing column(s) ['z_m']"),
    _bad([{**GOOD, "sensor_id": "S1"}], "unknown column(s) ['sensor_id']"),
    _bad([{**GOOD, "z_m": 209900.0}], "beyond any terrain"),  # millimetres
    _bad([{**GOOD, "z_m": -0.1}], "from the initial survey there, beyond any settlement"),  # another datum
    _bad([], "no control points given"),
]


@pytest.fixture
def first_day(site):
    """The site with readings of its first day only (2019-11-18)."""
    db, key, r = site
    _core.ingest(db, "mitt", r[r["timestamp"].str[:10] == "2019-11-18"].to_dict("records"), now=NOW)
    return db, key, r


@pytest.mark.parametrize("rows, what", BAD_CASES)
def test_bad_control_surveys_are_refused_with_one_clear_error(first_day, rows, what):
    db, _, _ = first_day
    today = int(pd.Timestamp("2026-12-03T12:00:00Z").value // 10**9)
    with pytest.raises(LongprofileError) as exc:
        _core.put_controls(db, "eng", "mitt", rows, now=today)
    assert what in str(exc.value)
    assert _core.get_controls(db, "mitt")["controls"] == []
    assert not [a for a in _core.audit_trail(db, "mitt") if a["entity"] == "controls"]


def test_a_site_without_readings_refuses_controls(site):
    db, _, _ = site
    with pytest.raises(InputError, match="no readings yet"):
        _core.put_controls(db, "eng", "mitt", [GOOD])


def test_the_api_takes_csv_and_json_with_the_survey_roles_and_shows_the_comparison(loaded):
    db, _, _ = loaded
    for u, role in (("viewer1", "viewer"), ("eng1", "engineer")):
        _core.add_user(db, "tester", u, f"{u}-password", role)
    client = TestClient(create_app(db, background=False))
    ct = control_table()
    eng, viewer = basic("eng1", "eng1-password"), basic("viewer1", "viewer1-password")
    csv = ct.to_csv(index=False)
    assert client.put("/api/v1/sites/mitt/controls", content=csv, headers={**viewer, "content-type": "text/csv"}
                      ).status_code == 403
    assert client.put("/api/v1/sites/mitt/controls", content=csv).status_code == 401
    ok = client.put("/api/v1/sites/mitt/controls", content=csv, headers={**eng, "content-type": "text/csv"})
    assert ok.status_code == 200 and ok.json()["points"] == len(ct)
    # the same surveys as JSON ({"controls": [...]} or a list) change nothing
    for body in ({"controls": ct.to_dict("records")}, ct.to_dict("records")):
        same = client.put("/api/v1/sites/mitt/controls", json=body, headers=eng)
        assert same.status_code == 200 and same.json()["changed"] == []
    bad = client.put("/api/v1/sites/mitt/controls", json=[{**GOOD, "x_m": 999}], headers=eng)
    assert bad.status_code == 422 and "outside the sensors' span" in bad.json()["detail"]
    recompute(db, "mitt")
    got = client.get("/api/v1/sites/mitt/controls", headers=viewer).json()
    assert len(got["controls"]) == len(ct)
    assert_same_comparison(pd.DataFrame(got["comparison"]), reference_comparison(ct))
    login(client, "viewer1", "viewer1-password")
    page = client.get("/sites/mitt")
    assert page.status_code == 200 and 'id="control-table"' in page.text and "2019-11-24" in page.text
    client.cookies.clear()
    assert client.delete("/api/v1/sites/mitt/controls/2019-11-21", headers=viewer).status_code == 403
    assert client.delete("/api/v1/sites/mitt/controls/2019-11-21", headers=eng).status_code == 200
    assert client.delete("/api/v1/sites/mitt/controls/2019-11-21", headers=eng).status_code == 404
    assert client.delete("/api/v1/sites/mitt/controls/..%2Fx", headers=eng).status_code == 404


def test_the_cli_stores_a_controls_file_as_rail_settle_reads_it(loaded, tmp_path, monkeypatch):
    import typer
    from typer.testing import CliRunner

    from longprofile.cli._rail_serve import register

    db, _, _ = loaded
    monkeypatch.setattr("longprofile.cli._rail_serve._db", lambda url: db)  # one engine (PostgreSQL: closed at the end)
    app = typer.Typer()
    register(app)
    runner = CliRunner()
    ct = control_table()
    ct.to_csv(tmp_path / "controls.csv", index=False)
    res = runner.invoke(app, ["site", "controls", "mitt", "--file", str(tmp_path / "controls.csv"), "--db", db.url,
                              "--actor", "dave"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["dates"] == ["2019-11-21", "2019-11-24"]
    assert recompute(db, "mitt")["status"] == "ok"
    assert_same_comparison(stored_comparison(db), reference_comparison(pd.read_csv(tmp_path / "controls.csv")))
    res = runner.invoke(app, ["site", "controls", "mitt", "--delete", "2019-11-21", "--db", db.url])
    assert res.exit_code == 0 and json.loads(res.stdout)["deleted"] == "2019-11-21"
    res = runner.invoke(app, ["site", "controls", "mitt", "--db", db.url])
    assert isinstance(res.exception, LongprofileError) and "--file" in str(res.exception)
    pd.DataFrame([{**GOOD, "x_m": 500.0}]).to_csv(tmp_path / "bad.csv", index=False)
    res = runner.invoke(app, ["site", "controls", "mitt", "--file", str(tmp_path / "bad.csv"), "--db", db.url])
    assert isinstance(res.exception, LongprofileError) and "outside the sensors' span" in str(res.exception)


def test_the_site_page_shows_the_runs_warnings_and_a_control_disagreement(loaded):
    """The warnings `rail settle` prints are on the site page (they were stored, not shown); control surveys that
    contradict the estimate add theirs."""
    import html

    from longprofile.rail.service._db import Run

    db, _, _ = loaded
    _core.add_user(db, "tester", "viewer1", "viewer1-password", "viewer")
    client = TestClient(create_app(db, background=False))
    login(client, "viewer1", "viewer1-password")

    def shown():
        with db.read() as s:
            run = s.scalars(select(Run).where(Run.status == "ok").order_by(Run.id.desc())).first()
            stored = json.loads(run.warnings_json)
        page = client.get("/sites/mitt").text
        assert stored and 'id="warning-list"' in page
        assert all(html.escape(w, quote=False) in page.replace("&#39;", "'").replace("&#34;", '"') for w in stored)
        return stored

    assert not any("control surveys disagree" in w for w in shown())
    _core.put_controls(db, "eng", "mitt", control_table(drop_mm=(2.0, 40.0)).to_dict("records"))
    recompute(db, "mitt")
    assert any(w.startswith("the control surveys disagree with the estimate") for w in shown())


def test_a_survey_in_millimetres_is_refused(site):
    """put_survey checks units as rail settle checks a survey file (rail.check_survey): altitudes in mm under z_m."""
    db, _, _ = site
    before = _core.get_site(db, "mitt")["survey"]
    rows = [{"x_m": float(x), "z_m": 210000.0 + x} for x in range(0, 170, 10)]
    with pytest.raises(LongprofileError, match="beyond any terrain"):
        _core.put_survey(db, "eng", "mitt", rows)
    assert _core.get_site(db, "mitt")["survey"] == before and len(before) > 2
