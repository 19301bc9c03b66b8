"""Issue 16 fast paths of the golden-car run: the shifted-slice moving average, all tracks in one engine call and
the shared start of the grinding search give the numbers of the straightforward formulas (bit for bit, or to
1e-15 relative where stated)."""

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from longprofile.road.indices._iri import (
    _C_RV,
    _moving_mean,
    _resume,
    _run_arrays,
    _run_golden_car,
    _shared_start,
    golden_car_matrices,
)
from longprofile.statespace import linear_recursion


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 12), rows=st.integers(12, 300), cols=st.integers(1, 5), seed=st.integers(0, 2**31 - 1))
@example(n=12, rows=12, cols=1, seed=70)  # a single window: the old bound 1e-15 x |mean| was below one rounding
def test_moving_mean_equals_sliding_window_mean(n, rows, cols, seed):
    z = np.cumsum(np.random.default_rng(seed).normal(size=(rows, cols)), axis=0) * 1e-3
    z -= z[0]
    old = np.lib.stride_tricks.sliding_window_view(z, n, axis=0).mean(axis=-1)  # the formula before issue 16
    new = _moving_mean(z, n)
    assert new.shape == old.shape
    if cols >= 2:  # C-ordered, several tracks: the same additions in the same order
        np.testing.assert_array_equal(new, old)
    else:  # one track: numpy sums a contiguous window pairwise, so only round-off agrees: two orders of summing n
        # terms differ by at most about n eps max|z| (the textbook bound of a recursive sum)
        np.testing.assert_allclose(new, old, rtol=0, atol=n * np.finfo(float).eps * np.abs(z).max())


def _per_track_run(x, z, lead_in):
    """The constant-step run before issue 16: one linear_recursion per track."""
    h = np.diff(x)
    st_, pr = golden_car_matrices(float((x[-1] - x[0]) / h.size))
    out = np.empty((h.size, z.shape[1]))
    for j in range(z.shape[1]):
        s0 = (np.interp(x[0] + lead_in, x, z[:, j]) - z[0, j]) / lead_in
        res = linear_recursion(st_, pr[:, None], np.diff(z[:, j]) / h, np.array([s0, 0.0, s0, 0.0]),
                               output_matrix=_C_RV)
        out[:, j] = np.abs(res.outputs[:, 0]) * 1000.0
    return out


@settings(max_examples=15, deadline=None)
@given(cols=st.integers(1, 6), seed=st.integers(0, 2**31 - 1))
def test_all_tracks_in_one_call_equal_one_run_per_track(cols, seed):
    x = np.arange(1200) * 0.025
    z = np.cumsum(np.random.default_rng(seed).normal(size=(1200, cols)), axis=0) * 1e-4
    _, out = _run_golden_car(x, z, 11.0, True)
    np.testing.assert_array_equal(out, _per_track_run(x, z, 11.0))


@settings(max_examples=25, deadline=None)
@given(first=st.integers(300, 1990), n_cand=st.integers(1, 5), dx=st.sampled_from([0.025, 0.05, 0.3]),
       seed=st.integers(0, 2**31 - 1))
def test_shared_start_and_resume_equal_whole_runs(first, n_cand, dx, seed):
    rng = np.random.default_rng(seed)
    n = 2000
    x = 100.0 + np.arange(n) * dx
    base = np.cumsum(rng.normal(size=(n, 2)), axis=0) * 1e-4
    cand = np.tile(base, (1, n_cand))
    cand[first:] -= np.abs(rng.normal(size=(n - first, 2 * n_cand))) * 1e-3  # changed from `first` on
    dxr = (x[-1] - x[0]) / (n - 1)
    whole = _run_arrays(x, cand.copy(), (), 11.0, None, 0.25, None, dxr)[0]
    shared = _shared_start(x, base, dxr, first)
    if shared is None:  # the change reaches the lead-in of the initial slope
        assert x[first] - x[0] < 11.0 + 0.5
        return
    s = shared.steps
    rest = _resume(shared, cand[s:].copy())
    np.testing.assert_array_equal(shared.station, whole.station)
    np.testing.assert_array_equal(shared.step, whole.step)
    np.testing.assert_array_equal(np.tile(shared.rectified, (1, n_cand)), whole.rectified[:s])
    np.testing.assert_array_equal(rest, whole.rectified[s:])


def test_shared_start_declines_irregular_stations_and_no_change():
    x = np.cumsum(np.full(500, 0.1) + np.linspace(0, 0.01, 500))
    z = np.zeros((500, 1))
    assert _shared_start(x, z, None, 300) is None
    assert _shared_start(np.arange(500) * 0.1, z, 0.1, None) is None
    assert _shared_start(np.arange(500) * 0.1, z, 0.1, 50) is None  # inside the 11 m lead-in
