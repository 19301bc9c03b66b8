"""International Roughness Index (ASTM E1926, World Bank Technical Paper 46): IRI, MRI, HRI.

The golden quarter car is a model; the recursion runs in the state-space engine
(:func:`longprofile.statespace.linear_recursion`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..._validation import require_positive
from ...core import Profile
from ...errors import InputError
from ...statespace import linear_recursion, linear_recursion_columns
from ._gaps import MIN_VALID_FRACTION, GappedIRI, GapSummary, gap_columns, gapped_iri, gaps_mode, min_valid_fraction

__all__ = [
    "AUTO_MOVING_AVERAGE_SHARE",
    "CONTINUOUS_WINDOW_M",
    "GOLDEN_CAR",
    "IRI_SPEED",
    "IRI_STEP_NOTE_M",
    "MAX_IRI_STEP_M",
    "MIN_IRI_INTERVAL_M",
    "iri_plausibility",
    "iri_notes",
    "sampling_note",
    "golden_car_continuous",
    "golden_car_matrices",
    "IRIResult",
    "IRIReport",
    "iri",
    "iri_report",
    "REPORT_UNITS",
    "rectified_slope",
    "RectifiedSlope",
]

#: Golden quarter car of the IRI (Sayers et al. 1986, WTP-46; ASTM E1926): spring and damper rates per
#: unit sprung mass (k1 tyre, k2 suspension in 1/s^2, c in 1/s) and mass ratio mu = unsprung / sprung.
GOLDEN_CAR = {"k1": 653.0, "k2": 63.3, "c": 6.0, "mu": 0.15}
#: Simulated speed of the IRI, 80 km/h in m/s.
IRI_SPEED = 80.0 / 3.6

#: Longest station step the IRI accepts anywhere in a profile, m (a longprofile assumption). The golden car
#: responds to waves down to about 1.3 m (wheel hop at 80 km/h); measured on an ISO 8608 class C road (10 km, the
#: same profile decimated, docs/road-indices.md "Station steps"): -1.7 % at 0.25 m, -2.9 % at 0.3 m, -7.7 % at
#: 0.5 m, -9.5 % at 1 m, -69 % at 2 m. A longer step is a gap (interpolated as a straight line, IRI about 0) or
#: stations in another unit under a metre label.
MAX_IRI_STEP_M = 1.0
#: Median station step above which the IRI is computed but noted as biased low (see :data:`MAX_IRI_STEP_M`).
IRI_STEP_NOTE_M = 0.3
#: IRI range of real roads, m/km (longprofile assumptions): unpaved roads stay below about 25 and the smoothest new
#: pavements are about 0.5; outside [0.2, 50] the usual cause is an elevation unit mistake (mm under a metre label
#: above, metres under a mm label below) or a profile that is not a road's (a smoothed or filtered series).
PLAUSIBLE_IRI_M_PER_KM = (0.2, 50.0)
#: Shortest segment or window of :func:`iri_report`, m: shorter, an IRI says nothing of roughness (the quarter car
#: integrates waves of 1.3-30 m) and is usually a unit mistake (0.1 given for 0.1 km).
MIN_IRI_INTERVAL_M = 1.0

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
    ``ST = expm(A tau)`` and ``PR = A^-1 (ST - I) B`` (tau = dx / v) by the eigendecomposition
    ``A = V diag(lambda) V^-1`` (the golden car has four distinct complex eigenvalues, cond(V) = 76):
    ``ST = V diag(exp(lambda tau)) V^-1`` and ``PR = V diag(expm1(lambda tau) / lambda) V^-1 B`` (no inverse of A;
    ``expm1`` keeps PR exact for short steps). It agrees with :func:`scipy.linalg.expm` of the augmented matrix
    ``[[A, B], [0, 0]] tau`` to 7e-15 relative from 0.1 mm to 5 m steps (tested against it as an oracle), and
    needs numpy only: importing scipy.linalg would add 0.1-0.15 s to every IRI command (issue 12). The
    eigendecomposition is computed once per process. Reference: Sayers, Gillespie, Paterson (1986), WTP-46, p. 36
    (the published ST/PR for 0.25 m and 0.05 m are reproduced to their 7 digits, except the misprinted
    PR[0] at 0.05 m; see docs/road-indices.md).
    """
    steps = np.asarray(dx, dtype=float)
    if np.any(~np.isfinite(steps)) or np.any(steps <= 0):
        raise InputError("dx must be finite and > 0 m for every step.")
    if steps.ndim > 1:
        raise InputError(f"dx must be a scalar or 1-D; got shape {steps.shape}.")
    vec, vinv, lam, vb = _golden_car_modes()
    uniq, inverse = np.unique(steps, return_inverse=True)
    z = lam[None, :] * (uniq[:, None] / IRI_SPEED)
    st_u = np.ascontiguousarray(np.einsum("ij,tj,jk->tik", vec, np.exp(z), vinv).real)
    pr_u = np.ascontiguousarray(np.einsum("ij,tj,j->ti", vec, np.expm1(z) / lam[None, :], vb).real)
    if steps.ndim == 0:
        return st_u[0], pr_u[0]
    return st_u[inverse], pr_u[inverse]


@functools.lru_cache(maxsize=1)
def _golden_car_modes() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(V, V^-1, lambda, V^-1 B)`` of the continuous golden car (:func:`golden_car_continuous`), read-only."""
    a, b = golden_car_continuous()
    lam, vec = np.linalg.eig(a)
    vinv = np.linalg.inv(vec)
    out = (vec, vinv, lam, vinv @ b)
    for arr in out:
        arr.flags.writeable = False
    return out


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
    moving_average_reason : str
        Why the moving average was (not) applied, in one sentence.
    """

    station: np.ndarray
    step: np.ndarray
    rectified: np.ndarray
    tracks: tuple[str, ...]
    moving_average: bool
    method: str
    moving_average_reason: str = ""


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
    moving_average_reason : str
        Why the moving average was (not) applied, in one sentence.
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
    moving_average_reason: str = ""
    valid_length: np.ndarray | None = None
    hri_valid_length: np.ndarray | None = None
    gaps: GapSummary | None = None

    def to_frame(self) -> pd.DataFrame:
        """One row per segment: ``start_m, end_m, iri_<track>_m_per_km`` (and ``mri_m_per_km, hri_m_per_km``); with
        ``gaps="restart"`` also ``valid_length_<track>_m`` (and ``valid_length_hri_m``), ``valid_fraction``,
        ``note``."""
        cols = {"start_m": self.segment_start, "end_m": self.segment_end}
        for j, t in enumerate(self.tracks):
            cols[f"iri_{t}_m_per_km"] = self.iri[:, j]
        if self.mri is not None:
            cols["mri_m_per_km"] = self.mri
            cols["hri_m_per_km"] = self.hri
        cols.update(_gap_columns(self.valid_length, self.hri_valid_length, self.tracks,
                                 self.segment_end - self.segment_start, self.gaps, "m"))
        return pd.DataFrame(cols)


def _gap_columns(valid, hri_valid, tracks, interval_length, gaps, unit) -> dict:
    """The ``valid_length_*``, ``valid_fraction`` and ``note`` columns of a table computed with gaps="restart"
    (none otherwise)."""
    if valid is None or gaps is None:
        return {}
    names = tuple(tracks)
    if hri_valid is not None:
        valid, names = np.column_stack([valid, hri_valid]), names + ("hri",)
    return gap_columns(valid, names, interval_length, gaps.min_valid, unit)


#: What a refusal of a profile with gaps says to do (the option of ``iri``, ``iri_report`` and the CLI).
GAPS_HINT = ("pass --gaps restart (gaps='restart') to compute the IRI over the measured parts, the quarter car "
             "restarted after each gap, or fill the gap explicitly")


