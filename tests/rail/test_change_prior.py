"""The prior of the settlement (change) profile: the quintic-spline prior and its maximum-likelihood fit."""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.interpolate import BPoly

from longprofile.errors import InputError
from longprofile.rail import fit_change_prior, measurement_std, rigidity_model, rigidity_posterior
from longprofile.statespace import simulate


def test_quintic_transition_density_equals_the_integral_of_the_quintic_hermite_jerk():
    # external oracle: scipy's Hermite interpolant with (z, slope, curvature) at both ends and quadrature of f'''^2
    rng = np.random.default_rng(3)
    for _ in range(6):
        l, r = rng.uniform(0.5, 6.0), 1e-6
        a, b = rng.normal(size=3), rng.normal(size=3)
        poly = BPoly.from_derivatives([0.0, l], [list(a), list(b)])
        d3 = poly.derivative(3)
        expected = quad(lambda s: float(d3(s)) ** 2, 0.0, l, epsabs=1e-13)[0]
        model = rigidity_model(np.array([0.0, l]), rigidity=r, penalty_order=3)
        q = r * l / 2.0
        F, Qbar = model.transition[0], model.process_cov[0] / q
        e = b - F @ a
        assert e @ np.linalg.solve(Qbar, e) == pytest.approx(expected, rel=1e-7, abs=1e-10)


def _prior_joint_cov(model, dtype=np.float64):
    """Prior covariance of all states of the chain, by the block recursion of x_{k+1} = F_k x_k + w_k (numpy only)."""
    F, Q = model.transition.astype(dtype), model.process_cov.astype(dtype)
    n, N = model.n_states, model.transition.shape[0] + 1
    S = np.zeros((N * n, N * n), dtype=dtype)
    S[:n, :n] = model.initial_cov
    for k in range(N - 1):
        a, b = slice(k * n, (k + 1) * n), slice((k + 1) * n, (k + 2) * n)
        S[b, : (k + 1) * n] = F[k] @ S[a, : (k + 1) * n]
        S[: (k + 1) * n, b] = S[b, : (k + 1) * n].T
        S[b, b] = F[k] @ S[a, a] @ F[k].T + Q[k]
    return S


def _dense_conditioning(model, y):
    """Posterior of all states of a linear-Gaussian chain by one dense solve in precision form (numpy only).

    Prior precision: P0^-1 on the first state plus [-F_k, I]^T Q_k^-1 [-F_k, I] per step (zero prior mean).
    The log-likelihood is the density of the stacked observations, N(0, Hb S Hb^T + R) with S the prior joint
    covariance: the precision-form determinant lemma loses ~1e-3 to the 1e13 condition of this stiff prior.
    """
    F, Q, H, R = model.transition, model.process_cov, model.observation, model.obs_cov
    N, n = y.shape[0], model.n_states
    assert not np.any(model.initial_mean)
    L = np.zeros((N * n, N * n))
    L[:n, :n] = np.linalg.inv(model.initial_cov)
    for k in range(N - 1):
        J = np.zeros((n, N * n))
        J[:, k * n:(k + 1) * n] = -F[k]
        J[:, (k + 1) * n:(k + 2) * n] = np.eye(n)
        L += J.T @ np.linalg.solve(Q[k], J)
    rows, vals, noise = [], [], []
    for k in range(N):
        for i in range(y.shape[1]):
            if np.isfinite(y[k, i]):
                h = np.zeros(N * n); h[k * n:(k + 1) * n] = H[i]
                rows.append(h); vals.append(y[k, i]); noise.append(R[i, i])
    Hb, yv, rv = np.array(rows), np.array(vals), np.array(noise)
    Lpost = L + Hb.T @ (Hb / rv[:, None])
    mean = np.linalg.solve(Lpost, Hb.T @ (yv / rv))
    cov = np.linalg.inv(Lpost)
    # the density in extended precision (np.longdouble, numpy's matmul and a hand Cholesky; no LAPACK): in float64
    # this 1e13-conditioned covariance loses ~1e-5 of the log-likelihood, and how much depends on the BLAS build
    Hl, yl = Hb.astype(np.longdouble), yv.astype(np.longdouble)
    C = Hl @ _prior_joint_cov(model, np.longdouble) @ Hl.T + np.diag(rv.astype(np.longdouble))
    chol = np.zeros_like(C)
    for j in range(C.shape[0]):
        chol[j, j] = np.sqrt(C[j, j] - chol[j, :j] @ chol[j, :j])
        chol[j + 1:, j] = (C[j + 1:, j] - chol[j + 1:, :j] @ chol[j, :j]) / chol[j, j]
    white = np.zeros_like(yl)
    for j in range(yl.size):
        white[j] = (yl[j] - chol[j, :j] @ white[:j]) / chol[j, j]
    ll = -0.5 * (white @ white + 2 * np.log(np.diag(chol)).sum() + yl.size * np.log(2 * np.pi))
    return mean.reshape(N, n), np.diag(cov).reshape(N, n), float(ll)


