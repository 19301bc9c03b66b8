"""Exceptions raised by longprofile.

Every exception raised on purpose by the library derives from
:class:`LongprofileError`, so callers (and the CLI) can catch all of them with
one clause. Each subclass also derives from the matching built-in exception
(``ValueError``, ``RuntimeError``, ...) so ``except ValueError`` keeps working.

Messages say what is wrong, what was given, what was expected and what to do.
"""

from __future__ import annotations

__all__ = [
    "LongprofileError",
    "InputError",
    "ShapeError",
    "InputFormatError",
    "UnitsError",
    "ModelError",
    "NotDetectableError",
    "ConvergenceError",
    "DependencyError",
    "OutputError",
]


class LongprofileError(Exception):
    """Base class of every error raised by longprofile."""


class InputError(LongprofileError, ValueError):
    """An argument or input value is invalid (wrong value, NaN where not allowed, ...)."""


class ShapeError(InputError):
    """An array does not have the shape the function documents."""


class InputFormatError(InputError):
    """A file is malformed; the message names the file, the line or column and the problem."""


class UnitsError(InputError):
    """Units are missing, unknown or inconsistent (longprofile never guesses units)."""


class ModelError(LongprofileError, ValueError):
    """A model is invalid: non-symmetric or non-PSD covariance, unstable system, ..."""


class NotDetectableError(ModelError):
    """A stationary Kalman filter does not exist for this model (not detectable/stabilisable)."""


class ConvergenceError(LongprofileError, RuntimeError):
    """An iterative estimation did not converge, or converged to an invalid point."""


class DependencyError(LongprofileError, ImportError):
    """An optional dependency needed by this function is not installed."""


class OutputError(LongprofileError, OSError):
    """An output cannot be written (e.g. it would overwrite one of the inputs)."""
