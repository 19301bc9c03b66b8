"""A sensor the user excluded has its own status, "excluded" (it was "improbable", a failed health test's status, with
"excluded by the user" only in the detail); every status the health tests give is one of ``SENSOR_STATUSES``."""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from longprofile.cli.app import app
from longprofile.rail import SENSOR_STATUSES, UNUSABLE_STATUSES, USER_EXCLUDED, assess_sensors


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(6, 12), data=st.data())
def test_the_users_exclusions_are_excluded_not_a_health_verdict(seed, n, data):
    rng = np.random.default_rng(seed)
    slopes = np.cumsum(rng.normal(0, 1e-5, (8, n)), axis=0)
    slopes[:, rng.integers(0, n)] = np.nan  # one sensor without readings: dead whatever the user says
    user = data.draw(st.sets(st.integers(0, n - 1), max_size=3))
    health, _, _ = assess_sensors(np.arange(n) * 3.0, slopes, sigma=1e-5, rigidity=1e-9, sigma_z=1e-3,
                                  exclude=sorted(user))
    assert set(health.status) <= set(SENSOR_STATUSES)
    for j in range(n):
        if j in user:
            assert health.status[j] == USER_EXCLUDED and health.detail[j] == "excluded by the user"
            assert health.excluded[j]
        else:
            assert health.status[j] != USER_EXCLUDED
    assert USER_EXCLUDED not in UNUSABLE_STATUSES  # counted as before where the health tests count their flags


def test_rail_settle_exclude_gives_the_status_excluded(tmp_path):
    run = CliRunner()
    site = tmp_path / "site"
    res = run.invoke(app, ["rail", "simulate", "--preset", "mittersheim-like", "-o", str(site), "--days", "6",
                           "--sampling-minutes", "120", "--seed", "2"])
    assert res.exit_code == 0, res.output
    out = tmp_path / "s.csv"
    res = run.invoke(app, ["rail", "settle", "--sensors", str(site / "sensors.csv"), "--readings",
                           str(site / "readings.csv"), "--survey", str(site / "survey.csv"), "--exclude", "S20",
                           "--monte-carlo", "0", "-o", str(out), "--report", str(tmp_path / "report")])
    assert res.exit_code == 0, res.output
    table = pd.read_csv(out)
    assert set(table.loc[table.sensor_id == "S20", "status"]) == {"excluded"}
    assert "excluded" not in set(table.loc[table.sensor_id != "S20", "status"])
    sensors = pd.read_csv(tmp_path / "report" / "sensors.csv")
    row = sensors[sensors.sensor_id == "S20"].iloc[0]
    assert row.status == "excluded" and row.detail == "excluded by the user"
    assert "sensor S20 excluded by the user." in " ".join(res.output.split())
    assert "(improbable)" not in res.output


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), first=st.integers(0, 6))
def test_a_sensor_stuck_after_days_of_normal_readings_is_frozen_and_stuck_from_the_start_is_dead(seed, first):
    """Stuck from day ``first`` on, for more than half the record: its robust spread over the record is under the
    resolution, as a stuck sensor's. Frozen when it read normally before (first > 0), dead when stuck from day 0;
    left out either way."""
    rng = np.random.default_rng(seed)
    D, N, j = 16, 10, 4
    slopes = np.cumsum(rng.normal(0, 1e-6, (D, N)), axis=0)
    day_spread = np.full((D, N), 2e-3)
    day_spread[first:, j] = 0.0
    raw_spread = np.full(N, 1e-2)
    raw_spread[j] = 0.0
    health, _, _ = assess_sensors(np.arange(N) * 3.0, slopes, sigma=1e-6, rigidity=1e-9, sigma_z=1e-3,
                                  raw_spread_deg=raw_spread, raw_day_spread_deg=day_spread, max_flagged=0)
    if first == 0:
        assert health.status[j] == "dead" and health.detail[j].startswith("stuck")
    else:
        assert health.status[j] == "frozen" and f"from day {first} on" in health.detail[j]
    assert health.excluded[j] and health.status[j] in UNUSABLE_STATUSES
    assert list(health.status).count("ok") == N - 1
