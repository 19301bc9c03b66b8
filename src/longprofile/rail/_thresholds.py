"""Alarm thresholds by quantity and level: settlement, rate and twist; alert, action, alarm (beyond paper 004).

Monitoring of track works sets graded limits (e.g. alert 10 mm, action 15 mm, alarm 20 mm of settlement) on the
altitude change, its daily rate and the twist-like difference between neighbouring sensors. Each level of each
quantity is tested with :func:`~longprofile.rail.settlement_alarms` (exceedance probability of the 90 % posterior
of |value| over the threshold >= ``min_probability``): ``rail settle --thresholds FILE`` and the monitoring
service (``rail.service``, which decides the open level of the newest day) call the same function.

Twist-like: the difference of the altitude changes of neighbouring sensors over their own, irregular spacing (not
the twist of EN 13848-1, a difference of cross-level over a fixed base, which needs both rails: a standard twist limit
does not apply to it; docs/rail.md, step 9), with the std of independent errors, sqrt(s_i^2 + s_j^2): the neighbours'
errors are positively correlated, so this overstates the std (conservative on the mean, optimistic on the band).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from ..errors import InputError
from ._temporal import check_threshold, settlement_alarms

__all__ = ["THRESHOLD_QUANTITIES", "THRESHOLD_LEVELS", "check_thresholds", "threshold_alarms"]

#: Quantities with thresholds: |altitude change| (m), |daily rate| (m/day), |difference of neighbours' changes| (m).
THRESHOLD_QUANTITIES = ("settlement", "rate", "twist")
#: Levels, in increasing order of their thresholds.
THRESHOLD_LEVELS = ("alert", "action", "alarm")


def check_thresholds(thresholds: Mapping) -> dict:
    """Validated copy of ``{quantity: {level: value}}`` (m, m/day for the rate; :data:`THRESHOLD_QUANTITIES`,
    :data:`THRESHOLD_LEVELS`): every value plausible (:func:`check_threshold`) and the levels of a quantity
    growing alert <= action <= alarm. :class:`~longprofile.errors.InputError` otherwise."""
    if not isinstance(thresholds, Mapping):
        raise InputError(f"thresholds must be a mapping {{quantity: {{level: value}}}}; got {type(thresholds).__name__}.")
    out: dict = {}
    for q, levels in thresholds.items():
        if q not in THRESHOLD_QUANTITIES:
            raise InputError(f"unknown threshold quantity {q!r}; use {', '.join(THRESHOLD_QUANTITIES)}.")
        if not isinstance(levels, Mapping):
            raise InputError(f"thresholds[{q!r}] must map levels ({', '.join(THRESHOLD_LEVELS)}) to values.")
        for lv, v in levels.items():
            if lv not in THRESHOLD_LEVELS:
                raise InputError(f"unknown threshold level {lv!r} for {q}; use {', '.join(THRESHOLD_LEVELS)}.")
            out.setdefault(q, {})[lv] = check_threshold(v, q)
        vals = [out.get(q, {})[lv] for lv in THRESHOLD_LEVELS if lv in out.get(q, {})]
        if vals != sorted(vals):
            raise InputError(f"{q} thresholds must grow alert <= action <= alarm; got {out[q]}.")
    return out


def threshold_alarms(days, sensor_ids, x, mean, std, thresholds: Mapping, *, rate=None, rate_std=None,
                     min_probability: float = 0.5) -> pd.DataFrame:
    """Every level of every quantity's threshold tested on every day (:func:`settlement_alarms` per level).

    Parameters
    ----------
    days, sensor_ids, x, mean, std, rate, rate_std, min_probability
        As :func:`~longprofile.rail.settlement_alarms` (``mean``, ``std``: (D, N) altitude change posterior, m).
    thresholds : mapping
        ``{quantity: {level: value}}`` (:func:`check_thresholds`); a rate threshold needs ``rate``.

    Returns
    -------
    DataFrame
        The columns of :func:`settlement_alarms` plus ``level``; ``kind`` is the quantity; for the twist,
        ``sensor_id`` is the pair ``"a|b"`` and ``x_m`` its midpoint. Sorted by date, station, kind and level.
    """
    thr = check_thresholds(thresholds)
    x = np.asarray(x, float)
    ids = list(sensor_ids)
    series = {"settlement": (ids, x, mean, std),
              "twist": ([f"{a}|{b}" for a, b in zip(ids[:-1], ids[1:])], 0.5 * (x[1:] + x[:-1]),
                        np.diff(mean, axis=1), np.sqrt(std[:, 1:] ** 2 + std[:, :-1] ** 2))}
    parts = []
    for q in THRESHOLD_QUANTITIES:
        for lv in THRESHOLD_LEVELS:
            v = thr.get(q, {}).get(lv)
            if v is None:
                continue
            if q == "rate":
                a = settlement_alarms(days, ids, x, mean, std, rate=rate, rate_std=rate_std,
                                      rate_threshold_m_per_day=v, min_probability=min_probability)
            else:
                sid, xs, m, s = series[q]
                a = settlement_alarms(days, sid, xs, m, s, threshold_m=v, min_probability=min_probability)
                a["kind"] = q
            parts.append(a.assign(level=lv))
    cols = ["date", "sensor_id", "x_m", "kind", "level", "value", "threshold", "probability"]
    found = [p for p in parts if len(p)]  # (empty frames would turn the text columns to object dtype)
    if not found:
        return (parts[0] if parts else settlement_alarms(days[:0], ids, x, mean[:0], std[:0])).assign(level="")[cols]
    df = pd.concat(found, ignore_index=True)[cols]
    order = {lv: k for k, lv in enumerate(THRESHOLD_LEVELS)}
    df = df.assign(_lv=df["level"].map(order)).sort_values(["date", "x_m", "kind", "_lv"], kind="stable")
    return df.drop(columns="_lv").reset_index(drop=True)