def _select_tracks(profile: Profile, tracks, allow_nan: bool = False) -> tuple[np.ndarray, tuple[str, ...]]:
    if tracks is None:
        names = profile.tracks
    else:
        names = (tracks,) if isinstance(tracks, str) else tuple(tracks)
        if not names:
            raise InputError("tracks must name at least one track.")
    z = np.column_stack([profile.track(t) for t in names])  # always a new array
    if not allow_nan and np.isnan(z.sum()):  # one pass, no temporary (infinite values are refused by Profile)
        i, j = np.argwhere(np.isnan(z))[0]
        raise InputError(f"track {names[j]!r} has a missing (NaN) elevation at station {profile.distance[i]:.3f} m; "
                         f"the IRI needs a continuous profile: {GAPS_HINT}.")
    return z, names


#: Share of the steps (by count) that must be short enough for the standard's rule to average them before the
#: "auto" moving average is applied to an irregular profile (a longprofile assumption; see :func:`iri_report`).
AUTO_MOVING_AVERAGE_SHARE = 0.10
#: Largest station interval of the smoothed irregular profile, as a fraction of the moving-average base.
_SMOOTH_SUBSTEP = 1.0 / 8.0


def _moving_average_mode(value) -> str:
    """Normalise ``moving_average``: "auto"/"on"/"off", or None/True/False of the :func:`iri` API."""
    if value is None:
        return "auto"
    if isinstance(value, (bool, np.bool_)):
        return "on" if value else "off"
    if isinstance(value, str) and value.strip().lower() in ("auto", "on", "off"):
        return value.strip().lower()
    raise InputError(f"moving_average must be 'auto', 'on' or 'off' (or None/True/False); got {value!r}.")


def _averaged_steps(h: np.ndarray, base: float) -> np.ndarray:
    """Steps the standard's rule would smooth: ``k = round(base / h) >= 2`` samples in the base (h <= base/1.5)."""
    return np.floor(base / h + 0.5) >= 2


def _moving_average_rule(base: float) -> str:
    return (f"ASTM E1926 / WTP-46: {base * 1000:g} mm moving average over k = round({base:g} m / dx) samples, "
            f"which smooths only when k >= 2 (dx <= {base / 1.5:.4g} m); irregular stations: applied when at least "
            f"{AUTO_MOVING_AVERAGE_SHARE:.0%} of the steps are that short (longprofile assumption), as the exact "
            f"{base * 1000:g} mm average of the linearly interpolated profile")


def _decide_moving_average(x: np.ndarray, regular_dx: float | None, mode: str, base: float) -> tuple[bool, str]:
    """Whether to apply the moving average, and why (one sentence for the metadata and the CLI summary)."""
    if regular_dx is not None:
        k = max(1, int(np.floor(base / regular_dx + 0.5)))
        plural = "s" if k > 1 else ""
        where = f"constant step {regular_dx:.6g} m: the {base * 1000:g} mm base holds k = {k} sample{plural}"
        if mode == "on":
            return True, f"forced on; {where}" + (" (a 1-sample average leaves the profile unchanged)" * (k == 1))
        if mode == "off":
            return False, f"forced off; {where}"
        return (k >= 2), f"{where} -> " + ("applied" if k >= 2 else "not needed (k = 1), as in the standard's program")
    h = np.diff(x)
    short = _averaged_steps(h, base)
    count_share = float(short.mean())
    length_share = float(h[short].sum() / h.sum())
    where = (f"irregular stations: {count_share:.1%} of the steps ({length_share:.1%} of the length) are "
             f"<= {base / 1.5:.4g} m, short enough for the standard to average them")
    if mode == "on":
        return True, f"forced on; {where}"
    if mode == "off":
        return False, f"forced off; {where}"
    apply = count_share >= AUTO_MOVING_AVERAGE_SHARE
    return apply, f"{where} -> {'>=' if apply else '<'} {AUTO_MOVING_AVERAGE_SHARE:.0%}: " + (
        "applied" if apply else "not applied")


