"""Atomic writes for the edges: :func:`atomic_path` and :func:`atomic_write_bytes` (from the shared
``longprofile._atomic``) and :func:`save_figure` (also there: the figure helper of :mod:`longprofile.report` saves
without importing the readers)."""

from __future__ import annotations

from .._atomic import atomic_path, atomic_write_bytes, save_figure

__all__ = ["atomic_path", "atomic_write_bytes", "save_figure"]
