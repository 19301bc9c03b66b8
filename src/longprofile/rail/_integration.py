"""Integration of sensor angles into altitudes: forward, backward, average and convex (paper 004 §2)."""

from __future__ import annotations

import numpy as np

from .._validation import as_float_array
from ..errors import InputError, ShapeError

__all__ = ["integrate_angles", "INTEGRATION_METHODS", "bar_angles_from_profile"]

INTEGRATION_METHODS = ("forward", "backward", "average", "convex")


def bar_angles_from_profile(x, z) -> np.ndarray:
    r"""Initial bar angles theta_i = arctan((z_{i+1} - z_i) / (x_{i+1} - x_i)) (paper 004 §2), rad.

    Parameters
    ----------
    x, z : (N,) array_like
        Stations (m) and altitudes (m).

    Returns
    -------
    (N-1,) ndarray
    """
    x = as_float_array("x", x, ndim=1, allow_nan=False)
    z = as_float_array("z", z, ndim=1, allow_nan=False)
    if x.shape != z.shape:
        raise ShapeError(f"x and z must have the same shape; got {x.shape} and {z.shape}.")
    return np.arctan(np.diff(z) / np.diff(x))


def integrate_angles(x, angles, *, method: str = "convex", z_first: float = 0.0, z_last: float = 0.0) -> np.ndarray:
    r"""Altitudes from bar angles by chaining the bars (paper 004 §2).

    Parameters
    ----------
    x : (N,) array_like
        Strictly increasing sensor stations, m.
    angles : (N-1,) or (D, N-1) array_like
        Angle theta_i(t) of the bar from sensor i to sensor i+1, rad (absolute: initial
        angle plus measured change), one row per profile.
    method : {"forward", "backward", "average", "convex"}, default "convex"
        ``forward``: z_{i+1} = z_i + (x_{i+1} - x_i) tan theta_i from z_1 = ``z_first``;
        ``backward``: the same chain from z_N = ``z_last``; ``average``: (z^f + z^b)/2;
        ``convex``: ((x_i - x_1) z^b_i + (x_N - x_i) z^f_i) / (x_N - x_1), which keeps both ends fixed.
    z_first, z_last : float
        Fixed altitudes of the first and last sensors, m.

    Returns
    -------
    (N,) or (D, N) ndarray
        Altitudes, m.

    Notes
    -----
    Errors accumulate along the chain (the paper's motivation for §3-4); these
    estimators give no error bounds.
    """
    if method not in INTEGRATION_METHODS:
        raise InputError(f"method must be one of {INTEGRATION_METHODS}; got {method!r}.")
    x = as_float_array("x", x, ndim=1, allow_nan=False)
    if x.size < 2 or np.any(np.diff(x) <= 0):
        raise InputError("x must hold at least 2 strictly increasing stations.")
    a = as_float_array("angles", angles, ndim=(1, 2))
    if a.shape[-1] != x.size - 1:
        raise ShapeError(f"angles must have N-1 = {x.size - 1} columns (one per bar); got shape {a.shape}.")
    steps = np.diff(x) * np.tan(a)
    zero = np.zeros(a.shape[:-1] + (1,))
    fwd = z_first + np.concatenate([zero, np.cumsum(steps, axis=-1)], axis=-1)
    bwd = z_last - np.concatenate([np.cumsum(steps[..., ::-1], axis=-1)[..., ::-1], zero], axis=-1)
    if method == "forward":
        return fwd
    if method == "backward":
        return bwd
    if method == "average":
        return 0.5 * (fwd + bwd)
    w = (x - x[0]) / (x[-1] - x[0])
    return w * bwd + (1 - w) * fwd
