"""Length units of files and reports: the one table of metres per unit, shared by ``io`` and ``road``."""

from __future__ import annotations

from ..errors import UnitsError

__all__ = ["LENGTH_UNITS", "LENGTH_SPELLINGS", "UNCONVERTED_LENGTH_UNITS", "MAX_ABS_ELEVATION_M", "MISSING_TEXT",
           "SPEED_UNITS", "length_unit", "speed_factor", "unit_factor"]

#: Length units understood in file headers, with their value in metres.
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "km": 1e3, "in": 0.0254, "ft": 0.3048, "mi": 1609.344}
#: Spelled-out names of :data:`LENGTH_UNITS` (lower case) that files write for them: ERD headers (``UNITSNAM inches``,
#: ``XUNITS feet``, as ProVAL writes them) and table column names (``LWP (inches)``, ``Distance (feet)``).
LENGTH_SPELLINGS = {
    **dict.fromkeys(("inch", "inches"), "in"), **dict.fromkeys(("foot", "feet"), "ft"),
    **dict.fromkeys(("millimeter", "millimeters", "millimetre", "millimetres"), "mm"),
    **dict.fromkeys(("centimeter", "centimeters", "centimetre", "centimetres"), "cm"),
    **dict.fromkeys(("meter", "meters", "metre", "metres"), "m"),
    **dict.fromkeys(("kilometer", "kilometers", "kilometre", "kilometres"), "km"),
    **dict.fromkeys(("mile", "miles"), "mi"),
}
#: Length units a header may give that this package does not convert (lower case): a column or channel so named is
#: refused naming its unit, never read as another unit.
UNCONVERTED_LENGTH_UNITS = ("um", "µm", "μm", "micron", "microns", "microm", "micrometer", "micrometers",
                            "micrometre", "micrometres", "nm", "dm", "mil", "mils", "thou", "yd")


def length_unit(text: str) -> str | None:
    """The :data:`LENGTH_UNITS` key a header's unit text stands for (``mm``, ``MM``, ``inches``, ``Feet``), else None.

    Examples
    --------
    >>> length_unit("Inches"), length_unit("ft"), length_unit("furlong")
    ('in', 'ft', None)
    """
    key = str(text).strip().lower()
    return key if key in LENGTH_UNITS else LENGTH_SPELLINGS.get(key)


#: No elevation or altitude on Earth is beyond this, m (terrain spans -430 m to 8 849 m): a value that is was given in
#: another unit (millimetres under a metre label). Shared by the road profile readers and the rail site tables.
MAX_ABS_ELEVATION_M = 10_000.0


def unit_factor(unit: str, *, what: str = "elevation") -> float:
    """Metres per ``unit`` (m, mm, cm, km, in, ft, mi); :class:`UnitsError` for anything else.

    Examples
    --------
    >>> unit_factor("mm")
    0.001
    """
    key = str(unit).strip().lower()
    if key not in LENGTH_UNITS:
        raise UnitsError(f"unknown {what} unit {unit!r}; use one of {sorted(LENGTH_UNITS)}.")
    return LENGTH_UNITS[key]


#: Speed units understood in file headers (a towing speed column: ``speed_kmh``, ``Speed [km/h]``), in m/s: the
#: length units above per second or per hour.
SPEED_UNITS = {"m/s": LENGTH_UNITS["m"], "km/h": LENGTH_UNITS["km"] / 3600.0, "mph": LENGTH_UNITS["mi"] / 3600.0,
               "ft/s": LENGTH_UNITS["ft"]}
#: Other spellings of :data:`SPEED_UNITS` (lower case, blanks removed; ``_`` stands for ``/`` in a suffix).
_SPEED_ALIASES = {"m_s": "m/s", "mps": "m/s", "kmh": "km/h", "km_h": "km/h", "kph": "km/h", "mi/h": "mph",
                  "ft_s": "ft/s", "fps": "ft/s"}


def speed_factor(unit: str) -> float:
    """Metres per second per ``unit`` (m/s, km/h, mph, ft/s and their spellings kmh, kph, km_h, m_s, mps, fps);
    :class:`UnitsError` for anything else.

    Examples
    --------
    >>> round(speed_factor("km/h") * 72.0, 9)
    20.0
    """
    key = str(unit).strip().lower().replace(" ", "")
    key = _SPEED_ALIASES.get(key, key)
    if key not in SPEED_UNITS:
        raise UnitsError(f"unknown speed unit {unit!r}; use one of {sorted(SPEED_UNITS)}.")
    return SPEED_UNITS[key]


#: Texts read as an empty cell where a value may be missing, in any letter case: what loggers and spreadsheets write
#: for a failed channel (Campbell Scientific loggers' "NAN", "#N/A", "null", ...). The CSV reader of ``io`` takes
#: them as missing values; so do the rail tables and the monitoring service's batches.
MISSING_TEXT = frozenset({"nan", "-nan", "na", "n/a", "#n/a", "null", "none", "<na>"})
