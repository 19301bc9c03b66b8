"""Settlement through time: a second smoothing pass over days per station, rates and alarms (beyond paper 004).

Model (per station i, day d >= 1): the daily posterior mean y_{d,i} of the change since the
reference day 0 is y_d = s_d + a_d - a_0, where s is the settlement and a_d the error the
angles of day d alone would give. The errors a_d are independent across days, but a_0 (the
reference day's) is SHARED by every day's change, so the daily errors are correlated; with the
daily posterior variance v_d split as v_d = rho v + (1 - rho) v_d (rho = ``reference_share``,
1/2 when every day, the reference included, has the same noise: Var(e_d - e_0) = 2 Var(e)),
the state is (s_d, a_0): a_0 ~ N(0, rho v) constant, the settlement a random walk over days,
s_{d+1} = s_d + w_d, w_d ~ N(0, q^2), s_0 = 0, and y_d = s_d - a_0 + noise of variance
(1 - rho) v_d. q (m/day) is one value for the site, chosen by maximum marginal likelihood
over a grid. The RTS smoother over days (the engine) gives E[s_d | all days] and its std
(which keeps the reference day's share: averaging days cannot remove it); the daily rate
s_d - s_{d-1} gets its std from the lag-one cross-covariance (a_0 cancels).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.special import ndtr

from ..errors import InputError
from ..statespace import StateSpaceModel, kalman_filter, rts_smoother
from ._results import TemporalSettlement

__all__ = ["TemporalSettlement", "smooth_through_time", "settlement_alarms", "check_threshold", "THRESHOLD_RANGE_M",
           "THRESHOLD_FLOORS_M", "PROCESS_STD_GRID"]

#: Candidate day-to-day settlement std q, m/day.
PROCESS_STD_GRID = (2e-5, 5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2)


#: The through-time model's structure (state (s_d, a_0), y_d = s_d - a_0): its noise and initial covariances
#: differ per station and candidate q and are given per series (``series_cov`` of the engine's filter).
_STRUCTURE = StateSpaceModel(transition=np.eye(2), observation=np.array([[1.0, -1.0]]), process_cov=np.zeros((2, 2)),
                             obs_cov=np.ones((1, 1)), initial_mean=np.zeros(2), initial_cov=np.eye(2))


def _station_covariances(var_obs, qs, reference_share):
    """Per-series covariances of the through-time model for every station j (columns of ``var_obs`` (D, N)) and
    candidate q: series g N + j is station j with q = qs[g]. Returns the engine's ``series_cov`` dict."""
    D, N = var_obs.shape
    G = len(qs)
    var_ref = reference_share * np.median(var_obs[1:], axis=0) if D > 1 else np.zeros(N)
    P0 = np.zeros((N, 2, 2))
    P0[:, 0, 0] = 1e-16
    P0[:, 1, 1] = np.maximum(var_ref, 1e-20)
    Q = np.zeros((G, N, 2, 2))
    Q[:, :, 0, 0] = np.asarray(qs, float)[:, None] ** 2
    R = np.broadcast_to(((1.0 - reference_share) * var_obs).T[None, :, :, None, None], (G, N, D, 1, 1))
    return {"process_cov": Q.reshape(G * N, 2, 2), "obs_cov": R.reshape(G * N, D, 1, 1),
            "initial_cov": np.broadcast_to(P0, (G, N, 2, 2)).reshape(G * N, 2, 2)}


def _station_smoother(Y, var_white, qs, reference_share, *, smooth):
    """The engine's filter (and RTS smoother when ``smooth``) of every station and candidate q in one batch:
    (filter or smoother result, log-likelihood (G, N))."""
    D, N = Y.shape
    cov = _station_covariances(var_white, qs, reference_share)
    y = np.broadcast_to(Y.T[None, :, :, None], (len(qs), N, D, 1)).reshape(len(qs) * N, D, 1)
    f = kalman_filter(_STRUCTURE, y, store_covariances=smooth, series_cov=cov)
    ll = np.asarray(f.log_likelihood).reshape(len(qs), N)
    return (rts_smoother(_STRUCTURE, f) if smooth else f), ll


