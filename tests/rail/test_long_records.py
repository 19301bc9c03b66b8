"""Sensor health on long records (issue 13, step 18): the site's own null for the all-days reversal evidence and the
day-to-day ratio's thresholds grown with the record's length."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import ndtri

from longprofile.errors import InputError
from longprofile.rail import estimate_settlement, validate_site
from longprofile.rail._health import (
    NULL_BASELINE_MEDIAN,
    NULL_BASELINE_SPREAD,
    REFERENCE_CHANGES,
    REVERSED_ALL_DAYS_LBF,
    ReversalEvidence,
    assess_sensors,
    record_length_factor,
    site_reversal_null,
)
from longprofile.rail._scenarios import SCENARIO_FAMILIES, simulate_scenario


def _evidence(s, info):
    """Evidence whose standardised values (log BF + 2 I) / (2 sqrt I) are ``s``."""
    return ReversalEvidence(log_bayes_factor=2.0 * np.sqrt(info) * s - 2.0 * info, information=info)


def _quantiles(n):
    return ndtri((np.arange(n) + 0.5) / n)


def test_a_site_within_the_baseline_keeps_the_models_evidence():
    n = 40
    s = NULL_BASELINE_MEDIAN + NULL_BASELINE_SPREAD * _quantiles(n)
    ev = _evidence(s, np.linspace(1.0, 30.0, n))
    assert site_reversal_null(ev, np.ones(n, bool)) is ev
    few = _evidence(5.0 + 4.0 * _quantiles(7), np.full(7, 10.0))  # too few sensors to say
    assert site_reversal_null(few, np.ones(7, bool)) is few


@settings(max_examples=40, deadline=None)
@given(centre=st.floats(3.0, 5.0), spread=st.floats(1.0, 3.0), n=st.integers(20, 60), seed=st.integers(0, 2**31))
def test_the_site_null_is_the_model_with_the_healthy_centre_moved_and_the_variance_scaled(centre, spread, n, seed):
    rng = np.random.default_rng(seed)
    info = rng.uniform(0.5, 40.0, n)
    s = centre + spread * rng.permutation(_quantiles(n))
    ev = _evidence(s, info)
    out = site_reversal_null(ev, np.ones(n, bool))
    assert out.null_shift > 0 and out.null_scale >= 1
    # the corrected evidence is that of a model whose standardised value is (s - shift) / scale
    s_out = (out.log_bayes_factor + 2 * out.information) / (2 * np.sqrt(out.information))
    np.testing.assert_allclose(s_out, (s - out.null_shift) / out.null_scale, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(out.information, info / out.null_scale**2)
    # what is left of the healthy centre's excess is within two of its standard errors of the baseline
    d = np.median(s)
    se = 1.2533 * 1.4826 * np.median(np.abs(s - d)) / np.sqrt(n)
    assert np.median(s_out) <= NULL_BASELINE_MEDIAN + 2 * se + 1e-9
    pos = out.log_bayes_factor > 0  # no sensor gets more evidence of a reversal than it had
    assert np.all(out.log_bayes_factor[pos] <= ev.log_bayes_factor[pos] + 1e-9)


def test_the_site_null_cuts_the_healthy_tail_and_keeps_a_clear_reversal():
    n = 40
    info = np.full(n, 16.0)
    s = 2.7 + 2.2 * _quantiles(n)  # the healthy sensors of a year's drift site (session 31)
    lbf = 2.0 * np.sqrt(info) * s - 2.0 * info
    lbf[7] = 2.0 * info[7] + 1.0  # one reversed sensor: + 2 I
    kept = np.ones(n, bool)
    ev = ReversalEvidence(log_bayes_factor=lbf, information=info)
    out = site_reversal_null(ev, kept)
    healthy = np.arange(n) != 7
    before = (ev.log_bayes_factor[healthy] > REVERSED_ALL_DAYS_LBF).sum()
    after = (out.log_bayes_factor[healthy] > REVERSED_ALL_DAYS_LBF).sum()
    assert before >= 6 and after <= before / 3, (before, after)  # the 2-standard-error tolerance keeps a few
    assert out.log_bayes_factor[7] > REVERSED_ALL_DAYS_LBF
    partly = kept.copy()
    partly[:5] = False  # sensors the health tests excluded do not enter the null
    assert site_reversal_null(replace(ev, log_bayes_factor=np.where(partly, lbf, np.nan)), partly).null_shift > 0


def test_record_length_factor_is_one_on_the_calibration_records_and_grows_as_the_cube_root():
    n = np.array([0, 5, 20, REFERENCE_CHANGES, 2 * REFERENCE_CHANGES, 8 * REFERENCE_CHANGES, 364])
    f = record_length_factor(n)
    np.testing.assert_array_equal(f[:4], 1.0)
    np.testing.assert_allclose(f[4:], [2 ** (1 / 3), 2.0, (364 / REFERENCE_CHANGES) ** (1 / 3)])
    assert np.all(np.diff(f) >= 0)


def test_assess_sensors_checks_its_reversal_null():
    with pytest.raises(InputError, match="reversal_null"):
        assess_sensors(np.arange(6.0), np.zeros((8, 6)), sigma=1e-5, rigidity=1e-9, sigma_z=1e-3,
                       reversal_null="empirical")


LONG = dict(n_sensors=(16, 20), n_days=(180, 180), sampling_minutes=60.0)


def _healthy_flagged(res, sc) -> int:
    return sum(1 for j, sid in enumerate(res.sensor_ids) if res.health.excluded[j] and sid not in sc.truth.faults)


def test_half_a_year_of_readings_flags_fewer_healthy_sensors_than_the_models_null():
    """Drifting sites read hourly for 180 days (seeds 900-907, not used to choose anything): the model's null flags
    healthy sensors there (the thresholds were set on 3-4-week records); the site's null and the length factor at
    most half as many (on seeds 300-339 of the study, 28 -> 7 of 1113)."""
    fam = replace(SCENARIO_FAMILIES["drift"], **LONG)
    site_rule, model_rule, n = 0, 0, 0
    for seed in range(900, 908):
        sc = simulate_scenario(fam, seed)
        site = validate_site(sc.sensors, sc.readings, sc.survey)
        res = estimate_settlement(site, n_monte_carlo=0, through_time=False)
        old = estimate_settlement(site, n_monte_carlo=0, through_time=False, reversal_null="model")
        site_rule += _healthy_flagged(res, sc)
        model_rule += _healthy_flagged(old, sc)
        n += len(res.sensor_ids)
    assert model_rule >= 3, (model_rule, n)
    assert site_rule <= model_rule / 2, (site_rule, model_rule)


def test_a_reversed_sensor_on_half_a_year_of_readings_is_still_found():
    fam = replace(SCENARIO_FAMILIES["faults"], **LONG)
    found = total = 0
    for seed in range(900, 904):
        sc = simulate_scenario(fam, seed)
        res = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=0,
                                  through_time=False)
        status = dict(zip(res.sensor_ids, res.health.status))
        for sid, kind in sc.truth.faults.items():
            if kind == "reversed":
                total += 1
                found += status[sid] == "reversed"
    assert total == 4 and found >= 3, (found, total)
