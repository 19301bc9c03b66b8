"""Names kept for backward compatibility after issue 12 moved file reading out of the rail domain."""

from __future__ import annotations

import importlib
import warnings

__all__ = ["read_site"]


def read_site(sensors, readings, survey=None, controls=None, *, angle_unit: str = "deg",
              check_units: bool = True):
    """Deprecated: use :func:`longprofile.io.read_rail_site` (same parameters, same result).

    Reads the site tables from CSV/Parquet files and validates them (:func:`~longprofile.rail.validate_site`).
    File reading is an edge (``longprofile.io``); the rail domain takes tables
    (:func:`~longprofile.rail.validate_site`). This alias forwards the call and emits a DeprecationWarning.
    """
    warnings.warn("longprofile.rail.read_site is deprecated; use longprofile.io.read_rail_site "
                  "(same parameters).", DeprecationWarning, stacklevel=2)
    # resolved at call time by name: the rail domain does not depend on the io edge
    reader = importlib.import_module("longprofile.io").read_rail_site
    return reader(sensors, readings, survey, controls, angle_unit=angle_unit, check_units=check_units)
