"""Profile files: CSV and Parquet with explicit units (station column + one column per track)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .._validation import true_runs
from ..core import LENGTH_UNITS, UNCONVERTED_LENGTH_UNITS, Profile, length_unit, unit_factor
from ..errors import InputError, InputFormatError, UnitsError
from ._plausible import check_missing_codes
from ._tables import read_table, write_table

__all__ = ["read_profile_table", "write_profile_table", "read_apl_signal", "read_apl_recording", "APLSignalFile",
           "backward_stations",
           "read_sampled_column",
           "RECONSTRUCT_COLUMNS", "RECORDING_COLUMNS", "is_reconstruct_output", "is_simulated_recording"]

#: Columns of a ``road reconstruct`` output table: one profile (``elevation``) plus diagnostics.
RECONSTRUCT_COLUMNS = ("distance_m", "elevation_m", "std_m", "raw_m", "raw_std_m")
#: Columns of a ``road simulate`` recording: the true profile (``true``) and the trailer's raw signal (``apl``).
RECORDING_COLUMNS = ("distance_m", "true_m", "apl_m")

_DISTANCE_NAMES = ("distance", "station", "chainage", "x")


def _with_rows(df: pd.DataFrame, path: Path) -> pd.DataFrame:
    """``df``, refused when the file had a header and no data rows."""
    if len(df) == 0:
        raise InputFormatError(f"{path}: the file has a header ({', '.join(map(str, df.columns))}) but no data rows; "
                               "one row per sample is needed.")
    return df


def _without_empty_tail(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` without its last rows whose every cell is empty: a spreadsheet's trailing ``,,,`` rows hold no sample."""
    filled = df.notna().to_numpy().any(axis=1)
    last = int(np.flatnonzero(filled)[-1]) + 1 if filled.any() else 0
    return df if last == len(df) else df.iloc[:last]


def _split(column: str) -> tuple[str, str | None]:
    """(base name, unit) of a column named ``name_unit``, ``name [unit]`` or ``name (unit)`` (the last as
    spreadsheets and ProVAL-style exports write it), the unit a :data:`longprofile.core.LENGTH_UNITS` key, short or
    spelled out as in ERD headers (``LWP (inches)``, ``Distance (feet)``, ``left_MM``:
    :func:`longprofile.core.length_unit`); (name, None) when the name gives none."""
    m = _ANY_SUFFIX.match(column.strip())
    unit = m and length_unit(m.group("u1") or m.group("u2") or m.group("u3"))
    return (m.group("base").strip(), unit) if unit else (column.strip(), None)


def _elevation_unit(path, column, unit, units, *, chosen: bool):
    """(column, unit) of an elevation column: its declared unit, else ``units``; refused without either, or when the
    two differ."""
    if unit is None:
        _refuse_unconverted(path, column)
        if units is None:
            hint = "" if chosen else " If it is not a track, choose the tracks with --track (e.g. --track left,right)."
            m = _ANY_SUFFIX.match(column.strip())
            named = (f"'{m.group('base').strip()} [mm]' ({m.group(0)[len(m.group('base')):].strip()!r} is no unit "
                     f"read: {', '.join(LENGTH_UNITS)} or spelled out, e.g. inches, feet)"
                     if m and not m.group("u1") else f"{column}_mm")
            raise UnitsError(f"{path}: column {column!r} does not give its elevation unit; pass --elevation-unit m|mm "
                             f"(units=...) or name the column e.g. {named}. Units are never guessed.{hint}")
        return column, length_unit(units) or units
    if units is not None and unit != (length_unit(units) or units.lower()):
        raise UnitsError(f"{path}: column {column!r} is in {unit!r} by its header but the unit {units!r} was given "
                         "(--elevation-unit, units=); remove the option or fix the header.")
    return column, unit


def _refuse_unconverted(path, column) -> None:
    """Refuse a column whose name gives a length unit this package does not convert (``LWP (µm)``): named, never
    read in another unit."""
    unit = _unconverted(str(column))
    if unit:
        raise UnitsError(f"{path}: column {column!r} is in {unit!r}, a unit this package does not convert (it reads "
                         f"{', '.join(LENGTH_UNITS)}, or spelled out: inches, feet...): convert the column to mm or m "
                         "and name it so (e.g. left_mm); it is never read in another unit.")


def _line_namer(path: Path):
    """Where row ``i`` of a table is, for a message: ``line i + 2`` of a CSV (after its header), ``row i`` else."""
    return (lambda i: f"line {i + 2}") if path.suffix.lower() in (".csv", ".txt") else (lambda i: f"row {i}")


