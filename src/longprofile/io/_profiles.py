"""Profile files: CSV and Parquet with explicit units (station column + one column per track)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from ..core import Profile, unit_factor
from ..errors import InputError, InputFormatError, UnitsError
from ._plausible import check_missing_codes
from ._tables import read_table, write_table

__all__ = ["read_profile_table", "write_profile_table", "read_apl_signal", "read_sampled_column",
           "RECONSTRUCT_COLUMNS", "RECORDING_COLUMNS", "is_reconstruct_output", "is_simulated_recording"]

#: Columns of a ``road reconstruct`` output table: one profile (``elevation``) plus diagnostics.
RECONSTRUCT_COLUMNS = ("distance_m", "elevation_m", "std_m", "raw_m", "raw_std_m")
#: Columns of a ``road simulate`` recording: the true profile (``true``) and the trailer's raw signal (``apl``).
RECORDING_COLUMNS = ("distance_m", "true_m", "apl_m")

_DISTANCE_NAMES = ("distance", "station", "chainage", "x")
#: ``name_unit``, ``name [unit]`` or ``name (unit)`` (the last as spreadsheets and ProVAL-style exports write it)
_SUFFIX = re.compile(r"^(?P<base>.+?)(?:_(?P<u1>m|mm|cm|km|in|ft|mi)|\s*\[(?P<u2>m|mm|cm|km|in|ft|mi)\]"
                     r"|\s*\((?P<u3>m|mm|cm|km|in|ft|mi)\))$", re.IGNORECASE)


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
    m = _SUFFIX.match(column.strip())
    if m:
        return m.group("base"), (m.group("u1") or m.group("u2") or m.group("u3")).lower()
    return column.strip(), None


def _elevation_unit(path, column, unit, units, *, chosen: bool):
    """(column, unit) of an elevation column: its declared unit, else ``units``; refused without either, or when the
    two differ."""
    if unit is None:
        if units is None:
            hint = "" if chosen else " If it is not a track, choose the tracks with --track (e.g. --track left,right)."
            raise UnitsError(f"{path}: column {column!r} does not give its elevation unit; pass --elevation-unit m|mm "
                             f"(units=...) or name the column e.g. {column}_mm. Units are never guessed.{hint}")
        return column, units
    if units is not None and unit != units.lower():
        raise UnitsError(f"{path}: column {column!r} is in {unit} but units={units!r} was given; remove the option "
                         "or fix the header.")
    return column, unit


def read_profile_table(path: Path, *, units: str | None = None, tracks=None, distance_column: str | None = None):
    """CSV/Parquet body of :func:`longprofile.io.read_profile` (same parameters, returns and errors)."""
    path = Path(path)
    if units is not None:
        unit_factor(units)
    df = _with_rows(_without_empty_tail(read_table(path)), path)
    fmt_line = (lambda i: f"line {i + 2}") if path.suffix.lower() in (".csv", ".txt") else (lambda i: f"row {i}")
    parsed = {c: _split(str(c)) for c in df.columns}
    if distance_column is None:
        candidates = [c for c, (base, _) in parsed.items() if base.lower() in _DISTANCE_NAMES]
        if not candidates:
            raise InputFormatError(f"{path}: no station column; expected one named distance_m (or station_m, "
                                   f"chainage_m, x_m, with its unit); the file has {list(df.columns)}.")
        distance_column = candidates[0]
    elif distance_column not in df.columns:
        raise InputFormatError(f"{path}: no column {distance_column!r}; the file has {list(df.columns)}.")
    _, dunit = parsed[distance_column]
    if dunit is None:
        raise UnitsError(f"{path}: the station column {distance_column!r} does not give its unit; rename it e.g. "
                         "distance_m (stations are never assumed to be in metres).")
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
        conv = pd.to_numeric(df[c], errors="coerce")
        bad = conv.isna() & df[c].notna()
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            raise InputFormatError(f"{path}: {fmt_line(i)}: column {c!r} has a non-numeric value {df[c].iloc[i]!r}.")
        df[c] = conv.astype(float)
    x = df[distance_column].to_numpy() * unit_factor(dunit, what="distance")
    if np.isnan(x).any():
        i = int(np.flatnonzero(np.isnan(x))[0])
        raise InputFormatError(f"{path}: {fmt_line(i)}: empty station in column {distance_column!r}.")
    if x.size > 1 and np.all(np.diff(x) < 0):
        raise InputFormatError(f"{path}: the stations in column {distance_column!r} decrease ({df[distance_column].iloc[0]:g} .. "
                               f"{df[distance_column].iloc[-1]:g}); they must increase in the driving direction: if "
                               "the file lists the run backwards, reverse its rows; if the run was driven the other "
                               "way, give the distances from its start.")
    if x.size > 1 and np.any(np.diff(x) <= 0):
        i = int(np.flatnonzero(np.diff(x) <= 0)[0]) + 1
        raise InputFormatError(f"{path}: {fmt_line(i)}: station {df[distance_column].iloc[i]:g} is not greater than "
                               f"the previous one {df[distance_column].iloc[i - 1]:g}; stations must increase strictly.")
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


def write_profile_table(profile, path: Path, *, units: str = "m") -> Path:
    """CSV/Parquet body of :func:`longprofile.io.write_profile` (same parameters and returns)."""
    factor = unit_factor(units)
    cols = {"distance_m": profile.distance}
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


def _refuse_apl_signal(path, names, columns, *, recording: bool, chosen: bool) -> None:
    """Refuse to read an APL trailer's raw signal (a track ``apl``: the column ``road reconstruct`` reads) as a
    profile: its IRI would be a number about the trailer, not the road. In a ``road simulate`` recording it is
    refused even when asked for; elsewhere only by default (``--track apl`` reads a profile that is named so)."""
    signal = next((t for t in names if str(t).lower() == "apl"), None)
    if signal is None or (chosen and not recording):
        return
    how = f"longprofile road reconstruct {path} -o profile.csv"
    if recording:
        raise InputError(f"{path}: track {signal!r} of this `road simulate` recording is the trailer's raw signal, "
                         "not a profile (its IRI would describe the trailer, not the road): analyse the true profile "
                         f"(--track true) or reconstruct the profile the trailer measured ({how}).")
    raise InputError(f"{path}: column {columns[signal][0]!r} looks like an APL trailer's raw signal (the column "
                     "`road reconstruct` reads), not a profile: reconstruct the profile first "
                     f"({how}); if it is a profile, choose the tracks with --track (e.g. --track {signal}).")


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


def read_apl_signal(path, *, column: str = "apl_m"):
    """Read an APL recording: its stations and the signal column, in metres, as a one-track Profile.

    Parameters
    ----------
    path : path-like
        CSV or Parquet with a station column named with its unit (``distance_m``, or ``distance_ft``, ``station_km``,
        ``chainage [m]``, ``x_m``, as profiles have them; converted to metres) and ``column``.
    column : str
        The signal column; a unit suffix (``apl_mm``) converts it, none means metres.

    Returns
    -------
    Profile
        Stations and the signal (NaN = missing sample), m; ``name`` is the file stem.

    Raises
    ------
    UnitsError
        The signal read as metres has an RMS above 1 m (impossible for an APL signal: a few cm at most; usually
        millimetres under a metre label).
    InputFormatError
        Missing columns, non-numeric cells (line named).
    """
    path = Path(path)
    names = _header_names(path)
    column = _signal_column(names, column)
    station = next((str(c) for c in names if _is_station(str(c))), "distance_m")  # any station name with its unit
    table = read_table(path, required=[station, column], numeric=[station, column])
    _, unit = _split(column)
    values = table[column].to_numpy() * (1.0 if unit is None else unit_factor(unit))
    finite = values[np.isfinite(values)]
    rms = float(np.sqrt(np.mean(finite**2))) if finite.size else 0.0
    if rms > 1.0:
        raise UnitsError(f"{path}: column {column!r} read as metres has an RMS of {rms:.3g} m, impossible for an APL "
                         "signal (a few cm at most); if it is in mm, name the column with its unit (e.g. apl_mm) "
                         "or convert it to metres.")
    x = table[station].to_numpy() * unit_factor(_split(station)[1], what="distance")
    return Profile(x, values, name=path.stem)


def _is_station(name: str) -> bool:
    """A station column named with its unit, as profiles have them: distance_m, station_ft, chainage [km], x_m."""
    base, unit = _split(name)
    return base.lower() in _DISTANCE_NAMES and unit is not None


def _signal_column(names, column: str) -> str:
    """``column``, or the file's only column of the same name with another unit (``apl_mm``, ``APL [mm]`` for
    ``apl_m``)."""
    if column in names:
        return column
    base = _split(column)[0].casefold()
    same = [str(c) for c in names if _split(str(c))[0].casefold() == base and _split(str(c))[1] is not None]
    return same[0] if len(same) == 1 else column


def read_sampled_column(path, column: str, *, dx: float) -> np.ndarray:
    """One column of a table sampled at a constant spacing ``dx`` (a bench record for identification), m.

    Parameters
    ----------
    path : path-like
        CSV or Parquet with ``column`` and, optionally, a station column (``distance_m``, ``station_<u>``, ...).
    column : str
        The signal column; a unit suffix (``apl_mm``) converts it to metres, none means metres.
    dx : float
        The spacing the samples must have, m. With a station column the stations must increase strictly by
        ``dx`` (to 1e-6 of it); without one the rows are taken as samples ``dx`` apart.

    Returns
    -------
    ndarray, shape (n,)

    Raises
    ------
    InputFormatError
        Missing column, non-numeric cell, stations not increasing or not ``dx`` apart (the line is named).
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
    _, unit = _split(column)
    return table[column].to_numpy(float) * (1.0 if unit is None else unit_factor(unit))
