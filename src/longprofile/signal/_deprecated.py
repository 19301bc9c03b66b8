"""Names kept for backward compatibility after issue 12 moved the figures to ``longprofile.report``."""

from __future__ import annotations

import importlib
import warnings

__all__ = ["plot_derivative"]


def plot_derivative(x, dt: float, result, *, truth=None, label: str = "x"):
    """Deprecated: use :func:`longprofile.report.plot_derivative` (same parameters, same Figure).

    Two stacked panels: the signal (and ``result.value``), the derivative with a ±2 std band. Figures are an
    edge (``longprofile.report``); this alias forwards the call and emits a DeprecationWarning.
    """
    warnings.warn("longprofile.signal.plot_derivative is deprecated; use longprofile.report.plot_derivative "
                  "(same parameters).", DeprecationWarning, stacklevel=2)
    # resolved at call time by name: the signal domain does not depend on the report edge
    plot = importlib.import_module("longprofile.report").plot_derivative
    return plot(x, dt, result, truth=truth, label=label)
