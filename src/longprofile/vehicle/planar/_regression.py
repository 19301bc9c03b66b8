"""Block means and conjugate Bayesian linear regression, shared by the drive-log self-checks (issue 13).

:func:`~longprofile.vehicle.force_scale_fit` (the force model against the accelerometer) and
:func:`~longprofile.vehicle.calibrate_sensors` (the gyro offset and the relative wheel radii against the wheel
kinematics) both regress 1 s block means of a residual on a few regressors, with the stated uncertainty of each
coefficient as a zero-mean Gaussian prior.
"""

from __future__ import annotations

import numpy as np

__all__ = ["block_means", "conjugate_regression"]


def block_means(a, n: int, start: int, mask=None) -> np.ndarray:
    """Means of ``a`` (T,) or (T, k) over consecutive blocks of ``n`` samples from sample ``start``, (nb,) or (nb, k).

    With ``mask`` (T,) bool, each block's mean is over its samples where ``mask`` is True, and a block with fewer
    than half of its samples selected is NaN (not enough of it to trust)."""
    a = np.asarray(a, dtype=float)
    T = a.shape[0]
    nb = max((T - start) // n, 0)
    x = a[start:start + nb * n].reshape((nb, n) + a.shape[1:])
    if mask is None:
        return x.mean(axis=1)
    w = np.asarray(mask, dtype=bool)[start:start + nb * n].reshape(nb, n)
    count = w.sum(axis=1)
    wx = w.reshape((nb, n) + (1,) * (a.ndim - 1))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(wx, x, 0.0).sum(axis=1) / count.reshape((nb,) + (1,) * (a.ndim - 1))
    return np.where((count >= 0.5 * n).reshape((nb,) + (1,) * (a.ndim - 1)), out, np.nan)


def conjugate_regression(X, y, prior_std, *, noise_var: float | None = None):
    r"""Posterior of theta in y = X theta + e, theta ~ N(0, diag(prior_std)^2), e ~ N(0, s^2 I).

    Parameters
    ----------
    X : (n, p) array_like
        Regressors, one row per observation.
    y : (n,) array_like
        Observations.
    prior_std : (p,) array_like
        Prior stds of the coefficients, all > 0.
    noise_var : float, optional
        s^2; by default the plug-in estimate from the least-squares residuals, with n - p degrees of freedom
        (n > p required).

    Returns
    -------
    mean : (p,) ndarray
    cov : (p, p) ndarray
        Posterior mean and covariance: cov = (P0^-1 + X^T X / s^2)^-1, mean = cov X^T y / s^2.
    noise_var : float
        The s^2 used.
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    prior = np.asarray(prior_std, dtype=float)
    if noise_var is None:
        coef, *_ = np.linalg.lstsq(X, y, rcond=None)
        resid = y - X @ coef
        noise_var = max(float(resid @ resid) / (y.size - X.shape[1]), 1e-30)
    cov = np.linalg.inv(np.diag(1.0 / prior ** 2) + X.T @ X / noise_var)
    mean = cov @ (X.T @ y) / noise_var
    return mean, cov, float(noise_var)
