"""The vehicle description file (TOML) shared by the planar (paper 001) and vertical (thesis 003) loaders."""

from __future__ import annotations

import tomllib
from pathlib import Path

from ..errors import InputError, InputFormatError


def read_car_file(path: Path) -> dict:
    """The parsed TOML of a vehicle description file (InputError if missing, InputFormatError if invalid)."""
    if not path.exists():
        raise InputError(f"{path}: no such vehicle description file.")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputFormatError(f"{path}: not valid TOML: {exc}") from None