def _numeric_column(path: Path, df: pd.DataFrame, column, line) -> np.ndarray:
    """Column ``column`` of ``df`` as floats (empty cells NaN); a non-numeric cell is refused with its line."""
    conv = pd.to_numeric(df[column], errors="coerce")
    bad = conv.isna() & df[column].notna()
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputFormatError(f"{path}: {line(i)}: column {column!r} has a non-numeric value {df[column].iloc[i]!r}.")
    return conv.to_numpy(dtype=float)


def _station_column(path: Path, df: pd.DataFrame, parsed: dict, distance_column):
    """The station column: ``distance_column``, else the first named distance/station/chainage/x (one with its
    unit first); refused when there is none, or it does not give its unit (a unit on the row under the header is
    named: it is not read)."""
    if distance_column is None:
        candidates = sorted((c for c, (base, _) in parsed.items() if base.lower() in _DISTANCE_NAMES),
                            key=lambda c: parsed[c][1] is None)
        if not candidates:
            raise InputFormatError(f"{path}: no station column; expected one named distance, station, chainage or x "
                                   "with its unit (distance_m, chainage_km, 'Distance [m]', 'Station (ft)'); the file "
                                   f"has {list(df.columns)}: rename the station column so (a library call can name "
                                   "it: distance_column=..., its unit still in the name).")
        distance_column = candidates[0]
    elif distance_column not in df.columns:
        raise InputFormatError(f"{path}: no column {distance_column!r}; the file has {list(df.columns)}.")
    if parsed[distance_column][1] is None:
        _refuse_unconverted(path, distance_column)
        first = str(df[distance_column].iloc[0]).strip() if len(df) else ""
        below = (f" (the row under the header holds {first!r}: a unit there is not read; put it in the header, "
                 f"e.g. '{distance_column} [{first}]', and delete that row)" if first.lower() in LENGTH_UNITS else "")
        raise UnitsError(f"{path}: the station column {distance_column!r} does not give its unit; rename it e.g. "
                         f"distance_m (stations are never assumed to be in metres){below}.")
    return distance_column


def _check_stations(path: Path, column, written, x, line) -> None:
    """Refuse stations ``x`` (m; ``written`` as in the file) that are empty, decrease throughout (the way out
    named) or do not increase strictly (the line named, with the likely cause of a repeat)."""
    if np.isnan(x).any():
        i = int(np.flatnonzero(np.isnan(x))[0])
        raise InputFormatError(f"{path}: {line(i)}: empty station in column {column!r}.")
    step = np.diff(x)
    if x.size > 1 and np.all(step < 0):
        raise InputFormatError(f"{path}: the stations in column {column!r} decrease ({written[0]:g} .. "
                               f"{written[-1]:g}); they must increase in the driving direction: if the file lists the "
                               "run backwards, reverse its rows; if the run was driven the other way, give the "
                               "distances from its start.")
    if x.size > 1 and np.any(step <= 0):
        i = int(np.flatnonzero(step <= 0)[0]) + 1
        raise InputFormatError(f"{path}: {line(i)}: station {written[i]:g} is not greater than the previous one "
                               f"{written[i - 1]:g}; stations must increase strictly{_repeat_cause(step, i)}.")


def _runs_backwards(x) -> bool:
    """Whether stations ``x`` decrease throughout (every step < 0, none empty): a run driven against the stationing
    (a southbound lane whose stations count down), which :func:`read_profile_table` reads in the order of its rows,
    the direction of travel, as the distance travelled from the first row (docs/file-formats.md, ASSUMPTION)."""
    x = np.asarray(x, float)
    return x.size > 1 and not np.isnan(x).any() and bool(np.all(np.diff(x) < 0))


def backward_stations(path) -> tuple[str, float, float] | None:
    """(station column, first station, last station, as written) of a CSV/Parquet profile whose stations decrease
    throughout, which :func:`longprofile.io.read_profile` reads as the distance travelled from the first row (the
    CLI notes it); None for any other file, or one that cannot be read (its reader reports the problem).

    Only the first two data rows are read unless they decrease (then the station column)."""
    path = Path(path)
    if path.suffix.lower() not in (".csv", ".txt", ".parquet", ".pq") or not path.is_file():
        return None
    if path.suffix.lower() in (".csv", ".txt") and not _first_steps_decrease(path):
        return None
    try:
        df = _without_empty_tail(read_table(path, dialect=True))
        column = _station_column(path, df, {c: _split(str(c)) for c in df.columns}, None)
        x = pd.to_numeric(df[column], errors="coerce").to_numpy(float)
    except Exception:  # the reader reports it
        return None
    return (str(column), float(x[0]), float(x[-1])) if _runs_backwards(x) else None


