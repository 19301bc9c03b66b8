"""All days at once: sensor errors correlated over days and a settlement prior that grows on work days (issue 13,
step 10; beyond paper 004).

Paper 004 (§4.2) estimates each day's profile from that day's slope changes alone, with white noise. Two facts of
real inclinometer records are lost that way:

* a sensor's error on day d is mostly its error on day d - 1: the bias drifts as a random walk and the reference
  day's error is shared by every day's change, so the errors of one sensor are correlated over the days;
* the settlement grows in steps during the night works of a few days (plus a slow creep), while the drift grows
  every day.

Model (per sensor i, days d = 1..D-1 after the reference day 0): the slope changes m_{.,i} = theta_{.,i} + e_{.,i},
with the errors of different sensors independent and

    Cov(e_{.,i}) = f_i^2 R,    R = c_ref 1 1^T + c_white I + c_walk min(t_d, t_e) + c_T dT dT^T + c_Tw diag(dT^2)
                                   + c_short exp(-|t_d - t_e| / tau),

(t: days since the reference; dT: site-mean temperature minus the reference day's: a shared reference error, white
daily noise, a random-walk drift, a residual thermal coefficient, a white thermal residual and a short-memory error
correlated over about tau = SHORT_MEMORY_DAYS days (session 41: without it, the drift-free sites' day-to-day
correlation was read as drift); f_i the sensor's noise factor of
:func:`~longprofile.rail._settle.sensor_noise_factors`). The settlement's slope profile is a random walk over
the days whose increment from day d - 1 to day d has the rigidity model's prior (paper 004 §4.2, eq. of Lemma 4.1;
``rigidity_model``) with its own r_d: vec(theta) ~ N(0, S ⊗ P) with S = L diag(r_d / r) L^T, L the lower-triangular
matrix of ones, P the spatial prior of rigidity r = max_d r_d.

Both day covariances are common to all sensors, so the generalised eigenvectors V of (R, S) (V^T S V = I,
V^T R V = diag(nu)) split the joint posterior exactly into D - 1 independent spatial problems ("modes"): mode k
observes V^T m with per-station noise std sqrt(nu_k) f_i under the spatial prior of rigidity r, and
theta = S V theta~. Every mode is a profile of the ordinary rigidity posterior (the engine's smoother over the
stations); no new recursion is written here. Only dense (D-1) x (D-1) algebra over the days.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh
from scipy.optimize import nnls

from ..errors import InputError
from ._rigidity import DEFAULT_SIGMA_Z, rigidity_posterior_levels

__all__ = ["DayNoiseCovariance", "DayModes", "JointPosterior", "day_noise_covariance", "day_modes", "joint_posterior",
           "NOISE_BASIS"]

#: The day-covariance terms of :func:`day_noise_covariance`, in the order of its coefficients.
NOISE_BASIS = ("reference", "white", "walk", "thermal", "thermal_white", "short")
#: Correlation time (days) of the "short" term of :data:`NOISE_BASIS`: an error that persists over a day or two
#: (the daily medians of a thermal residual, a slow logger) but does not grow. The increments of such an error
#: have a zero sum over a long horizon, those of a random walk do not; without this term the fit read a lag-1
#: covariance 0.9-1.3e-11 rad^2 above the longer lags' as a drift of 1.2-1.6e-11 rad^2/day on the drift-free
#: mittersheim-like preset (truth subtracted; its actual variance grows by 1.5e-12 rad^2/day; docs/rail.md,
#: session 41). 1 day, not fitted: 2 days also gave a zero walk there.
SHORT_MEMORY_DAYS = 1.0
#: Where a sensor's day-to-day departures are clipped, in robust std of its own (work days' settlement steps).
INCREMENT_CLIP = 3.0
#: Fewest day-to-day changes for the day covariance (:func:`day_noise_covariance`).
MIN_INCREMENTS = 5
#: Relative width of the noise-level groups that share one covariance pass (log scale).
_SIGMA_LEVEL_STEP = 0.02


def _noise_groups(sig_d, step: float = _SIGMA_LEVEL_STEP):
    """Index arrays of the days sharing one noise level (log step ``step``; 0: every day its own) and that level."""
    if step == 0:
        return [(np.array([d]), float(v)) for d, v in enumerate(np.asarray(sig_d, float))]
    key = np.round(np.log(sig_d) / step).astype(int)
    return [(idx, float(np.exp(np.median(np.log(sig_d[idx])))))
            for idx in (np.nonzero(key == k)[0] for k in np.unique(key))]


def _engine_groups(levels, M):
    """The engine's groups (:func:`~longprofile.rail._rigidity.rigidity_posterior_levels`) of noise-level groups
    ``levels`` [(rows, level)]: (the group of each row of M, the level of each group), a level group split by its
    rows' missing pattern (an engine group shares one)."""
    nan = np.isnan(M)
    if (nan == nan[:1]).all():  # the usual case: one missing pattern, one engine group per level
        group = np.empty(M.shape[0], dtype=np.int64)
        for g, (idx, _) in enumerate(levels):
            group[idx] = g
        return group, np.array([s for _, s in levels], float)
    group = np.empty(M.shape[0], dtype=np.int64)
    values: list = []
    for idx, s in levels:
        _, first, inverse = np.unique(np.packbits(np.isnan(M[idx]), axis=1), axis=0, return_index=True,
                                      return_inverse=True)
        group[idx] = len(values) + np.argsort(np.argsort(first))[inverse.ravel()]
        values += [s] * first.size
    return group, np.array(values, float)


