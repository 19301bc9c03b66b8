"""Names kept for backward compatibility after issue 12 moved the figures to ``longprofile.report``."""

from __future__ import annotations

import importlib
import warnings

__all__ = ["plot_frequency_response"]


def plot_frequency_response(models, *, tolerance: float = 0.1):
    """Deprecated: use :func:`longprofile.report.plot_frequency_response` (same parameters, same Figure).

    Magnitude, phase and group delay of one or more models, with the |H| ~ 1 band shaded. Figures are an edge
    (``longprofile.report``); this alias forwards the call and emits a DeprecationWarning.
    """
    warnings.warn("longprofile.road.apl.plot_frequency_response is deprecated; use "
                  "longprofile.report.plot_frequency_response (same parameters).", DeprecationWarning, stacklevel=2)
    # resolved at call time by name: the road domain does not depend on the report edge
    plot = importlib.import_module("longprofile.report").plot_frequency_response
    return plot(models, tolerance=tolerance)
