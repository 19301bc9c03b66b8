"""Temperature de-biasing and daily angles (paper 004 §3), plus a lagged thermal model (beyond the paper).

Linear model (paper §3): angle = level + k (T - T_ref); k per sensor is the median over 24 h
slices of the least-squares slope of angle on temperature; the corrected angle is
angle - k (T - T_ref); the daily value is the median of the corrected angles.

Lagged model (beyond the paper, for the hysteresis loops of §5.1): the sensor bias follows
the temperature through a first-order response, tau dT_s/dt = T - T_s, angle = level + k T_s.
tau is chosen per sensor on a grid by the median (over 24 h slices) residual variance of the
slice-wise regression on T_s — the median makes the fit ignore days with works (settlement
steps); with ``quiet_days`` only those days are used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.ndimage import median_filter

from .._validation import require_positive
from ..errors import InputError
from ..statespace import linear_recursion
from ._data import SiteData

__all__ = ["DailyAngles", "daily_angles", "first_order_response", "THERMAL_MODELS", "LAG_GRID_HOURS"]

THERMAL_MODELS = ("linear", "lagged", "none")
#: Candidate time constants of the lagged thermal model, hours.
LAG_GRID_HOURS = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0)
#: A reading is an outlier when it is this many robust stds away from its 7-sample running median.
OUTLIER_THRESHOLD = 8.0


@dataclass(frozen=True, eq=False)
class DailyAngles:
    """Daily angles per sensor after outlier removal and thermal correction.

    Attributes
    ----------
    days : (D,) datetime64[ns] ndarray
        Calendar days covered by the readings.
    sensor_ids : list of str
        Sensors by station (same order as ``SiteData.sensors``).
    angle_deg : (D, N) ndarray
        Daily median of the corrected angles, deg (NaN when a sensor has no reading that day).
    change_deg : (D, N) ndarray
        Angle change since the sensor's first day with readings, deg.
    n_readings : (D, N) int ndarray
        Readings used per day and sensor (after outlier removal).
    n_outliers : (N,) int ndarray
        Readings set aside as outliers per sensor (never silently: reported).
    raw_std_deg : (N,) ndarray
        Robust std of each sensor's raw readings (a dead sensor has ~0).
    raw_day_spread_deg : (D, N) ndarray or None
        Robust within-day spread (1.4826 MAD) of each sensor's raw readings (before outlier removal and
        thermal correction), deg; NaN on days with fewer than 2 readings. A sensor frozen from some day on
        reads the same value all day (the frozen-sensor test of :func:`~longprofile.rail.assess_sensors`).
    noise_deg : (N,) ndarray
        Robust high-frequency noise std of each sensor, deg.
    thermal_coef : (N,) ndarray
        k, deg/°C (0 for ``thermal="none"``).
    thermal_lag_hours : (N,) ndarray
        tau, h (0 for the linear model).
    reference_temp_c : float
        T_ref of the correction, °C.
    thermal : str
        ``"linear"``, ``"lagged"`` or ``"none"``.
    warnings : tuple of str
        Sensors whose thermal coefficient could not be fitted (left uncorrected), reported.
    """

    days: np.ndarray
    sensor_ids: list
    angle_deg: np.ndarray
    change_deg: np.ndarray
    n_readings: np.ndarray
    n_outliers: np.ndarray
    raw_std_deg: np.ndarray
    noise_deg: np.ndarray
    thermal_coef: np.ndarray
    thermal_lag_hours: np.ndarray
    reference_temp_c: float
    thermal: str
    warnings: tuple = ()
    raw_day_spread_deg: np.ndarray | None = None


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
    if T.size == 0:
        return T.copy()
    if T.size == 1:
        return T.copy()
    # exact discretisation between samples for T linear in between:
    # T_s[k] = a T_s[k-1] + (1 - b) T[k] + (b - a) T[k-1], a = exp(-h/tau), b = (1 - a) tau / h;
    # run on the engine's deterministic recursion (a repeated time stamp, h = 0, keeps T_s unchanged).
    h = np.diff(t)
    a = np.exp(-h / float(tau_hours))
    with np.errstate(divide="ignore", invalid="ignore"):
        b = np.where(h > 0, (1.0 - a) * float(tau_hours) / np.where(h > 0, h, 1.0), 1.0)
    input_matrix = np.stack([1.0 - b, b - a], axis=-1)[:, None, :]
    inputs = np.column_stack([T[1:], T[:-1]])
    run = linear_recursion(a[:, None, None], input_matrix, inputs, T[:1])
    return run.states[:, 0].copy()


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


def daily_angles(site: SiteData, *, thermal: str = "linear", reference_temp_c: float = 5.0,
                 quiet_days=None) -> DailyAngles:
    """Outlier removal, thermal correction and daily medians of every sensor's angle (paper 004 §3).

    Parameters
    ----------
    site : SiteData
        Validated site (:func:`~longprofile.rail.validate_site`).
    thermal : {"linear", "lagged", "none"}, default "linear"
        ``"linear"``: the paper's algorithm; ``"lagged"``: first-order thermal lag (module docstring);
        ``"none"``: daily medians of the raw angles.
    reference_temp_c : float, default 5
        T_ref, °C (the paper: 5 °C; it does not affect angle changes).
    quiet_days : sequence of dates, optional
        Days known to be without works; the thermal fit then uses only them.

    Returns
    -------
    DailyAngles
    """
    if thermal not in THERMAL_MODELS:
        raise InputError(f"thermal must be one of {THERMAL_MODELS}; got {thermal!r}.")
    r = site.readings
    ids = site.sensor_ids
    N = len(ids)
    dates = r["timestamp"].dt.normalize()
    days = pd.DatetimeIndex(np.sort(dates.unique()))
    if len(days) == 0:
        raise InputError("the readings table is empty.")
    D = len(days)
    quiet = None
    if quiet_days is not None:
        try:
            quiet = set(pd.DatetimeIndex(pd.to_datetime(list(quiet_days))).normalize())
        except (ValueError, TypeError) as exc:
            raise InputError(f"quiet_days must be dates like 2019-11-18; {exc}") from None
        if not quiet:
            raise InputError("quiet_days is empty; give at least one day without works, or None.")
    t0 = days[0]
    quiet_mask = None if quiet is None else np.asarray(days.isin(list(quiet)))
    unfitted = []
    angle = np.full((D, N), np.nan)
    nread = np.zeros((D, N), dtype=int)
    nout = np.zeros(N, dtype=int)
    rawstd = np.zeros(N)
    dayspread = np.full((D, N), np.nan)
    noise = np.full(N, np.nan)
    coef = np.zeros(N)
    lag = np.zeros(N)
    groups = dict(tuple(r.groupby("sensor_id", sort=False)))
    for j, sid in enumerate(ids):
        g = groups.get(sid)
        if g is None:
            continue
        g = g[np.isfinite(g["angle_deg"].to_numpy()) & np.isfinite(g["temperature_c"].to_numpy())]
        if len(g) == 0:
            continue
        a = g["angle_deg"].to_numpy(float)
        T = g["temperature_c"].to_numpy(float)
        th = (g["timestamp"] - t0).dt.total_seconds().to_numpy() / 3600.0
        day = np.searchsorted(days.to_numpy(), g["timestamp"].dt.normalize().to_numpy())
        med = median_filter(a, size=7, mode="nearest") if a.size >= 7 else np.full_like(a, np.median(a))
        dev = a - med
        s_hf = 1.4826 * np.median(np.abs(dev)) if a.size else 0.0
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
    change = np.full_like(angle, np.nan)
    for j in range(N):
        ok = np.nonzero(np.isfinite(angle[:, j]))[0]
        if ok.size:
            change[:, j] = angle[:, j] - angle[ok[0], j]
    return DailyAngles(days=days.to_numpy(), sensor_ids=list(ids), angle_deg=angle, change_deg=change,
                       n_readings=nread, n_outliers=nout, raw_std_deg=rawstd, raw_day_spread_deg=dayspread,
                       noise_deg=noise, thermal_coef=coef,
                       thermal_lag_hours=lag, reference_temp_c=float(reference_temp_c), thermal=thermal,
                       warnings=tuple([f"no thermal correction for {len(unfitted)} sensor(s) {unfitted[:5]}: too few "
                                       "readings (or < 0.5 °C of temperature spread within a day) on the days used "
                                       "for the fit"] if unfitted else []))
