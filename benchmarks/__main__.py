"""Run the benchmarks: ``python -m benchmarks [--quick] [--json out/bench.json] [AREA ...]``."""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
import shutil
import sys
from pathlib import Path

from rich.console import Console
from rich.table import Table

import benchmarks


def discover() -> list[str]:
    return sorted(m.name[len("bench_"):] for m in pkgutil.iter_modules(benchmarks.__path__) if m.name.startswith("bench_"))


def run_areas(areas: list[str], quick: bool) -> list:
    rows = []
    for area in areas:
        mod = importlib.import_module(f"benchmarks.bench_{area}")
        rows.extend(mod.run(quick=quick))
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks")
    p.add_argument("areas", nargs="*", help=f"areas to run (default: all of {discover()})")
    p.add_argument("--quick", action="store_true", help="smallest sizes only (seconds); used by the CI smoke test")
    p.add_argument("--json", type=Path, default=None, help="also write the rows as JSON here")
    args = p.parse_args(argv)
    areas = args.areas or discover()
    unknown = set(areas) - set(discover())
    if unknown:
        print(f"unknown benchmark area(s): {sorted(unknown)}; known: {discover()}", file=sys.stderr)
        return 2
    rows = run_areas(areas, args.quick)
    table = Table(title="longprofile benchmarks" + (" (quick)" if args.quick else ""))
    for col in ("area", "name", "value", "unit", "target", "ok", "detail"):
        table.add_column(col)
    for r in rows:
        ok = {True: "[green]yes[/green]", False: "[red]no[/red]", None: "-"}[r.passed]
        tgt = "-" if r.target is None else (f"{r.target:g}..{r.target_max:g}" if r.target_max is not None
                                            else f"{'>=' if r.higher_is_better else '<='} {r.target:g}")
        table.add_row(r.area, r.name, f"{r.value:.4g}", r.unit, tgt, ok, r.detail)
    # wide enough to stay readable when piped to a file (rich would squeeze columns to 80)
    Console(width=max(200, shutil.get_terminal_size().columns)).print(table)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps([r.as_dict() for r in rows], indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
