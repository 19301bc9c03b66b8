"""International Roughness Index (ASTM E1926, World Bank Technical Paper 46): IRI, MRI, HRI.

The golden quarter car is a model; the recursion runs in the state-space engine
(:func:`longprofile.statespace.linear_recursion`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .._validation import require_positive
from ..errors import InputError
from ..statespace import linear_recursion
from ._profile import Profile

__all__ = [
    "GOLDEN_CAR",
    "IRI_SPEED",
    "golden_car_continuous",
    "golden_car_matrices",
    "IRIResult",
    "iri",
    "rectified_slope",
    "RectifiedSlope",
]

#: Golden quarter car of the IRI (Sayers et al. 1986, WTP-46; ASTM E1926): spring and damper rates per
#: unit sprung mass (k1 tyre, k2 suspension in 1/s^2, c in 1/s) and mass ratio mu = unsprung / sprung.
GOLDEN_CAR = {"k1": 653.0, "k2": 63.3, "c": 6.0, "mu": 0.15}
#: Simulated speed of the IRI, 80 km/h in m/s.
IRI_SPEED = 80.0 / 3.6

_CHUNK = 1 << 16  # steps per chunk of per-step matrices (bounded memory for irregular profiles)
_C_RV = np.array([[1.0, 0.0, -1.0, 0.0]])  # rectified-velocity output: sprung minus unsprung slope rate


def golden_car_continuous() -> tuple[np.ndarray, np.ndarray]:
    """Continuous golden-car model ``dz/dt = A z + B s`` with the input s = profile slope.

    Returns
    -------
    A : (4, 4) ndarray, 1/s
    B : (4,) ndarray, 1/s

    Notes
    -----
    State ``z = [zs', zs'', zu', zu'']/v`` as in WTP-46 (sprung and unsprung displacements differentiated once
    more and divided by the speed, so that the input is the profile slope)::

        A = [[0, 1, 0, 0], [-k2, -c, k2, c], [0, 0, 0, 1], [k2/mu, c/mu, -(k1+k2)/mu, -c/mu]]
        B = [0, 0, 0, k1/mu]
    """
    k1, k2, c, mu = (GOLDEN_CAR[k] for k in ("k1", "k2", "c", "mu"))
    a = np.array([[0.0, 1.0, 0.0, 0.0],
                  [-k2, -c, k2, c],
                  [0.0, 0.0, 0.0, 1.0],
                  [k2 / mu, c / mu, -(k1 + k2) / mu, -c / mu]])
    b = np.array([0.0, 0.0, 0.0, k1 / mu])
    return a, b


def golden_car_matrices(dx) -> tuple[np.ndarray, np.ndarray]:
    """Exact discrete golden car (WTP-46 ``ST`` and ``PR``) for a profile step ``dx``.

    Parameters
    ----------
    dx : float or (T,) array_like
        Step(s) between profile samples, m (> 0).

    Returns
    -------
    ST : (4, 4) or (T, 4, 4) ndarray
        State transition ``expm(A dx / v)``.
    PR : (4,) or (T, 4) ndarray
        Partial response ``A^-1 (ST - I) B``: the exact response to a slope held constant over the step
        (a profile linear between samples).

    Notes
    -----
    Both come from one matrix exponential of the augmented matrix ``[[A, B], [0, 0]] dx / v``
    (:func:`scipy.linalg.expm`; no inverse of A). For an array of steps the exponential is evaluated once per
    distinct step when there are at most 4096 of them; beyond that, by the eigendecomposition
    ``A = V diag(lambda) V^-1`` (the golden car has four distinct complex eigenvalues), which agrees with
    ``expm`` to about 1e-13 relative (tested). Reference: Sayers, Gillespie, Paterson (1986), WTP-46, p. 36
    (the published ST/PR for 0.25 m and 0.05 m are reproduced to their 7 digits, except the misprinted
    PR[0] at 0.05 m; see docs/road-indices.md).
    """
    from scipy.linalg import expm

    a, b = golden_car_continuous()
    aug = np.zeros((5, 5))
    aug[:4, :4] = a
    aug[:4, 4] = b
    steps = np.asarray(dx, dtype=float)
    if np.any(~np.isfinite(steps)) or np.any(steps <= 0):
        raise InputError("dx must be finite and > 0 m for every step.")
    if steps.ndim == 0:
        e = expm(aug * (float(steps) / IRI_SPEED))
        return e[:4, :4].copy(), e[:4, 4].copy()
    if steps.ndim != 1:
        raise InputError(f"dx must be a scalar or 1-D; got shape {steps.shape}.")
    uniq, inverse = np.unique(steps, return_inverse=True)
    if uniq.size <= 4096:
        e = np.stack([expm(aug * (h / IRI_SPEED)) for h in uniq])
        st_u, pr_u = e[:, :4, :4], e[:, :4, 4]
    else:
        lam, vec = np.linalg.eig(a)
        vinv = np.linalg.inv(vec)
        vb = vinv @ b
        tau = uniq[:, None] / IRI_SPEED
        ex = np.exp(lam[None, :] * tau)
        st_u = np.einsum("ij,tj,jk->tik", vec, ex, vinv).real
        pr_u = np.einsum("ij,tj,j->ti", vec, (ex - 1.0) / lam[None, :], vb).real
    return st_u[inverse], pr_u[inverse]


@dataclass(frozen=True, eq=False)
class RectifiedSlope:
    """Per-step output of the golden car run over a profile.

    Attributes
    ----------
    station : (M,) ndarray
        Stations of the simulated (smoothed) profile, m, including inserted segment boundaries.
    step : (M - 1,) ndarray
        Step lengths, m (``diff(station)``).
    rectified : (M - 1, K) ndarray
        ``|zs' - zu'|`` at the end of each step (the rectified slope RS of WTP-46), m/km.
    tracks : tuple of str
    moving_average : bool
        Whether the 250 mm moving average was applied.
    method : str
        ``"constant-step"`` (one ST/PR) or ``"per-step"`` (irregular stations).
    """

    station: np.ndarray
    step: np.ndarray
    rectified: np.ndarray
    tracks: tuple[str, ...]
    moving_average: bool
    method: str


@dataclass(frozen=True, eq=False)
class IRIResult:
    """IRI per segment and for the whole section.

    Attributes
    ----------
    segment_start, segment_end : (S,) ndarray
        Segment limits, m (complete segments only).
    iri : (S, K) ndarray
        IRI per segment and track, m/km (= mm/m).
    tracks : tuple of str
        Track names of the columns of ``iri``.
    section_iri : (K,) ndarray
        IRI over the whole profile (first to last simulated station), m/km.
    section_start, section_end : float
        Limits of the whole-section IRI, m.
    mri, hri : (S,) ndarray or None
        Mean Roughness Index (mean of the two tracks' IRI) and Half-car Roughness Index (IRI of the
        point-by-point mean of the two tracks), m/km; None unless exactly two tracks were analysed.
    section_mri, section_hri : float or None
        The same over the whole section.
    segment_length : float
        m.
    moving_average : bool
        Whether the 250 mm moving average was applied.
    base_length : float
        Moving-average base, m.
    lead_in : float
        Initialisation length, m.
    method : str
        ``"constant-step"`` or ``"per-step"``.
    """

    segment_start: np.ndarray
    segment_end: np.ndarray
    iri: np.ndarray
    tracks: tuple[str, ...]
    section_iri: np.ndarray
    section_start: float
    section_end: float
    mri: np.ndarray | None
    hri: np.ndarray | None
    section_mri: float | None
    section_hri: float | None
    segment_length: float
    moving_average: bool
    base_length: float
    lead_in: float
    method: str

    def to_frame(self) -> pd.DataFrame:
        """One row per segment: ``start_m, end_m, iri_<track>_m_per_km`` (and ``mri_m_per_km, hri_m_per_km``)."""
        cols = {"start_m": self.segment_start, "end_m": self.segment_end}
        for j, t in enumerate(self.tracks):
            cols[f"iri_{t}_m_per_km"] = self.iri[:, j]
        if self.mri is not None:
            cols["mri_m_per_km"] = self.mri
            cols["hri_m_per_km"] = self.hri
        return pd.DataFrame(cols)


def _select_tracks(profile: Profile, tracks) -> tuple[np.ndarray, tuple[str, ...]]:
    if tracks is None:
        names = profile.tracks
    else:
        names = (tracks,) if isinstance(tracks, str) else tuple(tracks)
        if not names:
            raise InputError("tracks must name at least one track.")
    z = np.column_stack([profile.track(t) for t in names])  # always a new array
    if np.isnan(z.sum()):  # one pass, no temporary (infinite values are refused by Profile)
        i, j = np.argwhere(np.isnan(z))[0]
        raise InputError(f"track {names[j]!r} has a missing (NaN) elevation at station {profile.distance[i]:.3f} m; "
                         "the IRI needs a continuous profile: cut the profile at the gap or fill it explicitly.")
    return z, names


def _box_average_irregular(x: np.ndarray, z: np.ndarray, base: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact centred moving average of the linear interpolant of z over ``base``, at the stations whose
    window lies inside the profile."""
    h = np.diff(x)
    cum = np.concatenate([np.zeros((1, z.shape[1])), np.cumsum(0.5 * h[:, None] * (z[1:] + z[:-1]), axis=0)])

    def integral(q):
        i = np.clip(np.searchsorted(x, q, side="right") - 1, 0, x.size - 2)
        t = (q - x[i])[:, None]
        slope = (z[i + 1] - z[i]) / h[i][:, None]
        return cum[i] + z[i] * t + 0.5 * slope * t * t

    keep = (x - 0.5 * base >= x[0] - 1e-12) & (x + 0.5 * base <= x[-1] + 1e-12)
    xs = x[keep]
    zs = (integral(np.minimum(xs + 0.5 * base, x[-1])) - integral(np.maximum(xs - 0.5 * base, x[0]))) / base
    return xs, zs


