"""Atomic writes for the edges: :func:`atomic_path` and :func:`atomic_write_bytes` (from the shared
``longprofile._atomic``) and :func:`save_figure`."""

from __future__ import annotations

from pathlib import Path

from .._atomic import atomic_path, atomic_write_bytes

__all__ = ["atomic_path", "atomic_write_bytes", "save_figure"]


def save_figure(fig, path, **savefig_kwargs) -> Path:
    """``fig.savefig(path, ...)`` through a temporary file.

    The format is the suffix of ``path``; without one, matplotlib's ``rcParams["savefig.format"]`` (PNG by
    default), as ``fig.savefig(path)`` would choose.
    """
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower()
    if not fmt:
        import matplotlib

        fmt = matplotlib.rcParams["savefig.format"]
    savefig_kwargs.setdefault("format", fmt)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, **savefig_kwargs)
    return path
