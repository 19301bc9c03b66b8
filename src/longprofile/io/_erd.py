"""ERD files: the UMTRI text format used by ProVAL, RoadRuf and the LTPP profile data.

Layout read and written here (text data only; UMTRI, *The ERD File Specification*, and the LTPP files)::

    ERDFILEV2.00                            <- line 1: identifies the format
    NCHAN, NPTS, -1, 1, 5, DX, X0,          <- line 2: 7 comma-separated fields (a trailing comma is usual)
    TITLE   free text
    SHORTNAMleft    right                   <- channel names, one 8-character field per channel
    UNITSNAMmm      mm                      <- elevation unit of each channel, 8-character fields
    XUNITS  m                               <- unit of the stations (of DX and X0)
    END
    v11 v12                                 <- NPTS records of NCHAN numbers (blank or comma separated)

Line 2: field 1 NCHAN = number of channels, field 2 NPTS = number of records (samples per channel),
field 6 DX = station step and field 7 X0 = station of the first record, both in ``XUNITS``: the stations are
``X0 + i DX``. Each is a plain number in any notation (``0``, ``100``, ``100.0``, ``1.0E+02``). Fields 3-5
describe how the data are stored (text here; the LTPP and ProVAL files carry ``-1, 1, 5``); they are not
interpreted, and binary data (a companion ``.bin`` file) are not supported.

Header keyword lines have the keyword in columns 1-8 and the value after it; unknown keywords (``DATE``,
``LONGNAME``...) are ignored. The records are read in order, NCHAN values each, whatever the line breaks.
"""

from __future__ import annotations

import csv
import io
import math
import re
from pathlib import Path

import numpy as np

from .._validation import MISSING_PROFILE_HINT
from ..core import Profile, length_unit, unit_factor
from ..errors import InputError, InputFormatError, OutputError, UnitsError
from ._atomic import atomic_path
from ._plausible import check_missing_codes

__all__ = ["read_erd", "write_erd"]

#: The END line closing the header (columns around it may hold blanks; CRLF files allowed).
_END = re.compile(rb"^[ \t]*END[ \t]*\r?$", re.MULTILINE | re.IGNORECASE)
#: An empty value of a comma-separated body: two commas in a row, or a comma opening a line.
_EMPTY_FIELD = re.compile(rb",[ \t]*,|^[ \t]*,", re.MULTILINE)
#: Text a body cell may hold for a missing sample.
_NAN_TOKENS = ["nan", "NaN", "NAN", "-nan", "+nan"]
#: The spellings for a refusal, grouped by unit.
_SPELLED_NAMES = ("inch(es), foot/feet, millimeter(s)/millimetre(s), centimeter(s)/centimetre(s), meter(s)/metre(s), "
                  "kilometer(s)/kilometre(s), mile(s) (any letter case)")
#: A UTF-8 byte order mark (Windows editors put one at the start of a text file).
_BOM = b"\xef\xbb\xbf"
#: Station error tolerated when a profile is written as X0 + i DX, m.
_STATION_TOLERANCE = 1e-6
#: Resolution of the written elevations, m: the number of decimals is chosen per unit so that a written and
#: read-back elevation is within half of this (5e-8 m) of the original.
_RESOLUTION = 1e-7


def _fields8(path: Path, key: str, entry: tuple[int, str], n: int) -> list[str]:
    """The ``n`` per-channel fields of a SHORTNAM/UNITSNAM value (``entry``: its file line and the text after the
    keyword).

    The ERD convention is one 8-character field per channel. When the value holds exactly ``n`` blank-separated
    words (blanks or tabs, a hand-written ``SHORTNAM  LEFT RIGHT`` or ``UNITSNAM  inch inch``, or the long names
    :func:`write_erd` writes blank-separated), the words are the fields: the 8-character columns would cut them
    (``'LEFT R'``, ``'IGHT'``). Otherwise the 8-character fields are read (names of 8 characters written without a
    blank between them, names holding a blank), unless one of them looks cut (a word crossing a field boundary
    that starts after a blank of its field); then the line is refused.
    """
    lineno, value = entry
    value = value.rstrip("\r\n ")
    words = value.split()
    if len(words) == n:
        return words
    value = value.expandtabs(8)
    parts = [value[i:i + 8].strip() for i in range(0, 8 * n, 8)]
    if len(value) <= 8 * n and all(parts) and not _looks_cut(value, n):
        return parts
    raise InputFormatError(f"{path}: line {lineno}: {key} gives neither {n} blank-separated names nor {n} "
                           f"8-character fields (NCHAN = {n} on line 2): {value.strip()!r}; write one name per "
                           "channel, separated by blanks.")