def _station_sigma(s: float, factors):
    """The noise std of each station on a day of level ``s``: s, or s f_i with per-sensor factors."""
    return s if factors is None else s * factors


def _posterior_by_level(x, M, sig_d, *, rigidity, sigma_z, penalty_order, factors=None, weights=None,
                        step: float = _SIGMA_LEVEL_STEP):
    """Daily posterior means/stds (z and slope) and noise-only stds with one noise std per day (times f_i): the days
    of one noise level (:func:`_noise_groups`) share one covariance pass, all levels in one engine call."""
    group, lv = _engine_groups(_noise_groups(sig_d, step), M)
    _, res = rigidity_posterior_levels(x, M, group, levels=lv, rigidity=rigidity, sigma_z=sigma_z,
                                       penalty_order=penalty_order, sensor_factors=factors, segment_weights=weights,
                                       noise_std=True)
    D, N = M.shape
    cov = res.cov[group]
    return {"z_mean": res.mean[..., 0], "slope_mean": res.mean[..., 1], "z_std": np.sqrt(cov[..., 0, 0]),
            "slope_std": np.sqrt(cov[..., 1, 1]), "noise_std": np.sqrt(np.maximum(res.noise_cov[group, :, 0, 0], 0.0))}


def _neighbour_residuals(x, slopes):
    """Departure of each interior sensor's slope change from the line through its two neighbours' (same day),
    divided by its std under independent noise of unit std (the line's own error included)."""
    hl, hr = x[1:-1] - x[:-2], x[2:] - x[1:-1]
    pred = (hr * slopes[:, :-2] + hl * slopes[:, 2:]) / (hl + hr)
    return (slopes[:, 1:-1] - pred) / np.sqrt(1.0 + (hl**2 + hr**2) / (hl + hr) ** 2)


def _neighbour_weights(x):
    """(w_l, w_r, c^2) of the neighbour line of every interior station: departure = m_i - w_l m_{i-1} - w_r m_{i+1},
    its variance under independent unit noise c^2 = 1 + w_l^2 + w_r^2."""
    hl, hr = x[1:-1] - x[:-2], x[2:] - x[1:-1]
    wl, wr = hr / (hl + hr), hl / (hl + hr)
    return wl, wr, 1.0 + wl**2 + wr**2


def day_differences(cov) -> np.ndarray:
    """Delta C Delta^T for the day-difference operator Delta (Delta m)_d = m_d - m_{d-1}, m_0 = 0 (the covariance of
    the day-to-day increments), in O(K^2) by two differences; equal bit for bit to the dense product (each entry has
    two non-zero terms, added in one rounding either way)."""
    C = np.array(cov, float)
    X = C.copy()
    X[1:] -= C[:-1]
    Y = X.copy()
    Y[:, 1:] -= X[:, :-1]
    return Y


@dataclass(frozen=True)
class DayNoiseCovariance:
    """The day covariance R of a sensor of noise factor 1 (:func:`day_noise_covariance`).

    Attributes
    ----------
    cov : (D-1, D-1) ndarray
        R over the days 1..D-1 (day 0 is the reference), rad^2.
    coefficients : dict of str -> float
        c of each term of :data:`NOISE_BASIS` (rad^2, per day for "walk", per degC^2 for the thermal terms).
    """

    cov: np.ndarray
    coefficients: dict


def _basis(t, dT):
    """The day-covariance terms over days 1..D-1 (:data:`NOISE_BASIS`)."""
    K = t.size
    return [np.ones((K, K)), np.eye(K), np.minimum.outer(t, t), np.outer(dT, dT), np.diag(dT**2),
            np.exp(-np.abs(np.subtract.outer(t, t)) / SHORT_MEMORY_DAYS)]


