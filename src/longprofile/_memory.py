"""Memory settings of a longprofile process: reuse freed array memory, no transparent huge pages for arrays.

A longprofile computation allocates, fills and frees a few large arrays (a 100 km record at 5 cm is 2e6 float64
samples, 16 MB per column; a batch worker makes the same arrays of 1-10 MB for every file). Two defaults of the
platform make the first touch of that memory slow:

- **numpy's huge-page advice.** numpy calls ``madvise(MADV_HUGEPAGE)`` on every array of 4 MiB or more (Linux,
  kernel >= 4.6). Under a hypervisor that backs guest memory lazily (measured here: a Firecracker VM, kernel
  6.18), faulting such memory in costs ~7 ms per MB against ~0.7 ms per MB with normal pages (80 MB first
  written: 0.53 s against 0.057 s). :func:`tune_process_memory` turns the advice off
  (``numpy._core.multiarray._set_madvise_hugepage(False)``, the switch behind numpy's documented
  ``NUMPY_MADVISE_HUGEPAGE`` variable, which only works before numpy is imported).
- **glibc's mmap threshold.** Blocks above ``M_MMAP_THRESHOLD`` are served by a fresh ``mmap`` and returned on
  ``free``; glibc normally raises that threshold by itself after the first such free, but not when
  ``M_TRIM_THRESHOLD`` has been set explicitly -- which Dask's nanny does for every worker it starts
  (``MALLOC_TRIM_THRESHOLD_=65536`` in ``distributed.nanny.pre-spawn-environ``). Each file then page-faults all
  its arrays in again: measured on 40 files of 10 km (``docs/batch.md``, run 8), 0.18 s of CPU per file in a
  Dask worker against 0.11 s with the thresholds below. :func:`tune_process_memory` sets ``M_MMAP_THRESHOLD``
  to 32 MiB (glibc's own upper bound for its dynamic threshold) and ``M_TRIM_THRESHOLD`` to 128 MiB; the cost
  is that the process keeps up to about that much freed memory for reuse instead of returning it to the OS.

It is applied once per process by the processes longprofile owns: the ``longprofile`` command (its ``main``),
the workers of :func:`~longprofile.batch.process_executor` and Dask workers running longprofile batch tasks --
never by importing the library, and never in the caller's own process in serial and thread batch runs
(in-process Dask workers, ``processes=False``, do run it in the caller's process). Set
``LONGPROFILE_MALLOC_TUNING=0`` to leave both alone.
"""

from __future__ import annotations

import os
import threading

__all__ = ["tune_process_memory", "memory_status", "MMAP_THRESHOLD", "TRIM_THRESHOLD", "TUNING_ENV"]

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


def tune_process_memory() -> str:
    """Set glibc's mmap and trim thresholds and turn numpy's huge-page advice off, once per process.

    Returns
    -------
    str
        The allocator's status: ``"tuned"``, ``"disabled"`` (by ``LONGPROFILE_MALLOC_TUNING``; numpy left alone
        too), ``"unsupported"`` (not glibc; numpy's advice is still turned off) or ``"failed"`` (mallopt
        refused); the same string on every later call in the process.
    """
    with _LOCK:
        if "status" not in _STATE:
            _STATE["status"] = _apply()
        return _STATE["status"]


def _numpy_hugepages_off() -> None:
    import numpy as np

    switch = getattr(getattr(getattr(np, "_core", None), "multiarray", None), "_set_madvise_hugepage", None)
    if switch is not None:
        switch(False)


def _apply() -> str:
    if os.environ.get(TUNING_ENV, "").strip().lower() in ("0", "off", "false", "no"):
        return "disabled"
    _numpy_hugepages_off()
    libc = _glibc()
    if libc is None:
        return "unsupported"
    ok = libc.mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1
    ok = libc.mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD) == 1 and ok
    return "tuned" if ok else "failed"


def memory_status(_arg=None) -> str | None:
    """What :func:`tune_process_memory` did in this process (None: not called); for diagnostics and tests."""
    return _STATE.get("status")
