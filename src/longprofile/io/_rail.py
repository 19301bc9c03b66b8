"""Reading a rail inclinometer site (paper 004) from its CSV / Parquet tables."""

from __future__ import annotations

import re

import numpy as np

from ..core import LENGTH_UNITS
from ..errors import InputError, InputFormatError, UnitsError
from ..rail import THRESHOLD_LEVELS, THRESHOLD_QUANTITIES, SiteData, check_thresholds, validate_site
from ._tables import check_columns, read_table

__all__ = ["read_rail_site", "read_rail_table", "read_rail_thresholds"]

#: Columns of a thresholds table (``rail settle --thresholds``): one row per quantity and level, value in mm
#: (mm/day for the rate), as ``rail site threshold`` takes them.
THRESHOLD_COLUMNS = ("quantity", "level", "value_mm")


def read_rail_site(sensors, readings, survey=None, controls=None, *, angle_unit: str = "deg",
                   check_units: bool = True, temperature_fill: bool = True, timezone: str | None = None) -> SiteData:
    """Read the site tables from CSV/Parquet files (:func:`read_table`) and validate them.

    Parameters
    ----------
    sensors, readings : path-like
        Required tables.
    survey, controls : path-like, optional
        Initial survey (required unless the sensors table has ``z_m``) and control surveys.
    angle_unit, check_units, temperature_fill, timezone
        See :func:`longprofile.rail.validate_site`.

    Returns
    -------
    SiteData
    """
    s = read_rail_table(sensors, "sensors")
    r = read_rail_table(readings, "readings", angle_unit=angle_unit)
    sv = None if survey is None else read_rail_table(survey, "survey")
    ct = None if controls is None else read_rail_table(controls, "controls")
    return validate_site(s, r, sv, ct, angle_unit=angle_unit, check_units=check_units,
                         temperature_fill=temperature_fill, timezone=timezone)


def read_rail_table(path, kind: str, *, angle_unit: str = "deg"):
    """One table of a rail site (``kind``: sensors, readings, survey or controls) with its columns under their
    canonical names (:data:`longprofile.rail.SiteData.TABLE_COLUMNS`), as ``rail settle`` and ``rail site`` read it.

    A column may be named in any letter case or declare another unit, converted here: ``x_mm``, ``x [ft]`` (any
    length unit), ``angle_rad``, ``angle (mrad)``, ``temperature_f``, ``temperature [K]``. A declared angle unit
    is the unit: ``angle_unit`` (the unit of a plain ``angle_deg`` column, see
    :func:`longprofile.rail.validate_site`) must then be left at "deg".

    Raises
    ------
    InputFormatError
        Missing columns, non-numeric values in a converted column, two angle columns.
    UnitsError
        A declared angle unit together with ``angle_unit`` other than "deg".
    """
    if kind not in SiteData.TABLE_COLUMNS:
        raise InputError(f"unknown rail table {kind!r}; use one of {sorted(SiteData.TABLE_COLUMNS)}.")
    table = read_table(path, text=("sensor_id",))
    if kind == "readings" and "angle_deg" not in table.columns and any(_declared(str(c), "angle")
                                                                     for c in table.columns):
        table = _angle_in_degrees(table, path, angle_unit)
    if kind == "readings":
        _refuse_wide_readings(table, path)
    return _canonical_columns(table, path, SiteData.TABLE_COLUMNS[kind])


def _refuse_wide_readings(table, path) -> None:
    """A readings table with one column per sensor (a logger's export) gets a refusal that says how to reshape it."""
    names = [str(c).strip().lower() for c in table.columns]
    if len(names) < 4 or any(n.startswith(("sensor", "angle", "temperature")) for n in names):
        return  # a long table, maybe with a misnamed column: the missing-column message names it
    others = [c for c in table.columns if str(c).strip().lower() not in ("timestamp", "time", "date")]
    if len(others) >= 3:
        raise InputFormatError(
            f"{path}: no sensor_id column, and {len(others)} other columns ({[str(c) for c in others[:4]]}, ...): one "
            "column per sensor (a wide table)? The readings table is long: one row per reading with the columns "
            "timestamp, sensor_id, angle_deg, temperature_c (e.g. pandas: angles.melt(id_vars='timestamp', "
            "var_name='sensor_id', value_name='angle_deg'), and the same for the temperatures, then merge).")


#: Units a site table may declare in a column name instead of the canonical one (x_mm for x_m, angle_rad or
#: angle_mrad for angle_deg, temperature_f for temperature_c): quantity -> {unit: conversion to the canonical unit}.
_CONVERSIONS = {
    "length": {u: (lambda v, f=LENGTH_UNITS[u]: v * f) for u in LENGTH_UNITS},
    "angle": {"deg": lambda v: v, "rad": np.rad2deg, "mrad": lambda v: np.rad2deg(v * 1e-3)},
    "temperature": {"c": lambda v: v, "f": lambda v: (v - 32.0) * (5.0 / 9.0), "k": lambda v: v - 273.15},
}
_QUANTITY = {"x": "length", "z": "length", "angle": "angle", "temperature": "temperature"}
_NAME = re.compile(r"^(?P<base>[a-z]+?)(?:_(?P<u1>\w+)|\s*\[(?P<u2>[^\]]+)\]|\s*\((?P<u3>[^)]+)\))$", re.IGNORECASE)


