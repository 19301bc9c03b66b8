"""Helpers shared by the CLI command modules (no numerical code here)."""

from __future__ import annotations

import os
from pathlib import Path

import typer
from rich.console import Console

from ..errors import InputError, OutputError

console = Console(stderr=True)

#: True in the ``longprofile`` process itself (set by ``app.run``), which ends when its command returns; False when
#: ``app.main`` is called by tests or another program, whose process goes on.
COMMAND_PROCESS = False


#: Table formats a ``-o`` table output accepts (written by :func:`longprofile.io.write_table`).
TABLE_SUFFIXES = (".csv", ".parquet")
#: Profile formats a ``-o`` profile output accepts (:func:`longprofile.io.write_profile`): tables or ERD.
PROFILE_SUFFIXES = TABLE_SUFFIXES + (".erd",)


def parse_tracks(track: str | None) -> list[str] | None:
    """The names of a comma-separated ``--track`` list (None when not given or empty); a name given twice is refused."""
    if track is None:
        return None
    names = [t.strip() for t in track.split(",") if t.strip()]
    seen: dict[str, str] = {}
    for t in names:
        if t.casefold() in seen:
            raise InputError(f"--track names the track {t!r} twice ({track}); give each track once (an MRI or HRI "
                             "needs two different tracks).")
        seen[t.casefold()] = t
    return names or None


#: The ``--overwrite`` option of every command that writes a file or a folder (the same name and meaning).
OVERWRITE = typer.Option(False, "--overwrite", help="Replace an existing output file (or the files this command "
                         "writes into an existing, non-empty output folder). Without it an existing output is "
                         "refused; inputs are never overwritten.")


def _same_file(a: Path, b: Path) -> bool:
    """Same file by path or by inode (a symbolic or hard link)."""
    try:
        return a.resolve() == b.resolve() or os.path.samefile(a, b)
    except OSError:
        return False


def _exists_error(what: str, out: Path) -> OutputError:
    return OutputError(f"{what} {out} exists; pass --overwrite to replace it, or choose another path.")


def check_output_path(output: Path, *inputs: Path | None, suffixes: tuple[str, ...] | None = None,
                      overwrite: bool = False, what: str = "output") -> Path:
    """Refuse to write ``output`` over one of the command's inputs or an existing file; create its parent folder.

    Raises :class:`OutputError` (one line, exit code 2) when ``output`` is an input (even with ``overwrite``),
    exists and ``overwrite`` is False, is an existing folder, its folder cannot be created (a file is in the way,
    no permission), or — with ``suffixes`` — its suffix is not one of them. Call it once, before any work, and
    write to the path it returns (a second call after writing would refuse the command's own file).
    """
    out = Path(output)
    for inp in inputs:
        if inp is not None and Path(inp).exists() and out.exists() and _same_file(out, Path(inp)):
            how = "" if out.resolve() == Path(inp).resolve() else f" ({inp}, through a hard link)"
            raise OutputError(f"output {out} is also an input{how}; choose another output path (inputs are never "
                              "overwritten).")
    if out.is_dir():
        example = f"result{suffixes[0]}" if suffixes else "result.csv"
        raise OutputError(f"output {out} is an existing folder; give a file name, e.g. {out / example}.")
    if suffixes is not None and out.suffix.lower() not in suffixes:
        raise OutputError(f"output {out}: unknown format {out.suffix!r}; use one of {', '.join(suffixes)} "
                          f"(e.g. {out.with_suffix(suffixes[0])}).")
    if not overwrite and (out.exists() or out.is_symlink()):
        raise _exists_error(what, out)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create the folder {out.parent} for {out}: {exc.strerror or exc}; "
                          "choose another output path.") from None
    return out


def check_distinct_outputs(outputs: dict) -> None:
    """Refuse two outputs of one command at the same path (``{"-o": out, "--profile": prof, "--plot": png}``; None
    entries skipped): the second write would replace the first, whose result is lost. Call it before any work."""
    seen: dict[Path, str] = {}
    for option, path in outputs.items():
        if path is None:
            continue
        key = Path(path).resolve()
        if key in seen:
            raise OutputError(f"{option} {path} is the same file as the {seen[key]} output: the command writes both "
                              f"and the second would replace the first; give {option} another path.")
        seen[key] = option
    return None


def check_output_folder(output: Path, *inputs: Path | None, overwrite: bool = False, what: str = "output",
                        writes=(), hint: str | None = None, others: dict | None = None) -> Path:
    """Check an output *folder* before any work (:func:`longprofile.report.report_folder`, nothing created).

    Refused: the folder is an input, a file, not empty without ``overwrite``, or one of the files the command
    writes there (``writes``, e.g. ``REPORT_FILES["road"]``) is an input (even with ``overwrite``); one of the
    command's other outputs (``others``: option -> path, e.g. ``{"-o": out, "--plot": png}``) inside the folder
    (the report would replace it, or find its folder not empty). With ``overwrite`` the command replaces the files
    it writes there; other files in the folder are left alone.
    """
    from ..report import report_folder

    folder = Path(output).resolve()
    for option, path in (others or {}).items():
        if path is not None and folder in Path(path).resolve().parents:
            raise OutputError(f"{option} {path} is inside the {what} folder {output}, which holds the report's files "
                              f"only; write it outside that folder (e.g. {option} {Path(path).name}).")
    return report_folder(output, inputs, writes=writes, overwrite=overwrite, create=False, what=what, hint=hint)


#: Figure formats ``--plot`` accepts (matplotlib's Agg, PDF and SVG writers).
PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg")


def check_plot_path(plot: Path | None, *inputs: Path | None, overwrite: bool = False) -> Path | None:
    """Check a ``--plot`` path before any work: a known figure suffix, not an input, not an existing file
    (unless ``overwrite``), folder creatable."""
    if plot is None:
        return None
    if Path(plot).suffix.lower() not in PLOT_SUFFIXES:
        raise OutputError(f"--plot {plot}: unknown figure format {Path(plot).suffix!r}; use one of "
                          f"{', '.join(PLOT_SUFFIXES)} (e.g. --plot {Path(plot).with_suffix('.png')}).")
    return check_output_path(plot, *inputs, overwrite=overwrite, what="--plot")


def save_plot(path: Path, plot_fn, *args, announce: bool = False, savefig: dict | None = None, **kwargs) -> Path:
    """Save the figure ``plot_fn(*args, **kwargs)`` to a path already checked by :func:`check_plot_path`, atomically
    (``savefig`` keywords: e.g. dpi), drawn by the command's figure helper when one runs
    (:func:`longprofile.report.figure_renderer`, started by :func:`longprofile.cli.app.main`), else here; with
    ``announce``, print ``wrote <path>``."""
    from ..report import save_plot as _plot

    out = _plot(path, plot_fn, *args, savefig=savefig, **kwargs)
    if announce:
        console.print(f"wrote {out}", markup=False, soft_wrap=True)
    return out


def progress():
    """A rich progress bar on stderr for long work."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("[progress.description]{task.description}"), BarColumn(),
                    TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn(), console=console)
