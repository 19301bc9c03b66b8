"""process_noise_moments: E[w w^T | y] from a smoother against dense Gaussian conditioning."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.statespace import StateSpaceModel, kalman_filter, process_noise_moments, rts_smoother


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), T=st.integers(2, 6))
def test_process_noise_moments_match_dense_conditioning(seed, T):
    rng = np.random.default_rng(seed)
    n = 2
    F = np.eye(n) + 0.3 * rng.normal(size=(n, n))
    L = rng.normal(size=(n, n)); Q = L @ L.T + 0.1 * np.eye(n)
    H = rng.normal(size=(1, n)); R = np.array([[0.5]])
    c = rng.normal(size=n)
    m0, P0 = rng.normal(size=n), np.eye(n)
    model = StateSpaceModel(transition=F, observation=H, process_cov=Q, obs_cov=R, initial_mean=m0,
                            initial_cov=P0, state_offset=c)
    y = rng.normal(size=(T, 1))
    got = process_noise_moments(model, rts_smoother(model, kalman_filter(model, y)))
    # dense: X = (x_0..x_{T-1}) = A (x_0, w_0..w_{T-2}) + b
    k = n * T
    A = np.zeros((k, k)); b = np.zeros(k)
    off = np.zeros(n)
    for t in range(T):
        if t > 0:
            off = F @ off + c
        b[n * t:n * t + n] = off
        for s in range(t + 1):
            A[n * t:n * t + n, n * s:n * s + n] = np.linalg.matrix_power(F, t - s)
    mz = np.r_[m0, np.zeros(n * (T - 1))]
    Sz = np.zeros((k, k)); Sz[:n, :n] = P0
    for t in range(1, T):
        Sz[n * t:n * t + n, n * t:n * t + n] = Q
    mX, SX = A @ mz + b, A @ Sz @ A.T
    Hb = np.kron(np.eye(T), H)
    S = Hb @ SX @ Hb.T + np.kron(np.eye(T), R)
    K = SX @ Hb.T @ np.linalg.inv(S)
    mp = mX + K @ (y.ravel() - Hb @ mX)
    Sp = SX - K @ Hb @ SX
    for t in range(T - 1):
        E = np.zeros((n, k)); E[:, n * (t + 1):n * (t + 2)] = np.eye(n); E[:, n * t:n * t + n] = -F
        d = E @ mp - c
        want = np.outer(d, d) + E @ Sp @ E.T
        assert np.allclose(got[t], want, rtol=1e-6, atol=1e-8)