def day_noise_covariance(x, slopes, *, day_offsets=None, temperature_change=None, sensor_factors=None,
                         floor: float = 0.0) -> DayNoiseCovariance:
    r"""Covariance over the days of a sensor's slope-change error (random-walk drift, shared reference, thermal).

    The day-to-day increments of the sensors' departures from the line through their two neighbours
    (:func:`~longprofile.rail._settle.sensor_noise_factors`: a settlement bowl spanning a few sensors hardly departs
    from that line, and it moves only on the work days), each divided by the std its sensor factors give it and
    clipped at INCREMENT_CLIP robust std of its own sensor (the work days' steps), have the empirical covariance
    C (D-1 x D-1, averaged over the sensors). With Delta the difference operator over the days (m_0 = 0), the model
    R = sum_j c_j B_j (module docstring, B_j of :data:`NOISE_BASIS`) predicts Delta R Delta^T; c >= 0 is the
    non-negative least-squares fit of C (each entry weighted by the square root of its number of sensor pairs).
    R is positive semi-definite by construction; its diagonal is floored at ``floor``^2.

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    slopes : (D, N) ndarray
        Daily slope changes, rad (NaN = missing or excluded); row 0 is the reference day.
    day_offsets : (D,) array_like, optional
        Days since the reference day (default 0, 1, ..., D-1).
    temperature_change : (D,) array_like, optional
        Site-mean daily temperature minus the reference day's, degC (default: no thermal terms).
    sensor_factors : (N,) array_like, optional
        f_i (default 1).
    floor : float, default 0
        Lower bound of the std of every day, rad.

    Returns
    -------
    DayNoiseCovariance
    """
    M = np.asarray(slopes, float)
    if M.ndim != 2:
        raise InputError(f"slopes must be (D, N); got shape {M.shape}.")
    D = M.shape[0]
    ok = np.isfinite(M).sum(axis=0) > 0
    if ok.sum() < 5 or D - 1 < MIN_INCREMENTS:
        raise InputError(f"too few usable sensors (>= 5) or day-to-day changes (>= {MIN_INCREMENTS}) for the "
                         "day covariance of the noise.")
    xs = np.asarray(x, float)[ok]
    g = np.ones(xs.size) if sensor_factors is None else np.asarray(sensor_factors, float)[ok] ** 2
    wl, wr, c2 = _neighbour_weights(xs)
    r = _neighbour_residuals(xs, np.diff(M[:, ok], axis=0))
    r = r / np.sqrt((g[1:-1] + wl**2 * g[:-2] + wr**2 * g[2:]) / c2)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # sensors next to an excluded one: all NaN
        clip = INCREMENT_CLIP * 1.4826 * np.nanmedian(np.abs(r), axis=0, keepdims=True)
        r = np.clip(r, -clip, clip)
    valid = np.isfinite(r).astype(float)
    n = valid @ valid.T
    r0 = np.nan_to_num(r)
    C = (r0 @ r0.T) / np.maximum(n, 1.0)
    t = np.arange(D, dtype=float) if day_offsets is None else np.asarray(day_offsets, float)
    dT = np.zeros(D) if temperature_change is None else np.nan_to_num(np.asarray(temperature_change, float))
    B = _basis(t[1:], dT[1:])
    w = np.sqrt(n).ravel()
    coef, _ = nnls(np.column_stack([day_differences(b).ravel() * w for b in B]), C.ravel() * w)
    R = sum(c * b for c, b in zip(coef, B))
    R = R + np.diag(np.maximum(max(floor, 1e-12) ** 2 - np.diag(R), 0.0))
    return DayNoiseCovariance(cov=R, coefficients={k: float(c) for k, c in zip(NOISE_BASIS, coef)})


@dataclass(frozen=True)
class DayModes:
    """Generalised eigenbasis of the noise and prior day covariances (:func:`day_modes`). K = D - 1 days.

    Attributes
    ----------
    to_modes : (K, K) ndarray
        V^T: mode data = ``to_modes @ slopes[1:]``.
    from_modes : (K, K) ndarray
        S V: day profiles = ``from_modes @ mode profiles`` (means; variances with its square).
    noise : (K,) ndarray
        sqrt(nu_k): the noise std of mode k for a sensor of factor 1 (times f_i per sensor).
    rigidity : float
        r of the spatial prior of every mode (the largest r_d).
    """

    to_modes: np.ndarray
    from_modes: np.ndarray
    noise: np.ndarray
    rigidity: float