def _box_average_irregular(x: np.ndarray, z: np.ndarray, base: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact centred moving average ``S(q) = (1/base) * integral of the interpolant over [q - base/2, q + base/2]``.

    S is piecewise quadratic with knots at the stations and at the stations +- base/2; it is sampled at every
    knot whose window lies inside the profile and, between knots, at most ``base / 8`` apart, so that the
    car driven by its linear interpolant sees S within about 0.05 % in IRI (measured against a 5 mm grid).
    """
    lo, hi = x[0] + 0.5 * base, x[-1] - 0.5 * base
    if hi - lo <= 1e-9 * base:
        raise InputError(f"the profile ({x[-1] - x[0]:.3f} m) is shorter than the moving-average base ({base:g} m).")
    knots = np.concatenate([x[(x > lo) & (x < hi)], x[x < hi] + 0.5 * base, x[x > lo] - 0.5 * base, [lo, hi]])
    knots = np.unique(knots[(knots >= lo) & (knots <= hi)])
    knots = knots[np.concatenate([[True], np.diff(knots) > 1e-6 * base])]
    gaps = np.diff(knots)
    n = np.maximum(1, np.ceil(gaps / (_SMOOTH_SUBSTEP * base) - 1e-9).astype(np.int64))
    first = np.repeat(np.cumsum(n) - n, n)
    frac = (np.arange(int(n.sum())) - first) / np.repeat(n, n)
    q = np.append(np.repeat(knots[:-1], n) + frac * np.repeat(gaps, n), knots[-1])
    h = np.diff(x)
    cum = np.concatenate([np.zeros((1, z.shape[1])), np.cumsum(0.5 * h[:, None] * (z[1:] + z[:-1]), axis=0)])

    def integral(p):
        i = np.clip(np.searchsorted(x, p, side="right") - 1, 0, x.size - 2)
        t = (p - x[i])[:, None]
        slope = (z[i + 1] - z[i]) / h[i][:, None]
        return cum[i] + z[i] * t + 0.5 * slope * t * t

    zs = (integral(np.minimum(q + 0.5 * base, x[-1])) - integral(np.maximum(q - 0.5 * base, x[0]))) / base
    return q, zs


def _moving_mean(z: np.ndarray, n: int) -> np.ndarray:
    """Mean of ``n`` consecutive rows of ``z`` (N, K): (N - n + 1, K), row i the mean of rows i .. i + n - 1.

    The WTP-46 / ASTM E1926 moving average on a constant step, as a sum of the ``n`` shifted slices in row order
    divided by ``n`` (no running-sum drift): the same additions in the same order as
    ``sliding_window_view(z, n, axis=0).mean(axis=-1)`` on a C-ordered z of two or more columns (bit-identical,
    tested; otherwise within 1e-15 relative), without its per-window reduction overhead.
    """
    m = z.shape[0] - n + 1
    out = z[:m].copy()
    for i in range(1, n):
        out += z[i:i + m]
    out /= n
    return out


def _smooth(x, z, regular_dx, moving_average, base_length):
    """Apply the 250 mm moving average where the rule asks for it; return (x, z, applied, reason)."""
    apply, reason = _decide_moving_average(x, regular_dx, _moving_average_mode(moving_average), base_length)
    if not apply:
        return x, z, False, reason
    if regular_dx is not None:
        n_base = max(1, int(np.floor(base_length / regular_dx + 0.5)))
        if n_base == 1:
            return x, z, True, reason
        lo = (n_base - 1) // 2 if n_base % 2 else n_base // 2
        hi = n_base - 1 - lo
        if x.size <= n_base:
            raise InputError(f"the profile ({x.size} samples) is shorter than the moving-average base "
                             f"({n_base} samples of {regular_dx:g} m).")
        return x[lo:x.size - hi], _moving_mean(z, n_base), True, reason
    xs, zs = _box_average_irregular(x, z, base_length)
    return xs, zs, True, reason


def _insert_stations(x: np.ndarray, z: np.ndarray, new: np.ndarray,
                     tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Insert stations (linear interpolation; the simulated profile is linear between samples).

    Returns the stations, elevations and a mask of the inserted stations (None when nothing was inserted)."""
    new = np.unique(new[(new > x[0] + tol) & (new < x[-1] - tol)])
    new = new[np.concatenate([[True], np.diff(new) > tol])] if new.size else new  # no near-duplicate stations
    if new.size == 0:
        return x, z, None
    i = np.clip(np.searchsorted(x, new), 1, x.size - 1)
    near = np.minimum(np.abs(x[i] - new), np.abs(x[i - 1] - new)) <= tol
    new = new[~near]
    if new.size == 0:
        return x, z, None
    zn = np.column_stack([np.interp(new, x, z[:, j]) for j in range(z.shape[1])])
    xa = np.concatenate([x, new])
    order = np.argsort(xa, kind="stable")
    mask = np.zeros(xa.size, dtype=bool)
    mask[x.size:] = True
    return xa[order], np.concatenate([z, zn])[order], mask[order]


def _golden_car_step_matrices(dx: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`golden_car_matrices` of one constant step, cached (read-only arrays; many short runs share it)."""
    key = float(dx)
    hit = _STEP_MATRICES.get(key)
    if hit is None:
        st, pr = golden_car_matrices(key)
        st.flags.writeable = False
        pr = pr[:, None]
        pr.flags.writeable = False
        if len(_STEP_MATRICES) >= 64:
            _STEP_MATRICES.clear()
        hit = _STEP_MATRICES[key] = (st, pr)
    return hit


_STEP_MATRICES: dict[float, tuple[np.ndarray, np.ndarray]] = {}


def _run_golden_car(x: np.ndarray, z: np.ndarray, lead_in: float, regular: bool) -> tuple[np.ndarray, np.ndarray]:
    """Steps (M-1,) and rectified slope (M-1, K) in m/km for the profile (x, z), state carried through the run.

    Processed in chunks of ``_CHUNK`` steps (bounded temporaries that stay in cache); the state is carried
    exactly from one chunk to the next, so the result does not depend on the chunking. On a constant step all
    tracks run together (:func:`longprofile.statespace.linear_recursion_columns`, the same numbers as one
    :func:`~longprofile.statespace.linear_recursion` per track).
    """
    if x[-1] - x[0] < lead_in:
        raise InputError(f"the profile is {x[-1] - x[0]:.3f} m long, shorter than the {lead_in:g} m lead-in used to "
                         "initialise the IRI; use a longer profile or a shorter lead_in.")
    h = np.diff(x)
    out = np.empty((z.shape[1], h.size)).T  # column-major: each track's output is contiguous
    s0 = np.array([(np.interp(x[0] + lead_in, x, z[:, j]) - z[0, j]) / lead_in for j in range(z.shape[1])])
    if regular:
        state = np.column_stack([s0, np.zeros_like(s0), s0, np.zeros_like(s0)])
        _constant_step_run(h, z, _golden_car_step_matrices((x[-1] - x[0]) / h.size), state, out)
        return h, out
    for j in range(z.shape[1]):
        zj = z[:, j]
        state = np.array([s0[j], 0.0, s0[j], 0.0])
        for a in range(0, h.size, _CHUNK):
            b = min(h.size, a + _CHUNK)
            slope = np.subtract(zj[a + 1:b + 1], zj[a:b])
            slope /= h[a:b]
            st_k, pr_k = golden_car_matrices(h[a:b])
            res = linear_recursion(st_k, pr_k[:, :, None], slope, state, output_matrix=_C_RV)
            rv = res.outputs[:, 0]
            np.abs(rv, out=rv)
            np.multiply(rv, 1000.0, out=out[a:b, j])
            state = res.final_state
    return h, out


def _constant_step_run(h, z, matrices, state, out) -> np.ndarray:
    """The constant-step golden car over the steps ``h`` (S,) of the smoothed tracks ``z`` (S + 1, C) from the
    states ``state`` (C, 4): writes the rectified slope (m/km) into ``out`` (S, C), returns the final states."""
    st, pr = matrices
    for a in range(0, h.size, _CHUNK):
        b = min(h.size, a + _CHUNK)
        slope = np.subtract(z[a + 1:b + 1], z[a:b])
        slope /= h[a:b, None]
        res = linear_recursion_columns(st, pr, slope, state, _C_RV)
        rv = res.outputs[:, :, 0]
        np.abs(rv, out=rv)
        np.multiply(rv, 1000.0, out=out[a:b])
        state = res.final_state
    return state


@dataclass(frozen=True, eq=False)
class _SharedStart:
    """The golden-car run of a constant-step profile up to the first sample that candidate profiles change
    (:func:`_shared_start`): what :func:`_resume` needs to run only the rest of each candidate."""

    station: np.ndarray  # stations of the smoothed profile (M,), as in RectifiedSlope
    step: np.ndarray  # (M - 1,)
    z0: np.ndarray  # elevation of the first sample of each track (K,)
    steps: int  # number of steps (of the smoothed profile) that no candidate changes
    rectified: np.ndarray  # (steps, K) rectified slope of those steps, m/km
    state: np.ndarray  # (K, 4) golden-car states after those steps
    n_base: int  # samples per moving-average window (1: none)
    matrices: tuple


def _shared_start(x, z, dx, first_changed, lead_in=11.0, moving_average=None, base_length=0.25):
    """:class:`_SharedStart` of the constant-step profile ``(x, z)`` (N, K) whose candidates differ from it only
    from the sample ``first_changed`` on (None when the shortcut does not apply: irregular stations, or a change
    that reaches the lead-in of the initial slope). For the grinding search: the car is causal, so the states
    before the first change are those of the unchanged profile; each operation is the one :func:`_run_arrays`
    does (the same numbers bit for bit, tested)."""
    if dx is None or first_changed is None:
        return None
    xsm, zsm, _, _ = _smooth(x, z - z[0], dx, moving_average, base_length)
    n_base = x.size - xsm.size + 1
    steps = first_changed - n_base  # step i uses the smoothed samples i, i + 1 (raw samples i .. i + n_base)
    if steps < 1 or not xsm[steps] > xsm[0] + lead_in:  # initial slope from unchanged samples only
        return None
    h = np.diff(xsm)
    zp = zsm[:steps + 1]
    s0 = np.array([(np.interp(xsm[0] + lead_in, xsm[:steps + 1], zp[:, j]) - zp[0, j]) / lead_in
                   for j in range(z.shape[1])])
    state = np.column_stack([s0, np.zeros_like(s0), s0, np.zeros_like(s0)])
    matrices = _golden_car_step_matrices((xsm[-1] - xsm[0]) / h.size)
    rect = np.empty((z.shape[1], steps)).T
    state = _constant_step_run(h[:steps], zp, matrices, state, rect)
    return _SharedStart(station=xsm, step=h, z0=z[0].copy(), steps=steps, rectified=rect, state=state,
                        n_base=n_base, matrices=matrices)


def _resume(shared: _SharedStart, z_rest: np.ndarray) -> np.ndarray:
    """Rectified slope (m/km) of the steps ``steps ..`` of candidate profiles, column ``i K + j`` a candidate of
    track j that equals it before ``first_changed`` (:func:`_shared_start`), given their samples ``steps .. N - 1``
    only: ``z_rest`` (N - steps, n K), changed in place; run from the shared states. With ``shared.rectified``
    before them, the ``rectified`` of :func:`_run_arrays` on the whole candidates."""
    n_cand = z_rest.shape[1] // shared.z0.size
    z_rest -= np.tile(shared.z0, n_cand)  # the first sample, unchanged (as z -= z[0] in _run_arrays)
    zsm = _moving_mean(z_rest, shared.n_base) if shared.n_base > 1 else z_rest
    out = np.empty((z_rest.shape[1], shared.step.size - shared.steps)).T
    _constant_step_run(shared.step[shared.steps:], zsm, shared.matrices, np.tile(shared.state, (n_cand, 1)), out)
    return out


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
    return _run(profile, tracks, lead_in, moving_average, base_length, extra_stations, dx)[0]


def _check_steps(x: np.ndarray, gaps_allowed: bool = False) -> None:
    """Refuse a station step longer than :data:`MAX_IRI_STEP_M`: a coarse profile (its median step), or gaps (unless
    ``gaps_allowed``: ``gaps="restart"`` splits the profile there)."""
    h = np.diff(x)
    k = int(np.argmax(h))
    if h[k] <= MAX_IRI_STEP_M:
        return
    med = float(np.median(h))
    if med > MAX_IRI_STEP_M:
        raise InputError(f"the profile is sampled every {med:.4g} m: the IRI needs stations at most "
                         f"{MAX_IRI_STEP_M:g} m apart (the quarter car responds to waves down to about 1.3 m; at 2 m the "
                         "IRI of a class C road comes out 69 % low). Stations in mm or ft under a metre label? Name the "
                         "column with its unit (distance_mm, distance_ft).")
    if gaps_allowed:
        return
    n = int(np.count_nonzero(h > MAX_IRI_STEP_M))
    raise InputError(f"the profile has {n} gap(s) longer than {MAX_IRI_STEP_M:g} m between stations (the longest "
                     f"{h[k]:.4g} m from station {x[k]:.3f} m; the median step is {med:.4g} m): across a gap the IRI "
                     f"would be that of a straight line (about 0). Cut the profile at the gap(s) and analyse each "
                     f"part, or {GAPS_HINT}.")


def sampling_note(profile: Profile) -> str | None:
    """A note when the profile's median station step exceeds :data:`IRI_STEP_NOTE_M` (the IRI is then biased
    low: -7.7 % at 0.5 m, -9.5 % at 1 m on a class C road), else None. Steps above :data:`MAX_IRI_STEP_M` are
    refused by :func:`iri` and :func:`iri_report`."""
    x = profile.distance
    if x.size < 2:
        return None
    med = float(np.median(np.diff(x)))
    if med <= IRI_STEP_NOTE_M:
        return None
    return (f"the profile is sampled every {med:.3g} m, above {IRI_STEP_NOTE_M:g} m: its IRI is biased low (on a class "
            "C road -7.7 % at 0.5 m, -9.5 % at 1 m; docs/road-indices.md, \"Station steps\").")


def iri_plausibility(iri_m_per_km, *, what: str = "section IRI") -> str:
    """One sentence when an IRI value (m/km; any shape, e.g. one per track) lies outside any road's range
    (:data:`PLAUSIBLE_IRI_M_PER_KM`), naming the likely unit mistake; "" when all are plausible (NaN ignored).
    ``what`` names the values in the sentence."""
    v = np.asarray(iri_m_per_km, float).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return ""
    lo, hi = PLAUSIBLE_IRI_M_PER_KM
    if v.max() > hi:
        return (f"{what} {v.max():.3g} m/km is beyond any road (unpaved roads are below about 25 m/km): check "
                "the elevation unit in the column names (e.g. left_mm).")
    if v.min() < lo:
        return (f"{what} {v.min():.3g} m/km is below any paved road (the smoothest new pavements are about "
                "0.5 m/km): elevations in metres under a mm label (e.g. left_mm holding metres), or a smoothed "
                "series rather than a measured profile?")
    return ""


def iri_notes(result, profile: Profile) -> tuple[str, ...]:
    """The warnings of ``longprofile road iri`` and ``road report`` about an IRI and the profile it was computed on,
    in the order they are printed: a dropout written as a held value (:func:`~longprofile.road.dropout_note`), a
    section IRI out of any road's range (:func:`iri_plausibility`), stations coarse enough to bias the IRI low
    (:func:`sampling_note`). ``batch iri`` writes the same sentences to its manifest.

    Parameters
    ----------
    result : IRIReport or IRIResult
        The IRI (its ``section_iri``, in in/mi when ``result.units == "us"``, else m/km).
    profile : Profile
        The profile it was computed on.

    Returns
    -------
    tuple of str
        The non-empty sentences (empty tuple when there is nothing to look at).
    """
    from ._dropouts import dropout_note

    factor = REPORT_UNITS["us"]["iri_per_m_per_km"] if getattr(result, "units", "si") == "us" else 1.0
    notes = (dropout_note(profile), iri_plausibility([v / factor for v in result.section_iri]),
             sampling_note(profile))
    return tuple(n for n in notes if n)


def _run(profile, tracks, lead_in, moving_average, base_length, extra_stations, dx):
    """(RectifiedSlope, mask of the inserted stations or None)."""
    lead_in = require_positive("lead_in", lead_in)
    base_length = require_positive("base_length", base_length)
    z, names = _select_tracks(profile, tracks)
    x = profile.distance
    if x.size < 2:
        raise InputError("the profile needs at least 2 stations.")
    _check_steps(x)
    if dx is None:
        dx = _is_regular(x)
    return _run_arrays(x, z, names, lead_in, moving_average, base_length, extra_stations, dx)


def _run_arrays(x, z, names, lead_in, moving_average, base_length, extra_stations, dx):
    """:func:`_run` on validated arrays: stations x (N,), a fresh float array z (N, K) without NaN (changed in
    place), ``dx`` = ``_is_regular(x)``; for callers that run many short profiles (the grinding search)."""
    z -= z[0]  # (a fresh copy) exact invariance to a constant; keeps averages and slopes free of cancellation
    xs, zs, applied, reason = _smooth(x, z, dx, moving_average, base_length)
    tol = 1e-6 * (dx if dx is not None else float(np.min(np.diff(x))))
    mask = None
    if extra_stations is not None:
        xs, zs, mask = _insert_stations(xs, zs, np.asarray(extra_stations, dtype=float), tol)
    regular = dx is not None and mask is None  # smoothing keeps a constant step; inserted stations break it
    h, rs = _run_golden_car(xs, zs, lead_in, regular)
    return RectifiedSlope(station=xs, step=h, rectified=rs, tracks=names, moving_average=applied,
                          method="constant-step" if regular else "per-step", moving_average_reason=reason), mask


def _segment_sums(station, step, values, bounds, tol):
    """Integral of per-step values (step assigned by its end) and length covered over each [bounds[j], bounds[j+1]]:
    ``(sums (S, K), length (S,))``, both 0 for a segment the stations do not reach.

    Every boundary inside the station range is a station (inserted before the run), so segment j covers
    the steps ``e_j .. e_{j+1} - 1`` with ``e_j`` the index of the station at ``bounds[j]``.
    """
    n_seg = bounds.size - 1
    sums = np.zeros((max(n_seg, 0), values.shape[1]))
    if n_seg <= 0:
        return sums, np.zeros(0)
    e = np.minimum(np.searchsorted(station, bounds - tol, side="left"), step.size)
    ok = e[1:] > e[:-1]
    length = np.zeros(n_seg)
    if ok.any():  # the segments reached are contiguous runs of steps: one reduceat over them
        first, end = e[:-1][ok], int(e[1:][ok][-1])
        length[ok] = np.add.reduceat(step[:end], first)
        for j in range(values.shape[1]):
            sums[ok, j] = np.add.reduceat(step[:end] * values[:end, j], first)
    return sums, length


def _segment_means(station, step, values, bounds, tol):
    """Length-weighted mean of per-step values over [bounds[j], bounds[j+1]] (:func:`_segment_sums`; NaN where
    the stations do not reach)."""
    sums, length = _segment_sums(station, step, values, bounds, tol)
    out = np.full(sums.shape, np.nan)
    ok = length > 0
    out[ok] = sums[ok] / length[ok, None]
    return out


def _mri_hri(profile, rs, values, section, run_half, per_interval, factor=None):
    """MRI and HRI of a two-track run (Sayers, TRR 1501, 1995): ``(mri, hri, section_mri, section_hri)``.

    ``values``/``section``: the per-interval and section IRI of the tracks (already in the report unit);
    ``run_half(profile) -> (RectifiedSlope, mask)`` runs the golden car on the half-car (mean) profile with the
    same settings; ``per_interval(rectified_slope, mask)`` averages it per interval; ``factor`` converts the
    half-car values from m/km to the report unit (None: m/km). All None unless there are exactly two tracks.
    """
    if len(rs.tracks) != 2:
        return None, None, None, None
    mri = values.mean(axis=1)
    section_mri = float(section.mean())
    z = np.column_stack([profile.track(t) for t in rs.tracks]).mean(axis=1)
    half = Profile(distance=profile.distance, elevation=z, tracks=("half-car",))
    rh, mh = run_half(half)
    hri = per_interval(rh, mh)[:, 0]
    section_hri = (rh.step @ rh.rectified[:, 0]) / rh.step.sum()
    if factor is not None:
        hri = hri * factor
        section_hri = section_hri * factor
    return mri, hri, section_mri, float(section_hri)


def _gapped(profile, tracks, lead_in, moving_average, base_length, extra, starts_m, ends_m, min_valid, factor,
            per_interval):
    """The gaps="restart" computation of :func:`iri` and :func:`iri_report` (:func:`~._gaps.gapped_iri`): the
    checks of :func:`_run` (the station steps as gaps), then the golden car per run of measured samples."""
    lead_in = require_positive("lead_in", lead_in)
    base_length = require_positive("base_length", base_length)
    _moving_average_mode(moving_average)
    z, names = _select_tracks(profile, tracks, allow_nan=True)
    x = profile.distance
    _check_steps(x, gaps_allowed=True)
    return gapped_iri(x, z, names, lead_in=lead_in, moving_average=moving_average, base_length=base_length,
                      extra_stations=extra, per_interval=per_interval, starts_m=starts_m, ends_m=ends_m,
                      min_valid=min_valid, factor=factor)


def iri(profile: Profile, *, segment_length: float = 100.0, tracks=None, start: float | None = None,
        lead_in: float = 11.0, moving_average: bool | None = None, base_length: float = 0.25, gaps: str = "refuse",
        min_valid: float = MIN_VALID_FRACTION) -> IRIResult:
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
    moving_average : {None, True, False, "auto", "on", "off"}
        Apply the 250 mm moving average. Default (None = "auto"): as the standard's program does, when the base
        covers at least two samples (``round(base_length / dx) >= 2``, i.e. dx <= 0.167 m); on irregular
        stations when at least 10 % of the steps are that short (:data:`AUTO_MOVING_AVERAGE_SHARE`). The
        decision and its reason are in ``moving_average`` and ``moving_average_reason`` of the result.
    base_length : float
        Moving-average base, m (default 0.25).
    gaps : {"refuse", "restart"}
        Missing (NaN) elevations and station steps over :data:`MAX_IRI_STEP_M`: refused (default), or
        ``"restart"``: the IRI over the measured parts, the quarter car restarted after each gap, each run of
        measured samples computed exactly as its own file (:mod:`longprofile.road.indices._gaps`; the result gains
        ``valid_length``, ``hri_valid_length`` and ``gaps``).
    min_valid : float
        With ``gaps="restart"``: the smallest measured fraction of a segment for its IRI to be given (default
        0.8); below it the segment's IRI is NaN.

    Returns
    -------
    IRIResult
        IRI in m/km (= mm/m) per complete segment and per track, whole-section IRI, MRI/HRI for two tracks.

    Raises
    ------
    InputError
        NaN elevations (unless ``gaps="restart"``), a profile shorter than the lead-in, a start outside the profile.

    Notes
    -----
    WTP-46 (Sayers, Gillespie, Paterson 1986, section 3 and the IRI program p. 36) and ASTM E1926-08:

    1. smoothing (if applied): centred moving average over ``k = round(base/dx)`` samples on a constant step
       (equivalent to the WTP-46 slope ``(y[i+k] - y[i]) / (k dx)``); on irregular stations, the exact centred
       average of the linearly interpolated profile over ``base``, sampled at its knots and at most base/8
       apart (assumption: the standard defines only the regular case);
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
    gaps, min_valid = gaps_mode(gaps), min_valid_fraction(min_valid)
    x = profile.distance
    if x.size < 2:
        raise InputError(f"the profile needs at least 2 stations; got {x.size}.")
    first = float(x[0]) if start is None else float(start)
    if not np.isfinite(first) or first < x[0] or first >= x[-1]:
        raise InputError(f"start must lie within the profile ({x[0]:.3f} .. {x[-1]:.3f} m); got {start!r}.")
    dx = _is_regular(x)
    tol = 1e-6 * (dx if dx is not None else float(np.min(np.diff(x))))
    n_seg = int(np.floor((x[-1] - first) / segment_length + 1e-9))
    bounds = first + segment_length * np.arange(n_seg + 1)
    if gaps == "restart":
        g = _gapped(profile, tracks, lead_in, moving_average, base_length, bounds, bounds[:-1], bounds[1:],
                    min_valid, 1.0, lambda r, mask, t: _segment_sums(r.station, r.step, r.rectified, bounds, t))
        return IRIResult(segment_start=bounds[:-1], segment_end=bounds[1:], iri=g.values, tracks=g.tracks,
                         section_iri=g.section, section_start=g.start, section_end=g.end, mri=g.mri, hri=g.hri,
                         section_mri=g.section_mri, section_hri=g.section_hri, segment_length=segment_length,
                         moving_average=g.moving_average, base_length=float(base_length), lead_in=float(lead_in),
                         method=g.method, moving_average_reason=g.moving_average_reason, valid_length=g.valid,
                         hri_valid_length=g.hri_valid, gaps=g.summary)
    rs = _rectified_slope(profile, tracks, lead_in, moving_average, base_length, bounds, dx)
    seg = _segment_means(rs.station, rs.step, rs.rectified, bounds, tol)
    section = (rs.step @ rs.rectified) / rs.step.sum()
    mri, hri, section_mri, section_hri = _mri_hri(
        profile, rs, seg, section, lambda half: _run(half, None, lead_in, moving_average, base_length, bounds, dx),
        lambda r, mask: _segment_means(r.station, r.step, r.rectified, bounds, tol))
    return IRIResult(segment_start=bounds[:-1], segment_end=bounds[1:], iri=seg, tracks=rs.tracks,
                     section_iri=section, section_start=float(rs.station[0]), section_end=float(rs.station[-1]),
                     mri=mri, hri=hri, section_mri=section_mri, section_hri=section_hri,
                     segment_length=segment_length, moving_average=rs.moving_average,
                     base_length=float(base_length), lead_in=float(lead_in), method=rs.method,
                     moving_average_reason=rs.moving_average_reason)


def _window_means(station, step, values, inserted, starts, ends, tol):
    """Length-weighted mean of per-step values over each window ``[starts[j], ends[j]]``, O(M + S)
    (:func:`_window_sums`; NaN where the stations do not reach)."""
    total, length = _window_sums(station, step, values, inserted, starts, ends, tol)
    out = np.full_like(total, np.nan)
    ok = length > 0
    out[ok] = total[ok] / length[ok, None]
    return out


def _window_sums(station, step, values, inserted, starts, ends, tol):
    """Integral of per-step values and length covered over each window ``[starts[j], ends[j]]``, O(M + S):
    ``(total (S, K), length (S,))``, both 0 for a window the stations do not reach.

    Every window limit inside the station range is a station of the run (inserted before it; ``inserted`` marks
    them, None when none was). The quadrature is that of a run in which only the window's own two limits were
    inserted -- exactly what :func:`iri` computes for a segment with these limits -- although all windows share
    one run: a step split by other windows' limits keeps the value at the end of its unsplit step, and the step
    split by the window's end takes the value at that end (the inserted station). Cumulative-sum differences.
    """
    m = station.size
    if inserted is None:
        inserted = np.zeros(m, dtype=bool)
    orig = np.flatnonzero(~inserted)  # first and last stations are never inserted
    end_orig = orig[np.searchsorted(orig, np.arange(1, m), side="left")]  # end of the unsplit step of each step
    v_orig = values[end_orig - 1]
    cum = np.zeros((m, values.shape[1]))
    np.cumsum(step[:, None] * v_orig, axis=0, out=cum[1:])
    ia = np.clip(np.searchsorted(station, starts - tol, side="left"), 0, m - 1)
    ib = np.clip(np.searchsorted(station, ends - tol, side="left"), 0, m - 1)
    total = cum[ib] - cum[ia]
    cut = np.flatnonzero(inserted[ib] & (ib > ia))
    if cut.size:
        k = ib[cut]
        before = orig[np.searchsorted(orig, k) - 1]  # last unsplit station before the window's end
        lo = np.maximum(station[before], station[ia[cut]])
        total[cut] += (station[k] - lo)[:, None] * (values[k - 1] - v_orig[k - 1])
    return total, station[ib] - station[ia]


#: Report unit systems: length unit, its value in m, IRI unit, its value per m/km, column suffix.
REPORT_UNITS = {
    "si": {"length_unit": "m", "metres_per_unit": 1.0, "iri_unit": "m/km", "iri_per_m_per_km": 1.0,
           "iri_column": "m_per_km"},
    "us": {"length_unit": "ft", "metres_per_unit": 0.3048, "iri_unit": "in/mi", "iri_per_m_per_km": 63.36,
           "iri_column": "in_per_mi"},
}
#: Default continuous-IRI window: 25 ft (7.62 m), the short base length of ProVAL's continuous IRI
#: (Smoothness Assurance module, FHWA); the same physical length in both unit systems.
CONTINUOUS_WINDOW_M = 7.62
REPORT_MODES = ("fixed", "continuous", "overlapping")


class ReportUnits:
    """Unit properties of anything with a ``units`` attribute ("si" or "us"), from :data:`REPORT_UNITS`."""

    units: str

    @property
    def length_unit(self) -> str:
        return REPORT_UNITS[self.units]["length_unit"]

    @property
    def iri_unit(self) -> str:
        return REPORT_UNITS[self.units]["iri_unit"]

    @property
    def metres_per_unit(self) -> float:
        return REPORT_UNITS[self.units]["metres_per_unit"]

    @property
    def iri_factor(self) -> float:
        """IRI unit per m/km."""
        return REPORT_UNITS[self.units]["iri_per_m_per_km"]


@dataclass(frozen=True, eq=False)
class IRIReport(ReportUnits):
    """IRI as a road agency reports it: per reported interval (fixed, continuous or overlapping windows).

    Every length is in the report's length unit (m for ``units="si"``, ft for ``"us"``) and every IRI in its
    IRI unit (m/km or in/mi); the profile itself stays in SI.

    Attributes
    ----------
    interval_start, interval_end : (S,) ndarray
        Limits of each reported interval (segment or window), length unit.
    iri : (S, K) ndarray
        IRI per interval and track, IRI unit.
    tracks : tuple of str
    mri, hri : (S,) ndarray or None
        Mean of the two tracks' IRI and half-car IRI (two tracks only).
    section_iri : (K,) ndarray
        IRI over the whole simulated profile, IRI unit.
    section_mri, section_hri : float or None
    section_start, section_end : float
        Limits of the whole-section IRI, length unit.
    mode : str
        ``"fixed"``, ``"continuous"`` or ``"overlapping"``.
    units : str
        ``"si"`` or ``"us"``.
    metadata : dict
        Everything needed to reproduce the numbers (JSON-serialisable scalars): mode, interval/window/step,
        units, start station, moving average applied with its rule and reason, base length, lead-in, number of
        samples, method, section values. Written into CSV/Parquet outputs by
        :func:`longprofile.io.write_report_table`.
    """

    interval_start: np.ndarray
    interval_end: np.ndarray
    iri: np.ndarray
    tracks: tuple[str, ...]
    mri: np.ndarray | None
    hri: np.ndarray | None
    section_iri: np.ndarray
    section_mri: float | None
    section_hri: float | None
    section_start: float
    section_end: float
    mode: str
    units: str
    metadata: dict
    valid_length: np.ndarray | None = None
    hri_valid_length: np.ndarray | None = None
    gaps: GapSummary | None = None

    def to_frame(self) -> pd.DataFrame:
        """One row per interval: ``start_<u>, end_<u>, iri_<track>_<iri-u>`` (+ ``mri_<iri-u>, hri_<iri-u>``).

        SI: ``start_m, end_m, iri_left_m_per_km``; US: ``start_ft, end_ft, iri_left_in_per_mi``. The metadata are
        attached as ``frame.attrs["longprofile"]``.
        """
        lu, iu = self.length_unit, REPORT_UNITS[self.units]["iri_column"]
        cols = {f"start_{lu}": self.interval_start, f"end_{lu}": self.interval_end}
        for j, t in enumerate(self.tracks):
            cols[f"iri_{t}_{iu}"] = self.iri[:, j]
        if self.mri is not None:
            cols[f"mri_{iu}"] = self.mri
            cols[f"hri_{iu}"] = self.hri
        cols.update(_gap_columns(self.valid_length, self.hri_valid_length, self.tracks,
                                 self.interval_end - self.interval_start, self.gaps, lu))
        frame = pd.DataFrame(cols)
        frame.attrs["longprofile"] = dict(self.metadata)
        return frame


def _report_mode_and_units(mode, units) -> tuple[str, str]:
    """iri_report's ``mode`` and ``units`` normalised (stripped, lower case) and checked."""
    mode_key = str(mode).strip().lower() if isinstance(mode, str) else mode
    if mode_key not in REPORT_MODES:
        raise InputError(f"unknown mode {mode!r}; use one of {', '.join(REPORT_MODES)}.")
    units_key = str(units).strip().lower() if isinstance(units, str) else units
    if units_key not in REPORT_UNITS:
        raise InputError(f"unknown units {units!r}; use 'si' (m, m/km) or 'us' (ft, in/mi). (The elevation unit "
                         "of a file is given when reading it, e.g. read_profile(..., units='mm').)")
    return mode_key, units_key


def _report_start(start, x0, x1, tol_u, lu) -> float:
    """The station of the first interval, report unit: ``start`` (default the first station) checked to lie in
    the profile [x0, x1) within ``tol_u``."""
    first = x0 if start is None else start
    try:
        first = float(first)
    except (TypeError, ValueError):
        raise InputError(f"start must be a number ({lu}); got {start!r}.") from None
    if not np.isfinite(first) or first < x0 - tol_u or first >= x1 - tol_u:
        raise InputError(f"start must lie within the profile ({x0:.3f} .. {x1:.3f} {lu}); got {start!r}.")
    return max(first, x0)


def _report_length(name, value, unit, scale=None):
    """A positive length in the report unit; with ``scale`` (metres per report unit: an interval or a window) at
    least :data:`MIN_IRI_INTERVAL_M`."""
    length = require_positive(f"{name} ({unit})", value)
    if scale is not None and length * scale < MIN_IRI_INTERVAL_M * (1 - 1e-9):
        raise InputError(f"{name} {length:g} {unit} is shorter than {MIN_IRI_INTERVAL_M:g} m: an IRI over less than a "
                         "metre says nothing of roughness (the quarter car responds to waves of 1.3-30 m). A unit "
                         f"mistake (e.g. 0.1 for 0.1 km = 100 m)? Give the {name} in {unit}.")
    return length


def _report_intervals(mode_key, x, dx, first, x1, scale, lu, tol_u, interval, window, step):
    """The intervals of :func:`iri_report` in the report length unit: ``(starts, ends, bounds, grid)``, ``bounds``
    every interval end point (sorted, unique) and ``grid`` the interval/window/step for the metadata."""
    if mode_key == "fixed":
        if window is not None or step is not None:
            raise InputError("window and step are for mode='continuous' or 'overlapping'; mode='fixed' reports "
                             "consecutive segments of `interval`.")
        length = _report_length("interval", interval, lu, scale)
        n = int(np.floor((x1 - first) / length + 1e-9))
        if n > x.size + 1000:  # shorter than a sample spacing: every segment would be (nearly) empty
            raise InputError(f"segment {length:g} {lu} gives {n} segments, more than the profile's {x.size} samples: "
                             "a segment must hold several samples; use a longer segment (a unit mistake?).")
        bounds_u = first + length * np.arange(n + 1)
        starts_u, ends_u = bounds_u[:-1], bounds_u[1:]
        grid = {"interval": length}
    else:
        if window is None:
            window = CONTINUOUS_WINDOW_M / scale if mode_key == "continuous" else interval
        length = _report_length("window", window, lu, scale)
        if step is None:
            step = ((dx if dx is not None else (x[-1] - x[0]) / (x.size - 1)) / scale if mode_key == "continuous"
                    else 0.5 * length)
        stride = _report_length("step", step, lu)
        if mode_key == "overlapping" and stride >= length:
            raise InputError(f"overlapping windows need step < window; got step {stride:g} {lu} >= window "
                             f"{length:g} {lu} (use mode='fixed' for consecutive segments).")
        if mode_key == "continuous" and stride > length * (1 + 1e-12):
            raise InputError(f"a continuous report needs step <= window (got step {stride:g} {lu} > window "
                             f"{length:g} {lu}): the windows would leave gaps; use mode='fixed' or a shorter step.")
        if x1 - first < length - tol_u:
            raise InputError(f"the window ({length:g} {lu}) is longer than the profile from the start station "
                             f"({x1 - first:.3f} {lu}, {first:g} .. {x1:g} {lu}); use a shorter window or an "
                             "earlier start.")
        n = int(np.floor((x1 - first - length) / stride + 1e-9)) + 1
        if n > 4 * x.size + 1000:
            raise InputError(f"step {stride:g} {lu} gives {n} windows, more than 4 per sample of the profile "
                             f"({x.size} samples): a window every sample is the finest report; use a longer step.")
        starts_u = first + stride * np.arange(n)
        ends_u = starts_u + length
        bounds_u = np.union1d(starts_u, ends_u)
        grid = {"window": length, "step": stride}
    return starts_u, ends_u, bounds_u, grid


def _report_metadata(g, *, mode_key, units_key, lu, iri_unit, grid, first, x0, x1, n_samples, n_intervals, ma_mode,
                     base_length, lead_in, scale) -> dict:
    """The ``metadata`` of an :class:`IRIReport` (from the :class:`~._gaps.GappedIRI` ``g`` of
    :func:`_report_values`): software, standard, method, grid, stations, section values, gaps."""
    from ... import __version__

    carried = "state carried through" if g.summary is None else "restarted after each gap (gaps='restart')"
    meta = {
        "software": f"longprofile {__version__}",
        "standard": "ASTM E1926-08 (R2015) / World Bank Technical Paper 46 (1986); MRI, HRI: Sayers, TRR 1501 (1995)",
        "method": f"golden quarter car at 80 km/h, exact discretisation ({g.method}), {carried}",
        "mode": mode_key,
        "units": units_key,
        "length_unit": lu,
        "iri_unit": iri_unit,
        **grid,
        "start": float(first),
        "first_station": x0,
        "last_station": x1,
        "n_samples": n_samples,
        "n_intervals": n_intervals,
        "tracks": ",".join(g.tracks),
        "moving_average": ma_mode,
        "moving_average_applied": bool(g.moving_average),
        "moving_average_rule": _moving_average_rule(base_length),
        "moving_average_reason": g.moving_average_reason,
        "base_length_m": float(base_length),
        "lead_in_m": float(lead_in),
        "section_start": float(g.start / scale),
        "section_end": float(g.end / scale),
    }
    for t, v in zip(g.tracks, g.section):
        meta[f"section_iri_{t}"] = float(v)
    if g.section_mri is not None:
        meta["section_mri"], meta["section_hri"] = g.section_mri, g.section_hri
    if g.summary is not None:
        meta.update(g.summary.metadata(scale))
        meta["gap_note"] = g.summary.message(length_unit=lu, metres_per_unit=scale,
                                             what="segment" if mode_key == "fixed" else "window")
    return meta


def _report_values(profile, tracks, mode_key, lead_in, ma_mode, base_length, bounds_m, starts_m, ends_m, dx, tol,
                   factor, gaps, min_valid) -> GappedIRI:
    """The IRI per interval of :func:`iri_report` (in its unit: ``factor`` per m/km), MRI/HRI and section values,
    as a :class:`~._gaps.GappedIRI` (``valid``, ``hri_valid`` and ``summary`` None unless ``gaps="restart"``)."""
    if gaps == "restart":
        def sums(r, mask, t):
            if mode_key == "fixed":
                return _segment_sums(r.station, r.step, r.rectified, bounds_m, t)
            # only the windows that reach the run (the others are 0): O(run + its windows) per run
            a = np.searchsorted(ends_m, r.station[0], side="left")
            b = np.searchsorted(starts_m, r.station[-1], side="right")
            total, length = np.zeros((starts_m.size, r.rectified.shape[1])), np.zeros(starts_m.size)
            total[a:b], length[a:b] = _window_sums(r.station, r.step, r.rectified, mask, starts_m[a:b], ends_m[a:b], t)
            return total, length

        return _gapped(profile, tracks, lead_in, ma_mode, base_length, bounds_m, starts_m, ends_m, min_valid, factor,
                       sums)

    def per_interval(r, mask):
        if mode_key == "fixed":
            return _segment_means(r.station, r.step, r.rectified, bounds_m, tol)
        return _window_means(r.station, r.step, r.rectified, mask, starts_m, ends_m, tol)

    rs, inserted = _run(profile, tracks, lead_in, ma_mode, base_length, bounds_m, dx)
    values = per_interval(rs, inserted) * factor
    section = (rs.step @ rs.rectified) / rs.step.sum() * factor
    mri, hri, section_mri, section_hri = _mri_hri(
        profile, rs, values, section, lambda half: _run(half, None, lead_in, ma_mode, base_length, bounds_m, dx),
        per_interval, factor=factor)
    return GappedIRI(tracks=rs.tracks, values=values, valid=None, mri=mri, hri=hri, hri_valid=None, section=section,
                     section_mri=section_mri, section_hri=section_hri, start=float(rs.station[0]),
                     end=float(rs.station[-1]), moving_average=rs.moving_average,
                     moving_average_reason=rs.moving_average_reason, method=rs.method, summary=None)


def iri_report(profile: Profile, *, mode: str = "fixed", interval: float = 100.0, window: float | None = None,
               step: float | None = None, start: float | None = None, units: str = "si", tracks=None,
               lead_in: float = 11.0, moving_average="auto", base_length: float = 0.25, gaps: str = "refuse",
               min_valid: float = MIN_VALID_FRACTION) -> IRIReport:
    """The whole IRI report of a profile as road agencies make it: fixed, continuous or overlapping intervals.

    Parameters
    ----------
    profile : Profile
        Longitudinal profile in SI (stations and elevations in m); stations may be irregular; no NaN in the
        tracks used.
    mode : {"fixed", "continuous", "overlapping"}
        ``"fixed"``: consecutive segments of ``interval`` from ``start`` (complete segments only).
        ``"continuous"``: a sliding window of ``window`` reported every ``step`` (continuous IRI, e.g. ProVAL's
        Smoothness Assurance analysis). ``"overlapping"``: windows of ``window`` every ``step < window``.
    interval : float
        Fixed segment length, in the length unit of ``units`` (default 100: 100 m in SI; in US units give it,
        e.g. 528 ft = 0.1 mi). Also the default window of ``"overlapping"``; unused by ``"continuous"``.
    window : float, optional
        Window length, length unit. Default: ``"continuous"`` 25 ft = 7.62 m (the same length in both unit
        systems); ``"overlapping"`` ``interval``. Not accepted by ``"fixed"``.
    step : float, optional
        Distance between the starts of consecutive windows, length unit. Default: ``"continuous"`` one sample
        (the constant step of the profile; the mean step for irregular stations); ``"overlapping"`` half the
        window. ``"continuous"`` needs ``step <= window``, ``"overlapping"`` ``step < window``.
    start : float, optional
        Station where the first interval starts, length unit (default: the first station of the profile). The
        simulation always starts at the first station; only the reporting grid moves.
    units : {"si", "us"}
        Report units: ``"si"`` stations in m and IRI in m/km; ``"us"`` stations in ft and IRI in in/mi
        (1 m/km = 63.36 in/mi exactly).
    tracks : str or sequence of str, optional
        Tracks to analyse (default all); with exactly two the MRI and HRI are reported too.
    lead_in : float
        Initialisation length, **m** in both unit systems (a constant of the index definition; ASTM E1926: 11 m).
    moving_average : {"auto", "on", "off"} or {None, True, False}
        The 250 mm moving average (see Notes). None/True/False are the :func:`iri` spellings.
    base_length : float
        Moving-average base, **m** in both unit systems (default 0.25).
    gaps : {"refuse", "restart"}, min_valid : float
        As in :func:`iri`: missing elevations refused (default), or the IRI over the measured parts with the
        quarter car restarted after each gap, an interval measured over less than ``min_valid`` (default 0.8) of its
        length NaN. The report then has ``valid_length``, ``hri_valid_length`` (length unit), ``gaps`` and the gap
        metadata (``gap_count``, ``gap_length``, ``gap_note``...).

    Returns
    -------
    IRIReport
        Per-interval IRI (and MRI/HRI), section values and ``metadata``; ``to_frame()`` gives the table.

    Raises
    ------
    InputError
        Unknown mode or units; a non-positive interval, window or step; a window longer than the profile from
        ``start``; ``step`` not below the window for overlapping windows; ``window``/``step`` given to
        ``"fixed"``; a start outside the profile; NaN elevations; a profile shorter than the lead-in.

    Notes
    -----
    *Computation.* One golden-car run over the whole profile (ASTM E1926 / WTP-46, state carried through,
    exactly as :func:`iri`), with every interval limit that falls between samples inserted as a station
    (exact: the simulated profile is linear between samples). Fixed segments are the segment means of
    :func:`iri`; sliding and overlapping windows are differences of the cumulative length-weighted rectified
    slope (O(N + S), no loop of :func:`iri` calls), with the quadrature :func:`iri` would use for a segment with
    the same limits, so a window equals the fixed-interval IRI of the segment it coincides with.

    *Stations.* The profile's own stations are used (not re-zeroed); in US units they are the SI stations
    divided by 0.3048, and the interval limits are ``start + j * step`` computed in ft, so a profile recorded in
    ft reports its own round stations. Only windows lying entirely inside the profile are reported (the last
    incomplete segment or window is left out; the section IRI covers the whole profile). With the moving
    average the first and last half-base of the profile have no smoothed elevation: intervals touching them
    are averaged over the part that has one.

    *Moving average ("auto").* ASTM E1926 / WTP-46 smooth the profile with a 250 mm moving average computed
    over ``k = round(0.25 m / dx)`` samples; for k = 1 (dx > 0.167 m) it leaves the profile unchanged, so "auto"
    applies it exactly when ``k >= 2``. For irregular stations (assumption: the standard defines only a
    constant step) a step "would be averaged" when ``round(base / h) >= 2``; the average is applied when at
    least 10 % of the steps are such (:data:`AUTO_MOVING_AVERAGE_SHARE`), as the exact 250 mm average of the
    linearly interpolated profile. The decision, its rule and its reason (the shares measured) are in
    ``metadata``.

    References
    ----------
    ASTM E1926-08 (R2015); Sayers, Gillespie, Paterson, World Bank Technical Paper 46 (1986); Sayers, TRR 1501
    (1995) for MRI/HRI; FHWA ProVAL (continuous IRI, 25 ft base length).
    """
    mode_key, units_key = _report_mode_and_units(mode, units)
    gaps, min_valid = gaps_mode(gaps), min_valid_fraction(min_valid)
    u = REPORT_UNITS[units_key]
    lu, scale = u["length_unit"], u["metres_per_unit"]
    ma_mode = _moving_average_mode(moving_average)
    lead_in = require_positive("lead_in (m)", lead_in)
    base_length = require_positive("base_length (m)", base_length)
    x = profile.distance
    if x.size < 2:
        raise InputError("the profile needs at least 2 stations.")
    x0, x1 = float(x[0]) / scale, float(x[-1]) / scale  # profile limits in the report unit
    dx = _is_regular(x)
    tol = 1e-6 * (dx if dx is not None else float(np.min(np.diff(x))))
    tol_u = tol / scale
    first = _report_start(start, x0, x1, tol_u, lu)
    starts_u, ends_u, bounds_u, grid = _report_intervals(mode_key, x, dx, first, x1, scale, lu, tol_u, interval,
                                                         window, step)
    bounds_m = np.minimum(bounds_u * scale, x[-1])
    g = _report_values(profile, tracks, mode_key, lead_in, ma_mode, base_length, bounds_m,
                       np.minimum(starts_u * scale, x[-1]), np.minimum(ends_u * scale, x[-1]), dx, tol,
                       u["iri_per_m_per_km"], gaps, min_valid)
    meta = _report_metadata(g, mode_key=mode_key, units_key=units_key, lu=lu, iri_unit=u["iri_unit"], grid=grid,
                            first=first, x0=x0, x1=x1, n_samples=int(x.size), n_intervals=int(starts_u.size),
                            ma_mode=ma_mode, base_length=base_length, lead_in=lead_in, scale=scale)
    return IRIReport(interval_start=starts_u, interval_end=ends_u, iri=g.values, tracks=g.tracks, mri=g.mri,
                     hri=g.hri, section_iri=g.section, section_mri=g.section_mri, section_hri=g.section_hri,
                     section_start=g.start / scale, section_end=g.end / scale, mode=mode_key, units=units_key,
                     metadata=meta, valid_length=None if g.valid is None else g.valid / scale,
                     hri_valid_length=None if g.hri_valid is None else g.hri_valid / scale, gaps=g.summary)
