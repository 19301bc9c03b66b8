"""Dropouts written as a value: a profile track holding one exact elevation over a length no measured road does.

A profiler that loses its signal writes NaN, or -- worse -- zeros, a held last value or a logger's code. Codes
(-9999) are refused when the file is read (``io``); a run of one exact elevation is found here, for the road
commands to refuse or flag (``road acceptance`` refuses one outside its exclusion zones; ``road iri`` and
``road report`` print a warning naming it).

ASSUMPTION (:data:`MIN_DROPOUT_RUN_M`): no measured profile repeats one exact elevation over 2 m. Measured: the
longest run of equal consecutive elevations is 0.5 m on the Sroubek-Sorel road profile
(../shared/reference-data/sorel-iri-profile: 0.25 m step, 0.1 mm resolution); on this package's ISO 8608 class A
road (the smoothest class, and 0.43 x its spectrum, smoother than a new pavement) at 25 mm, elevations rounded to
0.01 mm give at most 0.25 m, to 0.001 in 0.38 m, to 0.1 mm 0.88 m, and to 0.01 in (0.25 mm, too coarse for a
smooth pavement's IRI) 1.45 m -- a plateau where the profile crosses a crest between two quantization levels.
"""

from __future__ import annotations

from ..._validation import MISSING_PROFILE_HINT, constant_runs
from ...core import Profile

__all__ = ["MIN_DROPOUT_RUN_M", "dropout_runs", "dropout_message", "dropout_note"]

#: Shortest run of one exact elevation taken for a dropout, m (ASSUMPTION, module notes).
MIN_DROPOUT_RUN_M = 2.0


def dropout_runs(profile: Profile, *, min_length: float = MIN_DROPOUT_RUN_M, exclusions=()) -> list[tuple]:
    """``(track, first station, last station, elevation)`` (m) of each run of one exact elevation over at least
    ``min_length`` m, in station order per track; runs lying wholly inside one of ``exclusions`` (``(start, end)``
    in m) are left out (not evaluated anyway)."""
    x = profile.distance
    z = profile.elevation.reshape(x.size, -1)
    runs = []
    for j, track in enumerate(profile.tracks):
        for i, k in constant_runs(x, z[:, j], min_length):
            if not any(a <= x[i] and x[k] <= b for a, b in exclusions):
                runs.append((track, float(x[i]), float(x[k]), float(z[i, j])))
    return runs


def dropout_message(runs, *, length_unit: str = "m", metres_per_unit: float = 1.0) -> str:
    """The sentence naming :func:`dropout_runs` (the first, and how many more), the assumption and the hint; ""
    for none. Stations are shown in ``length_unit``."""
    if not runs:
        return ""
    track, a, b, value = runs[0]
    f = metres_per_unit
    more = f" ({len(runs) - 1} more run(s) in the profile)" if len(runs) > 1 else ""
    return (f"track {track!r} holds one exact elevation ({value * 1e3:.6g} mm) from station {a / f:.3f} to "
            f"{b / f:.3f} {length_unit} ({(b - a) / f:.1f} {length_unit}){more}: a dropout written as a value "
            f"(a sensor zeroed or held)? No measured profile repeats one elevation over {MIN_DROPOUT_RUN_M:g} m. "
            f"{MISSING_PROFILE_HINT[0].upper()}{MISSING_PROFILE_HINT[1:]}.")


def dropout_note(profile: Profile) -> str:
    """:func:`dropout_message` of the profile's :func:`dropout_runs` ("" when it has none): the warning of
    ``road iri`` and ``road report``, beside :func:`~longprofile.road.iri_plausibility`."""
    return dropout_message(dropout_runs(profile))
