"""The whole settlement job: readings -> daily angles -> health -> daily posteriors -> through time -> alarms."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar

from .._validation import require_positive
from ..errors import InputError
from ._controls import check_controls, compare_controls, unmatched_controls
from ._data import SiteData
from ._given_sigma import check_sigma_range, compare_with_estimate
from ._health import (
    FROZEN_MIN_READINGS,
    REVERSAL_NULLS,
    REVERSAL_Z_RULES,
    SHAPE_RULES,
    UNUSABLE_STATUSES,
    USER_EXCLUDED,
    WITNESS_RULES,
    SensorHealth,
    all_days_reversal_evidence,
    all_days_step_evidence,
    assess_sensors,
    flag_detached_all_days,
    flag_limit,
    flag_reversed_all_days,
    n_flagged,
    shape_candidates,
    site_reversal_null,
)
from ._integration import INTEGRATION_METHODS, bar_angles_from_profile, integrate_angles
from ._joint import (
    DayModes,
    _engine_groups,
    _neighbour_residuals,
    _neighbour_weights,
    _noise_groups,
    _posterior_by_level,
    _station_sigma,
    day_differences,
    day_modes,
    day_noise_covariance,
    joint_posterior,
)
from ._reinstall import REINSTALL_MODES, condition_on_unknowns, offset_columns, reinstall_stage
from ._results import ChangePriorFit, SettlementResult
from ._rigidity import (
    DEFAULT_RIGIDITY,
    DEFAULT_SIGMA_A,
    DEFAULT_SIGMA_Z,
    MAX_SETTLEMENT_INTERVALS,
    PENALTY_ORDERS,
    ProfilePosterior,
    initial_profile_posterior,
    max_settlement_from_draws,
    max_settlement_interval,
    rigidity_log_likelihood_function,
    rigidity_log_likelihood_rows,
    sample_profiles,
    segment_process_energy_levels,
)
from ._shapes import shape_reversal_evidence
from ._smooth_reversal import flag_reversed_smooth, smooth_candidates, smooth_reversal_evidence
from ._temporal import TemporalSettlement, check_threshold, settlement_alarms, smooth_through_time
from ._thermal import DailyAngles, daily_angles
from ._thresholds import check_thresholds, threshold_alarms

__all__ = ["SettlementResult", "SettlementSettings", "estimate_settlement", "estimate_settlement_from_daily",
           "fit_noise_and_rigidity", "fit_change_prior", "ChangePriorFit", "day_difference_sigma", "affine_correction",
           "daily_noise_sigma", "ERROR_MODELS", "segment_prior_weights", "increment_rigidity",
           "residual_noise_factors"]

#: Error models of the daily slope changes: "drift" (one std per day, growing with the days since the
#: reference and with the temperature difference from it, :func:`daily_noise_sigma`) or "white" (one std).
ERROR_MODELS = ("drift", "white")


def day_difference_sigma(slopes) -> float:
    r"""Robust std of the day-to-day differences of the daily slope changes, rad: the slope noise sigma.

    If the daily error e_t of a sensor is independent across days, the change
    m_t = s_t + e_t - e_0 has error std sqrt(2) std(e), and so has m_t - m_{t-1}
    on days without settlement; the median absolute deviation over all sensor-days
    ignores the few days with settlement steps.
    """
    d = np.diff(np.asarray(slopes, float), axis=0)
    d = d[np.isfinite(d)]
    if d.size < 10:
        raise InputError("too few daily slope changes to estimate their noise; pass sigma.")
    s = 1.4826 * float(np.median(np.abs(d - np.median(d))))
    if s <= 0:
        raise InputError("the daily slope changes do not vary from day to day: the noise cannot be estimated; "
                         "pass sigma.")
    return s


def daily_noise_sigma(x, slopes, *, day_offsets=None, temperature_change=None, floor: float = 0.0):
    r"""Std of each day's slope-change errors, robust to settlement, for drifting and thermally biased sensors.

    The estimator's basic model (paper 004 §4.2) has one white noise std for all days. Real
    inclinometers drift (a random-walk-like bias) and keep a thermal residual, so the error of
    the change m_d = theta_d - theta_0 + e_d - e_0 grows with the days since the reference day and
    with the temperature difference from it. Per day, the sensors' departures from the line
    through their two neighbours (a settlement bowl spanning a few sensors hardly departs from it)
    give a robust variance v_d (mean square after setting aside departures beyond 5 MAD, which
    are the bowl's curvature); the model

        sigma_d^2 = a + b t_d + c dT_d^2,   a, b, c >= 0 (non-negative least squares over days),

    with t_d the days since the reference (random-walk drift: variance linear in time) and dT_d
    the site-mean daily temperature minus the reference day's (thermal residual), smooths the
    per-day values (a few tens of sensors each).

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    slopes : (D, N) ndarray
        Daily slope changes, rad (NaN = missing or excluded); row 0 is the reference day.
    day_offsets : (D,) array_like, optional
        Days since the reference day (default 0, 1, ..., D-1).
    temperature_change : (D,) array_like, optional
        dT_d, °C (default: no thermal term).
    floor : float, default 0
        Lower bound of sigma_d, rad (:func:`estimate_settlement` uses half the day-difference sigma).

    Returns
    -------
    (D,) ndarray
        sigma_d, rad (day 0 gets the day-1 value: its change is 0 by construction).
    """
    from scipy.optimize import nnls

    M = np.asarray(slopes, float)
    D = M.shape[0]
    ok = np.isfinite(M).sum(axis=0) > 0
    xs, Ms = np.asarray(x, float)[ok], M[:, ok]
    if xs.size < 5 or D < 2:
        raise InputError(f"too few usable sensors or days to estimate the daily noise: {xs.size} sensor(s) with a "
                         f"daily angle (at least 5 needed) over {D} day(s) (at least 2); the others are dead or "
                         "excluded. Check the warnings on dead sensors, or give the daily noise std "
                         "(error_model='white' or sigma=...; CLI --sigma-deg).")
    v = day_noise_variances(xs, Ms)
    t = np.arange(D, dtype=float) if day_offsets is None else np.asarray(day_offsets, float)
    cols = [np.ones(D), t]
    if temperature_change is not None:
        dT = np.nan_to_num(np.asarray(temperature_change, float))
        cols.append(dT**2)
    A = np.column_stack(cols)
    use = np.isfinite(v) & (np.arange(D) >= 1) & (v > 0)
    if use.sum() == 1:  # one change day (a 2-day campaign): its own level, no growth to fit (docs/rail.md)
        return np.full(D, np.sqrt(max(float(v[use][0]), max(floor, 1e-12) ** 2)))
    if use.sum() < 2:
        raise InputError("no day after the reference day with a measurable noise (its sensors' departures from "
                         "their neighbours): give the daily noise std (sigma=... rad; CLI --sigma-deg DEG, about "
                         "8e-4 deg on the simulated presets), or a longer record.")
    # weights ~ 1/v_d: the per-day variances are chi-square-like, their spread grows with their level
    w = 1.0 / np.maximum(v[use], 1e-300)
    coef, _ = nnls(A[use] * w[:, None], v[use] * w)
    fitted = A @ coef
    fitted[0] = fitted[1] if D > 1 else fitted[0]
    return np.sqrt(np.maximum(fitted, max(floor, 1e-12) ** 2))


def day_noise_variances(x, slopes) -> np.ndarray:
    """(D,) robust variance of each day's slope-change errors from the sensors' departures from the line through their
    two neighbours (scaled to unit noise; departures beyond 5 MAD, a bowl's curvature, set aside); NaN on a day with
    fewer than 3 departures. The per-day values of :func:`daily_noise_sigma`."""
    r = _neighbour_residuals(np.asarray(x, float), np.asarray(slopes, float))
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a day without any departure: its MAD is NaN
        mad = 1.4826 * np.nanmedian(np.abs(r), axis=1, keepdims=True)
        kept = np.where(np.abs(r) <= 5.0 * mad, r, np.nan)
    n = np.isfinite(kept).sum(axis=1)
    return np.where(n >= 3, np.nansum(kept**2, axis=1) / np.maximum(n, 1), np.nan)


#: Bounds of a sensor's noise variance relative to the site's (:func:`sensor_noise_factors`): f^2 in [1/4, 16].
SENSOR_VARIANCE_BOUNDS = (0.25, 16.0)
#: Weight of the pull of every sensor's relative variance towards 1 (ridge term of :func:`sensor_noise_factors`).
SENSOR_VARIANCE_RIDGE = 0.1
#: Fewest day-to-day changes for per-sensor noise factors (:func:`sensor_noise_factors`; fewer: all 1). A mean
#: square of 5 values still varies by a factor ~2; the ridge and the bounds keep such factors moderate.
SENSOR_FACTOR_MIN_DAYS = 5
#: Where a sensor's day-scaled residuals are clipped, in robust std (1.4826 median|r|) of that sensor's own.
SENSOR_RESIDUAL_CLIP = 3.0
#: E[min(z^2, 9)] for z ~ N(0, 1): the mean square of a Gaussian winsorized at 3 std (makes the clipped mean
#: square of :func:`sensor_noise_factors` consistent for a Gaussian sensor).
WINSORIZED_Z2_MEAN = 0.995007


def sensor_noise_factors(x, slopes) -> np.ndarray:
    r"""Noise std of each sensor relative to the day's, f_i (sigma_{d,i} = sigma_d f_i), robust to settlement.

    Inclinometers of one site do not drift alike (a random-walk bias whose diffusion varies tenfold
    between sensors): with one noise std per day the few strong drifters carry as much weight as the
    quiet ones and put most of the error into the profile (beyond paper 004, whose noise is one sigma).
    The departures r_{d,i} of each interior sensor's *day-to-day* slope change from the line through
    its two neighbours' (:func:`daily_noise_sigma` uses the cumulative changes), divided by the day's
    robust spread over the sensors, have a per-sensor robust mean square s_i: the mean over the days of
    r^2 with each r clipped at SENSOR_RESIDUAL_CLIP times the sensor's robust std (1.4826 median_d |r|),
    divided by WINSORIZED_Z2_MEAN (its value for a Gaussian sensor). A drift adds to every day's
    increment, the bowl only to the few work days', which the clipping bounds (docs/rail.md, step 9: the
    former median(r^2)/0.455 with ridge 0.3 compressed the factors, log-slope 0.47 on the true ones on
    calibration sites, against 0.62 now). With g = f^2, E s_i = (g_i + w_l^2 g_{i-1} + w_r^2 g_{i+1})
    / c_i^2 (the line's weights w_l, w_r, c_i^2 = 1 + w_l^2 + w_r^2), so g is the non-negative
    least-squares solution of these N - 2 equations plus a ridge SENSOR_VARIANCE_RIDGE (g_i - 1) = 0
    for every sensor (the end sensors have no equation of their own), clipped to SENSOR_VARIANCE_BOUNDS.
    Assumption: a sensor's share of the error is the same on every day (sigma_{d,i} = sigma_d f_i).

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    slopes : (D, N) ndarray
        Daily slope changes, rad (NaN = missing or excluded); row 0 is the reference day.

    Returns
    -------
    (N,) ndarray
        f_i (1 for sensors without readings, and for every sensor when fewer than 5 have some or the record has
        fewer than SENSOR_FACTOR_MIN_DAYS day-to-day changes).
    """
    from scipy.optimize import nnls

    M = np.asarray(slopes, float)
    f = np.ones(M.shape[1])
    ok = np.isfinite(M).sum(axis=0) > 0
    idx = np.nonzero(ok)[0]
    if idx.size < 5 or M.shape[0] - 1 < SENSOR_FACTOR_MIN_DAYS:
        return f
    xs = np.asarray(x, float)[ok]
    # day-to-day increments: a drift adds to every day's, the bowl only to the few work days' (set aside by
    # the medians); each day scaled by its robust spread over the sensors
    r = _neighbour_residuals(xs, np.diff(M[:, ok], axis=0))
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN days or sensors (excluded neighbours)
        r = r / (1.4826 * np.nanmedian(np.abs(r), axis=1, keepdims=True))
        clip = SENSOR_RESIDUAL_CLIP * 1.4826 * np.nanmedian(np.abs(r), axis=0, keepdims=True)
        msq = np.nanmean(np.clip(r, -clip, clip) ** 2, axis=0) / WINSORIZED_Z2_MEAN
    wl, wr, c2 = _neighbour_weights(xs)
    n = xs.size
    A = np.zeros((n - 2, n))
    rows = np.arange(n - 2)
    A[rows, rows], A[rows, rows + 1], A[rows, rows + 2] = wl**2 / c2, 1.0 / c2, wr**2 / c2
    use = np.isfinite(msq)
    lam = SENSOR_VARIANCE_RIDGE
    g, _ = nnls(np.vstack([A[use], lam * np.eye(n)]), np.concatenate([msq[use], np.full(n, lam)]))
    f[idx] = np.sqrt(np.clip(g, *SENSOR_VARIANCE_BOUNDS))
    return f


#: Re-estimations of the sensor factors from the all-days posterior (:func:`residual_noise_factors`); docs/rail.md
#: step 10 (calibration seeds 300-339: one pass lowered the RMS median on drift 0.79 -> 0.73 mm).
JOINT_FACTOR_REFITS = 1
#: Bounds of f^2 from :func:`residual_noise_factors` (wider than SENSOR_VARIANCE_BOUNDS: no neighbour deconvolution).
RESIDUAL_VARIANCE_BOUNDS = (1.0 / 16.0, 64.0)


def residual_noise_factors(slopes, fitted_slopes, quiet, *, reference_factors) -> np.ndarray:
    r"""Sensor noise factors f_i from the residual day-to-day increments of a fitted settlement (issue 13, step 10).

    :func:`sensor_noise_factors` must tell a sensor's noise from its neighbours' (the departures from the neighbours'
    line mix three sensors). Given the all-days posterior's slope changes theta_hat (docs/rail.md step 10), the
    increments r_{d,i} = Delta(m - theta_hat)_{d,i} on the quiet days (those whose settlement increment has the
    floor prior: the work days set aside; all days when fewer than SENSOR_FACTOR_MIN_DAYS are quiet) are mostly
    sensor i's own drift increments. Each day is divided by its robust spread over the sensors, each sensor's values
    clipped at SENSOR_RESIDUAL_CLIP robust std of its own, and g_i = mean square / WINSORIZED_Z2_MEAN is rescaled
    to the geometric mean of ``reference_factors``^2 (the day covariance was fitted with those), clipped to
    RESIDUAL_VARIANCE_BOUNDS. Assumption: the posterior absorbs little of a sensor's quiet-day increments (the
    quiet days' prior is stiff).

    Parameters
    ----------
    slopes, fitted_slopes : (D, N) ndarray
        Daily slope changes and their posterior mean, rad (NaN columns: excluded sensors).
    quiet : (D-1,) bool array_like
        Whether the increment from day d - 1 to day d is a quiet one.
    reference_factors : (N,) ndarray
        The factors the fit used (:func:`sensor_noise_factors`).

    Returns
    -------
    (N,) ndarray
        f_i (the reference factor where a sensor has no residual).
    """
    quiet = np.asarray(quiet, bool)
    res = np.diff(np.asarray(slopes, float) - np.asarray(fitted_slopes, float), axis=0)
    if quiet.sum() >= SENSOR_FACTOR_MIN_DAYS:
        res = res[quiet]
    f0 = np.asarray(reference_factors, float)
    keep = np.isfinite(res).sum(axis=0) > 0
    if keep.sum() < 5:
        return f0.copy()
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = res[:, keep] / (1.4826 * np.nanmedian(np.abs(res[:, keep]), axis=1, keepdims=True))
        clip = SENSOR_RESIDUAL_CLIP * 1.4826 * np.nanmedian(np.abs(r), axis=0, keepdims=True)
        g = np.nanmean(np.clip(r, -clip, clip) ** 2, axis=0) / WINSORIZED_Z2_MEAN
    ok = np.isfinite(g) & (g > 0)
    out = f0.copy()
    gk = g[ok] * np.exp(np.mean(np.log(f0[keep][ok] ** 2)) - np.mean(np.log(g[ok])))
    out[np.nonzero(keep)[0][ok]] = np.sqrt(np.clip(gk, *RESIDUAL_VARIANCE_BOUNDS))
    return out


def _site_temperature_change(daily: DailyAngles):
    """Site-mean daily mean temperature of each day minus the reference day's, °C (0 where unknown)."""
    T = np.asarray(daily.temperature_mean_c, float)
    return np.nan_to_num(T - T[0]) if np.isfinite(T[0]) else np.zeros(len(daily.days))


#: log10 grids of r searched before the Brent refinement, per penalty order (r in m^-2 for 2, m^-4 for 3).
_LOG10_RIGIDITY_GRID = {2: np.arange(-14.0, -5.0), 3: np.arange(-19.0, -7.0)}
#: The per-day noise's prior fit "cannot tell the settlement from the noise" (:func:`_change_prior_stage`) when the
#: stiffest prior of the grid (no change) is within this many log-likelihood units of the maximum: not rejected at
#: 95 % by the likelihood-ratio test (chi-square, 1 dof: 3.84 / 2). Until 2026-12-06 the rule was "the maximum is at
#: the grid's end" (r <= 1.01 x its stiffest value): on a flat likelihood the bounded search could stop at 1.2-1.3e-14
#: instead of 1e-14, and the fit then kept a prior that printed 0 +- 0.1-0.35 mm where the track had settled 8.8 mm
#: (docs/rail.md, "Logger outages, and a prior that claimed no change").
STIFFEST_LR = 0.5 * 3.841458820694124


def _fit_rigidity(x, rows, sigma, sigma_z, penalty_order, factors=None):
    """Maximum marginal likelihood of r (sigma fixed) over the profiles ``rows``: (r, log-likelihood, log-likelihood
    at the grid's stiffest r)."""

    groups = ([(np.arange(rows.shape[0]), float(sigma))] if np.ndim(sigma) == 0
              else _noise_groups(np.asarray(sigma, float)))

    parts = [rigidity_log_likelihood_function(x, rows[idx], sigma=_station_sigma(s, factors), sigma_z=sigma_z,
                                              penalty_order=penalty_order) for idx, s in groups]

    def nll(logr):
        if not -60 < logr < 5:
            return 1e300
        r = float(np.exp(logr))
        return -float(sum(np.sum(loglik(r)) for loglik in parts))

    grid = np.log(10.0) * _LOG10_RIGIDITY_GRID[penalty_order]
    vals = [nll(g) for g in grid]
    k = int(np.argmin(vals))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    res = minimize_scalar(nll, bounds=(lo, hi), method="bounded", options={"xatol": 1e-3})
    best, fun = (res.x, res.fun) if res.fun <= vals[k] else (grid[k], vals[k])
    return float(np.exp(best)), -float(fun), -float(vals[0])


def _fit_rigidity_each(x, rows, sigmas, sigma_z, penalty_order, factors=None) -> np.ndarray:
    """Maximum marginal likelihood of r for each profile of ``rows`` alone (noise std ``sigmas[d]``, times f_i): the
    r of ``_fit_rigidity(x, rows[d:d+1], sigmas[d], ...)`` for every d to the search's tolerance (1e-3 in log r): the
    same grid, every profile's grid in one engine call, then the grid's bracket around each minimum refined by
    scipy's element-wise minimiser (:func:`scipy.optimize.elementwise.find_minimum`, Chandrupatla's bracketing
    method: all days advance together, one engine call per iteration) instead of one bounded Brent search per day;
    a minimum at an end of the grid is bracketed between it and its neighbour (as ``_fit_rigidity``'s bounded
    search; :func:`scipy.optimize.elementwise.bracket_minimum`), or stays at the end when the likelihood is monotone
    there. The likelihood by the univariate treatment (equal to round-off).
    """
    loglik = rigidity_log_likelihood_rows(x, rows, levels=sigmas, sigma_z=sigma_z, penalty_order=penalty_order,
                                          sensor_factors=factors, univariate=True)

    def nll(logr, index):  # scipy's element-wise signature (its args arrive as floats)
        index = index.astype(np.intp)
        out = np.full(index.size, 1e300)
        ok = (-60 < logr) & (logr < 5)
        if ok.any():  # np.exp of the array: the scalar's values, bit for bit (tested)
            out[ok] = -loglik(index[ok], np.exp(logr[ok]))
        return out

    grid = np.log(10.0) * _LOG10_RIGIDITY_GRID[penalty_order]
    D, G = rows.shape[0], grid.size
    vals = nll(np.tile(grid, D), np.repeat(np.arange(D), G)).reshape(D, G)
    k = np.argmin(vals, axis=1)
    best, fun = grid[k].copy(), vals[np.arange(D), k]
    # brackets (left, middle, right) around each minimum: the grid's own where the minimum is inside it; at an end of
    # the grid, within the half-interval to its neighbour (as _fit_rigidity's bounded search), found by scipy
    left, mid, right = grid[np.maximum(k - 1, 0)], grid[k], grid[np.minimum(k + 1, G - 1)]
    edge = np.flatnonzero((k == 0) | (k == G - 1))
    if edge.size:
        from scipy.optimize.elementwise import bracket_minimum

        lo, hi = np.minimum(left[edge], right[edge]), np.maximum(left[edge], right[edge])
        w = hi - lo
        br = bracket_minimum(nll, lo + 0.5 * w, xl0=lo + 0.25 * w, xr0=lo + 0.75 * w, xmin=lo, xmax=hi, args=(edge,))
        for arr, b in zip((left, mid, right), br.bracket):
            arr[edge] = np.where(br.status == 0, b, arr[edge])  # else (-1): the grid's end is the minimiser
        mid[edge[br.status != 0]] = np.nan
    todo = np.flatnonzero(np.isfinite(mid) & (left < mid) & (mid < right))
    if todo.size:
        from scipy.optimize.elementwise import find_minimum

        res = find_minimum(nll, (left[todo], mid[todo], right[todo]), args=(todo,),
                           tolerances={"xatol": 1e-3, "xrtol": 0.0})
        better = res.f_x <= fun[todo]
        best[todo[better]] = res.x[better]
    return np.exp(best)


def _changed_rows(slopes, sigma=None):
    keep = np.nanmax(np.abs(np.nan_to_num(slopes)), axis=1) > 0
    rows = slopes[keep]
    if rows.shape[0] == 0:
        raise InputError("no day differs from the reference day: the rigidity cannot be estimated; pass it.")
    if sigma is None:
        return rows
    return rows, (sigma if np.ndim(sigma) == 0 else np.asarray(sigma, float)[keep])


def fit_noise_and_rigidity(x, slopes, *, sigma=None, rigidity=None, sigma_z=DEFAULT_SIGMA_Z, penalty_order: int = 2):
    """Noise sigma (robust day-to-day differences) and rigidity r (maximum marginal likelihood) of the daily slopes.

    Parameters
    ----------
    x : (N,) ndarray
    slopes : (D, N) ndarray
        Daily slope changes, rad (NaN = missing); row 0 is the reference day.
    sigma, rigidity : float, optional
        Fixed values; None = estimate.
    sigma_z : float
    penalty_order : {2, 3}, default 2
        Prior of the change profile (:func:`~longprofile.rail.rigidity_model`).

    Returns
    -------
    sigma, rigidity : float

    Notes
    -----
    sigma comes from :func:`day_difference_sigma` and only r is fitted, by the Kalman-filter
    likelihood of the rigidity model summed over the days that differ from the reference day
    (grid on log r, then Brent). Fitting sigma too is degenerate with the paper's prior
    (penalty_order 2): its slope is a Brownian motion along the track, whose increments absorb
    white slope noise, and the joint maximum sends sigma -> 0 (docs/rail.md).
    """
    slopes = np.asarray(slopes, float)
    s = float(sigma) if sigma is not None else day_difference_sigma(slopes)
    if rigidity is not None:
        return s, float(rigidity)
    return s, _fit_rigidity(x, _changed_rows(slopes), s, sigma_z, penalty_order)[0]


#: Decades above ``sigma_z`` over which :func:`fit_end_anchor` searches the end anchor of the health tests' prediction.
HEALTH_ANCHOR_DECADES = 5
#: ``SettlementSettings.health_end_anchor``: "fixed" (``sigma_z``, the default), "fit" (:func:`fit_end_anchor`, the
#: per-day likelihood) or "all-days" (:func:`fit_end_anchor_all_days`, the all-days likelihood).
HEALTH_END_ANCHORS = ("fixed", "fit", "all-days")
#: ``SettlementSettings.settlement_end_anchor``: "fixed" (``sigma_z``, the default until 2026-12-06 session 28) or
#: "all-days" (:func:`_settlement_anchor`, the default since).
SETTLEMENT_END_ANCHORS = ("fixed", "all-days")
#: ``SettlementSettings.end_ambiguity``: "off" (the settlement's anchor as chosen, the default until 2026-12-06
#: session 28) or "mixture" (:func:`_end_mixture`: when the all-days likelihood of all sensors loosens the ends but the
#: guarded test does not, the bands carry both hypotheses; docs/rail.md, "The settlement's ends when one sensor carries
#: the evidence").
END_AMBIGUITIES = ("off", "mixture")
#: Weight of the hypothesis "the ends moved" in :func:`_end_mixture`: the data cannot tell it from "a faulty sensor
#: faked it" (that is why the guard refused), so both get one half (docs/rail.md).
END_MIXTURE_WEIGHT = 0.5
#: Log-likelihood gain over the fixed anchor that the all-days likelihood of all sensors needs for :func:`_end_mixture`
#: to keep the hypothesis "the ends moved": half the 99 % quantile of chi-square with 1 degree of freedom (a 1 %
#: likelihood-ratio test, without the guard's leave-one-out checks). Chosen on calibration seeds 300-339 over the
#: guard's 0.1 % (:data:`ANCHOR_MIN_GAIN`), which left 5 of 40 joint-step sites with a fixed far end (docs/rail.md).
END_MIXTURE_MIN_GAIN = 3.317


def _running_median3(slopes):
    """Median of each kept sensor's slope change and its kept neighbours' on either side, per day (an end sensor: with
    its two inner neighbours): a single faulty sensor does not move it, a settlement shared by neighbouring sensors
    does. (Until session 27 an end sensor took the median of two, i.e. the mean with its neighbour, so a jump of the
    sensor next to an end moved the end's value by half: found by the property test of ``fit_end_anchor``.)"""
    out = np.full_like(slopes, np.nan)
    kept = np.flatnonzero(np.isfinite(slopes).any(axis=0))
    if kept.size < 3:
        return slopes.copy()
    S = slopes[:, kept]
    lo = np.clip(np.arange(kept.size) - 1, 0, kept.size - 3)  # first of each sensor's three
    W = np.stack([S[:, lo], S[:, lo + 1], S[:, lo + 2]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        med = np.nanmedian(W, axis=0)
    out[:, kept] = np.where(np.isfinite(S), med, np.nan)
    return out


def fit_end_anchor(x, slopes, *, sigma=None, sigma_z: float = DEFAULT_SIGMA_Z, decades: int = HEALTH_ANCHOR_DECADES):
    """Maximum-likelihood std of the end anchors of the change profile, for the health tests' prediction.

    Parameters
    ----------
    x : (N,) ndarray
    slopes : (D, N) ndarray
        Daily slope changes, rad (NaN = missing); row 0 is the reference day.
    sigma : float, optional
        Noise std (None: :func:`day_difference_sigma`).
    sigma_z : float
        The anchor std of the settings, m: the smallest value searched.
    decades : int
        Values searched: ``sigma_z * 10**k``, k = 0, ..., ``decades``.

    Returns
    -------
    sigma_z_hat : float
        The value of largest marginal likelihood, r profiled out (paper's prior, penalty order 2, as the
        health tests).
    loglik : (decades + 1,) ndarray
        Its profile log-likelihood at each value searched.

    Notes
    -----
    The prior of paper 004 (§4.2) anchors both ends of the change profile at 0 (std sigma_z), so the slopes must
    integrate to nothing over the span: a rigid rotation of the whole span (every sensor's angle changing by the same
    amount, a tilting embankment) cannot be represented, and the smoother then predicts some sensors from their
    neighbours with the wrong sign. The anchor std is a prior std of the end-to-end altitude change and is
    estimated here as the rigidity is, by the Kalman-filter marginal likelihood of all days (each day's noise std
    from :func:`daily_noise_sigma`, r profiled out), on the 3-point running median of the slope changes along the
    track: a tilt is shared by all sensors, a faulty sensor (reversed, detached) is alone and would otherwise
    loosen the anchor itself. A loose anchor is also chosen on many sites whose ends do not move (drift of the
    sensors' sum); there the health tests lose the information of the anchor (docs/rail.md, "Sensor health on
    settlements that are not a bowl").
    """
    slopes = np.asarray(slopes, float)
    s = float(sigma) if sigma is not None else day_difference_sigma(slopes)
    slopes = _running_median3(slopes)
    try:  # each day's error std, drift included (a tilt does not enter it: neighbour residuals)
        s = daily_noise_sigma(x, slopes, floor=0.5 * s)
    except InputError:
        pass
    rows, s = _changed_rows(slopes, s)
    grid = float(sigma_z) * 10.0 ** np.arange(int(decades) + 1)
    ll = np.array([_fit_rigidity(x, rows, s, sz, 2)[1] for sz in grid])
    return float(grid[int(np.argmax(ll))]), ll


#: Log-likelihood gain over the anchor at ``sigma_z`` that :func:`fit_end_anchor_all_days` needs to loosen it: half the
#: 99.9 % quantile of chi-square with 1 degree of freedom (a likelihood-ratio test of one parameter at 0.1 %). The 1 %
#: level (3.32) was also measured on calibration seeds: one more healthy sensor flagged on ``faults`` (docs/rail.md).
ANCHOR_MIN_GAIN = 5.414

#: Decades of the common scale of the increment rigidities r_d over which :func:`fit_end_anchor_all_days` profiles
#: the all-days likelihood (either side of the fit at ``sigma_z``), and the grid's steps per decade.
ANCHOR_SCALE_DECADES, ANCHOR_SCALE_STEPS = 3, 4


def _all_days_anchor_model(x, slopes, *, day_offsets, temperature_change, sigma, sigma_z):
    """The all-days model (docs/rail.md step 10) of ``slopes`` fitted with the anchor ``sigma_z`` and the paper's
    prior (order 2, as the health tests): (mode data (K, N), DayModes, sensor factors)."""
    M = np.asarray(slopes, float)
    t = np.arange(M.shape[0], dtype=float) if day_offsets is None else np.asarray(day_offsets, float)
    M, _ = _fill_missing_days(M, t)
    factors = sensor_noise_factors(x, M)
    noise = day_noise_covariance(x, M, day_offsets=t, temperature_change=temperature_change, sensor_factors=factors,
                                 floor=0.5 * sigma)
    prior = increment_rigidity(x, M, noise_cov=noise.cov, sigma_z=sigma_z, penalty_orders=(2,),
                               sensor_factors=factors)
    modes = day_modes(noise.cov, prior.rigidity_by_day)
    return modes.to_modes @ M[1:], modes, factors


def all_days_anchor_log_likelihood(x, mode_slopes, modes: DayModes, *, sigma_z: float, sensor_factors=None,
                                   penalty_order: int = 2, segment_weights=None) -> tuple[float, float]:
    r"""All-days marginal log-likelihood of the slope changes at the end-anchor std ``sigma_z``, the common scale c of
    the increment rigidities (r_d -> c r_d) profiled out: (log-likelihood, c).

    The modes of :func:`~longprofile.rail._joint.day_modes` are independent (step 10), so the log-likelihood of all
    days and stations is the sum over modes of the rigidity model's (paper 004 §4.2, Lemma 4.1; the engine's
    :func:`longprofile.statespace.grouped_log_likelihood`, one candidate per mode and scale) plus
    N log|det V|, which neither ``sigma_z`` nor c changes (V, the modes, depend on the ratios r_d / r only).
    The anchor's pseudo-observation in mode k has std ``sigma_z``: over the days the end-to-end change has the
    settlement increments' covariance sigma_z^2 S, so the noise's own end-to-end displacement (reference-day error,
    drift: R) is not evidence against the anchor, as it is in the per-day likelihood (:func:`fit_end_anchor`).
    """
    Y = np.asarray(mode_slopes, float)
    K = Y.shape[0]
    loglik = rigidity_log_likelihood_rows(x, Y, levels=modes.noise, sigma_z=sigma_z, penalty_order=penalty_order,
                                          sensor_factors=sensor_factors, segment_weights=segment_weights,
                                          univariate=True)
    r = float(modes.rigidity)

    def total(logc):
        logc = np.atleast_1d(np.asarray(logc, float))
        ll = loglik(np.tile(np.arange(K), logc.size), np.repeat(r * np.exp(logc), K))
        return ll.reshape(logc.size, K).sum(axis=1)

    step = np.log(10.0) / ANCHOR_SCALE_STEPS
    grid = step * np.arange(-ANCHOR_SCALE_DECADES * ANCHOR_SCALE_STEPS, ANCHOR_SCALE_DECADES * ANCHOR_SCALE_STEPS + 1)
    vals = total(grid)
    k = int(np.argmax(vals))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    res = minimize_scalar(lambda v: -float(total(v)[0]), bounds=(lo, hi), method="bounded", options={"xatol": 1e-2})
    best, ll = (float(res.x), -float(res.fun)) if -res.fun >= vals[k] else (float(grid[k]), float(vals[k]))
    return ll, float(np.exp(best))


def fit_end_anchor_all_days(x, slopes, *, day_offsets=None, temperature_change=None, sigma=None,
                            sigma_z: float = DEFAULT_SIGMA_Z, decades: int = HEALTH_ANCHOR_DECADES,
                            median: bool = False, min_gain: float = ANCHOR_MIN_GAIN, leave_one_out: bool = True,
                            witnesses=None):
    """Maximum-likelihood std of the end anchors by the all-days likelihood (docs/rail.md, "The end anchor by the
    all-days likelihood"), for the health tests' prediction.

    Parameters
    ----------
    x : (N,) ndarray
    slopes : (D, N) ndarray
        Daily slope changes, rad (NaN = missing or excluded); row 0 is the reference day.
    day_offsets, temperature_change : (D,) array_like, optional
        As in :func:`~longprofile.rail._joint.day_noise_covariance`.
    sigma : float, optional
        Day-to-day noise std (None: :func:`day_difference_sigma`); half of it floors each day's std.
    sigma_z : float
        The anchor std of the settings, m: the smallest value searched.
    decades : int
        Values searched: ``sigma_z * 10**k``, k = 0, ..., ``decades``.
    median : bool, default False
        Fit the 3-point running median of the slope changes along the track, as :func:`fit_end_anchor` does. Off: the
        median of three has another noise than the all-days model's R (fitted to the sensors' own departures) and
        loosened the anchor on bowl sites (calibration seeds, docs/rail.md); the margin ``min_gain`` and the re-fit
        on the kept sensors before each health pass stand in for it against a single faulty sensor.
    min_gain : float, default ANCHOR_MIN_GAIN
        The anchor is loosened only when its best value's log-likelihood exceeds the anchor at ``sigma_z``'s by more
        (a likelihood-ratio test of one parameter at 0.1 %).
    leave_one_out : bool, default True
        ... and also without any one of the kept sensors (:func:`_loo_anchor_gain`, the model of all sensors) and
        with the whole model fitted again without the most influential one: a single reversed or detached sensor
        does not loosen the anchor (it did on the paper's simulator, a healthy neighbour of the reversed sensor was
        then flagged; docs/rail.md).
    witnesses : (N,) bool array_like, optional
        Sensors the health tests kept as witnesses of a localised movement (``SensorHealth.witness``,
        ``witness_rule="steps-ends"``): the leave-one-out checks do not leave them out, i.e. one of them may carry the
        evidence that the ends moved (docs/rail.md, "Sensor health on a transition: the step's witnesses").

    Returns
    -------
    sigma_z_hat : float
        The value of largest all-days likelihood if it beats ``sigma_z`` by more than ``min_gain``, else ``sigma_z``.
    loglik : (decades + 1,) ndarray
        The all-days profile log-likelihood at each value searched (:func:`all_days_anchor_log_likelihood`).

    Notes
    -----
    The all-days model of step 10 (noise covariance over the days R, increment rigidities r_d, paper's prior order 2)
    is fitted once at ``sigma_z``; each candidate anchor is then scored with the modes fixed and the common scale of
    the r_d profiled. Unlike :func:`fit_end_anchor`'s per-day likelihood it knows that a sensor's reference-day
    error and drift are shared by all its days.
    """
    M = np.asarray(slopes, float)
    s = float(sigma) if sigma is not None else day_difference_sigma(M)
    if median:
        M = _running_median3(M)
    Y, modes, f = _all_days_anchor_model(x, M, day_offsets=day_offsets, temperature_change=temperature_change,
                                         sigma=s, sigma_z=sigma_z)
    grid, fits = _anchor_profile(x, Y, modes, sigma_z, decades, sensor_factors=f)
    ll = np.array([v for v, _ in fits])
    k = int(np.argmax(ll))
    if ll[k] - ll[0] <= min_gain:
        return float(sigma_z), ll
    if leave_one_out:
        skip = np.zeros(M.shape[1], bool) if witnesses is None else np.asarray(witnesses, bool)
        gain, j = _loo_anchor_gain(x, Y, modes, f, (grid[0], fits[0][1]), (grid[k], fits[k][1]), skip=skip)
        if gain <= min_gain:
            return float(sigma_z), ll
        # a faulty sensor also shapes the model (its neighbours' factors, R, r_d): fitted again without the most
        # influential sensor and without the one departing most from its neighbours' running median
        for jj in {j, _largest_departure(slopes, skip=skip)} - {-1}:
            Mj = np.array(slopes, float)
            Mj[:, jj] = np.nan
            if fit_end_anchor_all_days(x, Mj, day_offsets=day_offsets, temperature_change=temperature_change,
                                       sigma=s, sigma_z=sigma_z, decades=decades, median=median, min_gain=min_gain,
                                       leave_one_out=False)[0] == sigma_z:
                return float(sigma_z), ll
    return float(grid[k]), ll


def _anchor_profile(x, mode_slopes, modes: DayModes, sigma_z: float, decades: int, **options):
    """The anchors ``sigma_z * 10**k``, k = 0..``decades``, and the all-days profile log-likelihood with its scale c at
    each (:func:`all_days_anchor_log_likelihood`; ``options`` passed on): ((decades + 1,) grid, [(loglik, c), ...])."""
    grid = float(sigma_z) * 10.0 ** np.arange(int(decades) + 1)
    return grid, [all_days_anchor_log_likelihood(x, mode_slopes, modes, sigma_z=v, **options) for v in grid]


def _largest_departure(slopes, skip=None) -> int:
    """The kept sensor whose slope changes depart most from their 3-point running median along the track (mean over
    the days of the departure squared, each day in robust std of that day's nonzero departures); not one of ``skip``
    ((N,) bool; -1 when no sensor is left).

    Nonzero: a sensor whose value lies between its two neighbours' *is* their median, so its departure is exactly 0;
    on a day of smooth settlement most sensors do (a bowl's flanks are monotone), and the median of all departures
    was then 0 — until 2026-12-06 (session 28) such days were left out, and a reversed sensor on a flank, which departs
    only on the settlement days, was not the largest (found by the property test of
    :func:`fit_end_anchor_all_days`: seed 186, sensor 18)."""
    M = np.asarray(slopes, float)
    r = M - _running_median3(M)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        scale = 1.4826 * np.nanmedian(np.abs(np.where(r != 0, r, np.nan)), axis=1, keepdims=True)
        score = np.nanmean((r / np.where(scale > 0, scale, np.inf)) ** 2, axis=0)
    score = np.where(np.isfinite(score) & (True if skip is None else ~np.asarray(skip, bool)), score, -np.inf)
    return int(np.argmax(score)) if skip is None or np.isfinite(score).any() else -1


def _loo_anchor_gain(x, Y, modes: DayModes, factors, fixed, loose, skip=None) -> tuple[float, int]:
    """The smallest over the kept sensors j of the all-days log-likelihood gain of the anchor ``loose`` = (sigma_z, c)
    over ``fixed`` without sensor j (its column of the mode data missing; modes and the scales c of the fit with all
    sensors), and that j: a tilt is in every sensor, a reversed or detached sensor's own departure is gone without
    it. One engine call per anchor (:func:`~longprofile.rail._rigidity.rigidity_log_likelihood_rows`, each sensor's
    K modes). Sensors of ``skip`` ((N,) bool, the health tests' witnesses) are not left out; (inf, -1) when none is
    left to leave out."""
    kept = np.flatnonzero(np.isfinite(Y).all(axis=0) & (True if skip is None else ~np.asarray(skip, bool)))
    if kept.size == 0:
        return float("inf"), -1
    K, N = Y.shape
    J = kept.size
    Ys = np.repeat(Y[None], J, axis=0)
    Ys[np.arange(J), :, kept] = np.nan
    Ys = Ys.reshape(J * K, N)
    levels = np.tile(modes.noise, J)
    out = []
    for sz, c in (fixed, loose):
        loglik = rigidity_log_likelihood_rows(x, Ys, levels=levels, sigma_z=sz, penalty_order=2,
                                              sensor_factors=factors, univariate=True)
        out.append(loglik(np.arange(J * K), np.full(J * K, modes.rigidity * c)).reshape(J, K).sum(axis=1))
    gain = out[1] - out[0]
    return float(np.min(gain)), int(kept[int(np.argmin(gain))])


def fit_change_prior(x, slopes, *, sigma: float, sigma_z: float = DEFAULT_SIGMA_Z,
                     penalty_orders=PENALTY_ORDERS, sensor_factors=None) -> ChangePriorFit:
    r"""Fit the prior of the settlement (change) profile by maximum marginal likelihood, sigma fixed.

    For each penalty order (2: the paper's cubic-spline prior exp(-||f''||^2/r); 3: the smoother
    quintic-spline prior exp(-||f‴||^2/r)) r is fitted by maximising the Kalman-filter likelihood of
    the slope changes summed over the days (:func:`fit_noise_and_rigidity`); the order with the
    larger maximised likelihood wins (same number of parameters, so this is also the AIC choice).

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    slopes : (D, N) ndarray
        Daily slope changes, rad (NaN = missing or excluded); row 0 is the reference day.
    sigma : float or (D,) array_like
        Slope-change noise std, rad (e.g. :func:`day_difference_sigma`), kept fixed; one value per
        day (:func:`daily_noise_sigma`) is allowed.
    sigma_z : float
        End-anchor std, m.
    penalty_orders : iterable of int
        Orders to try.
    sensor_factors : (N,) array_like, optional
        Per-sensor noise factors f_i (:func:`sensor_noise_factors`): the noise std of sensor i on day
        d is then sigma_d f_i.

    Returns
    -------
    ChangePriorFit
    """
    rows, sig = _changed_rows(np.asarray(slopes, float), sigma if np.ndim(sigma) else float(sigma))
    f = None if sensor_factors is None else np.asarray(sensor_factors, float)
    lls, rs, stiff = {}, {}, {}
    for order in penalty_orders:
        rs[int(order)], lls[int(order)], stiff[int(order)] = _fit_rigidity(x, rows, sig, sigma_z, int(order), f)
    best = max(lls, key=lls.get)
    return ChangePriorFit(penalty_order=best, rigidity=rs[best], log_likelihood=lls, rigidities=rs,
                          sigma=float(sigma) if np.ndim(sigma) == 0 else float(np.median(sigma)),
                          stiffest_log_likelihood=stiff)


#: Floor of the per-day settlement-increment rigidity r_d relative to the largest (:func:`increment_rigidity`): a day
#: without works keeps 2 % of the busiest day's prior intensity (creep, and works the data barely show). Chosen on
#: calibration seeds 300-339 (docs/rail.md, step 10).
INCREMENT_PRIOR_FLOOR = 0.02


@dataclass(frozen=True)
class IncrementPrior:
    """Prior of the settlement's day-to-day increments (:func:`increment_rigidity`). K = D - 1 days.

    Attributes
    ----------
    penalty_order : int
        2 = the paper's ||f''||^2 prior, 3 = ||f‴||^2 (the larger maximised likelihood of all increments).
    rigidity_by_day : (K,) ndarray
        r_d of the increment from day d - 1 to day d (m^-2 or m^-4), floored at INCREMENT_PRIOR_FLOOR x the largest.
    fit : ChangePriorFit
        The stationary fit over all increments that chose the order.
    """

    penalty_order: int
    rigidity_by_day: np.ndarray
    fit: ChangePriorFit


def increment_rigidity(x, slopes, *, noise_cov, sigma_z: float = DEFAULT_SIGMA_Z, penalty_orders=PENALTY_ORDERS,
                       sensor_factors=None, floor: float = INCREMENT_PRIOR_FLOOR) -> IncrementPrior:
    r"""Prior intensity of each day's settlement increment, by maximum likelihood (issue 13, step 10).

    Beyond paper 004, whose prior (§4.2, π(f) ∝ exp(-||f''||^2 / r)) is the same on every day: the settlement of a
    site grows in steps during a few nights of works, the sensors' drift every day. The day-to-day increments
    Delta m_d = m_d - m_{d-1} of the slope changes have, under the noise model of
    :func:`~longprofile.rail._joint.day_noise_covariance`, the noise std sqrt((Delta R Delta^T)_{dd}) f_i; the
    penalty order is the one with the larger likelihood of all increments (:func:`fit_change_prior`), and r_d
    maximises the likelihood of increment d alone (:func:`fit_noise_and_rigidity`'s grid and Brent search), then is
    floored at ``floor`` times the largest (a quiet day's ML r is at the stiffest of the grid: no change at all).
    The increments' noise correlation (white noise's differences) is neglected in this fit only.

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    slopes : (D, N) ndarray
        Daily slope changes, rad (NaN = missing or excluded); row 0 is the reference day.
    noise_cov : (D-1, D-1) array_like
        R of a sensor of factor 1 over days 1..D-1 (:func:`~longprofile.rail._joint.day_noise_covariance`).
    sigma_z, penalty_orders, sensor_factors
        As in :func:`fit_change_prior`.
    floor : float, default INCREMENT_PRIOR_FLOOR
        0 < floor <= 1.

    Returns
    -------
    IncrementPrior
    """
    if not 0.0 < floor <= 1.0:
        raise InputError(f"floor must be in (0, 1]; got {floor!r}.")
    M = np.asarray(slopes, float)
    K = M.shape[0] - 1
    R = np.asarray(noise_cov, float)
    if R.shape != (K, K):
        raise InputError(f"noise_cov must be ({K}, {K}) for {K + 1} days; got shape {R.shape}.")
    dM = np.diff(M, axis=0)
    s_inc = np.sqrt(np.diag(day_differences(R)))
    fit = fit_change_prior(x, dM, sigma=s_inc, sigma_z=sigma_z, penalty_orders=penalty_orders,
                           sensor_factors=sensor_factors)
    f = None if sensor_factors is None else np.asarray(sensor_factors, float)
    rd = _fit_rigidity_each(x, dM, s_inc, sigma_z, fit.penalty_order, f)
    return IncrementPrior(penalty_order=fit.penalty_order, rigidity_by_day=np.maximum(rd, floor * float(rd.max())),
                          fit=fit)


#: EM steps of :func:`segment_prior_weights`, started from the stationary prior (w = 1); chosen on calibration
#: seeds 300-311 (docs/rail.md, step 7).
PRIOR_WEIGHT_ITERATIONS = 8
#: Floor of the segment weights relative to their maximum (:func:`segment_prior_weights`).
PRIOR_WEIGHT_FLOOR = 0.3
#: Half-width (segments) of the moving average applied to the segment weights after each EM step.
PRIOR_WEIGHT_HALF_WIDTH = 1


def segment_prior_weights(x, slopes, *, sigma, rigidity: float, penalty_order: int, sigma_z: float = DEFAULT_SIGMA_Z,
                          sensor_factors=None, n_iter: int = PRIOR_WEIGHT_ITERATIONS,
                          floor: float = PRIOR_WEIGHT_FLOOR, half_width: int = PRIOR_WEIGHT_HALF_WIDTH) -> np.ndarray:
    r"""Space-varying prior of the change profile: a relative intensity w_i per segment, by empirical Bayes.

    Beyond paper 004, whose prior π(f) ∝ exp(-||f''||^2 / r) (§4.2) has one r along the whole track: a
    settlement bowl is local, so one r fitted by maximum likelihood (:func:`fit_change_prior`) is a compromise
    between the quiet track, which wants r small, and the bowl, whose curvature it then shrinks (the bowl
    comes out too shallow and that bias is not in the band, docs/rail.md). Here segment i gets r w_i
    (:func:`~longprofile.rail.rigidity_model`, ``segment_weights``): process noise Q_i = q w_i Qbar(l_i).
    Starting from w = 1 (the maximum-likelihood stationary prior), each step is the EM update of the
    intensities shared by all days (Shumway & Stoffer's M-step for a scaled process covariance),

        w_i <- (1 / (k D)) Σ_d E[e_{d,i}^T (q Qbar(l_i))^{-1} e_{d,i} | m_d; w],

    (k = penalty_order, the state dimension; :func:`~longprofile.rail._rigidity.segment_process_energy`), then
    regularised: a moving average over 2 ``half_width`` + 1 segments (a bowl spans several segments and one
    segment's statistic is noisy) and a floor at ``floor`` times the maximum (the quiet track keeps some
    freedom: a weight near 0 would make its band vanish). ``n_iter`` steps (an early-stopped EM: with the
    smoothing and the floor it is not an exact likelihood ascent; the three constants were chosen on
    calibration seeds, not on the benchmark's).

    Parameters
    ----------
    x, slopes, sigma, sigma_z, sensor_factors
        As in :func:`fit_change_prior` (stations, daily slope changes with the reference day first, the noise
        std of every day or one for all, the end-anchor std, the per-sensor noise factors).
    rigidity : float
        r of the stationary prior (m^-2 for order 2, m^-4 for order 3).
    penalty_order : {2, 3}
    n_iter, floor, half_width
        EM steps, floor relative to the maximum (0 < floor <= 1; 1 gives w = 1), moving-average half-width.

    Returns
    -------
    (N-1,) ndarray
        w_i > 0, one per segment between consecutive stations (all 1 when no day differs from the reference).
    """
    x = np.asarray(x, float)
    M = np.asarray(slopes, float)
    w = np.ones(x.size - 1)
    if not 0.0 < floor <= 1.0:
        raise InputError(f"floor must be in (0, 1]; got {floor!r}.")
    if floor == 1.0 or n_iter <= 0:
        return w
    try:
        rows, sig = _changed_rows(M, sigma if np.ndim(sigma) else float(sigma))
    except InputError:
        return w
    levels = ([(np.arange(rows.shape[0]), float(sig))] if np.ndim(sig) == 0 else _noise_groups(np.asarray(sig)))
    group, lv = _engine_groups(levels, rows)
    f = None if sensor_factors is None else np.asarray(sensor_factors, float)
    kernel = np.full(2 * half_width + 1, 1.0 / (2 * half_width + 1))
    for _ in range(int(n_iter)):
        e = segment_process_energy_levels(x, rows, group, levels=lv, rigidity=rigidity, sigma_z=sigma_z,
                                          penalty_order=penalty_order, sensor_factors=f, segment_weights=w)
        energy = sum(e[idx].sum(axis=0) for idx, _ in levels)
        wn = energy / (penalty_order * rows.shape[0])
        if half_width > 0:
            wn = np.convolve(np.pad(wn, half_width, mode="edge"), kernel, mode="valid")
        top = float(np.max(wn))
        if not np.isfinite(top) or top <= 0:
            return np.ones(x.size - 1)
        w = np.maximum(wn, floor * top)
    return w


def affine_correction(x, slopes, usable):
    r"""Affine-in-space correction of §5.2: remove, per day, the line through the first and last usable sensors' changes.

    m'_i(t) = m_i(t) - [m_a(t) + (m_b(t) - m_a(t)) (x_i - x_a) / (x_b - x_a)], a, b = first and last usable sensors.

    Warning (paper 004 §5.2): this forces the end sensors to read no change; it fixed the
    drifting sensors of Farébersviller track 2 but degraded track 1 — it is not robust, and it
    removes any genuine rotation of the ends.
    """
    idx = np.nonzero(usable)[0]
    if idx.size < 2:
        raise InputError("the affine correction needs at least 2 usable sensors.")
    a, b = idx[0], idx[-1]
    w = (x - x[a]) / (x[b] - x[a])
    return slopes - (slopes[:, [a]] + (slopes[:, [b]] - slopes[:, [a]]) * w[None, :])


@dataclass(frozen=True)
class SettlementSettings:
    """Options of :func:`estimate_settlement`, with their defaults, validated once (``__post_init__``).

    ``estimate_settlement(site, settings=SettlementSettings(...))`` and
    ``estimate_settlement(site, **options)`` give identical results.

    Attributes
    ----------
    thermal : {"auto", "linear", "lagged", "none"}, default "auto"
        Temperature de-biasing of the daily angles: the paper's §3 ("linear"), the first-order lag model, or the
        lagged model where the data show a lag and the linear one elsewhere ("auto"; docs/rail.md, "The thermal
        model chosen by the data").
    sigma : float or None, default None
        Std of the daily slope changes, rad (None: estimated from the day-to-day differences).
    rigidity : float or None, default None
        r of the prior of the change profile, m^-2 (penalty order 2) or m^-4 (order 3); None: maximum likelihood.
    penalty_order : {None, 2, 3}, default None
        Prior of the change profile (None: the larger maximised likelihood, or 2 with a given ``rigidity``).
    survey_rigidity : float, default 1e-8
        r of the track geometry for the initial profile from the survey (§4.4), m^-2.
    sigma_z : float, default 1e-5
        Std of the end anchors, m (> 0).
    sigma_a : float, default 2e-3
        Survey noise, m (> 0).
    reference_temp_c : float, default 5
        Reference temperature of the thermal correction, °C.
    quiet_days : sequence of dates or None, default None
        Days without works (e.g. "2019-11-18") for the thermal fit; None: every day.
    check_health : bool, default True
        Flag and exclude improbable sensors (§6); dead, frozen and late sensors are always excluded.
    exclude_sensors : tuple of str, default ()
        Sensor ids excluded by the user (status "excluded", not tested).
    use_affine_correction : bool, default False
        Apply the §5.2 affine correction (not robust, see :func:`affine_correction`).
    through_time : bool, default True
        Also smooth across days per station and compute daily rates.
    process_std : float or None, default None
        Day-to-day settlement std of the through-time model, m/day (None: maximum likelihood).
    settlement_threshold_m : float or None, default None
        Alarm threshold on |altitude change|, m.
    rate_threshold_m_per_day : float or None, default None
        Alarm threshold on |daily rate|, m/day.
    thresholds : mapping or None, default None
        Graded thresholds ``{quantity: {level: value}}`` (settlement, rate, twist; alert, action, alarm; m or m/day:
        :func:`~longprofile.rail.check_thresholds`), tested by :func:`~longprofile.rail.threshold_alarms` (the
        alarms table then has a ``level`` column); not together with the two single thresholds above. With no
        threshold at all nothing is tested: ``SettlementResult.alarms`` is empty and says nothing about limits.
    alarm_probability : float, default 0.5
        Report a station-day when its exceedance probability is at least this (0..1).
    n_monte_carlo : int, default 1000
        Posterior draws per day for the maximum settlement (0 = skip, NaN results).
    rng : int or numpy Generator, default 0
        Seed (or generator) of the Monte Carlo.
    error_model : {"drift", "white"}, default "drift"
        Error model of the daily slope changes (:data:`ERROR_MODELS`); a given ``sigma`` implies "white".
    sensor_noise : bool, default True
        With ``error_model="drift"``: one noise factor per sensor (:func:`sensor_noise_factors`), so
        that strongly drifting sensors weigh less; False gives every sensor the day's std.
    spatial_prior : bool, default True
        With the fitted change prior (``rigidity=None``): a space-varying r, larger where the data say the
        track moves (:func:`segment_prior_weights`); False keeps one r along the track (stationary prior).
    joint_days : bool, default True
        With ``error_model="drift"`` and the fitted prior: all days at once (issue 13 step 10,
        :mod:`~longprofile.rail._joint`): each sensor's error is correlated over the days (random-walk drift, the
        shared reference day, thermal residual; :func:`~longprofile.rail._joint.day_noise_covariance`) and the
        settlement grows by increments whose prior intensity is fitted per day (:func:`increment_rigidity`: the
        work days). False gives the per-day posteriors of step 9 exactly. Records of fewer than 6 days use the
        per-day model.
    max_settlement_interval : {"draws", "band"}, default "draws"
        The maximum settlement's 90 % interval (:func:`~longprofile.rail.max_settlement_interval`): "draws", the
        band-shaped interval holding the maximum of :data:`~longprofile.rail._rigidity.MAX_SETTLEMENT_PROBABILITY`
        of the posterior draws (issue 13 step 13, docs/rail.md); "band", the simultaneous band's (conservative;
        the default until 2026-12-06, :meth:`until_2026_12_06`).
    shape_evidence : bool, default False
        With the all-days model and ``check_health``: also flag a sensor "reversed" on the evidence of a dictionary
        of localised settlement shapes fitted to the other sensors (issue 13 step 14, docs/rail.md;
        :func:`~longprofile.rail._shapes.shape_reversal_evidence`, :data:`~longprofile.rail._health.REVERSED_SHAPE_EVIDENCE`).
        Off by default: on the benchmark it found 94 instead of 92 of 100 reversed sensors (faults seeds 200-299;
        95 -> 95 on 100-199) but flagged 2 more healthy sensors of 1020 on asymmetric bowls (0.98 -> 1.18 %).
    shape_rule : {"threshold", "sum"}, default "threshold"
        With ``shape_evidence``: how the shape evidence flags a sensor (:data:`~longprofile.rail._health.SHAPE_RULES`):
        "threshold", its shape log Bayes factor alone above a threshold (step 14); "sum", the sum of its all-days and
        shape log Bayes factors plus half its day-to-day ratio above one threshold (issue 13 step 15, docs/rail.md;
        :data:`~longprofile.rail._health.REVERSED_SUM_LBF`). Not the default: on the benchmark it found 94 of 100
        reversed sensors (faults seeds 200-299, as "threshold"; 96 instead of 95 on 100-199) with one healthy sensor
        fewer flagged, but 14 instead of 12 of 1020 on asymmetric bowls.
    smooth_reversal : bool, default True
        With the all-days model and ``check_health``: also flag a sensor "reversed" on the evidence of a smooth-slope
        (order-3) settlement prior, its predictive variance scaled to the site's own sensors, far above every healthy
        calibration sensor (log Bayes factor > 20) with the day-to-day ratio > 5 (issue 13 step 20, docs/rail.md,
        "Sensor health, step 20"; :func:`~longprofile.rail._smooth_reversal.smooth_reversal_evidence`). False: the
        tests as before (session 41).
    health_end_anchor : {"fixed", "fit", "all-days"}, default "all-days"
        End anchors of the health tests' prediction of a sensor from its neighbours: "fixed", ``sigma_z`` (the default
        until 2026-12-06, :meth:`until_2026_12_06`); "fit", the
        anchor std of largest marginal likelihood from ``sigma_z`` up, re-chosen on the kept sensors before each
        pass (:func:`fit_end_anchor`): a tilt of the whole span is then a rigid rotation, not an anomaly of some
        sensors. Off by default: on calibration seeds it flagged 1 instead of 68 of 494 healthy sensors on tilted
        sites but 10 instead of 7 of 1453 on the Gaussian-bowl ``faults`` sites (docs/rail.md, "Sensor health on
        settlements that are not a bowl"). "all-days" (the default): the anchor chosen by the all-days likelihood of
        step 10 (:func:`fit_end_anchor_all_days`; errors correlated over the days), loosened only past a 0.1 %
        likelihood-ratio test, re-chosen before each pass as "fit" (docs/rail.md, "The end anchor by the all-days
        likelihood": on the benchmark's tilted sites 24 instead of 145 of 1020 healthy sensors flagged, none more on
        the Gaussian-bowl families). The settlement itself keeps ``sigma_z`` either way (see
        ``settlement_end_anchor``).
    reversal_z_rule : {"gated", "alone"}, default "gated"
        How the reversal z of the day-to-day health tests flags a sensor
        (:data:`~longprofile.rail._health.REVERSAL_Z_RULES`): "gated", only when the sensor's day-to-day reversal log-likelihood ratio also exceeds
        :data:`~longprofile.rail._health.REVERSED_Z_GATE_LLR` or, with the all-days model, its all-days log Bayes
        factor exceeds :data:`~longprofile.rail._health.REVERSED_ALL_DAYS_LBF` (issue 13 step 16, docs/rail.md: the z
        treats the days as independent, which a drifting sensor's changes since day 0 are not); "alone", on its own
        (the default until 2026-12-06, :meth:`until_2026_12_06`).
    settlement_end_anchor : {"fixed", "all-days"}, default "all-days"
        End anchors of the settlement itself under the all-days model: "fixed", ``sigma_z`` (assumption 1: the span
        covers the works; the default until 2026-12-06 session 28, :meth:`until_2026_12_06`); "all-days" (the
        default), loosened when the all-days likelihood says the ends move (:func:`_settlement_anchor`: the 0.1 % test
        of ``health_end_anchor="all-days"`` on the settlement's own modes, and the health tests' anchor loosened too),
        e.g. a tilt of the whole span: on the benchmark's tilted sites daily / rate / maximum-settlement coverage
        49.75 / 74.63 / 40.53 % -> 74.56 / 87.78 / 69.75 %, still under 85 %; the five Gaussian-bowl families the same
        to 0.2 points (docs/rail.md, "The settlement's end anchor by default").
        The slopes fix only the end-to-end change, not which end moved: a loosened anchor splits it between the two
        ends and widens the bands by about the anchor std (docs/rail.md, "The end anchor by the all-days likelihood").
    end_ambiguity : {"off", "mixture"}, default "off"
        With ``settlement_end_anchor="all-days"`` and the all-days model: what the bands say when the all-days
        likelihood of *all* sensors (those the health tests excluded included, a sensor flagged reversed
        sign-corrected; no leave-one-out guard) says the span's ends moved. "off": the bands of the anchor as chosen
        (:func:`_settlement_anchor`; the only behaviour until 2026-12-06 session 28, :meth:`until_2026_12_06`).
        "mixture": :func:`_end_mixture`, the bands of an even, sign-symmetric mixture of that estimate and of the
        profile of all sensors but the dead ones with one end fixed (near or far), for a step of the track that only
        an excluded sensor saw (a rail joint) or a tilt whose loosened anchor splits the end-to-end change: on the
        benchmark daily / rate / maximum-settlement coverage of faults-joint-step 64.68 / 77.99 / 39.71 % ->
        85.55 / 90.60 / 80.76 %, faults-tilt 76.76 / 88.23 / 71.60 % -> 89.82 / 94.35 / 85.39 %. Opt-in: it also
        widens the bands of Gaussian-bowl sites whose detached sensor looks like such a step (``faults`` daily
        87.32 -> 91.06 %, faults-none 85.47 -> 96.47 %; docs/rail.md, "The settlement's ends when one sensor carries
        the evidence").
    witness_rule : {"off", "steps", "steps-ends"}, default "off"
        "steps": a sensor whose departure from its neighbours' prediction grows in two separate same-sign steps
        (:func:`~longprofile.rail._health.step_witness_z` above :data:`~longprofile.rail._health.WITNESS_STEP_Z`), never
        steps back as far and does not point to a reversal is kept as the witness of a localised movement (a step at a
        joint or a transition that its neighbours cannot show) instead of being flagged "detached"/"drifting" by the
        step and leave-one-out score tests; the reversal tests still apply (docs/rail.md, "Sensor health on a
        transition: the step's witnesses"). "steps-ends": as "steps", and a witness may carry alone the all-days
        evidence that the span's ends moved (the leave-one-out checks of :func:`fit_end_anchor_all_days` do not leave
        it out; with ``health_end_anchor="all-days"``). "off" (the default, and :meth:`until_2026_12_06`): every test
        as before. Opt-in: on the benchmark's transition sites healthy sensors flagged 51 -> 19 of 1180, but a reversed
        sensor on a transition has a witness's record (faults-joint-step reversed found 35 -> 17 of 40; faults-ramp
        40 -> 27), and the transition's far half stays outside its band (daily coverage 64.44 -> 63.90 % with
        "steps", 65.19 % with "steps-ends").
    reversal_null : {"site", "model"}, default "site"
        What a healthy sensor's reversal statistics are judged against on records longer than the 3-4 weeks the
        thresholds were set on (:data:`~longprofile.rail._health.REVERSAL_NULLS`). "site" (the default since session
        31): the all-days evidence against the spread of the site's own kept sensors beyond the calibration records'
        (:func:`~longprofile.rail._health.site_reversal_null`), and the day-to-day reversal ratio's thresholds times
        :func:`~longprofile.rail._health.record_length_factor` ((n / 27)^(1/3) past 27 day-to-day changes). "model":
        the model's own null and fixed thresholds (the rule until session 31, :meth:`until_2026_12_06`). On sites read
        hourly for 90 / 180 / 365 days (seeds 300-339) healthy sensors flagged 369 -> 163 of 9537, reversed sensors
        found 100 -> 96 of 120; on the benchmark's 28-day families one status changed, a false alarm fewer
        (docs/rail.md, "Sensor health, step 18").
    reinstallations : {"detect", "off"}, default "detect"
        "detect": a sensor whose daily angle resumes after a gap in its readings with a jump its neighbours do not
        show over the same days (:func:`~longprofile.rail._reinstall.find_reinstallations`, a new mounting offset after
        maintenance) is re-baselined: its angle change across the gap is treated as unknown, with a warning naming it
        (docs/rail.md, "Re-installed sensors"). "off": every series is taken as continuous (the rule until session 39).
    events : pandas.DataFrame or None, default None
        Declared re-installations and replacements (:func:`~longprofile.rail._reinstall.check_events`; columns
        sensor_id, date, event, new_id): each starts a new reference of the sensor's series on its date.
    """

    thermal: str = "auto"
    sigma: float | None = None
    rigidity: float | None = None
    penalty_order: int | None = None
    survey_rigidity: float = DEFAULT_RIGIDITY
    sigma_z: float = DEFAULT_SIGMA_Z
    sigma_a: float = DEFAULT_SIGMA_A
    reference_temp_c: float = 5.0
    quiet_days: Any = None
    check_health: bool = True
    exclude_sensors: tuple = ()
    use_affine_correction: bool = False
    through_time: bool = True
    process_std: float | None = None
    settlement_threshold_m: float | None = None
    rate_threshold_m_per_day: float | None = None
    thresholds: Any = None
    alarm_probability: float = 0.5
    n_monte_carlo: int = 1000
    rng: Any = 0
    error_model: str = "drift"
    sensor_noise: bool = True
    spatial_prior: bool = True
    joint_days: bool = True
    max_settlement_interval: str = "draws"
    shape_evidence: bool = False
    shape_rule: str = "threshold"
    smooth_reversal: bool = True
    health_end_anchor: str = "all-days"
    reversal_z_rule: str = "gated"
    settlement_end_anchor: str = "all-days"
    end_ambiguity: str = "off"
    witness_rule: str = "off"
    reversal_null: str = "site"
    reinstallations: str = "detect"
    events: Any = None

    @classmethod
    def until_2026_12_06(cls, **options) -> "SettlementSettings":
        """The defaults before the maximum-settlement interval changed on 2026-12-06 (issue 13 step 13): the
        simultaneous band's interval (``max_settlement_interval="band"``), the fixed end anchors of the health tests
        and of the settlement (``health_end_anchor="fixed"``, ``settlement_end_anchor="fixed"``, the defaults until
        the all-days anchors of the same day, sessions 27 and 28) and the reversal z on its own
        (``reversal_z_rule="alone"``, the default until step 16 of the same day) and the paper's linear thermal model
        (``thermal="linear"``, the default until session 29 of the same day) and the model's null for the reversal
        tests (``reversal_null="model"``, the rule until session 31) and every series taken as continuous
        (``reinstallations="off"``, the rule until session 39) and no smooth-slope reversal test
        (``smooth_reversal=False``, the rule until session 41); reproduces that estimator's outputs.
        ``options`` as the constructor's."""
        return cls(**{"thermal": "linear", "max_settlement_interval": "band", "health_end_anchor": "fixed",
                      "settlement_end_anchor": "fixed",
                      "reversal_z_rule": "alone", "end_ambiguity": "off", "witness_rule": "off",
                      "reversal_null": "model", "reinstallations": "off", "smooth_reversal": False, **options})

    def __post_init__(self):
        require_positive("sigma_z", self.sigma_z)
        require_positive("sigma_a", self.sigma_a)
        if self.sigma is not None:  # a datasheet's ±0.05° is no daily-median noise (_given_sigma)
            object.__setattr__(self, "sigma", check_sigma_range(self.sigma))
        if self.error_model not in ERROR_MODELS:
            raise InputError(f"error_model must be one of {ERROR_MODELS}; got {self.error_model!r}.")
        if self.penalty_order is not None and self.penalty_order not in PENALTY_ORDERS:
            raise InputError(f"penalty_order must be None, 2 or 3; got {self.penalty_order!r}.")
        if self.settlement_threshold_m is not None:
            check_threshold(self.settlement_threshold_m, "settlement")
        if self.rate_threshold_m_per_day is not None:
            check_threshold(self.rate_threshold_m_per_day, "rate")
        if self.thresholds is not None:
            if self.settlement_threshold_m is not None or self.rate_threshold_m_per_day is not None:
                raise InputError("give either thresholds (by quantity and level) or settlement_threshold_m / "
                                 "rate_threshold_m_per_day, not both.")
            object.__setattr__(self, "thresholds", check_thresholds(self.thresholds))
        for name, choices in (("max_settlement_interval", MAX_SETTLEMENT_INTERVALS), ("shape_rule", SHAPE_RULES),
                              ("health_end_anchor", HEALTH_END_ANCHORS), ("reversal_z_rule", REVERSAL_Z_RULES),
                              ("settlement_end_anchor", SETTLEMENT_END_ANCHORS), ("end_ambiguity", END_AMBIGUITIES),
                              ("witness_rule", WITNESS_RULES), ("reversal_null", REVERSAL_NULLS),
                              ("reinstallations", REINSTALL_MODES)):
            if getattr(self, name) not in choices:
                raise InputError(f"{name} must be one of {choices}; got {getattr(self, name)!r}.")
        object.__setattr__(self, "exclude_sensors", tuple(self.exclude_sensors))
        if self.quiet_days is not None:
            object.__setattr__(self, "quiet_days", tuple(self.quiet_days))


def _resolve_settings(settings, options) -> SettlementSettings:
    if settings is None:
        return SettlementSettings(**options)
    if not isinstance(settings, SettlementSettings):
        raise InputError(f"settings must be a SettlementSettings; got {type(settings).__name__}.")
    return replace(settings, **options) if options else settings


def _check_exclusions(ids, exclude_sensors) -> None:
    unknown = sorted(set(exclude_sensors) - set(ids))
    if unknown:
        raise InputError(f"exclude_sensors: unknown sensor id(s) {unknown[:5]}; known ids are like {ids[:3]}.")


#: An altitude change beyond this, m, gets a warning naming the angles' unit (milliradians or mm/m under angle_deg
#: multiply every change by 17.45; found by a user's probe, session 35: a 20 mm bowl printed as 337 mm).
PLAUSIBLE_CHANGE_M = 0.1


def _daily_stage(daily: DailyAngles, opt: SettlementSettings, warnings: list) -> DailyAngles:
    """Checks of the daily angles (§3) and their warnings; at least 2 days."""
    ids = daily.sensor_ids
    D = daily.days.size
    if D < 2:
        raise InputError(f"the readings cover {D} day; at least 2 days are needed to see a change.")
    warnings.extend(daily.warnings)
    empty = ~np.isfinite(daily.change_deg).any(axis=1)
    if empty.any() and not empty.all():  # e.g. a day when the loggers sent angles but no sensor a temperature
        dates = pd.DatetimeIndex(daily.days[empty]).strftime("%Y-%m-%d").tolist()
        warnings.append(f"{int(empty.sum())} day(s) without a usable daily angle on any sensor ({dates[:5]}: no "
                        "reading with both an angle and a temperature that day?); they are left out of the "
                        "estimate and the output.")
        daily = daily.select_days(~empty)
        D = daily.days.size
        if D < 2:
            raise InputError(f"the readings cover {D} usable day; at least 2 days are needed to see a change.")
    daily = _partial_first_days(daily, warnings)
    gaps = np.diff(daily.days).astype("timedelta64[D]").astype(int)
    if (gaps > 1).any():
        first = pd.Timestamp(daily.days[int(np.argmax(gaps > 1))]) + pd.Timedelta(days=1)
        warnings.append(f"{int((gaps - 1).sum())} calendar day(s) without readings (the first {first:%Y-%m-%d}): the "
                        "settlement is given on the days with readings, and the rate after a gap is the mean daily rate "
                        "over it.")
    n_out = int(daily.n_outliers.sum())
    if n_out:
        warnings.append(f"{n_out} outlier reading(s) set aside (> {8:g} robust std from their running median), "
                        f"most on {ids[int(np.argmax(daily.n_outliers))]} ({int(daily.n_outliers.max())}).")
    if daily.days.size == 2 and opt.sigma is None:
        warnings.append(_TWO_DAYS)
    return daily


#: The warning of a 2-day record (:func:`daily_noise_sigma` with one change day; docs/rail.md, "A user's probe").
_TWO_DAYS = ("a 2-day record: one change, whose noise is that day's scatter of the sensors about their neighbours (no "
             "growth over the days can be fitted, and the health tests see one change per sensor); on 2-day cuts of "
             "the simulated presets the 90 % band covered 92.5 % (mittersheim-like) and 95.6 % (farebersviller-like) "
             "of the true settlement; each further day adds to what the noise and the health tests rest on.")


def _partial_first_days(daily: DailyAngles, warnings: list) -> DailyAngles:
    """``daily`` without its first days that hold less than ``DailyAngles.PARTIAL_DAY_SHARE`` of the median day's readings
    (all sensors; at least 2 days kept). The first day is every later day's reference: a daily angle from part of a
    day carries part of the daily thermal cycle into every change (a record that starts at 23:00 excluded two
    healthy sensors, installation tests the day before three; session 35)."""
    share = daily.reading_shares()
    k = 0
    while k < daily.days.size - 2 and share[k] < daily.PARTIAL_DAY_SHARE:
        k += 1
    if k:
        dates = pd.DatetimeIndex(daily.days[:k]).strftime("%Y-%m-%d").tolist()
        shares = ", ".join(f"{100 * v:.0f} %" for v in share[:k][:3])
        warnings.append(f"the first {k} day(s) ({dates[:3]}) hold {shares} of a usual day's readings (a record that "
                        "starts late in the day, installation tests, or times converted to UTC from another zone?): a "
                        "daily angle from part of a day carries part of the daily thermal cycle into every later change, "
                        f"so they are left out and {pd.Timestamp(daily.days[k]):%Y-%m-%d} is the reference day.")
        daily = daily.select_days(np.arange(daily.days.size) >= k)
    return daily


def _slope_changes(site: SiteData, daily: DailyAngles, opt: SettlementSettings):
    """Initial profile from the survey (§4.4) and the slope changes tan(theta0 + m) - tan(theta0)."""
    x, sv = site.x, site.survey
    initial = initial_profile_posterior(x, sv["x_m"].to_numpy(), sv["z_m"].to_numpy(), sigma_a=opt.sigma_a,
                                        rigidity=opt.survey_rigidity)
    theta0 = np.arctan(initial.slope_mean)
    change = np.deg2rad(daily.change_deg)
    slopes = np.tan(theta0[None, :] + change) - np.tan(theta0)[None, :]
    return initial, slopes


def _check_given_sigma(x, slopes, opt: SettlementSettings, warnings: list) -> None:
    """A given ``sigma`` against the data's noise, the median over the days after the first of
    :func:`day_noise_variances` of every sensor with a daily angle (robust to a settlement, unlike the day-to-day
    differences on a short record with works: 2e-3 instead of 8e-4 deg on a 3-day cut of mittersheim-like)
    (:func:`~longprofile.rail._given_sigma.compare_with_estimate`: a warning, or InputError when far off); nothing
    when none was given or fewer than 5 sensors have an angle."""
    if opt.sigma is None:
        return
    ok = np.isfinite(slopes).any(axis=0)
    v = day_noise_variances(x[ok], slopes[1:, ok]) if ok.sum() >= 5 else np.array([np.nan])
    if not np.isfinite(v).any():  # too few sensors: only the plausible range was checked (SettlementSettings)
        return
    estimate = float(np.sqrt(np.nanmedian(v)))
    if estimate > 0 and (message := compare_with_estimate(opt.sigma, estimate, source="the sensors' departures "
                                                          "from their neighbours, median over the days")):
        warnings.append(message)


def _anchor_fitter(x, daily: DailyAngles, opt: SettlementSettings):
    """``fit_anchor(slopes_masked) -> sigma_z`` of the health tests (``opt.health_end_anchor``), None when fixed."""
    if opt.health_end_anchor == "fit":
        return lambda M: fit_end_anchor(x, M, sigma=opt.sigma, sigma_z=opt.sigma_z)[0]
    if opt.health_end_anchor == "all-days":
        t = np.asarray((pd.DatetimeIndex(daily.days) - pd.Timestamp(daily.days[0])) / pd.Timedelta(days=1), float)
        dT = _site_temperature_change(daily)

        def fit(M, witnesses=None):
            if M.shape[0] - 1 < 5 or (np.isfinite(M).sum(axis=0) > 0).sum() < 5:
                return opt.sigma_z  # too short for the all-days model (as _joint_stage)
            try:
                return fit_end_anchor_all_days(x, M, day_offsets=t, temperature_change=dT, sigma=opt.sigma,
                                               sigma_z=opt.sigma_z, witnesses=witnesses)[0]
            except InputError:  # no change on any day, too few noisy days: nothing to loosen the anchor for
                return opt.sigma_z
        return fit
    return None


def _anchor_witnesses(health: SensorHealth, opt: SettlementSettings):
    """The kept witnesses (``health.witness``) with ``witness_rule="steps-ends"`` when there are any, else None."""
    if opt.witness_rule != "steps-ends" or health.witness is None:
        return None
    w = np.asarray(health.witness, bool) & ~np.asarray(health.excluded, bool)
    return w if w.any() else None


def _health_stage(x, ids, slopes, daily: DailyAngles, opt: SettlementSettings, warnings: list):
    """Sensor health (§6) and the slope changes of the kept sensors (NaN elsewhere, affine-corrected if asked)."""
    excl_idx = [ids.index(s) for s in opt.exclude_sensors]
    # health checks need a prior as stiff as the data allow (a loose prior predicts nothing from the
    # neighbours), so they always use the maximum-likelihood r of the paper's prior (penalty order 2); the
    # settlement then uses its own change prior (``rigidity``/``penalty_order`` or the maximum-likelihood fit).
    # their prediction lets both ends move when the data say so (a tilt of the whole span, fit_end_anchor)
    # of the kept sensors, before each pass (a detached sensor's jump also moves the ends)
    fit_anchor = _anchor_fitter(x, daily, opt)
    fit = (lambda M, s, r, sz: fit_noise_and_rigidity(x, M, sigma=opt.sigma, rigidity=None, sigma_z=sz))
    sz = opt.sigma_z
    s0, r0 = fit(slopes, None, None, sz)
    day_spread = np.where(daily.n_readings >= FROZEN_MIN_READINGS, daily.raw_day_spread_deg, np.nan)
    health, sig, rig = assess_sensors(x, slopes, sigma=s0, rigidity=r0, sigma_z=sz,
                                      raw_spread_deg=daily.raw_std_deg, raw_day_spread_deg=day_spread,
                                      exclude=excl_idx, max_flagged=None if opt.check_health else 0, fit=fit,
                                      fit_anchor=fit_anchor, reversal_z_rule=opt.reversal_z_rule,
                                      witness_rule=opt.witness_rule, reversal_null=opt.reversal_null)
    health = replace(health, sensor_ids=list(ids))
    witnesses = _anchor_witnesses(health, opt)
    if witnesses is not None and opt.health_end_anchor == "all-days":
        # "steps-ends": a witness may carry the evidence that the ends moved (the anchor's leave-one-out checks)
        health = replace(health, anchor_std=fit_anchor(np.where(health.excluded[None, :], np.nan, slopes), witnesses))
    sz = health.anchor_std
    for sid, st, why in health.flagged():
        warnings.append(f"sensor {sid} excluded by the user." if st == USER_EXCLUDED else
                        f"sensor {sid} excluded ({st}): {why}.")
    for j in np.flatnonzero(health.excluded_witness if health.excluded_witness is not None else []):
        warnings.append(_EXCLUDED_WITNESS.format(sid=ids[j], status=health.status[j], x=x[j]))
    for j in np.flatnonzero(health.witness if health.witness is not None else []):
        warnings.append(f"sensor {ids[j]} kept although its departure from its neighbours is beyond the step test: it "
                        "grew in separate steps of one sign, as a witness of a localised movement of the track would "
                        "(witness_rule='steps').")
    if health.excluded[0] or health.excluded[-1]:
        warnings.append("an end sensor is excluded: the end anchor still holds at its station, but the angle there "
                        "is only known through the rigidity prior.")
    warnings.extend(_gap_warnings(x, ids, health.excluded))
    M = np.where(health.excluded[None, :], np.nan, slopes)
    if opt.use_affine_correction:
        M = affine_correction(x, M, ~health.excluded)
        warnings.append("affine correction of §5.2 applied: end sensors forced to read no change; the paper warns it "
                        "is not robust (it helped one track and degraded the other).")
    return health, M, sz


#: A run of at least this many consecutive excluded sensors gets a warning (:func:`_gap_warnings`): on `drift` sites
#: (seeds 100-139) the daily 90 % band at the stations of K consecutive sensors left out covered 87.6 / 87.4 / 84.5 /
#: 82.5 / 80.1 % for K = 2 / 3 / 4 / 6 / 8 (docs/rail.md, "A failed temperature channel").
GAP_WARN_SENSORS = 4


def _gap_warnings(x, ids, excluded) -> list[str]:
    """One warning per run of >= :data:`GAP_WARN_SENSORS` consecutive excluded sensors: the settlement between the
    kept sensors on either side is the prior's interpolation, and a bowl inside the gap is not seen."""
    ex = np.concatenate([[False], np.asarray(excluded, bool), [False]])
    starts = np.flatnonzero(~ex[:-1] & ex[1:])
    ends = np.flatnonzero(ex[:-1] & ~ex[1:])
    out = []
    for a, b in zip(starts, ends):  # sensors a .. b - 1 excluded
        if b - a < GAP_WARN_SENSORS:
            continue
        left = f"{ids[a - 1]}" if a > 0 else "the span's start"
        right = f"{ids[b]}" if b < len(ids) else "the span's end"
        out.append(f"{b - a} consecutive sensors excluded ({ids[a]} to {ids[b - 1]}, x = {x[a]:g} to {x[b - 1]:g} m): "
                   f"between {left} and {right} the settlement is the prior's smooth interpolation, which cannot see "
                   "a bowl inside the gap, and its bands there are too narrow if one is there (docs/rail.md, \"Not "
                   "done / limits\").")
    return out


#: The warning for a sensor excluded by the step or leave-one-out tests whose record was a witness's
#: (``SensorHealth.excluded_witness``; docs/rail.md, "Sensor health: an excluded sensor that may be a witness").
_EXCLUDED_WITNESS = ("sensor {sid} was excluded ({status}), but its departure from its neighbours grew in separate "
                     "steps of one sign, as a settling transition at x = {x:g} m (a joint, an abutment, a culvert) "
                     "would show it, seen by this sensor alone; if the track can step there, the settlement beyond "
                     "it is not what is printed: check with a levelling survey (--controls), or keep such sensors "
                     "with --witness-rule steps and widen the bands with --end-ambiguity mixture.")
#: The warning when the health tests stopped at their limit (a quarter of the sensors they examine, i.e. all but the
#: user's exclusions; dead and user-excluded ones not counted among the flags: :func:`~longprofile.rail._health.flag_limit`,
#: :func:`~longprofile.rail._health.n_flagged`).
_HEALTH_CAPPED = ("the health tests stopped at their limit: {n} of {N} sensors excluded as faulty (a quarter). So many "
                  "independent faults are unlikely; a cause common to many sensors is likelier: {given}a thermal response the "
                  "model does not follow (thermal model '{thermal}'; try --thermal lagged), angles in another unit or "
                  "sign convention, or a settlement the instrumented span does not contain. Check the excluded sensors "
                  "before trusting the result (docs/rail.md, \"Sensor health\").")


def _warn_if_health_capped(health, opt: SettlementSettings, warnings: list, daily: DailyAngles | None = None) -> None:
    """Warn when the tests flagged as many sensors as they may (:data:`_HEALTH_CAPPED`)."""
    if not opt.check_health:
        return
    status = np.asarray(health.status)
    n = n_flagged(status)
    if n >= max(2, flag_limit(status)):
        N = int((status != USER_EXCLUDED).sum())  # the sensors the tests examined
        given = ("" if opt.sigma is None else f"the noise std given (sigma = {np.rad2deg(opt.sigma):.3g} deg, CLI "
                 "--sigma-deg), if far from the data's noise (leave it out to estimate it), ")
        warnings.append(_HEALTH_CAPPED.format(n=n, N=N, thermal=opt.thermal if daily is None else daily.thermal,
                                              given=given))


def _noise_stage(daily: DailyAngles, x, M, days, opt: SettlementSettings):
    """Slope-change noise: (sigma, sigma of each day, drift model used?, per-sensor factors or None)."""
    D = days.size
    sig = float(opt.sigma) if opt.sigma is not None else day_difference_sigma(M)
    drift = opt.error_model == "drift" and opt.sigma is None
    if drift:
        t_days = (pd.DatetimeIndex(days) - pd.Timestamp(days[0])) / pd.Timedelta(days=1)
        # floor at half the day-to-day noise: a fit driven by the thermal term alone would otherwise give the
        # days at the reference temperature no noise at all (a floor at the full day-difference sigma made
        # mittersheim-like over-cover: 95.6 %)
        sig_days = daily_noise_sigma(x, M, day_offsets=np.asarray(t_days, float),
                                     temperature_change=_site_temperature_change(daily), floor=0.5 * sig)
        sig = float(np.median(sig_days[1:]))
        factors = sensor_noise_factors(x, M) if opt.sensor_noise else None
    else:
        sig_days = np.full(D, sig)
        factors = None
    return sig, sig_days, drift, factors


def _change_prior_stage(x, M, sig, sig_days, drift, factors, opt: SettlementSettings, warnings: list):
    """Prior of the change profile: (fit or None, penalty order, r, sigma, sigma of each day, drift, factors)."""
    if opt.rigidity is None:
        orders = PENALTY_ORDERS if opt.penalty_order is None else (opt.penalty_order,)
        prior_fit = fit_change_prior(x, M, sigma=sig_days if drift else sig, sigma_z=opt.sigma_z,
                                     penalty_orders=orders, sensor_factors=factors)
        order, rig = prior_fit.penalty_order, prior_fit.rigidity
        if drift and prior_fit.log_likelihood[order] - prior_fit.stiffest_log_likelihood[order] < STIFFEST_LR:
            # the stiffest prior of the grid (no change) is not rejected (STIFFEST_LR): with the per-day noise the
            # likelihood cannot tell the bowl from the noise (a weak bowl under strong drift, or a bowl spanning most
            # of a sparse site that inflated the noise estimate) and the stiffest prior would claim "no change, no
            # doubt". The prior is then fitted with the day-difference sigma (where the bowl stands out) and the
            # per-day noise is kept: before issue 13 step 7 the white noise model replaced it, whose late-day sigma is 5-10 times too
            # small on drifting sites (coverage 70-90 % on 3 of 24 calibration drift sites, 99-100 % now).
            warnings.append("error_model='drift': with the per-day noise the likelihood does not reject the prior "
                            "at its stiffest (the settlement cannot be told from the noise); the prior is fitted with "
                            "the day-to-day noise instead, the per-day noise is kept.")
            white = float(day_difference_sigma(M))
            prior_fit = fit_change_prior(x, M, sigma=white, sigma_z=opt.sigma_z, penalty_orders=orders)
            order, rig = prior_fit.penalty_order, prior_fit.rigidity
    else:
        prior_fit = None
        order = 2 if opt.penalty_order is None else int(opt.penalty_order)
        rig = float(opt.rigidity)
    return prior_fit, order, rig, sig, sig_days, drift, factors


def _chain_integrations(x, M, health: SensorHealth, initial: ProfilePosterior) -> dict:
    """§2 chain integrations on the same slope changes (excluded sensors interpolated from neighbours)."""
    ok = ~health.excluded
    Mi = np.array([np.interp(x, x[ok & np.isfinite(row)], row[ok & np.isfinite(row)]) for row in M])
    bar0 = bar_angles_from_profile(x, initial.z_mean)
    bar_change = Mi[:, :-1]  # §2: sensor i measures the bar from sensor i to i+1
    return {meth: integrate_angles(x, np.arctan(np.tan(bar0)[None, :] + bar_change), method=meth)
            - integrate_angles(x, bar0, method=meth)[None, :] for meth in INTEGRATION_METHODS}


def _max_settlement_stage(x, M, sig_days, rig, order, opt: SettlementSettings, factors=None, weights=None):
    """Monte Carlo mean, std and 90 % interval (lower, upper) of the maximum settlement of each day (§4.3), NaN when
    skipped."""
    D = sig_days.size
    out = np.full((4, D), np.nan)
    if opt.n_monte_carlo > 0:
        gen = np.random.default_rng(opt.rng)
        for idx, s in _noise_groups(sig_days):
            ms = max_settlement_interval(x, M[idx], int(opt.n_monte_carlo), sigma=_station_sigma(s, factors),
                                         rigidity=rig, sigma_z=opt.sigma_z, rng=gen, penalty_order=order,
                                         segment_weights=weights, level=0.9,
                                         interval=opt.max_settlement_interval)
            out[:, idx] = ms.mean, ms.std, ms.lower, ms.upper
    return tuple(out)


def _through_time_stage(site: SiteData, days, post, sig_days, drift, opt: SettlementSettings, smoothed=None):
    """Through-time smoothing and rates (or the given ``smoothed``: the all-days posterior), alarms, control
    comparison: (smoothed, dz_std, alarms, controls)."""
    ids, x, sv = site.sensor_ids, site.x, site.survey
    dz_std = np.array(post["z_std"])
    if smoothed is not None:
        smoothed = smoothed if opt.through_time else None
    elif opt.through_time:
        smoothed = smooth_through_time(post["z_mean"], dz_std, process_std=opt.process_std,
                                       noise_variance_by_day=sig_days**2 if drift else None)
    else:
        smoothed = None
    if smoothed is not None:
        smoothed = _per_calendar_day(smoothed, days)
    src_mean = smoothed.mean if smoothed is not None else post["z_mean"]
    src_std = smoothed.std if smoothed is not None else dz_std
    rate = (None, None) if smoothed is None else (smoothed.rate, smoothed.rate_std)
    if opt.thresholds is not None:
        alarms = threshold_alarms(days, ids, x, src_mean, src_std, opt.thresholds, rate=rate[0], rate_std=rate[1],
                                  min_probability=opt.alarm_probability)
    else:
        alarms = settlement_alarms(days, ids, x, src_mean, src_std, threshold_m=opt.settlement_threshold_m,
                                   rate=rate[0], rate_std=rate[1], rate_threshold_m_per_day=opt.rate_threshold_m_per_day,
                                   min_probability=opt.alarm_probability)
    controls = compare_controls(site.controls, days, x, src_mean, src_std, sv["x_m"].to_numpy(), sv["z_m"].to_numpy(),
                                sigma_a=opt.sigma_a)
    return smoothed, dz_std, alarms, controls


def _per_calendar_day(smoothed: TemporalSettlement, days) -> TemporalSettlement:
    """The rate and its std per calendar day: a change between two days with readings that are k days apart (days
    without readings between them) divided by k (found by a user's probe, session 35: a 3-day change was printed as
    one day's rate and raised rate alarms)."""
    gaps = np.diff(np.asarray(days, "datetime64[D]")).astype(float)
    if gaps.size == 0 or (gaps == 1.0).all():
        return smoothed
    rate, rate_std = smoothed.rate.copy(), smoothed.rate_std.copy()
    rate[1:] /= gaps[:, None]
    rate_std[1:] /= gaps[:, None]
    return replace(smoothed, rate=rate, rate_std=rate_std)


def _spatial_prior_stage(x, M, sig_days, drift, factors, rig, order, opt: SettlementSettings):
    """Segment weights of the change prior (:func:`segment_prior_weights`) or None (stationary prior)."""
    if not opt.spatial_prior or opt.rigidity is not None:
        return None
    return segment_prior_weights(x, M, sigma=sig_days if drift else float(sig_days[0]), rigidity=rig,
                                 penalty_order=order, sigma_z=opt.sigma_z, sensor_factors=factors)


@dataclass(frozen=True, eq=False)
class _JointFit:
    """What the all-days model (:func:`_joint_stage`) gives the rest of the pipeline."""

    noise: Any            # DayNoiseCovariance
    prior: IncrementPrior
    modes: DayModes
    weights: np.ndarray | None
    mode_slopes: np.ndarray  # (D-1, N) data of the modes
    post: dict            # (D, N) z_mean, z_std, slope_mean, slope_std, noise_std
    smoothed: TemporalSettlement
    sigma: float
    sigma_by_day: np.ndarray
    factors: np.ndarray | None
    sigma_z: float = DEFAULT_SIGMA_Z  # the settlement's end-anchor std (settlement_end_anchor)
    end_shift: np.ndarray | None = None  # (2, D, N) the second hypothesis' means minus the first's (_end_mixture)
    end_weight: float = 0.0  # the second hypothesis' weight (_end_mixture)
    end_sigma_z: float | None = None  # its end-anchor std
    imputed_mode_slopes: np.ndarray | None = None  # (n, D-1, N) the modes' data of completed records (_impute_missing)
    timing_shift: np.ndarray | None = None  # (D, N) the outages' timing differences (_outage_timing_shift)
    timing_group: np.ndarray | None = None  # (D, N) int: the outage span of each shifted entry, -1 elsewhere


#: Records completed by draws of the missing sensor-days (:func:`_impute_missing`) among which the maximum
#: settlement's Monte Carlo draws are shared (docs/rail.md, "Logger outages").
MISSING_DAY_IMPUTATIONS = 8
#: A read neighbour's change across an outage, in its band's stds, above which its timing is evidence of the
#: outage sensors' (:func:`_outage_timing_shift`; docs/rail.md, "Logger outages: the timing of the change").
TIMING_MIN_CHANGE = 2.0
#: Most missing sensor-days treated as missing (:func:`_impute_missing`: 2 |J| + 2 posterior calls and a |J| x |J|
#: matrix, 72 MB at this count); beyond, they stay interpolated, with a warning.
MISSING_DAY_MAX = 3000


def _missing_summary(ids, days, M, limit: int = 4) -> str:
    """The sensor-days without a daily angle of the kept sensors (those with some), compactly: neighbouring sensors
    missing on the same days share one entry, e.g. "S30-S45 on 2019-12-05..09; S3 on 2019-12-11" (at most ``limit``
    entries, then how many more)."""
    miss = np.isnan(np.asarray(M, float))
    part = miss.any(axis=0) & ~miss.all(axis=0)
    dates = pd.DatetimeIndex(days)

    def runs(col):  # the sensor's missing days as "first..last" runs of consecutive rows
        d = np.flatnonzero(col)
        cut = np.flatnonzero(np.diff(d) > 1)
        out = []
        for a, b in zip(np.r_[d[0], d[cut + 1]], np.r_[d[cut], d[-1]]):
            first, last = dates[a], dates[b]
            out.append(f"{first:%Y-%m-%d}" if a == b else
                       f"{first:%Y-%m-%d}..{last:%d}" if (first.year, first.month) == (last.year, last.month)
                       else f"{first:%Y-%m-%d}..{last:%Y-%m-%d}")
        return ", ".join(out)

    groups = []  # [first sensor, last sensor, runs] of neighbouring partly-missing sensors with the same runs
    for j in np.flatnonzero(part):  # (sensors without any daily angle, i.e. excluded, between them do not part them)
        r = runs(miss[:, j])
        if groups and groups[-1][2] == r and miss[:, groups[-1][1] + 1:j].all():
            groups[-1][1] = j
        else:
            groups.append([j, j, r])
    text = [f"{ids[a]}{'' if a == b else '-' + str(ids[b])} on {r}" for a, b, r in groups[:limit]]
    more = f"; and {len(groups) - limit} more sensor group(s)" if len(groups) > limit else ""
    return "; ".join(text) + more


def _fill_missing_days(M, t):
    """Slope changes with a sensor's missing days (not all of them) filled by linear interpolation over the days
    (flat beyond its first and last): (filled (D, N), number of sensor-days filled)."""
    M = np.array(M, float)
    miss = np.isnan(M)
    part = miss.any(axis=0) & ~miss.all(axis=0)
    for j in np.nonzero(part)[0]:
        ok = ~miss[:, j]
        M[~ok, j] = np.interp(t[~ok], t[ok], M[ok, j])
    return M, int(miss[:, part].sum())


def _joint_stage(x, M, days, daily: DailyAngles, sig, factors, opt: SettlementSettings, warnings: list,
                 health_sz: float | None = None):
    """The all-days posterior (module :mod:`~longprofile.rail._joint`; docs/rail.md step 10), or None when it does
    not apply (``joint_days=False``, a given rigidity, fewer than 5 day-to-day changes or usable sensors).
    ``health_sz``: the health tests' end anchor on the same sensors (:func:`_settlement_anchor`)."""
    D = days.size
    if not opt.joint_days or opt.rigidity is not None or D - 1 < 5 or (np.isfinite(M).sum(axis=0) > 0).sum() < 5:
        return None
    t = np.asarray((pd.DatetimeIndex(days) - pd.Timestamp(days[0])) / pd.Timedelta(days=1), float)
    observed = np.asarray(M, float)
    M, n_filled = _fill_missing_days(M, t)
    exact = n_filled <= MISSING_DAY_MAX
    where = _missing_summary(daily.sensor_ids, days, observed) if n_filled else ""
    if n_filled and exact:
        warnings.append(f"{n_filled} sensor-day(s) without a daily angle ({where}): the all-days model's noise and "
                        "prior were fitted without them, and its settlement and bands treat them as missing; the "
                        "output's 'measured' column marks them (docs/rail.md, \"Logger outages\").")
    elif n_filled:
        warnings.append(f"{n_filled} sensor-day(s) without a daily angle ({where}) were filled by linear interpolation "
                        "over the days of their sensor and counted as measured (too many to treat as missing): the "
                        "bands on and after those days are too narrow (docs/rail.md, \"Logger outages\").")
    seen = observed if n_filled else None
    noise, prior, weights, jp = _joint_fit(x, M, t, daily, sig, factors, opt, seen)
    for _ in range(JOINT_FACTOR_REFITS if factors is not None else 0):
        quiet = prior.rigidity_by_day <= (1.0 + 1e-9) * prior.rigidity_by_day.min()
        factors = residual_noise_factors(observed, jp.slope_mean, quiet, reference_factors=factors)
        noise, prior, weights, jp = _joint_fit(x, M, t, daily, sig, factors, opt, seen)
    sz = _settlement_anchor(x, jp, prior.penalty_order, factors, weights, opt, health_sz)
    if sz != opt.sigma_z:
        noise, prior, weights, jp = _joint_fit(x, M, t, daily, sig, factors, replace(opt, sigma_z=sz), seen)
    modes = jp.modes
    post = {k: getattr(jp, k) for k in ("z_mean", "z_std", "slope_mean", "slope_std", "noise_std")}
    rate_std, imputed = jp.rate_std, None
    if n_filled and exact or daily.rebaselined is not None:
        # a child stream: the maximum settlement's draws start from opt.rng itself, and must not reuse these numbers
        post, rate_std, imputed = _impute_missing(x, observed, M, jp, noise.cov, prior.penalty_order, factors, weights,
                                                  sz, np.random.default_rng(opt.rng).spawn(1)[0],
                                                  segments=daily.rebaselined)
    shift = group = None
    if n_filled and exact:  # the outages' timing (docs/rail.md, "Logger outages: the timing of the change")
        shift, group = _outage_timing_shift(x, post["z_mean"], post["z_std"], observed, M)
        z_std, rate_std = _with_timing_shift(post["z_std"], rate_std, shift)
        post = {**post, "z_std": z_std}
    rate = np.full(M.shape, np.nan)
    rate[1:] = np.diff(post["z_mean"], axis=0)
    smoothed = TemporalSettlement(mean=post["z_mean"], std=post["z_std"], rate=rate, rate_std=rate_std,
                                  process_std=float("nan"))
    sig_days = np.sqrt(np.diag(noise.cov))
    sig_days = np.r_[sig_days[0], sig_days]
    return _JointFit(noise=noise, prior=prior, modes=modes, weights=weights, mode_slopes=jp.mode_slopes, post=post,
                     smoothed=smoothed, sigma=float(np.median(sig_days[1:])), sigma_by_day=sig_days, factors=factors,
                     sigma_z=sz, imputed_mode_slopes=imputed, timing_shift=shift, timing_group=group)


def _missing_runs(col):
    """(first, last) rows of each run of consecutive True entries of a boolean column."""
    d = np.flatnonzero(col)
    if d.size == 0:
        return []
    cut = np.flatnonzero(np.diff(d) > 1)
    return list(zip(np.r_[d[0], d[cut + 1]].tolist(), np.r_[d[cut], d[-1]].tolist()))


def _with_timing_shift(z_std, rate_std, shift):
    """(z std, rate std) of the all-days posterior widened by the outages' timing shift delta
    (:func:`_outage_timing_shift`): the band of the mixture "mean +/- delta" (both timings), about the unchanged mean,
    sqrt(z_std^2 + delta^2) and, for the daily rate, sqrt(rate_std^2 + (delta_t - delta_{t-1})^2) (row 0 stays NaN)."""
    shift = np.asarray(shift, float)
    return (np.sqrt(np.asarray(z_std, float) ** 2 + shift**2),
            np.sqrt(np.asarray(rate_std, float) ** 2 + np.diff(shift, axis=0, prepend=np.nan) ** 2))


def _outage_timing_shift(x, z_mean, z_std, observed, filled):
    r"""The difference, on each missing sensor-day, between the all-days mean and the mean the nearest read
    sensors' timing gives (beyond paper 004; docs/rail.md, "Logger outages: the timing of the change").

    For a kept sensor j (``filled`` finite) unread on days a+1..b-1 (``observed`` NaN) and read on days a >= 0 and
    b <= D-1, the all-days posterior (:func:`_impute_missing`) observes its change Delta = z_b - z_a and shares it
    among the unread days as its Gaussian increments allow: a ramp, whatever the track did. Its nearest kept sensors
    k on each side read on every day a..b changed by Delta_k, reaching the fractions
    c_k(t) = clip((z_k(t) - z_k(a)) / Delta_k, 0, 1) by day t (a step on a work day: 0, then 1). Those whose change is
    clearly more than its band, |Delta_k| > :data:`TIMING_MIN_CHANGE` * hypot(std_k(a), std_k(b)), give the timing
    C = sum_k |Delta_k| c_k / sum_k |Delta_k| and the alternative mean z_a + Delta C(t); the result is

    .. math:: \delta_j(t) = z_a + \Delta\, C(t) - z_t

    (0 outside the runs, on a run that starts on day 0 or reaches the last day, and where no neighbour changed that
    clearly). The printed mean stays z_t; the band holds both timings (:func:`_with_timing_shift`), and the maximum
    settlement's draws are shifted by +/- delta, one sign per draw and outage span (:func:`_joint_max_settlement`).

    Returns
    -------
    shift : (D, N) ndarray
    group : (D, N) int ndarray
        The index of each shifted entry's span (its first and last unread days), -1 elsewhere.
    """
    z, sd = np.asarray(z_mean, float), np.asarray(z_std, float)
    kept = np.isfinite(np.asarray(filled, float)).all(axis=0)
    miss = np.isnan(np.asarray(observed, float)) & kept[None, :]
    x = np.asarray(x, float)
    D, N = z.shape
    shift = np.zeros((D, N))
    group = np.full((D, N), -1)
    spans: dict = {}
    for j in np.flatnonzero(miss.any(axis=0) & kept):
        for first, last in _missing_runs(miss[:, j]):
            a, b = first - 1, last + 1
            if a < 0 or b >= D:
                continue
            ok = kept & ~miss[a:b + 1].any(axis=0)
            left, right = np.flatnonzero(ok & (x < x[j])), np.flatnonzero(ok & (x > x[j]))
            near = ([left[np.argmax(x[left])]] if left.size else []) + ([right[np.argmin(x[right])]] if right.size
                                                                          else [])
            change = np.array([z[b, k] - z[a, k] for k in near])
            spread = np.array([np.hypot(sd[a, k], sd[b, k]) for k in near])
            use = np.abs(change) > TIMING_MIN_CHANGE * spread
            if not use.any():
                continue
            frac = np.array([np.clip((z[first:b, k] - z[a, k]) / c, 0.0, 1.0) for k, c in zip(near, change)])[use]
            timing = np.abs(change[use]) @ frac / np.abs(change[use]).sum()
            shift[first:b, j] = z[a, j] + (z[b, j] - z[a, j]) * timing - z[first:b, j]
            group[first:b, j] = spans.setdefault((first, last), len(spans))
    return shift, group


def _impute_missing(x, observed, filled, jp, noise_cov, order, factors, weights, sigma_z, rng,
                    n_records: int = MISSING_DAY_IMPUTATIONS, segments=None):
    r"""The all-days posterior with the sensor-days that have no daily angle treated as missing (beyond paper 004).

    The modes of :func:`~longprofile.rail._joint.joint_posterior` need every kept sensor on every day, so a missing
    sensor-day was filled by interpolation and then counted as measured: its band did not widen. The posterior given
    the observed days alone is exact here, from the complete-data posterior and its responses. With m the slope
    changes of days 1..D-1 (every kept sensor), theta the settlement's, m = theta + e, e of sensor i ~ N(0, f_i^2 R),
    the posterior mean is linear, theta_hat = H m (one ``joint_posterior`` call per data), and the precision of m is
    Lambda = Sigma_e^{-1} (I - H). For the missing entries J (observed O):

        E[m_J | m_O] = -(Lambda_JJ)^{-1} Lambda_JO m_O,   Cov[m_J | m_O] = (Lambda_JJ)^{-1},
        E[theta | m_O] = H m*,   Cov[theta | m_O] = Cov[theta | m] + H_J Cov[m_J | m_O] H_J^T,

    m* the record completed by E[m_J | m_O]. Lambda_JJ's columns come from the posterior means of unit data at each
    missing entry, and diag(H_J Cov H_J^T) from the posterior means of the columns of a square root of Cov put at the
    entries: 2 |J| + 2 calls, memory O(D N + |J|^2). The same for z and the rate. The day covariance R, the increment
    prior and the factors are fitted without the missing days (:func:`_joint_fit`'s ``observed``), the segment
    weights and the end anchor on the interpolated record, and all are taken as known (named assumptions,
    docs/rail.md, "Logger outages").

    Returns
    -------
    post : dict
        ``z_mean``, ``z_std``, ``slope_mean``, ``slope_std``, ``noise_std`` (the last unchanged), (D, N) each.
    rate_std : (D, N) ndarray
    records : (n_records, D-1, N) ndarray
        The modes' data of records completed by draws of m_J from N(E[m_J | m_O], Cov[m_J | m_O]), for the maximum
        settlement's draws (:func:`_joint_max_settlement`).
    """
    obs = np.asarray(observed, float)[1:]
    kept = np.isfinite(np.asarray(filled, float)[1:]).all(axis=0)
    missing = np.isnan(obs) & kept[None, :]
    days, cols = np.nonzero(missing)
    f2 = (np.ones(kept.size) if factors is None else np.asarray(factors, float)) ** 2
    base = np.where(kept[None, :], 0.0, np.nan) * np.ones_like(obs)  # excluded sensors stay NaN

    def posterior(data):
        return joint_posterior(x, np.vstack([np.zeros((1, kept.size)), data]), jp.modes, penalty_order=order,
                               sensor_factors=factors, sigma_z=sigma_z, segment_weights=weights)

    def precision_times(data, fitted):  # Sigma_e^{-1} (data - fitted), sensor by sensor over the days
        return np.linalg.solve(noise_cov, np.nan_to_num(data - fitted)) / f2[None, :]

    m0 = np.where(missing, 0.0, np.where(kept[None, :], obs, np.nan))
    columns = [(np.array([d]), np.array([i])) for d, i in zip(days, cols)]  # a missing entry: an unknown of its own
    if segments is not None:  # a new reference's offset (re-installed sensor): one unknown on its observed days
        columns += offset_columns(segments, np.isnan(obs) | ~kept[None, :])
    mean, add, records = condition_on_unknowns(posterior, precision_times, m0, columns, base, rng, n_records,
                                               jp.modes.to_modes)
    post = {"z_mean": mean.z_mean, "slope_mean": mean.slope_mean, "noise_std": jp.noise_std,
            "z_std": np.sqrt(jp.z_std**2 + add["z"]), "slope_std": np.sqrt(jp.slope_std**2 + add["slope"])}
    rate_std = np.vstack([jp.rate_std[:1], np.sqrt(jp.rate_std[1:] ** 2 + add["rate"])])
    return post, rate_std, records


#: The warning of a site whose end anchors the all-days likelihood loosened (``settlement_end_anchor="all-days"``).
_ENDS_LOOSENED = ("the span's ends appear to move: the all-days likelihood loosened the settlement's end anchors from "
                  "{fixed:.3g} to {loose:.3g} mm std. The bands include that movement, but the angles fix only the "
                  "end-to-end change, not which end moved; the instrumented span should reach beyond the works on both "
                  "sides (docs/rail.md, assumption 1).")


def _settlement_anchor(x, jp, order, factors, weights, opt: SettlementSettings, health_sz=None) -> float:
    """The settlement's end-anchor std: ``opt.sigma_z``, or with ``settlement_end_anchor="all-days"`` the value of
    largest all-days likelihood (:func:`all_days_anchor_log_likelihood`, modes and weights of the fit at
    ``sigma_z``) if it beats ``sigma_z`` by more than :data:`ANCHOR_MIN_GAIN`, over ``sigma_z * 10**k``,
    k = 0..:data:`HEALTH_ANCHOR_DECADES` — and, when the health tests' anchor was chosen by a likelihood
    (``health_sz`` given, ``health_end_anchor`` not "fixed"), only if that one was loosened too (its checks against a
    single faulty sensor, :func:`fit_end_anchor_all_days`)."""
    if opt.settlement_end_anchor == "fixed":
        return opt.sigma_z
    if opt.health_end_anchor != "fixed" and health_sz is not None and health_sz <= opt.sigma_z:
        return opt.sigma_z
    grid, fits = _anchor_profile(x, jp.mode_slopes, jp.modes, opt.sigma_z, HEALTH_ANCHOR_DECADES,
                                 sensor_factors=factors, penalty_order=order, segment_weights=weights)
    ll = np.array([v for v, _ in fits])
    k = int(np.argmax(ll))
    return float(grid[k]) if ll[k] - ll[0] > ANCHOR_MIN_GAIN else float(opt.sigma_z)


def _restored_slopes(slopes, health: SensorHealth, user_excluded) -> np.ndarray:
    """The slope changes of every sensor but the user's exclusions and those flagged "dead", "frozen" or "late" (no
    reading, or frozen: their record says nothing of the track after they stopped, and the all-days model would fill it
    as "no change"), those
    flagged "reversed" with their sign corrected (under the fixed ends a reversal explains them; as read they would
    fake an end movement)."""
    M = np.array(slopes, float)
    M[:, list(user_excluded)] = np.nan
    M[:, np.isin(health.status, UNUSABLE_STATUSES)] = np.nan
    rev = np.asarray(health.status) == "reversed"
    M[:, rev] = -M[:, rev]
    return M


def _end_mixture(x, slopes, days, daily: DailyAngles, health: SensorHealth, joint: _JointFit,
                 opt: SettlementSettings, warnings: list) -> _JointFit:
    r"""The all-days estimate ``joint`` with bands that carry the doubt on its fixed ends (``end_ambiguity="mixture"``,
    docs/rail.md, "The settlement's ends when one sensor carries the evidence"), or ``joint`` itself.

    The settlement's ends stay fixed (paper 004 §4.2's prior anchors both ends at 0; assumption 1 of docs/rail.md: the
    span covers the works) unless the all-days likelihood loosens
    them on the kept sensors with a margin that survives leaving out any one sensor (:func:`fit_end_anchor_all_days`,
    :func:`_settlement_anchor`). A step of the track at one sensor (a rail joint) moves one end and only that sensor
    sees it — which is also what a reversed or detached sensor looks like, so the guard (or the health tests, which
    exclude the sensor) keeps the ends fixed and the bands at the far end shrink to the anchor's std; and where the
    ends are loosened, the anchor's std splits the end-to-end change between the two ends and is chosen on a grid of
    decades (a tilt: 1 mm where the far end fell 10-20 mm). Here, if the all-days likelihood of all sensors
    (:func:`_restored_slopes`, no leave-one-out) loosens the ends past :data:`END_MIXTURE_MIN_GAIN`, the hypothesis
    H1 "they moved, one of them only" is kept beside H0, the estimate as it is (mean m_0, variance v_0; ends fixed or
    loosened). Under H1 the profile is the all-days estimate of those sensors with free ends (anchor std
    ``sigma_z * 10**HEALTH_ANCHOR_DECADES``; the restored sensors healthy, so starting from the kept sensors' median
    noise factor), m_1, levelled so that one end did not move — the near end (m_1 - m_1(x_0))
    or the far end (m_1 - m_1(x_N)), which the slopes cannot tell (docs/rail.md, the named limit of the all-days
    anchor) — and read either way (a faulty sensor read the other way gives m_0 - delta). With weight
    w = :data:`END_MIXTURE_WEIGHT` on H1, delta_n and delta_f the two levelled profiles minus m_0, and H0's variance
    for every component, the mixture has mean m_0 and variance

    .. math:: v_0 + \tfrac{w}{2} (\delta_n^2 + \delta_f^2)

    (daily settlement; the daily rate with the day differences of the deltas); the maximum-settlement draws shift a
    share w of H0's draws by one of +/- delta_n, +/- delta_f (:func:`_joint_max_settlement`). Nothing changes (the same
    object) when the settlement's anchor is "fixed" or all sensors together do not loosen the ends.
    """
    if opt.end_ambiguity == "off" or opt.settlement_end_anchor == "fixed" or joint is None:
        return joint
    user = [list(health.sensor_ids).index(s) for s in opt.exclude_sensors]
    M1 = _restored_slopes(slopes, health, user)
    t = np.asarray((pd.DatetimeIndex(days) - pd.Timestamp(days[0])) / pd.Timedelta(days=1), float)
    try:
        sz1 = fit_end_anchor_all_days(x, M1, day_offsets=t, temperature_change=_site_temperature_change(daily),
                                      sigma=opt.sigma, sigma_z=opt.sigma_z, min_gain=END_MIXTURE_MIN_GAIN,
                                      leave_one_out=False)[0]
    except InputError:
        return joint
    if sz1 <= opt.sigma_z:
        return joint
    opt1 = replace(opt, sigma_z=opt.sigma_z * 10.0**HEALTH_ANCHOR_DECADES, settlement_end_anchor="fixed")
    sig, _, _, factors = _noise_stage(daily, x, M1, days, opt1)
    back = np.asarray(health.excluded) & np.isfinite(M1).any(axis=0)  # healthy under H1: a kept sensor's noise
    if factors is not None and back.any() and (~back & np.isfinite(M1).any(axis=0)).any():
        factors = np.where(back, np.median(factors[~back & np.isfinite(M1).any(axis=0)]), factors)
    h1 = _joint_stage(x, M1, days, daily, sig, factors, opt1, [])
    if h1 is None:
        return joint
    m1, m0 = h1.post["z_mean"], joint.post["z_mean"]
    shift = np.stack([m1 - m1[:, :1] - m0, m1 - m1[:, -1:] - m0])  # (2, D, N): near end, far end fixed
    w = END_MIXTURE_WEIGHT
    z_std = np.sqrt(joint.post["z_std"] ** 2 + 0.5 * w * (shift**2).sum(axis=0))
    rshift = np.diff(shift, axis=1, prepend=np.nan)
    rate_std = np.sqrt(joint.smoothed.rate_std ** 2 + 0.5 * w * (rshift**2).sum(axis=0))
    out = [sid for sid, st, _ in health.flagged() if sid not in opt.exclude_sensors and st not in UNUSABLE_STATUSES]
    warnings.append(f"the all-days likelihood of all sensors{' (' + ', '.join(out) + ' included)' if out else ''} "
                    f"says the span's ends moved (anchor std {sz1:g} m), the guarded test on the kept sensors does "
                    "not: the bands carry both (end_ambiguity='mixture'), up to "
                    f"{1e3 * float(np.nanmax(np.abs(shift))):.1f} mm apart.")
    return replace(joint, post={**joint.post, "z_std": z_std},
                   smoothed=replace(joint.smoothed, std=z_std, rate_std=rate_std),
                   end_shift=shift, end_weight=w, end_sigma_z=float(sz1))


def _joint_fit(x, M, t, daily: DailyAngles, sig, factors, opt: SettlementSettings, observed=None):
    """One fit of the all-days model with given sensor factors: (noise covariance, increment prior, segment weights,
    JointPosterior). ``observed``: the record with its missing sensor-days NaN (``M`` has them filled), from which the
    noise covariance and the increment prior are fitted."""
    seen = M if observed is None else observed
    noise = day_noise_covariance(x, seen, day_offsets=t, temperature_change=_site_temperature_change(daily),
                                 sensor_factors=factors, floor=0.5 * sig)
    orders = PENALTY_ORDERS if opt.penalty_order is None else (opt.penalty_order,)
    prior = increment_rigidity(x, seen, noise_cov=noise.cov, sigma_z=opt.sigma_z, penalty_orders=orders,
                               sensor_factors=factors)
    modes = day_modes(noise.cov, prior.rigidity_by_day)
    order = prior.penalty_order
    weights = (segment_prior_weights(x, modes.to_modes @ M[1:], sigma=modes.noise, rigidity=modes.rigidity,
                                     penalty_order=order, sigma_z=opt.sigma_z, sensor_factors=factors)
               if opt.spatial_prior else None)
    jp = joint_posterior(x, M, modes, penalty_order=order, sensor_factors=factors, sigma_z=opt.sigma_z,
                         segment_weights=weights)
    return noise, prior, weights, jp


def _joint_max_settlement(x, joint: _JointFit, order, factors, opt: SettlementSettings):
    """Monte Carlo mean, std and 90 % interval of the maximum settlement of each day (§4.3) under the all-days
    posterior: draws of every mode (the engine's posterior sampler), mapped to the days; day 0 is 0."""
    K, N = joint.mode_slopes.shape
    out = np.full((4, K + 1), np.nan)
    if opt.n_monte_carlo <= 0:
        return tuple(out)
    gen = np.random.default_rng(opt.rng)
    S = int(opt.n_monte_carlo)
    draws = np.empty((S, K, N))
    # with imputed sensor-days (_impute_missing) the draws are shared among the completed records
    records = joint.mode_slopes[None] if joint.imputed_mode_slopes is None else joint.imputed_mode_slopes
    for data, rows in zip(records, np.array_split(np.arange(S), len(records))):
        if rows.size == 0:  # fewer draws than completed records: the later records get none
            continue
        for idx, s in _noise_groups(joint.modes.noise):
            draws[rows[0]:rows[-1] + 1, idx] = sample_profiles(
                x, data[idx], rows.size, sigma=_station_sigma(s, factors), rigidity=joint.modes.rigidity,
                sigma_z=joint.sigma_z, rng=gen, penalty_order=order, segment_weights=joint.weights)
    z = np.matmul(joint.modes.from_modes, draws)  # (K, K) @ (S, K, N): one BLAS product per draw
    if joint.end_shift is not None:  # the mixture of _end_mixture: a share w of the draws shifted by +/- delta
        pick = np.flatnonzero(gen.random(S) < joint.end_weight)
        end, sign = gen.integers(0, 2, pick.size), gen.choice([-1.0, 1.0], pick.size)
        z[pick] += sign[:, None, None] * joint.end_shift[end][:, 1:]
    if joint.timing_shift is not None:  # the outages' two timings (_outage_timing_shift): +/- delta, one sign per span
        for g in range(int(joint.timing_group.max()) + 1):
            sel = joint.timing_group[1:] == g
            z[:, sel] += gen.choice([-1.0, 1.0], S)[:, None] * joint.timing_shift[1:][sel][None, :]
    ms = max_settlement_from_draws(z, joint.post["z_mean"][1:], joint.post["z_std"][1:], level=0.9,
                                   interval=opt.max_settlement_interval)
    out[:, 0] = 0.0
    out[:, 1:] = ms.mean, ms.std, ms.lower, ms.upper
    return tuple(out)


def _settings_record(opt: SettlementSettings, *, drift, sig, rig, order, prior_fit, smoothed, joint=False,
                     health_sigma_z=None, settlement_sigma_z=None, end_mixture=(0.0, None), daily) -> dict:
    """The options used, as reported in :attr:`SettlementResult.settings`."""
    return dict(thermal=daily.thermal, thermal_requested=opt.thermal, lag_variance_ratio=daily.lag_variance_ratio,
                error_model="drift" if drift else "white", joint_days=bool(joint),
                max_settlement_interval=opt.max_settlement_interval, shape_evidence=bool(opt.shape_evidence and joint),
                shape_rule=opt.shape_rule, smooth_reversal=bool(opt.smooth_reversal and joint),
                health_end_anchor=opt.health_end_anchor, reversal_z_rule=opt.reversal_z_rule,
                reversal_null=opt.reversal_null, health_sigma_z=opt.sigma_z if health_sigma_z is None else float(health_sigma_z),
                settlement_end_anchor=opt.settlement_end_anchor,
                settlement_sigma_z=opt.sigma_z if settlement_sigma_z is None else float(settlement_sigma_z),
                end_ambiguity=opt.end_ambiguity, end_mixture_weight=float(end_mixture[0]),
                end_mixture_sigma_z=end_mixture[1], witness_rule=opt.witness_rule,
                spatial_prior=bool(opt.spatial_prior and opt.rigidity is None),
                sensor_noise=bool(drift and opt.sensor_noise), sigma_rad=sig,
                sigma_deg=float(np.rad2deg(sig)), rigidity=rig,
                penalty_order=order, sigma_estimated=opt.sigma is None, rigidity_estimated=opt.rigidity is None,
                change_prior_log_likelihood=None if prior_fit is None else prior_fit.log_likelihood,
                survey_rigidity=opt.survey_rigidity, sigma_z=opt.sigma_z,
                sigma_a=opt.sigma_a, reference_temp_c=opt.reference_temp_c,
                affine_correction=opt.use_affine_correction,
                through_time=opt.through_time,
                process_std=None if smoothed is None or joint else smoothed.process_std,
                settlement_threshold_m=opt.settlement_threshold_m,
                rate_threshold_m_per_day=opt.rate_threshold_m_per_day, thresholds=opt.thresholds,
                thresholds_set=bool(opt.thresholds) or opt.settlement_threshold_m is not None
                or opt.rate_threshold_m_per_day is not None,
                alarm_probability=opt.alarm_probability, n_monte_carlo=opt.n_monte_carlo)


def estimate_settlement(site: SiteData, settings: SettlementSettings | None = None,
                        **options) -> SettlementResult:
    r"""Altitude change of the track, day by day, with 90 % bands, from sleeper inclinometers (paper 004).

    Parameters
    ----------
    site : SiteData
        From :func:`~longprofile.rail.validate_site` (or :func:`longprofile.io.read_rail_site` for files).
    settings : SettlementSettings, optional
        All the options below in one frozen, validated object (default: ``SettlementSettings()``).
    **options
        Any field of :class:`SettlementSettings` by keyword (overrides ``settings``); the fields are:
    thermal : {"auto", "linear", "lagged", "none"}, default "auto"
        Temperature de-biasing: the paper's §3 ("linear"), the first-order lag model, or ("auto", the default since
        2026-12-06 session 29; "linear" before) the lagged model where a lag explains the within-day residual
        (:func:`~longprofile.rail._thermal.lag_variance_ratio`), else the linear one; ``settings["thermal"]`` of the
        result says which.
    sigma : float, optional
        Std of the daily slope changes, rad. Default: estimated from the day-to-day differences
        (:func:`day_difference_sigma`); the paper's 5e-3 deg is the noise of single readings,
        far too wide for daily medians of ~100 readings.
    rigidity : float or None, default None
        r of the prior of the change (settlement) profile. None: maximum marginal likelihood over
        the days, sigma fixed (:func:`fit_change_prior`). A given value is used as is (the paper's
        1e-8 m^-2 gives bands ≈ 30 times too wide on synthetic truth, docs/rail.md).
    penalty_order : {None, 2, 3}, default None
        Prior of the change profile: 2 = the paper's exp(-||f''||^2 / r), 3 = the smoother
        exp(-||f‴||^2 / r) (beyond the paper). None: the order with the larger maximised likelihood
        when ``rigidity`` is None, else 2 (a given r is the paper's, m^-2).
    survey_rigidity : float, default 1e-8
        r of the track geometry for the initial profile from the survey (§4.4), m^-2: the track
        itself is much rougher than the settlement bowl, so it keeps the paper's value.
    sigma_z : float, default 1e-5
        Std of the end anchors, m (ends assumed fixed, §2 and §4.2).
    sigma_a : float, default 2e-3
        Survey noise, m (§4.4).
    reference_temp_c : float, default 5
    quiet_days : sequence of dates, optional
        Days without works, for the thermal fit.
    check_health : bool, default True
        Flag and exclude improbable sensors (§6). Dead, frozen and late sensors are always excluded.
    exclude_sensors : iterable of str
        Sensor ids to exclude (status "excluded", detail "excluded by the user").
    use_affine_correction : bool, default False
        Apply the §5.2 affine correction (see :func:`affine_correction` for the paper's warning).
    through_time : bool, default True
        Also smooth across days per station and compute daily rates.
    process_std : float, optional
        Day-to-day settlement std of the through-time model, m/day (default: maximum likelihood).
    settlement_threshold_m, rate_threshold_m_per_day : float, optional
        Alarm thresholds on |altitude change| (m) and |daily rate| (m/day).
    thresholds : mapping, optional
        Graded thresholds ``{quantity: {level: value}}`` instead (:class:`SettlementSettings`).
    alarm_probability : float, default 0.5
        Report a station-day when the exceedance probability is at least this.
    n_monte_carlo : int, default 1000
        Posterior draws per day for the maximum settlement (0 = skip, NaN results).
    rng : int or Generator, default 0
    error_model : {"drift", "white"}, default "drift"
        "white": one noise std for all days (sigma, the paper's model). "drift": one std per day,
        growing with the days since the reference day and with the temperature difference from it
        (:func:`daily_noise_sigma`: drifting inclinometers and thermal residuals, calibrated on
        independent scenarios, docs/rail.md); the through-time model then carries the drift as a
        random walk of the error. A given ``sigma`` implies "white".
    sensor_noise : bool, default True
        With "drift": each sensor's std is the day's times its own factor (:func:`sensor_noise_factors`,
        ``SettlementResult.sensor_noise_factor``), so strongly drifting sensors weigh less.
    spatial_prior : bool, default True
        With ``rigidity=None``: the change prior's r varies along the track, r w_i on segment i, with w
        from an empirical-Bayes (EM) fit (:func:`segment_prior_weights`, ``SettlementResult.prior_weights``),
        so a local bowl is not shrunk by a prior fitted mostly on quiet track.
    joint_days : bool, default True
        With "drift" and ``rigidity=None``: all days in one posterior (issue 13 step 10, docs/rail.md): a
        sensor's error correlated over the days (random-walk drift, shared reference day, thermal residual) and a
        settlement that grows by increments whose prior is fitted per day (the work days), so a strong drifter's
        accumulated bias is subtracted, not only down-weighted. False: the per-day posteriors (step 9) exactly.

    Returns
    -------
    SettlementResult

    Notes
    -----
    Steps: daily angles (§3) -> slope changes tan(theta0 + m) - tan(theta0) with the
    initial angles of §4.4 -> sensor health (§6) with sigma and r re-estimated after each
    exclusion -> the prior of the change profile fitted by maximum likelihood (sigma fixed)
    -> its posterior given the slope changes with both ends anchored at 0 (§4.2 applied to the
    change itself, so the band is that of the change, not of two independent days) -> Monte
    Carlo of the maximum settlement (§4.3) -> through-time smoothing, rates and alarms (beyond
    the paper).
    """
    opt = _resolve_settings(settings, options)
    _check_exclusions(site.sensor_ids, opt.exclude_sensors)
    daily = daily_angles(site, thermal=opt.thermal, reference_temp_c=opt.reference_temp_c, quiet_days=opt.quiet_days)
    return estimate_settlement_from_daily(site, daily, opt)


def estimate_settlement_from_daily(site: SiteData, daily: DailyAngles, settings: SettlementSettings | None = None,
                                   **options) -> SettlementResult:
    """:func:`estimate_settlement` from daily angles already computed (every stage after §3).

    Parameters
    ----------
    site : SiteData
        Its sensors, survey, controls and warnings are used; its readings are not (they are in ``daily``).
    daily : DailyAngles
        Of the same sensors, e.g. :func:`daily_angles` or :func:`daily_angles_from_statistics` on cached
        per-day statistics (the monitoring service); ``daily.thermal`` must match the settings.
    settings, **options
        As :func:`estimate_settlement` (``thermal``, ``reference_temp_c`` and ``quiet_days`` shaped ``daily``).

    Returns
    -------
    SettlementResult
    """
    opt = _resolve_settings(settings, options)
    warnings = list(site.warnings)
    ids = site.sensor_ids
    x = site.x
    _check_exclusions(ids, opt.exclude_sensors)
    if list(daily.sensor_ids) != list(ids) or daily.thermal != opt.thermal and not (
            opt.thermal == "auto" and daily.thermal in ("linear", "lagged")):
        raise InputError("the daily angles are of other sensors or another thermal model than the settings.")
    if daily.temperature_mean_c is None:
        raise InputError("the daily angles carry no site-mean daily temperature (temperature_mean_c).")
    daily = _daily_stage(daily, opt, warnings)
    daily = reinstall_stage(x, ids, daily, opt.reinstallations, opt.events, warnings)
    days = daily.days
    initial, slopes = _slope_changes(site, daily, opt)
    _check_given_sigma(x, slopes, opt, warnings)
    health, M, health_sz = _health_stage(x, ids, slopes, daily, opt, warnings)
    sig, sig_days, drift, factors = _noise_stage(daily, x, M, days, opt)
    joint = _joint_stage(x, M, days, daily, sig, factors, opt, warnings, health_sz) if drift else None
    while joint is not None:  # sensor health with the all-days model (docs/rail.md, "Sensor health, step 11")
        evidence = all_days_reversal_evidence(x, joint.mode_slopes, joint.modes.noise, rigidity=joint.modes.rigidity,
                                              penalty_order=joint.prior.penalty_order, sensor_factors=joint.factors,
                                              segment_weights=joint.weights, sigma_z=health_sz)
        if opt.reversal_null == "site":  # the site's own healthy spread ("Sensor health, step 18")
            evidence = site_reversal_null(evidence, ~np.asarray(health.excluded, bool))
        cand = shape_candidates(health, evidence, opt.shape_rule) & opt.shape_evidence  # localised shapes ("Sensor health, step 14")
        shape = shape_reversal_evidence(x, joint.mode_slopes, joint.modes.noise, sensor_factors=joint.factors,
                                        sensors=cand) if cand.any() else None
        health, j = flag_reversed_all_days(health, evidence, max_flagged=None if opt.check_health else 0, shape=shape,
                                           shape_rule=opt.shape_rule, reversal_z_rule=opt.reversal_z_rule)
        if j is None:  # a jump the day-to-day test missed ("Sensor health, step 12")
            steps = all_days_step_evidence(x, joint.mode_slopes, joint.modes.noise, joint.modes.to_modes,
                                           rigidity=joint.modes.rigidity, penalty_order=joint.prior.penalty_order,
                                           sensor_factors=joint.factors, segment_weights=joint.weights,
                                           sigma_z=health_sz)
            health, j = flag_detached_all_days(health, steps, max_flagged=None if opt.check_health else 0)
        if j is None and opt.smooth_reversal and smooth_candidates(health).any():  # last ("Sensor health, step 20")
            smooth = smooth_reversal_evidence(x, joint.mode_slopes, joint.modes.noise, sensor_factors=joint.factors,
                                              sigma_z=health_sz)
            health, j = flag_reversed_smooth(health, smooth, max_flagged=None if opt.check_health else 0)
        if j is None:
            break
        warnings.append(f"sensor {ids[j]} excluded ({health.status[j]}): {health.detail[j]}.")
        M = M.copy()
        M[:, j] = np.nan
        if opt.health_end_anchor != "fixed":
            w = _anchor_witnesses(health, opt)
            health_sz = _anchor_fitter(x, daily, opt)(M) if w is None else _anchor_fitter(x, daily, opt)(M, w)
        sig, sig_days, drift, factors = _noise_stage(daily, x, M, days, opt)
        joint = _joint_stage(x, M, days, daily, sig, factors, opt, [], health_sz)
    _warn_if_health_capped(health, opt, warnings, daily)
    joint = _end_mixture(x, slopes, days, daily, health, joint, opt, warnings) if joint is not None else None
    if joint is None:
        prior_fit, order, rig, sig, sig_days, drift, factors = _change_prior_stage(x, M, sig, sig_days, drift, factors,
                                                                                   opt, warnings)
        weights = _spatial_prior_stage(x, M, sig_days, drift, factors, rig, order, opt)
        post = _posterior_by_level(x, M, sig_days, rigidity=rig, sigma_z=opt.sigma_z, penalty_order=order,
                                   factors=factors, weights=weights)
        mc_mean, mc_std, mc_lo, mc_hi = _max_settlement_stage(x, M, sig_days, rig, order, opt, factors, weights)
    else:
        prior_fit, order, rig, sig, sig_days = joint.prior.fit, joint.prior.penalty_order, joint.modes.rigidity, \
            joint.sigma, joint.sigma_by_day
        weights, post = joint.weights, joint.post
        factors = joint.factors
        mc_mean, mc_std, mc_lo, mc_hi = _joint_max_settlement(x, joint, order, factors, opt)
    if joint is not None and joint.sigma_z > opt.sigma_z:
        warnings.append(_ENDS_LOOSENED.format(fixed=opt.sigma_z * 1e3, loose=joint.sigma_z * 1e3))
    integrated = _chain_integrations(x, M, health, initial)
    smoothed, dz_std, alarms, controls = _through_time_stage(site, days, post, sig_days, drift, opt,
                                                             smoothed=None if joint is None else joint.smoothed)
    if (big := float(np.nanmax(np.abs(post["z_mean"]), initial=0.0))) > PLAUSIBLE_CHANGE_M:
        warnings.append(f"the track moved by up to {1e3 * big:.0f} mm, beyond what monitoring near works sees (a track "
                        f"is closed long before {1e3 * PLAUSIBLE_CHANGE_M:.0f} mm): check the angles' unit. Milliradians "
                        "or mm/m under angle_deg give 17.5 times the change (name the column angle_mrad, or convert: "
                        "deg = mrad x 0.0573).")
    control_check = check_controls(controls)
    if control_check is not None and control_check.disagree:
        warnings.append(control_check.message())
    if unmatched := unmatched_controls(site.controls, controls, days):
        warnings.append(unmatched)
    settings_used = _settings_record(opt, daily=daily, drift=drift, sig=sig, rig=rig, order=order, prior_fit=prior_fit,
                                     smoothed=smoothed, joint=joint is not None,
                                     health_sigma_z=health_sz,
                                     settlement_sigma_z=None if joint is None else joint.sigma_z,
                                     end_mixture=(0.0, None) if joint is None else (joint.end_weight, joint.end_sigma_z))
    return SettlementResult(days=days, sensor_ids=list(ids), x=x, dz=post["z_mean"], dz_std=dz_std,
                            dz_noise_std=post["noise_std"],
                            slope_change=post["slope_mean"], slope_change_std=post["slope_std"], smoothed=smoothed,
                            initial=initial, integrated=integrated, max_settlement_mean=np.atleast_1d(mc_mean),
                            max_settlement_std=np.atleast_1d(mc_std), health=health, daily=daily, sigma=sig,
                            rigidity=rig, penalty_order=order, change_prior=prior_fit, alarms=alarms,
                            controls=controls, warnings=tuple(warnings), settings=settings_used, sigma_by_day=sig_days,
                            sensor_noise_factor=np.ones(len(ids)) if factors is None else factors,
                            prior_weights=np.ones(len(ids) - 1) if weights is None else weights,
                            max_settlement_lower=mc_lo, max_settlement_upper=mc_hi,
                            increment_rigidity=None if joint is None else np.r_[np.nan, joint.prior.rigidity_by_day],
                            noise_day_cov=None if joint is None else joint.noise.cov, control_check=control_check)
