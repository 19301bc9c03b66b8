"""The C allocator of a batch worker process: keep freed array memory for the next file (glibc only).

A batch task allocates and frees the same few arrays of 1-10 MB for every file (a 10 km two-track profile at
5 cm is 2 x 200 000 float64 samples, and the IRI filter and report make several such temporaries). glibc
serves blocks above ``M_MMAP_THRESHOLD`` with a fresh ``mmap`` and gives them back on ``free``; it normally
raises that threshold by itself after the first such free, but not when ``M_TRIM_THRESHOLD`` has been set
explicitly -- which Dask's nanny does for every worker it starts (``MALLOC_TRIM_THRESHOLD_=65536`` in
``distributed.nanny.pre-spawn-environ``, to return unmanaged memory to the OS). Each file then page-faults
all its arrays in again: measured on 40 files of 10 km (``docs/batch.md``, run 8), 0.18 s of CPU per file in a
Dask worker against 0.11 s with the thresholds below.

:func:`tune_allocator` sets ``M_MMAP_THRESHOLD`` to 32 MiB (glibc's own upper bound for its dynamic threshold)
and ``M_TRIM_THRESHOLD`` to 128 MiB in the worker process, once; the cost is that a worker keeps up to about
that much freed memory for reuse instead of returning it to the OS. It is applied in the workers of
:func:`~longprofile.batch.process_executor` and in Dask workers running longprofile batch tasks, never in the
caller's own process in serial and thread runs (in-process Dask workers, ``processes=False``, do run
it in the caller's process). Set ``LONGPROFILE_MALLOC_TUNING=0`` to leave the allocator alone.
"""

from __future__ import annotations

import os
import threading

__all__ = ["tune_allocator", "MMAP_THRESHOLD", "TRIM_THRESHOLD", "TUNING_ENV"]

#: Blocks up to this size come from the heap, not from a fresh mmap, bytes (glibc's DEFAULT_MMAP_THRESHOLD_MAX).
MMAP_THRESHOLD = 32 * 1024 * 1024
#: Free memory kept at the top of the heap before it is returned to the OS, bytes.
TRIM_THRESHOLD = 128 * 1024 * 1024
#: Environment variable: "0", "off", "false" or "no" disables the tuning.
TUNING_ENV = "LONGPROFILE_MALLOC_TUNING"

_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # <malloc.h>
_LOCK = threading.Lock()
_STATE: dict = {}


def _glibc():
    """The C library as a ctypes handle when it is glibc, else None."""
    try:
        if not os.confstr("CS_GNU_LIBC_VERSION"):
            return None
    except (AttributeError, ValueError, OSError):  # not glibc (musl, macOS, Windows)
        return None
    import ctypes

    try:
        return ctypes.CDLL("libc.so.6")
    except OSError:  # pragma: no cover - glibc under another name
        return None


def tune_allocator() -> str:
    """Set glibc's mmap and trim thresholds for a batch worker, once per process.

    Returns
    -------
    str
        ``"tuned"``, ``"disabled"`` (by ``LONGPROFILE_MALLOC_TUNING``), ``"unsupported"`` (not glibc) or
        ``"failed"`` (mallopt refused); the same string on every later call in the process.
    """
    with _LOCK:
        if "status" not in _STATE:
            _STATE["status"] = _apply()
        return _STATE["status"]


def _apply() -> str:
    if os.environ.get(TUNING_ENV, "").strip().lower() in ("0", "off", "false", "no"):
        return "disabled"
    libc = _glibc()
    if libc is None:
        return "unsupported"
    ok = libc.mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1
    ok = libc.mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD) == 1 and ok
    return "tuned" if ok else "failed"


def allocator_status(_arg=None) -> str | None:
    """What :func:`tune_allocator` did in this process (None: not called); for diagnostics and tests."""
    return _STATE.get("status")
