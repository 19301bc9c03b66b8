"""Reading a rail inclinometer site (paper 004) from its CSV / Parquet tables."""

from __future__ import annotations

from ..errors import InputError, InputFormatError
from ..rail import THRESHOLD_LEVELS, THRESHOLD_QUANTITIES, SiteData, check_thresholds, validate_site
from ._tables import read_table

__all__ = ["read_rail_site", "read_rail_thresholds"]

#: Columns of a thresholds table (``rail settle --thresholds``): one row per quantity and level, value in mm
#: (mm/day for the rate), as ``rail site threshold`` takes them.
THRESHOLD_COLUMNS = ("quantity", "level", "value_mm")


def read_rail_site(sensors, readings, survey=None, controls=None, *, angle_unit: str = "deg",
                   check_units: bool = True) -> SiteData:
    """Read the site tables from CSV/Parquet files (:func:`read_table`) and validate them.

    Parameters
    ----------
    sensors, readings : path-like
        Required tables.
    survey, controls : path-like, optional
        Initial survey (required unless the sensors table has ``z_m``) and control surveys.
    angle_unit, check_units
        See :func:`longprofile.rail.validate_site`.

    Returns
    -------
    SiteData
    """
    cols = SiteData.TABLE_COLUMNS
    s = read_table(sensors, required=cols["sensors"])
    r = read_table(readings, required=cols["readings"])
    sv = None if survey is None else read_table(survey, required=cols["survey"])
    ct = None if controls is None else read_table(controls, required=cols["controls"])
    return validate_site(s, r, sv, ct, angle_unit=angle_unit, check_units=check_units)


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