def _declared(name: str, quantity: str) -> tuple[str, str] | None:
    """(base, unit) of a column named ``base_unit``, ``base [unit]`` or ``base (unit)`` whose base has ``quantity``
    and whose unit is one of it; None otherwise."""
    m = _NAME.match(name.strip())
    if m is None:
        return None
    base, unit = m.group("base").lower(), (m.group("u1") or m.group("u2") or m.group("u3")).strip().lower()
    return (base, unit) if _QUANTITY.get(base) == quantity and unit in _CONVERSIONS[quantity] else None


def _canonical_columns(df, path, required):
    """``df`` with each required column found under its canonical name: in any letter case, or declared with another
    unit (x_mm, ``x [ft]``, temperature_f: converted)."""
    for col in required:  # the canonical units (m, deg, °C) are the conversions' targets
        base = col.partition("_")[0]
        quantity = _QUANTITY.get(base)
        if quantity in (None, "angle") or col in df.columns:
            continue
        found = [c for c in df.columns if (_declared(str(c), quantity) or ("",))[0] == base]
        if len(found) == 1:
            values = check_columns(df[[found[0]]], path, numeric=[found[0]])[found[0]].to_numpy(float)
            converted = _CONVERSIONS[quantity][_declared(str(found[0]), quantity)[1]](values)
            df = df.drop(columns=found).assign(**{col: converted})
    return check_columns(df, path, required=required)


def _angle_in_degrees(r, path, angle_unit: str):
    """The readings with their declared angle column (angle_rad, angle_mrad, ``angle [rad]``) as angle_deg."""
    found = [c for c in r.columns if _declared(str(c), "angle")]
    if len(found) != 1:
        raise InputFormatError(f"{path}: give the angle once, in one column (angle_deg, angle_rad or angle_mrad); "
                               f"the file has {found}.")
    unit = _declared(str(found[0]), "angle")[1]
    if angle_unit != "deg":
        raise UnitsError(f"{path}: column {found[0]!r} declares its unit ({unit}); leave out --angle-unit "
                         f"{angle_unit} (angle_unit=...), which is for a plain angle_deg column.")
    values = check_columns(r[[found[0]]], path, numeric=[found[0]])[found[0]].to_numpy(float)
    return r.drop(columns=found).assign(angle_deg=_CONVERSIONS["angle"][unit](values))


def read_rail_thresholds(path) -> dict:
    """Read a thresholds table: columns ``quantity`` (settlement, rate, twist), ``level`` (alert, action, alarm) and
    ``value_mm`` (mm; mm/day for the rate), one row per quantity and level.

    Returns
    -------
    dict
        ``{quantity: {level: value}}`` in m (m/day), checked by :func:`longprofile.rail.check_thresholds`.

    Raises
    ------
    InputFormatError
        Missing or unknown columns, an unknown quantity or level, a quantity and level given twice, a value that
        is not a plausible threshold (:func:`longprofile.rail.check_threshold`), or levels not growing.
    """
    t = read_table(path, required=THRESHOLD_COLUMNS, numeric=("value_mm",))
    extra = sorted(set(map(str, t.columns)) - set(THRESHOLD_COLUMNS))
    if extra:
        raise InputFormatError(f"{path}: unknown column(s) {extra}; a thresholds table has {list(THRESHOLD_COLUMNS)}.")
    out: dict = {}
    for i, (q, lv, v) in enumerate(zip(t["quantity"].astype(str).str.strip(), t["level"].astype(str).str.strip(),
                                       t["value_mm"])):
        where = f"{path}: row {i + 1}"
        if q not in THRESHOLD_QUANTITIES or lv not in THRESHOLD_LEVELS:
            raise InputFormatError(f"{where}: quantity {q!r} / level {lv!r}; use {', '.join(THRESHOLD_QUANTITIES)} "
                                   f"and {', '.join(THRESHOLD_LEVELS)}.")
        if lv in out.get(q, {}):
            raise InputFormatError(f"{where}: {q} {lv} is given twice.")
        out.setdefault(q, {})[lv] = float(v) * 1e-3
    if not out:
        raise InputFormatError(f"{path}: no thresholds (one row per quantity and level: {list(THRESHOLD_COLUMNS)}).")
    try:
        return check_thresholds(out)
    except InputError as exc:  # the library's message, with the file named
        raise InputFormatError(f"{path}: {exc}") from None
