"""Ctrl-C in worker processes: the command that started them reports the interruption, not each worker.

A terminal's Ctrl-C sends SIGINT to the whole foreground process group: the command *and* its helper processes (the
figure helpers of ``report/_render.py``, the process pool of ``batch``). The command turns its own
``KeyboardInterrupt`` into exit code 130 without a traceback (``cli/app.py``) and stops its pools on the way out; a
worker interrupted while a pool's initializer ran would print ``Exception in initializer:`` and a traceback
(``concurrent.futures`` logs it), one per worker. :func:`quiet_interrupt` wraps such an initializer: interrupted, the
worker exits at once with status 130 and prints nothing. An initializer only imports and warms up (nothing is being
written), so nothing is left half-done; a worker interrupted inside a task returns the interruption to the pool as
the task's outcome, which ``concurrent.futures`` does without printing.
"""

from __future__ import annotations

import functools
import os

__all__ = ["quiet_interrupt"]

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
