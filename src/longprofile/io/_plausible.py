"""Plausibility of what a file holds, per physical quantity: a wrong unit is refused, never computed with.

The input layer checks each quantity it reads against a range no real measurement leaves (below). The limits
are deliberately wide -- a real file never meets them -- and a file that does is refused with the value, where
it is, and the usual cause (a unit under the wrong label). Assumptions, documented in docs/file-formats.md:

* elevation: |z| <= 10 000 m (Earth's terrain spans -430 m to 8 849 m);
* missing-value codes: an elevation that is, in the file's own unit, a logger's code for a missing value (-9999,
  99999: a whole number of 9s >= 999, the rule of the rail tables) is refused where it stands apart from the
  profile -- the step to the nearest other sample steeper than :data:`MISSING_CODE_GRADE` (a 100 % grade); a road
  whose elevation passes through 9999.00 mm is read;
* profile grade: the median |dz/dx| between consecutive stations <= 1 (a 100 % grade). A road's grade is under
  0.3 and roughness adds little to the median: measured, 0.0044 on the Sroubek-Sorel road profile
  (../shared/reference-data/sorel-iri-profile, 0.25 m step) and, on this package's ISO 8608 generator at 25 mm
  sampling, 0.046 for a class E road and 0.37 for class H (the worst class); millimetres under a metre label
  multiply it by 1000 (class A: 2.9).
"""

from __future__ import annotations

import numpy as np

from .._validation import MISSING_PROFILE_HINT, missing_value_codes, true_runs
from ..core import MAX_ABS_ELEVATION_M
from ..errors import InputFormatError, UnitsError

__all__ = ["MAX_ABS_ELEVATION_M", "MAX_MEDIAN_GRADE", "MISSING_CODE_GRADE", "check_missing_codes",
           "check_profile_plausible"]

MAX_MEDIAN_GRADE = 1.0
#: A missing-value code is refused when the step from it to the nearest other sample is steeper than this grade
#: (-9999 mm next to a road at 0 mm is a 10 m step within 25 mm; no road surface rises by its own length).
MISSING_CODE_GRADE = 1.0
#: A median station step below this, m, names the stations rather than the elevations as the likely unit mistake
#: (profilers sample every 1 mm to 0.3 m; kilometres under a metre label give 5e-5 for a 5 cm step).
MIN_PLAUSIBLE_STEP_M = 1e-3


def check_profile_plausible(profile, source) -> None:
    """Refuse elevations out of any terrain's range, or changing faster than any road (a unit mistake).

    Parameters
    ----------
    profile : Profile
        As read, in metres.
    source : path-like or str
        Named in the message.

    Raises
    ------
    UnitsError
        Naming the track, the value and its station, and what to check.
    """
    x = profile.distance
    z = profile.elevation.reshape(x.size, -1)
    for j, track in enumerate(profile.tracks):
        zj = z[:, j]
        finite = np.isfinite(zj)
        big = finite & (np.abs(zj) > MAX_ABS_ELEVATION_M)
        if big.any():
            i = int(np.flatnonzero(big)[0])
            raise UnitsError(f"{source}: track {track!r} has an elevation of {zj[i]:.6g} m at station {x[i]:.6g} m, "
                             f"beyond any terrain (|z| <= {MAX_ABS_ELEVATION_M:g} m): check that value, and the unit "
                             "in the column name (e.g. left_mm) or the file header.")
        if x.size < 3:
            continue
        dz = np.abs(np.diff(zj)) / np.diff(x)
        dz = dz[np.isfinite(dz)]
        if dz.size and (grade := float(np.median(dz))) > MAX_MEDIAN_GRADE:
            step = float(np.median(np.diff(x)))
            cause = ("the stations look like kilometres (or another unit) under a metre label: name the station column "
                     "with its unit (e.g. distance_km)" if step < MIN_PLAUSIBLE_STEP_M else
                     "the values look like millimetres under a metre label; name the column with its unit (e.g. "
                     "left_mm) or convert it to metres")
            raise UnitsError(f"{source}: the elevations of track {track!r} change by a median {grade:.3g} m per m of "
                             f"distance (a {100 * grade:.0f} % grade; median station step {step:.3g} m), beyond any "
                             f"road: {cause}.")


def check_missing_codes(source, x, raw, tracks, units, factors, *, hint: str = MISSING_PROFILE_HINT,
                        what: str = "track") -> None:
    """Refuse elevations that are a logger's missing-value code in the file's unit (module notes), with the station.

    ``x`` stations (m, N), ``raw`` (N, K) the elevations as written, ``tracks``/``units``/``factors`` (m per unit)
    of each column. Raises :class:`~longprofile.errors.InputFormatError` naming the ``what`` (track, column), the
    value, its stations and what to write instead: ``hint`` (default
    :data:`longprofile._validation.MISSING_PROFILE_HINT`; an APL recording's and an ERD file's say it their way).
    """
    raw = np.asarray(raw, dtype=float).reshape(len(x), -1)
    for j, track in enumerate(tracks):
        code = missing_value_codes(raw[:, j])
        if not code.any():
            continue
        z = raw[:, j] * factors[j]
        other = np.flatnonzero(np.isfinite(z) & ~code)
        for i, k in true_runs(code):
            if _stands_apart(x, z, other, i, k):
                more = f" to {x[k]:.3f} m ({k - i + 1} samples)" if k > i else ""
                raise InputFormatError(f"{source}: {what} {track!r} holds {raw[i, j]:g} {units[j]} at station "
                                       f"{x[i]:.3f} m{more}: a logger's code for a missing value? "
                                       f"{hint[0].upper()}{hint[1:]}.")


def _stands_apart(x, z, other, i, k) -> bool:
    """Whether the code samples ``i .. k`` step from the nearest other samples (indices ``other``, sorted) by more
    than :data:`MISSING_CODE_GRADE`, or have none."""
    p = int(np.searchsorted(other, i))
    pairs = ([(i, other[p - 1])] if p > 0 else []) + ([(k, other[p])] if p < other.size else [])
    return not pairs or any(abs(z[a] - z[b]) > MISSING_CODE_GRADE * abs(x[a] - x[b]) for a, b in pairs)
