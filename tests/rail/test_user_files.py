"""A track engineer's own files (session 35, a probe of `rail settle` with realistic variations): time stamps with
UTC offsets that change at a DST switch, a first day that is only part of a day, a stray reading years away, days
without readings, ids that are text, angles in milliradians under angle_deg, and heave in the summary."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from longprofile.errors import InputError, InputFormatError
from longprofile.rail import SettlementSettings, estimate_settlement, simulate_site, validate_site


@pytest.fixture(scope="module")
def syn():
    return simulate_site("mittersheim-like", seed=4, sampling_minutes=60, n_days=8)


def _settle(syn, readings, **kw):
    site = validate_site(syn.sensors, readings, syn.survey)
    return estimate_settlement(site, settings=SettlementSettings(n_monte_carlo=0, **kw))


@pytest.fixture(scope="module")
def plain(syn):
    return _settle(syn, syn.readings)


def test_utc_offsets_that_change_at_a_dst_switch_are_the_same_instants(syn):
    r = syn.readings.copy()
    t = pd.to_datetime(r["timestamp"])
    summer = np.arange(len(r)) % 2 == 0  # any mix of +02:00 and +01:00 (pandas refused the mix: a traceback)
    local = np.where(summer, (t + pd.Timedelta(hours=2)).dt.strftime("%Y-%m-%dT%H:%M:%S+02:00"),
                     (t + pd.Timedelta(hours=1)).dt.strftime("%Y-%m-%dT%H:%M:%S+01:00"))
    site = validate_site(syn.sensors, r.assign(timestamp=local), syn.survey)
    ref = validate_site(syn.sensors, r, syn.survey)
    assert site.readings["timestamp"].equals(ref.readings["timestamp"])


def test_times_with_and_without_an_offset_are_refused_in_one_line(syn):
    r = syn.readings.copy()
    t = pd.to_datetime(r["timestamp"]).dt.strftime("%Y-%m-%dT%H:%M:%S")
    mixed = t.where(np.arange(len(r)) < len(r) // 2, t + "Z")
    with pytest.raises(InputFormatError, match="mixes times with a UTC offset .* and without one"):
        validate_site(syn.sensors, r.assign(timestamp=mixed), syn.survey)


def _shifted(readings, first_rows, hours):
    head = readings.iloc[:first_rows].copy()
    head["timestamp"] = pd.to_datetime(head["timestamp"]) - pd.Timedelta(hours=hours)
    return pd.concat([head, readings], ignore_index=True)


@pytest.mark.parametrize(("rows", "hours"), [(58, 6), (1, 24 * 365 * 19)])  # installation tests; a clock reset
def test_a_first_day_with_few_readings_is_left_out_and_the_next_is_the_reference(syn, plain, rows, hours):
    res = _settle(syn, _shifted(syn.readings, rows, hours))
    assert res.days[0] == plain.days[0] and res.days.size == plain.days.size
    assert any("is the reference day" in w for w in res.warnings)
    # the extra readings still count in each sensor's thermal fit: close to, not equal to, the record without them
    ok = np.isfinite(plain.dz_std[1:]) & (plain.dz_std[1:] > 0)
    assert np.max(np.abs(res.dz - plain.dz)[1:][ok] / plain.dz_std[1:][ok]) < 0.5


def test_the_rate_after_days_without_readings_is_per_calendar_day(syn):
    t = pd.to_datetime(syn.readings["timestamp"])
    days = t.dt.normalize().unique()
    gap = syn.readings[~t.dt.normalize().isin(days[3:5])]  # two whole days without any reading
    res = _settle(syn, gap)
    sm = res.smoothed
    step = np.diff(res.days.astype("datetime64[D]")).astype(float)
    assert step.max() == 3.0 and any("calendar day(s) without readings" in w for w in res.warnings)
    np.testing.assert_allclose(sm.rate[1:] * step[:, None], np.diff(sm.mean, axis=0), rtol=1e-12, atol=1e-15)


def test_an_empty_sensor_id_is_refused_with_its_row(syn):
    r = syn.readings.copy()
    r["sensor_id"] = r["sensor_id"].astype(object)
    r.loc[7, "sensor_id"] = None
    with pytest.raises(InputError, match="readings table, row 7 .*the sensor_id is empty"):
        validate_site(syn.sensors, r, syn.survey)


def test_ids_are_text_in_the_files(syn, tmp_path):
    from longprofile.io import read_rail_site

    names = {s: n for s, n in zip(syn.sensors["sensor_id"], ["NA", "007", "null"])}
    s = syn.sensors.assign(sensor_id=syn.sensors["sensor_id"].replace(names))
    r = syn.readings.assign(sensor_id=syn.readings["sensor_id"].replace(names))
    s.to_csv(tmp_path / "s.csv", index=False)
    r.to_csv(tmp_path / "r.csv", index=False)
    syn.survey.to_csv(tmp_path / "v.csv", index=False)
    site = read_rail_site(tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "v.csv")
    assert {"NA", "007", "null"} <= set(site.sensor_ids)
    assert (site.readings["sensor_id"] == "NA").sum() == (syn.readings["sensor_id"] == syn.sensors["sensor_id"][0]).sum()


def test_angles_in_milliradians_under_angle_deg_get_a_warning(syn, plain):
    assert not any("milliradians" in w.lower() for w in plain.warnings)
    mrad = syn.readings.assign(angle_deg=np.deg2rad(syn.readings["angle_deg"]) * 1e3)
    res = _settle(syn, mrad)
    assert np.nanmax(np.abs(res.dz)) > 0.1
    assert any("Milliradians or mm/m under angle_deg" in w for w in res.warnings)


def test_the_summary_names_heave(syn, tmp_path, capsys):
    """Angles of the other sign (or stations counted from the other end) give heave; the summary said "max settlement
    on the last day 0.0 mm" next to the alarms."""
    from longprofile.cli.app import main

    syn.sensors.to_csv(tmp_path / "s.csv", index=False)
    syn.readings.assign(angle_deg=-syn.readings["angle_deg"]).to_csv(tmp_path / "r.csv", index=False)
    syn.survey.to_csv(tmp_path / "v.csv", index=False)
    assert main(["rail", "settle", "--sensors", str(tmp_path / "s.csv"), "--readings", str(tmp_path / "r.csv"),
                 "--survey", str(tmp_path / "v.csv"), "-o", str(tmp_path / "o.csv"), "--monte-carlo", "0"]) == 0
    cap = capsys.readouterr()
    assert "max settlement on the last day 0.0 mm, max heave" in " ".join((cap.out + cap.err).split())
