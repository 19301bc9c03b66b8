"""Localised-shape evidence of a reversed sensor (issue 13, sensor health step 14), non-Gaussian scenario shapes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import logsumexp
from scipy.stats import norm

from longprofile.rail import estimate_settlement, validate_site
from longprofile.rail._health import (
    REVERSED_ALL_DAYS_INC_LLR,
    REVERSED_ALL_DAYS_LBF,
    REVERSED_SHAPE_EVIDENCE,
    REVERSED_SHAPE_GATE_INC_LLR,
    REVERSED_SHAPE_GATE_LBF,
    REVERSED_SUM_GATE_INC_LLR,
    REVERSED_SUM_INC_WEIGHT,
    REVERSED_SUM_LBF,
    ReversalEvidence,
    SensorHealth,
    flag_reversed_all_days,
    shape_candidates,
)
from longprofile.rail._scenarios import BOWL_SHAPES, SHAPE_FAMILIES, _bowl_shape, simulate_scenario
from longprofile.rail._shapes import SHAPE_REL_ERR, ShapeEvidence, localized_slope_shapes, shape_reversal_evidence


def _site(seed, N, K, bowl=True):
    rng = np.random.default_rng(seed)
    x = np.cumsum(np.r_[0.0, rng.uniform(2.0, 4.0, N - 1)])
    c, w = rng.uniform(0.35, 0.65) * x[-1], rng.uniform(4.0, 10.0)
    u = (x - c) / w
    # the slope of a raised-cosine dip -(1 + cos(pi u)) / 2, |u| < 1: smooth, localised, not a dictionary family
    shape = np.where(np.abs(u) < 1, np.sin(np.pi * u), 0.0) * 1e-3 if bowl else np.zeros(N)
    noise = rng.uniform(0.5, 3.0, K) * 1e-5
    Y = rng.uniform(0.2, 2.0, K)[:, None] * shape[None, :] + noise[:, None] * rng.normal(0, 1, (K, N))
    return x, Y, noise, rng.uniform(0.5, 2.0, N), u


def _brute_evidence(Y, g, w, j, nu):
    """Sensor j's log BF and information by refitting every shape to the other sensors (weighted lstsq): each shape
    weighed by the others' profile likelihood, sensor j's predictive density as read and flipped under each."""
    n = Y.shape[1]
    others = np.arange(n) != j
    Ls, lp, lm, infos = [], [], [], []
    for gs in g:
        G = np.column_stack([gs, np.ones(n)])
        sw = np.sqrt(w[others])
        A = G[others] * sw[:, None]
        L, a, b, info = 0.0, 0.0, 0.0, 0.0
        for k in range(Y.shape[0]):
            coef, *_ = np.linalg.lstsq(A, Y[k, others] * sw, rcond=None)
            res = Y[k, others] * sw - A @ coef
            Q = float(res @ res)
            var = max(Q / (n - 1), nu[k] ** 2)
            L += -0.5 * (n - 1) * np.log(var) - 0.5 * Q / var
            mu = G[j] @ coef
            h = w[j] * G[j] @ np.linalg.solve(A.T @ A, G[j])  # the new point's leverage against the others' fit
            v = max(Q / (n - 3), nu[k] ** 2) / w[j] * (1.0 + h) + (SHAPE_REL_ERR * mu) ** 2
            a += norm.logpdf(Y[k, j], mu, np.sqrt(v))
            b += norm.logpdf(-Y[k, j], mu, np.sqrt(v))
            info += mu**2 / v
        Ls.append(L), lp.append(a), lm.append(b), infos.append(info)
    Ls = np.array(Ls)
    return logsumexp(Ls + lm) - logsumexp(Ls + lp), infos[int(np.argmax(Ls))]


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**31), N=st.integers(7, 12), K=st.integers(1, 3))
def test_evidence_equals_refitting_every_shape_to_the_other_sensors(seed, N, K):
    """The deletion identities from one fit per shape against a refit of every shape without the sensor (lstsq) and
    scipy's normal densities."""
    x, Y, noise, f, _ = _site(seed, N, K)
    g = localized_slope_shapes(x)[0][::97][:40]
    ev = shape_reversal_evidence(x, Y, noise, sensor_factors=f, shapes=g)
    for j in (0, N // 2, N - 1):
        lbf, info = _brute_evidence(Y, g, 1.0 / f**2, j, noise)
        assert ev.log_bayes_factor[j] == pytest.approx(lbf, rel=1e-6, abs=1e-7)
        assert ev.information[j] == pytest.approx(info, rel=1e-6, abs=1e-9)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31), scale=st.floats(0.1, 10.0), i=st.integers(0, 11))
