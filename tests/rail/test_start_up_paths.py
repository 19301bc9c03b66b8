"""Start-up of ``rail settle --plot --report`` (issue 12): what its figure helper imports to read a result, and how
many engine runs the choice of the thermal model costs."""

from __future__ import annotations

import json
import pickle
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import longprofile.rail as rail
from longprofile.rail import _controls, _health, _rigidity, _settle, _shapes, _temporal, _thermal

HEAVY = ("scipy", "numba", "longprofile.statespace", "matplotlib")


@pytest.fixture(scope="module")
def small_result():
    syn = rail.simulate_site("mittersheim-like", seed=2, sampling_minutes=120, n_days=4)
    return rail.estimate_settlement(rail.validate_site(syn.sensors, syn.readings, syn.survey), n_monte_carlo=20)


def test_a_result_unpickles_without_scipy_or_numba(small_result, tmp_path):
    """The figure helper (report/_render.py) receives the result pickled and preloads
    ``longprofile.rail:SettlementResult`` (cli/app.py): neither may import scipy or numba (0.35-0.4 s)."""
    path = tmp_path / "result.pkl"
    path.write_bytes(pickle.dumps(small_result, protocol=pickle.HIGHEST_PROTOCOL))
    code = ("import json, pickle, sys\n"
            "from longprofile.rail import SettlementResult\n"
            "r = pickle.loads(open(sys.argv[1], 'rb').read())\n"
            "assert isinstance(r, SettlementResult), type(r)\n"
            "print(json.dumps([m for m in json.loads(sys.argv[2]) if m in sys.modules]))\n")
    proc = subprocess.run([sys.executable, "-c", code, str(path), json.dumps(HEAVY)], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == []


def test_the_result_types_keep_their_names_in_the_modules_that_compute_them(small_result):
    """Moved to ``rail/_results.py``; every old import path gives the same class (old pickles still load)."""
    assert _settle.SettlementResult is rail.SettlementResult is type(small_result)
    assert _settle.ChangePriorFit is rail.ChangePriorFit
    assert _thermal.DailyAngles is rail.DailyAngles is type(small_result.daily)
    assert _health.SensorHealth is rail.SensorHealth is type(small_result.health)
    for evidence in (_health.ReversalEvidence, _health.StepEvidence, _shapes.ShapeEvidence):
        assert evidence.__module__ == "longprofile.rail._results"
    assert _rigidity.ProfilePosterior is rail.ProfilePosterior is type(small_result.initial)
    assert _rigidity.Z90 == 1.6448536269514722
    assert _temporal.TemporalSettlement is rail.TemporalSettlement is type(small_result.smoothed)
    assert _controls.ControlCheck is rail.ControlCheck
    back = pickle.loads(pickle.dumps(small_result))
    np.testing.assert_array_equal(back.dz, small_result.dz)
    assert back.to_table().equals(small_result.to_table())


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 400), seed=st.integers(0, 2**32 - 1),
       taus=st.lists(st.sampled_from([0.25, 0.5, 1.0, 3.0, 6.0, 12.0]), min_size=1, max_size=5))
def test_several_lags_in_one_run_are_each_lag_alone_bit_for_bit(n, seed, taus):
    """``_first_order_responses`` (one engine run, the lags as the states of a diagonal recursion) gives each lag's
    :func:`first_order_response` to the last bit, repeated time stamps (h = 0) included."""
    rng = np.random.default_rng(seed)
    h = rng.exponential(0.3, max(n - 1, 0))
    h[rng.random(h.size) < 0.1] = 0.0
    t = np.concatenate([[rng.normal()], h]).cumsum()
    T = np.cumsum(rng.normal(0.0, 1.0, n)) + 10.0
    together = _thermal._first_order_responses(t, T, taus)
    assert together.shape == (n, len(taus))
    for i, tau in enumerate(taus):
        assert np.array_equal(together[:, i], _thermal.first_order_response(t, T, tau))


def test_the_lag_ratio_runs_the_engine_once_per_sensor(monkeypatch):
    """``lag_variance_ratio`` (``thermal="auto"``, the default) ran one recursion per sensor and lag (174 runs on the
    README's 10-day site); now one per sensor (the ratios unchanged: the lags bit for bit, test above)."""
    syn = rail.simulate_site("farebersviller-like", seed=1, sampling_minutes=60, n_days=4)
    site = rail.validate_site(syn.sensors, syn.readings, syn.survey)
    calls = []
    engine = _thermal.linear_recursion
    monkeypatch.setattr(_thermal, "linear_recursion", lambda *a, **k: calls.append(1) or engine(*a, **k))
    ratio = _thermal.lag_variance_ratio(site)
    fitted = int(np.isfinite(ratio).sum())
    assert fitted > 0 and len(calls) == fitted
    assert np.all((ratio[np.isfinite(ratio)] >= 0) & (ratio[np.isfinite(ratio)] <= 1))
