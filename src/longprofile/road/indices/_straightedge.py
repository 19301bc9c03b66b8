"""Rolling straightedge simulation of a longitudinal profile (ProVAL practice; e.g. a 10 ft straightedge)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..._validation import require_positive
from ..._validation import true_runs as _runs
from ...core import Profile
from ...errors import InputError

__all__ = ["STRAIGHTEDGE_10FT", "StraightedgeDefect", "StraightedgeResult", "rolling_straightedge"]

#: 10 ft = 3.048 m, the straightedge length of most US smoothness specifications (exact conversion).
STRAIGHTEDGE_10FT = 3.048


@dataclass(frozen=True)
class StraightedgeDefect:
    """A run of centre stations where |deviation| exceeds the threshold.

    Attributes
    ----------
    track : str
    start, end : float
        First and last centre station of the run, m.
    peak_station : float
        Station of the largest |deviation|, m.
    peak_deviation : float
        Signed deviation there, m (positive: bump above the chord; negative: dip below it).
    """

    track: str
    start: float
    end: float
    peak_station: float
    peak_deviation: float


@dataclass(frozen=True, eq=False)
class StraightedgeResult:
    """Deviation of the profile from the chord of a rolling straightedge.

    Attributes
    ----------
    station : (M,) ndarray
        Centre stations, m (those whose two supports lie on the profile).
    deviation : (M, K) ndarray
        ``z(x) - (z(x - L/2) + z(x + L/2)) / 2``, m; columns ``tracks``.
    tracks : tuple of str
    length : float
        Straightedge length L, m.
    threshold : float or None
        |deviation| limit, m.
    defects : tuple of StraightedgeDefect
    """

    station: np.ndarray
    deviation: np.ndarray
    tracks: tuple[str, ...]
    length: float
    threshold: float | None
    defects: tuple[StraightedgeDefect, ...]

    @property
    def max_abs_deviation(self) -> np.ndarray:
        """(K,) largest |deviation| per track, m."""
        return np.max(np.abs(self.deviation), axis=0)

    def to_frame(self) -> pd.DataFrame:
        cols = {"station_m": self.station}
        for j, t in enumerate(self.tracks):
            cols[f"deviation_{t}_m"] = self.deviation[:, j]
        return pd.DataFrame(cols)


def rolling_straightedge(profile: Profile, *, length: float = STRAIGHTEDGE_10FT, threshold: float | None = None,
                         tracks=None) -> StraightedgeResult:
    """Simulate a rolling straightedge of length ``L`` with its measuring wheel at mid-length.

    Parameters
    ----------
    profile : Profile
        Stations (may be irregular) and elevations in m; no NaN in the tracks used.
    length : float
        Straightedge length L, m (default 10 ft = 3.048 m).
    threshold : float, optional
        Deviation limit, m (e.g. 1/8 in = 3.175 mm); runs of centre stations with ``|deviation| > threshold``
        are reported as defects.
    tracks : str or sequence of str, optional

    Returns
    -------
    StraightedgeResult

    Notes
    -----
    The straightedge rests on the profile at ``x - L/2`` and ``x + L/2``; the deviation is the elevation
    under the mid-length wheel minus the chord between the supports::

        d(x) = z(x) - (z(x - L/2) + z(x + L/2)) / 2

    evaluated at every profile station whose supports lie on the profile (supports between samples by
    linear interpolation; exact sample values when L/2 is a multiple of a constant step). This is the
    "simulated rolling straightedge" of FHWA ProVAL (a support at each end, a measuring wheel at the centre);
    the supports are treated as points (no wheel radius) -- a longprofile assumption, as are the sign
    convention (positive = bump) and the use of every profile station as a centre. On a sine
    ``A sin(2 pi x / lambda)`` it gives ``A (1 - cos(pi L / lambda)) sin(2 pi x / lambda)`` (tested).
    """
    length = require_positive("length (m)", length)
    if threshold is not None:
        threshold = require_positive("threshold (m)", threshold)
    names = profile.tracks if tracks is None else ((tracks,) if isinstance(tracks, str) else tuple(tracks))
    z = np.column_stack([profile.track(t) for t in names])
    x = profile.distance
    if np.isnan(z).any():
        i, j = np.argwhere(np.isnan(z))[0]
        raise InputError(f"track {names[j]!r} has a missing (NaN) elevation at station {x[i]:.3f} m; the "
                         "straightedge needs a continuous profile.")
    half = 0.5 * length
    tol = 1e-9 * max(1.0, abs(x[-1]))
    keep = (x - half >= x[0] - tol) & (x + half <= x[-1] + tol)
    if not keep.any():
        raise InputError(f"the profile ({x[-1] - x[0]:.3f} m) is shorter than the straightedge ({length:g} m).")
    c = x[keep]
    lo, hi = np.clip(c - half, x[0], x[-1]), np.clip(c + half, x[0], x[-1])
    dev = np.column_stack([z[keep, j] - 0.5 * (np.interp(lo, x, z[:, j]) + np.interp(hi, x, z[:, j]))
                           for j in range(z.shape[1])])
    defects = []
    if threshold is not None:
        for j, t in enumerate(names):
            for a, b in _runs(np.abs(dev[:, j]) > threshold):
                k = a + int(np.argmax(np.abs(dev[a:b + 1, j])))
                defects.append(StraightedgeDefect(t, float(c[a]), float(c[b]), float(c[k]), float(dev[k, j])))
    return StraightedgeResult(station=c, deviation=dev, tracks=tuple(names), length=length, threshold=threshold,
                              defects=tuple(defects))
