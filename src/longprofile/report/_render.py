"""Figures drawn in a helper process while the command computes: matplotlib's import and drawing off the critical path.

A command that writes figures pays matplotlib twice in its own process: the import (0.4 s on the development machine)
and the drawing (0.1 s per figure). :func:`figure_renderer` starts one helper process when the command starts; the
helper imports matplotlib and draws a small figure (font cache, Agg) while the command reads and computes, then
draws the figures the report submits while the command writes its tables. The figures are the same PNG bytes as
drawn in the command's own process (the same functions, the same matplotlib).

A report of several figures (``road report``, ``rail settle --report``: ``second=True``) gets a second helper,
forked by the first once it is warm (matplotlib and the preload imported, before any figure exists: nothing large
to copy on write); the two share the report's figures (:func:`spread`). On a machine whose second core adds only
part of a core's throughput (2026-12-06: two vCPUs, 1.2x one) it gains 0.06-0.09 s on those commands.

The helper is started only when the machine is not oversubscribed (1-minute load average below the core count,
:func:`_spare_core`): it costs more CPU in total than drawing inline, which a busy machine pays in wall time. The
CLI asks for it only where it was measured to help (``longprofile.cli.app._HELPER_COMMANDS``).
``LONGPROFILE_FIGURES=helper`` always starts it, ``inline`` never. Where the helper cannot run (no ``fork`` start method, a daemonic process such
as a worker of :mod:`longprofile.batch`), when it dies, or for arguments that cannot be sent to it, the figures are
drawn in the calling process (:class:`InlineRenderer`): the same result, without the overlap.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
from concurrent.futures import Future
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

from .._interrupt import quiet_interrupt

__all__ = ["InlineRenderer", "BackgroundRenderer", "figure_renderer", "current_renderer", "use_renderer",
           "save_plot", "draw", "spread"]


class InlineRenderer:
    """Draws each figure at once in the calling process (the library's default)."""

    background = False

    def submit(self, fn, /, *args, **kwargs) -> Future:
        """Run ``fn(*args, **kwargs)`` now; a finished :class:`~concurrent.futures.Future` of its result."""
        fut: Future = Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except Exception as exc:  # raised again by .result(), where the caller would have seen it
            fut.set_exception(exc)
        return fut


@quiet_interrupt
def _warm(preload=(), second: bool = False) -> None:
    """Helper-process start: import matplotlib and draw a small figure with text (fonts, Agg), then import the
    ``preload`` modules (those the submitted figures' arguments will need to be unpickled; an entry
    ``"module:function()"`` calls that function, e.g. one drawing the command's figure on small data so that its
    first use of fonts, bands and legends is paid here). ``second``: then fork a
    second helper from this warm one (:func:`spread`).

    Not warmed here (measured 2026-12-06, session 28): log axes with mathtext tick labels, a legend, a band and a
    date axis (the first use of each in the reports' figures): `road report` was 0.07 s slower with them, its
    figures arriving before the longer warm-up ended."""
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(1, 1), dpi=20)
    FigureCanvasAgg(fig)
    fig.add_subplot().set_title("warm")
    fig.savefig(io.BytesIO(), format="png")
    _import_preload(preload)
    if second:
        _start_second()


def _import_preload(preload, call: bool = True) -> None:
    """Import the ``preload`` entries: ``"module"`` or ``"module:name,name"`` (names fetched: a lazy package loads
    their submodules); a ``"name()"`` is called (a command's own warm-up figure), only with ``call``."""
    import importlib

    for entry in preload:
        module, _, names = entry.partition(":")
        mod = importlib.import_module(module)
        for name in filter(None, names.split(",")):
            obj = getattr(mod, name.removesuffix("()"))
            if call and name.endswith("()"):
                obj()


#: In a helper process started with ``second=True``: a second helper forked from it once warm (matplotlib and the
#: preload imported), which :func:`spread` shares a multi-figure job with.
_SECOND = None


