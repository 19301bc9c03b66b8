"""Localised-shape GLR of a reversed sensor (issue 13, sensor health step 14) and the non-Gaussian scenario shapes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.rail._health import (
    REVERSED_SHAPE_GLR,
    ReversalEvidence,
    SensorHealth,
    flag_reversed_all_days,
    shape_candidates,
)
from longprofile.rail._scenarios import BOWL_SHAPES, SHAPE_FAMILIES, _bowl_shape, simulate_scenario
from longprofile.rail._shapes import ShapeEvidence, localized_slope_shapes, shape_reversal_glr


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


def _brute_glr(Y, g, w, j, floor):
    """max over shapes of the profile log-likelihood with sensor j flipped minus as read: refit per shape (lstsq)."""
    def best(Yd):
        out = -np.inf
        for gs in g:
            G = np.column_stack([gs, np.ones(gs.size)]) * np.sqrt(w)[:, None]
            tot = 0.0
            for k in range(Yd.shape[0]):
                yk = Yd[k] * np.sqrt(w)
                res = yk - G @ np.linalg.lstsq(G, yk, rcond=None)[0]
                Q = float(res @ res)
                var = max(Q / yk.size, floor[k])
                tot += -0.5 * yk.size * np.log(var) - 0.5 * Q / var
            out = max(out, tot)
        return out
    Yf = Y.copy()
    Yf[:, j] *= -1.0
    return best(Yf) - best(Y)


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**31), N=st.integers(6, 12), K=st.integers(1, 3), floored=st.booleans())
def test_glr_equals_refitting_every_shape_with_the_sensor_flipped(seed, N, K, floored):
    """The rank-one update of the residual sum of squares against a refit of every shape by least squares."""
    x, Y, noise, f, _ = _site(seed, N, K)
    g = localized_slope_shapes(x)[0][::97][:40]
    ev = shape_reversal_glr(x, Y, noise if floored else None, sensor_factors=f, shapes=g)
    floor = noise**2 if floored else np.zeros(K)
    for j in (0, N // 2, N - 1):
        assert ev.log_glr[j] == pytest.approx(_brute_glr(Y, g, 1.0 / f**2, j, floor), rel=1e-7, abs=1e-6)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31), scale=st.floats(0.1, 10.0))
def test_glr_is_unchanged_by_the_sign_and_the_unit_of_the_data(seed, scale):
    x, Y, noise, f, _ = _site(seed, 12, 2)
    a = shape_reversal_glr(x, Y, noise, sensor_factors=f).log_glr
    b = shape_reversal_glr(x, -scale * Y, scale * noise, sensor_factors=f).log_glr
    assert np.allclose(a, b, rtol=1e-6, atol=1e-6)


def test_a_reversed_flank_sensor_of_a_non_dictionary_dip_stands_out_and_healthy_ones_do_not():
    """A raised-cosine dip (not a dictionary family): the reversed sensor on its flank has the largest GLR of the site and
    passes the threshold; without it the healthy sensors' GLR stay below; excluded sensors and sensors not asked for
    are NaN."""
    hits, top, healthy = 0, 0, []
    for seed in range(20):
        x, Y, noise, f, u = _site(seed, 30, 6)
        Y[:, 3] = np.nan
        want = np.ones(30, bool)
        want[5] = False
        ev = shape_reversal_glr(x, Y, noise, sensor_factors=f, sensors=want)
        assert np.isnan(ev.log_glr[3]) and np.isnan(ev.log_glr[5]) and ev.family[3] == -1
        healthy.extend(ev.log_glr)
        j = int(np.argmin(np.abs(np.abs(u) - 0.5)))  # on a flank
        Y[:, j] *= -1.0
        glr = shape_reversal_glr(x, Y, noise, sensor_factors=f).log_glr
        hits += glr[j] > REVERSED_SHAPE_GLR
        top += int(np.nanargmax(glr)) == j
    assert hits >= 18 and top >= 18
    assert np.nanmax(healthy) < REVERSED_SHAPE_GLR


def test_without_settlement_no_sensor_shows_a_reversal():
    glr = np.concatenate([shape_reversal_glr(*_site(s, 25, 5, bowl=False)[:3]).log_glr for s in range(10)])
    assert np.nanmax(glr) < REVERSED_SHAPE_GLR


def test_the_shape_test_flags_only_candidates_above_its_threshold():
    N = 6
    health = SensorHealth(sensor_ids=list(range(N)), status=np.array(["ok"] * N), detail=np.array([""] * N),
                          excluded=np.zeros(N, bool), loo_score=np.ones(N), reversal_llr=np.array([5.0] * N))
    lbf = np.array([-20.0, 1.0, 1.0, 1.0, -1.0, 1.0])
    ev = ReversalEvidence(log_bayes_factor=lbf, information=np.ones(N))
    cand = shape_candidates(health, ev)
    glr = np.array([50.0, 2.0, REVERSED_SHAPE_GLR + 3.0, np.nan, 50.0, REVERSED_SHAPE_GLR + 1.0])
    out, j = flag_reversed_all_days(health, ev, shape=ShapeEvidence(log_glr=glr, family=np.zeros(N, int),
                                                                     healthy_family=0))
    assert j == 2 and out.status[2] == "reversed" and "localised-shape GLR" in out.detail[2]
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
    smooth = np.ones(x.size, bool) if kind != "ramp" else np.abs(np.diff(dshape, prepend=dshape[0])) == 0
    assert np.allclose(dshape[smooth][2:-2], num[smooth][2:-2], atol=2e-4)
    assert np.min(shape) == pytest.approx(0.0 if kind == "none" else -1.0, abs=2e-3)


def test_the_gaussian_families_are_unchanged_and_the_shape_families_differ():
    a = simulate_scenario("faults", 5)
    b = simulate_scenario("faults-asymmetric", 5)
    u = (a.truth.x - a.truth.params["center_m"]) / a.truth.params["width_m"]
    ratio = a.truth.settlement[-1] / -np.exp(-0.5 * u**2)
    assert np.allclose(ratio, ratio[0])
    assert set(SHAPE_FAMILIES) == {f"faults-{k}" for k in BOWL_SHAPES[1:]}
    assert not np.allclose(a.truth.settlement, b.truth.settlement)
    assert np.array_equal(a.truth.x, b.truth.x)
