"""Shared argument validators (private).

All public functions validate their inputs here, once, and raise
:mod:`longprofile.errors` exceptions with actionable messages. Compiled kernels
trust their inputs.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .errors import InputError, ModelError, ShapeError

__all__ = [
    "as_float_array",
    "require_finite",
    "require_symmetric_psd",
    "validate_step",
    "require_positive",
    "time_resolution",
    "utc_offset_mix",
    "first_undecodable_line",
    "missing_value_code",
    "missing_value_codes",
    "constant_runs",
    "true_runs",
    "MISSING_PROFILE_HINT",
]

#: What a refusal of a missing profile sample written as a number (a logger's code, a held or zero value) says to do:
#: one hint for the profile readers (``io``) and the road commands.
MISSING_PROFILE_HINT = ("write the missing samples as NaN (leave the cells empty), then analyse with --gaps restart (road "
                        "iri, road report, batch iri: the IRI over the measured parts) or cover them with an exclusion "
                        "zone (road acceptance: [exclusions] zones)")


def as_float_array(name: str, value, *, ndim: int | Sequence[int] | None = None,
                   allow_nan: bool = True) -> np.ndarray:
    """Convert ``value`` to a float64 ndarray and check its number of dimensions."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numeric array-like; got {type(value).__name__} ({exc}).") from None
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in allowed:
            want = " or ".join(f"{d}-D" for d in allowed)
            raise ShapeError(f"{name} must be {want}; got shape {arr.shape}.")
    if not allow_nan:
        require_finite(name, arr)
    elif np.isinf(arr).any():
        raise InputError(f"{name} contains infinite values; use NaN for missing samples or remove them.")
    return arr


def require_finite(name: str, arr: np.ndarray) -> None:
    """Raise :class:`InputError` if ``arr`` has NaN or infinite entries."""
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        first = tuple(int(i) for i in bad[0])
        raise InputError(f"{name} must be finite; {len(bad)} non-finite value(s), first at index {first}.")


def require_positive(name: str, value, *, strict: bool = True) -> float:
    """Return ``value`` as float after checking it is (strictly) positive and finite."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number; got {value!r}.") from None
    if not np.isfinite(v) or (v <= 0 if strict else v < 0):
        cmp = "> 0" if strict else ">= 0"
        raise InputError(f"{name} must be finite and {cmp}; got {value!r}.")
    return v


def require_symmetric_psd(name: str, mat: np.ndarray, *, rtol: float = 1e-8) -> None:
    """Check that ``mat`` (shape (..., n, n)) is symmetric positive semi-definite.

    Symmetry is checked to a relative tolerance ``rtol`` of the largest entry;
    positive semi-definiteness through the smallest eigenvalue, allowing
    ``-rtol * max|eig|`` for round-off.
    """
    if mat.shape[-1] != mat.shape[-2]:
        raise ShapeError(f"{name} must be square; got shape {mat.shape}.")
    require_finite(name, mat)
    scale = max(float(np.max(np.abs(mat), initial=0.0)), np.finfo(float).tiny)
    asym = float(np.max(np.abs(mat - np.swapaxes(mat, -1, -2)), initial=0.0))
    if asym > rtol * scale:
        raise ModelError(f"{name} must be symmetric; max |A - A^T| = {asym:.3g} (scale {scale:.3g}). "
                         "Symmetrise it, e.g. (A + A.T) / 2.")
    eig = np.linalg.eigvalsh(0.5 * (mat + np.swapaxes(mat, -1, -2)))
    emin = float(eig.min(initial=0.0))
    emax = float(np.max(np.abs(eig), initial=0.0))
    if emin < -rtol * max(emax, np.finfo(float).tiny) and emin < -1e-300:
        raise ModelError(f"{name} must be positive semi-definite; smallest eigenvalue is {emin:.3g}.")


def validate_step(step_name: str, step, positions_name: str, positions, n_samples: int) -> np.ndarray:
    """Return the sample positions from either a constant step or explicit positions.

    Exactly one of ``step`` (a positive scalar, e.g. ``dt`` in s or ``dx`` in m)
    and ``positions`` (a strictly increasing array of length ``n_samples``) must
    be given. The returned array has length ``n_samples``.
    """
    if (step is None) == (positions is None):
        raise InputError(f"give exactly one of {step_name} (constant step) and {positions_name} "
                         f"(sample positions); got {'both' if step is not None else 'neither'}.")
    if step is not None:
        h = require_positive(step_name, step)
        return np.arange(n_samples, dtype=np.float64) * h
    pos = as_float_array(positions_name, positions, ndim=1, allow_nan=False)
    if pos.shape[0] != n_samples:
        raise ShapeError(f"{positions_name} must have one entry per sample ({n_samples}); got {pos.shape[0]}.")
    if n_samples > 1 and np.any(np.diff(pos) <= 0):
        k = int(np.argmax(np.diff(pos) <= 0))
        raise InputError(f"{positions_name} must be strictly increasing; {positions_name}[{k + 1}] = {pos[k + 1]!r} "
                         f"<= {positions_name}[{k}] = {pos[k]!r}.")
    return pos


def time_resolution(t) -> float:
    """The float resolution of the time stamps ``t`` (s), to add to a sampling-uniformity tolerance: steps between
    Unix time stamps (~1.7e9 s) differ by +-2.4e-7 s from float64 rounding alone, which is not the logger's jitter."""
    t = np.asarray(t, float)
    return 4.0 * float(np.spacing(np.max(np.abs(t)))) if t.size else 0.0