def _start_second() -> None:
    global _SECOND
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing.util import Finalize

    try:
        _SECOND = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("fork"))
        _SECOND.submit(_ready)  # forked now, idle until a job is shared with it
    except OSError:  # no process could be started: this helper draws alone
        _SECOND = None
        return
    # stopped when this helper exits: multiprocessing joins a process's children before the executors' own exit
    # hook would stop them; a finalizer with exitpriority >= 0 runs before that join, and one above 10 before the
    # executor's queues close their feeder threads (exitpriority 10), which would leave the stop message unsent
    Finalize(_SECOND, _SECOND.shutdown, kwargs={"cancel_futures": True}, exitpriority=100)


def spread(fn, names, /, *args, **kwargs) -> dict:
    """``{name: fn(name, *args, **kwargs)}`` for each of ``names``, in their order.

    In a helper process that has a second helper (:func:`_warm` with ``second=True``), the two share the names:
    this process takes them from the front, the second one from the back (each sent with its own copy of the
    arguments), until they meet. Elsewhere (the calling process, a helper alone) one after the other, here. A
    second helper that has died leaves its names to this process."""
    from concurrent.futures.process import BrokenProcessPool

    names = list(names)
    if _SECOND is None or len(names) < 2:
        return {name: fn(name, *args, **kwargs) for name in names}
    try:
        shared = {name: _SECOND.submit(fn, name, *args, **kwargs) for name in reversed(names[1:])}
    except (BrokenProcessPool, RuntimeError):
        return {name: fn(name, *args, **kwargs) for name in names}
    out = {}
    for name in names:
        job = shared.get(name)
        if job is None or job.cancel():  # not yet taken by the second helper: drawn here
            out[name] = fn(name, *args, **kwargs)
            continue
        try:
            out[name] = job.result()
        except BrokenProcessPool:
            out[name] = fn(name, *args, **kwargs)
    return out


def _ready() -> bool:
    return True


def _run_pickled(payload: bytes):
    """In the helper: ``fn(*args, **kwargs)`` of the pickled ``(fn, args, kwargs)``."""
    fn, args, kwargs = pickle.loads(payload)
    return fn(*args, **kwargs)


class _Job:
    """A figure submitted to the helper; drawn here instead if the helper has died."""

    def __init__(self, fut, fn, args, kwargs):
        self._fut, self._call = fut, (fn, args, kwargs)

    def result(self):
        from concurrent.futures.process import BrokenProcessPool

        try:
            return self._fut.result()
        except BrokenProcessPool:
            fn, args, kwargs = self._call
            return fn(*args, **kwargs)


class BackgroundRenderer:
    """One helper process (``fork``) that draws the submitted figures; see the module docstring.

    ``preload``: modules the helper imports after matplotlib, while the command computes (e.g. the domain
    package whose result classes the figures receive: unpickled there without waiting for their imports).
    ``second``: the helper, once warm, forks a second helper that shares the multi-figure jobs (:func:`spread`)."""

    background = True

    def __init__(self, preload=(), second: bool = False):
        from concurrent.futures import ProcessPoolExecutor

        self._pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("fork"),
                                         initializer=_warm, initargs=(tuple(preload), bool(second)))
        self._pool.submit(_ready)  # starts the helper now: matplotlib is imported while the command computes

    def submit(self, fn, /, *args, **kwargs) -> _Job:
        """Queue ``fn(*args, **kwargs)`` (a module-level function returning picklable data, e.g. PNG bytes); what
        cannot be sent to the helper (e.g. a result holding compiled closures) is drawn here, at once."""
        from concurrent.futures.process import BrokenProcessPool

        try:  # pickled once, here: what cannot be sent is known before anything is queued
            payload = pickle.dumps((fn, args, kwargs), protocol=pickle.HIGHEST_PROTOCOL)
        except Exception:
            return InlineRenderer().submit(fn, *args, **kwargs)
        try:
            return _Job(self._pool.submit(_run_pickled, payload), fn, args, kwargs)
        except (BrokenProcessPool, RuntimeError):
            return InlineRenderer().submit(fn, *args, **kwargs)

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _spare_core() -> bool:
    """The machine is not oversubscribed: its 1-minute load average is below its core count. The helper costs
    0.3-0.5 s of CPU more than drawing inline (its own imports); on a machine with no core to spare that is wall
    time and the command gets slower (measured: `road iri --plot` 2.9 s inline against 3.9 s with a helper at load
    2.9 on 2 cores; at load 1.4-1.5 the helper still gained 0-0.7 s on `road acceptance`). A stricter rule (load at
    most cores - 1) switched the helper off for commands run back to back, whose own runs raise the average; an
    instantaneous count of runnable tasks (``/proc/loadavg``) saw a second task too often to be useful."""
    try:
        return os.getloadavg()[0] < _cores()
    except OSError:  # no load average on this system
        return False