def _first_steps_decrease(path: Path) -> bool:
    """Whether the first cell of the first two data rows of a CSV decreases (a cheap look before a full read): the
    station column is usually first; any doubt gives True (then the full read decides)."""
    rows = []
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            text = line.strip().lstrip("\ufeff")
            if text and not text.startswith("#"):
                rows.append(text)
            if len(rows) == 3:
                break
    if len(rows) < 3:
        return False
    sep = "," if "," in rows[0] else "\t" if "\t" in rows[0] else ";"
    try:
        first, second = (float(r.split(sep)[0].replace(",", ".")) for r in rows[1:])
    except ValueError:
        return True
    station_first = _split(rows[0].split(sep)[0].strip().strip('"'))[0].lower() in _DISTANCE_NAMES
    return second < first or not station_first


def _repeat_cause(step, i: int) -> str:
    """The likely cause of station ``i`` repeating the previous one: a stop (one run of repeats: keep one row) or
    stations rounded coarser than the sampling (repeats at many places); "" when it is smaller."""
    if step[i - 1] != 0:
        return ""
    runs = true_runs(step == 0)
    if len(runs) == 1:
        a, b = runs[0]
        return (f" ({b - a + 2} rows at this station: a stop? the rows logged at a standstill hold no road sample; "
                "keep one of them)")
    forward = step[step > 0]
    size = f", the others step by {float(np.min(forward)):.3g} m" if forward.size else ""
    return (f" (stations repeat at {len(runs)} places{size}: written with too few decimals for the sampling? export "
            "them with more decimals, or in metres)")


def read_profile_table(path: Path, *, units: str | None = None, tracks=None, distance_column: str | None = None):
    """CSV/Parquet body of :func:`longprofile.io.read_profile` (same parameters, returns and errors)."""
    path = Path(path)
    if units is not None:
        unit_factor(units)
    df = _with_rows(_without_empty_tail(read_table(path, dialect=True)), path)
    fmt_line = _line_namer(path)
    parsed = {c: _split(str(c)) for c in df.columns}
    distance_column = _station_column(path, df, parsed, distance_column)
    dunit = parsed[distance_column][1]
    columns = {}
    std_columns = {}
    for c, (base, unit) in parsed.items():
        if c == distance_column or (str(c).startswith("Unnamed: ") and df[c].isna().all()):
            continue  # a spreadsheet's empty trailing column (",," at the end of every row)
        if base.lower().endswith("_std"):
            std_columns[base[:-4]] = (c, unit)
        elif base.lower() == "std":  # `road reconstruct`'s std_m: the standard deviation of elevation_m
            std_columns["elevation"] = (c, unit)
        else:
            columns[base] = (c, unit)
    # a track's std pairs with it whatever the case of the header (ELEVATION_M with STD_M, Left_mm with left_std_mm)
    by_lower = {t.lower(): t for t in columns}
    std_columns = {by_lower.get(t.lower(), t): v for t, v in std_columns.items()}
    orphans = [c for t, (c, _) in std_columns.items() if t not in columns]
    if orphans:
        raise InputFormatError(f"{path}: column {orphans[0]!r} is a standard deviation but the file has no column of "
                               f"its elevations ({list(df.columns)}); a standard deviation is never read as a track.")
    chosen = tracks is not None
    recording = _is_header(df.columns, RECORDING_COLUMNS)
    if tracks is None and _is_header(df.columns, RECONSTRUCT_COLUMNS):
        # a `road reconstruct` output holds one profile: elevation_m with its std_m (raw_m is the undetrended
        # estimate, a diagnostic, not a track)
        tracks = ("elevation",)
    elif tracks is None and recording:
        tracks = ("true",)  # a `road simulate` recording: its one profile is the truth (apl_m is the raw signal)
    names = list(columns) if tracks is None else ([tracks] if isinstance(tracks, str) else list(tracks))
    names = [t if t in columns else by_lower.get(str(t).lower(), t) for t in names]  # --track left finds Left_mm
    for t in names:
        if t not in columns:
            raise InputError(f"{path}: no track {t!r}; {_tracks_line(df.columns, columns, recording)}.")
    _refuse_apl_signal(path, names, columns, recording=recording, chosen=chosen)
    if not names:
        raise InputFormatError(f"{path}: no elevation column besides {distance_column!r}.")
    for t in names:  # units are checked on the columns used only: a GPS or comment column is not a track
        columns[t] = _elevation_unit(path, *columns[t], units, chosen=tracks is not None)
        if t in std_columns:
            std_columns[t] = _elevation_unit(path, *std_columns[t], units, chosen=tracks is not None)
    used = [distance_column] + [columns[t][0] for t in names] + [std_columns[t][0] for t in names if t in std_columns]
    for c in used:
        df[c] = _numeric_column(path, df, c, fmt_line)
    x = df[distance_column].to_numpy() * unit_factor(dunit, what="distance")
    if _runs_backwards(x):  # a run driven against the stationing: distance travelled from its first row
        x = x[0] - x
    _check_stations(path, distance_column, df[distance_column].to_numpy(), x, fmt_line)
    raw = np.column_stack([df[columns[t][0]].to_numpy() for t in names])
    factors = [unit_factor(columns[t][1]) for t in names]
    check_missing_codes(path, x, raw, names, [columns[t][1] for t in names], factors)
    z = raw * np.array(factors)
    std = None
    if any(t in std_columns for t in names):
        std = np.full(z.shape, np.nan)
        for j, t in enumerate(names):
            if t in std_columns:
                c, u = std_columns[t]
                std[:, j] = df[c].to_numpy() * unit_factor(u)
    return Profile(distance=x, elevation=z, tracks=tuple(names), std=std, name=path.stem)


