"""Long-record filter, smoother and likelihood (exact start, constant gain, chunks) against the exact engine."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, NotDetectableError
from longprofile.statespace import (
    StateSpaceModel,
    chunked_kalman_filter,
    kalman_filter,
    long_record_filter,
    long_record_log_likelihood,
    long_record_smoother,
    rts_smoother,
    simulate,
)


def _random_model(seed, n, m, radius):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    F = radius * A / max(np.abs(np.linalg.eigvals(A)).max(), 1e-9)
    H = rng.normal(size=(m, n))
    G = rng.normal(size=(n, n))
    Q = G @ G.T / n + 1e-3 * np.eye(n)
    Rg = rng.normal(size=(m, m))
    R = Rg @ Rg.T / m + 0.1 * np.eye(m)
    P0 = np.eye(n) * rng.uniform(0.5, 3.0)
    return StateSpaceModel(F, H, Q, R, rng.normal(size=n), P0)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 4), m=st.integers(1, 2),
       radius=st.floats(0.3, 0.97), exact_chunk=st.integers(8, 64), chunk=st.integers(5, 80))
def test_equals_the_exact_filter_and_smoother(seed, n, m, radius, exact_chunk, chunk):
    """Any chunking, any switch point: the means and the likelihood of the exact engine (kalman_filter/rts)."""
    model = _random_model(seed, n, m, radius)
    _x, y = simulate(model, 600, rng=seed)
    exact_f = kalman_filter(model, y)
    exact_s = rts_smoother(model, exact_f)
    kw = dict(tol=1e-13, chunk_size=chunk, exact_chunk=exact_chunk)
    f = long_record_filter(model, y, **kw)
    s = long_record_smoother(model, y, **kw)
    ll = long_record_log_likelihood(model, y, **kw)
    scale = np.abs(exact_s.mean).max()
    np.testing.assert_allclose(f.mean, exact_f.mean, atol=1e-9 * scale, rtol=0)
    np.testing.assert_allclose(s.mean, exact_s.mean, atol=1e-9 * scale, rtol=0)
    assert ll.log_likelihood == pytest.approx(exact_f.log_likelihood, rel=1e-10, abs=1e-8)
    assert s.log_likelihood == pytest.approx(ll.log_likelihood, rel=1e-12)
    assert ll.n_observed == y.size and ll.mean is None


def test_switches_to_constant_gain_and_keeps_selected_states():
    model = _random_model(1, 3, 1, 0.9)
    _x, y = simulate(model, 5000, rng=2)
    s = long_record_smoother(model, y, states=[-1, 0], exact_chunk=50, chunk_size=333)
    assert s.converged and 0 < s.n_exact < 5000  # the constant-gain part really ran
    exact = rts_smoother(model, kalman_filter(model, y)).mean
    np.testing.assert_allclose(s.mean, exact[:, [2, 0]], atol=1e-7 * np.abs(exact).max())
    assert s.states == (2, 0)


def test_not_converged_flag_and_bounded_exact_start():
    # a slow filter: weak process noise seen through heavy measurement noise (closed loop close to 1)
    model = StateSpaceModel([[0.999]], [[1.0]], [[1e-5]], [[100.0]], [0.0], [[10.0]])
    _x, y = simulate(model, 3000, rng=0)
    s = long_record_smoother(model, y, exact_chunk=16, max_exact=32, tol=1e-14)
    assert not s.converged and s.n_exact == 32


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 4), m=st.integers(1, 2),
       radius=st.floats(0.3, 0.97), exact_chunk=st.integers(8, 64), chunk=st.integers(5, 80),
       gaps=st.lists(st.tuples(st.integers(0, 599), st.integers(1, 40)), min_size=1, max_size=4))
def test_gaps_are_bridged_as_by_the_exact_filter_and_smoother(seed, n, m, radius, exact_chunk, chunk, gaps):
    """Missing samples anywhere (in the exact start, in the constant-gain part, at the end): the means and the
    likelihood of kalman_filter/rts_smoother on the same record with the same gaps."""
    model = _random_model(seed, n, m, radius)
    _x, y = simulate(model, 600, rng=seed)
    for a, length in gaps:
        y[a:a + length] = np.nan
    exact_f = kalman_filter(model, y)
    exact_s = rts_smoother(model, exact_f)
    kw = dict(tol=1e-13, chunk_size=chunk, exact_chunk=exact_chunk)
    f = long_record_filter(model, y, **kw)
    s = long_record_smoother(model, y, **kw)
    scale = np.abs(exact_s.mean).max()
    np.testing.assert_allclose(f.mean, exact_f.mean, atol=1e-9 * scale, rtol=0)
    np.testing.assert_allclose(s.mean, exact_s.mean, atol=1e-9 * scale, rtol=0)
    assert s.log_likelihood == pytest.approx(exact_f.log_likelihood, rel=1e-10, abs=1e-8)
    assert s.n_observed == exact_f.n_observed


def test_a_gap_after_the_switch_hands_back_to_the_exact_filter():
    """A gap in the constant-gain part: the exact filter bridges it and the constant gain takes over again."""
    model = _random_model(1, 3, 1, 0.9)
    _x, y = simulate(model, 5000, rng=2)
    y[2500:2540] = np.nan
    y[4000] = np.nan
    s = long_record_smoother(model, y, exact_chunk=50, chunk_size=333)
    assert s.converged and 0 < s.n_exact < 2500 and 41 <= s.n_bridged < 2500
    exact = rts_smoother(model, kalman_filter(model, y)).mean
    np.testing.assert_allclose(s.mean, exact, atol=1e-7 * np.abs(exact).max())


def test_refusals():
    y = np.ones((100, 2))
    y[5, 0] = np.nan
    with pytest.raises(InputError, match="in part only"):
        long_record_smoother(_random_model(0, 2, 2, 0.5), y)
    model = _random_model(0, 2, 1, 0.5)
    walk = StateSpaceModel([[1.0, 0.0], [0.0, 0.5]], [[0.0, 1.0]], np.eye(2), [[1.0]], [0.0, 0.0], np.eye(2))
    with pytest.raises(NotDetectableError):
        long_record_smoother(walk, np.ones(100))
    with pytest.raises(InputError, match="states"):
        long_record_filter(model, np.ones(100), states=[5])


def test_chunked_filter_equals_kalman_filter_without_detectability():
    """An unobservable random walk (no stationary filter): chunks with NaN gaps equal the whole-record filter."""
    walk = StateSpaceModel([[1.0, 0.0], [0.0, 0.8]], [[0.0, 1.0]], np.diag([0.1, 1.0]), [[0.5]], [0.0, 0.0],
                           np.eye(2))
    y = np.random.default_rng(0).normal(size=1000)
    y[100:130] = np.nan
    exact = kalman_filter(walk, y)
    res = chunked_kalman_filter(walk, y, states=[0, 1], chunk_size=77)
    np.testing.assert_allclose(res.mean, exact.mean, atol=1e-12)
    np.testing.assert_allclose(res.var, np.stack([exact.cov[:, 0, 0], exact.cov[:, 1, 1]], axis=1), rtol=1e-12)
    assert res.log_likelihood == pytest.approx(exact.log_likelihood, rel=1e-12)