def _smooth(x, z, regular_dx, moving_average, base_length):
    """Apply the 250 mm moving average where the standard asks for it; return (x, z, applied)."""
    dx_ref = regular_dx if regular_dx is not None else float(np.median(np.diff(x)))
    n_base = max(1, int(np.floor(base_length / dx_ref + 0.5)))
    apply = (n_base > 1) if moving_average is None else bool(moving_average)
    if not apply:
        return x, z, False
    if regular_dx is not None:
        if n_base == 1:
            return x, z, True
        lo = (n_base - 1) // 2 if n_base % 2 else n_base // 2
        hi = n_base - 1 - lo
        if x.size <= n_base:
            raise InputError(f"the profile ({x.size} samples) is shorter than the moving-average base "
                             f"({n_base} samples of {regular_dx:g} m).")
        zs = np.lib.stride_tricks.sliding_window_view(z, n_base, axis=0).mean(axis=-1)  # no running-sum drift
        return x[lo:x.size - hi], zs, True
    xs, zs = _box_average_irregular(x, z, base_length)
    if xs.size < 2:
        raise InputError(f"the profile is shorter than the moving-average base ({base_length:g} m).")
    return xs, zs, True


def _insert_stations(x: np.ndarray, z: np.ndarray, new: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Insert stations (linear interpolation; the simulated profile is linear between samples)."""
    new = new[(new > x[0] + tol) & (new < x[-1] - tol)]
    if new.size == 0:
        return x, z
    i = np.clip(np.searchsorted(x, new), 1, x.size - 1)
    near = np.minimum(np.abs(x[i] - new), np.abs(x[i - 1] - new)) <= tol
    new = new[~near]
    if new.size == 0:
        return x, z
    zn = np.column_stack([np.interp(new, x, z[:, j]) for j in range(z.shape[1])])
    xa = np.concatenate([x, new])
    order = np.argsort(xa, kind="stable")
    return xa[order], np.concatenate([z, zn])[order]


def _run_golden_car(x: np.ndarray, z: np.ndarray, lead_in: float, regular: bool) -> tuple[np.ndarray, np.ndarray]:
    """Steps (M-1,) and rectified slope (M-1, K) in m/km for the profile (x, z), state carried through the run.

    Processed in chunks of ``_CHUNK`` steps (bounded temporaries that stay in cache); the state is carried
    exactly from one chunk to the next, so the result does not depend on the chunking.
    """
    if x[-1] - x[0] < lead_in:
        raise InputError(f"the profile is {x[-1] - x[0]:.3f} m long, shorter than the {lead_in:g} m lead-in used to "
                         "initialise the IRI; use a longer profile or a shorter lead_in.")
    h = np.diff(x)
    out = np.empty((z.shape[1], h.size)).T  # column-major: each track's output is contiguous
    if regular:
        st, pr = golden_car_matrices(float((x[-1] - x[0]) / h.size))
        pr = pr[:, None]
    for j in range(z.shape[1]):
        zj = z[:, j]
        s0 = (np.interp(x[0] + lead_in, x, zj) - zj[0]) / lead_in
        state = np.array([s0, 0.0, s0, 0.0])
        for a in range(0, h.size, _CHUNK):
            b = min(h.size, a + _CHUNK)
            slope = np.subtract(zj[a + 1:b + 1], zj[a:b])
            slope /= h[a:b]
            if regular:
                res = linear_recursion(st, pr, slope, state, output_matrix=_C_RV)
            else:
                st_k, pr_k = golden_car_matrices(h[a:b])
                res = linear_recursion(st_k, pr_k[:, :, None], slope, state, output_matrix=_C_RV)
            rv = res.outputs[:, 0]
            np.abs(rv, out=rv)
            np.multiply(rv, 1000.0, out=out[a:b, j])
            state = res.final_state
    return h, out


def _is_regular(x: np.ndarray) -> float | None:
    """Mean step if all steps agree with it to 1e-6 relative (the rule of ``Profile.spacing``), else None.

    Scans the steps in chunks (no full-size temporary)."""
    if x.size < 2:
        return None
    mean = (x[-1] - x[0]) / (x.size - 1)
    block = 4 * _CHUNK
    for a in range(0, x.size - 1, block):
        d = np.diff(x[a:a + block + 1])
        if d.max() - mean > 1e-6 * mean or mean - d.min() > 1e-6 * mean:
            return None
    return float(mean)


def rectified_slope(profile: Profile, *, tracks=None, lead_in: float = 11.0, moving_average: bool | None = None,
                    base_length: float = 0.25, extra_stations=None) -> RectifiedSlope:
    """Run the golden quarter car at 80 km/h over the profile and return the rectified slope per step.

    The building block of :func:`iri` and of the continuous (short-interval) IRI. Parameters as in
    :func:`iri`; ``extra_stations`` (m) are inserted by linear interpolation before the run (segment
    boundaries), which does not change the simulated states at the original stations.
    """
    return _rectified_slope(profile, tracks, lead_in, moving_average, base_length, extra_stations, None)


def _rectified_slope(profile, tracks, lead_in, moving_average, base_length, extra_stations, dx):
    """rectified_slope with the constant step ``dx`` already known (None: irregular or not yet checked)."""
    lead_in = require_positive("lead_in", lead_in)
    base_length = require_positive("base_length", base_length)
    z, names = _select_tracks(profile, tracks)
    z -= z[0]  # (a fresh copy) exact invariance to a constant; keeps averages and slopes free of cancellation
    x = profile.distance
    if x.size < 2:
        raise InputError("the profile needs at least 2 stations.")
    if dx is None:
        dx = _is_regular(x)
    xs, zs, applied = _smooth(x, z, dx, moving_average, base_length)
    tol = 1e-6 * (dx if dx is not None else float(np.min(np.diff(x))))
    inserted = False
    if extra_stations is not None:
        before = xs
        xs, zs = _insert_stations(xs, zs, np.asarray(extra_stations, dtype=float), tol)
        inserted = xs is not before
    regular = dx is not None and not inserted  # smoothing keeps a constant step; inserted stations break it
    h, rs = _run_golden_car(xs, zs, lead_in, regular)
    return RectifiedSlope(station=xs, step=h, rectified=rs, tracks=names, moving_average=applied,
                          method="constant-step" if regular else "per-step")


def _segment_means(station, step, values, bounds, tol):
    """Length-weighted mean of per-step values over [bounds[j], bounds[j+1]] (step assigned by its end).

    Every boundary inside the station range is a station (inserted before the run), so segment j covers
    the steps ``e_j .. e_{j+1} - 1`` with ``e_j`` the index of the station at ``bounds[j]``.
    """
    n_seg = bounds.size - 1
    out = np.full((n_seg, values.shape[1]), np.nan)
    if n_seg == 0:
        return out
    e = np.minimum(np.searchsorted(station, bounds - tol, side="left"), step.size)
    ok = e[1:] > e[:-1]
    starts = np.minimum(e[:-1], max(e[-1] - 1, 0))
    length = np.add.reduceat(step[:e[-1]], starts) if e[-1] > 0 else np.zeros(n_seg)
    for j in range(values.shape[1]):
        weighted = step[:e[-1]] * values[:e[-1], j]
        sums = np.add.reduceat(weighted, starts) if e[-1] > 0 else np.zeros(n_seg)
        out[ok, j] = sums[ok] / length[ok]
    return out


def iri(profile: Profile, *, segment_length: float = 100.0, tracks=None, start: float | None = None,
        lead_in: float = 11.0, moving_average: bool | None = None, base_length: float = 0.25) -> IRIResult:
    """International Roughness Index per fixed-length segment and for the whole section (ASTM E1926).

    Parameters
    ----------
    profile : Profile
        Longitudinal profile, elevations in m; stations may be irregular. No NaN in the tracks used.
    segment_length : float
        Length of the reporting segments, m (default 100).
    tracks : str or sequence of str, optional
        Tracks to analyse (default: all). With exactly two tracks the MRI and HRI are also returned.
    start : float, optional
        Station where the first segment starts, m (default: the first station). The simulation always starts
        at the first station; only the reporting grid moves.
    lead_in : float
        Length over which the initial slope is taken, m (ASTM E1926 / WTP-46: 11 m, i.e. 0.5 s at 80 km/h).
    moving_average : bool, optional
        Apply the 250 mm moving average. Default (None): as the standard asks, when the base covers at least
        two samples (``round(base_length / dx) >= 2``, i.e. dx < 0.167 m; median step for irregular stations).
    base_length : float
        Moving-average base, m (default 0.25).

    Returns
    -------
    IRIResult
        IRI in m/km (= mm/m) per complete segment and per track, whole-section IRI, MRI/HRI for two tracks.

    Raises
    ------
    InputError
        NaN elevations, a profile shorter than the lead-in, a start outside the profile.

    Notes
    -----
    WTP-46 (Sayers, Gillespie, Paterson 1986, section 3 and the IRI program p. 36) and ASTM E1926-08:

    1. smoothing (if applied): centred moving average over ``k = round(base/dx)`` samples on a constant step
       (equivalent to the WTP-46 slope ``(y[i+k] - y[i]) / (k dx)``); on irregular stations, the exact centred
       average of the linearly interpolated profile over ``base`` (assumption: the standard defines only the
       regular case);
    2. initial state ``z = [s0, 0, s0, 0]`` with ``s0`` the slope between the first station and the
       (interpolated) point ``lead_in`` metres ahead;
    3. for each step, ``z = ST z + PR s`` with ``s`` the profile slope over the step and ST/PR the exact
       matrix-exponential discretisation for that step's length (:func:`golden_car_matrices`), run by
       :func:`longprofile.statespace.linear_recursion` with the state carried through all segments;
    4. ``RS = |z1 - z3|``; the IRI over an interval is the step-length-weighted mean of RS over the steps
       ending in it (on a constant step: the plain mean of WTP-46), times 1000 for m/km.

    Segment boundaries that fall between samples are inserted as stations by linear interpolation, which
    is exact for the simulation (the profile is linear between samples) and splits the step between two
    segments. Only complete segments are reported; the whole-section IRI covers everything.

    References
    ----------
    M. W. Sayers, T. D. Gillespie, W. D. O. Paterson, Guidelines for Conducting and Calibrating Road Roughness
    Measurements, World Bank Technical Paper 46, 1986. ASTM E1926-08 (2015), Standard Practice for Computing
    International Roughness Index of Roads from Longitudinal Profile Measurements.
    M. W. Sayers, "On the calculation of IRI from longitudinal road profile", TRR 1501, 1995 (HRI, MRI).
    """
    segment_length = require_positive("segment_length", segment_length)
    x = profile.distance
    first = float(x[0]) if start is None else float(start)
    if not np.isfinite(first) or first < x[0] or first >= x[-1]:
        raise InputError(f"start must lie within the profile ({x[0]:.3f} .. {x[-1]:.3f} m); got {start!r}.")
    dx = _is_regular(x)
    tol = 1e-6 * (dx if dx is not None else float(np.min(np.diff(x))))
    n_seg = int(np.floor((x[-1] - first) / segment_length + 1e-9))
    bounds = first + segment_length * np.arange(n_seg + 1)
    rs = _rectified_slope(profile, tracks, lead_in, moving_average, base_length, bounds, dx)
    seg = _segment_means(rs.station, rs.step, rs.rectified, bounds, tol)
    section = (rs.step @ rs.rectified) / rs.step.sum()
    mri = hri = None
    section_mri = section_hri = None
    if len(rs.tracks) == 2:
        mri = seg.mean(axis=1)
        section_mri = float(section.mean())
        z = np.column_stack([profile.track(t) for t in rs.tracks]).mean(axis=1)
        half = Profile(distance=x, elevation=z, tracks=("half-car",))
        rh = _rectified_slope(half, None, lead_in, moving_average, base_length, bounds, dx)
        hri = _segment_means(rh.station, rh.step, rh.rectified, bounds, tol)[:, 0]
        section_hri = float((rh.step @ rh.rectified[:, 0]) / rh.step.sum())
    return IRIResult(segment_start=bounds[:-1], segment_end=bounds[1:], iri=seg, tracks=rs.tracks,
                     section_iri=section, section_start=float(rs.station[0]), section_end=float(rs.station[-1]),
                     mri=mri, hri=hri, section_mri=section_mri, section_hri=section_hri,
                     segment_length=segment_length, moving_average=rs.moving_average,
                     base_length=float(base_length), lead_in=float(lead_in), method=rs.method)
