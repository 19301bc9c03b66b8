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


def test_vehicle_calibration_stated_background_draws_within_the_stated_tolerances():
    """The stated-tolerance cars scatter by SlopeUncertainty's stds; the family's own parameter is left to it."""
    import numpy as np
    from benchmarks.bench_vehicle_calibration import _stated_background, calibrate

    from longprofile.vehicle import SensorSpec, SlopeUncertainty, default_vehicle

    car, unc, rng = default_vehicle(), SlopeUncertainty(), np.random.default_rng(0)
    draws = [_stated_background("own model", rng, car, SensorSpec()) for _ in range(2000)]
    mass = np.array([c.mass for c, *_ in draws]) / car.mass - 1
    offset = np.array([s.accel_offset for _, s, *_ in draws])
    gain = np.array([g for *_, g in draws]) - 1
    for x, std in ((mass, unc.mass_rel_std), (offset, unc.accel_offset_std), (gain, unc.accel_gain_std)):
        assert abs(np.std(x) / std - 1) < 0.08 and abs(np.mean(x)) < 0.1 * std
    heavy = car.with_changes(mass=1.2 * car.mass)
    assert _stated_background("mass error", rng, heavy, SensorSpec())[0].mass == heavy.mass
    scores = calibrate("own model", 1, duration=6.0, background="stated", methods=("cascade",))
    assert all(sc.n > 0 for sc in scores.values())
