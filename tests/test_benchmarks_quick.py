"""Smoke test: every benchmark runs in quick mode and returns finite figures."""

import math
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.__main__ import discover, run_areas  # noqa: E402


@pytest.mark.parametrize("area", discover())
def test_benchmark_quick(area):
    rows = run_areas([area], quick=True)
    assert rows, f"benchmark {area} returned no rows"
    for r in rows:
        assert math.isfinite(r.value), r
