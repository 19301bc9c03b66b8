"""``longprofile vehicle ...``: vehicle states and road slope (paper 001), vertical states (thesis 003)."""

from __future__ import annotations

import typer

from . import _vehicle_planar, _vehicle_vertical

vehicle_app = typer.Typer(help="Vehicle state estimation: road slope and planar states, vertical (suspension) states.",
                          no_args_is_help=True)

_vehicle_planar.register(vehicle_app)
_vehicle_vertical.register(vehicle_app)