def utc_offset_mix(times) -> tuple[int, int] | None:
    """Among ISO 8601 date-time texts, the first index with a UTC offset (``Z``, ``+01:00``) and the first without,
    when both kinds occur (which zone the others are in cannot be known); None otherwise. Values that are not
    date-time texts are left to the parser. One rule for files (``rail settle``) and the service's batches."""
    import pandas as pd

    text = pd.Series(list(times) if not isinstance(times, pd.Series) else times, dtype=object)
    text = text.where(text.map(lambda v: isinstance(v, str))).str.strip()
    iso = text.str.match(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}", na=False).to_numpy(bool)
    has = text.str.contains(r"(?:[Zz]|[+-]\d{2}:?\d{2})$", regex=True, na=False).to_numpy(bool) & iso
    if not has.any() or not (iso & ~has).any():
        return None
    return int(np.flatnonzero(has)[0]), int(np.flatnonzero(iso & ~has)[0])


def time_zone(name):
    """The ``zoneinfo.ZoneInfo`` of the IANA zone ``name`` (``Europe/Paris``, ``UTC``; empty: UTC), an unknown one
    refused. One check for files (``rail settle --timezone``) and the service's site field."""
    from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

    try:
        return ZoneInfo(str(name).strip() or "UTC")
    except (ZoneInfoNotFoundError, ValueError):
        raise InputError(f"unknown time zone {str(name)[:64]!r}: give an IANA name such as Europe/Paris, "
                         "America/New_York or UTC.") from None


def first_undecodable_line(lines, codec: str = "utf-8") -> tuple[int, str] | None:
    """(1-based number, text as Latin-1) of the first of ``lines`` (bytes) that ``codec`` cannot decode; None if all
    can. For messages naming the line (pandas' and the codec's positions are within a chunk)."""
    for n, raw in enumerate(lines, start=1):
        try:
            raw.decode(codec)
        except UnicodeDecodeError:
            return n, raw.decode("latin-1").strip()
    return None


def missing_value_codes(values) -> np.ndarray:
    """Mask of the values that look like a logger's code for a missing value: a whole number of 9s, at least 999 in
    size (-9999, 99999). One rule for the rail tables and the road profile files."""
    a = np.abs(np.asarray(values, dtype=float))
    with np.errstate(invalid="ignore", divide="ignore"):
        whole = np.isfinite(a) & (a >= 999.0) & (a == np.round(a)) & (a < 1e15)
        return whole & (10.0 ** np.round(np.log10(np.where(whole, a + 1.0, 1.0))) == a + 1.0)


def missing_value_code(value: float) -> bool:
    """Whether one value looks like a logger's code for a missing value (:func:`missing_value_codes`)."""
    return bool(missing_value_codes([value])[0])


def true_runs(mask) -> list[tuple[int, int]]:
    """``(first, last)`` index of each run of True in a 1-D boolean mask."""
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        return []
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), (np.flatnonzero(d == -1) - 1).tolist()))


def constant_runs(x, z, min_length: float) -> list[tuple[int, int]]:
    """``(first, last)`` sample indices of the runs of exactly equal, finite values of ``z`` over at least
    ``min_length`` of ``x`` (stations, increasing): a sensor holding one value (a dropout written as a number)."""
    x, z = np.asarray(x, dtype=float), np.asarray(z, dtype=float)
    if z.size < 2:
        return []
    same = np.isfinite(z[1:]) & (z[1:] == z[:-1])
    # steps i .. j equal: samples i .. j + 1
    return [(i, j + 1) for i, j in true_runs(same) if x[j + 1] - x[i] >= min_length]