def smooth_through_time(daily_mean, daily_std, *, process_std=None, reference_share: float = 0.5,
                        noise_variance_by_day=None) -> TemporalSettlement:
    """Smooth daily settlement posteriors across days, per station (random-walk model, module docstring).

    Parameters
    ----------
    daily_mean, daily_std : (D, N) array_like
        Daily posterior mean and std of the altitude change, m (day 0 is the reference, mean 0).
    process_std : float, optional
        q, m/day; estimated by maximum likelihood when None.
    reference_share : float, default 0.5
        Share of each day's variance due to the reference day's error, common to all days
        (module docstring); 0 treats the daily errors as independent.
    noise_variance_by_day : (D,) array_like, optional
        Variance of the daily slope-change noise of each day (``error_model="drift"`` of
        :func:`~longprofile.rail.estimate_settlement`). The share of each day's variance above the
        smallest day's, v_d (1 - min_d sigma_d^2 / sigma_d^2), is then an error that persists from day
        to day (sensor drift, thermal residual) and that smoothing across days cannot average away:
        the smoother runs on the remainder (split into the reference share and independent daily
        noise) and the persistent share is added to the smoothed variance; the rate variance gets
        the day-to-day growth of that share (a random walk of the error: its increments).
        (A joint state (s_d, a_0, c_d) with c a random walk of the error is not identifiable from one
        station's series: the error walk absorbs the settlement.)

    Returns
    -------
    TemporalSettlement
    """
    mu = np.asarray(daily_mean, float)
    sd = np.asarray(daily_std, float)
    if mu.ndim != 2 or mu.shape != sd.shape:
        raise InputError(f"daily_mean and daily_std must be (D, N) of the same shape; got {mu.shape} and {sd.shape}.")
    D, N = mu.shape
    if not 0.0 <= reference_share < 1.0:
        raise InputError(f"reference_share must be in [0, 1); got {reference_share!r}.")
    var = np.maximum(sd, 1e-7) ** 2
    Y = mu.copy()
    Y[0] = np.nan  # day 0 is the reference: its change is 0 by construction and carries no information
    if noise_variance_by_day is not None:
        nv = np.asarray(noise_variance_by_day, float)
        if nv.shape != (D,) or not np.all(np.isfinite(nv) & (nv > 0)):
            raise InputError(f"noise_variance_by_day must be (D,) = ({D},) positive values.")
        white_share = np.minimum(np.min(nv[1:]) / nv, 1.0) if D > 1 else np.ones(D)
        white_share[0] = 1.0  # the reference day: no persistent error yet
        var_white, var_drift = var * white_share[:, None], var * (1.0 - white_share[:, None])
    else:
        var_white, var_drift = var, None

    if process_std is None:  # every station and candidate q in one batch of the engine's filter
        _, ll = _station_smoother(Y, var_white, PROCESS_STD_GRID, reference_share, smooth=False)
        q = PROCESS_STD_GRID[int(np.argmax(ll.sum(axis=1)))]
    else:
        q = float(process_std)
        if not (np.isfinite(q) and q > 0):
            raise InputError(f"process_std must be > 0 (m/day); got {process_std!r}.")
    sm, _ = _station_smoother(Y, var_white, (q,), reference_share, smooth=True)
    mean = sm.mean[:, :, 0].T.copy()
    P = sm.cov[:, :, 0, 0].T  # (D, N)
    rate = np.full((D, N), np.nan); rate_std = np.full((D, N), np.nan)
    Pr = P[1:] + P[:-1] - 2 * sm.cross_cov[:, :, 0, 0].T if D > 1 else None
    if var_drift is not None:
        walk = np.maximum.accumulate(var_drift, axis=0)
        P = P + walk
        Pr = Pr + np.diff(walk, axis=0) if D > 1 else None
    std = np.sqrt(P)
    if D > 1:
        rate[1:] = np.diff(mean, axis=0)
        rate_std[1:] = np.sqrt(np.maximum(Pr, 0.0))
    return TemporalSettlement(mean=mean, std=std, rate=rate, rate_std=rate_std, process_std=q)


def _prob_abs_exceeds(mean, std, thr):
    std = np.maximum(std, 1e-300)
    return ndtr((-thr - mean) / std) + ndtr((mean - thr) / std)


