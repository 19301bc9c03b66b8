"""The streaming (recursive, O(1) per sample) estimator against the batch FIR, drift guard included."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import lfilter

from longprofile.errors import InputError, ShapeError
from longprofile.signal import (
    StreamingDerivative,
    derivative,
    ml_coefficients_float,
    polyfit_coefficients_float,
)

MILLION = 1_000_000


def _signal(n, dt=1e-3, offset=0.0, seed=0):
    t = np.arange(n) * dt
    rng = np.random.default_rng(seed)
    return offset + np.sin(2 * np.pi * 0.7 * t) + 0.3 * np.cos(2 * np.pi * 5.0 * t) + 0.01 * rng.standard_normal(n)


def _feed(est, x, rng, max_block=5000):
    parts, i = [], 0
    while i < x.shape[0]:
        k = int(rng.integers(1, max_block))
        parts.append(est.update(x[i:i + k]))
        i += k
    return np.concatenate(parts)


@pytest.mark.parametrize("window,degree,order", [(45, 2, 1), (45, 2, 2), (6, 3, 1), (200, 3, 3), (1, 1, 1)])
def test_stream_of_a_million_samples_matches_batch_and_scipy(window, degree, order):
    dt = 1e-3
    x = _signal(MILLION, dt, offset=100.0)
    est = StreamingDerivative(dt, window=window, degree=degree, order=order)
    streamed = _feed(est, x, np.random.default_rng(window))
    assert est.n_seen == MILLION
    batch = derivative(x, dt, method="ml", window=window, degree=degree, order=order, noise_std=0.01)
    ref = lfilter(ml_coefficients_float(window, degree, order) / dt ** order, 1.0, x)
    ref[:window] = np.nan
    scale = np.nanmax(np.abs(ref))
    np.testing.assert_array_equal(np.isnan(streamed), np.isnan(ref))
    assert np.nanmax(np.abs(streamed - batch.derivative)) <= 1e-9 * scale
    assert np.nanmax(np.abs(streamed - ref)) <= 1e-9 * scale


def test_drift_guard_is_what_keeps_the_recursion_exact():
    # the moment recursion is marginally stable: without the periodic exact recomputation
    # the constant-jerk estimator drifts far away over 10^6 samples; with it, it stays at round-off.
    dt = 1e-3
    x = _signal(MILLION, dt)
    ref = lfilter(ml_coefficients_float(5, 3) / dt, 1.0, x)
    scale = np.max(np.abs(ref[5:]))
    guarded = StreamingDerivative(dt, window=5, degree=3).update(x)
    unguarded = StreamingDerivative(dt, window=5, degree=3, refresh=10 ** 9).update(x)
    assert np.max(np.abs(guarded[5:] - ref[5:])) <= 1e-9 * scale
    assert np.max(np.abs(unguarded[5:] - ref[5:])) > 1e-6 * scale


@settings(max_examples=15, deadline=None)
@given(window=st.integers(2, 60), degree=st.integers(1, 3), method=st.sampled_from(["ml", "polyfit"]),
       cuts=st.lists(st.integers(0, 3000), max_size=6), seed=st.integers(0, 10))
def test_output_does_not_depend_on_block_boundaries(window, degree, method, cuts, seed):
    window = max(window, degree)
    x = _signal(3000, seed=seed)
    whole = StreamingDerivative(1e-3, window=window, degree=degree, method=method).update(x)
    est = StreamingDerivative(1e-3, window=window, degree=degree, method=method)
    pieces = np.split(x, sorted(set(cuts)))
    split = np.concatenate([est.update(p) for p in pieces])
    np.testing.assert_allclose(split, whole, rtol=1e-12, atol=1e-9, equal_nan=True)
    taps = (polyfit_coefficients_float if method == "polyfit" else ml_coefficients_float)(window, degree, 1)
    ref = lfilter(taps / 1e-3, 1.0, x)
    np.testing.assert_allclose(whole[window:], ref[window:], rtol=1e-9, atol=1e-9 * np.abs(ref).max())


def test_single_sample_updates_and_multichannel():
    x = _signal(400)
    X = np.stack([x, -2 * x], axis=1)
    est = StreamingDerivative(1e-3, window=10, degree=2)
    one_by_one = np.array([est.update(X[k:k + 1])[0] for k in range(X.shape[0])])
    ref = StreamingDerivative(1e-3, window=10, degree=2).update(x)
    np.testing.assert_allclose(one_by_one[:, 0], ref, equal_nan=True, rtol=1e-12)
    np.testing.assert_allclose(one_by_one[:, 1], -2 * ref, equal_nan=True, rtol=1e-12)


def test_nan_in_stream_blanks_one_window_then_recovers():
    x = _signal(300)
    x[150] = np.nan
    out = StreamingDerivative(1e-3, window=20, degree=2).update(x)
    assert np.isnan(out[150:171]).all() and np.isfinite(out[171:]).all()
    ref = lfilter(ml_coefficients_float(20, 2) / 1e-3, 1.0, x)
    np.testing.assert_allclose(out[171:], ref[171:], rtol=1e-9, atol=1e-9 * np.nanmax(np.abs(ref)))


def test_backward_and_reset():
    est = StreamingDerivative(1.0, window=2, degree=2, method="backward")
    np.testing.assert_allclose(est.update(np.arange(6.0) ** 2)[2:], 2 * np.arange(2, 6.0))
    est.reset()
    assert est.n_seen == 0
    assert np.isnan(est.update(np.array([1.0, 2.0]))).all()


def test_errors():
    with pytest.raises(InputError, match="window .* must be >= degree"):
        StreamingDerivative(0.1, window=1, degree=2)
    with pytest.raises(InputError, match="backward difference of order n uses window = n"):
        StreamingDerivative(0.1, window=5, degree=2, method="backward")
    with pytest.raises(InputError, match="method must be one of"):
        StreamingDerivative(0.1, window=5, method="kalman")
    with pytest.raises(InputError, match="refresh must be >= 1"):
        StreamingDerivative(0.1, window=5, refresh=0)
    est = StreamingDerivative(0.1, window=5)
    est.update(np.zeros((10, 2)))
    with pytest.raises(ShapeError, match="keep the stream's shape"):
        est.update(np.zeros(10))


@settings(max_examples=20, deadline=None)
@given(window=st.integers(1, 30), degree=st.integers(1, 4), nan_at=st.lists(st.integers(0, 799), max_size=8),
       block=st.integers(1, 300))
def test_random_nans_match_the_fir_exactly_in_pattern_and_value(window, degree, nan_at, block):
    window = max(window, degree)
    x = _signal(800, seed=3)
    x[nan_at] = np.nan
    est = StreamingDerivative(1e-3, window=window, degree=degree)
    out = np.concatenate([est.update(x[i:i + block]) for i in range(0, x.size, block)])
    ref = lfilter(ml_coefficients_float(window, degree) / 1e-3, 1.0, x)
    ref[:window] = np.nan
    np.testing.assert_array_equal(np.isnan(out), np.isnan(ref))
    ok = ~np.isnan(ref)
    if ok.any():
        np.testing.assert_allclose(out[ok], ref[ok], rtol=1e-9, atol=1e-9 * np.abs(ref[ok]).max())
