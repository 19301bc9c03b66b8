"""Helpers shared by the CLI command modules (no numerical code here)."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from ..errors import OutputError

console = Console(stderr=True)


def check_output_path(output: Path, *inputs: Path | None) -> Path:
    """Refuse to write ``output`` over one of the command's inputs; create its parent folder."""
    out = Path(output)
    for inp in inputs:
        if inp is not None and Path(inp).exists() and out.exists() and out.resolve() == Path(inp).resolve():
            raise OutputError(f"output {out} is also an input; choose another output path (inputs are never overwritten).")
    out.parent.mkdir(parents=True, exist_ok=True)
    return out


def progress():
    """A rich progress bar on stderr for long work."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("[progress.description]{task.description}"), BarColumn(),
                    TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn(), console=console)