def test_evidence_is_antisymmetric_in_the_sensor_and_unchanged_by_the_unit(seed, scale, i):
    """Flipping sensor i's data flips the sign of its log BF (its own data choose no shape); the unit of the data
    (with the noise) changes nothing."""
    x, Y, noise, f, _ = _site(seed, 12, 2)
    a = shape_reversal_evidence(x, Y, noise, sensor_factors=f)
    Yf = Y.copy()
    Yf[:, i] *= -1.0
    b = shape_reversal_evidence(x, Yf, noise, sensor_factors=f)
    assert b.log_bayes_factor[i] == pytest.approx(-a.log_bayes_factor[i], rel=1e-9, abs=1e-9)
    assert b.information[i] == pytest.approx(a.information[i], rel=1e-9)
    c = shape_reversal_evidence(x, scale * Y, scale * noise, sensor_factors=f)
    assert np.allclose(c.log_bayes_factor, a.log_bayes_factor, rtol=1e-6, atol=1e-6)


def test_a_reversed_flank_sensor_of_a_non_dictionary_dip_stands_out_and_healthy_ones_rarely_do():
    """A raised-cosine dip (not a dictionary family) at a flank signal-to-noise ratio of ~100: the reversed sensor on
    its flank has the largest evidence of the site and passes the threshold. As read, a healthy sensor passes it only
    next to the dip's centre (whose sign says on which side of the misfitting shapes' centre it sits) or its edges
    (where the dip ends abruptly): <= 2 % of them, none on a flank; in the tool the all-days gates
    (:func:`shape_candidates`) stand between these and a flag. Excluded sensors and sensors not asked for are NaN."""
    hits, top, healthy, flank = 0, 0, [], []
    for seed in range(20):
        x, Y, noise, f, u = _site(seed, 30, 6)
        Y[:, 3] = np.nan
        want = np.ones(30, bool)
        want[5] = False
        ev = shape_reversal_evidence(x, Y, noise, sensor_factors=f, sensors=want)
        assert np.isnan(ev.log_bayes_factor[3]) and np.isnan(ev.log_bayes_factor[5]) and ev.family[3] == -1
        healthy.extend(ev.log_bayes_factor[want & np.isfinite(ev.log_bayes_factor)])
        flank.extend(ev.log_bayes_factor[(np.abs(u) > 0.25) & (np.abs(u) < 0.9) & want])
        j = int(np.argmin(np.abs(np.abs(u) - 0.5)))  # on a flank
        Y[:, j] *= -1.0
        lbf = shape_reversal_evidence(x, Y, noise, sensor_factors=f).log_bayes_factor
        hits += lbf[j] > REVERSED_SHAPE_EVIDENCE
        top += int(np.nanargmax(lbf)) == j
    assert hits >= 18 and top >= 18
    assert np.mean(np.array(healthy) > REVERSED_SHAPE_EVIDENCE) <= 0.02
    assert np.nanmax(flank) < REVERSED_SHAPE_EVIDENCE


def test_without_settlement_no_sensor_shows_a_reversal():
    lbf = np.concatenate([shape_reversal_evidence(*_site(s, 25, 5, bowl=False)[:3]).log_bayes_factor
                          for s in range(10)])
    assert np.nanmax(lbf) < REVERSED_SHAPE_EVIDENCE


def test_the_shape_test_flags_only_candidates_above_its_threshold():
    N = 6
    health = SensorHealth(sensor_ids=list(range(N)), status=np.array(["ok"] * N), detail=np.array([""] * N),
                          excluded=np.zeros(N, bool), loo_score=np.ones(N), reversal_llr=np.array([6.0] * N))
    lbf = np.array([-20.0, 1.0, 1.0, 1.0, -1.5, 1.0])
    ev = ReversalEvidence(log_bayes_factor=lbf, information=np.ones(N))
    cand = shape_candidates(health, ev)
    glr = np.array([50.0, 2.0, REVERSED_SHAPE_EVIDENCE + 3.0, np.nan, 50.0, REVERSED_SHAPE_EVIDENCE + 1.0])
    shape = ShapeEvidence(log_bayes_factor=glr, information=np.ones(N), family=np.zeros(N, int))
    out, j = flag_reversed_all_days(health, ev, shape=shape)
    assert j == 2 and out.status[2] == "reversed" and "localised settlement shape" in out.detail[2]
    assert out.shape_evidence is not None
    assert cand[1] and not cand[0] and not cand[4]
    none, k = flag_reversed_all_days(health, ev)  # without shape evidence: the step-11 rule only (none passes)
    assert k is None and none.shape_evidence is None


