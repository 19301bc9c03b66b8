"""A record towed at a varying speed: the trailer re-discretised at every station (docs/road-apl.md, "Varying towing
speed"); oracles: the instrument's own step, a dense Gaussian conditioning, the constant-speed path."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.cli.app import main
from longprofile.core import Profile
from longprofile.road.apl import (
    apl_model,
    instrument_state_space,
    reconstruct_profile,
    reconstruct_time_sampled,
    reconstruct_varying_speed,
    resample_model,
    simulate_apl_recording,
    station_steps,
    step_transitions,
    varying_speed_model,
)
from longprofile.statespace import kalman_filter, rts_smoother


@settings(max_examples=20, deadline=None)
@given(st.floats(0.4, 4.0))
def test_step_transitions_are_the_model_at_its_step_and_resample_model_elsewhere(ratio):
    m = apl_model(20.0, 0.05)
    A, B, C, D = instrument_state_space(m)
    Ak, Bk, Ck, Dk = step_transitions(m, [m.dt, ratio * m.dt])
    np.testing.assert_allclose(Ak[0], A, rtol=0, atol=1e-10)
    np.testing.assert_allclose(Bk[0], B, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(Ck, C)
    np.testing.assert_array_equal(Dk, D)
    other = resample_model(m, ratio * m.dt) if ratio <= 5 * 0.5 / 0.0965 / 5 else None  # resolved at the new step
    if other is not None:
        np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(Ak[1])), np.sort_complex(other.poles),
                                   rtol=0, atol=1e-10)
        w = np.linspace(0.01, 3.0, 50)  # the same frequency response (Hz) as resample_model's
        Hk = np.array([(Ck @ np.linalg.solve(np.exp(1j * x) * np.eye(A.shape[0]) - Ak[1], Bk[1]) + Dk)[0, 0]
                       for x in w])
        np.testing.assert_allclose(Hk, other.response_at(w / (2 * np.pi * other.dt)), rtol=1e-7, atol=1e-12)


def test_time_varying_smoother_and_likelihood_are_the_dense_gaussian_conditioning():
    """The engine on a time-varying model (F of shape (T-1, n, n)) against the joint Gaussian of states and
    observations built by stacking the recursion, conditioned on y by a dense solve (an external oracle)."""
    from scipy.stats import multivariate_normal

    m = apl_model(20.0, 0.05)
    T = 14
    v = np.linspace(12.0, 28.0, T)
    model = varying_speed_model(m, station_steps(v, 0.05), 2e-6, 1e-8)
    n = model.n_states
    F = model.transition
    # joint covariance of Z = (z_0..z_T-1): z_k = Phi(k, 0) z_0 + sum_j Phi(k, j+1) w_j
    Phi = [np.eye(n)]
    for k in range(T - 1):
        Phi.append(F[k] @ Phi[-1])
    cov = np.zeros((T * n, T * n))
    for a in range(T):
        for b in range(T):
            c = Phi[a] @ model.initial_cov @ Phi[b].T
            for j in range(min(a, b)):
                pa = np.linalg.multi_dot([F[i] for i in range(a - 1, j, -1)] + [np.eye(n)]) if a - 1 > j else np.eye(n)
                pb = np.linalg.multi_dot([F[i] for i in range(b - 1, j, -1)] + [np.eye(n)]) if b - 1 > j else np.eye(n)
                c = c + pa @ model.process_cov @ pb.T
            cov[a * n:(a + 1) * n, b * n:(b + 1) * n] = c
    H = np.kron(np.eye(T), model.observation)
    Syy = H @ cov @ H.T + model.obs_cov[0, 0] * np.eye(T)
    y = multivariate_normal(np.zeros(T), Syy).rvs(random_state=3)
    gain = np.linalg.solve(Syy, H @ cov).T
    mean = gain @ y
    post = cov - gain @ H @ cov
    sm = rts_smoother(model, kalman_filter(model, y))
    np.testing.assert_allclose(sm.mean.reshape(-1), mean, rtol=1e-6, atol=1e-9 * np.abs(mean).max())
    u = np.arange(T) * n + n - 1
    np.testing.assert_allclose(sm.cov[:, -1, -1], np.diag(post)[u], rtol=1e-6, atol=1e-18)
    assert kalman_filter(model, y).log_likelihood == pytest.approx(multivariate_normal(np.zeros(T), Syy).logpdf(y),
                                                                    rel=1e-9)


def test_at_a_constant_speed_the_varying_path_is_the_constant_speed_reconstruction():
    m = apl_model(20.0, 0.05)
    rec = simulate_apl_recording("iso8608", m, length=400, road_class="C", noise_fraction=0.02, rng=1)
    p = Profile(rec.distance, rec.signal)
    a = reconstruct_profile(p, m)
    b = reconstruct_varying_speed(p, np.full(p.n_samples, 20.0), m)
    assert b.q == pytest.approx(a.q, rel=1e-6) and b.r == pytest.approx(a.r, rel=1e-6)
    np.testing.assert_allclose(b.profile.elevation, a.profile.elevation, rtol=0, atol=1e-9)
    np.testing.assert_allclose(b.profile.std, a.profile.std, rtol=1e-9)
    # the Wiener model of a trailer with a zero at 1 is not detectable: its covariance recursion amplifies the
    # 2e-13 of A_k (eigenvalues) to ~1e-4 relative near the start
    np.testing.assert_allclose(b.raw_std, a.raw_std, rtol=1e-3)
    assert b.speed_range == (20.0, 20.0, 20.0) and a.speed_range is None


def _varying_file(tmp_path, *, column="Speed [km/h]", kmh=None):
    """A 20 m/s simulated record with a speed column of 61-83 km/h (traffic)."""
    plain = tmp_path / "plain.csv"
    assert main(["road", "simulate", "--length", "300", "--seed", "2", "-o", str(plain)]) == 0
    df = pd.read_csv(plain)
    x = df["distance_m"].to_numpy()
    df.insert(1, column, 72.0 + 11.0 * np.sin(2 * np.pi * x / 150.0) if kmh is None else kmh)
    df.to_csv(tmp_path / "vary.csv", index=False)
    return tmp_path / "vary.csv", plain


def test_a_varying_speed_record_is_reconstructed_at_each_stations_speed(tmp_path, capsys):
    """61-83 km/h was refused ("reconstruct separately the parts ..."): now it is reconstructed, with std_m printed at
    every station and the provenance saying how; batch reconstruct does the same through the same function."""
    from longprofile.batch import ReconstructTask
    from longprofile.io import read_report_table

    rec, _ = _varying_file(tmp_path)
    assert main(["road", "reconstruct", str(rec), "-o", str(tmp_path / "o.csv")]) == 0
    err = "".join(capsys.readouterr().err.split())  # rich wraps anywhere
    assert "re-discretisedateachstation'sspeed" in err
    out = pd.read_csv(tmp_path / "o.csv", comment="#")
    assert out["std_m"].notna().all() and out["raw_std_m"].notna().all()
    meta = read_report_table(tmp_path / "o.csv")[1]
    assert meta["towing_speed"].startswith("varying") and len(meta["speed_min_median_max_m_per_s"]) == 3
    task = ReconstructTask()(rec)
    np.testing.assert_array_equal(task.profile["elevation_m"].to_numpy(), out["elevation_m"].to_numpy())
    assert "re-discretised" in task.warning


@pytest.mark.parametrize("args, message", [
    (["--method", "double"], "--method double assumes a constant speed"),
    (["--method", "fixed-lag"], "--method fixed-lag assumes a constant speed"),
    (["--instrument-uncertainty", "freq=0.1"], "without --instrument-uncertainty"),
    (["--speed", "6"], "leave out --speed"),
])
def test_what_a_varying_speed_cannot_do_is_still_refused_in_one_line(tmp_path, capsys, args, message):
    rec, _ = _varying_file(tmp_path)
    assert main(["road", "reconstruct", str(rec), "-o", str(tmp_path / "o.csv"), *args]) == 2
    err = capsys.readouterr().err
    assert "".join(message.split()) in "".join(err.split()) and "Traceback" not in err
    assert not (tmp_path / "o.csv").exists()


def test_a_constant_speed_column_gives_the_output_of_a_file_without_one_bit_for_bit(tmp_path):
    """Regression guard: a record towed at a constant 72 km/h takes the constant-speed path unchanged."""
    rec, plain = _varying_file(tmp_path, kmh=72.0)
    assert main(["road", "reconstruct", str(rec), "-o", str(tmp_path / "a.csv")]) == 0
    assert main(["road", "reconstruct", str(plain), "-o", str(tmp_path / "b.csv")]) == 0
    a = pd.read_csv(tmp_path / "a.csv", comment="#")
    b = pd.read_csv(tmp_path / "b.csv", comment="#")
    pd.testing.assert_frame_equal(a, b, check_exact=True)


def test_a_time_sampled_record_at_the_models_step_is_the_constant_speed_reconstruction():
    """At a constant 20 m/s sampled every dt = dx / V, the reconstruction at the file's time step (one station per
    step) is the constant-speed one."""
    m = apl_model(20.0, 0.05)
    rec = simulate_apl_recording("iso8608", m, length=400, road_class="B", noise_fraction=0.02, rng=4)
    p = Profile(rec.distance, rec.signal)
    a = reconstruct_profile(p, m)
    b = reconstruct_time_sampled((rec.distance / 20.0, rec.distance, rec.signal), p, np.full(p.n_samples, 20.0), m)
    assert b.q == pytest.approx(a.q, rel=1e-6) and b.r == pytest.approx(a.r, rel=1e-6)
    np.testing.assert_allclose(b.profile.elevation, a.profile.elevation, rtol=0, atol=1e-9)
    np.testing.assert_allclose(b.profile.std, a.profile.std, rtol=1e-9)


def _time_sampled(length, speed_of_time, *, dt=0.0025, seed=5, noise=0.02, slowest=17.0):
    """The Table 1 20 m/s trailer run at its own step dt (its dynamics are in time) along a road at x(t), white noise
    per time sample: (time samples, record at every 5 cm, speed there, truth there)."""
    from longprofile.road import iso8608_profile
    from longprofile.road.apl import apl_filter

    rng = np.random.default_rng(seed)
    road = iso8608_profile(length + 20.0, 0.01, "B", rng=rng)
    t = np.arange(0.0, 1.2 * length / slowest, dt)
    v = speed_of_time(t)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    t, v, x = t[x <= length], v[x <= length], x[x <= length]
    u = np.interp(x, road.distance, road.elevation[:, 0])
    y = np.asarray(apl_filter(apl_model(20.0, 0.05), u)).reshape(-1)
    y = y + rng.normal(0.0, noise * np.std(y), y.size)
    grid = np.arange(0.0, x[-1], 0.05)
    p = Profile(grid, np.interp(grid, x, y))
    return (t, x, y), p, np.interp(grid, x, v), np.interp(grid, road.distance, road.elevation[:, 0])


def test_the_noise_of_a_time_sampled_record_taken_at_every_dx_is_the_interpolated_noise():
    """The cause of the time path's band twice too wide (sp_vary.csv, 99.9 %): linear interpolation of the file's
    samples onto the stations averages their noise, so the record at every dx is not white of variance r and the
    short-wave estimate failed its noise check. Oracle: a Monte Carlo of interpolated white noise."""
    from longprofile.road.apl._short_waves import SHORT_WAVE_NOISE_FLOOR_RANGE, _welch
    from longprofile.road.apl._varying_speed import _interpolated_noise

    rng = np.random.default_rng(1)
    x = np.concatenate([[0.0], np.cumsum(0.05 * rng.uniform(0.75, 1.25, 12_000))])  # 15-25 m/s at 2.5 ms
    grid = np.arange(0.0, x[-1], 0.05)
    missing = np.zeros(grid.size, bool)
    missing[3000:3010] = True
    noise = _interpolated_noise(x, grid, missing, 2.0)
    acc = 0.0
    for _ in range(40):
        e = np.interp(grid, x, rng.normal(0.0, np.sqrt(2.0), x.size))
        e[missing] = np.nan
        w, P, _ = _welch(e, 4096)
        acc = acc + P / 40
    for lo, hi in [(50, 500), (500, 1500), (1500, 2048)]:
        assert np.mean(acc[lo:hi]) == pytest.approx(np.mean(noise(w[lo:hi])), rel=0.02)
    assert np.mean(noise(w[1500:])) < SHORT_WAVE_NOISE_FLOOR_RANGE[0] * 2.0  # below r where the road is invisible
    assert _interpolated_noise(np.arange(100.0) * 0.05, np.arange(100.0) * 0.05, np.zeros(100, bool), 2.0) is None


def test_a_time_sampled_record_at_a_varying_speed_prints_the_band_of_the_same_road_at_a_constant_speed():
    """17-23 m/s sampled every 2.5 ms (0.87-1.15 samples per station), the trailer's exact discrete dynamics: the
    printed std is that of the same road and noise recorded at a constant 20 m/s (one sample per station, the
    constant-speed path, calibrated), not twice it (before 2026-12-08: the noise check failed, the prior's short
    waves taken), and covers the error."""
    from longprofile.road.apl import detrend_profile

    samples, p, v, truth = _time_sampled(600.0, lambda t: 20.0 + 3.0 * np.sin(2 * np.pi * t / 10.0))
    rec = reconstruct_time_sampled(samples, p, v, apl_model(20.0, 0.05))
    _, p20, _, _ = _time_sampled(600.0, lambda t: np.full(t.size, 20.0))
    ref = reconstruct_profile(p20, apl_model(20.0, 0.05))
    inner = (p.distance > 100.0) & (p.distance < p.distance[-1] - 100.0)
    ratio = np.median(rec.profile.std[inner, 0]) / np.median(ref.profile.std[:, 0])
    assert 0.8 < ratio < 1.25
    err = rec.profile.elevation[:, 0] - detrend_profile(truth - truth[0], 0.05)
    z = np.sqrt(np.mean(err[inner] ** 2) / np.mean(rec.profile.std[inner, 0] ** 2))
    assert 0.7 < z < 1.4


@pytest.mark.parametrize("speed", [2.5, 10.0])
def test_a_station_sampled_k_times_has_the_std_of_the_constant_speed_path_on_the_files_grid(speed):
    """At a constant 2.5 (10) m/s sampled every 2.5 ms, each 5 cm station is sampled 8 (2) times: the printed std is
    the constant-speed path's on the same samples read at their own spacing (6.25 mm, 2.5 cm; the trailer at its
    step), not that of one sample per station at dx / v = 20 ms (before 2026-12-08: 2.5 x it at 2.5 m/s)."""
    samples, p, v, _ = _time_sampled(300.0, lambda t: np.full(t.size, speed), slowest=speed)
    rec = reconstruct_time_sampled(samples, p, v, apl_model(20.0, 0.05))
    h = speed * 0.0025
    own = Profile(h * np.arange(samples[2].size), samples[2])
    ref = reconstruct_profile(own, resample_model(apl_model(20.0, 0.05), 0.0025, speed=speed, dx=h))
    inner = (p.distance > 100.0) & (p.distance < p.distance[-1] - 100.0)
    at = (own.distance > 100.0) & (own.distance < own.distance[-1] - 100.0)
    assert np.median(rec.profile.std[inner, 0]) == pytest.approx(np.median(ref.profile.std[at, 0]), rel=0.05)
