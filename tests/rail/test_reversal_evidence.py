"""All-days reversal evidence (issue 13, sensor health step 11): the Bayes factor of "reversed" against "healthy"."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.rail import estimate_settlement, validate_site
from longprofile.rail._health import (
    REVERSED_ALL_DAYS_INC_LLR,
    REVERSED_ALL_DAYS_LBF,
    ReversalEvidence,
    SensorHealth,
    all_days_reversal_evidence,
    flag_reversed_all_days,
)
from longprofile.rail._rigidity import rigidity_log_likelihood
from longprofile.rail._scenarios import SCENARIO_FAMILIES, simulate_scenario

SMALL = dict(n_sensors=(16, 18), n_days=(14, 16), sampling_minutes=60.0)


def _modes(seed, N, K):
    rng = np.random.default_rng(seed)
    x = np.cumsum(np.r_[0.0, rng.uniform(2.0, 4.0, N - 1)])
    shape = np.gradient(-np.exp(-0.5 * ((x - x.mean()) / 6.0) ** 2), x) * 1e-2
    noise = rng.uniform(0.5, 3.0, K) * 1e-5
    Y = rng.uniform(0.2, 2.0, K)[:, None] * shape[None, :] + noise[:, None] * rng.normal(0, 1, (K, N))
    return x, Y, noise, rng.uniform(0.5, 2.0, N)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31), N=st.integers(6, 14), K=st.integers(1, 3), order=st.sampled_from([2, 3]))
def test_log_bayes_factor_is_the_likelihood_of_the_flipped_data_minus_that_of_the_data(seed, N, K, order):
    """Exactly log p(data with sensor i's sign flipped) - log p(data), summed over the independent modes."""
    x, Y, noise, f = _modes(seed, N, K)
    r = 1e-9 if order == 2 else 1e-11
    ev = all_days_reversal_evidence(x, Y, noise, rigidity=r, penalty_order=order, sensor_factors=f)
    ll = sum(rigidity_log_likelihood(x, Y[k], sigma=noise[k] * f, rigidity=r, penalty_order=order) for k in range(K))
    for i in (0, N // 2, N - 1):
        Yf = Y.copy()
        Yf[:, i] *= -1.0
        llf = sum(rigidity_log_likelihood(x, Yf[k], sigma=noise[k] * f, rigidity=r, penalty_order=order)
                  for k in range(K))
        # the engine's covariance-form filter loses ~5 digits of the stds (docs/rail.md, "Numerical note": 2e-5
        # relative), so the leverage-based identity and the two filter likelihoods agree to ~1e-5, not 1e-9
        assert ev.log_bayes_factor[i] == pytest.approx(llf - ll, rel=5e-5, abs=1e-4)
    assert np.all(ev.information >= 0)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31), i=st.integers(0, 9))
def test_flipping_a_sensor_flips_the_sign_of_its_evidence_only(seed, i):
    x, Y, noise, f = _modes(seed, 10, 2)
    a = all_days_reversal_evidence(x, Y, noise, rigidity=1e-9, sensor_factors=f)
    Yf = Y.copy()
    Yf[:, i] *= -1.0
    b = all_days_reversal_evidence(x, Yf, noise, rigidity=1e-9, sensor_factors=f)
    assert b.log_bayes_factor[i] == pytest.approx(-a.log_bayes_factor[i], rel=1e-9, abs=1e-9)
    assert b.information[i] == pytest.approx(a.information[i], rel=1e-9)


def test_excluded_sensors_get_no_evidence():
    x, Y, noise, f = _modes(1, 10, 2)
    Y[:, 4] = np.nan
    ev = all_days_reversal_evidence(x, Y, noise, rigidity=1e-9, sensor_factors=f)
    assert np.isnan(ev.log_bayes_factor[4]) and np.isnan(ev.information[4])
    assert np.all(np.isfinite(np.delete(ev.log_bayes_factor, 4)))


def _health(N, llr):
    return SensorHealth(sensor_ids=list(range(N)), status=np.array(["ok"] * N), detail=np.array([""] * N),
                        excluded=np.zeros(N, bool), loo_score=np.ones(N), reversal_llr=np.asarray(llr, float))


def test_flagging_needs_both_the_bayes_factor_and_the_day_to_day_ratio():
    N = 8
    lbf = np.full(N, -3.0)
    lbf[2] = REVERSED_ALL_DAYS_LBF + 1  # only the Bayes factor
    lbf[5] = REVERSED_ALL_DAYS_LBF + 2  # both
    llr = np.full(N, -5.0)
    llr[5] = REVERSED_ALL_DAYS_INC_LLR + 1
    llr[6] = 100.0  # only the day-to-day ratio
    ev = ReversalEvidence(log_bayes_factor=lbf, information=np.full(N, 4.0))
    h, j = flag_reversed_all_days(_health(N, llr), ev)
    assert j == 5 and h.status[5] == "reversed" and h.excluded[5] and "Bayes factor" in h.detail[5]
    assert h.excluded.sum() == 1 and h.reversal_evidence is ev
    h2, j2 = flag_reversed_all_days(h, ev)  # the flagged one is not flagged again, nor the others
    assert j2 is None and h2.excluded.sum() == 1
    _, j3 = flag_reversed_all_days(_health(N, llr), ev, max_flagged=0)  # check_health=False
    assert j3 is None


def test_a_weak_reversal_the_day_to_day_tests_miss_is_flagged_by_the_all_days_evidence():
    """Calibration seed 302 of the faults family: a reversed sensor with a true slope change of only ~1.3 times the
    last day's noise std; the step-5 tests leave it (day-to-day ratio 13.7 < 25), the all-days evidence does not."""
    sc = simulate_scenario("faults", 302)
    sid = next(s for s, k in sc.truth.faults.items() if k == "reversed")
    res = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=0)
    flagged = {s: (k, why) for s, k, why in res.health.flagged()}
    assert flagged[sid][0] == "reversed" and "all days" in flagged[sid][1]
    healthy = [j for j, s in enumerate(res.sensor_ids) if s not in sc.truth.faults]
    assert not any(res.health.excluded[j] for j in healthy)
    assert any(f"sensor {sid} excluded (reversed): all days" in w for w in res.warnings)


def test_healthy_sites_flag_almost_no_sensor_by_the_all_days_evidence():
    """A small batch of healthy drifting sites (seeds 900-905, not used to choose the thresholds): no sensor is
    flagged reversed, and the log Bayes factors of the kept sensors stay below the threshold on all but <= 1 %."""
    fam = replace(SCENARIO_FAMILIES["drift"], **SMALL)
    n, above, reversed_ = 0, 0, 0
    for seed in range(900, 906):
        sc = simulate_scenario(fam, seed)
        res = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=0)
        ev = res.health.reversal_evidence
        assert ev is not None  # the all-days model ran
        kept = ~res.health.excluded
        n += int(kept.sum())
        above += int(np.sum(ev.log_bayes_factor[kept] > REVERSED_ALL_DAYS_LBF))
        reversed_ += int(np.sum(res.health.status == "reversed"))
        # a healthy sensor that follows its neighbours has negative evidence on average
        assert np.nanmedian(ev.log_bayes_factor[kept]) < 0
    assert reversed_ == 0
    assert above <= 0.01 * n


def test_the_per_day_model_has_no_all_days_evidence():
    sc = simulate_scenario("drift", 901, **SMALL)
    res = estimate_settlement(validate_site(sc.sensors, sc.readings, sc.survey), n_monte_carlo=0, joint_days=False)
    assert res.health.reversal_evidence is None
