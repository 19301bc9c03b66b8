"""Ctrl-C in worker processes and in the process that drives them: one interruption, one clean stop.

A terminal's Ctrl-C sends SIGINT to the whole foreground process group: the command *and* its helper processes (the
figure helpers of ``report/_render.py``, the process pool of ``batch``). The command turns its own
``KeyboardInterrupt`` into exit code 130 without a traceback (``cli/app.py``) and stops its pools on the way out; a
worker interrupted while a pool's initializer ran would print ``Exception in initializer:`` and a traceback
(``concurrent.futures`` logs it), one per worker. :func:`quiet_interrupt` wraps such an initializer: interrupted, the
worker exits at once with status 130 and prints nothing. An initializer only imports and warms up (nothing is being
written), so nothing is left half-done; a worker interrupted inside a task returns the interruption to the pool as
the task's outcome, which ``concurrent.futures`` does without printing. (The ``batch`` pool's workers go further:
they start with SIGINT blocked and ignore it, ``batch/_map.py``; the driver alone answers Ctrl-C.)

:func:`interrupt_once` is the driver's side: the first SIGINT (or SIGTERM, for a command) raises
``KeyboardInterrupt``; the ones after it are ignored while the interrupted work cleans up (writes what it finished,
stops its pool). A second Ctrl-C landing in that cleanup had left ``batch`` hanging (session 35, a probe).
"""

from __future__ import annotations

import functools
import os
import signal
import threading
from contextlib import contextmanager

__all__ = ["quiet_interrupt", "interrupt_once"]

#: The exit status of a process stopped by SIGINT, as shells report it (128 + 2).
INTERRUPTED_STATUS = 130


def quiet_interrupt(initializer):
    """``initializer`` for a worker process, exiting silently (status 130) when interrupted (see the module)."""

    @functools.wraps(initializer)
    def wrapper(*args, **kwargs):
        try:
            return initializer(*args, **kwargs)
        except KeyboardInterrupt:
            os._exit(INTERRUPTED_STATUS)

    return wrapper


def _is_default(signum) -> bool:
    """Whether ``signum`` still has Python's default handling (not ignored, not handled by the application)."""
    handler = signal.getsignal(signum)
    return handler is signal.default_int_handler or handler == signal.SIG_DFL


@contextmanager
def interrupt_once(*signums, keep_ignoring: bool = False):
    """Within the block, the first of ``signums`` raises ``KeyboardInterrupt``; later ones are ignored (see the module).

    Only signals with their default handling are taken over (an ignored SIGINT, as in a background job, stays
    ignored; an application's own handler is left alone); main thread only. The previous handlers come back at the
    end of the block, unless a signal came and ``keep_ignoring`` is true: then they stay ignored (a process that ends
    with the block, which a late Ctrl-C would kill half-way through its exit). Yields the list of signals received.
    """
    received: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield received
        return

    def handler(signum, frame):
        """Count the signal; raise at the first."""
        received.append(signum)
        if len(received) == 1:
            raise KeyboardInterrupt

    previous = {s: signal.signal(s, handler) for s in signums if _is_default(s)}
    try:
        yield received
    finally:
        for s, h in previous.items():
            signal.signal(s, signal.SIG_IGN if received and keep_ignoring else h)
