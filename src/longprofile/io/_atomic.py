"""Atomic file replacement: write to a temporary file in the target's folder, then ``os.replace`` it."""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path", "atomic_write_bytes", "save_figure"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_FILE_MODE = 0o666 & ~_umask()  # the mode a plain open() would give a new file


@contextmanager
def atomic_path(path):
    """Yield a temporary path next to ``path`` (same suffix); on success it replaces ``path`` atomically.

    On any error the temporary file is removed and ``path`` (an older file there) is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        os.chmod(tmp, _FILE_MODE)
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def atomic_write_bytes(path, data: bytes) -> Path:
    """``Path(path).write_bytes(data)``, atomically."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return path


def save_figure(fig, path, **savefig_kwargs) -> Path:
    """``fig.savefig(path, ...)`` through a temporary file (format from the suffix of ``path``)."""
    path = Path(path)
    savefig_kwargs.setdefault("format", path.suffix.lstrip(".").lower() or None)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, **savefig_kwargs)
    return path