def _looks_cut(value: str, n: int) -> bool:
    """Whether a word crosses a boundary of the 8-character fields having started after a blank of its field (a
    name of exactly 8 characters followed at once by the next is not cut)."""
    for b in range(8, 8 * n, 8):
        if b < len(value) and not value[b - 1].isspace() and not value[b].isspace() \
                and any(c.isspace() for c in value[b - 8:b]):
            return True
    return False


def _line2(path: Path, line: str) -> tuple[int, int, float, float]:
    """NCHAN, NPTS, DX, X0 from line 2 (any numeric notation)."""
    fields = [f.strip() for f in line.split(",")]
    fields = [f for f in fields if f != ""]
    expected = "expected 7 comma-separated fields 'NCHAN, NPTS, f3, f4, f5, DX, X0'"
    if len(fields) < 7:
        raise InputFormatError(f"{path}: line 2: {expected}; got {len(fields)} in {line.strip()!r}.")

    def number(k: int, name: str) -> float:
        try:
            v = float(fields[k])
        except ValueError:
            raise InputFormatError(f"{path}: line 2: field {k + 1} ({name}) is not a number: {fields[k]!r} "
                                   f"({expected}).") from None
        if not math.isfinite(v):
            raise InputFormatError(f"{path}: line 2: field {k + 1} ({name}) must be finite; got {fields[k]!r}.")
        return v

    def count(k: int, name: str) -> int:
        v = number(k, name)
        if not v.is_integer():
            raise InputFormatError(f"{path}: line 2: field {k + 1} ({name}) must be a whole number; got {fields[k]!r}.")
        return int(v)

    nchan, npts = count(0, "NCHAN"), count(1, "NPTS")
    dx, x0 = number(5, "DX"), number(6, "X0")
    if nchan < 1 or npts < 2 or not dx > 0:
        raise InputFormatError(f"{path}: line 2: need NCHAN >= 1, NPTS >= 2 and DX > 0; got NCHAN = {nchan}, "
                               f"NPTS = {npts}, DX = {dx:g}.")
    return nchan, npts, dx, x0


def _split_header(path: Path, raw: bytes) -> tuple[list[str], int, int]:
    """Header lines (line 1 .. the line before END), the byte offset of the data and the file line of END."""
    if not raw[:4096].strip() and not raw.strip():
        raise InputFormatError(f"{path}: empty file; expected an ERD file starting with 'ERDFILEV2.00'.")
    first = raw[:raw.find(b"\n") if b"\n" in raw else len(raw)]
    if b"\x00" in raw[:4096]:
        raise InputFormatError(f"{path}: not a text file (binary ERD data are not supported; export the profile as "
                               "text ERD, CSV or Parquet).")
    if not first.strip().upper().startswith(b"ERDFILEV2"):
        raise InputFormatError(f"{path}: line 1: expected 'ERDFILEV2.00', got "
                               f"{first[:20].decode('latin-1').strip()!r}.")
    m = _END.search(raw, len(first))
    if m is None:
        raise InputFormatError(f"{path}: no END line closing the header (a line holding only END must follow the "
                               "keyword lines).")
    head = raw[:m.start()]
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError:
        text = head.decode("latin-1")  # Windows tools write titles in a code page
    lines = [ln.rstrip("\r") for ln in text.split("\n")]
    if lines and lines[-1] == "":
        lines.pop()
    end_line = head.count(b"\n") + 1
    return lines, m.end() + 1, end_line


