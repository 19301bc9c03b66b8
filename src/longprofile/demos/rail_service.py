"""Demo step of the rail monitoring service: a synthetic site replayed day by day through the ingestion API of a
service on 127.0.0.1 (``longprofile.rail.service.run_demo``: server, recompute, alarms, dashboard screenshots-free
pages and tables under ``outdir/rail-service``)."""

from __future__ import annotations

from pathlib import Path


def run_demo(outdir: Path) -> list[Path]:
    """Run the service replay demo; the files written (see ``longprofile.rail.service.run_demo``)."""
    from ..rail.service import run_demo as service_demo

    return service_demo(outdir)
