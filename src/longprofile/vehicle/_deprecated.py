"""Names kept for backward compatibility after issue 12 moved the figures to ``longprofile.report``.

Each alias forwards its call to the report edge, resolved by name at call time (the vehicle domain does not import
the edge), and emits a DeprecationWarning.
"""

from __future__ import annotations

import importlib
import warnings

__all__ = ["plot_drive", "plot_slope_estimate", "plot_vertical_estimate"]


def _forward(name: str, args, kwargs):
    warnings.warn(f"longprofile.vehicle.{name} is deprecated; use longprofile.report.{name} (same parameters).",
                  DeprecationWarning, stacklevel=3)
    return getattr(importlib.import_module("longprofile.report"), name)(*args, **kwargs)


def plot_drive(*args, **kwargs):
    """Deprecated: use :func:`longprofile.report.plot_drive` (same parameters, same Figure): the simulated drive's
    inputs and truth."""
    return _forward("plot_drive", args, kwargs)


def plot_slope_estimate(*args, **kwargs):
    """Deprecated: use :func:`longprofile.report.plot_slope_estimate` (same parameters, same Figure): estimated
    states and slope against the truth."""
    return _forward("plot_slope_estimate", args, kwargs)


def plot_vertical_estimate(*args, **kwargs):
    """Deprecated: use :func:`longprofile.report.plot_vertical_estimate` (same parameters, same Figure): the vertical
    states against the truth."""
    return _forward("plot_vertical_estimate", args, kwargs)