def write_profile_table(profile, path: Path, *, units: str = "m", distance_units: str = "m") -> Path:
    """CSV/Parquet body of :func:`longprofile.io.write_profile` (same parameters and returns)."""
    factor = unit_factor(units)
    cols = {f"distance_{distance_units}": profile.distance / unit_factor(distance_units, what="distance")}
    for j, t in enumerate(profile.tracks):
        cols[f"{t}_{units}"] = profile.elevation[:, j] / factor
    if profile.std is not None:
        for j, t in enumerate(profile.tracks):
            cols[f"{t}_std_{units}"] = profile.std[:, j] / factor
    return write_table(pd.DataFrame(cols), path)


def is_reconstruct_output(path) -> bool:
    """True when the header of a CSV/Parquet file is exactly the column set written by ``road reconstruct``.

    Such a file holds one profile, ``elevation``; ``std_m`` and ``raw_m`` would otherwise be read as tracks.
    An unreadable file gives False (its reader reports the problem).
    """
    return _is_header(_header_names(path), RECONSTRUCT_COLUMNS)


def is_simulated_recording(path) -> bool:
    """True when the header of a CSV/Parquet file is exactly the column set written by ``road simulate``
    (:data:`RECORDING_COLUMNS`).

    Such a file holds one profile, ``true`` (the simulated road); ``apl_m`` is what the trailer records, not a
    profile (``road reconstruct`` turns it into one). An unreadable file gives False (its reader reports the
    problem).
    """
    return _is_header(_header_names(path), RECORDING_COLUMNS)


def _tracks_line(header, columns, recording: bool) -> str:
    """What a file's tracks are, for a refusal: a ``road reconstruct`` output's profile only (``raw_m`` is the
    undetrended estimate, a diagnostic) and a ``road simulate`` recording's true profile only (``apl_m`` is the
    trailer's raw signal)."""
    if _is_header(header, RECONSTRUCT_COLUMNS):
        return "the file (a `road reconstruct` output) has the track ['elevation'] (raw_m is not a track)"
    if recording:
        return "the file (a `road simulate` recording) has the track ['true'] (apl_m is the trailer's raw signal)"
    return f"the file has {list(columns)}"


