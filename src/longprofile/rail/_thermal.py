"""Temperature de-biasing and daily angles (paper 004 §3), plus a lagged thermal model (beyond the paper).

Linear model (paper §3): angle = level + k (T - T_ref); k per sensor is the median over 24 h
slices of the least-squares slope of angle on temperature; the corrected angle is
angle - k (T - T_ref); the daily value is the median of the corrected angles.

Lagged model (beyond the paper, for the hysteresis loops of §5.1): the sensor bias follows
the temperature through a first-order response, tau dT_s/dt = T - T_s, angle = level + k T_s.
tau is chosen per sensor on a grid by the median (over 24 h slices) residual variance of the
slice-wise regression on T_s — the median makes the fit ignore days with works (settlement
steps); with ``quiet_days`` only those days are used.

Automatic choice (``thermal="auto"``, beyond the paper): the lagged model where a lag explains much of the
within-day residual, the linear one elsewhere. For each sensor, the ratio of the median slice residual variance at
the best lag of ``LAG_AUTO_GRID_HOURS`` to that at no lag (:func:`lag_variance_ratio`); the lagged model when the
median ratio over the sensors is below ``LAG_AUTO_RATIO``. On the calibration seeds the median ratio was 0.92-1.00 on
sites with swings of 2-8 degC and lags up to 4 h (where both models give the same bands) and 0.07-0.50 on sites with
sun-heated rails (swings of 15-30 degC, lags of 1-6 h, and the farebersviller-like preset), where the linear model
flagged healthy sensors as reversed and under-covered (docs/rail.md, "The thermal model chosen by the data").
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from scipy.ndimage import median_filter

from .._validation import require_positive
from ..errors import InputError
from ..statespace import linear_recursion
from ._data import SiteData
from ._results import DailyAngles, _changes

__all__ = ["DailyAngles", "daily_angles", "first_order_response", "THERMAL_MODELS", "LAG_GRID_HOURS", "DayStatistics",
           "lag_variance_ratio", "LAG_AUTO_RATIO", "LAG_AUTO_GRID_HOURS",
           "day_statistics", "daily_angles_from_statistics", "statistics_window", "MEDIAN_UPDATE_TOLERANCE_DEG",
           "NOISE_STD_TOLERANCE", "MEDIAN_LINES"]

THERMAL_MODELS = ("linear", "lagged", "none", "auto")
#: Candidate time constants of the lagged thermal model, hours.
LAG_GRID_HOURS = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0)
#: ``thermal="auto"`` takes the lagged model when the median over sensors of :func:`lag_variance_ratio` is below this
#: (module docstring; chosen between the families' 0.92-1.00 and 0.07-0.50 on calibration seeds 300-305).
LAG_AUTO_RATIO = 0.75
#: The lags (h) :func:`lag_variance_ratio` tries: a coarse subset of ``LAG_GRID_HOURS`` (the choice, not the fit).
LAG_AUTO_GRID_HOURS = (0.0, 1.0, 3.0, 6.0)
#: A reading is an outlier when it is this many robust stds away from its 7-sample running median.
OUTLIER_THRESHOLD = 8.0


def _noise_std(dev) -> float:
    """Robust noise std of a sensor's readings from their deviations from the 7-sample running median: 1.4826 x the
    median of the *non-zero* |deviation| (0 when every deviation is 0, NaN when there is none).

    Where the angle is monotonic over a 7-sample window (a thermal swing read hourly, steeper than the noise) the
    running median is the reading itself and its deviation exactly 0; with these zeros the median collapsed to 0 on
    sun-heated rails and the outlier threshold to its floor (docs/rail.md, "The outlier test's noise std, step 19").
    """
    ad = np.abs(np.asarray(dev, float))
    if ad.size == 0:
        return float("nan")
    nz = ad[ad > 0]
    return 1.4826 * float(np.median(nz)) if nz.size else 0.0


def first_order_response(t_hours, temperature, tau_hours: float) -> np.ndarray:
    r"""Response T_s of a first-order thermal lag, tau dT_s/dt = T - T_s, to a sampled temperature.

    Parameters
    ----------
    t_hours : (T,) array_like
        Increasing sample times, h (irregular allowed).
    temperature : (T,) array_like
        Temperature T at those times, °C (taken linear between samples).
    tau_hours : float
        Time constant, h; 0 returns the temperature itself.

    Returns
    -------
    (T,) ndarray
        T_s, starting in equilibrium (T_s(t_0) = T(t_0)). Exact for piecewise-linear T.
    """
    t = np.ascontiguousarray(t_hours, dtype=float)
    T = np.ascontiguousarray(temperature, dtype=float)
    if tau_hours == 0:
        return T.copy()
    require_positive("tau_hours", tau_hours)
    return _first_order_responses(t, T, (tau_hours,))[:, 0].copy()


def _first_order_responses(t_hours, temperature, taus_hours) -> np.ndarray:
    """(T, L) :func:`first_order_response` of the same temperature at each of L time constants > 0, in one run of the
    engine: the L lags as the L states of one recursion with a diagonal transition (each state's operations those of
    its own run, to the last bit: the off-diagonal terms add exact zeros)."""
    t = np.ascontiguousarray(t_hours, dtype=float)
    T = np.ascontiguousarray(temperature, dtype=float)
    taus = [float(tau) for tau in taus_hours]
    for tau in taus:
        require_positive("tau_hours", tau)
    if T.size <= 1:
        return np.repeat(T[:, None], len(taus), axis=1)
    # exact discretisation between samples for T linear in between:
    # T_s[k] = a T_s[k-1] + (1 - b) T[k] + (b - a) T[k-1], a = exp(-h/tau), b = (1 - a) tau / h;
    # run on the engine's deterministic recursion (a repeated time stamp, h = 0, keeps T_s unchanged).
    h = np.diff(t)
    L = len(taus)
    transition = np.zeros((h.size, L, L))
    input_matrix = np.empty((h.size, L, 2))
    for i, tau in enumerate(taus):  # a and b computed per lag as for one lag alone
        a = np.exp(-h / tau)
        with np.errstate(divide="ignore", invalid="ignore"):
            b = np.where(h > 0, (1.0 - a) * tau / np.where(h > 0, h, 1.0), 1.0)
        transition[:, i, i] = a
        input_matrix[:, i, 0] = 1.0 - b
        input_matrix[:, i, 1] = b - a
    inputs = np.column_stack([T[1:], T[:-1]])
    return linear_recursion(transition, input_matrix, inputs, np.full(L, T[0])).states


def _slice_regression(day, a, T, n_days):
    """Per-day least-squares slope of a on T and residual variance; days with too little spread -> NaN."""
    n = np.bincount(day, minlength=n_days).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        ma = np.bincount(day, a, n_days) / n
        mT = np.bincount(day, T, n_days) / n
        da, dT = a - ma[day], T - mT[day]
        sxy = np.bincount(day, da * dT, n_days)
        sxx = np.bincount(day, dT * dT, n_days)
        syy = np.bincount(day, da * da, n_days)
        ok = (n >= 6) & (sxx > 0) & (np.sqrt(sxx / np.maximum(n, 1)) > 0.5)  # >= 0.5 °C spread within the day
        slope = np.where(ok, sxy / sxx, np.nan)
        resid = np.where(ok, (syy - sxy**2 / sxx) / (n - 2), np.nan)
    return slope, resid


#: Largest error allowed when a cached day's median of corrected angles is carried to a new thermal coefficient
#: by its first-order update (:func:`day_statistics` with ``previous``), deg: a tenth of the MEMS resolution
#: (1e-4 deg, paper 004 §1.3). Beyond it the sensor's days are recomputed from its readings.
MEDIAN_UPDATE_TOLERANCE_DEG = 1e-5
#: Per-day fields of :class:`DayStatistics`, (D, N) each, in storage order.
#: A cached sensor keeps its noise std s (the outlier threshold) while the exact noise std of all its readings
#: (the median of 1.4826 |deviation|) is within s (1 +- this), decided exactly from per-day counts
#: (:func:`day_statistics`, Notes).
NOISE_STD_TOLERANCE = 0.01
DAY_FIELDS = ("n_raw", "raw_median_deg", "raw_spread_deg", "noise_used_deg", "n_dev_below", "n_dev_at_most",
              "n_dev_nonzero", "n_outliers", "n_kept", "thermal_slope", "coef_deg_per_c", "median_deg",
              "median_temp_c", "temp_range_c", "temperature_sum_c", "n_temperature", "last_ts",
              "n_below_lines", "median_window_deg_per_c")
_INT_FIELDS = ("n_raw", "n_dev_below", "n_dev_at_most", "n_dev_nonzero", "n_outliers", "n_kept", "n_temperature",
               "last_ts", "n_below_lines")
#: Kept readings per (day, sensor) whose (angle, temperature) are kept with the day's statistics: the ones whose
#: corrected angle is nearest the day's median (``DayStatistics.median_lines``). From them the median at another
#: thermal coefficient k' is exact while |k' - k| <= ``median_window_deg_per_c`` (:func:`day_statistics`, Notes).
MEDIAN_LINES = 16
#: Per-day fields of shape (D, N, 2 MEDIAN_LINES): not among DAY_FIELDS (one value per day and sensor).
_LINE_FIELDS = ("median_lines",)


@dataclass(frozen=True, eq=False)
class DayStatistics:
    """Per (day, sensor) quantities from which :func:`daily_angles_from_statistics` builds :class:`DailyAngles`.

    The per-day stage of :func:`daily_angles` (linear and no thermal model): everything it needs from the
    readings of one sensor and day, so that a new or revised day is recomputed from its own readings (and the
    three readings on either side, the running median's window) while the other days come from a cache.
    Shapes: D days, N sensors (by station). Days without a reading hold n = 0 and NaN.

    Attributes
    ----------
    days : (D,) datetime64[ns] ndarray
    sensor_ids : list of str
    n_raw : (D, N) int ndarray
        Readings with a finite angle and temperature.
    raw_median_deg, raw_spread_deg : (D, N) ndarray
        Median and robust spread (1.4826 MAD, NaN below 2 readings) of the raw angles, deg.
    noise_used_deg : (D, N) ndarray
        Robust noise std s of the sensor the day was computed with (1.4826 median of the non-zero |angle - 7-sample
        running median| over the sensor's readings, §3, :func:`_noise_std`), deg; the outlier threshold is
        8 max(s, 1e-4).
    n_dev_below, n_dev_at_most, n_dev_nonzero : (D, N) int ndarray
        Readings with 0 < 1.4826 |deviation| < s (1 - e), with 0 < 1.4826 |deviation| <= s (1 + e), and with a
        non-zero deviation, e = :data:`NOISE_STD_TOLERANCE`: summed over the days, they tell whether the noise std
        of all the sensor's readings is still within s (1 +- e) (exactly, without the readings).
    n_outliers : (D, N) int ndarray
    n_kept : (D, N) int ndarray
        Readings kept (after outlier removal).
    thermal_slope : (D, N) ndarray
        Least-squares slope of the kept angles on temperature, deg/°C (NaN: fewer than 6 readings or
        < 0.5 °C of spread, :func:`_slice_regression`).
    coef_deg_per_c : (D, N) ndarray
        Thermal coefficient k the median was computed with, deg/°C (the sensor's current k is
        ``thermal_coef``; they differ on cached days carried over by ``previous``).
    median_deg : (D, N) ndarray
        Median of the corrected kept angles a - k (T - T_ref), deg.
    median_temp_c : (D, N) ndarray
        Temperature of the median reading(s): d median / dk = -(median_temp_c - T_ref) while the median
        reading stays the same.
    temp_range_c : (D, N) ndarray
        max - min of the kept readings' temperatures, °C: |median(k') - first-order update| <= |k' - k| range.
    temperature_sum_c, n_temperature : (D, N) ndarray
        Sum and count of the finite temperatures of all the day's readings (site-mean daily temperature).
    last_ts : (D, N) int ndarray
        Newest reading of the day, seconds since 1970 UTC (-1: none).
    n_below_lines, median_window_deg_per_c : (D, N) ndarray
        Kept readings below the median lines, and the half-width W of the coefficients k' around
        ``coef_deg_per_c`` for which the median of the corrected angles is the median of the lines' (shifted by
        the ranks below them): exact for |k' - k| <= W (inf: every kept reading is a line).
    median_lines : (D, N, 2 MEDIAN_LINES) ndarray
        Angles (first half) and temperatures (second half) of the :data:`MEDIAN_LINES` kept readings whose
        corrected angle is nearest the day's median, NaN-padded.
    noise_deg, raw_std_deg, thermal_coef : (N,) ndarray
        Per-sensor values of :class:`DailyAngles`.
    unfitted : (N,) bool ndarray
        Sensors left without thermal correction.
    thermal : str
    reference_temp_c : float
    exact : bool
        True when computed from every reading (``previous=None``); False when the noise and raw spread come
        from the per-day medians (:func:`day_statistics`, Notes).
    stale_sensors : tuple of str
        Sensors whose cached days could not be carried over (``previous``) within the tolerances; the caller
        recomputes them from all their readings.
    """

    days: np.ndarray
    sensor_ids: list
    n_raw: np.ndarray
    raw_median_deg: np.ndarray
    raw_spread_deg: np.ndarray
    noise_used_deg: np.ndarray
    n_dev_below: np.ndarray
    n_dev_at_most: np.ndarray
    n_dev_nonzero: np.ndarray
    n_outliers: np.ndarray
    n_kept: np.ndarray
    thermal_slope: np.ndarray
    coef_deg_per_c: np.ndarray
    median_deg: np.ndarray
    median_temp_c: np.ndarray
    temp_range_c: np.ndarray
    temperature_sum_c: np.ndarray
    n_temperature: np.ndarray
    last_ts: np.ndarray
    n_below_lines: np.ndarray
    median_window_deg_per_c: np.ndarray
    median_lines: np.ndarray
    noise_deg: np.ndarray
    raw_std_deg: np.ndarray
    thermal_coef: np.ndarray
    unfitted: np.ndarray
    thermal: str
    reference_temp_c: float
    exact: bool = True
    stale_sensors: tuple = ()

    def select_days(self, mask) -> "DayStatistics":
        """The same statistics on the days where ``mask`` (D,) is true."""
        m = np.asarray(mask, bool)
        return replace(self, days=self.days[m], **{f: getattr(self, f)[m] for f in DAY_FIELDS + _LINE_FIELDS})

    def replace_sensors(self, other: "DayStatistics") -> "DayStatistics":
        """These statistics with the sensors of ``other`` (recomputed from all their readings) put in; the
        days of ``other`` must be among these days. The result is exact only if both are."""
        idx = np.searchsorted(self.days, other.days)
        if np.any(idx >= self.days.size) or np.any(self.days[np.minimum(idx, self.days.size - 1)] != other.days):
            raise InputError("replace_sensors: the other statistics have days these do not have.")
        cols = [self.sensor_ids.index(s) for s in other.sensor_ids]
        new = {}
        for f in DAY_FIELDS + _LINE_FIELDS:
            v = getattr(self, f).copy()
            empty = _empty_days(self.days.size, len(cols))[f]
            empty[idx] = getattr(other, f)
            v[:, cols] = empty
            new[f] = v
        per = {}
        for f in ("noise_deg", "raw_std_deg", "thermal_coef", "unfitted"):
            v = getattr(self, f).copy()
            v[cols] = getattr(other, f)
            per[f] = v
        return replace(self, **new, **per, exact=self.exact and other.exact,
                       stale_sensors=tuple(s for s in self.stale_sensors if s not in other.sensor_ids))


def statistics_window(previous: DayStatistics, changed_day):
    """Days to recompute after a change at ``changed_day`` and the readings they need: (first_day, context_day).

    A reading's deviation from its 7-sample running median depends on the 3 readings on either side, so the
    days from ``first_day`` on are recomputed — per sensor the last day before ``changed_day`` from which it has
    at least 3 readings up to that day — and the readings from ``context_day`` on (3 more per sensor) are needed.
    Both are the earliest over the sensors, as datetime64[ns] days.
    """
    days = pd.DatetimeIndex(previous.days)
    c = int(np.searchsorted(days.to_numpy(), pd.Timestamp(changed_day).normalize().to_datetime64()))

    def back(stop):
        if stop <= 0:
            return 0
        n = previous.n_raw[:stop][::-1].cumsum(axis=0)  # readings from day stop-1-i up to stop-1
        enough = n >= 3
        first = np.where(enough.any(axis=0), stop - 1 - enough.argmax(axis=0), 0)
        return int(first.min()) if first.size else 0

    def at(i):
        return days[i].to_datetime64() if i < days.size else pd.Timestamp(changed_day).normalize().to_datetime64()

    f = back(c)
    return at(f), at(back(f))


def _empty_days(D: int, N: int) -> dict:
    out = {f: np.full((D, N), np.nan) for f in DAY_FIELDS}
    out["temperature_sum_c"][:] = 0.0
    for f in _INT_FIELDS:
        out[f] = np.zeros((D, N), dtype=np.int64)
    out["last_ts"][:] = -1
    out["median_lines"] = np.full((D, N, 2 * MEDIAN_LINES), np.nan)
    return out


def _group_median(day, v, D, *, weights_of=None):
    """Median of ``v`` per day index (NaN on empty days) and, optionally, the mean of ``weights_of`` at the
    median element(s). Same value as ``np.median`` per group (mean of the two middle values)."""
    order = np.lexsort((v, day))
    vs, ds = v[order], day[order]
    n = np.bincount(ds, minlength=D)
    start = np.concatenate([[0], np.cumsum(n)[:-1]])
    has = n > 0
    lo = np.where(has, start + (n - 1) // 2, 0)
    hi = np.where(has, start + n // 2, 0)
    med = np.full(D, np.nan)
    if vs.size:
        med[has] = (vs[lo[has]] + vs[hi[has]]) / 2
    if weights_of is None:
        return med
    at = np.full(D, np.nan)
    if vs.size:
        ws = weights_of[order]
        at[has] = (ws[lo[has]] + ws[hi[has]]) / 2
    return med, at


def _weighted_median(v, w) -> float:
    """Median of the values ``v`` each counted ``w`` times (NaN and zero weights ignored)."""
    ok = np.isfinite(v) & (w > 0)
    if not ok.any():
        return np.nan
    v, w = v[ok], w[ok]
    o = np.argsort(v, kind="stable")
    c = np.cumsum(w[o])
    half = c[-1] / 2.0
    i = int(np.searchsorted(c, half))
    if c[i] == half and i + 1 < v.size:  # even total: mean of the two middle values, as np.median
        return float((v[o][i] + v[o][i + 1]) / 2)
    return float(v[o][i])


def _sensor_days(a, T, dev, day, D, *, noise, tref, coef_of):
    """Per-day statistics of one sensor's readings (time order) on day indices ``day`` (>= 0; context rows,
    only in the running median, are dropped before). ``coef_of(slope, n_kept) -> (k, fitted)``."""
    out = {}
    out["n_raw"] = np.bincount(day, minlength=D)
    raw_med = _group_median(day, a, D)
    out["raw_median_deg"] = raw_med
    spread = 1.4826 * _group_median(day, np.abs(a - raw_med[day]), D)
    out["raw_spread_deg"] = np.where(out["n_raw"] >= 2, spread, np.nan)
    ad = np.abs(dev)
    out["noise_used_deg"] = np.where(out["n_raw"] > 0, noise, np.nan)
    m = noise / 1.4826 if np.isfinite(noise) else 0.0
    nonzero = ad > 0
    out["n_dev_below"] = np.bincount(day[nonzero & (ad < m * (1 - NOISE_STD_TOLERANCE))], minlength=D)
    out["n_dev_at_most"] = np.bincount(day[nonzero & (ad <= m * (1 + NOISE_STD_TOLERANCE))], minlength=D)
    out["n_dev_nonzero"] = np.bincount(day[nonzero], minlength=D)
    keep = ad <= OUTLIER_THRESHOLD * max(noise if np.isfinite(noise) else 0.0, 1e-4)
    out["n_outliers"] = np.bincount(day[~keep], minlength=D)
    a, T, day = a[keep], T[keep], day[keep]
    out["n_kept"] = np.bincount(day, minlength=D)
    slope, _ = _slice_regression(day, a, T, D)
    out["thermal_slope"] = slope
    k, fitted = coef_of(slope, out["n_kept"])
    out["coef_deg_per_c"] = np.where(out["n_raw"] > 0, k, np.nan)
    v = a - k * (T - tref)
    med, Tm = _group_median(day, v, D, weights_of=T)
    out["median_deg"], out["median_temp_c"] = med, Tm
    tmax = np.full(D, -np.inf)
    np.maximum.at(tmax, day, T)
    tmin = np.full(D, np.inf)
    np.minimum.at(tmin, day, T)
    out["temp_range_c"] = np.where(out["n_kept"] > 0, tmax - tmin, np.nan)
    out["median_lines"], out["n_below_lines"], out["median_window_deg_per_c"] = _median_lines(
        day, a, T, v, med, D, out["temp_range_c"])
    return out, k, fitted


def _median_lines(day, a, T, v, med, D, temp_range):
    """The MEDIAN_LINES kept readings per day whose corrected angle v is nearest the day's median, the number of
    the others below the median, and the half-width W of the coefficients around k within which they give the
    median exactly.

    Each reading's corrected angle is a line in k, v_i(k') = a_i - k' (T_i - T_ref); relative to the line through
    the median with the mid-range temperature, each moves by at most |k' - k| rho / 2 (rho: the day's
    temperature range), and so does every order statistic. The readings left out are at least h from the
    median at k, the two middle ones within d (half their gap; 0 for an odd count). While |k' - k| rho <= h - d,
    no reading left out below (above) rises above (falls below) the middle ones, so the median at k' is the
    median of the lines' v_i(k') at the ranks (n - 1) // 2 and n // 2 less the number left out below.
    """
    K = MEDIAN_LINES
    dist = np.abs(v - med[day])
    order = np.lexsort((dist, day))
    ds = day[order]
    n = np.bincount(ds, minlength=D)
    start = np.concatenate([[0], np.cumsum(n)[:-1]])
    rank = np.arange(ds.size) - start[ds]
    inc = rank < K
    lines = np.full((D, 2 * K), np.nan)
    sel = order[inc]
    lines[ds[inc], rank[inc]] = a[sel]
    lines[ds[inc], K + rank[inc]] = T[sel]
    out = order[~inc]
    n_below = np.bincount(day[out][v[out] < med[day[out]]], minlength=D)
    h = np.full(D, np.inf)
    np.minimum.at(h, day[out], dist[out])
    by_value = np.lexsort((v, day))  # the middle readings' distance from the median: half their gap (0 if odd)
    has = n > 0
    d = np.full(D, np.inf)
    d[has] = np.maximum(dist[by_value[(start + (n - 1) // 2)[has]]], dist[by_value[(start + n // 2)[has]]])
    with np.errstate(invalid="ignore", divide="ignore"):
        window = np.where(temp_range > 0, (h - d) / temp_range, np.inf)
    return lines, n_below, np.where(n > 0, window, np.nan)


def _lines_median(lines, n_kept, n_below, k, tref):
    """Median of the corrected angles a - k (T - T_ref) at ``k`` from the median lines (M, 2 MEDIAN_LINES) of M
    (day, sensor) pairs with their kept counts and counts below the lines (:func:`_median_lines`); the same
    arithmetic as the median over all kept readings."""
    K = MEDIAN_LINES
    v = np.sort(lines[:, :K] - k[:, None] * (lines[:, K:] - tref), axis=1)  # NaN (padding) last
    rows = np.arange(v.shape[0])
    lo, hi = (n_kept - 1) // 2 - n_below, n_kept // 2 - n_below
    return (v[rows, lo] + v[rows, hi]) / 2


def _coef_rule(thermal, quiet_mask):
    """k of a sensor from its per-day slopes (paper §3: the median over 24 h slices; only quiet days if given)."""
    def coef_of(slope, n_kept):
        if thermal == "none":
            return 0.0, True
        use = np.ones(slope.size, bool) if quiet_mask is None else quiet_mask
        if n_kept[use].sum() > 12 and np.isfinite(slope[use]).any():
            return float(np.nanmedian(slope[use])), True
        return 0.0, False
    return coef_of


def _noise_still_median(fields, j) -> bool:
    """Is the noise std of all the sensor's readings (1.4826 x the median non-zero |deviation|, the mean of the two
    middle values for an even count, :func:`_noise_std`) still within NOISE_STD_TOLERANCE of the kept one s?
    Exactly, over the n non-zero deviations: the lower middle value is >= s (1 - e) while fewer than (n - 1) // 2 + 1
    of them are below it, the upper one <= s (1 + e) while at least n // 2 + 1 are at most it."""
    n = int(fields["n_dev_nonzero"][:, j].sum())
    if n == 0:
        return True
    return bool(fields["n_dev_below"][:, j].sum() <= (n - 1) // 2 and fields["n_dev_at_most"][:, j].sum() >= n // 2 + 1)


def _approx_raw_std(raw_median, raw_spread, n_raw) -> float:
    centre = _weighted_median(raw_median, n_raw)
    return max(_weighted_median(raw_spread, n_raw), 1.4826 * _weighted_median(np.abs(raw_median - centre), n_raw))


def _quiet_mask(days: pd.DatetimeIndex, quiet_days):
    if quiet_days is None:
        return None
    try:
        quiet = set(pd.DatetimeIndex(pd.to_datetime(list(quiet_days))).normalize())
    except (ValueError, TypeError) as exc:
        raise InputError(f"quiet_days must be dates like 2019-11-18; {exc}") from None
    if not quiet:
        raise InputError("quiet_days is empty; give at least one day without works, or None.")
    return np.asarray(days.isin(list(quiet)))


def day_statistics(readings: pd.DataFrame, sensor_ids, *, thermal: str = "linear", reference_temp_c: float = 5.0,
                   quiet_days=None, first_day=None, previous: DayStatistics | None = None) -> DayStatistics:
    r"""Per (day, sensor) statistics of :func:`daily_angles` (its per-day stage; linear or no thermal model).

    Parameters
    ----------
    readings : DataFrame
        ``timestamp`` (datetime64, UTC), ``sensor_id``, ``angle_deg``, ``temperature_c``, each sensor's rows
        in time order (``SiteData.readings``); readings before ``first_day`` only feed the running median.
    sensor_ids : list of str
        Sensors by station.
    thermal : {"linear", "none"}
    reference_temp_c : float
        T_ref, °C.
    quiet_days : sequence of dates, optional
        Days without works for the thermal fit.
    first_day : date, optional
        With ``previous``: the first day recomputed from ``readings``; earlier days come from ``previous``.
    previous : DayStatistics, optional
        Statistics of the earlier days (a cache), same sensors, thermal model and T_ref.

    Returns
    -------
    DayStatistics
        Every day: ``previous`` before ``first_day``, the readings' days from it on.

    Notes
    -----
    Without ``previous`` the result is exact: the noise std s (1.4826 median |deviation| over all readings)
    and the raw spread (MAD of all raw angles) come from every reading, as in paper 004 §3. With
    ``previous`` (assumptions, docs/rail-service.md) each sensor keeps the s of its cached days (so the outlier
    threshold 8 s, and every cached outlier set, stay as they are) while the noise std of all its readings is
    within s (1 +- NOISE_STD_TOLERANCE), decided exactly from the per-day counts of readings with
    1.4826 |deviation| below s (1 - e) / at most s (1 + e) (only readings within that band of the outlier
    threshold can then be set aside differently from the full computation); the raw spread
    is the larger of the count-weighted median of the within-day spreads and the robust spread of the daily
    medians (it only feeds the dead-sensor test, < 1e-4 deg). The thermal coefficient is exact in both cases
    (the median of the per-day slopes of the same outlier sets). A cached day's median at the new k is
    computed exactly from its :data:`MEDIAN_LINES` median lines while |k' - k| <= ``median_window_deg_per_c``
    (:func:`_median_lines`); beyond, by the first-order update m(k') = m(k) - (k' - k)(T_m - T_ref), exact while
    the median reading stays the same, error at most |k' - k| * temp_range <= :data:`MEDIAN_UPDATE_TOLERANCE_DEG`.
    Sensors beyond either tolerance are listed in ``stale_sensors``.
    """
    if thermal not in ("linear", "none"):
        raise InputError(f"day_statistics supports thermal='linear' or 'none'; got {thermal!r} (the lagged model "
                         "fits its lag on the whole record: use daily_angles).")
    if (previous is None) != (first_day is None):
        raise InputError("day_statistics: give first_day and previous together (or neither).")
    ids = list(sensor_ids)
    N = len(ids)
    ts = pd.to_datetime(readings["timestamp"])
    day_all = ts.dt.normalize()
    first, prev, P, days = _statistics_days(day_all, ids, thermal, reference_temp_c, first_day, previous)
    D = len(days)
    if D == 0:
        raise InputError("the readings table is empty.")
    quiet_mask = _quiet_mask(days, quiet_days)
    coef_rule = _coef_rule(thermal, quiet_mask)
    fields = _empty_days(D, N)
    if prev is not None:
        for f in DAY_FIELDS + _LINE_FIELDS:
            fields[f][:P] = getattr(prev, f)
    noise, rawstd, coef = np.full(N, np.nan), np.zeros(N), np.zeros(N)
    unfitted = np.zeros(N, bool)
    stale = []
    tref = float(reference_temp_c)
    dnum = np.searchsorted(days.to_numpy(), day_all.to_numpy())
    tsec = ts.to_numpy().astype("datetime64[s]").astype(np.int64)
    positions = pd.Series(np.arange(len(readings))).groupby(readings["sensor_id"].to_numpy(), sort=False).indices
    ang_all = readings["angle_deg"].to_numpy(float)
    tmp_all = readings["temperature_c"].to_numpy(float)
    for j, sid in enumerate(ids):
        rows = positions.get(sid)
        if rows is None or rows.size == 0:
            if prev is not None:
                _carry_over(fields, j, P, D, prev, coef_rule, tref, stale, sid, noise, rawstd, coef, unfitted)
            continue
        dj, Tj_all = dnum[rows], tmp_all[rows]
        inwin = day_all.to_numpy()[rows] >= first.to_datetime64() if first is not None else np.ones(rows.size, bool)
        tfin = np.isfinite(Tj_all) & inwin
        _add_temperatures(fields, j, P, dj[tfin], Tj_all[tfin])
        fin = np.isfinite(ang_all[rows]) & np.isfinite(Tj_all)
        a, T, d, w, t = ang_all[rows][fin], Tj_all[fin], dj[fin], inwin[fin], tsec[rows][fin]
        if a.size == 0:
            if prev is not None:
                _carry_over(fields, j, P, D, prev, coef_rule, tref, stale, sid, noise, rawstd, coef, unfitted)
            continue
        med = median_filter(a, size=7, mode="nearest") if a.size >= 7 else np.full_like(a, np.median(a))
        dev = a - med
        a, T, d, dev, t = a[w], T[w], d[w], dev[w], t[w]
        if prev is None:
            s_hf = _noise_std(dev)
            rawstd[j] = 1.4826 * np.median(np.abs(a - np.median(a))) if a.size else 0.0
            base = None
        else:
            base = {f: fields[f][:P, j] for f in DAY_FIELDS}
        loc = d - P
        Dn = D - P
        coef_of = _sensor_coef_rule(coef_rule, base)
        if prev is not None:
            s_hf = _kept_noise(fields, j, P)
            if s_hf is None:  # no cached day of this sensor: its noise needs all its readings
                stale.append(sid)
                s_hf = _noise_std(dev)
        st, k, fitted = _sensor_days(a, T, dev, loc, Dn, noise=s_hf, tref=tref, coef_of=coef_of)
        for f, v in st.items():
            fields[f][P:, j] = v
        lt = np.full(Dn, -1, dtype=np.int64)
        np.maximum.at(lt, loc, t)
        fields["last_ts"][P:, j] = lt
        noise[j], coef[j], unfitted[j] = s_hf, k, not fitted
        if prev is not None:
            rawstd[j] = _approx_raw_std(fields["raw_median_deg"][:, j], fields["raw_spread_deg"][:, j],
                                        fields["n_raw"][:, j])
            if sid not in stale and not _update_cached(fields, j, P, k):
                stale.append(sid)
    return DayStatistics(days=days.to_numpy(), sensor_ids=ids, **fields, noise_deg=noise, raw_std_deg=rawstd,
                         thermal_coef=coef, unfitted=unfitted, thermal=thermal, reference_temp_c=tref,
                         exact=prev is None, stale_sensors=tuple(stale))


def _statistics_days(day_all, ids, thermal, reference_temp_c, first_day, previous):
    """The days of day_statistics' result: (first recomputed day, kept days of ``previous``, their number P, all
    days), ``previous`` checked to be of the same sensors, thermal model and T_ref."""
    if previous is None:
        return None, None, 0, pd.DatetimeIndex(np.sort(day_all.unique()))
    if list(previous.sensor_ids) != ids or previous.thermal != thermal \
            or previous.reference_temp_c != float(reference_temp_c):
        raise InputError("day_statistics: previous statistics are of other sensors, thermal model or T_ref.")
    first = pd.Timestamp(first_day).normalize()
    prev = previous.select_days(pd.DatetimeIndex(previous.days) < first)
    new_days = pd.DatetimeIndex(np.sort(day_all[day_all >= first].unique()))
    days = pd.DatetimeIndex(np.concatenate([pd.DatetimeIndex(prev.days).to_numpy(), new_days.to_numpy()]))
    return first, prev, prev.days.size, days


def _add_temperatures(fields, j, P, day, temperature):
    """Sensor j's temperature sums and counts of the recomputed days (>= P) from its finite readings in the window."""
    D = fields["temperature_sum_c"].shape[0]
    fields["temperature_sum_c"][:, j] = np.where(np.arange(D) >= P, 0.0, fields["temperature_sum_c"][:, j])
    fields["n_temperature"][:, j] = np.where(np.arange(D) >= P, 0, fields["n_temperature"][:, j])
    np.add.at(fields["temperature_sum_c"][:, j], day, temperature)
    np.add.at(fields["n_temperature"][:, j], day, 1)


def _sensor_coef_rule(coef_rule, base):
    """``coef_rule`` of one sensor: the slopes and counts of its cached days (``base``; None: no cache) first."""
    if base is None:
        return coef_rule

    def coef_of(slope_new, n_kept_new):
        return coef_rule(np.concatenate([base["thermal_slope"], slope_new]),
                         np.concatenate([base["n_kept"], n_kept_new]))
    return coef_of


def _carry_over(fields, j, P, D, prev, coef_rule, tref, stale, sid, noise, rawstd, coef, unfitted):
    """A sensor without readings in the recomputed window: its cached days with the new site-wide parameters."""
    fields["temperature_sum_c"][P:, j] = 0.0
    fields["n_temperature"][P:, j] = 0
    n = fields["n_raw"][:P, j]
    if n.sum() == 0:
        return
    s_hf = _kept_noise(fields, j, P)
    slope = np.concatenate([fields["thermal_slope"][:P, j], np.full(D - P, np.nan)])
    k, fitted = coef_rule(slope, np.concatenate([fields["n_kept"][:P, j], np.zeros(D - P, np.int64)]))
    noise[j], coef[j], unfitted[j] = s_hf, k, not fitted
    rawstd[j] = _approx_raw_std(fields["raw_median_deg"][:, j], fields["raw_spread_deg"][:, j], fields["n_raw"][:, j])
    if not _update_cached(fields, j, P, k):
        stale.append(sid)


def _kept_noise(fields, j, P):
    """The noise std the sensor's cached days were computed with (None: no cached day)."""
    v = fields["noise_used_deg"][:P, j]
    v = v[np.isfinite(v) & (fields["n_raw"][:P, j] > 0)]
    return float(v[-1]) if v.size else None


def _update_cached(fields, j, P, k) -> bool:
    """Can sensor j's cached days (< P) be carried to coefficient ``k``? False when not exact enough.

    The kept noise std must still be the median |deviation| of all the sensor's readings (old and new days,
    within :data:`NOISE_STD_TOLERANCE`), and the first-order update of each median from the k it was
    computed with (:func:`daily_angles_from_statistics`) must be within :data:`MEDIAN_UPDATE_TOLERANCE_DEG`.
    """
    if P == 0:
        return True
    has = fields["n_raw"][:P, j] > 0
    dk = np.abs(k - fields["coef_deg_per_c"][:P, j])
    exact = dk <= fields["median_window_deg_per_c"][:P, j]  # the median lines give the exact median
    err = np.where(exact, 0.0, dk * np.nan_to_num(fields["temp_range_c"][:P, j]))
    return _noise_still_median(fields, j) and not np.any(err[has] > MEDIAN_UPDATE_TOLERANCE_DEG)


def daily_angles_from_statistics(stats: DayStatistics) -> DailyAngles:
    """The combine stage of :func:`daily_angles`: :class:`DailyAngles` from per-day statistics.

    Parameters
    ----------
    stats : DayStatistics
        From :func:`day_statistics` (with no ``stale_sensors``).

    Returns
    -------
    DailyAngles
        ``temperature_mean_c`` is the site-mean daily temperature (all sensors' readings of the day).
    """
    if stats.stale_sensors:
        raise InputError(f"day statistics of sensor(s) {list(stats.stale_sensors)[:5]} are stale: recompute them "
                         "from their readings (day_statistics without previous).")
    # each median was computed with k = coef_deg_per_c; carried to the sensor's k exactly from its median lines
    # within their window (below), else by the first-order update
    # m(k') = m(k) - (k' - k)(T_m - T_ref) (exact while the median reading stays the same; error bound in
    # day_statistics); a no-op (k' = k) on statistics computed from all readings
    dk = stats.thermal_coef[None, :] - stats.coef_deg_per_c
    angle = np.where(stats.n_kept > 0, stats.median_deg - np.where(dk != 0, dk, 0.0)
                     * (stats.median_temp_c - stats.reference_temp_c), np.nan)
    # within the window of its median lines the median at the new k is computed exactly from them
    di, sj = np.nonzero((dk != 0) & (np.abs(dk) <= stats.median_window_deg_per_c) & (stats.n_kept > 0))
    if di.size:
        angle[di, sj] = _lines_median(stats.median_lines[di, sj], stats.n_kept[di, sj], stats.n_below_lines[di, sj],
                                      stats.thermal_coef[sj], stats.reference_temp_c)
    change = _changes(angle)
    nt = stats.n_temperature.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        tmean = np.where(nt > 0, stats.temperature_sum_c.sum(axis=1) / np.maximum(nt, 1), np.nan)
    unfitted = [s for s, u in zip(stats.sensor_ids, stats.unfitted) if u]
    return DailyAngles(days=stats.days, sensor_ids=list(stats.sensor_ids), angle_deg=angle, change_deg=change,
                       n_readings=stats.n_kept.astype(int), n_outliers=stats.n_outliers.sum(axis=0).astype(int),
                       raw_std_deg=stats.raw_std_deg, raw_day_spread_deg=stats.raw_spread_deg,
                       noise_deg=stats.noise_deg, thermal_coef=stats.thermal_coef,
                       thermal_lag_hours=np.zeros(len(stats.sensor_ids)), reference_temp_c=stats.reference_temp_c,
                       thermal=stats.thermal, warnings=_unfitted_warning(unfitted), temperature_mean_c=tmean)


def _unfitted_warning(unfitted) -> tuple:
    return tuple([f"no thermal correction for {len(unfitted)} sensor(s) {unfitted[:5]}: too few "
                  "readings (or < 0.5 °C of temperature spread within a day) on the days used "
                  "for the fit"] if unfitted else [])


def _sensor_readings(r, days) -> dict:
    """{sensor_id: (angle deg, temperature degC, hours since ``days[0]``, day index)} of each sensor's readings with a
    finite angle and temperature, in the table's order (the times of the whole table converted once)."""
    th = (r["timestamp"] - days[0]).dt.total_seconds().to_numpy() / 3600.0
    day = np.searchsorted(days.to_numpy(), r["timestamp"].dt.normalize().to_numpy())
    a = r["angle_deg"].to_numpy(float)
    T = r["temperature_c"].to_numpy(float)
    finite = np.isfinite(a) & np.isfinite(T)
    positions = pd.Series(np.arange(len(r))).groupby(r["sensor_id"].to_numpy(), sort=False).indices
    out = {}
    for sid, rows in positions.items():
        rows = rows[finite[rows]]
        out[sid] = (a[rows], T[rows], th[rows], day[rows])
    return out


def _running_deviation(a):
    """Deviation of each reading from the 7-sample running median and its robust std s_hf -- the outlier test keeps
    |deviation| <= OUTLIER_THRESHOLD s_hf."""
    med = median_filter(a, size=7, mode="nearest") if a.size >= 7 else np.full_like(a, np.median(a))
    dev = a - med
    return dev, (_noise_std(dev) if a.size else 0.0)


def lag_variance_ratio(site: SiteData, *, quiet_days=None, lags_hours=LAG_AUTO_GRID_HOURS) -> np.ndarray:
    """Per sensor: how much a thermal lag explains of the within-day residual (the choice of ``thermal="auto"``).

    The median over 24 h slices of the residual variance of the slice-wise regression of the angle on the lagged
    temperature (the lagged model's criterion, module docstring), least over ``lags_hours``, divided by its value at
    no lag: 1 where a lag explains nothing, near 0 where the linear model leaves a hysteresis loop.

    Parameters
    ----------
    site : SiteData
    quiet_days : sequence of dates, optional
        Days without works: only they enter (as for the thermal fit).
    lags_hours : sequence of float
        Lags tried, h; the first must be 0.

    Returns
    -------
    (N,) ndarray
        The ratio per sensor (in order of ``site.sensor_ids``), in [0, 1]; NaN for a sensor with too few readings
        or no day of >= 0.5 degC temperature spread.
    """
    lags = tuple(float(v) for v in lags_hours)
    if not lags or lags[0] != 0.0:
        raise InputError(f"lags_hours must start with 0 (the linear model); got {lags_hours!r}.")
    r = site.readings
    days = pd.DatetimeIndex(np.sort(r["timestamp"].dt.normalize().unique()))
    if len(days) == 0:
        raise InputError("the readings table is empty.")
    quiet_mask = _quiet_mask(days, quiet_days)
    series = _sensor_readings(r, days)
    out = np.full(len(site.sensor_ids), np.nan)
    for j, sid in enumerate(site.sensor_ids):
        if sid not in series or series[sid][0].size == 0:  # angles without a temperature (a failed temperature
            continue                                      # channel): nothing to fit
        a, T, th, day = series[sid]
        dev, s_hf = _running_deviation(a)
        keep = np.abs(dev) <= OUTLIER_THRESHOLD * max(s_hf, 1e-4)
        if quiet_mask is not None:
            keep &= quiet_mask[day]
        if keep.sum() <= 12:
            continue
        a, T, th, day = a[keep], T[keep], th[keep], day[keep]
        lagged = iter(_first_order_responses(th, T, [tau for tau in lags if tau != 0]).T.copy())  # one engine run
        scores = []
        for tau in lags:
            slope, resid = _slice_regression(day, a, T if tau == 0 else next(lagged), len(days))
            scores.append(float(np.nanmedian(resid)) if np.isfinite(slope).any() else np.nan)
        if np.isfinite(scores[0]) and scores[0] > 0:
            out[j] = min(1.0, float(np.nanmin(scores)) / scores[0])
    return out


def _require_temperatures(readings) -> None:
    """One clear refusal when no reading has both an angle and a temperature: every sensor would be dead."""
    r = readings
    if len(r) and r["angle_deg"].notna().any() and not (r["angle_deg"].notna() & r["temperature_c"].notna()).any():
        raise InputError("readings: no reading has both an angle and a temperature (temperature_c is empty in every "
                         "row: no temperature channel, or every one failed). The thermal correction (paper 004 §3) "
                         "needs the sensors' temperature: put a temperature record of the rail (or the air) in "
                         "temperature_c. Without any, pass thermal='none' (CLI --thermal none; validate_site with "
                         "require_temperature=False): no thermal correction.")


def daily_angles(site: SiteData, *, thermal: str = "linear", reference_temp_c: float = 5.0,
                 quiet_days=None) -> DailyAngles:
    """Outlier removal, thermal correction and daily medians of every sensor's angle (paper 004 §3).

    Parameters
    ----------
    site : SiteData
        Validated site (:func:`~longprofile.rail.validate_site`).
    thermal : {"linear", "lagged", "none", "auto"}, default "linear"
        ``"linear"``: the paper's algorithm; ``"lagged"``: first-order thermal lag (module docstring);
        ``"none"``: daily medians of the raw angles; ``"auto"``: the lagged model where a lag explains the
        within-day residual (:func:`lag_variance_ratio` below ``LAG_AUTO_RATIO``), else the linear one (the result's
        ``thermal`` says which, ``lag_variance_ratio`` why).
    reference_temp_c : float, default 5
        T_ref, °C (the paper: 5 °C; it does not affect angle changes).
    quiet_days : sequence of dates, optional
        Days known to be without works; the thermal fit then uses only them.

    Returns
    -------
    DailyAngles

    Notes
    -----
    The linear and no-thermal models run in two stages shared with the monitoring service: the per-day stage
    :func:`day_statistics` and the combine stage :func:`daily_angles_from_statistics`. The lagged model fits
    its lag over the whole record and runs here in one piece.
    """
    _require_temperatures(site.readings)
    if thermal not in THERMAL_MODELS:
        raise InputError(f"thermal must be one of {THERMAL_MODELS}; got {thermal!r}.")
    if thermal == "auto":
        per_sensor = lag_variance_ratio(site, quiet_days=quiet_days)
        # no sensor with a day of enough readings and temperature spread: no evidence of a lag, the linear model
        ratio = float(np.nanmedian(per_sensor)) if np.isfinite(per_sensor).any() else float("nan")
        chosen = "lagged" if ratio < LAG_AUTO_RATIO else "linear"
        out = daily_angles(site, thermal=chosen, reference_temp_c=reference_temp_c, quiet_days=quiet_days)
        return replace(out, lag_variance_ratio=ratio)
    if thermal != "lagged":
        if len(site.readings) == 0:
            raise InputError("the readings table is empty.")
        return daily_angles_from_statistics(day_statistics(site.readings, site.sensor_ids, thermal=thermal,
                                                           reference_temp_c=reference_temp_c,
                                                           quiet_days=quiet_days))
    r = site.readings
    ids = site.sensor_ids
    N = len(ids)
    dates = r["timestamp"].dt.normalize()
    days = pd.DatetimeIndex(np.sort(dates.unique()))
    if len(days) == 0:
        raise InputError("the readings table is empty.")
    D = len(days)
    quiet_mask = _quiet_mask(days, quiet_days)
    quiet = quiet_mask
    unfitted = []
    angle = np.full((D, N), np.nan)
    nread = np.zeros((D, N), dtype=int)
    nout = np.zeros(N, dtype=int)
    rawstd = np.zeros(N)
    dayspread = np.full((D, N), np.nan)
    noise = np.full(N, np.nan)
    coef = np.zeros(N)
    lag = np.zeros(N)
    series = _sensor_readings(r, days)
    for j, sid in enumerate(ids):
        if sid not in series or series[sid][0].size == 0:
            continue
        a, T, th, day = series[sid]
        dev, s_hf = _running_deviation(a)
        rawstd[j] = 1.4826 * np.median(np.abs(a - np.median(a)))
        by_day = pd.Series(a).groupby(day)
        spread = 1.4826 * (pd.Series(a) - by_day.transform("median")).abs().groupby(day).median()
        many = by_day.size().to_numpy() >= 2
        dayspread[spread.index.to_numpy()[many], j] = spread.to_numpy()[many]
        noise[j] = s_hf
        keep = np.abs(dev) <= OUTLIER_THRESHOLD * max(s_hf, 1e-4)
        nout[j] = int((~keep).sum())
        a, T, th, day = a[keep], T[keep], th[keep], day[keep]
        use = np.ones(a.size, bool) if quiet is None else quiet_mask[day]
        if thermal != "none" and use.sum() > 12:
            taus = (0.0,) if thermal == "linear" else LAG_GRID_HOURS
            best = None
            for tau in taus:
                Ts = first_order_response(th, T, tau)
                slope, resid = _slice_regression(day[use], a[use], Ts[use], D)
                if np.isfinite(slope).sum() == 0:
                    continue
                score = float(np.nanmedian(resid))
                if best is None or score < best[0]:
                    best = (score, tau, float(np.nanmedian(slope)), Ts)
            if best is not None:
                _, lag[j], coef[j], Ts = best
                a = a - coef[j] * (Ts - reference_temp_c)
            else:
                unfitted.append(sid)
        elif thermal != "none":
            unfitted.append(sid)
        dm = pd.Series(a).groupby(day).median()
        cnt = pd.Series(a).groupby(day).size()
        angle[dm.index.to_numpy(), j] = dm.to_numpy()
        nread[cnt.index.to_numpy(), j] = cnt.to_numpy()
    change = _changes(angle)
    tm = r.groupby(dates)["temperature_c"].mean().reindex(days).to_numpy(float)
    return DailyAngles(temperature_mean_c=tm, days=days.to_numpy(), sensor_ids=list(ids), angle_deg=angle, change_deg=change,
                       n_readings=nread, n_outliers=nout, raw_std_deg=rawstd, raw_day_spread_deg=dayspread,
                       noise_deg=noise, thermal_coef=coef,
                       thermal_lag_hours=lag, reference_temp_c=float(reference_temp_c), thermal=thermal,
                       warnings=_unfitted_warning(unfitted))
