"""statespace.shared_covariance_smoother (owned by the rail helper): same numbers as the per-series engine."""

import numpy as np
import pytest

from longprofile.errors import ShapeError
from longprofile.statespace import StateSpaceModel, kalman_filter, rts_smoother, shared_covariance_smoother


def _model(T, rng):
    h = rng.uniform(1, 3, T - 1)
    F = np.array([[[1, hh], [0, 1]] for hh in h])
    Q = np.array([[[hh**3 / 3, hh**2 / 2], [hh**2 / 2, hh]] for hh in h])
    return StateSpaceModel(F, np.eye(2), Q, np.diag([0.1, 0.2]), np.zeros(2), np.eye(2),
                           state_offset=np.full((T - 1, 2), 0.01), obs_offset=np.array([0.5, -0.2]))


def test_matches_kalman_filter_and_rts_smoother_with_missing_data():
    rng = np.random.default_rng(0)
    T = 30
    model = _model(T, rng)
    y = rng.normal(size=(4, T, 2))
    y[:, 3, 0] = np.nan
    y[:, 5, :] = np.nan
    y[:, -1, 1] = np.nan
    shared = shared_covariance_smoother(model, y)
    ref = rts_smoother(model, kalman_filter(model, y))
    assert np.allclose(shared.mean, ref.mean, atol=1e-12)
    assert np.allclose(shared.cov, ref.cov[0], atol=1e-12)
    assert np.allclose(shared.cross_cov, ref.cross_cov[0], atol=1e-12)
    assert np.allclose(shared.filtered.log_likelihood, ref.filtered.log_likelihood, atol=1e-9)
    assert np.allclose(shared.filtered.pred_mean, ref.filtered.pred_mean, atol=1e-12)
    assert shared.filtered.method == "shared-covariance"


def test_pykalman_oracle_single_series():
    pykalman = pytest.importorskip("pykalman")
    rng = np.random.default_rng(1)
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    model = StateSpaceModel(F, [[1.0, 0.0]], 0.01 * np.eye(2), [[0.5]], [0.0, 0.0], np.eye(2))
    y = np.cumsum(rng.normal(size=40))[:, None]
    ours = shared_covariance_smoother(model, y)
    kf = pykalman.KalmanFilter(transition_matrices=F, observation_matrices=[[1.0, 0.0]],
                               transition_covariance=0.01 * np.eye(2), observation_covariance=[[0.5]],
                               initial_state_mean=[0.0, 0.0], initial_state_covariance=np.eye(2))
    m, P = kf.smooth(y)
    assert np.allclose(ours.mean, m, atol=1e-9)
    assert np.allclose(ours.cov, P, atol=1e-9)
    assert ours.filtered.log_likelihood == pytest.approx(kf.loglikelihood(y), rel=1e-9)


def test_rejects_different_missing_patterns_and_inputs():
    rng = np.random.default_rng(2)
    model = _model(10, rng)
    y = rng.normal(size=(3, 10, 2))
    y[1, 2, 0] = np.nan
    with pytest.raises(ShapeError, match="same places"):
        shared_covariance_smoother(model, y)
    m_in = StateSpaceModel(np.eye(1), np.eye(1), np.eye(1), np.eye(1), [0.0], np.eye(1), input_transition=np.eye(1))
    with pytest.raises(ShapeError, match="known inputs"):
        shared_covariance_smoother(m_in, np.zeros((5, 1)))


def test_noise_covariance_equals_the_impulse_responses_of_the_engine_smoother():
    from longprofile.statespace import smoother_noise_covariance

    rng = np.random.default_rng(3)
    T = 12
    model = _model(T, rng)
    pattern = np.zeros((T, 2))
    pattern[2, 0] = pattern[7, :] = np.nan
    Rn = np.diag([0.1, 0.0])  # only the first component's noise drives the estimate
    got = smoother_noise_covariance(model, pattern, noise_cov=Rn)
    # oracle: the smoothed mean's linear map A from the observations, column by column, with the generic engine
    obs = np.argwhere(~np.isnan(pattern))
    base = rts_smoother(model, kalman_filter(model, pattern)).mean
    cols = []
    for k, j in obs:
        y = pattern.copy()
        y[k, j] = 1.0
        cols.append(rts_smoother(model, kalman_filter(model, y)).mean - base)
    A = np.stack(cols, axis=-1)  # (T, n, n_obs)
    w = np.array([Rn[j, j] for _, j in obs])
    expected = np.einsum("tio,o,tjo->tij", A, w, A)
    assert np.allclose(got, expected, atol=1e-12)
    with pytest.raises(ShapeError, match="noise_cov must have shape"):
        smoother_noise_covariance(model, pattern, noise_cov=np.eye(3))
