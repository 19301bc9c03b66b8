"""Issue 16 fast paths of the grinding search: whole runs touching the area by accumulated logic, the resumed
cumulative sum, and the reuse of the acceptance result, against the straightforward formulas."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.road import Profile
from longprofile.road.smoothness._acceptance import smoothness_acceptance, spec_from_dict
from longprofile.road.smoothness._grinding import _cumulative_resumed, _touching_runs, simulate_grinding


def _touching_runs_by_labels(cut, rows_in):
    """The formula before issue 16: label the runs of cutting, keep those with a row in the area."""
    pos = cut > 0
    start = pos & ~np.vstack([np.zeros((1, pos.shape[1]), bool), pos[:-1]])
    label = np.cumsum(start, axis=0) * pos
    hit = np.zeros((int(label.max()) + 1, pos.shape[1]), bool)
    hit[label[rows_in], np.arange(pos.shape[1])[None, :]] = True
    hit[0] = False
    return np.where(np.take_along_axis(hit, label, axis=0), cut, 0.0)


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(3, 80), cols=st.integers(1, 6), data=st.data(), seed=st.integers(0, 2**31 - 1))
def test_touching_runs_equal_the_labelled_runs(rows, cols, data, seed):
    rng = np.random.default_rng(seed)
    cut = np.where(rng.random((rows, cols)) < 0.6, rng.random((rows, cols)), 0.0)
    i0 = data.draw(st.integers(0, rows - 1))
    i1 = data.draw(st.integers(i0, rows - 1))
    np.testing.assert_array_equal(_touching_runs(cut, i0, i1), _touching_runs_by_labels(cut, np.arange(i0, i1 + 1)))


def test_resumed_cumulative_equals_one_cumulative_sum():
    from types import SimpleNamespace

    rng = np.random.default_rng(4)
    m, s, k, n_cand = 400, 150, 2, 3
    step = np.full(m - 1, 0.025) + rng.normal(size=m - 1) * 1e-9
    rect = rng.random((m - 1, k * n_cand))
    rect[:s] = np.tile(rect[:s, :k], (1, n_cand))
    shared = SimpleNamespace(station=np.arange(m) * 0.025, step=step, steps=s)
    cum0 = np.cumsum(np.vstack([np.zeros((1, k)), step[:s, None] * rect[:s, :k]]), axis=0)
    _, cum = _cumulative_resumed(shared, cum0, rect[s:].copy())
    want = np.concatenate([np.zeros((1, k * n_cand)), np.cumsum(step[:, None] * rect, axis=0)])  # _cumulative
    np.testing.assert_array_equal(cum, want)


def test_grinding_with_the_acceptance_result_equals_grinding_without_it():
    x = np.arange(0, 800, 0.025)
    bumps = sum(5e-3 * np.exp(-((x - s) / 0.4) ** 2) for s in (200.0, 520.0))
    z = np.column_stack([4e-3 * np.sin(2 * np.pi * x / 37) + bumps, 3e-3 * np.sin(2 * np.pi * x / 23) + bumps])
    prof = Profile(distance=x, elevation=z, tracks=("left", "right"))
    for index in ("auto", "mri", "iri"):
        spec = spec_from_dict({"index": index, "lot": {"length": 200.0}, "localized": {"threshold": 2.0},
                               "exclusions": {"zones": [[600.0, 610.0]]}})
        res = smoothness_acceptance(prof, spec, check_units=False) if index != "iri" else None  # a sine: 0.16 m/km
        if res is None:  # "iri" needs one track for the acceptance: grind the two-track profile on its own
            g = simulate_grinding(prof, spec)
            assert len(g.grinds)
            continue
        a, b = simulate_grinding(prof, spec, acceptance=res), simulate_grinding(prof, spec)
        assert len(a.grinds) >= 2
        np.testing.assert_array_equal(a.profile.elevation, b.profile.elevation)
        np.testing.assert_array_equal(a.index_after, b.index_after)
        np.testing.assert_array_equal(a.index_before, b.index_before)
        assert a.grinds.equals(b.grinds)


def test_shared_start_changes_no_number_of_the_grinding(monkeypatch):
    import longprofile.road.smoothness._grinding as grinding

    x = np.arange(0, 500, 0.025)
    z = 4e-3 * np.sin(2 * np.pi * x / 37) + 5e-3 * np.exp(-((x - 250.0) / 0.4) ** 2)
    prof = Profile(distance=x, elevation=z)
    spec = spec_from_dict({"index": "iri", "localized": {"threshold": 2.0}})
    fast = simulate_grinding(prof, spec)
    monkeypatch.setattr(grinding, "_shared_start", lambda *args, **kwargs: None)  # whole runs every round
    slow = simulate_grinding(prof, spec)
    assert len(fast.grinds) == 1
    assert fast.grinds.equals(slow.grinds)
    np.testing.assert_array_equal(fast.profile.elevation, slow.profile.elevation)
    np.testing.assert_array_equal(fast.index_after, slow.index_after)