def day_modes(noise_cov, rigidity_by_day) -> DayModes:
    r"""Split the all-days posterior into independent spatial problems (module docstring).

    Parameters
    ----------
    noise_cov : (K, K) array_like
        R of :func:`day_noise_covariance` (days 1..D-1), positive definite.
    rigidity_by_day : (K,) array_like
        r_d > 0: the prior rigidity of the settlement increment from day d - 1 to day d.

    Returns
    -------
    DayModes
        V^T S V = I and V^T R V = diag(nu) with S = L diag(r_d / r) L^T, r = max r_d.
    """
    R = np.asarray(noise_cov, float)
    rd = np.asarray(rigidity_by_day, float)
    K = rd.size
    if R.shape != (K, K) or not np.all(np.isfinite(R)):
        raise InputError(f"noise_cov must be a finite ({K}, {K}) matrix; got shape {R.shape}.")
    if not np.all(np.isfinite(rd) & (rd > 0)):
        raise InputError("rigidity_by_day must be finite and > 0.")
    scale = float(rd.max())
    L = np.tril(np.ones((K, K)))
    S = (L * (rd / scale)[None, :]) @ L.T
    nu, V = eigh(R, S)
    nu = np.maximum(nu, 1e-12 * float(np.max(nu)))
    return DayModes(to_modes=V.T, from_modes=S @ V, noise=np.sqrt(nu), rigidity=scale)


@dataclass(frozen=True, eq=False)
class JointPosterior:
    """The all-days posterior (:func:`joint_posterior`). D days (day 0 the reference), N stations.

    Attributes
    ----------
    z_mean, z_std : (D, N) ndarray
        Posterior mean and std of the altitude change since day 0, m (0 on day 0: no change by construction).
    slope_mean, slope_std : (D, N) ndarray
        The same for the slope change, rad.
    noise_std : (D, N) ndarray
        The part of z_std due to the slope noise alone for a fixed true profile (a lower bound, not a band).
    rate_std : (D, N) ndarray
        Std of z_d - z_{d-1}, m/day (NaN on day 0).
    modes : DayModes
    mode_slopes : (D-1, N) ndarray
        The modes' data, ``modes.to_modes @ slopes[1:]``.
    """

    z_mean: np.ndarray
    z_std: np.ndarray
    slope_mean: np.ndarray
    slope_std: np.ndarray
    noise_std: np.ndarray
    rate_std: np.ndarray
    modes: DayModes
    mode_slopes: np.ndarray


def joint_posterior(x, slopes, modes: DayModes, *, penalty_order: int = 2, sensor_factors=None,
                    sigma_z: float = DEFAULT_SIGMA_Z, segment_weights=None,
                    level_step: float = _SIGMA_LEVEL_STEP) -> JointPosterior:
    r"""Posterior of the settlement of all days at once (module docstring), through the modes of :func:`day_modes`.

    Mode k observes y_k = (V^T m)_k with per-station noise std sqrt(nu_k) f_i under the rigidity prior of r
    (paper 004 §4.2, the engine's RTS smoother over the stations, :func:`~longprofile.rail.rigidity_posterior`);
    the modes are independent a posteriori, so day d's mean is sum_k B_dk mu_k and its variance
    sum_k B_dk^2 var_k (B = S V), and the rate's variance sum_k (B_dk - B_{d-1,k})^2 var_k.

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    slopes : (D, N) ndarray
        Daily slope changes, rad; row 0 the reference day; a column is either all NaN (excluded sensor) or finite
        on every day >= 1.
    modes : DayModes
        From :func:`day_modes` (D - 1 modes).
    penalty_order, sigma_z, segment_weights
        As in :func:`~longprofile.rail.rigidity_posterior`.
    sensor_factors : (N,) array_like, optional
        f_i (default 1).
    level_step : float, default 0.02
        Modes whose noise levels agree within this relative step share one covariance pass (their median level);
        0 runs every mode with its own.

    Returns
    -------
    JointPosterior
    """
    M = np.asarray(slopes, float)
    K = modes.noise.size
    if M.ndim != 2 or M.shape[0] != K + 1:
        raise InputError(f"slopes must be ({K + 1}, N) for {K} modes; got shape {M.shape}.")
    part = np.isnan(M[1:]).any(axis=0) & ~np.isnan(M[1:]).all(axis=0)
    if part.any():
        raise InputError(f"{int(part.sum())} sensor(s) miss some days but not all: fill or exclude them first.")
    Mt = modes.to_modes @ M[1:]
    f = None if sensor_factors is None else np.asarray(sensor_factors, float)
    mp = _posterior_by_level(x, Mt, modes.noise, rigidity=modes.rigidity, sigma_z=sigma_z,
                             penalty_order=penalty_order, factors=f, weights=segment_weights, step=level_step)
    B = modes.from_modes
    zero = np.zeros((1, M.shape[1]))
    out = {k: np.vstack([zero, np.sqrt((B**2) @ mp[k] ** 2) if k.endswith("std") else B @ mp[k]])
           for k in ("z_mean", "z_std", "slope_mean", "slope_std", "noise_std")}
    dB = np.diff(np.vstack([np.zeros((1, K)), B]), axis=0)
    rate_std = np.vstack([np.full_like(zero, np.nan), np.sqrt((dB**2) @ mp["z_std"] ** 2)])
    return JointPosterior(rate_std=rate_std, modes=modes, mode_slopes=Mt, **out)