#: The smallest plausible alarm threshold of each quantity, m (m/day for the rate). ASSUMPTION (docs/rail.md, "Alarm
#: thresholds"): track limits on settlement and twist are millimetres to tens of millimetres (graded limits near works
#: start at a few mm; a twist limit of 1 in 300 over 3 m is 10 mm), rate limits 0.5-5 mm/day (1 mm/week is 0.14
#: mm/day); the estimate's own error is ~0.1-0.3 mm RMS, so a limit below 0.5 mm would alarm on noise. The same limits
#: in metres read as millimetres (0.010 under value_mm: 0.01 mm; 0.003 m/day: 0.003 mm/day) fall 10 times or more
#: below these floors and are refused as a unit mistake.
THRESHOLD_FLOORS_M = {"settlement": 5e-4, "twist": 5e-4, "rate": 5e-5}
#: Plausible alarm thresholds (m, m/day for the rate): from the smallest of :data:`THRESHOLD_FLOORS_M` (each quantity
#: has its own) to 1 m; a value outside is taken as a unit mistake (mm given as m or the reverse) and refused.
THRESHOLD_RANGE_M = (min(THRESHOLD_FLOORS_M.values()), 1.0)


def check_threshold(value, kind: str = "settlement") -> float:
    """``value`` as a float when it is a plausible threshold of ``kind`` ("settlement", "rate" or "twist"), m or
    m/day; :class:`~longprofile.errors.InputError` otherwise (not finite, not > 0, below the kind's
    :data:`THRESHOLD_FLOORS_M` or above 1 m)."""
    unit = "m/day" if kind == "rate" else "m"
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"the {kind} threshold must be a number in {unit}; got {value!r}.") from None
    if not v > 0 or not np.isfinite(v):
        raise InputError(f"the {kind} threshold must be > 0 {unit}; got {value!r}.")
    lo, hi = THRESHOLD_FLOORS_M.get(kind, THRESHOLD_RANGE_M[0]), THRESHOLD_RANGE_M[1]
    if not lo <= v <= hi:
        per = "/day" if kind == "rate" else ""
        raise InputError(f"a {kind} threshold of {v:g} {unit} ({v * 1e3:g} mm{per}) is not plausible ({lo * 1e3:g} "
                         f"mm{per} to {hi:g} m{per}): a unit mistake? (the library and the service API take m, the "
                         "command line and thresholds files mm).")
    return v


def settlement_alarms(days, sensor_ids, x, mean, std, *, threshold_m=None, rate=None, rate_std=None,
                      rate_threshold_m_per_day=None, min_probability: float = 0.5) -> pd.DataFrame:
    """Alarms: station-days where |altitude change| or |daily rate| exceeds a threshold with enough probability.

    Parameters
    ----------
    days : (D,) datetime64 array
    sensor_ids : list of str
    x : (N,) ndarray
    mean, std : (D, N) ndarray
        Altitude change posterior, m.
    threshold_m : float, optional
        Settlement (or heave) threshold on |change|, m.
    rate, rate_std : (D, N) ndarray, optional
        Daily rate posterior, m/day.
    rate_threshold_m_per_day : float, optional
        Threshold on |rate|, m/day.
    min_probability : float, default 0.5
        List a station-day when P(exceedance) >= this.

    Returns
    -------
    DataFrame
        Columns date, sensor_id, x_m, kind ("settlement" or "rate"), value (posterior mean), threshold,
        probability — sorted by date and station. Empty (same columns) when nothing exceeds.
    """
    if not 0 < min_probability <= 1:
        raise InputError(f"min_probability must be in (0, 1]; got {min_probability!r}.")
    rows = []
    checks = []
    if threshold_m is not None:
        checks.append(("settlement", mean, std, check_threshold(threshold_m, "settlement")))
    if rate_threshold_m_per_day is not None:
        thr = check_threshold(rate_threshold_m_per_day, "rate")
        if rate is None:
            raise InputError("a rate threshold needs the rate posterior (temporal smoothing).")
        checks.append(("rate", rate, rate_std, thr))
    for kind, m, s, thr in checks:
        with np.errstate(invalid="ignore"):
            p = _prob_abs_exceeds(m, s, thr)
        d_idx, j_idx = np.nonzero(np.nan_to_num(p) >= min_probability)
        for d, j in zip(d_idx, j_idx):
            rows.append((pd.Timestamp(days[d]).date().isoformat(), sensor_ids[j], float(x[j]), kind, float(m[d, j]),
                         thr, float(p[d, j])))
    df = pd.DataFrame(rows, columns=["date", "sensor_id", "x_m", "kind", "value", "threshold", "probability"])
    if not rows:  # the dtypes of a non-empty result (an empty list gives object columns: no arithmetic on them)
        df = df.astype({"date": str, "sensor_id": str, "x_m": float, "kind": str, "value": float, "threshold": float,
                        "probability": float})
    return df.sort_values(["date", "x_m", "kind"], kind="stable").reset_index(drop=True)
