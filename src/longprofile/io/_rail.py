"""Reading a rail inclinometer site (paper 004) from its CSV / Parquet tables."""

from __future__ import annotations

from ..rail import SiteData, validate_site
from ._tables import read_table

__all__ = ["read_rail_site"]


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
