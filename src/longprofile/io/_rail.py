"""Reading a rail inclinometer site (paper 004) from its CSV / Parquet tables."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from ..core import LENGTH_UNITS
from ..errors import InputError, InputFormatError, UnitsError
from ..rail import (
    THRESHOLD_FLOORS_M,
    THRESHOLD_LEVELS,
    THRESHOLD_QUANTITIES,
    SiteData,
    check_thresholds,
    validate_site,
)
from ._tables import check_columns, read_table

__all__ = ["read_rail_events", "read_rail_site", "read_rail_table", "read_rail_tables", "read_rail_thresholds"]

#: Columns of a thresholds table (``rail settle --thresholds``): one row per quantity and level, value in mm
#: (mm/day for the rate), as ``rail site threshold`` takes them.
THRESHOLD_COLUMNS = ("quantity", "level", "value_mm")


def read_rail_site(sensors, readings, survey=None, controls=None, *, angle_unit: str = "deg",
                   check_units: bool = True, temperature_fill: bool = True, timezone: str | None = None,
                   require_temperature: bool = True) -> SiteData:
    """Read the site tables from CSV/Parquet files (:func:`read_table`) and validate them.

    Parameters
    ----------
    sensors, readings : path-like
        Required tables.
    survey, controls : path-like, optional
        Initial survey (required unless the sensors table has ``z_m``) and control surveys.
    angle_unit, check_units, temperature_fill, timezone, require_temperature
        See :func:`longprofile.rail.validate_site` (``require_temperature=False``: the readings may lack a
        temperature column, for ``thermal="none"``).

    Returns
    -------
    SiteData
    """
    tables = read_rail_tables(sensors, readings, survey, controls, angle_unit=angle_unit,
                              require_temperature=require_temperature)
    return validate_site(*tables, angle_unit=angle_unit, check_units=check_units, temperature_fill=temperature_fill,
                         timezone=timezone, require_temperature=require_temperature)


def read_rail_tables(sensors, readings, survey=None, controls=None, *, angle_unit: str = "deg",
                     require_temperature: bool = True) -> tuple:
    """(sensors, readings, survey, controls) tables of a site read by :func:`read_rail_table`, not yet validated
    (survey and controls None when not given); the readings may be wide (one column per sensor of the sensors
    table)."""
    s = read_rail_table(sensors, "sensors")
    r = read_rail_table(readings, "readings", angle_unit=angle_unit, require_temperature=require_temperature,
                        sensor_ids=s["sensor_id"].astype(str).tolist())
    sv = None if survey is None else read_rail_table(survey, "survey")
    ct = None if controls is None else read_rail_table(controls, "controls")
    return s, r, sv, ct


def read_rail_events(path):
    """The events table of ``rail settle --events`` and ``rail site events`` (sensor_id, date, event, new_id),
    checked by :func:`longprofile.rail.check_events` (docs/file-formats.md, "Rail events table").

    Raises
    ------
    InputFormatError
        One line naming the file, and the row and what is wrong.
    """
    from ..rail import check_events

    table = read_table(path, required=("sensor_id", "date", "event"), text=("sensor_id", "new_id"))
    try:
        return check_events(table)
    except InputError as exc:
        raise InputFormatError(f"{path}: {exc}") from None


def read_rail_table(path, kind: str, *, angle_unit: str = "deg", require_temperature: bool = True,
                    sensor_ids=None):
    """One table of a rail site (``kind``: sensors, readings, survey or controls) with its columns under their
    canonical names (:data:`longprofile.rail.SiteData.TABLE_COLUMNS`), as ``rail settle`` and ``rail site`` read it.

    A column may be named in any letter case, with blanks for underscores (``Sensor ID``), or declare another unit,
    converted here: ``x_mm``, ``x [ft]`` (any length unit), ``angle_rad``, ``angle (arcsec)``, ``tilt_mm_per_m``
    (mm/m and % are gradients: the angle is their arctangent), ``angle [µrad]``, ``temperature_f``,
    ``Temperature [°C]``, ``Temp_C``, ``temperature [K]`` (:data:`ANGLE_UNITS`, :data:`TEMPERATURE_UNITS`). A
    declared angle unit is the unit: ``angle_unit`` (the unit of a plain ``angle_deg`` column, see
    :func:`longprofile.rail.validate_site`) must then be left at "deg". Readings with the date and the time of day in
    two columns (``date``, ``time``: a spreadsheet's export) get them joined into ``timestamp``. A station written
    in km+m (``12+345.600``, a railway chainage), in ``x_m`` or in a ``chainage`` / ``station`` column, is read as
    metres (12345.6 m). ``require_temperature=False``: a readings table without a temperature column is taken (its
    ``temperature_c`` empty; for ``thermal="none"``). With ``sensor_ids`` (those of the sensors table) a wide readings
    table (a logger's export: a time column and one or two columns per sensor, ``S01`` or ``S01_angle_deg`` and
    ``S01 Temp [°C]``, the sensor's id then the column's name as above) is read as the long table it holds
    (:func:`_wide_readings`), then checked as a long one.

    Raises
    ------
    InputFormatError
        Missing columns (named with the file's own headers), non-numeric values in a converted column, two angle
        columns.
    UnitsError
        A declared angle unit together with ``angle_unit`` other than "deg"; a unit not known.
    """
    if kind not in SiteData.TABLE_COLUMNS:
        raise InputError(f"unknown rail table {kind!r}; use one of {sorted(SiteData.TABLE_COLUMNS)}.")
    table = read_table(path, text=("sensor_id", "sensor id", "sensor-id"))
    headers = [str(c) for c in table.columns]
    table = table.rename(columns=_spaced_names(table.columns, SiteData.TABLE_COLUMNS[kind]))
    required = SiteData.TABLE_COLUMNS[kind]
    if kind == "readings":
        table = _joined_date_time(table, path)
        if "angle_deg" not in table.columns and any(_declared(str(c), "angle", path) for c in table.columns):
            table = _angle_in_degrees(table, path, angle_unit)
        if sensor_ids is not None and "sensor_id" not in {str(c).casefold() for c in table.columns}:
            table = _wide_readings(table, path, sensor_ids, require_temperature, angle_unit)
        _refuse_wide_readings(table, path)
        if not require_temperature:
            required = tuple(c for c in required if c != "temperature_c")
    if "x_m" in required:
        table = _chainage(table, path)
    table = _canonical_columns(table, path, required, headers)
    if kind == "readings" and "temperature_c" not in table.columns:
        table = table.assign(temperature_c=np.nan)  # no temperature column: require_temperature=False
    return table


def _spaced_names(columns, canonical) -> dict:
    """Renames of headers that are a canonical name with blanks or hyphens for its underscores (``Sensor ID``,
    ``sensor-id``), when the canonical name itself is absent."""
    present = {str(c) for c in columns}
    out = {}
    for c in columns:
        key = re.sub(r"[\s\-]+", "_", str(c).strip()).lower()
        if key != str(c) and key in canonical and key not in present:
            out[c] = key
    return out


def _joined_date_time(table, path):
    """Readings with the date and the time of day in two columns (``date`` and ``time``, any letter case: a
    spreadsheet's export) and no ``timestamp``: one ``timestamp`` column, ``date`` + ``T`` + ``time``."""
    names = {str(c).strip().lower(): c for c in table.columns}
    if "timestamp" in names or "date" not in names or "time" not in names:
        return table
    d, t = table[names["date"]], table[names["time"]]
    if d.isna().any() or t.isna().any():
        k = int(np.flatnonzero((d.isna() | t.isna()).to_numpy())[0])
        raise InputFormatError(f"{path}: row {k} (CSV line {k + 2}): the date or the time is empty; every reading "
                               "needs both.")
    stamp = d.astype(str).str.strip() + "T" + t.astype(str).str.strip()
    return table.drop(columns=[names["date"], names["time"]]).assign(timestamp=stamp)


#: A railway chainage in km+m: ``12+345.600`` is 12 345.6 m.
_KM_PLUS_M = re.compile(r"^\s*(\d+)\+(\d{1,3}(?:\.\d*)?)\s*$")


def _chainage(table, path):
    """The station as ``x_m``: a ``chainage`` or ``station`` column (no unit in its name: metres, or km+m) when there
    is no x column, and km+m values (``12+345.600``) read as metres; a column mixing km+m and other text refused."""
    names = {str(c).strip().lower(): c for c in table.columns}
    has_x = any(_declared(str(c), "length", path) and str(c).strip().lower().startswith("x") for c in table.columns)
    if "x_m" not in names and not has_x:
        alias = [names[n] for n in ("chainage", "station", "chainage_m", "station_m") if n in names]
        if len(alias) == 1:
            table = table.rename(columns={alias[0]: "x_m"})
            names["x_m"] = "x_m"
    col = names.get("x_m")
    if col is None or pd.api.types.is_numeric_dtype(table[col]):
        return table
    text = table[col].astype(str)
    parts = text.str.extract(_KM_PLUS_M)
    plus = parts[0].notna()
    if not plus.any():
        return table
    if not plus.all():
        k = int(np.flatnonzero(~plus.to_numpy())[0])
        raise InputFormatError(f"{path}: row {k} (CSV line {k + 2}): station {text.iloc[k]!r} is not in km+m like the "
                               f"other rows ({text[plus].iloc[0]!r}); write every station as km+m or in metres.")
    metres = 1e3 * parts[0].astype(float) + parts[1].astype(float)
    return table.drop(columns=[col]).assign(x_m=metres.to_numpy())


def _refuse_wide_readings(table, path) -> None:
    """A readings table with one column per sensor (a logger's export) gets a refusal that says how to reshape it."""
    names = [str(c).strip().lower() for c in table.columns]
    if len(names) < 4 or any(n.startswith(("sensor", "angle", "temperature", "tilt", "temp")) for n in names):
        return  # a long table, maybe with a misnamed column: the missing-column message names it
    others = [c for c in table.columns if str(c).strip().lower() not in ("timestamp", "time", "date")]
    if len(others) >= 3:
        raise InputFormatError(
            f"{path}: no sensor_id column, and {len(others)} other columns ({[str(c) for c in others[:4]]}, ...): one "
            "column per sensor (a wide table)? Name each column after a sensor id of the sensors table (S01, or "
            "S01_angle_deg and S01_temperature_c) and it is read as it is; or make it long, one row per reading with "
            "the columns timestamp, sensor_id, angle_deg, temperature_c (e.g. pandas: angles.melt(id_vars='timestamp', "
            "var_name='sensor_id', value_name='angle_deg'), and the same for the temperatures, then merge).")


#: Names of the time column of a wide readings table (any letter case).
_WIDE_TIME = ("timestamp", "time", "datetime", "date_time")


def _wide_sensor_column(name: str, ids, path) -> tuple[str, str, str | None] | None:
    """(sensor id, quantity "angle" or "temperature", declared unit or None) of a wide readings column: a sensor's id
    alone (its angle), or followed by a blank, '_', '-' or '.' and an angle or temperature column name
    (``angle_deg``, ``Temp [°C]``, ``tilt``; :func:`_declared`, whose unknown units are refused); None otherwise."""
    text = name.strip()
    for sid in ids:  # the longest ids first: S1_2 before S1
        if text == sid:
            return sid, "angle", None
        if not text.startswith(sid) or not re.match(r"[\s_.\-]", text[len(sid):]):
            continue
        rest = re.sub(r"^[\s_.\-]+", "", text[len(sid):])
        for quantity in ("angle", "temperature"):
            if (_BASES.get(rest.lower()) and _QUANTITY[_BASES[rest.lower()]] == quantity):
                return sid, quantity, None
            try:
                declared = _declared(rest, quantity, path)
            except UnitsError as exc:  # named as the file names the column
                raise UnitsError(str(exc).replace(f"column {rest!r}", f"column {name!r}", 1)) from None
            if declared is not None:
                return sid, quantity, declared[1]
    return None


def _wide_readings(table, path, sensor_ids, require_temperature: bool, angle_unit: str):
    """A wide readings table (one row per time, one angle and maybe one temperature column per sensor, named after
    the sensors table's ids) as the long table (timestamp, sensor_id, angle_deg, temperature_c), each column converted
    from its declared unit (:data:`ANGLE_UNITS`, :data:`TEMPERATURE_UNITS`; a plain angle is in ``angle_unit``, which
    must then be "deg" if any column declares its unit, as for a long table).
    A table none of whose columns names a sensor is returned as is (a long table: its own checks). A sensor's pair
    of cells both empty is no reading. Refused, one line: a column naming no sensor, a sensor's angle (or
    temperature) in two columns, a temperature without an angle, several time columns, and no temperature column at
    all when the temperature is required."""
    ids = sorted(map(str, sensor_ids), key=len, reverse=True)
    columns = [str(c) for c in table.columns]
    times = [c for c in columns if c.strip().lower() in _WIDE_TIME]
    parsed = {c: _wide_sensor_column(c, ids, path) for c in columns if c not in times}
    if not any(parsed.values()):
        return table
    where = f"{path}: a wide readings table (one column per sensor)"
    if len(times) != 1:
        raise InputFormatError(f"{where} needs one time column (timestamp); it has {times or 'none'}.")
    bad = [c for c, v in parsed.items() if v is None]
    if bad:
        raise InputFormatError(f"{where}: column(s) {bad[:4]} name no sensor of the sensors table; name each column "
                               "after a sensor id, alone (its angle in deg) or with the angle or the temperature "
                               "and its unit (S01_angle_deg, 'S01 Temp [°C]'), or leave the column out.")
    found: dict = {}
    for c, (sid, quantity, unit) in parsed.items():
        if (sid, quantity) in found:
            raise InputFormatError(f"{where}: sensor {sid}'s {quantity} is in two columns, {found[sid, quantity][0]!r} "
                                   f"and {c!r}; keep one.")
        found[sid, quantity] = (c, unit)
    lone = sorted(sid for sid, q in found if q == "temperature" and (sid, "angle") not in found)
    if lone:
        raise InputFormatError(f"{where}: sensor(s) {lone[:4]} have a temperature column and no angle column.")
    if require_temperature and not any(q == "temperature" for _, q in found):
        raise InputFormatError(f"{where} with angle columns only: add each sensor's temperature (S01_temperature_c), "
                               "or switch the thermal correction off (--thermal none; thermal='none').")
    for (_, quantity), (c, unit) in found.items():
        if quantity == "angle" and unit is not None:  # a plain column is in angle_unit, a declared one in its own
            _check_angle_unit(path, c, unit, angle_unit)
    values = {}
    for (sid, quantity), (c, unit) in found.items():
        v = check_columns(table[[c]].copy(), path, numeric=[c])[c].to_numpy(float)
        values[sid, quantity] = v if unit is None else _CONVERSIONS[quantity][unit](v)
    stamp = table[[c for c in table.columns if str(c) == times[0]][0]].to_numpy()
    sids = [sid for sid in map(str, sensor_ids) if (sid, "angle") in found]  # the sensors table's order
    nan = np.full(len(table), np.nan)
    angle = np.column_stack([values[sid, "angle"] for sid in sids])
    temp = np.column_stack([values.get((sid, "temperature"), nan) for sid in sids])
    keep = (np.isfinite(angle) | np.isfinite(temp)).ravel()  # row-major: each time's sensors together
    long = pd.DataFrame({"timestamp": np.repeat(stamp, len(sids)), "sensor_id": np.tile(np.array(sids, object),
                                                                                        len(table)),
                         "angle_deg": angle.ravel(), "temperature_c": temp.ravel()})
    return long[keep].reset_index(drop=True)


#: Angle units a readings column may declare (``angle_<unit>``, ``angle [<unit>]``, ``tilt (<unit>)``), to degrees.
#: mm/m and % are gradients (the tangent of the angle: 1000 tan and 100 tan), read through the arctangent.
ANGLE_UNITS = {
    "deg": lambda v: v, "mdeg": lambda v: v * 1e-3, "rad": np.rad2deg, "mrad": lambda v: np.rad2deg(v * 1e-3),
    "urad": lambda v: np.rad2deg(v * 1e-6), "arcmin": lambda v: v / 60.0, "arcsec": lambda v: v / 3600.0,
    "mm/m": lambda v: np.rad2deg(np.arctan(v * 1e-3)), "%": lambda v: np.rad2deg(np.arctan(v * 1e-2)),
}
#: Temperature units (``temperature_f``, ``Temperature [°C]``, ``Temp_C``, ``temperature (degC)``), to °C.
TEMPERATURE_UNITS = {"c": lambda v: v, "f": lambda v: (v - 32.0) * (5.0 / 9.0), "k": lambda v: v - 273.15}
#: Units a site table may declare in a column name instead of the canonical one (x_mm for x_m, angle_rad for
#: angle_deg, temperature_f for temperature_c): quantity -> {unit: conversion to the canonical unit}.
_CONVERSIONS = {
    "length": {u: (lambda v, f=LENGTH_UNITS[u]: v * f) for u in LENGTH_UNITS},
    "angle": ANGLE_UNITS,
    "temperature": TEMPERATURE_UNITS,
}
#: Other spellings of the units (after lower case, µ/μ -> u, blanks removed).
_UNIT_ALIASES = {
    "degree": "deg", "degrees": "deg", "°": "deg", "millideg": "mdeg", "radian": "rad", "radians": "rad",
    "microrad": "urad", "arcsecond": "arcsec", "arcseconds": "arcsec", '"': "arcsec", "″": "arcsec",
    "arcminute": "arcmin", "'": "arcmin", "mm_per_m": "mm/m", "mmperm": "mm/m", "mm_m": "mm/m", "‰": "mm/m",
    "permille": "mm/m", "percent": "%", "pct": "%",
    "°c": "c", "degc": "c", "deg_c": "c", "celsius": "c", "°f": "f", "degf": "f", "deg_f": "f", "fahrenheit": "f",
    "kelvin": "k",
}
#: Column bases: the canonical one of each name a table may use, and its quantity.
_BASES = {"x": "x", "z": "z", "angle": "angle", "tilt": "angle", "inclination": "angle", "temperature": "temperature",
          "temp": "temperature"}
_QUANTITY = {"x": "length", "z": "length", "angle": "angle", "temperature": "temperature"}
_NAME = re.compile(r"^(?P<base>[a-z]+?)(?:_(?P<u1>\S+)|\s*\[(?P<u2>[^\]]+)\]|\s*\((?P<u3>[^)]+)\))$", re.IGNORECASE)


def _unit(text: str) -> str:
    """A declared unit in its canonical spelling (:data:`_UNIT_ALIASES`)."""
    key = text.strip().lower().replace("µ", "u").replace("μ", "u").replace(" ", "")
    return _UNIT_ALIASES.get(key, key)


def _declared(name: str, quantity: str, path=None) -> tuple[str, str] | None:
    """(canonical base, unit) of a column named ``base_unit``, ``base [unit]`` or ``base (unit)`` whose base has
    ``quantity`` and whose unit is one of it; None otherwise. With ``path``, an angle or temperature column whose unit
    is not known is refused (UnitsError naming the known ones)."""
    m = _NAME.match(name.strip())
    if m is None:
        return None
    base = _BASES.get(m.group("base").lower())
    unit = _unit(m.group("u1") or m.group("u2") or m.group("u3"))
    if base is None or _QUANTITY[base] != quantity:
        return None
    if unit in _CONVERSIONS[quantity]:
        return base, unit
    if path is not None and quantity in ("angle", "temperature"):
        axis = ""
        if base == "angle" and unit in ("x", "y", "z", "1", "2", "a", "b", "long", "lat", "trans"):  # a biaxial sensor
            axis = (f"; {name!r} looks like one axis of a biaxial inclinometer: keep the axis along the track (the "
                    "sleeper's rotation in the vertical plane of the rail) as angle_deg (or angle_<unit>) and leave "
                    "the other out")
        raise UnitsError(f"{path}: column {name!r}: unit {unit!r} not known; known: "
                         f"{', '.join(_CONVERSIONS[quantity])}{axis}.")
    return None


def _canonical_columns(df, path, required, headers):
    """``df`` with each required column found under its canonical name: in any letter case, or declared with another
    unit (x_mm, ``x [ft]``, temperature_f: converted); a missing one named with the file's own ``headers``."""
    for col in required:  # the canonical units (m, deg, °C) are the conversions' targets
        base = col.partition("_")[0]
        quantity = _QUANTITY.get(base)
        if quantity in (None, "angle") or col in df.columns:
            continue
        found = [c for c in df.columns if (_declared(str(c), quantity, path if quantity == "temperature" else None)
                                           or ("",))[0] == base]
        if len(found) == 1:
            values = check_columns(df[[found[0]]], path, numeric=[found[0]])[found[0]].to_numpy(float)
            converted = _CONVERSIONS[quantity][_declared(str(found[0]), quantity)[1]](values)
            df = df.drop(columns=found).assign(**{col: converted})
    folded = {str(c).casefold() for c in df.columns}
    missing = [c for c in required if c.casefold() not in folded]
    if missing:
        hint = (" (an angles-only logger? thermal='none', CLI --thermal none, needs no temperature)"
                if "temperature_c" in missing else "")
        raise InputFormatError(f"{path}: missing column(s) {missing}{hint}; the file's columns are {headers}. "
                               f"Name them {list(required)} (a unit may be declared: x_mm, angle (arcsec), "
                               "temperature [°F]).")
    return check_columns(df, path, required=required)


def _angle_in_degrees(r, path, angle_unit: str):
    """The readings with their declared angle column (angle_rad, ``angle (arcsec)``, tilt_mm_per_m) as angle_deg."""
    found = [c for c in r.columns if _declared(str(c), "angle")]
    if len(found) != 1:
        raise InputFormatError(f"{path}: give the angle once, in one column (angle_deg, angle_rad, angle (arcsec)...); "
                               f"the file has {found}.")
    unit = _declared(str(found[0]), "angle")[1]
    _check_angle_unit(path, found[0], unit, angle_unit)
    values = check_columns(r[[found[0]]], path, numeric=[found[0]])[found[0]].to_numpy(float)
    return r.drop(columns=found).assign(angle_deg=ANGLE_UNITS[unit](values))


def _check_angle_unit(path, column, unit: str, angle_unit: str) -> None:
    """Refuse ``angle_unit`` (the unit of a plain angle column) other than "deg" with a column declaring its unit."""
    if angle_unit != "deg":
        raise UnitsError(f"{path}: column {column!r} declares its unit ({unit}); leave out --angle-unit "
                         f"{angle_unit} (angle_unit=...), which is for a plain angle_deg column.")


def read_rail_thresholds(path) -> dict:
    """Read a thresholds table: columns ``quantity`` (settlement, rate, twist), ``level`` (alert, action, alarm) and
    ``value_mm`` (mm; mm/day for the rate), one row per quantity and level.

    Column names and the quantities and levels may be in any letter case; the value column may declare another
    length unit (``value_m``, ``value_cm``, ``value (mm)``, ``Value [in]``), converted. The rate rows may instead
    give their value in a column with a per-day unit (``value_mm_per_day``, ``value (mm/day)``, ``value_mm/day``,
    ``value [cm/d]``), alone or next to the length column (then each row fills one of the two); a settlement or twist
    value there is refused (those are lengths).

    Returns
    -------
    dict
        ``{quantity: {level: value}}`` in m (m/day), checked by :func:`longprofile.rail.check_thresholds`.

    Raises
    ------
    InputFormatError
        Missing or unknown columns, an unknown quantity or level, a quantity and level given twice, a value below
        the quantity's smallest plausible limit (:data:`longprofile.rail.THRESHOLD_FLOORS_M`: metres under
        value_mm?) or not a plausible threshold (:func:`longprofile.rail.check_threshold`), or levels not growing,
        a settlement or twist value in a per-day column, a row with a value in both columns.
    """
    t = read_table(path)
    t, columns = _threshold_columns(t, path)
    out: dict = {}
    for i, (q, lv) in enumerate(zip(t["quantity"].astype(str).str.strip().str.lower(),
                                    t["level"].astype(str).str.strip().str.lower())):
        where = f"{path}: row {i + 1}"
        if q not in THRESHOLD_QUANTITIES or lv not in THRESHOLD_LEVELS:
            raise InputFormatError(f"{where}: quantity {q!r} / level {lv!r}; use {', '.join(THRESHOLD_QUANTITIES)} "
                                   f"and {', '.join(THRESHOLD_LEVELS)}.")
        if lv in out.get(q, {}):
            raise InputFormatError(f"{where}: {q} {lv} is given twice.")
        value, unit, v = _threshold_value(t, i, q, columns, where)
        out.setdefault(q, {})[lv] = metres = float(v) * LENGTH_UNITS[unit]
        floor, per = THRESHOLD_FLOORS_M[q], "/day" if q == "rate" else ""
        if metres < floor and metres > 0:
            why = ("metres under value_mm? Write the values in mm (10 for 10 mm) or name the column value_m"
                   if unit == "mm" else f"is the column {value!r} in another unit than {unit}{per}?")
            raise InputFormatError(f"{where}: {q} {lv} {float(v):g} {unit}{per} is below {floor * 1e3:g} mm{per}, the "
                                   f"smallest plausible {q} limit (track limits are mm to tens of mm, rates 0.5-5 "
                                   f"mm/day; the estimate's own error is ~0.1 mm): {why}.")
    if not out:
        raise InputFormatError(f"{path}: no thresholds (one row per quantity and level: {list(THRESHOLD_COLUMNS)}).")
    try:
        return check_thresholds(out)
    except InputError as exc:  # the library's message, with the file named
        raise InputFormatError(f"{path}: {exc}") from None


#: The value columns a thresholds table may have, as the refusals list them.
_THRESHOLD_VALUE_COLUMNS = ("value_mm (mm; mm/day on rate rows), or value with its length unit: value_m, "
                            "'value (cm)', 'Value [in]'; for rate rows also a per-day unit: value_mm_per_day, "
                            "'value (mm/day)', value_m/day")
#: A per-day unit declared in a value column's name: ``mm/day``, ``mm_per_day``, ``mm/d``, ``mm per day``.
_PER_DAY = re.compile(r"^(?P<length>[a-z]+)(?:/|_per_|_per|per)(?:day|d)$")


def _value_unit(name) -> tuple[str, bool] | None:
    """(length unit, per day) of a thresholds table's value column (``value_mm``, ``value (cm)``,
    ``value_mm_per_day``, ``value (mm/day)``); None for another column."""
    m = _NAME.match(str(name).strip())
    if m is None or m.group("base").lower() != "value":
        return None
    unit = (m.group("u1") or m.group("u2") or m.group("u3")).strip().lower()
    if unit in LENGTH_UNITS:
        return unit, False
    day = _PER_DAY.match(re.sub(r"\s+", "_", re.sub(r"\s*/\s*", "/", unit)))
    if day is not None and day.group("length") in LENGTH_UNITS:
        return day.group("length"), True
    return None


def _threshold_columns(t, path):
    """(table with quantity and level found in any letter case and the value columns numeric, {False: the length
    value column, True: the per-day one} (one of them or both), see :func:`_value_unit`)."""
    found: dict = {}
    for c in t.columns:
        unit = _value_unit(c)
        if unit is not None:
            found.setdefault(unit[1], []).append(c)
    t = check_columns(t, path, required=THRESHOLD_COLUMNS[:2])
    if not found or any(len(v) > 1 for v in found.values()):
        raise InputFormatError(f"{path}: {'no' if not found else 'more than one'} value column; accepted: "
                               f"{_THRESHOLD_VALUE_COLUMNS}; the file has {[str(c) for c in t.columns]}.")
    columns = {k: v[0] for k, v in found.items()}
    extra = sorted(set(map(str, t.columns)) - {*THRESHOLD_COLUMNS[:2], *map(str, columns.values())})
    if extra:
        raise InputFormatError(f"{path}: unknown column(s) {extra}; a thresholds table has {list(THRESHOLD_COLUMNS)} "
                               f"(value columns accepted: {_THRESHOLD_VALUE_COLUMNS}).")
    return check_columns(t, path, numeric=list(columns.values())), columns


def _threshold_value(t, i: int, quantity: str, columns: dict, where: str):
    """(column, length unit, value) of row ``i``: the per-day column's value for a rate row that has one, else the
    length column's; a settlement or twist value in the per-day column, or a row with both, refused."""
    per_day = columns.get(True)
    given = per_day is not None and not np.isnan(t[per_day].iloc[i])
    if given and quantity != "rate":
        raise InputFormatError(f"{where}: a {quantity} threshold is a length, not a rate: give it in "
                               f"{columns.get(False, 'value_mm')!r}, not in {str(per_day)!r}.")
    if given and False in columns and not np.isnan(t[columns[False]].iloc[i]):
        raise InputFormatError(f"{where}: a value in both {str(columns[False])!r} and {str(per_day)!r}; give it in "
                               "one of them.")
    col = per_day if given or False not in columns else columns[False]
    return str(col), _value_unit(col)[0], t[col].iloc[i]
