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


def _viewer_seeing_figures(db, monkeypatch):
    """A logged-in viewer's test client, and the list every figure the app encodes is appended to."""
    from fastapi.testclient import TestClient

    from longprofile.rail.service import _web
    from longprofile.rail.service._web import create_app

    _core.add_user(db, "t", "v1", "v1-password", "viewer")
    seen = []
    real = _web._fig_png
    monkeypatch.setattr(_web, "_fig_png", lambda fig: (seen.append(fig), real(fig))[1])
    client = TestClient(create_app(db, background=False))
    login(client, "v1", "v1-password")
    return client, seen


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
    db, _, r = site
    _core.ingest(db, "mitt", r.to_dict("records"))
    recompute(db, "mitt")
    client, seen = _viewer_seeing_figures(db, monkeypatch)
    png = client.get("/sites/mitt/sensors/S20/series.png")
    assert png.status_code == 200 and png.content[:4] == b"\x89PNG"
    axes = seen[-1].axes
    assert [a.get_ylabel() for a in axes] == ["altitude change (mm)", "angle (deg)", "temperature (°C)"]
    daily = _daily(db, "S20")
    x, y = axes[1].lines[0].get_data()
    np.testing.assert_array_equal(np.asarray(y, float), daily["raw_median_deg"].to_numpy())
    x, y = axes[2].lines[0].get_data()
    np.testing.assert_array_equal(np.asarray(y, float), daily["mean_temp_c"].to_numpy())


def test_a_failed_or_stuck_temperature_channel_is_said_on_the_sensor_page(site, monkeypatch):
    """S20 sends no temperature from the fourth day on and S21 one constant value from the third: the page says so
    (counts from the stored readings), and the figure circles those days, whose plotted temperature is the one the
    estimate used (the neighbours')."""
    db, _, r = site
    days = r["timestamp"].str[:10]
    ud = sorted(days.unique())
    r = r.copy()
    empty = ((r["sensor_id"] == "S20") & (days >= ud[3])).to_numpy()
    held = ((r["sensor_id"] == "S21") & (days >= ud[2])).to_numpy()
    r.loc[empty, "temperature_c"] = np.nan
    r.loc[held, "temperature_c"] = 7.25
    _core.ingest(db, "mitt", r.to_dict("records"))
    assert recompute(db, "mitt")["status"] == "ok"
    s20, s21, s22 = _daily(db, "S20"), _daily(db, "S21"), _daily(db, "S22")
    assert list(s20["n_no_temperature"] > 0) == [d >= ud[3] for d in s20["day"]]
    assert s20["n_no_temperature"].sum() == empty.sum()
    assert list(s21["constant_temperature"]) == [d >= ud[2] for d in s21["day"]]
    assert s22["n_no_temperature"].sum() == 0 and not s22["constant_temperature"].any()
    assert np.isfinite(s20["mean_temp_c"]).all()  # the neighbours' temperature, as the estimate used it
    client, seen = _viewer_seeing_figures(db, monkeypatch)
    page = client.get("/sites/mitt/sensors/S20").text
    assert 'id="temperature-channel"' in page and f"{int(empty.sum())} reading(s) without a temperature" in page
    assert 'id="temperature-channel"' not in client.get("/sites/mitt/sensors/S22").text
    assert "constant value all day on" in client.get("/sites/mitt/sensors/S21").text
    assert client.get("/sites/mitt/sensors/S20/series.png").status_code == 200
    labels = [t.get_text() for t in seen[-1].axes[2].get_legend().get_texts()]
    assert any("empty or constant: the neighbours'" in lab for lab in labels)


def test_the_sensor_figure_marks_its_declared_events(site, monkeypatch):
    """A re-installed sensor's series has a dashed line at its event's day on each panel, labelled; another
    sensor's has none."""
    from longprofile.rail.service._events import put_events

    db, _, r = site
    put_events(db, "t", "mitt", [{"sensor_id": "S20", "date": "2019-11-22", "event": "reinstalled"}])
    _core.ingest(db, "mitt", r.to_dict("records"))
    assert recompute(db, "mitt")["status"] == "ok"
    client, seen = _viewer_seeing_figures(db, monkeypatch)
    assert client.get("/sites/mitt/sensors/S20/series.png").status_code == 200
    for ax in seen[-1].axes:
        assert [pd.Timestamp(ln.get_xdata()[0]) for ln in ax.lines if ln.get_linestyle() == "--"] == [
            pd.Timestamp("2019-11-22")]
    assert "re-installed" in [t.get_text() for t in seen[-1].axes[0].texts]
    assert client.get("/sites/mitt/sensors/S21/series.png").status_code == 200
    assert not [ln for ln in seen[-1].axes[0].lines if ln.get_linestyle() == "--"]
