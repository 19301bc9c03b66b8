"""Pieces shared by the HTML reports: the report folder, figures written as PNG and embedded in the page, and the
page itself rendered from its Jinja2 template in ``report/templates/`` (:func:`render`)."""

from __future__ import annotations

import base64
import functools
import html
import io
import os
from pathlib import Path

from .._atomic import png_defaults
from ..errors import OutputError
from ..io import atomic_path, atomic_write_bytes

__all__ = ["REPORT_FILES", "report_folder", "png_bytes", "write_figures", "write_pngs", "figure_pngs", "img_tag",
           "write_csv", "write_text", "render"]

#: The files each report writes into its folder (an input of one of these names there is never overwritten).
REPORT_FILES: dict[str, tuple[str, ...]] = {
    "road": ("index.html", "iri_segments.csv", "localized_roughness.csv", "psd.csv", "iso8608.csv",
             "waveband_energy.csv", "profile.png", "iri.png", "localized_roughness.png", "psd.png"),
    "acceptance": ("index.html", "lots.csv", "localized.parquet", "defects.csv", "grinds.csv", "histogram.csv",
                   "summary.json", "lots.png", "localized.png", "histogram.png", "grinds.png", "profile_ground.csv"),
    "compare": ("runs.csv", "pairs.csv", "summary.json", "correlation.png"),
    "network": ("index.html", "iri_histogram.png", "worst_routes.png", "routes.csv", "worst_segments.csv",
                "failed.csv"),
    "rail": ("index.html", "profiles_by_week.png", "through_time.png", "settlement_map.png", "initial_profile.png",
             "controls.png", "settlement.csv", "alarms.csv", "sensors.csv"),
}


def report_folder(outdir, inputs=(), *, writes=(), overwrite: bool = True, create: bool = True,
                  what: str = "output", hint: str | None = None) -> Path:
    """Check (and create) an output folder: the one check of every command and report that writes a folder.

    Refused (:class:`~longprofile.errors.OutputError`, one line) when the folder is one of ``inputs``, a file is
    in the way, it exists and is not empty while ``overwrite`` is False, or one of the files it would write
    (``writes``) is an input — the last even with ``overwrite``: inputs are never overwritten.

    Parameters
    ----------
    outdir : path-like
    inputs : iterable of path-like or None
        The inputs (files or folders).
    writes : iterable of str
        File names written into the folder (e.g. ``REPORT_FILES["road"]``).
    overwrite : bool, default True
        False refuses an existing folder that is not empty (the CLI's default). True replaces the files written
        there and leaves the others alone; the files of ``writes`` an earlier run left there are removed first
        (with ``create``), so that a run that writes fewer of them (no grind list, no correlation plot) does not
        leave the earlier run's beside its own: the folder never mixes two runs. Only names of ``writes`` are
        removed, never a folder, never an input (refused above).
    create : bool, default True
        Create the folder (and remove the earlier run's files). False only checks (a command's check before any
        work).
    what : str
        How the folder is named in the messages (``"output"``, ``"--report"``).
    hint : str, optional
        What to do when ``outdir`` is a file (default: give a folder, with an example).
    """
    out = Path(outdir)
    resolved = out.resolve()
    targets = {(out / name).resolve(): name for name in writes}
    inputs = [Path(p) for p in inputs if p is not None]
    for inp in inputs:
        if inp.resolve() == resolved:
            raise OutputError(f"{what} folder {out} is an input; choose another folder (inputs are never "
                              "overwritten).")
    if out.exists() and not out.is_dir():
        raise OutputError(f"{what} {out} is a file; "
                          + (hint or f"give a folder, e.g. {out.with_suffix('')}_out/."))
    if not overwrite and out.is_dir() and any(out.iterdir()):
        raise OutputError(f"{what} folder {out} exists and is not empty; pass --overwrite to replace the files "
                          "this command writes there, or choose another path.")
    linked = {}  # written files that exist and are an input through a hard link
    for target, name in targets.items():
        for inp in inputs:
            try:
                if target.is_file() and inp.is_file() and os.path.samefile(target, inp):
                    linked[inp.resolve()] = name
            except OSError:
                pass
    for inp in inputs:
        name = targets.get(inp.resolve()) or linked.get(inp.resolve())
        if name is not None:
            raise OutputError(f"this would overwrite its input {inp} (it writes {name} into {out}); choose another "
                              "folder (inputs are never overwritten).")
    if create:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"cannot create the folder {out}: {exc.strerror or exc}; choose another folder.") from None
        _remove_earlier_run(out, writes)
    return out


