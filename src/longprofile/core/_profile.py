"""The longitudinal profile type shared by reconstruction, indices, files and reports (``longprofile.core``)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .._validation import as_float_array
from ..errors import InputError, ShapeError

__all__ = ["Profile"]


@dataclass(frozen=True, eq=False)
class Profile:
    """A longitudinal profile: elevations along a line, one column per track.

    Parameters
    ----------
    distance : (N,) array_like
        Station of each sample along the road, m, strictly increasing (may be irregular).
    elevation : (N,) or (N, K) array_like
        Elevation, m, for each of K tracks (wheel paths). NaN marks a missing sample.
    tracks : tuple of str, optional
        Track names, one per column (default ``("left",)`` or ``("track0", ...)``).
    std : (N,) or (N, K) array_like, optional
        Posterior standard deviation of the elevation, m (reconstructions provide it).
    name : str
        Free label (section name, file name).

    Notes
    -----
    Elevations are always stored in metres; readers convert from the unit the file
    declares and never guess it.
    """

    distance: np.ndarray
    elevation: np.ndarray
    tracks: tuple[str, ...] = ()
    std: np.ndarray | None = None
    name: str = ""

    def __post_init__(self):
        x = as_float_array("distance", self.distance, ndim=1, allow_nan=False)
        z = as_float_array("elevation", self.elevation, ndim=(1, 2))
        if z.ndim == 1:
            z = z[:, None]
        if z.shape[0] != x.shape[0]:
            raise ShapeError(f"elevation must have one row per station ({x.shape[0]}); got shape {z.shape}.")
        if x.shape[0] > 1 and np.any(np.diff(x) <= 0):
            k = int(np.argmax(np.diff(x) <= 0))
            raise InputError(f"distance must be strictly increasing; distance[{k + 1}] = {x[k + 1]} <= "
                             f"distance[{k}] = {x[k]}.")
        tracks = tuple(self.tracks) or (("left",) if z.shape[1] == 1 else tuple(f"track{i}" for i in range(z.shape[1])))
        if len(tracks) != z.shape[1]:
            raise ShapeError(f"tracks names {len(tracks)} track(s) but elevation has {z.shape[1]} column(s).")
        std = None
        if self.std is not None:
            std = as_float_array("std", self.std, ndim=(1, 2))
            if std.ndim == 1:
                std = std[:, None]
            if std.shape != z.shape:
                raise ShapeError(f"std must have the shape of elevation {z.shape}; got {std.shape}.")
        object.__setattr__(self, "distance", x)
        object.__setattr__(self, "elevation", z)
        object.__setattr__(self, "tracks", tracks)
        object.__setattr__(self, "std", std)

    @property
    def n_samples(self) -> int:
        return self.distance.shape[0]

    @property
    def spacing(self) -> float | None:
        """The constant sample spacing in m, or None if the stations are irregular (relative tolerance 1e-6)."""
        if self.n_samples < 2:
            return None
        d = np.diff(self.distance)
        return float(d.mean()) if np.allclose(d, d.mean(), rtol=1e-6, atol=0) else None

    def track(self, name: str) -> np.ndarray:
        """Elevation of one track, (N,) m."""
        if name not in self.tracks:
            raise InputError(f"no track {name!r}; the profile has {list(self.tracks)}.")
        return self.elevation[:, self.tracks.index(name)]

    def renamed(self, mapping: dict) -> Profile:
        """The profile with tracks renamed, ``{old: new}`` (the data and the other tracks unchanged).

        Tracks are matched by name wherever profiles meet (``certify_profiler``, MRI/HRI of ``left``/``right``):
        this makes a run's ``elevation`` the reference's ``left``, say. A name that is not a track, an empty new
        name, or a result with two tracks of one name is refused (:class:`~longprofile.errors.InputError`).
        """
        unknown = [old for old in mapping if old not in self.tracks]
        if unknown:
            raise InputError(f"cannot rename track {unknown[0]!r}: the profile has {list(self.tracks)}.")
        names = tuple(str(mapping.get(t, t)) for t in self.tracks)
        if any(not n.strip() for n in names):
            raise InputError(f"a track cannot be renamed to an empty name ({mapping}).")
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise InputError(f"renaming {mapping} gives two tracks named {twice[0]!r} ({list(self.tracks)} -> "
                             f"{list(names)}); rename or drop the other one.")
        return replace(self, tracks=names)
