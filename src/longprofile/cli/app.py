"""Root of the ``longprofile`` command."""

from __future__ import annotations

import os
import sys

import typer
from rich.markup import escape

from .._memory import tune_process_memory
from ..errors import LongprofileError
from ._common import console

app = typer.Typer(
    name="longprofile",
    help="Road and rail longitudinal profiles, road grade and vehicle states from indirect sensors.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)

_CITATION = """\
longprofile implements methods from:
[000] Piasco, Legeay - APL longitudinal profile analyser: instrument model, double filtering, identification, Kalman deconvolution.
[001] Sebsadji, Glaser, Mammar - vehicle state and road slope estimation, EKF cascaded with a Luenberger observer.
[002] Recursive maximum-likelihood derivative estimators of noisy sampled signals.
[003] Plancke - real-time vertical vehicle state estimation (thesis, SUPELEC / Delphi).
[004] SNCF / Sorbonne - rail track settlement from sleeper inclinometers with a Bayesian rigidity prior."""


def _version_callback(value: bool):
    if value:
        from .. import __version__

        typer.echo(f"longprofile {__version__}")
        raise typer.Exit()


def _cite_callback(value: bool):
    if value:
        typer.echo(_CITATION)
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version_callback, is_eager=True,
                                 help="Print the version and exit."),
    cite: bool = typer.Option(False, "--cite", callback=_cite_callback, is_eager=True,
                              help="Print the papers implemented and exit."),
):
    """longprofile command line."""


def _register():
    from . import demo, road, signal, vehicle

    app.command("demo")(demo.demo)
    app.command("differentiate")(signal.differentiate)
    app.add_typer(road.road_app, name="road")
    from . import rail

    app.add_typer(rail.rail_app, name="rail")
    app.add_typer(vehicle.vehicle_app, name="vehicle")
    from .batch import batch_app

    app.add_typer(batch_app, name="batch")


_register()


#: Commands that draw figures without a --plot or --report option.
_FIGURE_COMMANDS = (("road", "report"), ("road", "acceptance"))


def _draws_figures(args) -> bool:
    """Whether the command line asks for figures (``--plot``, ``--report`` or a report command)."""
    args = [str(a) for a in args]
    if any(a in ("--plot", "--report") or a.startswith(("--plot=", "--report=")) for a in args):
        return True
    words = tuple(a for a in args if not a.startswith("-"))
    return any(words[:len(c)] == c for c in _FIGURE_COMMANDS)


#: Commands whose figures the helper draws by default, with what the helper imports while the command computes:
#: the modules (``"module"`` or ``"module:name,name"``, names fetched to load a lazy package's submodules) that
#: unpickling and drawing the figure's arguments need (report/_render.py). Without a preload, a figure whose
#: arguments come from heavy domain modules (vehicle vertical estimate, road reconstruct, rail settle) made the
#: command 0.3-1.5 s slower: the helper imported them only when the figure arrived. Measured 2026-12-04 (docs/
#: architecture.md, "Start-up"); the other commands draw inline unless ``LONGPROFILE_FIGURES=helper``.
_HELPER_COMMANDS = {
    ("road", "acceptance"): (), ("road", "convert"): (), ("road", "compare"): (), ("differentiate",): (),
    ("road", "reconstruct"): ("longprofile.report:warm_reconstructions()",),
    ("road", "report"): ("pandas", "longprofile.road:analyse_roughness"),
    ("rail", "settle"): ("pandas", "longprofile.rail:SettlementResult"),
    ("vehicle", "vertical", "estimate"): ("pandas", "longprofile.vehicle.vertical:VerticalStateEstimate,CORNER_NAMES"),
    ("vehicle", "vertical", "tables"): ("pandas",),
    ("vehicle", "slope"): ("pandas", "longprofile.vehicle:SlopeEstimate"),
}


#: Commands whose reports draw several figures after their results exist: their helper forks a second helper
#: once warm, and the two draw the figures in parallel (report/_render.py, ``spread``; measured 2026-12-06,
#: session 28, docs/architecture.md "Start-up").
_TWO_HELPER_COMMANDS = (("road", "report"), ("rail", "settle"))


#: Commands that import their helper's preload themselves, first thing: imported before the helper is forked, which
#: inherits them (``figure_renderer(inherit=True)``); measured on ``rail settle --plot --report`` (session 41, docs/
#: architecture.md "Start-up": pandas imported once instead of twice).
_INHERIT_PRELOAD_COMMANDS = (("rail", "settle"),)


def _figure_helper(args) -> tuple[bool, tuple[str, ...]]:
    """Whether to start the figure helper for this command line (:data:`_HELPER_COMMANDS`, or any command that
    draws with ``LONGPROFILE_FIGURES=helper``), and what it preloads."""
    if not _draws_figures(args):
        return False, ()
    words = tuple(str(a) for a in args if not str(a).startswith("-"))
    for command, preload in _HELPER_COMMANDS.items():
        if words[:len(command)] == command:
            return True, preload
    return os.environ.get("LONGPROFILE_FIGURES", "").lower() == "helper", ()


#: What a command can do when its request does not fit in memory, by command words (session 38); any other command
#: gets the size options it has among :data:`_SIZE_OPTIONS`, else "split the input".
_MEMORY_HINTS = {
    ("vehicle", "vertical", "estimate"): "split the log into shorter files (the estimate holds ~2 kB per sample, "
                                         "~7 GB for an hour at 1 kHz); --profile also keeps the filter's covariance "
                                         "histories, several times that: leave it out or split the log further",
}
_SIZE_OPTIONS = ("--length", "--duration", "--days", "--sampling-minutes")