def _can_fork() -> bool:
    """``LONGPROFILE_FIGURES``: ``inline`` never starts a helper, ``helper`` always does (where ``fork`` exists),
    unset or ``auto`` only when a core is free (:func:`_spare_core`)."""
    mode = os.environ.get("LONGPROFILE_FIGURES", "auto").lower()
    if (mode == "inline" or "fork" not in multiprocessing.get_all_start_methods()
            or multiprocessing.current_process().daemon):
        return False
    return mode == "helper" or _spare_core()


@contextmanager
def figure_renderer(background: bool = True, preload=(), second: bool = False, inherit: bool = False):
    """A renderer for a command's figures: a :class:`BackgroundRenderer` (helper process started now, importing
    matplotlib and the ``preload`` modules) where it can run, else an :class:`InlineRenderer`; the helper is
    stopped on exit. Start it before the command's imports. ``second``: on a machine with two cores or more, the
    helper forks a second one once warm, and the two draw a report's figures in parallel (:func:`spread`).
    ``inherit``: the ``preload`` modules are imported here, before the helper is forked, which then inherits them
    instead of importing its own copy: for modules the command imports first anyway, one import instead of two
    (``rail settle --plot --report``, pandas: 0.25 s of CPU less at load 8-10 on two vCPUs, session 41); an entry
    ending in ``()`` is still called in the helper only."""
    if not (background and _can_fork()):
        yield InlineRenderer()
        return
    if inherit:
        _import_preload(preload, call=False)
    try:
        renderer = BackgroundRenderer(preload, second=second and _cores() >= 2)
    except OSError:  # no process could be started (limits): draw here
        yield InlineRenderer()
        return
    try:
        yield renderer
    finally:
        renderer.close()


_CURRENT: ContextVar = ContextVar("longprofile_figure_renderer", default=None)


def current_renderer():
    """The renderer set by :func:`use_renderer` (the CLI sets one per command), else an :class:`InlineRenderer`."""
    renderer = _CURRENT.get()
    return InlineRenderer() if renderer is None else renderer


@contextmanager
def use_renderer(renderer):
    """Make ``renderer`` the :func:`current_renderer` inside the block."""
    token = _CURRENT.set(renderer)
    try:
        yield renderer
    finally:
        _CURRENT.reset(token)


def _draw_to_file(plot_fn, args, kwargs, path, savefig):
    from .._atomic import save_figure  # not longprofile.io: its readers import pandas

    return save_figure(plot_fn(*args, **kwargs), path, **savefig)


def save_plot(path, plot_fn, /, *args, savefig: dict | None = None, **kwargs) -> Path:
    """``save_figure(plot_fn(*args, **kwargs), path, **savefig)`` (atomic), drawn by the current renderer; returns
    ``path`` once the file is written."""
    return current_renderer().submit(_draw_to_file, plot_fn, args, kwargs, Path(path), savefig or {}).result()


def draw(plot_fn, /, *args, **kwargs):
    """``plot_fn(*args, **kwargs)`` for a plotting function that writes its own file, by the current renderer."""
    return current_renderer().submit(plot_fn, *args, **kwargs).result()
