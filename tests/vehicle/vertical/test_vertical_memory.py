"""Memory of the vertical estimator on long logs (probe of 2026-12-07, session 38).

The per-corner EKFs used to keep every filtered and predicted covariance, innovation covariance and Jacobian
(~7.7 kB per sample in configurations 2 and 3: 17.7 GB for 30 min at 1 kHz); a log estimate now keeps the means
and the filtered variances only, with the same numbers.
"""

import tracemalloc

import numpy as np
import pytest

from longprofile.errors import InputError
from longprofile.statespace import block_extended_kalman_filter, extended_kalman_filter
from longprofile.vehicle import (
    estimate_vertical_log,
    estimate_vertical_states,
    vertical_ekf_inputs,
    vertical_ekf_model,
    vertical_test_run,
)
from longprofile.vehicle.vertical import STATE_BLOCKS, smooth_vertical_states

#: Bound on the traced peak per sample of a log estimate (numpy arrays are traced): the old code kept ~9.3 kB per
#: sample (config 3), the new one ~1.1 kB (the estimate's outputs plus the handling simulation of the zero check).
PEAK_BYTES_PER_SAMPLE = 2000


@pytest.fixture(scope="module")
def config3_runs():
    return {d: vertical_test_run(3, test="road", road_class="C", speed=20.0, duration=d, seed=4)[1] for d in (2.5, 20.0)}


def test_log_estimate_peak_memory_per_sample_is_bounded(config3_runs):
    estimate_vertical_log(config3_runs[2.5])  # compiled code and caches loaded outside the measurement
    sensors = config3_runs[20.0]
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        result = estimate_vertical_log(sensors)
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    per_sample = peak / sensors.time.size
    assert per_sample < PEAK_BYTES_PER_SAMPLE, f"{per_sample:.0f} B per sample"
    assert result.estimate.state_std.shape == (sensors.time.size, 16)


@pytest.mark.parametrize("decentralised", [True, False])
def test_lean_estimate_has_the_same_numbers(config3_runs, decentralised):
    sensors = config3_runs[2.5]
    full = estimate_vertical_states(sensors, decentralised=decentralised)
    lean = estimate_vertical_states(sensors, decentralised=decentralised, store_covariances=False)
    for name in ("suspension_deflection", "suspension_velocity", "vehicle_disturbance", "tyre_deflection",
                 "tyre_force", "body_velocity", "wheel_velocity", "state_std", "actuator_force"):
        np.testing.assert_array_equal(getattr(lean, name), getattr(full, name), err_msg=name)
    assert lean.filtered.cov is None and lean.filtered.pred_mean is None
    assert full.filtered.cov is not None


def test_smoothing_a_lean_estimate_says_what_to_do(config3_runs):
    lean = estimate_vertical_log(config3_runs[2.5]).estimate
    with pytest.raises(InputError, match="store_covariances=True"):
        smooth_vertical_states(lean)


@pytest.mark.parametrize("block", [True, False])
def test_engine_variances_mode_is_the_diagonal_of_the_covariances(config3_runs, block):
    sensors = config3_runs[2.5]
    model = vertical_ekf_model(3, sensors.dt, fused_steps=block, decentralised=block)
    y = np.hstack([sensors.displacement, sensors.wheel_accel])
    u = vertical_ekf_inputs(sensors)

    def run(store):
        if block:
            return block_extended_kalman_filter(model, y, u=u, state_blocks=STATE_BLOCKS,
                                                obs_blocks=np.tile(np.arange(4), 2), store_covariances=store)
        return extended_kalman_filter(model, y, u=u, store_covariances=store)

    full, lean = run(True), run("variances")
    np.testing.assert_array_equal(lean.variance, np.diagonal(full.cov, axis1=1, axis2=2))
    np.testing.assert_array_equal(lean.mean, full.mean)
    assert lean.cov is None and lean.pred_cov is None and lean.transition_jacobians is None
    assert run(False).variance is None and full.variance is None
    with pytest.raises(InputError, match="'variances'"):
        run("diagonal")


def _memory_error(*args, **kwargs):
    raise MemoryError("Unable to allocate 28 GiB")


def test_cli_out_of_memory_names_what_the_estimate_can_do(tmp_path, monkeypatch, capsys):
    import longprofile.vehicle as vehicle
    from longprofile.cli.app import main
    from longprofile.io import write_table
    from longprofile.vehicle import sensors_to_frame

    _, sens = vertical_test_run(3, test="road", road_class="C", speed=20.0, duration=1.0, seed=4)
    log = tmp_path / "log.csv"
    write_table(sensors_to_frame(sens), log)
    monkeypatch.setattr(vehicle, "estimate_vertical_log", _memory_error)
    assert main(["vehicle", "vertical", "estimate", str(log), "-o", str(tmp_path / "s.csv")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "not enough memory for this request" in err and "split the log into shorter files" in err
    for option in ("--length", "--duration", "--days", "--sampling-minutes"):  # options it does not have
        assert option not in err


def test_cli_out_of_memory_names_only_options_the_command_has(tmp_path, capsys):
    from longprofile.cli.app import main

    assert main(["road", "simulate", "--length", "1e14", "-o", str(tmp_path / "x.csv")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "reduce its size (--length) or split the input" in err and "--sampling-minutes" not in err
