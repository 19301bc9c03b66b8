"""The model's longitudinal force against the accelerometer: a relative force error per drive (issue 13).

Both slope estimators of paper 001 read the grade from the force balance (21), M dV_x/dt = F_res - M g sin(theta),
with F_res from the tyre model. A mass or tyre-stiffness error scales F_res/M by (1 + beta) and shifts the slope
by beta F_res/(M g): a bias for the whole drive that wheel speeds cannot tell from a grade (docs/vehicle-slope.md,
Calibration). The longitudinal accelerometer reads the specific force a_x = dV_x/dt - r V_y + g sin(theta), so

    d(t) = (F_res/M - a_x - r V_y) / g = beta F_res/(M g) + c + noise

does not contain the grade at all: regressing d on F_res/(M g) over the drive estimates beta wherever the force
varies (accelerating, braking), and the intercept c the force model's constant error (rolling resistance, which
model (21) does not have; the fake slips of unequal wheel radii; a lateral-force error through r V_y) minus the
accelerometer's offset / g, which stays in the corrected slope (``SlopeUncertainty.accel_offset_std``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ._regression import block_means, conjugate_regression

__all__ = ["ForceScaleFit", "force_scale_fit"]

#: Fewest blocks for the regression of :func:`force_scale_fit`; fewer: the prior is returned unchanged.
FORCE_FIT_MIN_BLOCKS = 6


@dataclass(frozen=True, eq=False)
class ForceScaleFit:
    """The drive's force-model error against the accelerometer (:func:`force_scale_fit`): d = beta x + c.

    Attributes
    ----------
    beta, offset : float
        Posterior means of the relative force error beta (0.05 = the model's F_res/M 5 % too large) and of the
        constant c, in sin(theta) (the force model's constant error, e.g. rolling resistance or the fake slips of
        unequal wheel radii, minus the accelerometer's offset / g).
    cov : (2, 2) ndarray
        Posterior covariance of (beta, offset).
    prior_std : (2,) ndarray
        The prior stds of (beta, offset).
    residual_std : float
        Std of the block means of d about the fitted line, in sin(theta).
    n_blocks : int
        Number of blocks used (0: too short a log; the prior is returned).
    """

    beta: float
    offset: float
    cov: np.ndarray
    prior_std: np.ndarray
    residual_std: float
    n_blocks: int

    @property
    def beta_std(self) -> float:
        return float(np.sqrt(self.cov[0, 0]))

    @property
    def offset_std(self) -> float:
        return float(np.sqrt(self.cov[1, 1]))


def force_scale_fit(resisting_force, accel_x, yaw_rate, vy, mass: float, dt: float, *, beta_prior_std: float,
                    offset_prior_std: float, block: float = 1.0, skip: float = 1.0) -> ForceScaleFit:
    r"""Posterior of the force-model error (beta, c) from the accelerometer (module docstring; issue 13).

    Parameters
    ----------
    resisting_force : (T,) array_like
        F_res = sum F_X + M r V_y - C_x V_x|V_x| of eq. (21) along the estimate, N.
    accel_x : (T,) array_like
        Longitudinal accelerometer (specific force, gravity included), m/s^2.
    yaw_rate, vy : (T,) array_like
        Estimated r (rad/s) and V_y (m/s).
    mass : float
        The estimator's vehicle mass M, kg.
    dt : float
        Sample interval, s.
    beta_prior_std, offset_prior_std : float
        Prior stds of beta (e.g. hypot(mass_rel_std, force_rel_std) of :class:`SlopeUncertainty`) and of c
        (in sin(theta)).
    block : float
        Length of the blocks whose means enter the regression, s (1 s: longer than the filters' time constants,
        so that block errors are roughly independent).
    skip : float
        Start-up left out, s (the EKF's convergence).

    Returns
    -------
    ForceScaleFit

    Notes
    -----
    With x_b and d_b the block means of F_res/(M g) and d and X = [x_b, 1], (beta, c) has the Gaussian prior
    N(0, diag(prior stds)^2) and the blocks' residual variance s^2 is estimated from the least-squares fit
    (n_b - 2 degrees of freedom): posterior precision P0^-1 + X^T X / s^2, mean its inverse times X^T d / s^2
    (conjugate linear regression with a plug-in noise variance). Assumptions (docs/vehicle-slope.md): the
    accelerometer's scale is right and the body does not pitch (a pitch of k rad per m/s^2 reads as beta = g k,
    about 1.7 % for 1 deg per g; :class:`SlopeUncertainty` ``accel_gain_std`` adds such an error to the band),
    and the force model's error is one beta and one c for the whole drive.
    """
    cols = [np.asarray(a, dtype=float) for a in (resisting_force, accel_x, yaw_rate, vy)]
    T = cols[0].shape[0]
    if any(c.shape != (T,) for c in cols):
        raise InputError(f"resisting_force, accel_x, yaw_rate and vy must be (T,) arrays of one length; got shapes "
                         f"{[c.shape for c in cols]}.")
    numbers = (mass, dt, beta_prior_std, offset_prior_std, block)
    if not (all(math.isfinite(v) and v > 0 for v in numbers) and math.isfinite(skip) and skip >= 0):
        raise InputError("mass, dt, beta_prior_std, offset_prior_std and block must be finite and > 0, skip >= 0; "
                         f"got {numbers + (skip,)!r}.")
    from ._params import GRAVITY

    res, ax, r, vy = cols
    x = res / (mass * GRAVITY)
    d = x - (ax + r * vy) / GRAVITY
    n = max(int(round(block / dt)), 1)
    start = min(int(round(skip / dt)), T)
    xb = block_means(x, n, start)
    db = block_means(d, n, start)
    ok = np.isfinite(xb) & np.isfinite(db)
    xb, db = xb[ok], db[ok]
    prior = np.array([beta_prior_std, offset_prior_std], dtype=float)
    if xb.size < FORCE_FIT_MIN_BLOCKS:
        return ForceScaleFit(0.0, 0.0, np.diag(prior ** 2), prior, float("nan"), 0)
    mean, cov, s2 = conjugate_regression(np.column_stack([xb, np.ones_like(xb)]), db, prior)
    return ForceScaleFit(beta=float(mean[0]), offset=float(mean[1]), cov=cov, prior_std=prior,
                         residual_std=float(math.sqrt(s2)), n_blocks=int(xb.size))