@pytest.mark.parametrize("kind", BOWL_SHAPES)
def test_scenario_shapes_have_their_exact_derivative(kind):
    """The slope profile of every scenario shape against central differences of its altitude profile."""
    x = np.linspace(0.0, 90.0, 9001)
    shape, dshape = _bowl_shape(kind, x, 45.0, 8.0, np.random.default_rng(3))
    num = np.gradient(shape, x)
    # away from the ramp's kinks (central differences straddle them); elsewhere within the differences' own error
    kink = np.convolve((np.abs(np.diff(dshape, prepend=dshape[0])) > 1e-3).astype(float), np.ones(5), "same") > 0
    keep = ~kink if kind == "ramp" else np.ones(x.size, bool)
    keep[:2] = keep[-2:] = False
    assert np.allclose(dshape[keep], num[keep], atol=2e-3 * max(np.abs(dshape).max(), 1e-9))
    assert np.min(shape) == pytest.approx(0.0 if kind == "none" else -1.0, abs=2e-3)


def test_the_gaussian_families_are_unchanged_and_the_shape_families_differ():
    a = simulate_scenario("faults", 5)
    b = simulate_scenario("faults-asymmetric", 5)
    u = (a.truth.x - a.truth.params["center_m"]) / a.truth.params["width_m"]
    ratio = a.truth.settlement[-1] / -np.exp(-0.5 * u**2)
    assert np.allclose(ratio, ratio[0])
    assert set(SHAPE_FAMILIES) == ({f"faults-{k}" for k in BOWL_SHAPES[1:]} | {"transition"}
                                   | {f"{k}-healthy" for k in ("asymmetric", "two-bowls", "ramp", "tilt")})
    assert all(SHAPE_FAMILIES[f"{k}-healthy"].faults == () for k in ("asymmetric", "two-bowls", "ramp", "tilt"))
    assert SHAPE_FAMILIES["transition"].bowl_shape == "joint-step" and SHAPE_FAMILIES["transition"].faults == ()
    assert not np.allclose(a.truth.settlement, b.truth.settlement)
    assert np.array_equal(a.truth.x, b.truth.x)


def test_estimate_settlement_flags_a_reversal_by_its_shape_evidence_only_when_asked():
    """Calibration site faults 321 (docs/rail.md step 14): its reversed sensor I016 passes the shape test and no
    other; without ``shape_evidence`` it is kept, as before, and nothing of the shape test is computed."""
    sc = simulate_scenario("faults", 321)
    site = validate_site(sc.sensors, sc.readings, sc.survey)
    off = estimate_settlement(site, n_monte_carlo=0)
    on = estimate_settlement(site, n_monte_carlo=0, shape_evidence=True)
    j = off.sensor_ids.index("I016")
    assert sc.truth.faults["I016"] == "reversed"
    assert off.health.status[j] == "ok" and off.health.shape_evidence is None and not off.settings["shape_evidence"]
    assert on.health.status[j] == "reversed" and "localised settlement shape" in on.health.detail[j]
    assert on.settings["shape_evidence"]
    newly = (np.asarray(on.health.status) != np.asarray(off.health.status))
    assert list(np.nonzero(newly)[0]) == [j]


def test_a_shape_flat_over_the_stations_is_left_out_not_a_nan():
    """A dictionary row constant over the kept stations duplicates the fitted tilt (singular normal equations): it
    is dropped; the evidence equals that of the dictionary without it."""
    x, Y, noise, f, _ = _site(4, 10, 2)
    g = localized_slope_shapes(x)[0][::211][:20]
    both = np.vstack([g, np.ones(10)])
    a = shape_reversal_evidence(x, Y, noise, sensor_factors=f, shapes=g)
    b = shape_reversal_evidence(x, Y, noise, sensor_factors=f, shapes=both)
    assert np.all(np.isfinite(b.log_bayes_factor))
    assert np.allclose(a.log_bayes_factor, b.log_bayes_factor, rtol=1e-12, atol=1e-12)