def _refuse_apl_signal(path, names, columns, *, recording: bool, chosen: bool, erd: bool = False) -> None:
    """Refuse to read an APL trailer's raw signal (a track ``apl``: the column ``road reconstruct`` reads) as a
    profile: its IRI would be a number about the trailer, not the road. In a ``road simulate`` recording it is
    refused even when asked for; elsewhere only by default (``--track apl`` reads a profile that is named so). An
    ERD file's (``erd``) way out goes through a table first: ``road reconstruct`` reads CSV and Parquet."""
    signal = next((t for t in names if str(t).lower() == "apl"), None)
    if signal is None or (chosen and not recording):
        return
    how = f"longprofile road reconstruct {path} -o profile.csv"
    if recording:
        raise InputError(f"{path}: track {signal!r} of this `road simulate` recording is the trailer's raw signal, "
                         "not a profile (its IRI would describe the trailer, not the road): analyse the true profile "
                         f"(--track true) or reconstruct the profile the trailer measured ({how}).")
    what = "column"
    if erd:
        what, how = "track", (f"longprofile road convert {path} signal.csv --track {signal}, then longprofile road "
                              "reconstruct signal.csv -o profile.csv")
    raise InputError(f"{path}: {what} {columns[signal][0]!r} looks like an APL trailer's raw signal (the column "
                     "`road reconstruct` reads), not a profile: reconstruct the profile first "
                     f"({how}); if it is a profile, choose the tracks with --track (e.g. --track {signal}).")


def refuse_erd_apl_signal(path, tracks, *, chosen: bool) -> None:
    """:func:`_refuse_apl_signal` for the tracks of an ERD file (``SHORTNAM``), as a table's columns are refused."""
    _refuse_apl_signal(path, list(tracks), {t: (t, None) for t in tracks}, recording=False, chosen=chosen, erd=True)


def _header_names(path) -> list:
    """The column names of a CSV/Parquet table without reading its rows; [] when it cannot be read (its reader
    reports the problem)."""
    suffix = Path(path).suffix.lower()
    try:
        if suffix in (".parquet", ".pq"):
            import pyarrow.parquet as pq

            return list(pq.read_schema(path).names)
        if suffix in (".csv", ".txt"):
            return list(pd.read_csv(path, comment="#", nrows=0).columns)
    except Exception:
        pass
    return []


def _is_header(names, expected) -> bool:
    """The header is the column set ``expected`` (``road reconstruct``'s, ``road simulate``'s; any letter case;
    ``__`` columns, e.g. pandas' index, aside)."""
    return [str(c).lower() for c in names if not str(c).startswith("__")] == list(expected)


def read_apl_signal(path, *, column: str = "apl_m", distance_column: str | None = None):
    """Read an APL recording: its stations and the signal column, in metres, as a one-track Profile
    (:func:`read_apl_recording`'s ``signal``; same parameters and errors)."""
    return read_apl_recording(path, column=column, distance_column=distance_column).signal


@dataclass(frozen=True)
class APLSignalFile:
    """An APL recording as read (:func:`read_apl_recording`).

    Attributes
    ----------
    signal : Profile
        Stations and the signal, m (NaN = missing sample).
    absent : tuple of (float, float, int)
        Each run of stations absent from the record's grid (rows a logger dropped), filled as missing samples:
        first and last station (m) and their number.
    """

    signal: Profile
    absent: tuple = ()


def read_apl_recording(path, *, column: str = "apl_m", distance_column: str | None = None) -> APLSignalFile:
    """Read an APL recording: its stations and the signal column, in metres, and the stations it lacks.

    Parameters
    ----------
    path : path-like
        CSV or Parquet with a station column named with its unit (``distance_m``, or ``distance_ft``, ``station_km``,
        ``chainage [m]``, ``x_m``, as profiles have them; converted to metres) and ``column``.
    column : str
        The signal column; a unit suffix (``apl_mm``) converts it, none means metres. A file whose only column of
        that name carries another unit (``apl_mm``, ``APL [mm]`` for ``apl_m``) is read from it.
    distance_column : str, optional
        The station column, named with its unit (``PR_m``, ``PK [km]``), as :func:`read_profile_table` takes it.

    Returns
    -------
    APLSignalFile
        ``signal``: stations and the signal (NaN = missing sample), m; its ``name`` is the file stem. Stations
        absent from the record's grid (steps whole multiples of its median step: rows a logger dropped) are missing
        samples (NaN) there, listed in ``absent``.

    Raises
    ------
    UnitsError
        A station column without its unit; a signal in a unit this package does not convert (``apl_um``); a
        signal whose RMS is outside :data:`APL_SIGNAL_RMS_RANGE` (a unit mistake: millimetres under a metre label,
        or metres under a millimetre one).
    InputFormatError
        No station or signal column (the names it takes, and ``--column``), a header without rows, non-numeric
        cells, empty, decreasing or repeated stations (the line named, and the way out), a logger's missing-value
        code (-9999) in the signal (its stations named), as :func:`read_profile_table` refuses them.

    Notes
    -----
    The checks are those of the profile reader (docs/file-formats.md §3), with the hint of a recording: a missing
    sample is an empty cell, which ``road reconstruct`` bridges (paper 000's Kalman filter takes a missing
    observation as such).
    """
    path = Path(path)
    df = _with_rows(_without_empty_tail(read_table(path, dialect=True)), path)
    line = _line_namer(path)
    station = _station_column(path, df, {c: _split(str(c)) for c in df.columns}, distance_column)
    column = _signal_column(path, [str(c) for c in df.columns], column)
    written = _numeric_column(path, df, station, line)
    x = written * unit_factor(_split(str(station))[1], what="distance")
    _check_stations(path, station, written, x, line)
    values = apl_signal_values(path, x, _numeric_column(path, df, column, line), column)
    x, values, absent = _on_grid(x, values)
    return APLSignalFile(Profile(x, values, name=path.stem), absent)