def _parse_body_fast(raw: bytes, start: int, nchan: int, npts: int) -> np.ndarray | None:
    """The ``(npts, nchan)`` records by pandas' C parser, or None when anything is off (then the slow pass)."""
    import pandas as pd

    body = raw[start:]
    if b"," in body:
        if _EMPTY_FIELD.search(body):
            return None
        body = body.replace(b",", b" ")
    try:
        frame = pd.read_csv(io.BytesIO(body), sep=r"\s+", header=None, dtype=np.float64, engine="c",
                            keep_default_na=False, na_values=_NAN_TOKENS, quoting=csv.QUOTE_NONE,
                            skip_blank_lines=True)
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        return None
    values = frame.to_numpy(dtype=np.float64)
    if values.shape == (npts, nchan):
        return values
    return values.reshape(npts, nchan) if values.size == nchan * npts else None


def _tokens(path: Path, lineno: int, line: str) -> list[str]:
    if "," not in line:
        return line.split()
    parts = [p.strip() for p in line.split(",")]
    if parts and parts[-1] == "":
        parts.pop()  # trailing comma
    if any(p == "" for p in parts):
        raise InputFormatError(f"{path}: line {lineno}: empty value between commas in {line.strip()!r}; write a "
                               "number (or nan for a missing sample) in every field.")
    return [t for p in parts for t in p.split()]


def _parse_body_slow(path: Path, raw: bytes, start: int, first_line: int, nchan: int, npts: int) -> np.ndarray:
    """Line-by-line pass: the values, or an error naming the first bad line of the file."""
    expected = nchan * npts
    values: list[float] = []
    for k, line in enumerate(raw[start:].decode("utf-8", errors="replace").split("\n")):
        lineno = first_line + k
        tokens = _tokens(path, lineno, line)
        for t in tokens:
            try:
                values.append(float(t))
            except ValueError:
                raise InputFormatError(f"{path}: line {lineno}: {t!r} is not a number.") from None
        if len(values) > expected:
            _refuse_decimal_commas(path, raw, start, first_line, expected)
            raise InputFormatError(f"{path}: line {lineno}: more values than NCHAN x NPTS = {nchan} x {npts} = "
                                   f"{expected} announced on line 2.")
    if len(values) != expected:
        _refuse_decimal_commas(path, raw, start, first_line, expected)
        raise InputFormatError(f"{path}: the data have {len(values)} values; line 2 announces NCHAN x NPTS = "
                               f"{nchan} x {npts} = {expected}.")
    return np.asarray(values, dtype=np.float64)


#: A number written with a decimal comma (``0,7866``, ``-12,5``): digits on both sides of the comma.
_DECIMAL_COMMA = re.compile(rb"(?<![\d.,])-?\d+,\d+(?![\d.,])")


def _refuse_decimal_commas(path: Path, raw: bytes, start: int, first_line: int, expected: int) -> None:
    """Refuse a body written with decimal commas (``0,7866 0,3635``: a spreadsheet in a decimal-comma locale), which
    gives the wrong count of values: when it holds no decimal point and reading each comma as one gives exactly
    NCHAN x NPTS values, the file line of the first such number is named. Nothing is read on a guess."""
    body = raw[start:]
    if b"." in body or b"," not in body:
        return
    m = _DECIMAL_COMMA.search(body)
    if m is None or len(body.replace(b",", b".").split()) != expected:
        return
    line = first_line + body.count(b"\n", 0, m.start())
    text = body[body.rfind(b"\n", 0, m.start()) + 1:].split(b"\n", 1)[0].decode("utf-8", "replace").strip()
    raise InputFormatError(f"{path}: line {line}: the data are written with decimal commas ({text!r}); ERD numbers "
                           "take decimal points: export the file again with decimal points (or replace each comma "
                           "of the data lines by a point).")


