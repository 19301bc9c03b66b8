"""A sensor installed (or first read) after the reference day: "late", left out, never read as "no change before".

Its changes exist only from its own first day; taken as changes since the reference day they would claim that the
track did not move before it. The oracle: the site estimated with the late sensor equals the site estimated with
that sensor left out by the user (it contributes nothing), and the status and warning name the day and the way in.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from longprofile.rail import SettlementSettings, estimate_settlement, simulate_site, validate_site


@pytest.fixture(scope="module")
def site():
    return simulate_site("mittersheim-like", seed=2, sampling_minutes=60.0, n_days=12)


def _estimate(syn, readings, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return estimate_settlement(validate_site(syn.sensors, readings, syn.survey),
                                   settings=SettlementSettings(n_monte_carlo=0, **kw))


@pytest.mark.parametrize("first_day", [1, 3, 5])
def test_a_late_sensor_is_left_out_as_late(site, first_day):
    r = site.readings
    t = pd.to_datetime(r["timestamp"])
    late = r[~((r.sensor_id == "S20") & (t < t.min().normalize() + pd.Timedelta(days=first_day)))]
    res = _estimate(site, late)
    j = list(res.sensor_ids).index("S20")
    assert res.health.status[j] == "late" and bool(res.health.excluded[j])
    assert f"its first on day {first_day} of" in res.health.detail[j]
    assert any("S20 excluded (late)" in w for w in res.warnings)
    alone = _estimate(site, r, exclude_sensors=("S20",))
    # equal to a micrometre (its own day-to-day changes still enter the noise fits, as any reading does)
    np.testing.assert_allclose(res.dz, alone.dz, rtol=0, atol=1e-6)
    np.testing.assert_allclose(res.dz_std, alone.dz_std, rtol=0, atol=1e-6)
