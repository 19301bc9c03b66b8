"""The force-model error against the accelerometer (force_scale_fit) and estimate_slope's correction (issue 13)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.vehicle import default_vehicle, drive_scenario, estimate_slope, force_scale_fit, simulate_drive
from longprofile.vehicle.planar import GRAVITY

Z90 = 1.6448536269514722
M, DT = 1500.0, 1e-3


def _synthetic(rng, beta, c, T=24_000, noise=0.5):
    """F_res varying block by block, the accelerometer reading F_res/(M (1 + beta)) - c g plus white noise."""
    force = np.repeat(rng.uniform(-4000.0, 4000.0, T // 500), 500)
    ax = force / M - beta * force / M - c * GRAVITY + rng.normal(0.0, noise, T)
    return force, ax, np.zeros(T), np.zeros(T)


def test_posterior_intervals_of_beta_and_offset_are_calibrated():
    """Over 300 random cases with a weak prior, the 90 % intervals of beta and c cover the truth 85-95 %."""
    rng = np.random.default_rng(7)
    hits = np.zeros(2)
    n = 300
    for _ in range(n):
        beta, c = rng.uniform(-0.2, 0.2), rng.uniform(-0.02, 0.02)
        fit = force_scale_fit(*_synthetic(rng, beta, c), M, DT, beta_prior_std=10.0, offset_prior_std=10.0)
        hits += np.abs(np.array([fit.beta - beta, fit.offset - c])) <= Z90 * np.array([fit.beta_std, fit.offset_std])
    assert np.all((0.85 <= hits / n) & (hits / n <= 0.95)), hits / n


@settings(max_examples=25, deadline=None)
@given(level=st.floats(-3000.0, 3000.0), prior=st.floats(0.01, 1.0), seed=st.integers(0, 2**16))
def test_a_constant_force_says_nothing_about_beta(level, prior, seed):
    """Cruising at one force x0 (in sin(theta)): the data fix beta x0 + c only, so beta's posterior is its prior
    conditioned on that constraint, precision 1/prior^2 + x0^2/offset_prior^2."""
    rng = np.random.default_rng(seed)
    T = 12_000
    force = np.full(T, level)
    ax = force / M + rng.normal(0.0, 0.3, T)
    fit = force_scale_fit(force, ax, np.zeros(T), np.zeros(T), M, DT, beta_prior_std=prior, offset_prior_std=0.03)
    x0 = level / (M * GRAVITY)
    assert fit.beta_std == pytest.approx((1 / prior**2 + x0**2 / 0.03**2) ** -0.5, rel=0.02)


def test_too_short_a_log_returns_the_prior_and_bad_input_is_refused():
    rng = np.random.default_rng(0)
    fit = force_scale_fit(*_synthetic(rng, 0.1, 0.0, T=5_000), M, DT, beta_prior_std=0.15, offset_prior_std=0.03)
    assert fit.n_blocks == 0 and fit.beta == 0.0 and fit.beta_std == pytest.approx(0.15)
    force, ax, r, vy = _synthetic(rng, 0.0, 0.0)
    with pytest.raises(InputError, match="one length"):
        force_scale_fit(force, ax[:-1], r, vy, M, DT, beta_prior_std=0.15, offset_prior_std=0.03)
    with pytest.raises(InputError, match="finite and > 0"):
        force_scale_fit(force, ax, r, vy, -M, DT, beta_prior_std=0.15, offset_prior_std=0.03)


@pytest.fixture(scope="module")
def heavy_hill():
    """The hill drive with a car 15 % heavier than the estimator's."""
    car = default_vehicle()
    sim = simulate_drive(drive_scenario("hill", duration=20.0), car.with_changes(mass=1.15 * car.mass), seed=5)
    return sim, car


def test_the_correction_finds_a_mass_error_and_removes_most_of_its_slope_error(heavy_hill):
    sim, car = heavy_hill
    keep = sim.log.time >= 2.0
    for method in ("cascade", "joint"):
        fixed = estimate_slope(sim.log, car, method=method)
        paper = estimate_slope(sim.log, car, method=method, force_correction=False)
        # the model's F_res/M is 1.15 times the true specific force: d = (1 - 1/1.15) F_res/(M g)
        assert fixed.force_fit.beta == pytest.approx(1 - 1 / 1.15, abs=0.03), method
        rms = [np.sqrt(np.mean((e.slope - sim.truth.slope)[keep] ** 2)) for e in (fixed, paper)]
        assert rms[0] < 0.6 * rms[1], (method, rms)
        err = (fixed.slope - sim.truth.slope)[keep]
        assert 0.85 <= np.mean(np.abs(err) <= Z90 * fixed.slope_std[keep]) <= 1.0, method


def test_cli_prints_the_fit_and_no_force_correction_gives_the_papers_estimate(tmp_path, capsys):
    import pandas as pd

    from longprofile.cli.app import main

    log = tmp_path / "log.csv"
    assert main(["vehicle", "simulate", "--scenario", "hill", "--duration", "10", "-o", str(log)]) == 0
    capsys.readouterr()
    assert main(["vehicle", "slope", str(log), "-o", str(tmp_path / "a.csv")]) == 0
    printed = capsys.readouterr()
    assert "force model vs accelerometer (9 blocks of 1 s)" in " ".join((printed.out + printed.err).split())
    assert main(["vehicle", "slope", str(log), "-o", str(tmp_path / "b.csv"), "--no-force-correction"]) == 0
    printed = capsys.readouterr()
    assert "force model vs accelerometer" not in printed.out + printed.err
    a, b = (pd.read_csv(tmp_path / f) for f in ("a.csv", "b.csv"))
    truth = pd.read_csv(log)["true_slope"]
    keep = a["time"] >= 2.0
    assert not np.allclose(a["slope"], b["slope"])
    # the same drive, the own car: the corrected band is several times narrower and still holds the truth
    assert np.median(a["slope_std"][keep]) < 0.5 * np.median(b["slope_std"][keep])
    assert np.mean(np.abs(a["slope"] - truth)[keep] <= Z90 * a["slope_std"][keep]) >= 0.9


def test_a_reversed_accelerometer_is_named_in_the_warnings(heavy_hill):
    """accel_x of the wrong sign makes d ~ 2 F_res/(M g): far beyond the prior, so warnings() says so."""
    from dataclasses import replace

    sim, car = heavy_hill
    good = estimate_slope(sim.log, car)
    bad = estimate_slope(replace(sim.log, accel_x=-sim.log.accel_x), car)
    assert not any("accelerometer disagree" in w for w in good.warnings())
    assert abs(bad.force_fit.beta) > 0.3
    assert any("accelerometer disagree" in w for w in bad.warnings())
