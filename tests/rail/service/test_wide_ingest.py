"""A logger's wide export (one column per sensor) loaded with ``rail site ingest --file``: read by the function that
reads ``rail settle --readings`` (the site's sensor ids name the columns), stored as the long file's readings; the
API, whose outcome is per row of the batch, refuses a wide CSV batch and says where to load it."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import typer
from fastapi.testclient import TestClient
from typer.testing import CliRunner

from longprofile.cli._rail_serve import register
from longprofile.rail.service._recompute import load_site_data
from longprofile.rail.service._web import create_app

from .conftest import synthetic


def test_a_wide_file_is_stored_as_its_long_table(site, tmp_path, monkeypatch):
    db, key, r = site
    syn, _ = synthetic()
    part = r[r["timestamp"].str[:10] <= "2019-11-19"]
    a = part.pivot(index="timestamp", columns="sensor_id", values="angle_deg")
    t = part.pivot(index="timestamp", columns="sensor_id", values="temperature_c")
    wide = np.concatenate([np.deg2rad(a.to_numpy()), t.to_numpy() + 273.15], axis=1)
    names = [f"{s} Angle [rad]" for s in a.columns] + [f"{s}_temperature_k" for s in t.columns]
    pd.DataFrame(wide, columns=names, index=a.index).reset_index().to_csv(tmp_path / "wide.csv", index=False)
    monkeypatch.setattr("longprofile.cli._rail_serve._db", lambda url, existing=False: db)
    app = typer.Typer()
    register(app)
    res = CliRunner().invoke(app, ["site", "ingest", "mitt", "--file", str(tmp_path / "wide.csv"), "--db", db.url])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["accepted"] == len(part)
    from longprofile.rail.service._core import _site

    with db.read() as s:
        _, got, _ = load_site_data(s, _site(s, "mitt"))
    got = got.sort_values(["sensor_id", "timestamp"]).reset_index(drop=True)
    want = part.assign(timestamp=pd.to_datetime(part["timestamp"]).dt.tz_localize(None)).sort_values(
        ["sensor_id", "timestamp"]).reset_index(drop=True)
    assert list(got["sensor_id"]) == list(want["sensor_id"])
    np.testing.assert_array_equal(got["timestamp"].to_numpy(), want["timestamp"].to_numpy())
    np.testing.assert_allclose(got["angle_deg"], want["angle_deg"], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(got["temperature_c"], want["temperature_c"], rtol=0, atol=1e-9)
    # the API takes one row per reading: a wide batch is refused whole, saying where to load it
    client = TestClient(create_app(db, background=False))
    body = a.iloc[:3].reset_index().to_csv(index=False)
    resp = client.post("/api/v1/sites/mitt/readings", content=body, headers={"content-type": "text/csv",
                                                                          "x-api-key": key})
    assert resp.status_code == 422 and "rail site ingest SITE --file" in resp.json()["detail"]