def test_the_sum_rule_flags_on_the_sum_of_the_two_log_bayes_factors_above_its_gates():
    """Step 15: with ``shape_rule="sum"`` a kept sensor is flagged when its all-days plus shape log Bayes factors plus
    REVERSED_SUM_INC_WEIGHT x its day-to-day ratio exceed REVERSED_SUM_LBF, its all-days one exceeds
    REVERSED_SHAPE_GATE_LBF and its day-to-day ratio REVERSED_SUM_GATE_INC_LLR;
    here every sensor passes step 14's gates too, and step 14's rule (the shape log Bayes factor alone above
    REVERSED_SHAPE_EVIDENCE) and step 11's flag none of them."""
    N = 6
    hi = REVERSED_ALL_DAYS_INC_LLR - 1.0  # above both shape rules' gates, below step 11's
    assert hi > max(REVERSED_SUM_GATE_INC_LLR, REVERSED_SHAPE_GATE_INC_LLR)
    inc = np.array([hi] * 5 + [REVERSED_SUM_GATE_INC_LLR - 0.5])
    health = SensorHealth(sensor_ids=list(range(N)), status=np.array(["ok"] * N), detail=np.array([""] * N),
                          excluded=np.zeros(N, bool), loo_score=np.ones(N), reversal_llr=inc)
    a = REVERSED_ALL_DAYS_LBF - 0.1 + REVERSED_SUM_INC_WEIGHT * hi  # all-days evidence (+ the ratio's share) ...
    lim = REVERSED_ALL_DAYS_LBF - 0.1  # ... just under step 11's threshold
    lbf = np.array([REVERSED_SHAPE_GATE_LBF - 0.5, lim, lim, lim, lim - 1.0, lim])
    ev = ReversalEvidence(log_bayes_factor=lbf, information=np.ones(N))
    # 0: sum far above but all-days evidence below its gate; 1: sum just below; 2: sum above (flagged first);
    # 3: no shape evidence; 4: sum above, less (flagged second); 5: sum above but day-to-day ratio below the gate
    glr = np.array([40.0, REVERSED_SUM_LBF - a - 0.1, REVERSED_SUM_LBF - a + 1.5, np.nan,
                    REVERSED_SUM_LBF - (a - 1.0) + 0.2, REVERSED_SUM_LBF - a + 5.0])
    assert np.all(np.nan_to_num(glr, nan=0.0)[1:5] < REVERSED_SHAPE_EVIDENCE)  # (5: step 14's gate stops it)
    assert inc[0] > REVERSED_SHAPE_GATE_INC_LLR and lbf[1] > REVERSED_SHAPE_GATE_LBF
    shape = ShapeEvidence(log_bayes_factor=glr, information=np.ones(N), family=np.zeros(N, int))
    cand = shape_candidates(health, ev, "sum")
    assert list(np.nonzero(cand)[0]) == [1, 2, 3, 4]
    out, j = flag_reversed_all_days(health, ev, shape=shape, shape_rule="sum", max_flagged=N)
    assert j == 2 and out.status[2] == "reversed" and "score with the all-days one" in out.detail[2]
    out2, k = flag_reversed_all_days(out, ev, shape=shape, shape_rule="sum", max_flagged=N)
    assert k == 4
    assert flag_reversed_all_days(out2, ev, shape=shape, shape_rule="sum", max_flagged=N)[1] is None
    assert flag_reversed_all_days(health, ev, shape=shape, max_flagged=N)[1] is None  # step 14's rule and step 11's
    with pytest.raises(ValueError):
        shape_candidates(health, ev, "max")


def test_the_sum_rule_finds_a_reversal_that_both_step_11_and_step_14_keep():
    """Calibration site faults 650 (docs/rail.md step 15): its reversed sensor I012 of modest SNR (1.9, the harness's:
    largest true slope change / last day's noise std; all-days log BF 11.8 but day-to-day ratio 3.2 < 10; shape log BF
    15.1 but ratio < 5; score 28.5) is kept by the default and by step 14's rule, and flagged by the sum rule, with no
    other sensor's status changed."""
    sc = simulate_scenario("faults", 650)
    site = validate_site(sc.sensors, sc.readings, sc.survey)
    off = estimate_settlement(site, n_monte_carlo=0)
    step14 = estimate_settlement(site, n_monte_carlo=0, shape_evidence=True)
    on = estimate_settlement(site, n_monte_carlo=0, shape_evidence=True, shape_rule="sum")
    j = off.sensor_ids.index("I012")
    assert sc.truth.faults["I012"] == "reversed"
    assert off.health.status[j] == "ok" and step14.health.status[j] == "ok"
    assert on.health.status[j] == "reversed" and "score with the all-days one" in on.health.detail[j]
    assert on.settings["shape_rule"] == "sum"
    newly = np.asarray(on.health.status) != np.asarray(off.health.status)
    assert list(np.nonzero(newly)[0]) == [j]


def test_an_unknown_shape_rule_is_refused():
    from longprofile.errors import InputError
    from longprofile.rail import SettlementSettings

    with pytest.raises(InputError):
        SettlementSettings(shape_rule="max")
