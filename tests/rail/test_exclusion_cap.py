"""The health tests' limit (a quarter of the sensors they examine) leaves out the user's exclusions: a user who excludes
sensors they know are bad leaves the tests the same room to find the others (docs/rail.md, "Sensor health")."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.rail import USER_EXCLUDED, estimate_settlement, validate_site
from longprofile.rail._health import SensorHealth, _flag_worst
from longprofile.rail._scenarios import SHAPE_FAMILIES, simulate_scenario


def _health(status):
    status = np.array(status, dtype=object).astype(str)
    n = status.size
    return SensorHealth(sensor_ids=[f"S{i}" for i in range(n)], status=status, detail=np.full(n, "", dtype=str),
                        excluded=status != "ok", loo_score=np.zeros(n))


@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_an_excluded_sensor_counts_as_one_that_is_not_there(data):
    """Oracle: the all-days stage flags on a site with user exclusions exactly when it flags on the same site without
    those sensors at all (an excluded sensor is not examined, so it neither uses up nor widens the limit)."""
    n = data.draw(st.integers(8, 40))
    kinds = data.draw(st.lists(st.sampled_from(["ok", "ok", "ok", "dead", "late", "reversed", "detached",
                                                USER_EXCLUDED]), min_size=n, max_size=n))
    kinds[data.draw(st.integers(0, n - 1))] = "ok"  # at least one candidate
    ok = [i for i, k in enumerate(kinds) if k == "ok"]
    passes = np.zeros(n, bool)
    passes[sorted(data.draw(st.sets(st.sampled_from(ok), min_size=1)))] = True
    score = np.asarray(data.draw(st.lists(st.floats(0, 100), min_size=n, max_size=n)))
    _, j = _flag_worst(_health(kinds), score, passes, "reversed", lambda j: "", None)
    keep = np.array([k != USER_EXCLUDED for k in kinds])
    _, j_without = _flag_worst(_health([k for k in kinds if k != USER_EXCLUDED]), score[keep], passes[keep],
                               "reversed", lambda j: "", None)
    assert (j is None) == (j_without is None)
    if j is not None:
        assert j == np.flatnonzero(keep)[j_without]


def test_a_fault_found_by_the_all_days_tests_is_still_found_when_the_user_excludes_sensors():
    """faults-tilt seed 7 (18 sensors, limit 4): the reversed I003 is found by the all-days test after two day-to-day
    flags; with two sensors the user excluded counted among the flags (until session 38) the limit was reached and
    I003 kept, its reversed angles in the settlement."""
    sc = simulate_scenario(SHAPE_FAMILIES["faults-tilt"], 7, n_sensors=(16, 18), n_days=(14, 16),
                           sampling_minutes=60.0)
    assert sc.truth.faults["I003"] == "reversed"
    site = validate_site(sc.sensors, sc.readings, sc.survey)
    res = estimate_settlement(site, exclude_sensors=("I015", "I016"))
    status = dict(zip(res.health.sensor_ids, res.health.status))
    assert status["I015"] == status["I016"] == USER_EXCLUDED
    assert status["I003"] == "reversed"
    assert not any("stopped at their limit" in w for w in res.warnings)
