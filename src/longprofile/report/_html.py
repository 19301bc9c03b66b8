"""Pieces shared by the HTML reports: the report folder, figures written as PNG and embedded in the page."""

from __future__ import annotations

import base64
import html
import io
from pathlib import Path

from ..errors import OutputError
from ..io import atomic_write_bytes

__all__ = ["report_folder", "png_bytes", "write_figures", "img_tag"]


def report_folder(outdir, inputs=(), *, writes=(), overwrite: bool = True) -> Path:
    """The report folder, created; refused when it is an input, would overwrite an input, or a file is in the way.

    With ``overwrite=False`` an existing folder that is not empty is refused too (the CLI's default; the
    library default True replaces the files the report writes and leaves the others alone).

    Parameters
    ----------
    outdir : path-like
    inputs : iterable of path-like or None
        The report's inputs (files or folders).
    writes : iterable of str
        File names the report writes into the folder (an input of that name there would be overwritten).
    """
    out = Path(outdir)
    names = set(writes)
    for inp in inputs:
        if inp is None:
            continue
        p = Path(inp).resolve()
        if p == out.resolve():
            raise OutputError(f"the report folder {out} is an input; choose another folder, e.g. -o {Path(inp).name}_report/.")
        if p.parent == out.resolve() and p.name in names:
            raise OutputError(f"the report would overwrite its input {inp} (it writes {p.name} into {out}); "
                              "choose another folder.")
    if out.exists() and not out.is_dir():
        raise OutputError(f"output {out} is a file; the report needs a folder, e.g. -o {out.with_suffix('')}_report/.")
    if not overwrite and out.is_dir() and any(out.iterdir()):
        raise OutputError(f"output folder {out} exists and is not empty; pass --overwrite to replace the files "
                          "this command writes there, or choose another path.")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create the report folder {out}: {exc.strerror or exc}; choose another folder.") from None
    return out


def png_bytes(fig, **savefig_kwargs) -> bytes:
    """A matplotlib Figure as PNG bytes."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", **savefig_kwargs)
    return buf.getvalue()


def write_figures(figures: dict, out: Path, **savefig_kwargs) -> tuple[list[Path], dict[str, str]]:
    """Write each ``{file name: Figure}`` as a PNG into ``out``; return the paths and the base64 of each PNG."""
    paths, images = [], {}
    for fname, fig in figures.items():
        data = png_bytes(fig, **savefig_kwargs)
        atomic_write_bytes(out / fname, data)
        paths.append(out / fname)
        images[fname] = base64.b64encode(data).decode("ascii")
    return paths, images


def img_tag(images: dict[str, str], fname: str, alt: str) -> str:
    """An ``<img>`` embedding the PNG ``fname`` of :func:`write_figures` (the page works without its folder)."""
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{images[fname]}">'