def _remove_earlier_run(out: Path, writes) -> None:
    """Remove the files named in ``writes`` from ``out`` (an earlier run's outputs; files and links only)."""
    for name in writes:
        path = out / name
        if path.is_symlink() or path.is_file():
            try:
                path.unlink()
            except OSError as exc:
                raise OutputError(f"cannot remove the earlier run's {path}: {exc.strerror or exc}; remove it or "
                                  "choose another folder.") from None


def write_csv(frame, path: Path) -> Path:
    """``frame.to_csv(path, index=False)`` through a temporary file (an older file survives a failure)."""
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False)
    return Path(path)


def write_text(path: Path, text: str) -> Path:
    """UTF-8 text through a temporary file (an older file survives a failure)."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def png_bytes(fig, **savefig_kwargs) -> bytes:
    """A matplotlib Figure as PNG bytes."""
    buf = io.BytesIO()
    fig.savefig(buf, **png_defaults({"format": "png", **savefig_kwargs}))
    return buf.getvalue()


def write_figures(figures: dict, out: Path, **savefig_kwargs) -> tuple[list[Path], dict[str, str]]:
    """Write each ``{file name: Figure}`` as a PNG into ``out``; return the paths and the base64 of each PNG."""
    return write_pngs({fname: png_bytes(fig, **savefig_kwargs) for fname, fig in figures.items()}, out)


def write_pngs(pngs: dict, out: Path) -> tuple[list[Path], dict[str, str]]:
    """Write each ``{file name: PNG bytes}`` into ``out``; return the paths and the base64 of each PNG."""
    paths, images = [], {}
    for fname, data in pngs.items():
        atomic_write_bytes(out / fname, data)
        paths.append(out / fname)
        images[fname] = base64.b64encode(data).decode("ascii")
    return paths, images


def _figure_png(fname, builders, args, kwargs, savefig) -> bytes:
    return png_bytes(builders[fname](*args, **kwargs), **savefig)


def figure_pngs(builders: dict, /, *args, savefig: dict | None = None, **kwargs) -> dict[str, bytes]:
    """``{file name: PNG bytes}`` of ``builders`` (``{file name: function}``, each ``function(*args, **kwargs)``
    returning a Figure), in their order: the unit of work a report sends to its figure renderer
    (:func:`longprofile.report.current_renderer`). In a figure helper with a second helper the two draw them in
    parallel (:func:`longprofile.report._render.spread`), else one after the other."""
    from ._render import spread

    return spread(_figure_png, builders, builders, args, kwargs, savefig or {})


def img_tag(images: dict[str, str], fname: str, alt: str) -> str:
    """An ``<img>`` embedding the PNG ``fname`` of :func:`write_figures` (the page works without its folder)."""
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{images[fname]}">'


@functools.lru_cache(maxsize=1)
def _environment():
    """The Jinja2 environment of the report templates (package data ``report/templates/``), made once.

    ``autoescape=False``: the writers pass HTML (values escaped with :func:`html.escape` where they are text), so a
    page is the same bytes as the f-string each replaced. ``StrictUndefined``: a name missing from the context is an
    error, not an empty string. Jinja2 is imported here, when the first page is rendered: commands that write no
    report never load it.
    """
    import jinja2

    return jinja2.Environment(loader=jinja2.PackageLoader("longprofile.report", "templates"), autoescape=False,
                              keep_trailing_newline=True, undefined=jinja2.StrictUndefined)


def render(template: str, /, **context) -> str:
    """Render ``report/templates/<template>`` with ``context`` (values are HTML already, see :func:`_environment`)."""
    return _environment().get_template(template).render(**context)