def apl_signal_values(path, x, raw, column: str) -> np.ndarray:
    """An APL signal column as written (``raw``, at stations ``x`` in m) in metres, refused as the recording readers
    refuse it: a logger's missing-value code (its stations named), an RMS outside :data:`APL_SIGNAL_RMS_RANGE`."""
    unit = _split(column)[1] or "m"
    factor = unit_factor(unit)
    check_missing_codes(path, x, np.asarray(raw, float)[:, None], [column], [unit], [factor], hint=_APL_MISSING_HINT,
                        what="column")
    values = np.asarray(raw, float) * factor
    _check_signal_size(path, column, unit, values)
    return values


#: What a refusal of a missing-value code in an APL signal says to do.
_APL_MISSING_HINT = ("write the missing samples as empty cells (NaN): `road reconstruct` bridges them (smoother and "
                     "filter at any length, fixed-lag up to 200 000 samples; its std_m grows there)")
#: The RMS an APL signal has, m: a recording outside is refused as a unit mistake (docs/file-formats.md §3).
#: Measured (``road simulate``, ISO 8608 class A, the smoothest, 20 seeds, 100 m to 1 km, every Table 1
#: configuration): 1.84 mm at least (6 m/s, 100 m), 3.6 mm at most; the floor is 18 times below. The ceiling: a
#: trailer's pendulum moves a few centimetres at most.
APL_SIGNAL_RMS_RANGE = (1e-4, 1.0)
#: Length units a header may give that this package does not convert (:data:`longprofile.core.LENGTH_UNITS`): a
#: signal column so named is refused, never read as metres.
_UNCONVERTED_UNITS = UNCONVERTED_LENGTH_UNITS
#: Any suffix a column name may carry a unit in: ``_unit``, `` [unit]``, `` (unit)``.
_ANY_SUFFIX = re.compile(r"^(?P<base>.+?)(?:_(?P<u1>[^\W_]+)|\s*\[(?P<u2>[^\]]+)\]|\s*\((?P<u3>[^)]+)\))$")


def _signal_column(path, names, column: str) -> str:
    """``column``, or the file's only column of the same name with another unit (``apl_mm``, ``APL [mm]`` for
    ``apl_m``); refused when there is none (naming ``--column``), or its unit is one this package does not
    convert (``apl_um``: named, never read as metres)."""
    chosen = column if column in names else None
    if chosen is None:
        base = _split(column)[0].casefold()
        same = [c for c in names if _split(c)[0].casefold() == base and _split(c)[1] is not None]
        alike = [c for c in names if (m := _ANY_SUFFIX.match(c.strip())) and m.group("base").strip().casefold() == base]
        chosen = same[0] if len(same) == 1 else alike[0] if len(alike) == 1 and _unconverted(alike[0]) else None
    if chosen is None:
        bare = [c for c in names if c.strip().casefold() == _split(column)[0].casefold()]
        unit = f" (column {bare[0]!r} gives no unit: name it with its unit, e.g. '{bare[0]} [mm]')" if bare else ""
        raise InputFormatError(f"{path}: no signal column {column!r}; the file has {names}{unit}: choose the column "
                               "with --column NAME (column=...; a unit suffix converts it, e.g. apl_mm or "
                               "'APL [mm]'; none means metres).")
    unit = _unconverted(chosen)
    if unit:
        raise UnitsError(f"{path}: column {chosen!r} is in {unit!r}, a unit this package does not convert (it reads "
                         f"{', '.join(LENGTH_UNITS)}): convert the column to mm or m and name it so (e.g. apl_mm); "
                         "it is never read as metres.")
    return chosen


