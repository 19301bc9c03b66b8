"""ERD files (UMTRI text format used by ProVAL, RoadRuf and the LTPP profile data).

Layout read and written here (text data only)::

    ERDFILEV2.00
    NCHAN, NPTS, -1, 1, 5, DX, X0,          <- 7 comma-separated fields; DX = station step
    TITLE   free text
    SHORTNAMleft    right                   <- 8-character fields, one per channel
    UNITSNAMmm      mm                      <- elevation unit of each channel
    XUNITS  m                               <- station unit
    END
    v11 v12                                 <- NPTS rows of NCHAN numbers (blank / comma separated)

Header keyword lines have the keyword in columns 1-8 and the value after it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError, InputFormatError, UnitsError
from ._profiles import unit_factor

__all__ = ["read_erd", "write_erd"]


def _fields8(value: str, n: int) -> list[str]:
    """Split a value into n 8-character fields (the ERD convention), falling back to whitespace."""
    parts = [value[i:i + 8].strip() for i in range(0, 8 * n, 8)]
    if all(parts) and len(parts) == n:
        return parts
    return value.split()


def read_erd(path, *, units: str | None = None, tracks=None, distance_units: str | None = None):
    """Read a text ERD profile file.

    Parameters
    ----------
    path : path-like
    units : str, optional
        Elevation unit to use when the header has no ``UNITSNAM`` line (never guessed). If the header
        gives units and ``units`` disagrees, :class:`UnitsError`.
    tracks : str or sequence of str, optional
        Channels to keep, by ``SHORTNAM`` (default all; unnamed channels are ``ch1``, ``ch2``...).
    distance_units : str, optional
        Station unit when the header has no ``XUNITS`` line.

    Returns
    -------
    Profile
        Stations ``X0 + i DX`` and elevations, in metres.

    Raises
    ------
    InputFormatError
        Not an ERD file, bad second line, missing END, wrong number of values (line named).
    UnitsError
        Units missing (and not given) or unknown.

    Notes
    -----
    Second line: ``NCHAN, NPTS, ..., DX, X0``: fields 1, 2, 6 are the number of channels, the number of
    samples and the station step. Field 7 is used as the first station only when written as a real
    number (with a decimal point); an integer there (e.g. ``-1`` in LTPP files) is a flag and the first
    station is 0. Fields 3-5 (storage flags) are not interpreted; only text data are supported.
    """
    from ..road import Profile

    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file.")
    try:
        lines = path.read_text(errors="strict").splitlines()
    except UnicodeDecodeError:
        raise InputFormatError(f"{path}: not a text file (binary ERD data are not supported).") from None
    if not lines or not lines[0].strip().upper().startswith("ERDFILEV2"):
        raise InputFormatError(f"{path}: line 1: expected 'ERDFILEV2.00', got {lines[0][:20]!r}." if lines else
                               f"{path}: empty file.")
    if len(lines) < 3:
        raise InputFormatError(f"{path}: the file ends after line {len(lines)}; an ERD header has at least 3 lines.")
    fields = [f.strip() for f in lines[1].split(",")]
    fields = [f for f in fields if f != ""]
    try:
        nchan, npts = int(fields[0]), int(fields[1])
        dx = float(fields[5])
    except (ValueError, IndexError):
        raise InputFormatError(f"{path}: line 2: expected 'NCHAN, NPTS, f3, f4, f5, DX, X0'; got {lines[1]!r}.") from None
    if nchan < 1 or npts < 2 or not dx > 0:
        raise InputFormatError(f"{path}: line 2: need NCHAN >= 1, NPTS >= 2, DX > 0; got {nchan}, {npts}, {dx}.")
    x0 = 0.0
    if len(fields) > 6 and any(ch in fields[6] for ch in ".eE"):
        try:
            x0 = float(fields[6])
        except ValueError:
            raise InputFormatError(f"{path}: line 2: field 7 (first station) is not a number: {fields[6]!r}.") from None
    keys: dict[str, str] = {}
    end = None
    for i in range(2, len(lines)):
        line = lines[i]
        if line.strip().upper() == "END":
            end = i
            break
        if line.strip():
            keys.setdefault(line[:8].strip().upper(), line[8:])
    if end is None:
        raise InputFormatError(f"{path}: no END line closing the header.")
    names = _fields8(keys["SHORTNAM"], nchan) if "SHORTNAM" in keys else [f"ch{k + 1}" for k in range(nchan)]
    if len(names) != nchan:
        raise InputFormatError(f"{path}: SHORTNAM names {len(names)} channel(s) but line 2 says NCHAN = {nchan}.")
    if "UNITSNAM" in keys:
        chan_units = _fields8(keys["UNITSNAM"], nchan)
        if len(chan_units) != nchan:
            raise InputFormatError(f"{path}: UNITSNAM gives {len(chan_units)} unit(s) for {nchan} channel(s).")
        if units is not None and any(u.lower() != units.lower() for u in chan_units):
            raise UnitsError(f"{path}: the header gives units {chan_units} but units={units!r} was given; remove the "
                             "option or fix the header.")
    elif units is None:
        raise UnitsError(f"{path}: the ERD header has no UNITSNAM line; pass --units m|mm (units=...) or add the "
                         "line. Units are never guessed.")
    else:
        chan_units = [units] * nchan
    factors = [unit_factor(u) for u in chan_units]
    xunit = keys.get("XUNITS", "").strip() or distance_units
    if not xunit:
        raise UnitsError(f"{path}: the ERD header has no XUNITS line; pass distance_units or add 'XUNITS  m'.")
    xfactor = unit_factor(xunit, what="distance")
    values = []
    for i in range(end + 1, len(lines)):
        text = lines[i].replace(",", " ").split()
        if not text:
            continue
        try:
            row = [float(t) for t in text]
        except ValueError:
            bad = next(t for t in text if not _is_float(t))
            raise InputFormatError(f"{path}: line {i + 1}: {bad!r} is not a number.") from None
        values.extend(row)
        if len(values) > nchan * npts:
            raise InputFormatError(f"{path}: line {i + 1}: more values than NCHAN x NPTS = {nchan} x {npts}.")
    if len(values) != nchan * npts:
        raise InputFormatError(f"{path}: the data have {len(values)} values; line 2 announces NCHAN x NPTS = "
                               f"{nchan} x {npts} = {nchan * npts}.")
    data = np.asarray(values).reshape(npts, nchan) * np.asarray(factors)
    keep = list(range(nchan)) if tracks is None else [_index(path, names, t) for t in
                                                      ([tracks] if isinstance(tracks, str) else tracks)]
    x = (x0 + dx * np.arange(npts)) * xfactor
    title = keys.get("TITLE", "").strip() or path.stem
    return Profile(distance=x, elevation=data[:, keep], tracks=tuple(names[k] for k in keep), name=title)


def _is_float(t: str) -> bool:
    try:
        float(t)
        return True
    except ValueError:
        return False


def _index(path, names, t):
    if t not in names:
        raise InputError(f"{path}: no channel {t!r}; the file has {names}.")
    return names.index(t)


def write_erd(profile, path, *, units: str = "mm", title: str | None = None) -> Path:
    """Write a regularly spaced profile as a text ERD file (stations in m, elevations in ``units``).

    Raises
    ------
    InputError
        Irregular stations (ERD stores a constant step; write CSV/Parquet instead) or track names longer than
        8 characters or with blanks (the ERD name field).
    """
    path = Path(path)
    factor = unit_factor(units)
    dx = profile.spacing
    if dx is None:
        raise InputError("ERD files store a constant station step; this profile is irregular. Write it as CSV or "
                         "Parquet instead.")
    for t in profile.tracks:
        if len(t) > 8 or " " in t:
            raise InputError(f"track name {t!r} does not fit the 8-character ERD name field; rename the track.")
    n, k = profile.elevation.shape
    head = [
        "ERDFILEV2.00",
        f"{k:>6},{n:>10},{-1:>6},{1:>6},{5:>6},{dx:>16.9E},{profile.distance[0]:>16.9E},",
        f"TITLE   {title or profile.name or 'longprofile'}",
        "SHORTNAM" + "".join(f"{t:<8}" for t in profile.tracks),
        "UNITSNAM" + "".join(f"{units:<8}" for _ in profile.tracks),
        "XUNITS  m",
        "END",
    ]
    body = "\n".join(" ".join(f"{v:.10g}" for v in row) for row in profile.elevation / factor)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(head) + "\n" + body + "\n")
    return path
