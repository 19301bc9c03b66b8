"""``longprofile road ...``: road profile reconstruction (APL, paper 000), roughness indices, profile files."""

from __future__ import annotations

import typer

from . import _road_acceptance, _road_apl, _road_compare, _road_convert, _road_indices, _road_proval

road_app = typer.Typer(help="Road profiles: APL trailer reconstruction, IRI and roughness reports, Ride Number, "
                            "straightedge, Profile Index and faulting, file conversion, profiler comparison and "
                            "smoothness acceptance.", no_args_is_help=True)

_road_apl.register(road_app)
_road_indices.register(road_app)
_road_proval.register(road_app)
_road_convert.register(road_app)
_road_compare.register(road_app)
_road_acceptance.register(road_app)
