"""Runs of consecutive excluded sensors: the settlement there is the prior's interpolation, and the output says so."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from longprofile.rail import estimate_settlement, validate_site
from longprofile.rail._scenarios import simulate_scenario
from longprofile.rail._settle import GAP_WARN_SENSORS, _gap_warnings


@given(st.lists(st.booleans(), min_size=1, max_size=40))
def test_one_warning_per_run_of_enough_excluded_sensors(mask):
    ids = [f"S{i:02d}" for i in range(len(mask))]
    x = np.arange(len(mask), dtype=float) * 1.5
    got = _gap_warnings(x, ids, mask)
    runs, i = [], 0
    for excluded, group in itertools.groupby(mask):
        n = len(list(group))
        if excluded and n >= GAP_WARN_SENSORS:
            runs.append((i, i + n - 1))
        i += n
    assert len(got) == len(runs)
    for w, (a, b) in zip(got, runs):
        assert w.startswith(f"{b - a + 1} consecutive sensors excluded ({ids[a]} to {ids[b]},")
        assert ("the span's start" in w) == (a == 0) and ("the span's end" in w) == (b == len(mask) - 1)


def test_a_dead_logger_is_named_and_a_short_gap_is_not():
    """Four consecutive sensors without readings (a logger that died) get the warning; three do not."""
    sc = simulate_scenario("drift", 11, n_days=(8, 8))
    ids = list(sc.sensors["sensor_id"])
    for k, expected in ((GAP_WARN_SENSORS, 1), (GAP_WARN_SENSORS - 1, 0)):
        gone = ids[6:6 + k]
        site = validate_site(sc.sensors, sc.readings[~sc.readings["sensor_id"].isin(gone)], sc.survey)
        res = estimate_settlement(site, n_monte_carlo=0)
        gaps = [w for w in res.warnings if "consecutive sensors excluded" in w]
        assert len(gaps) == expected, res.warnings
        if expected:
            assert f"({gone[0]} to {gone[-1]}," in gaps[0] and f"between {ids[5]} and {ids[6 + k]}" in gaps[0]
