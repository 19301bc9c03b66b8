"""Shared domain types (layer 1: imported by ``io``, ``road`` and every other package; imports nothing above).

Profile -- a longitudinal profile (stations in m, elevations in m, one column per track); also
           ``longprofile.road.Profile``.
unit_factor -- metres per length unit (m, mm, cm, km, in, ft, mi); UnitsError for anything else.
speed_factor -- m/s per speed unit (m/s, km/h, mph, ft/s; SPEED_UNITS).
LENGTH_UNITS -- the table behind it.
LENGTH_SPELLINGS, length_unit -- spelled-out unit names files write (inches, feet...) and the key each one is.
UNCONVERTED_LENGTH_UNITS -- length units a header may give that are not converted (µm, mil...): refused.
MAX_ABS_ELEVATION_M -- no elevation on Earth is beyond it (a value that is: another unit).
MISSING_TEXT -- the texts read as an empty cell ("NAN", "#N/A", "null", ...; any letter case).
"""

from ._profile import Profile
from ._units import (
    LENGTH_SPELLINGS,
    LENGTH_UNITS,
    MAX_ABS_ELEVATION_M,
    MISSING_TEXT,
    SPEED_UNITS,
    UNCONVERTED_LENGTH_UNITS,
    length_unit,
    speed_factor,
    unit_factor,
)

__all__ = ["Profile", "unit_factor", "LENGTH_UNITS", "LENGTH_SPELLINGS", "UNCONVERTED_LENGTH_UNITS", "length_unit",
           "MAX_ABS_ELEVATION_M", "MISSING_TEXT", "SPEED_UNITS", "speed_factor"]
