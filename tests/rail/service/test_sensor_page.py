"""The per-sensor time series page shows angle and temperature besides the settlement: the daily statistics it
plots are ``rail.day_statistics`` of the sensor's stored readings (oracle), from the day cache or, for the lagged
thermal model (no cache), computed from the readings."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from sqlalchemy import select

from longprofile.errors import InputError
from longprofile.rail import day_statistics, validate_site
from longprofile.rail.service import _core
from longprofile.rail.service._recompute import REFERENCE_TEMP_C, recompute, sensor_daily_statistics

from .conftest import synthetic
from .test_api import login


def _oracle(sensor):
    syn, r = synthetic()
    readings = validate_site(syn.sensors, r, syn.survey).readings
    one = readings[readings["sensor_id"] == sensor]
    st = day_statistics(one, [sensor], thermal="linear", reference_temp_c=REFERENCE_TEMP_C)
    n_t = st.n_temperature[:, 0]
    # the oracle's own mean temperature: the readings' mean per UTC day (not the statistics' sums)
    mean_t = one.groupby(one["timestamp"].dt.strftime("%Y-%m-%d"))["temperature_c"].mean()
    return st, n_t, mean_t


def _daily(db, sensor):
    with db.read() as s:
        st = s.scalar(select(_core.Site).where(_core.Site.name == "mitt"))
        return sensor_daily_statistics(s, st, sensor)


@pytest.mark.parametrize("thermal", ["linear", "lagged"])
def test_daily_angle_and_temperature_are_day_statistics_of_the_sensors_readings(site, thermal):
    db, _, r = site
    if thermal == "lagged":
        _core.update_site(db, "t", "mitt", settings={"thermal": "lagged"})
    _core.ingest(db, "mitt", r.to_dict("records"))
    assert recompute(db, "mitt")["status"] == "ok"
    for sensor in ("S01", "S20", "S58"):
        got = _daily(db, sensor)
        st, n_t, mean_t = _oracle(sensor)
        assert list(got["day"]) == list(pd.DatetimeIndex(st.days).strftime("%Y-%m-%d"))
        np.testing.assert_array_equal(got["n_raw"], st.n_raw[:, 0])
        np.testing.assert_array_equal(got["raw_median_deg"], st.raw_median_deg[:, 0])
        np.testing.assert_allclose(got["mean_temp_c"], mean_t.reindex(got["day"]).to_numpy(), rtol=1e-12)
        np.testing.assert_allclose(got["temp_range_c"], st.temp_range_c[:, 0], rtol=1e-12, equal_nan=True)
        if thermal == "linear":  # the estimate's corrected medians (the cache's); none for the lagged model
            np.testing.assert_allclose(got["median_deg"], st.median_deg[:, 0], rtol=0, atol=1e-9)
        else:
            assert got["median_deg"].isna().all()
    with pytest.raises(InputError, match="unknown sensor"):
        _daily(db, "NOPE")


def test_the_sensor_figure_has_the_three_panels(site, monkeypatch):
    """The PNG route draws the settlement, angle and temperature panels (checked on the figure before encoding)."""
    from fastapi.testclient import TestClient

    from longprofile.rail.service import _web
    from longprofile.rail.service._web import create_app

    db, _, r = site
    _core.ingest(db, "mitt", r.to_dict("records"))
    recompute(db, "mitt")
    _core.add_user(db, "t", "v1", "v1-password", "viewer")
    seen = []
    real = _web._fig_png
    monkeypatch.setattr(_web, "_fig_png", lambda fig: (seen.append(fig), real(fig))[1])
    client = TestClient(create_app(db, background=False))
    login(client, "v1", "v1-password")
    png = client.get("/sites/mitt/sensors/S20/series.png")
    assert png.status_code == 200 and png.content[:4] == b"\x89PNG"
    axes = seen[-1].axes
    assert [a.get_ylabel() for a in axes] == ["altitude change (mm)", "angle (deg)", "temperature (°C)"]
    daily = _daily(db, "S20")
    x, y = axes[1].lines[0].get_data()
    np.testing.assert_array_equal(np.asarray(y, float), daily["raw_median_deg"].to_numpy())
    x, y = axes[2].lines[0].get_data()
    np.testing.assert_array_equal(np.asarray(y, float), daily["mean_temp_c"].to_numpy())
