"""Control surveys against the estimate: the comparison table and a test of whether they agree (issue 13).

Paper 004 checks its estimates against topographic surveys of the track (Mittersheim, Farebersviller). The settlement
the tool prints rests on assumptions the angles cannot check by themselves: the span's ends do not move, and a
movement seen by one or two sensors is not a faulty sensor (docs/rail.md, "Assumptions"). A levelling of the track
during the works measures the altitude change directly, so it can. :func:`compare_controls` sets each control point
against the estimate (the control's change is its altitude minus the initial survey's at that station), and
:func:`check_controls` asks whether the differences are as small as the bands and the survey noise say.

The test: under the estimate's model the standardised differences z = (control - estimate) / sqrt(s^2 + 2 sigma_a^2)
(s the estimate's posterior std at the point, linearly interpolated between sensors; sigma_a the survey noise, once
for the control and once for the initial survey) are N(0, 1), and sum z^2 is chi-squared with one degree of freedom
per point. The estimate's errors are correlated along the track, the survey noises are not; with the survey noise
the larger term (2 sigma_a^2 = (2.8 mm)^2 at the default 2 mm, against a band std of 0.3-1 mm on the benchmark's
sites) the chi-squared law held: at ``CONTROL_CHECK_P`` = 1e-3 no site of 120 draws of six families whose
settlement is a bowl between stable ends was flagged (calibration seeds 300-319; docs/rail.md, "Control surveys").
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError
from ._results import ControlCheck
from ._rigidity import DEFAULT_SIGMA_A, Z90

__all__ = ["ControlCheck", "compare_controls", "check_controls", "common_offsets", "unmatched_controls",
           "CONTROL_CHECK_P", "OFFSET_SHARE", "OFFSET_MIN_POINTS", "OFFSET_MIN_RATIO"]

#: The control surveys disagree with the estimate when the chi-squared test of their standardised differences has a
#: p-value below this (module docstring).
CONTROL_CHECK_P = 1e-3

_COLUMNS = ["date", "x_m", "dz_control_m", "dz_estimate_m", "std_m", "z", "inside_90"]


def compare_controls(controls: pd.DataFrame | None, days, x, dz, dz_std, survey_x, survey_z, *,
                     sigma_a: float = DEFAULT_SIGMA_A) -> pd.DataFrame | None:
    """Each control point against the estimate: the table of :attr:`SettlementResult.controls`.

    Parameters
    ----------
    controls : DataFrame or None
        date, x_m, z_m (a validated site's ``controls``).
    days : (D,) datetime64 array
    x : (N,) ndarray
        Sensor stations, m.
    dz, dz_std : (D, N) ndarray
        The estimate's altitude change and its posterior std, m.
    survey_x, survey_z : ndarray
        The initial survey, m.
    sigma_a : float
        Survey noise std, m (``SettlementSettings.sigma_a``; the control's and the initial survey's).

    Returns
    -------
    DataFrame or None
        date, x_m, dz_control_m (the control's altitude minus the initial survey's, interpolated), dz_estimate_m and
        std_m (the estimate and its std, linearly interpolated between sensors), z (the standardised difference,
        module docstring) and inside_90 (|z| <= 1.645); None without a control point inside both spans on an
        estimated day.
    """
    if controls is None or len(controls) == 0:
        return None
    if not np.isfinite(sigma_a) or sigma_a <= 0:
        raise InputError(f"sigma_a must be a positive number of metres; got {sigma_a!r}.")
    sx, sz = np.asarray(survey_x, float), np.asarray(survey_z, float)
    dayidx = {pd.Timestamp(d): i for i, d in enumerate(pd.DatetimeIndex(days))}
    frames = []
    for date, g in controls.groupby("date"):
        d = dayidx.get(pd.Timestamp(date))
        g = g[(g["x_m"] >= max(x[0], sx[0])) & (g["x_m"] <= min(x[-1], sx[-1]))]
        if d is None or len(g) == 0:
            continue
        cx = g["x_m"].to_numpy(float)
        ctrl = g["z_m"].to_numpy(float) - np.interp(cx, sx, sz)
        est, sd = np.interp(cx, x, dz[d]), np.interp(cx, x, dz_std[d])
        z = (ctrl - est) / np.hypot(sd, np.sqrt(2.0) * sigma_a)
        frames.append(pd.DataFrame({"date": pd.Timestamp(date).date().isoformat(), "x_m": cx, "dz_control_m": ctrl,
                                    "dz_estimate_m": est, "std_m": sd, "z": z, "inside_90": np.abs(z) <= Z90}))
    return pd.concat(frames, ignore_index=True)[_COLUMNS] if frames else None


def unmatched_controls(controls: pd.DataFrame | None, table: pd.DataFrame | None, days) -> str:
    """A warning for the control points :func:`compare_controls` left out (empty when every point was compared): those
    on a day without readings, and those outside the sensors' or the initial survey's span."""
    if controls is None or len(controls) == 0:
        return ""
    n_given, n_used = len(controls), 0 if table is None else len(table)
    if n_used == n_given:
        return ""
    known = set(pd.DatetimeIndex(days).normalize())
    off_day = ~pd.to_datetime(controls["date"]).dt.normalize().isin(known)
    first, last = pd.Timestamp(min(known)).date(), pd.Timestamp(max(known)).date()
    dates = sorted({pd.Timestamp(d).date().isoformat() for d in controls.loc[off_day, "date"]})
    parts = []
    if off_day.any():
        parts.append(f"{int(off_day.sum())} on day(s) without readings ({', '.join(dates[:3])}"
                     f"{', ...' if len(dates) > 3 else ''}; the readings cover {first} to {last})")
    if n_given - n_used - int(off_day.sum()) > 0:
        parts.append(f"{n_given - n_used - int(off_day.sum())} outside the span of the sensors and the initial survey")
    return (f"{n_given - n_used} of {n_given} control point(s) not compared with the estimate: " + "; ".join(parts)
            + ". Check the controls' dates and stations.")


def check_controls(table: pd.DataFrame | None, *, p: float = CONTROL_CHECK_P) -> ControlCheck | None:
    """The chi-squared test of :func:`compare_controls`' standardised differences (module docstring).

    Parameters
    ----------
    table : DataFrame or None
        :func:`compare_controls`' table.
    p : float
        The test's level: the surveys disagree when the p-value is below it.

    Returns
    -------
    ControlCheck or None
        None without a table.
    """
    if table is None or len(table) == 0:
        return None
    if not 0 < p < 1:
        raise InputError(f"p must be in (0, 1); got {p!r}.")
    from scipy.special import chdtrc  # the chi-squared survival function (scipy.stats would add 0.24 s to start-up)

    z = table["z"].to_numpy(float)
    stat = float(np.sum(z**2))
    pv = float(chdtrc(z.size, stat))
    k = int(np.argmax(np.abs(z)))
    row = table.iloc[k]
    worst = (str(row["date"]), float(row["x_m"]), float(row["dz_control_m"] - row["dz_estimate_m"]), float(z[k]))
    return ControlCheck(n_points=int(z.size), n_outside=int((~table["inside_90"].to_numpy(bool)).sum()), chi2=stat,
                        p_value=pv, disagree=pv < p, worst=worst, offsets=common_offsets(table, p=p) if pv < p else ())


#: A survey's disagreement is "one offset" when removing its weighted mean difference leaves at most this share of its
#: chi-squared (or a chi-squared the test accepts): :func:`common_offsets`.
OFFSET_SHARE = 0.05
#: Fewest points of a survey for :func:`common_offsets` to call its disagreement an offset.
OFFSET_MIN_POINTS = 3
#: ... and the offset must be at least this many times the RMS of the points about it: on transitions and tilts with
#: 2 mm levelling (calibration seeds 300-319) offsets of 0.55-1.7 times their scatter passed the other criteria.
OFFSET_MIN_RATIO = 3.0


def common_offsets(table: pd.DataFrame, *, p: float = CONTROL_CHECK_P) -> tuple:
    """The surveys (dates) of :func:`compare_controls`' table that disagree with the estimate by one offset shared by
    all their points: controls levelled on another datum or benchmark than the initial survey (a user's probe,
    session 39: +0.3 m on every point was reported as "a span end that moved").

    A date with at least :data:`OFFSET_MIN_POINTS` points whose chi-squared fails the test at ``p`` is an offset when
    the differences minus their weighted mean c (weights 1 / (std_m^2 + 2 sigma_a^2), recovered from z) pass it
    (n - 1 degrees of freedom) or keep at most :data:`OFFSET_SHARE` of its chi-squared, and when |c| is at least
    :data:`OFFSET_MIN_RATIO` times the RMS of the differences about it. A moved end leaves a difference that grows
    along the span, a step one beyond a station: neither is removed by one constant much larger than what is left.

    Returns
    -------
    tuple of (date, offset_m, spread_m)
        c and the RMS of the differences around it, m, for each such date; empty when there is none.
    """
    from scipy.special import chdtrc

    out = []
    for date, g in table.groupby("date", sort=True):
        d, z = (g["dz_control_m"] - g["dz_estimate_m"]).to_numpy(float), g["z"].to_numpy(float)
        if d.size < OFFSET_MIN_POINTS or chdtrc(d.size, float(np.sum(z**2))) >= p:
            continue
        scale = np.abs(np.divide(d, z, out=np.full(d.shape, np.nan), where=z != 0))
        scale = np.where(np.isfinite(scale) & (scale > 0), scale, np.nanmedian(scale))
        w = 1.0 / scale**2
        c = float(np.sum(w * d) / np.sum(w))
        rest = float(np.sum(w * (d - c) ** 2))
        spread = float(np.sqrt(np.mean((d - c) ** 2)))
        if abs(c) >= OFFSET_MIN_RATIO * spread and (chdtrc(d.size - 1, rest) >= p
                                                    or rest <= OFFSET_SHARE * float(np.sum(z**2))):
            out.append((str(date), c, spread))
    return tuple(out)
