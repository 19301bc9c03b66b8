"""CLI commands (module owned by one domain; registered on its group in road.py / vehicle.py)."""

from __future__ import annotations

import typer


def register(app: typer.Typer) -> None:
    """Attach this module's commands to app."""