def _memory_hint(args) -> str:
    """What to do when the command of ``args`` runs out of memory: its own hint, its size options or splitting."""
    words = tuple(str(a) for a in args if not str(a).startswith("-"))
    for command, hint in _MEMORY_HINTS.items():
        if words[:len(command)] == command:
            return hint
    try:
        cmd = typer.main.get_command(app)
        for word in words:
            sub = getattr(cmd, "commands", {}).get(word)
            if sub is None:
                break
            cmd = sub
        options = {o for p in getattr(cmd, "params", ()) for o in getattr(p, "opts", ())}
    except Exception:  # the hint must never hide the memory error itself
        options = set()
    sizes = [o for o in _SIZE_OPTIONS if o in options]
    return f"reduce its size ({', '.join(sizes)}) or split the input" if sizes else "split the input into smaller files"


def _command_in(args, commands) -> bool:
    """Whether the command words of ``args`` begin with one of ``commands`` (tuples of words)."""
    words = tuple(str(a) for a in args if not str(a).startswith("-"))
    return any(words[:len(c)] == c for c in commands)


def _second_helper(args) -> bool:
    """Whether the figure helper forks a second one (:data:`_TWO_HELPER_COMMANDS`)."""
    return _command_in(args, _TWO_HELPER_COMMANDS)


def main(argv: list[str] | None = None) -> int:
    """Console-script entry point: run the app, turn library errors into one red line and exit code 2.

    The process's memory settings are tuned first (:func:`longprofile._memory.tune_process_memory`: freed
    arrays reused, no huge-page advice; ``LONGPROFILE_MALLOC_TUNING=0`` leaves them alone)."""
    tune_process_memory()
    from ..report import figure_renderer, use_renderer

    # a command that draws figures (of _HELPER_COMMANDS) gets a helper process now, before its imports: matplotlib
    # loads and the figures are drawn there while this process reads and computes (report/_render.py)
    try:
        args = sys.argv[1:] if argv is None else argv
        background, preload = _figure_helper(args)
        with (figure_renderer(background=background, preload=preload, second=_second_helper(args),
                              inherit=_command_in(args, _INHERIT_PRELOAD_COMMANDS)) as renderer,
              use_renderer(renderer)):
            # with standalone_mode=False click returns a raised typer.Exit's code instead of exiting
            code = app(args=argv, standalone_mode=False)
    except LongprofileError as exc:
        # the message is text, not rich markup: "[lot]" or "[units]" in a message must print as written; one line
        # even when it quotes a library's multi-line message (pandas' parser hints)
        console.print(f"[red]error:[/red] {escape(' '.join(str(exc).split()))}", highlight=False, soft_wrap=True)
        return 2
    except (MemoryError, ValueError) as exc:
        # a size no machine holds (e.g. a simulator asked for 1e9 s or 1e12 m): numpy's MemoryError, or its
        # ValueError "Maximum allowed size exceeded" beyond the address space; any other ValueError is a bug
        if not isinstance(exc, MemoryError) and "Maximum allowed size exceeded" not in str(exc):
            raise
        hint = _memory_hint(sys.argv[1:] if argv is None else argv)
        console.print(f"[red]error:[/red] not enough memory for this request ({escape(str(exc))}); {escape(hint)}.",
                      highlight=False, soft_wrap=True)
        return 2
    except typer.Exit as exc:
        return exc.exit_code
    except typer.Abort:
        console.print("[red]aborted[/red]")
        return 1
    except Exception as exc:
        # usage errors from typer's bundled click (ClickException: has show(), format_message() and exit_code)
        if hasattr(exc, "show") and isinstance(getattr(exc, "exit_code", None), int):
            return _usage_error(exc)
        raise
    return code if isinstance(code, int) else 0


def _usage_error(exc) -> int:
    """A command line click refuses (a mistyped option or command, a missing or invalid value): one line, as every
    other input error, naming the command's help instead of click's usage block. A group called without a command
    (click's ``NoArgsIsHelpError``) shows its help, as click does."""
    if type(exc).__name__ == "NoArgsIsHelpError":
        exc.show()
        return exc.exit_code
    ctx = getattr(exc, "ctx", None)
    see = f" (see '{ctx.command_path} --help')" if ctx is not None else ""
    message = " ".join(str(exc.format_message()).split())
    console.print(f"[red]error:[/red] {escape(message.rstrip('.'))}{escape(see)}.", highlight=False, soft_wrap=True)
    return exc.exit_code


def _other_threads() -> bool:
    """True when a non-daemon thread other than the main one is alive (the normal exit would wait for it)."""
    import threading

    return any(t is not threading.main_thread() and not t.daemon and t.is_alive() for t in threading.enumerate())


def run() -> None:
    """The ``longprofile`` console script and ``python -m longprofile``: :func:`main`, then a fast exit.

    Tearing down an interpreter that has loaded numba/LLVM, pandas and pyarrow takes 0.2-0.3 s (``road
    acceptance``: 0.3 s between the command's end and the process's, measured 2026-12-03), all of it after the work
    is done. By then every output file is written and closed (``atomic_path``); the exit handlers still run (atexit:
    multiprocessing's, the figure helper's, coverage's), the standard streams are flushed, and the process ends
    with :func:`os._exit`, skipping only the freeing of modules and objects. The normal exit is kept when another
    non-daemon thread is alive, on an uncaught exception (the traceback prints as usual) and with
    ``LONGPROFILE_FAST_EXIT=0``. :func:`main` itself (called by tests and by other programs) returns normally.
    """
    from . import _common

    _common.COMMAND_PROCESS = True  # e.g. an interrupted batch keeps ignoring Ctrl-C until the exit (cli/batch.py)
    code = main()
    if os.environ.get("LONGPROFILE_FAST_EXIT", "1") == "0" or _other_threads():
        sys.exit(code)
    import atexit

    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (e.g. `| head`): nothing more can be written
            pass
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    run()
