"""Dugoff tyre model, paper 001 eq. (15)-(17), with its analytic derivatives (numba kernels)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._jit import njit
from ..._validation import as_float_array, require_positive
from ...errors import InputError, ShapeError

__all__ = ["TyreForces", "dugoff_forces"]

_TINY = 1e-12


@njit(cache=True, inline="always")
def dugoff_grad(slip, tan_alpha, normal_force, mu, cx0, cy0):
    """Dugoff forces and their partial derivatives w.r.t. slip and tan(slip angle).

    Returns ``(fx, fy, dfx_dslip, dfx_dtan, dfy_dslip, dfy_dtan, dfx_dfn, dfy_dfn)``. Written without the
    1/(1 - slip) factor in the adhesion-limited branch (sigma < 1), where
    F = C * s * G * (2 - sigma) / S with G = mu Fn / 2 and S = sqrt(Cx0^2 s^2 + Cy0^2 t^2),
    so that the formula stays finite as the slip approaches 1. The one Dugoff kernel of the package: a caller that
    uses only (fx, fy) gets the partials dropped by the compiler (for S > 1e-12, sigma >= 1 exactly when
    (1 - s) G >= S, the test of the value-only version this replaced).
    """
    one_m = 1.0 - slip
    g = 0.5 * mu * max(normal_force, 0.0)
    s2 = cx0 * cx0 * slip * slip + cy0 * cy0 * tan_alpha * tan_alpha
    s = np.sqrt(s2)
    sigma = 2.0  # k = 1 when there is no slip at all (force zero anyway)
    if s > _TINY:
        sigma = one_m * g / s
    if sigma >= 1.0:
        inv = 1.0 / one_m
        fx = cx0 * slip * inv
        fy = cy0 * tan_alpha * inv
        return fx, fy, cx0 * inv * inv, 0.0, cy0 * tan_alpha * inv * inv, cy0 * inv, 0.0, 0.0
    # sigma < 1: k = (2 - sigma) sigma;  F = C s k / (1 - s) = C s G (2 - sigma) / S
    ds_dl = cx0 * cx0 * slip / s
    ds_dt = cy0 * cy0 * tan_alpha / s
    dsig_dl = -g / s - sigma / s * ds_dl
    dsig_dt = -sigma / s * ds_dt
    h = (2.0 - sigma) / s
    dh_dl = -dsig_dl / s - (2.0 - sigma) / s2 * ds_dl
    dh_dt = -dsig_dt / s - (2.0 - sigma) / s2 * ds_dt
    fx = cx0 * g * slip * h
    fy = cy0 * g * tan_alpha * h
    # d/dFn through G = mu Fn / 2 (sigma = (1 - s) G / S, so d(sigma)/dG = sigma / G)
    dg_dfn = 0.5 * mu if normal_force > 0.0 else 0.0
    dh_dg = -(one_m / s) / s
    return (fx, fy, cx0 * g * (h + slip * dh_dl), cx0 * g * slip * dh_dt,
            cy0 * g * tan_alpha * dh_dl, cy0 * g * (h + tan_alpha * dh_dt),
            cx0 * slip * (h + g * dh_dg) * dg_dfn, cy0 * tan_alpha * (h + g * dh_dg) * dg_dfn)


@njit(cache=True)
def _dugoff_arrays(slip, tan_alpha, normal_force, mu, cx0, cy0, fx, fy):
    for i in range(slip.shape[0]):
        r = dugoff_grad(slip[i], tan_alpha[i], normal_force[i], mu[i], cx0, cy0)
        fx[i] = r[0]
        fy[i] = r[1]


@dataclass(frozen=True, eq=False)
class TyreForces:
    """Tyre/road contact forces of one or several tyres.

    Attributes
    ----------
    longitudinal : ndarray
        F_x, N, along the wheel plane (positive = traction), same shape as the inputs.
    lateral : ndarray
        F_y, N, perpendicular to the wheel plane (positive to the left), same shape as the inputs.
    """

    longitudinal: np.ndarray
    lateral: np.ndarray


def dugoff_forces(slip, slip_angle, normal_force, friction, *, longitudinal_stiffness: float,
                  cornering_stiffness: float) -> TyreForces:
    r"""Tyre forces of the Dugoff model (paper 001, eq. (15)-(17)).

    Parameters
    ----------
    slip : array_like
        Longitudinal slip lambda of eq. (18), dimensionless, in [-1, 1) (negative when braking).
    slip_angle : array_like
        Slip angle alpha, rad, |alpha| < pi/2 (same shape as ``slip`` or broadcastable).
    normal_force : array_like
        F_n, N, >= 0.
    friction : array_like
        mu, available adhesion, > 0.
    longitudinal_stiffness : float
        C_x0, N per unit slip.
    cornering_stiffness : float
        C_y0, N/rad.

    Returns
    -------
    TyreForces
        Longitudinal and lateral forces, N, with the broadcast shape of the inputs.

    Raises
    ------
    InputError
        If a slip is outside [-1, 1), a slip angle outside (-pi/2, pi/2), a normal force negative,
        a friction coefficient not positive, or a value is not finite.

    Notes
    -----
    .. math::

        F_x = C_{x0}\,\frac{\lambda}{1-\lambda}\,k, \quad
        F_y = C_{y0}\,\frac{\tan\alpha}{1-\lambda}\,k, \quad
        k = \begin{cases}(2-\sigma)\sigma & \sigma < 1\\ 1 & \sigma\ge 1\end{cases}, \quad
        \sigma = \frac{(1-\lambda)\,\mu F_n}{2\sqrt{C_{x0}^2\lambda^2 + C_{y0}^2\tan^2\alpha}}.

    Paper 001 (Sebsadji, Glaser, Mammar), eq. (15)-(17), after Dugoff, Fancher and Segel (SAE 700377,
    1970). ``k`` is continuous with a continuous derivative at sigma = 1, so the model has the
    smooth Jacobian an EKF needs.

    Examples
    --------
    >>> f = dugoff_forces(0.01, 0.0, 4000.0, 0.8, longitudinal_stiffness=6e4, cornering_stiffness=5e4)
    >>> round(float(f.longitudinal), 1)
    606.1
    """
    cx0 = require_positive("longitudinal_stiffness", longitudinal_stiffness)
    cy0 = require_positive("cornering_stiffness", cornering_stiffness)
    arrays = [as_float_array(n, v, allow_nan=False) for n, v in
              (("slip", slip), ("slip_angle", slip_angle), ("normal_force", normal_force), ("friction", friction))]
    try:
        lam, alpha, fn, mu = np.broadcast_arrays(*arrays)
    except ValueError:
        raise ShapeError("slip, slip_angle, normal_force and friction must have broadcastable shapes; got "
                         f"{[a.shape for a in arrays]}.") from None
    if np.any(lam < -1.0) or np.any(lam >= 1.0):
        raise InputError(f"slip must be in [-1, 1); got values from {lam.min():g} to {lam.max():g}.")
    if np.any(np.abs(alpha) >= np.pi / 2):
        raise InputError(f"slip_angle must be in (-pi/2, pi/2) rad; got max |alpha| = {np.abs(alpha).max():g}.")
    if np.any(fn < 0):
        raise InputError(f"normal_force must be >= 0 N; got min {fn.min():g}.")
    if np.any(mu <= 0):
        raise InputError(f"friction must be > 0; got min {mu.min():g}.")
    shape = lam.shape
    flat = [np.ascontiguousarray(a, dtype=np.float64).ravel() for a in (lam, np.tan(alpha), fn, mu)]
    fx = np.empty(flat[0].shape[0])
    fy = np.empty_like(fx)
    _dugoff_arrays(flat[0], flat[1], flat[2], flat[3], cx0, cy0, fx, fy)
    return TyreForces(longitudinal=fx.reshape(shape), lateral=fy.reshape(shape))
