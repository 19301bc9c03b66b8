"""Faulting of jointed concrete pavements from a longitudinal profile (AASHTO R 36 practice)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..._validation import require_positive
from ...core import Profile
from ...errors import InputError

__all__ = ["FaultingResult", "find_joints", "joint_faulting", "step_statistic"]

_TOL = 1e-9  # m: a station within this of a window limit is inside the window


@dataclass(frozen=True, eq=False)
class FaultingResult:
    """Fault height at each joint.

    Attributes
    ----------
    joints : pandas.DataFrame
        ``joint_m, track, fault_m, residual_rms_m, n_samples``: fault = approach-side elevation minus
        leave-side elevation at the joint (positive: the slab after the joint, in the direction of increasing
        station, is lower).
    mean_fault : dict
        Per track, mean fault over the joints, m.
    mean_abs_fault : dict
        Per track, mean |fault|, m.
    metadata : dict
    """

    joints: pd.DataFrame
    mean_fault: dict
    mean_abs_fault: dict
    metadata: dict = field(default_factory=dict)


def joint_faulting(profile: Profile, joints, *, window: float = 0.3, gap: float = 0.05,
                   tracks=None) -> FaultingResult:
    """Fault height at given transverse joints: the step of a least-squares line with a step at the joint.

    Parameters
    ----------
    profile : Profile
        Stations increasing in the direction of traffic, m; elevations m.
    joints : (J,) array_like
        Joint stations, m (e.g. from an event file or a joint-detection step), inside the profile.
    window : float
        Length of profile used on each side of the joint, m (default 0.3 m; ASSUMPTION, see Notes).
    gap : float
        Length skipped on each side of the joint (the joint itself, the sensor footprint), m (default 0.05 m;
        ASSUMPTION).
    tracks : str or sequence of str, optional

    Returns
    -------
    FaultingResult

    Raises
    ------
    InputError
        A joint outside the profile or too close to its ends, a window with fewer than 2 samples per side.

    Notes
    -----
    AASHTO R 36 defines faulting as the difference in elevation across a transverse joint or crack (its
    Fig. 1), and its automated method estimates it from a profile (the ProVAL AFM algorithm, Chang et al.
    2012, ASTM STP 1555). Here the samples in ``[j - gap - window, j - gap]`` and ``[j + gap, j + gap + window]``
    are fitted in least squares by ``z = a + b (x - j) - F H(x - j)`` (one grade through both slabs, a step F
    at the joint), so a uniform grade does not bias F. The window, gap and one-grade model are longprofile
    choices (ASSUMPTION: R 36's automated-method constants were not confirmed here). Tested on synthetic
    steps on a grade with noise (exact recovery, and the least-squares error bound).
    """
    window = require_positive("window (m)", window)
    gap = require_positive("gap (m)", gap, strict=False)
    j_st = np.atleast_1d(np.asarray(joints, dtype=float))
    if j_st.ndim != 1 or not np.all(np.isfinite(j_st)):
        raise InputError("joints must be a 1-D list of finite stations, m.")
    x = profile.distance
    reach = gap + window
    bad = (j_st - reach < x[0]) | (j_st + reach > x[-1])
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(f"joint at {j_st[k]:g} m is outside the profile or closer than gap + window "
                         f"({reach:g} m) to its ends ({x[0]:g} .. {x[-1]:g} m).")
    names = profile.tracks if tracks is None else ((tracks,) if isinstance(tracks, str) else tuple(tracks))
    rows = []
    for t in names:
        z = profile.track(t)
        for j in j_st:
            before = (x >= j - reach - _TOL) & (x <= j - gap + _TOL)  # window limits inclusive (rounding)
            after = (x >= j + gap - _TOL) & (x <= j + reach + _TOL)
            m = before | after
            if before.sum() < 2 or after.sum() < 2:
                raise InputError(f"joint at {j:g} m: fewer than 2 samples on a side of it within the window "
                                 f"({window:g} m); use a longer window.")
            if np.isnan(z[m]).any():
                rows.append({"joint_m": j, "track": t, "fault_m": np.nan, "residual_rms_m": np.nan,
                             "n_samples": int(m.sum())})
                continue
            design = np.column_stack([np.ones(int(m.sum())), x[m] - j, -(x[m] > j).astype(float)])
            coef, *_ = np.linalg.lstsq(design, z[m], rcond=None)
            resid = z[m] - design @ coef
            rows.append({"joint_m": float(j), "track": t, "fault_m": float(coef[2]),
                         "residual_rms_m": float(np.sqrt(np.mean(resid * resid))), "n_samples": int(m.sum())})
    frame = pd.DataFrame(rows, columns=["joint_m", "track", "fault_m", "residual_rms_m", "n_samples"])
    mean = {t: float(np.nanmean(frame.fault_m[frame.track == t])) if (frame.track == t).any() else np.nan
            for t in names}
    mean_abs = {t: float(np.nanmean(np.abs(frame.fault_m[frame.track == t]))) for t in names}
    meta = {"practice": "AASHTO R 36 (faulting = elevation difference across the joint); step-line fit",
            "window_m": window, "gap_m": gap, "sign": "approach minus leave (positive: leave slab lower)"}
    return FaultingResult(joints=frame, mean_fault=mean, mean_abs_fault=mean_abs, metadata=meta)


def step_statistic(profile: Profile, track: str, *, window: float = 0.3, gap: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """The fault F of :func:`joint_faulting` evaluated with a joint at every station (vectorised).

    Parameters
    ----------
    profile : Profile
        Constant step, m.
    track : str
    window, gap : float
        As in :func:`joint_faulting`, m.

    Returns
    -------
    station : (M,) ndarray
        Stations where both windows fit, m.
    fault : (M,) ndarray
        Least-squares step there, m (approach minus leave).

    Notes
    -----
    Per station the 3x3 normal equations of ``z = a + b t - F H(t)`` (t = x - station) over the two windows are
    built from cumulative sums of 1, t, t^2, z, t z and solved at once (``numpy.linalg.solve`` on a stack);
    equal to :func:`joint_faulting` at every station (tested).
    """
    dx = profile.spacing
    if dx is None:
        raise InputError("step_statistic needs a constant sample interval; resample the profile first.")
    window = require_positive("window (m)", window)
    gap = require_positive("gap (m)", gap, strict=False)
    z = profile.track(track)
    if np.isnan(z).any():
        raise InputError(f"track {track!r} has missing (NaN) elevations; cut or fill them before finding joints.")
    x = profile.distance
    g = int(np.ceil(gap / dx - 1e-9))  # first sample at or beyond the gap
    w = int(np.floor((gap + window) / dx + 1e-9))  # last sample within gap + window
    if w - g + 1 < 2:
        raise InputError(f"window {window:g} m holds fewer than 2 samples of {dx:g} m on a side.")
    n = z.size
    centre = np.arange(w, n - w)
    if centre.size == 0:
        raise InputError("the profile is shorter than two windows.")
    k = np.arange(n, dtype=float)
    zc = z - z.mean()

    def csum(v):
        return np.concatenate([[0.0], np.cumsum(v)])

    c0, c1, c2, cz, ckz = csum(np.ones(n)), csum(k), csum(k * k), csum(zc), csum(k * zc)

    def side(lo, hi):  # sums over samples lo..hi (inclusive), in t = (k - centre) dx
        s0 = c0[hi + 1] - c0[lo]
        s1 = c1[hi + 1] - c1[lo] - centre * s0
        s2 = (c2[hi + 1] - c2[lo]) - 2 * centre * (c1[hi + 1] - c1[lo]) + centre ** 2 * s0
        sz = cz[hi + 1] - cz[lo]
        skz = ckz[hi + 1] - ckz[lo] - centre * sz
        return s0, s1 * dx, s2 * dx * dx, sz, skz * dx

    l0, l1, l2, lz, ltz = side(centre - w, centre - g)
    r0, r1, r2, rz, rtz = side(centre + g, centre + w)
    # unknowns (a, b, F) with the design row [1, t, -H]: H = 1 on the right window only
    m = np.empty((centre.size, 3, 3))
    m[:, 0, 0], m[:, 0, 1], m[:, 0, 2] = l0 + r0, l1 + r1, -r0
    m[:, 1, 1], m[:, 1, 2], m[:, 2, 2] = l2 + r2, -r1, r0
    m[:, 1, 0], m[:, 2, 0], m[:, 2, 1] = m[:, 0, 1], m[:, 0, 2], m[:, 1, 2]
    rhs = np.stack([lz + rz, ltz + rtz, -rz], axis=1)
    sol = np.linalg.solve(m, rhs[:, :, None])[:, :, 0]
    return x[centre], sol[:, 2]


def find_joints(profile: Profile, track: str, *, min_fault: float = 1e-3, min_spacing: float = 3.0,
                window: float = 0.3, gap: float = 0.05) -> np.ndarray:
    """Joint candidates: stations where |step statistic| peaks above ``min_fault``, at least ``min_spacing`` apart.

    Parameters
    ----------
    profile : Profile
        Constant step, m.
    track : str
    min_fault : float
        Smallest |fault| detected, m (default 1 mm; ASSUMPTION: a longprofile choice, not R 36's joint finder).
    min_spacing : float
        Smallest distance between joints, m (default 3 m, shorter than any jointed-slab length in use;
        ASSUMPTION).
    window, gap : float
        As in :func:`joint_faulting`.

    Returns
    -------
    (J,) ndarray
        Joint stations, m, increasing.

    Notes
    -----
    Only faulted joints are found (a joint without a step has no signature in this statistic); AASHTO R 36's
    automated method (ProVAL AFM) also uses the narrow dip at the saw cut, which is not modelled here. Peaks
    are taken greedily from the largest |F|, each suppressing its ``min_spacing`` neighbourhood; since F is
    flat while the true step lies inside the gap, a joint is placed at the middle of the run of stations where
    |F| is within 5 % of its peak (tested: within one sample of the true joint).
    """
    min_fault = require_positive("min_fault (m)", min_fault)
    min_spacing = require_positive("min_spacing (m)", min_spacing)
    st, f = step_statistic(profile, track, window=window, gap=gap)
    a = np.abs(f)
    cand = np.flatnonzero(a > min_fault)
    if cand.size == 0:
        return np.empty(0)
    order = cand[np.argsort(a[cand])[::-1]]
    free = np.ones(st.size, bool)
    chosen = []
    for i in order:
        if free[i]:
            # F is flat while the true step lies inside the gap: take the middle of the run within 5 % of the peak
            lo = hi = i
            while lo > 0 and a[lo - 1] >= 0.95 * a[i]:
                lo -= 1
            while hi < a.size - 1 and a[hi + 1] >= 0.95 * a[i]:
                hi += 1
            chosen.append(0.5 * (st[lo] + st[hi]))
            lo, hi = np.searchsorted(st, [st[i] - min_spacing, st[i] + min_spacing])
            free[lo:hi] = False
    return np.sort(np.array(chosen))
