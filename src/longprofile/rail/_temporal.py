"""Settlement through time: a second smoothing pass over days per station, rates and alarms (beyond paper 004).

Model (per station i, day d): the daily posterior mean s^obs_{d,i} of the rigidity model is
an observation of the settlement s_{d,i} with the daily posterior variance v_{d,i}
(independent across days: each day's posterior uses that day's angles only); the settlement
itself is a random walk over days, s_{d+1} = s_d + w_d, w_d ~ N(0, q^2), starting at s_0 = 0.
q (m/day) is one value for the site, chosen by maximum marginal likelihood over a grid.
The RTS smoother over days (the engine) gives E[s_d | all days] and its std; the daily
rate s_d - s_{d-1} gets its std from the lag-one cross-covariance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.special import ndtr

from ..errors import InputError
from ..statespace import StateSpaceModel
from ..statespace._shared_cov import shared_covariance_smoother

__all__ = ["TemporalSettlement", "smooth_through_time", "settlement_alarms", "PROCESS_STD_GRID"]

#: Candidate day-to-day settlement std q, m/day.
PROCESS_STD_GRID = (2e-5, 5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2)


@dataclass(frozen=True, eq=False)
class TemporalSettlement:
    """Settlement smoothed across days.

    Attributes
    ----------
    mean, std : (D, N) ndarray
        Smoothed altitude change and its std, m.
    rate, rate_std : (D, N) ndarray
        Altitude change per day s_d - s_{d-1} and its std, m/day (NaN on day 0).
    process_std : float
        q, m/day (maximum likelihood on the grid :data:`PROCESS_STD_GRID`).
    """

    mean: np.ndarray
    std: np.ndarray
    rate: np.ndarray
    rate_std: np.ndarray
    process_std: float


def _station_model(var_obs, q):
    D = var_obs.size
    return StateSpaceModel(transition=np.eye(1), observation=np.eye(1), process_cov=np.array([[q**2]]),
                           obs_cov=var_obs.reshape(D, 1, 1), initial_mean=np.zeros(1),
                           initial_cov=np.array([[1e-16]]))


def smooth_through_time(daily_mean, daily_std, *, process_std=None) -> TemporalSettlement:
    """Smooth daily settlement posteriors across days, per station (random-walk model, module docstring).

    Parameters
    ----------
    daily_mean, daily_std : (D, N) array_like
        Daily posterior mean and std of the altitude change, m (day 0 is the reference, mean 0).
    process_std : float, optional
        q, m/day; estimated by maximum likelihood when None.

    Returns
    -------
    TemporalSettlement
    """
    mu = np.asarray(daily_mean, float)
    sd = np.asarray(daily_std, float)
    if mu.ndim != 2 or mu.shape != sd.shape:
        raise InputError(f"daily_mean and daily_std must be (D, N) of the same shape; got {mu.shape} and {sd.shape}.")
    D, N = mu.shape
    var = np.maximum(sd, 1e-7) ** 2

    def run(q, j):
        y = mu[:, j:j + 1]
        return shared_covariance_smoother(_station_model(var[:, j], q), y)

    if process_std is None:
        ll = [sum(run(q, j).filtered.log_likelihood for j in range(N)) for q in PROCESS_STD_GRID]
        q = PROCESS_STD_GRID[int(np.argmax(ll))]
    else:
        q = float(process_std)
        if not (np.isfinite(q) and q > 0):
            raise InputError(f"process_std must be > 0 (m/day); got {process_std!r}.")
    mean = np.empty((D, N)); std = np.empty((D, N))
    rate = np.full((D, N), np.nan); rate_std = np.full((D, N), np.nan)
    for j in range(N):
        sm = run(q, j)
        mean[:, j] = sm.mean[:, 0]
        P = sm.cov[:, 0, 0]
        std[:, j] = np.sqrt(P)
        if D > 1:
            rate[1:, j] = np.diff(sm.mean[:, 0])
            rate_std[1:, j] = np.sqrt(np.maximum(P[1:] + P[:-1] - 2 * sm.cross_cov[:, 0, 0], 0.0))
    return TemporalSettlement(mean=mean, std=std, rate=rate, rate_std=rate_std, process_std=q)


def _prob_abs_exceeds(mean, std, thr):
    std = np.maximum(std, 1e-300)
    return ndtr((-thr - mean) / std) + ndtr((mean - thr) / std)


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
        if not threshold_m > 0:
            raise InputError(f"the settlement threshold must be > 0 m; got {threshold_m!r}.")
        checks.append(("settlement", mean, std, float(threshold_m)))
    if rate_threshold_m_per_day is not None:
        if not rate_threshold_m_per_day > 0:
            raise InputError(f"the rate threshold must be > 0 m/day; got {rate_threshold_m_per_day!r}.")
        if rate is None:
            raise InputError("a rate threshold needs the rate posterior (temporal smoothing).")
        checks.append(("rate", rate, rate_std, float(rate_threshold_m_per_day)))
    for kind, m, s, thr in checks:
        with np.errstate(invalid="ignore"):
            p = _prob_abs_exceeds(m, s, thr)
        d_idx, j_idx = np.nonzero(np.nan_to_num(p) >= min_probability)
        for d, j in zip(d_idx, j_idx):
            rows.append((pd.Timestamp(days[d]).date().isoformat(), sensor_ids[j], float(x[j]), kind, float(m[d, j]),
                         thr, float(p[d, j])))
    df = pd.DataFrame(rows, columns=["date", "sensor_id", "x_m", "kind", "value", "threshold", "probability"])
    return df.sort_values(["date", "x_m", "kind"], kind="stable").reset_index(drop=True)