def read_erd(path, *, units: str | None = None, tracks=None, distance_units: str | None = None):
    """Read a text ERD profile file.

    Parameters
    ----------
    path : path-like
    units : str, optional
        Elevation unit (m, mm, cm, in, ft...) to use when the header has no ``UNITSNAM`` line (never guessed).
        If the header gives units and ``units`` disagrees, :class:`UnitsError`.
    tracks : str or sequence of str, optional
        Channels to keep, by ``SHORTNAM`` (default all; unnamed channels are ``ch1``, ``ch2``...).
    distance_units : str, optional
        Station unit when the header has no ``XUNITS`` line; if both are given they must agree.

    Returns
    -------
    Profile
        Stations ``(X0 + i DX) * xunit``, i = 0 .. NPTS-1, and elevations ``(NPTS, K)``, in metres; named by
        the ``TITLE`` line (else the file name).

    Raises
    ------
    InputFormatError
        Not an ERD file, bad line 2, missing END, a non-number in the data, or not NCHAN x NPTS values: the
        message names the file line.
    UnitsError
        Units missing (and not given), unknown or contradicting the header.

    Notes
    -----
    Layout: module docstring (UMTRI ERD specification; the LTPP and ProVAL text files). Every header field
    that defines a number is honoured: NCHAN, NPTS, DX, X0 (line 2), ``UNITSNAM`` and ``XUNITS`` (short unit names or
    spelled out: ``inches``, ``Feet``, ``millimetres``...). A UTF-8 byte order mark and an ``END`` line after the
    records are ignored. The data are
    parsed by pandas' C reader; only when that fails, or the count of values is not NCHAN x NPTS, a line-by-line
    pass finds and names the offending line (it also reads records broken over several lines).
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file.")
    if path.is_dir():
        raise InputError(f"{path} is a folder; give an ERD file.")
    raw = path.read_bytes()
    raw = raw[len(_BOM):] if raw.startswith(_BOM) else raw  # as the CSV reader, a byte order mark is ignored
    lines, start, end_line = _split_header(path, raw)
    if len(lines) < 2:
        raise InputFormatError(f"{path}: line 2: expected 'NCHAN, NPTS, f3, f4, f5, DX, X0' before END.")
    nchan, npts, dx, x0 = _line2(path, lines[1])
    keys: dict[str, str] = {}
    fields: dict[str, tuple[int, str]] = {}  # SHORTNAM/UNITSNAM: file line and value
    for lineno, line in enumerate(lines[2:], start=3):
        if line.strip():
            keys.setdefault(line[:8].strip().upper(), line[8:])
            fields.setdefault(line[:8].strip().upper(), (lineno, line[8:]))
    names = (_fields8(path, "SHORTNAM", fields["SHORTNAM"], nchan) if "SHORTNAM" in keys
             else [f"ch{k + 1}" for k in range(nchan)])
    keep = list(range(nchan)) if tracks is None else [_index(path, names, t) for t in
                                                      ([tracks] if isinstance(tracks, str) else tracks)]
    if "UNITSNAM" in keys:
        chan_units = [_spelled(u) for u in _fields8(path, "UNITSNAM", fields["UNITSNAM"], nchan)]
        wrong = [chan_units[k] for k in keep if units is not None and chan_units[k].lower() != _spelled(units).lower()]
        if wrong:
            raise UnitsError(f"{path}: the header gives units {chan_units} but units={units!r} was given; remove the "
                             "option or fix the header.")
    elif units is None:
        raise UnitsError(f"{path}: the ERD header has no UNITSNAM line; pass --elevation-unit m|mm (units=...) or "
                         "add the line. Units are never guessed.")
    else:
        chan_units = [_spelled(units)] * nchan
    factors = np.array([_unit(path, chan_units[k], "UNITSNAM", "elevation") for k in keep])
    xunit = _spelled(keys.get("XUNITS", ""))
    if xunit and distance_units is not None and xunit.lower() != _spelled(distance_units).lower():
        raise UnitsError(f"{path}: XUNITS is {xunit!r} but distance_units={distance_units!r} was given; remove the "
                         "option or fix the header.")
    xunit = xunit or distance_units
    if not xunit:
        raise UnitsError(f"{path}: the ERD header has no XUNITS line; pass distance_units or add 'XUNITS  m'.")
    xfactor = _unit(path, xunit, "XUNITS", "distance")
    binary = [b for b in (path.with_suffix(".bin"), path.with_name(path.name + ".bin")) if b.exists()]
    if binary and not raw[start:].strip():
        raise InputFormatError(f"{path}: the data are in the binary file {binary[0].name}, which is not supported; "
                               "export the profile as text ERD, CSV or Parquet.")
    end = _body_end(raw, start)
    raw = raw if end == len(raw) else raw[:end]
    values = _parse_body_fast(raw, start, nchan, npts)
    if values is None:
        values = _parse_body_slow(path, raw, start, end_line + 1, nchan, npts).reshape(npts, nchan)
    x = (x0 + dx * np.arange(npts)) * xfactor
    check_missing_codes(path, x, values[:, keep], [names[k] for k in keep], [chan_units[k] for k in keep], factors,
                        hint=_ERD_MISSING_HINT)
    data = values[:, keep] * factors
    title = keys.get("TITLE", "").strip() or path.stem
    return Profile(distance=x, elevation=data, tracks=tuple(names[k] for k in keep), name=title)


#: What a refusal of a missing-value code in an ERD file says to do: ERD has no cells to leave empty; its missing
#: sample is the text ``nan``.
_ERD_MISSING_HINT = ("write nan in place of each missing value (an ERD file's missing sample), then "
                     + MISSING_PROFILE_HINT.split(", then ", 1)[1])


def _spelled(unit: str) -> str:
    """The short name of a unit, spelled out or not (``inches``, ``Metres``, ``MM`` -> ``in``, ``m``, ``mm``:
    :func:`longprofile.core.length_unit`, the table the CSV column names are read with); any other text unchanged."""
    return length_unit(unit) or unit.strip()


def _unit(path: Path, unit: str, key: str, what: str) -> float:
    try:
        return unit_factor(unit, what=what)
    except UnitsError as exc:
        raise UnitsError(f"{path}: {key}: {str(exc).rstrip('.')}, or spelled out: {_SPELLED_NAMES}.") from None


def _body_end(raw: bytes, start: int) -> int:
    """Where the records end: before an END line after them (some writers close the data with one; blank lines after
    it aside), else the end of the file."""
    stripped = raw.rstrip()
    cut = stripped.rfind(b"\n") + 1
    if cut >= start and stripped[cut:].strip().upper() == b"END":
        return cut
    return len(raw)


def _index(path, names, t):
    """The channel named ``t``: that exact name, else the one name equal to it in any letter case (``--track left``
    finds ``Left``, as in CSV files)."""
    if t in names:
        return names.index(t)
    same = [k for k, name in enumerate(names) if name.casefold() == str(t).casefold()]
    if len(same) != 1:
        raise InputError(f"{path}: no channel {t!r}; the file has {names}." if not same else
                         f"{path}: {len(same)} channels are {t!r} in some letter case ({[names[k] for k in same]}); "
                         "give the exact name.")
    return same[0]


def _decimals(factor: float) -> int:
    """Decimals of a value in a unit of ``factor`` m so that the printed resolution is <= _RESOLUTION."""
    return max(0, math.ceil(math.log10(factor / _RESOLUTION) - 1e-9))


def _shortest_step(x0: float, x1: float, n: int, tolerance: float = 1e-9) -> float:
    """The step from ``x0`` to ``x1`` in ``n - 1`` steps, with the fewest significant digits that still lands on
    ``x1`` within ``tolerance`` (1e-9 m in the stations' unit; 0.025, not the 0.02499999999999858 that the
    subtraction gives)."""
    exact = (x1 - x0) / (n - 1)
    for digits in range(1, 17):
        dx = float(f"{exact:.{digits}g}")
        if abs(x0 + dx * (n - 1) - x1) <= tolerance:
            return dx
    return exact


#: How :func:`write_erd` names a unit in UNITSNAM/XUNITS: inches and feet spelled out, as ProVAL writes its US files
#: (``UNITSNAM inches``, ``XUNITS feet``); the others by their short name.
_WRITTEN_NAMES = {"in": "inches", "ft": "feet"}


def write_erd(profile, path, *, units: str = "mm", title: str | None = None, distance_units: str = "m") -> Path:
    """Write a regularly spaced profile as a text ERD file (stations in ``distance_units``, elevations in ``units``).

    Parameters
    ----------
    profile : Profile
        Stations ``X0 + i DX`` (checked to 1e-6 m) and one channel per track. ``profile.std`` is not written
        (ERD holds elevations only; write CSV or Parquet to keep it).
    path : path-like
    units : str
        Elevation unit of the file (m, mm, cm, in, ft...; ProVAL and LTPP use mm or in).
    title : str, optional
        ``TITLE`` line (default: the profile name).
    distance_units : str
        Unit of the stations, DX and X0 (``XUNITS``): m (default) or ft for a US file (with ``units="in"``: the
        ``UNITSNAM inches`` / ``XUNITS feet`` a ProVAL US file has), km, mi...

    Returns
    -------
    Path

    Notes
    -----
    Read back by :func:`read_erd`, stations are identical to 1e-9 m (in feet: to the float round-off of the
    conversion, 1e-9 m over 100 km) and elevations to half the printed resolution: 1e-7 m, i.e. 4 decimals in mm, 7
    in m, 6 in inches (error <= 5e-8 m). DX and X0 are written in ``distance_units`` in their shortest exact form
    (``repr``); inches and feet are written spelled out (``inches``, ``feet``), as ProVAL writes them. Track names of up to 8 characters fill the 8-character
    ``SHORTNAM`` fields; longer names are written blank-separated (read back whole by :func:`read_erd`; other
    readers may cut them at 8 characters). NaN elevations are written ``nan``. The body is formatted by
    pyarrow's CSV writer (values rounded to the decimals first, then printed in their shortest form).

    Raises
    ------
    InputError
        Irregular stations (ERD stores a constant step; write CSV/Parquet instead), fewer than 2 samples, or a
        track name that is empty or holds blanks.
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    path = Path(path)
    factor = unit_factor(units)
    xfactor = unit_factor(distance_units, what="distance")
    x = profile.distance
    n, k = profile.elevation.shape
    if n < 2:
        raise InputError("an ERD file needs at least 2 samples (the step DX is implied by them).")
    x0 = float(x[0]) / xfactor
    dx = _shortest_step(x0, float(x[-1]) / xfactor, n, 1e-9 / xfactor)
    deviation = np.abs(x - (x0 + dx * np.arange(n)) * xfactor)
    worst = int(np.argmax(deviation))
    if deviation[worst] > _STATION_TOLERANCE:
        raise InputError(f"ERD files store a constant station step; this profile is irregular (station "
                         f"{x[worst]:.6f} m is {deviation[worst]:.3g} m off the grid X0 + i DX, DX = "
                         f"{dx * xfactor:.9g} m). "
                         "Write it as CSV or Parquet instead, or resample it (`road convert --spacing DX`, "
                         "longprofile.road.resample_profile).")
    for t in profile.tracks:
        if not t or any(c.isspace() for c in t):
            raise InputError(f"track name {t!r} cannot be an ERD channel name (empty or with blanks); rename the "
                             f"track (road convert --rename '{t}={_channel_name(t)}'; a library call: "
                             "Profile(..., tracks=...)).")
    names = "".join(f"{t:<8}" for t in profile.tracks)
    if any(len(t) > 8 for t in profile.tracks):
        names = " ".join(f"{t:<8}" for t in profile.tracks)
    name = (title or profile.name or "longprofile").replace("\r", " ").replace("\n", " ")
    head = "\n".join([
        "ERDFILEV2.00",
        f"{k:>6},{n:>10},{-1:>6},{1:>6},{5:>6},{dx!r:>24},{x0!r:>24},",
        f"TITLE   {name}",
        "SHORTNAM" + names,
        "UNITSNAM" + "".join(f"{_WRITTEN_NAMES.get(length_unit(units), units):<8}" for _ in profile.tracks),
        f"XUNITS  {_WRITTEN_NAMES.get(length_unit(distance_units), distance_units)}",
        "END",
        "",
    ])
    z = np.round(profile.elevation / factor, _decimals(factor))
    table = pa.table({f"c{j}": z[:, j] for j in range(k)})
    try:
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:  # the old file is replaced only when complete
            fh.write(head.encode("utf-8"))
            pacsv.write_csv(table, fh, write_options=pacsv.WriteOptions(include_header=False, delimiter=" "))
    except OSError as exc:
        raise OutputError(f"cannot write {path}: {exc.strerror or exc}.") from None
    return path


def _channel_name(track: str) -> str:
    """A channel name for a track name holding blanks, for a refusal's example: its first word in lower case
    (``Left Elevation`` -> ``left``), ``ch1`` when it has none."""
    words = str(track).split()
    return words[0].lower() if words else "ch1"
