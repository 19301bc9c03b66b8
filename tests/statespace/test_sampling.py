"""Forward-filter backward-sample and simulation: moments against the RTS smoother, scipy oracles
(dlsim, discrete Lyapunov), singular process noise, reproducibility, errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from numpy.testing import assert_allclose, assert_array_equal

import longprofile.statespace as ss
from longprofile.errors import InputError, ShapeError
from longprofile.statespace import StateSpaceModel, kalman_filter, posterior_sample, rts_smoother, simulate
from tests.statespace._models import draw, random_model

N_SIGMA = 5.0  # per-entry tolerance in standard errors of the Monte Carlo estimate (fixed seeds)


def _check_moments(samples, sm):
    """Sample mean, covariance and lag-one cross-covariance of FFBS draws vs the smoother, with
    tolerances from the sampling distribution of each estimate (Gaussian: var(s_ij) = (S_ii S_jj + S_ij^2)/N)."""
    N = samples.shape[0]
    mu = samples.mean(axis=0)
    d = samples - mu
    var = np.einsum("tii->ti", sm.cov)
    assert np.all(np.abs(mu - sm.mean) <= N_SIGMA * np.sqrt(var / N) + 1e-12)
    cov = np.einsum("sti,stj->tij", d, d) / (N - 1)
    sd = np.sqrt((var[:, :, None] * var[:, None, :] + sm.cov**2) / N)
    assert np.all(np.abs(cov - sm.cov) <= N_SIGMA * sd + 1e-12)
    cc = np.einsum("sti,stj->tij", d[:, :-1], d[:, 1:]) / (N - 1)
    sd = np.sqrt((var[:-1, :, None] * var[1:, None, :] + sm.cross_cov**2) / N)
    assert np.all(np.abs(cc - sm.cross_cov) <= N_SIGMA * sd + 1e-12)


@pytest.mark.parametrize("n,m", [(2, 1), (3, 2)])
def test_ffbs_moments_converge_to_smoother(n, m):
    rng = np.random.default_rng(21 + n)
    T = 25
    model = random_model(rng, n, m, T, tv=True, tv_cov=True, offsets=True)
    _x, y = draw(model, T, rng)
    y[5:8] = np.nan
    y[12, 0] = np.nan
    samples = posterior_sample(model, y, 4000, rng=np.random.default_rng(1))
    assert samples.shape == (4000, T, n)
    _check_moments(samples, rts_smoother(model, kalman_filter(model, y)))


def test_ffbs_integrated_random_walk_with_singular_process_noise():
    """Noise on the velocity only: given x_{t+1}, x_t lies on a line (singular conditional covariance)."""
    dt = 0.1
    model = StateSpaceModel([[1.0, dt], [0.0, 1.0]], [[1.0, 0.0]], np.diag([0.0, 0.5]), [[0.2]],
                            [0.0, 0.0], np.eye(2))
    rng = np.random.default_rng(4)
    _x, y = draw(model, 40, rng)
    y[10:18] = np.nan
    samples = posterior_sample(model, y, 4000, rng=2)
    assert np.all(np.isfinite(samples))
    # every draw satisfies the deterministic part of the dynamics exactly
    resid = samples[:, 1:, 0] - samples[:, :-1, 0] - dt * samples[:, :-1, 1]
    assert np.max(np.abs(resid)) < 1e-9
    _check_moments(samples, rts_smoother(model, kalman_filter(model, y)))


def test_ffbs_batched_inputs_and_reproducible():
    rng = np.random.default_rng(8)
    T, B = 15, 2
    model = random_model(rng, 2, 1, T, p=1)
    u = rng.normal(size=(T, 1))
    y = np.stack([draw(model, T, rng, u=u)[1] for _ in range(B)])
    a = posterior_sample(model, y, 3000, rng=5, u=u)
    assert a.shape == (3000, B, T, 2)
    assert_array_equal(a, posterior_sample(model, y, 3000, rng=np.random.default_rng(5), u=u))
    sm = rts_smoother(model, kalman_filter(model, y, u=u))
    for b in range(B):
        one = type(sm)(mean=sm.mean[b], cov=sm.cov[b], cross_cov=sm.cross_cov[b], filtered=sm.filtered)
        _check_moments(a[:, b], one)


def test_simulate_deterministic_matches_scipy_dlsim():
    """Zero noise: the trajectory is the LTI response, offsets acting as a constant extra input."""
    rng = np.random.default_rng(3)
    n, m, p, T = 3, 2, 2, 50
    F = 0.9 * np.linalg.qr(rng.normal(size=(n, n)))[0]
    H, Bm, Dm = rng.normal(size=(m, n)), rng.normal(size=(n, p)), rng.normal(size=(m, p))
    c, d, x0 = rng.normal(size=n), rng.normal(size=m), rng.normal(size=n)
    model = StateSpaceModel(F, H, np.zeros((n, n)), np.zeros((m, m)), x0, np.zeros((n, n)),
                            input_transition=Bm, input_observation=Dm, state_offset=c, obs_offset=d)
    u = rng.normal(size=(T, p))
    x, y = simulate(model, T, rng=0, u=u)
    u_ext = np.column_stack([u, np.ones(T)])
    _t, y_ref, x_ref = scipy.signal.dlsim((F, np.column_stack([Bm, c]), H, np.column_stack([Dm, d]), 1.0),
                                          u_ext, x0=x0)
    assert_allclose(x, x_ref, rtol=0, atol=1e-10)
    assert_allclose(y, y_ref, rtol=0, atol=1e-10)


def test_simulate_stationary_covariance_matches_lyapunov():
    rng = np.random.default_rng(12)
    n, m, T = 2, 2, 100_000
    F = np.array([[0.8, 0.2], [-0.1, 0.7]])
    Q = np.array([[0.5, 0.1], [0.1, 0.3]])
    R = np.array([[0.2, 0.0], [0.0, 0.4]])
    H = rng.normal(size=(m, n))
    Sigma = scipy.linalg.solve_discrete_lyapunov(F, Q)
    model = StateSpaceModel(F, H, Q, R, np.zeros(n), Sigma)
    x, y = simulate(model, T, rng=1)
    # effective sample size >= T / 20 for this spectral radius (~0.77): relative error ~ 2 %
    assert_allclose(np.cov(x.T), Sigma, rtol=0, atol=0.08 * np.abs(Sigma).max())
    assert_allclose(np.cov(y.T), H @ Sigma @ H.T + R, rtol=0, atol=0.08 * np.abs(H @ Sigma @ H.T + R).max())
    assert np.abs(x.mean(axis=0)).max() < 0.05


def test_simulate_time_varying_and_singular_noise_is_exact_on_null_directions():
    T, dt = 30, 0.05
    F = np.stack([[[1.0, dt * (1 + 0.1 * k)], [0.0, 1.0]] for k in range(T - 1)])
    Q = np.stack([np.diag([0.0, 0.1 + 0.01 * k]) for k in range(T - 1)])
    model = StateSpaceModel(F, [[1.0, 0.0]], Q, [[0.1]], [0.0, 1.0], np.diag([1.0, 0.0]))
    x, y = simulate(model, T, rng=3)
    assert x[0, 1] == 1.0
    assert_allclose(x[1:, 0], x[:-1, 0] + F[:, 0, 1] * x[:-1, 1], rtol=0, atol=1e-12)
    with pytest.raises(ShapeError, match=r"time-varying with 29 steps, but the data have T = 31"):
        simulate(model, 31)


def test_sampling_errors():
    model = random_model(np.random.default_rng(0), 2, 1, 5)
    y = np.zeros(5)
    with pytest.raises(InputError, match=r"n_samples must be a positive integer; got 0"):
        posterior_sample(model, y, 0)
    with pytest.raises(InputError, match=r"rng must be None, an integer seed or a numpy.random.Generator"):
        posterior_sample(model, y, 3, rng="seed")
    with pytest.raises(InputError, match=r"n_steps must be a positive integer"):
        simulate(model, 2.5)
    with pytest.raises(ShapeError, match=r"y must have m = 1 columns"):
        posterior_sample(model, np.zeros((5, 2)), 3)


def test_public_names():
    assert ss.posterior_sample is posterior_sample and ss.simulate is simulate
    assert {"posterior_sample", "simulate"} <= set(ss.__all__)
