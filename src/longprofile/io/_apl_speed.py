"""The towing speed column of an APL recording (``speed_kmh``, ``Speed [km/h]``, ``v_m_s``), in m/s."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core import speed_factor
from ..errors import InputFormatError, UnitsError
from ._tables import read_table

__all__ = ["SpeedColumn", "TimeSampledRecording", "APLRecord", "find_speed_column", "read_apl_speed",
           "read_time_sampled_apl", "read_apl_record"]

#: Names of a towing speed column (any letter case), before its unit.
SPEED_NAMES = ("speed", "v", "velocity", "vitesse", "towing_speed", "vehicle_speed")
_SPEED_HEADER = re.compile(r"^(?P<base>.+?)(?:\s*\[(?P<u1>[^\]]+)\]|\s*\((?P<u2>[^)]+)\)"
                           r"|_(?P<u3>m_s|mps|kmh|km_h|kph|mph|ft_s|fps))$", re.IGNORECASE)


@dataclass(frozen=True)
class SpeedColumn:
    """A recording's towing speed column.

    Attributes
    ----------
    column : str
        Its name in the file.
    unit : str
        Its unit as the header gives it (``km/h``, ``kmh``, ``m_s``, ...).
    values : (T,) ndarray
        The speed of each row, m/s (NaN where the cell is empty).
    """

    column: str
    unit: str
    values: np.ndarray


def find_speed_column(names, *, source="the file") -> tuple[str, str] | None:
    """(column, unit) of the towing speed column among ``names``, or None when there is none.

    Raises
    ------
    UnitsError
        A column named ``speed`` (``v``, ``velocity``, ...) without a unit, or with one that is no speed unit (units
        are never guessed), or two speed columns.
    """
    found = []
    for name in map(str, names):
        m = _SPEED_HEADER.match(name.strip())
        base = (m.group("base") if m else name).strip().casefold()
        if base not in SPEED_NAMES:
            continue
        unit = (m.group("u1") or m.group("u2") or m.group("u3")) if m else None
        if unit is None:
            raise UnitsError(f"{source}: column {name!r} gives no speed unit; name it with its unit (speed_kmh, "
                             "speed_m_s or 'Speed [km/h]'): units are never guessed.")
        try:
            speed_factor(unit)
        except UnitsError:
            raise UnitsError(f"{source}: column {name!r}: {unit!r} is not a speed unit; use m/s, km/h, mph or "
                             "ft/s (speed_kmh, 'Speed [km/h]').") from None
        found.append((name, unit))
    if len(found) > 1:
        raise UnitsError(f"{source}: two speed columns ({', '.join(repr(n) for n, _ in found)}); keep one.")
    return found[0] if found else None


def read_apl_speed(path) -> SpeedColumn | None:
    """The towing speed column of an APL recording, m/s, one value per row (as :func:`read_apl_signal` reads them);
    None when the file has none.

    Raises
    ------
    UnitsError
        See :func:`find_speed_column`; a negative speed.
    InputFormatError
        A non-numeric cell (line named).
    """
    from ._profiles import _header_names

    path = Path(path)
    found = find_speed_column(_header_names(path), source=str(path))
    if found is None:
        return None
    column, unit = found
    values = read_table(path, required=[column], numeric=[column])[column].to_numpy(float) * speed_factor(unit)
    if np.any(values < 0):
        i = int(np.flatnonzero(values < 0)[0])
        given = values[i] / speed_factor(unit)
        raise UnitsError(f"{path}: line {i + 2}: column {column!r} has a negative speed ({given:g} {unit}); the "
                         "towing speed is its magnitude along the record: correct the column.")
    return SpeedColumn(column, unit, values)


#: Names of a time column (any letter case), before its unit (s or ms).
TIME_NAMES = ("time", "t", "temps")
_TIME_UNITS = {"s": 1.0, "ms": 1e-3}
_TIME_HEADER = re.compile(r"^(?P<base>.+?)(?:\s*\[(?P<u1>s|ms)\]|\s*\((?P<u2>s|ms)\)|_(?P<u3>s|ms))$", re.IGNORECASE)
#: Coarsest spacing of the moving samples of a time-sampled record, in units of dx, that is taken at every dx by
#: linear interpolation (the APL samples every dx; beyond it, the short waves would be invented).
MAX_TIME_SAMPLE_SPACING = 1.5


@dataclass(frozen=True)
class TimeSampledRecording:
    """A time-sampled APL record taken at every dx of distance (how the APL samples).

    Attributes
    ----------
    signal : Profile
        Stations every dx from the first moving sample, and the signal there (linear interpolation in distance), m.
    speed : SpeedColumn
        The speed at each of those stations, m/s.
    notes : tuple of str
        What was done: the distance's origin, the stops removed (distance and time of each).
    samples : tuple of three (N,) ndarrays
        The file's own samples from the first moving one to the last, stops included: time (s), distance (m, the
        stations' scale) and signal (m) -- for a reconstruction at the file's time step.
    """

    signal: object
    speed: SpeedColumn
    notes: tuple
    samples: tuple = ()


_STATION_NAMES = ("distance", "station", "chainage", "x")
_LENGTH_HEADER = re.compile(r"^(?P<base>.+?)(?:_(?P<u1>m|mm|cm|km|in|ft|mi)|\s*\[(?P<u2>m|mm|cm|km|in|ft|mi)\]"
                            r"|\s*\((?P<u3>m|mm|cm|km|in|ft|mi)\))$", re.IGNORECASE)


def _length_column(name: str, bases=None):
    """(base, unit or None) of a column named ``base_unit``, ``base [unit]`` or ``base (unit)`` with a length unit;
    with ``bases``, None unless its base is one of them (any letter case) and it has a unit."""
    m = _LENGTH_HEADER.match(name.strip())
    base, unit = (m.group("base"), (m.group("u1") or m.group("u2") or m.group("u3")).lower()) if m else (name, None)
    if bases is None or (unit is not None and base.strip().casefold() in {b.casefold() for b in bases}):
        return base.strip(), unit
    return None


def _time_column(names):
    """(column, seconds per unit) of the time column among ``names``, or None."""
    for name in map(str, names):
        m = _TIME_HEADER.match(name.strip())
        if m and m.group("base").strip().casefold() in TIME_NAMES:
            return name, _TIME_UNITS[(m.group("u1") or m.group("u2") or m.group("u3")).lower()]
    return None


def read_time_sampled_apl(path, *, column: str = "apl_m", dx: float, stop_speed: float = 1.0):
    """A time-sampled APL record (a time column, a speed column, and no station column or one not ``dx`` apart)
    taken at every ``dx`` of distance; None for a record sampled in distance (read by :func:`read_apl_signal`).

    ASSUMPTION (docs/road-apl.md, "Time-sampled records"): the distance is the station column when there is one,
    else the cumulative trapezoidal integral of the speed; the samples slower than ``stop_speed`` (m/s: stops) are
    removed (their ranges are named in ``notes``) and the stations passed meanwhile are missing samples whose speed is
    the mean speed across the stop (distance over duration: a varying-speed reconstruction lets the trailer settle
    for the stop's duration); the signal between the moving samples is linear in distance, which
    is refused when they are more than 1.5 dx apart (the short waves would be invented).

    Raises
    ------
    InputFormatError
        A time column without a speed column nor a station column; times not increasing; moving samples too far apart;
        no moving sample.
    UnitsError
        See :func:`find_speed_column`.
    """
    from .._validation import check_time_order, true_runs
    from ..core import Profile, unit_factor
    from ..errors import InputFormatError
    from ._profiles import _header_names, _signal_column, apl_signal_values

    path = Path(path)
    names = [str(c) for c in _header_names(path)]
    timed = _time_column(names)
    if timed is None:
        return None
    speed_col = find_speed_column(names, source=str(path))
    station = next((c for c in names if _length_column(c, _STATION_NAMES)), None)
    if speed_col is None:
        if station is None:
            raise InputFormatError(f"{path}: a time-sampled record ({timed[0]!r}) without a speed column nor a distance "
                                   "column: add the towing speed (speed_kmh or 'Speed [km/h]') or the distance "
                                   "(distance_m) of each sample.")
        return None
    signal_col = _signal_column(path, names, column)
    table = read_table(path, required=[c for c in (timed[0], speed_col[0], signal_col, station) if c],
                       numeric=[c for c in (timed[0], speed_col[0], signal_col, station) if c])
    x_file = None if station is None else table[station].to_numpy(float) * unit_factor(_length_column(station)[1],
                                                                                        what="distance")
    if x_file is not None and x_file.size > 1 and np.all(np.abs(np.diff(x_file) - dx) <= 1e-6 * dx):
        return None  # sampled every dx already
    t = table[timed[0]].to_numpy(float) * timed[1]
    check_time_order(t, source=str(path), column=timed[0])
    v = table[speed_col[0]].to_numpy(float) * speed_factor(speed_col[1])
    if not np.all(np.isfinite(v)):
        raise InputFormatError(f"{path}: column {speed_col[0]!r} has empty cells; every sample of a time-sampled "
                               "record needs its speed.")
    x = x_file if x_file is not None else np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    y = apl_signal_values(path, x, table[signal_col].to_numpy(float), signal_col)  # the recording readers' checks
    moving = v > stop_speed
    if not moving.any():
        raise InputFormatError(f"{path}: the trailer never moves faster than {stop_speed:g} m/s: nothing to sample.")
    stops = [(x[a], t[a], t[b]) for a, b in true_runs(~moving)]
    kept = np.flatnonzero(moving)
    rows = slice(kept[0], kept[-1] + 1)  # from the first moving sample to the last, stops inside kept
    samples = (t[rows], x[rows], y[rows])
    across = np.diff(kept) > 1  # a stop between these two moving samples
    x, y, v, t = x[moving], y[moving], v[moving], t[moving]
    step = np.diff(x)
    if np.any(step <= 0):
        i = int(np.flatnonzero(step <= 0)[0])
        raise InputFormatError(f"{path}: the distance does not increase at {x[i]:.6g} m between moving samples; "
                               "correct the distance or speed column.")
    if np.any(step[~across] > MAX_TIME_SAMPLE_SPACING * dx):
        i = int(np.argmax(np.where(across, 0.0, step)))
        raise InputFormatError(f"{path}: the moving samples are up to {step[i]:.3g} m apart (at {x[i]:.6g} m, "
                               f"{3.6 * v[i]:.3g} km/h), more than {MAX_TIME_SAMPLE_SPACING:g} x --dx {dx:g} m: the "
                               "signal cannot be taken at every dx without inventing its short waves; record faster "
                               "or give a larger --dx.")
    grid = x[0] + dx * np.arange(int(np.floor((x[-1] - x[0]) / dx + 1e-6)) + 1)
    signal = np.interp(grid, x, y)
    speed = np.interp(grid, x, v)
    for i in np.flatnonzero(across):  # the stations passed while stopping and starting: missing samples, at the
        inside = (grid > x[i]) & (grid < x[i + 1])  # mean speed across the stop (its duration: the trailer settles)
        signal[inside] = np.nan
        speed[inside] = (x[i + 1] - x[i]) / (t[i + 1] - t[i])
    notes = [f"time-sampled record: {t.size} samples taken at every {dx:g} m of distance ("
             + (f"column {station!r}" if station else f"integral of {speed_col[0]!r}") + f"): {grid.size} samples"]
    if stops:
        shown = ", ".join(f"at {s[0]:.1f} m for {s[2] - s[1]:.3g} s" for s in stops[:5])
        notes.append(f"{len(stops)} stop(s) below {3.6 * stop_speed:g} km/h removed ({shown}"
                     f"{' ...' if len(stops) > 5 else ''}); the stations passed below that speed are missing samples "
                     "(estimated from the stop's samples when the record is reconstructed at its time step)")
    speed = SpeedColumn(speed_col[0], speed_col[1], speed)
    return TimeSampledRecording(Profile(grid, signal, name=path.stem), speed, tuple(notes), samples)


@dataclass(frozen=True)
class APLRecord:
    """An APL record as ``road reconstruct`` and ``batch reconstruct`` read it (:func:`read_apl_record`).

    Attributes
    ----------
    recording : APLSignalFile
        The signal on its stations (and the stations a logger dropped, read as missing samples).
    speed : SpeedColumn or None
        The record's towing speed at each station, m/s (None: the file has no speed column).
    notes : tuple of str
        How a time-sampled record was placed at every dx (empty otherwise).
    time_samples : tuple or None
        A time-sampled record's own samples (:attr:`TimeSampledRecording.samples`); None for a record sampled in
        distance.
    """

    recording: object
    speed: SpeedColumn | None
    notes: tuple = ()
    time_samples: tuple | None = None


def read_apl_record(path, *, column: str = "apl_m", dx: float) -> APLRecord:
    """An APL record sampled in distance (:func:`read_apl_recording`, with its speed column when it has one, one
    value per station), or time-sampled with a speed column and taken at every ``dx``
    (:func:`read_time_sampled_apl`, whose notes say how).

    Parameters
    ----------
    path : path-like
        CSV or Parquet.
    column : str
        The signal column (a unit suffix converts it).
    dx : float
        Spacing of the record's stations, m.

    Returns
    -------
    APLRecord
    """
    from ._profiles import APLSignalFile, read_apl_recording

    timed = read_time_sampled_apl(path, column=column, dx=dx)
    if timed is not None:
        return APLRecord(APLSignalFile(timed.signal), timed.speed, tuple(timed.notes), timed.samples)
    recording = read_apl_recording(path, column=column)
    speed = read_apl_speed(path)
    return APLRecord(recording, None if speed is None else _on_stations(path, speed, recording))


def _on_stations(path, speed: SpeedColumn, recording) -> SpeedColumn:
    """The speed column at each station of ``recording``: its rows, and between them at the stations a logger dropped
    (filled as missing samples by the reader), linear in distance."""
    import dataclasses

    x = recording.signal.distance
    values = speed.values
    n = values.size
    while n > 0 and not np.isfinite(values[n - 1]) and n > x.size:  # a spreadsheet's empty tail rows
        n -= 1
    present = np.ones(x.size, dtype=bool)
    for first, last, _ in recording.absent:
        present &= ~((x >= first) & (x <= last))
    if int(present.sum()) != n:
        raise InputFormatError(f"{path}: column {speed.column!r} has {n} values for {int(present.sum())} stations; "
                               "give every sample its speed.")
    full = np.interp(x, x[present], values[:n]) if n < x.size else values[:n]
    return dataclasses.replace(speed, values=full)