def _unconverted(name: str) -> str | None:
    """The unit in a column name's suffix when it is a length unit this package does not convert (``um``), else
    None."""
    m = _ANY_SUFFIX.match(name.strip())
    unit = m and (m.group("u1") or m.group("u2") or m.group("u3")).strip()
    return unit if unit and unit.casefold() in _UNCONVERTED_UNITS else None


def _check_signal_size(path, column: str, unit: str, values) -> None:
    """Refuse a signal column without values, or whose RMS (m) is outside :data:`APL_SIGNAL_RMS_RANGE`: a unit
    mistake, named with the way out."""
    finite = values[np.isfinite(values)]
    if not finite.size:
        raise InputFormatError(f"{path}: column {column!r} holds no value (every cell is empty); a recording needs "
                               "its signal.")
    rms = float(np.sqrt(np.mean(finite**2)))
    low, high = APL_SIGNAL_RMS_RANGE
    label = "metres" if unit == "m" else unit
    if rms > high:
        fix = ("if it is in mm, name the column with its unit (e.g. apl_mm) or convert it to metres" if unit == "m"
               else "check the unit in its name")
        raise UnitsError(f"{path}: column {column!r} read as {label} has an RMS of {rms:.3g} m, impossible for an "
                         f"APL signal (a few cm at most); {fix}.")
    if rms < low:
        fix = ("if the values are in metres, name the column apl_m" if unit != "m" else "check the unit of the column")
        raise UnitsError(f"{path}: column {column!r} read as {label} has an RMS of {rms * 1e3:.3g} mm, below any APL "
                         f"recording of a road (under {low * 1e3:g} mm; the smoothest, ISO 8608 class A, gives about "
                         f"2 mm): {fix}. A trailer on a flat bench: reconstruct it from Python "
                         "(reconstruct_recording(Profile(distance, signal), speed=..., dx=...)), which does not "
                         "check this.")


def _on_grid(x, values):
    """Stations and values with the stations a logger dropped put back as missing samples (NaN), and the runs
    filled (first, last station, number): when every step is a whole multiple of the median step (to
    :attr:`Profile.spacing`'s 1e-6), the absent stations are filled in."""
    if x.size < 3:
        return x, values, ()
    step = np.diff(x)
    h = float(np.median(step))
    k = np.round(step / h)
    if not (k > 1).any() or not np.all((k >= 1) & (np.abs(step - k * h) <= 1e-6 * k * h)):
        return x, values, ()
    at = np.concatenate([[0], np.cumsum(k).astype(int)])
    grid = np.interp(np.arange(at[-1] + 1), at, x)
    full = np.full(grid.size, np.nan)
    full[at] = values
    filled = np.ones(grid.size, dtype=bool)
    filled[at] = False
    return grid, full, tuple((float(grid[a]), float(grid[b]), b - a + 1) for a, b in true_runs(filled))


def _is_station(name: str) -> bool:
    """A station column named with its unit, as profiles have them: distance_m, station_ft, chainage [km], x_m."""
    base, unit = _split(name)
    return base.lower() in _DISTANCE_NAMES and unit is not None



#: A time-stamp column of a bench record: ``time_s``, ``t_ms``, ``Time [s]``, ``time (us)``; ``time`` or ``t`` alone
#: is refused (no unit).
_TIME = re.compile(r"^(?:time|t)(?:_(?P<u1>s|ms|us)|\s*\[(?P<u2>s|ms|us)\]|\s*\((?P<u3>s|ms|us)\))?$", re.IGNORECASE)
_TIME_FACTORS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
#: Largest deviation of one time step from dt (a clock's jitter, rounded time stamps), relative; a dropped or
#: repeated sample is a deviation of 100 %.
TIME_STEP_TOLERANCE = 0.1
#: Largest deviation of the record's mean time step from dt, relative (another sampling rate).
TIME_RATE_TOLERANCE = 1e-4


