"""Helpers shared by the CLI command modules (no numerical code here)."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from ..errors import OutputError

console = Console(stderr=True)


#: Table formats a ``-o`` table output accepts (written by :func:`longprofile.io.write_table`).
TABLE_SUFFIXES = (".csv", ".parquet")
#: Profile formats a ``-o`` profile output accepts (:func:`longprofile.io.write_profile`): tables or ERD.
PROFILE_SUFFIXES = TABLE_SUFFIXES + (".erd",)


def check_output_path(output: Path, *inputs: Path | None, suffixes: tuple[str, ...] | None = None) -> Path:
    """Refuse to write ``output`` over one of the command's inputs; create its parent folder.

    Raises :class:`OutputError` (one line, exit code 2) when ``output`` is an input, is an existing folder, its
    folder cannot be created (a file is in the way, no permission), or — with ``suffixes`` — its suffix is not
    one of them (checked before any work, so a long computation never ends on an unwritable format).
    """
    out = Path(output)
    for inp in inputs:
        if inp is not None and Path(inp).exists() and out.exists() and out.resolve() == Path(inp).resolve():
            raise OutputError(f"output {out} is also an input; choose another output path (inputs are never overwritten).")
    if out.is_dir():
        example = f"result{suffixes[0]}" if suffixes else "result.csv"
        raise OutputError(f"output {out} is an existing folder; give a file name, e.g. {out / example}.")
    if suffixes is not None and out.suffix.lower() not in suffixes:
        raise OutputError(f"output {out}: unknown format {out.suffix!r}; use one of {', '.join(suffixes)} "
                          f"(e.g. {out.with_suffix(suffixes[0])}).")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create the folder {out.parent} for {out}: {exc.strerror or exc}; "
                          "choose another output path.") from None
    return out


#: Figure formats ``--plot`` accepts (matplotlib's Agg, PDF and SVG writers).
PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg")


def check_plot_path(plot: Path | None, *inputs: Path | None) -> Path | None:
    """Check a ``--plot`` path before any work: a known figure suffix, not an input, folder creatable."""
    if plot is None:
        return None
    if Path(plot).suffix.lower() not in PLOT_SUFFIXES:
        raise OutputError(f"--plot {plot}: unknown figure format {Path(plot).suffix!r}; use one of "
                          f"{', '.join(PLOT_SUFFIXES)} (e.g. --plot {Path(plot).with_suffix('.png')}).")
    return check_output_path(plot, *inputs)


def progress():
    """A rich progress bar on stderr for long work."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("[progress.description]{task.description}"), BarColumn(),
                    TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn(), console=console)
