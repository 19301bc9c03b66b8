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


def test_vehicle_calibration_sample_rate_families_sample_the_log_and_the_truth_alike():
    """The ``sample rate`` families (session 38): a rate of 50-200 Hz, plain sampling keeps the 1 kHz values at the
    returned index, the anti-alias FIR keeps a smooth channel and reduces the white gyro noise by about sqrt(step);
    the other families' logs pass as they are; calibrate scores them against the truth at the same samples."""
    import numpy as np
    from benchmarks.bench_vehicle_calibration import _sampled, calibrate

    from longprofile.vehicle import drive_scenario, simulate_drive

    sim = simulate_drive(drive_scenario("paper", duration=4.0), seed=0)
    log = sim.log
    assert _sampled("own model", np.random.default_rng(0), log) == (log, slice(None))
    for seed in range(6):
        plain, i = _sampled("sample rate", np.random.default_rng(seed), log)
        step = round(plain.dt / log.dt)
        assert 5 <= step <= 20 and i.step == step and 0 <= i.start < step
        np.testing.assert_array_equal(plain.yaw_rate, log.yaw_rate[i])
        np.testing.assert_array_equal(plain.wheel_speeds, log.wheel_speeds[i])
        filt, j = _sampled("sample rate, filtered", np.random.default_rng(seed), log)
        assert j == i and filt.time.size == plain.time.size
        np.testing.assert_allclose(filt.wheel_speeds, log.wheel_speeds[i], rtol=0.01)
        noise = filt.yaw_rate - sim.truth.yaw_rate[i]
        assert np.std(noise[5:-5]) < 2.0 * np.std(log.yaw_rate - sim.truth.yaw_rate) / np.sqrt(step)
    scores = calibrate("sample rate", 1, duration=6.0, methods=("cascade",))
    assert all(sc.n > 0 for sc in scores.values())