def test_quintic_posterior_and_likelihood_equal_dense_gaussian_conditioning():
    rng = np.random.default_rng(4)
    x = np.cumsum(rng.uniform(2.5, 3.5, 14))
    slopes = rng.normal(0, 1e-4, x.size)
    slopes[5] = np.nan
    kw = dict(sigma=2e-5, rigidity=1e-10, sigma_z=1e-3, penalty_order=3)
    post = rigidity_posterior(x, slopes, z_ends=(0.0, 0.002), **kw)
    model = rigidity_model(x, sigma=2e-5, rigidity=1e-10, sigma_z=1e-3, penalty_order=3)
    y = np.full((x.size, 2), np.nan)
    y[:, 0] = slopes
    y[-1, 1] = 0.002
    mean, var, ll = _dense_conditioning(model, y)
    assert post.station_cov.shape == (x.size, 3, 3)
    assert np.abs(post.z_mean - mean[:, 0]).max() < 1e-9
    assert np.allclose(post.z_std, np.sqrt(var[:, 0]), rtol=1e-5)
    assert np.allclose(post.slope_std, np.sqrt(var[:, 1]), rtol=1e-5)
    assert post.log_likelihood == pytest.approx(ll, abs=1e-6)
    # the posterior variance is at least the noise-only part (it adds the prior's share)
    noise = measurement_std(x, slopes, sigma=2e-5, rigidity=1e-10, sigma_z=1e-3, penalty_order=3)
    assert np.all(noise <= post.z_std * (1 + 1e-9))


@pytest.mark.parametrize("order, r_true", [(2, 1e-9), (3, 1e-12)])
def test_fit_change_prior_recovers_the_order_and_rigidity_of_simulated_profiles(order, r_true):
    rng = np.random.default_rng(5)
    x = np.cumsum(rng.uniform(2.8, 3.2, 40))
    sigma = 2e-5
    model = rigidity_model(x, sigma=sigma, rigidity=r_true, sigma_z=10.0, penalty_order=order)
    start = dataclasses.replace(model, initial_cov=np.eye(model.n_states) * 1e-24)  # profiles start flat at 0
    slopes = np.array([simulate(start, x.size, rng=rng)[1][:, 0] for _ in range(30)])
    fit = fit_change_prior(x, slopes, sigma=sigma, sigma_z=10.0)
    assert fit.penalty_order == order
    assert fit.log_likelihood[order] > fit.log_likelihood[5 - order]
    assert 0.5 < fit.rigidity / r_true < 2.0
    assert fit.rigidities[order] == fit.rigidity and fit.sigma == sigma


def test_bad_penalty_order_is_an_input_error():
    with pytest.raises(InputError, match="penalty_order"):
        rigidity_model(np.array([0.0, 1.0, 2.0]), penalty_order=4)
    with pytest.raises(InputError, match="no day differs"):
        fit_change_prior(np.array([0.0, 1.0, 2.0]), np.zeros((3, 3)), sigma=1e-5)