def read_sampled_column(path, column: str, *, dx: float, speed: float | None = None) -> np.ndarray:
    """One column of a table sampled at a constant spacing ``dx`` (a bench record for identification), m.

    Parameters
    ----------
    path : path-like
        CSV or Parquet with ``column`` and, optionally, a station column (``distance_m``, ``station_<u>``, ...)
        and a time-stamp column (``time_s``, ``time_ms``, ``t_s``, ``Time [s]``).
    column : str
        The signal column; a unit suffix (``apl_mm``) converts it to metres, none means metres.
    dx : float
        The spacing the samples must have, m. With a station column the stations must increase strictly by
        ``dx`` (to 1e-6 of it); without one the rows are taken as samples ``dx`` apart.
    speed : float, optional
        Towing speed the record stands for, m/s: time stamps must then be dt = dx / speed apart (each step to
        :data:`TIME_STEP_TOLERANCE` of dt, their mean to :data:`TIME_RATE_TOLERANCE`). A file with time stamps
        needs it.

    Returns
    -------
    ndarray, shape (n,)

    Raises
    ------
    InputFormatError
        Missing column, non-numeric cell, stations not increasing or not ``dx`` apart, time stamps not
        dx / speed apart (the line is named), a time column without its unit, time stamps without ``speed``.

    Notes
    -----
    Paper 000 (§4.1) samples its bench at a fixed rate (Te = 7.5 ms); identification assumes the samples are
    dt = dx / speed apart, so a bench record's time stamps are checked against it rather than ignored.
    """
    path = Path(path)
    table = _with_rows(read_table(path, required=[column], numeric=[column]), path)
    stations = [c for c in table.columns if _is_station(str(c))]
    if stations:
        c = stations[0]
        x = pd.to_numeric(table[c], errors="coerce").to_numpy(float) * unit_factor(_split(str(c))[1], what="distance")
        step = np.diff(x)
        bad = ~(np.abs(step - dx) <= 1e-6 * dx)
        if bad.any():
            i = int(np.flatnonzero(bad)[0]) + 1
            what = "is not greater than" if not step[i - 1] > 0 else f"is {step[i - 1]:.6g} m after"
            raise InputFormatError(f"{path}: line {i + 2}: station {x[i]:.6g} m {what} the previous one "
                                   f"{x[i - 1]:.6g} m; the samples must be dx = {dx:g} m apart (pass --dx, or "
                                   "resample the record).")
    times = [c for c in table.columns if _TIME.match(str(c).strip())]
    if times:
        _check_time_stamps(path, table, str(times[0]), dx, speed)
    _, unit = _split(column)
    return table[column].to_numpy(float) * (1.0 if unit is None else unit_factor(unit))


def _check_time_stamps(path, table, column: str, dx: float, speed: float | None) -> None:
    """Refuse time stamps in ``column`` that are not dt = dx / speed apart (one step, or their mean rate), naming
    the line and the --dx giving the file's step at this speed."""
    m = _TIME.match(column.strip())
    unit = m.group("u1") or m.group("u2") or m.group("u3")
    if unit is None:
        raise InputFormatError(f"{path}: the time column {column!r} does not give its unit; rename it time_s or "
                               "time_ms (time stamps are never assumed to be in seconds).")
    if speed is None:
        raise InputFormatError(f"{path}: the record has time stamps ({column!r}) but no towing speed was given to "
                               "check them against dt = dx / speed; pass speed.")
    t = pd.to_numeric(table[column], errors="coerce").to_numpy(float) * _TIME_FACTORS[unit.lower()]
    dt = dx / speed
    if t.size < 2:
        return
    step = np.diff(t)
    median = float(np.nanmedian(step))
    fix = (f"the identification assumes dt = --dx / --speed = {dx:g} m / {speed:g} m/s = {dt:.6g} s; "
           + (f"the file's step is {median:.6g} s: at --speed {speed:g} give --dx {median * speed:.6g}, or "
              "resample the record." if median > 0 else "resample the record."))
    bad = ~(np.abs(step - dt) <= TIME_STEP_TOLERANCE * dt)
    if bad.any():
        i = int(np.flatnonzero(bad)[0]) + 1
        what = "is not later than" if not step[i - 1] > 0 else f"is {step[i - 1]:.6g} s after"
        if abs(median - dt) <= TIME_STEP_TOLERANCE * dt:  # the rate is right: a sample dropped or repeated there
            fix = (f"the other steps are dt = {dt:.6g} s: a sample is missing or repeated there (or the clock "
                   "jumped); mend the record or cut it there.")
        raise InputFormatError(f"{path}: line {i + 2}: time {t[i]:.6g} s {what} the previous one {t[i - 1]:.6g} s; "
                               + fix)
    mean = (t[-1] - t[0]) / (t.size - 1)
    if abs(mean - dt) > TIME_RATE_TOLERANCE * dt:
        raise InputFormatError(f"{path}: line {t.size + 1}: time {t[-1]:.6g} s is {t.size - 1} steps after "
                               f"{t[0]:.6g} s, a mean step of {mean:.6g} s; " + fix.replace(f"{median:.6g}",
                                                                                         f"{mean:.6g}"))
