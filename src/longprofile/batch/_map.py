"""Map a function over files on any executor: in-process, ``concurrent.futures`` pools or a Dask client.

Nothing here imports numpy: a spawned worker process unpickles this module (and the task) before its
initializer pins the BLAS thread count, which must happen before numpy is first imported.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing.context import SpawnContext, SpawnProcess
from typing import Any, Callable, Iterable, Iterator

from .._interrupt import quiet_interrupt
from .._memory import tune_process_memory
from ..errors import DependencyError, InputError, LongprofileError

__all__ = ["BLAS_ENV", "FileResult", "iter_files", "map_files", "process_executor", "dask_client", "open_executor",
           "SCHEDULERS", "error_message"]

#: Environment variables that set the BLAS / OpenMP thread count; workers set each of them to 1.
BLAS_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
#: Names accepted by :func:`open_executor` besides a Dask scheduler address (``tcp://HOST:PORT``).
SCHEDULERS = ("processes", "threads", "serial")
_DASK_PREFIXES = ("tcp://", "tls://", "ucx://", "inproc://")
_MAX_MESSAGE = 2000
#: How often a pool worker checks that its driver process is still there, s.
_DRIVER_POLL_SECONDS = 0.5
#: How long an interrupted pool's workers get to end after SIGTERM before they are killed, s.
_STOP_SECONDS = 5.0


@dataclass(frozen=True, eq=False)
class FileResult:
    """The outcome of one file of a batch.

    Attributes
    ----------
    index : int
        Position of the file in the input list.
    path : str
        The path as given.
    value : object
        What the function returned (None when it failed).
    error : str or None
        None on success; otherwise the message of a :class:`~longprofile.errors.LongprofileError`, or
        ``"<ExceptionType>: <message>"`` for any other exception (one line).
    seconds : float
        Wall time of the call in the worker, s (excluding the once-per-worker warm-up); NaN when the worker
        itself was lost.
    """

    index: int
    path: str
    value: Any = None
    error: str | None = None
    seconds: float = float("nan")

    @property
    def ok(self) -> bool:
        return self.error is None


def error_message(exc: BaseException) -> str:
    """One line for a failed file: a library error's own message, else ``"TypeName: message"``."""
    text = str(exc) if isinstance(exc, LongprofileError) else f"{type(exc).__name__}: {exc}".rstrip(": ")
    text = " ".join(text.split())
    return text if len(text) <= _MAX_MESSAGE else text[:_MAX_MESSAGE - 3] + "..."


# ---- once-per-worker warm-up ---------------------------------------------------------------------------------

_WARM_LOCK = threading.Lock()
_WARMED: set = set()
_NUMPY_BEFORE_INIT: bool | None = None  # set by the process-pool initializer (diagnostics, tests)


def _warm(func) -> None:
    """Call ``func.warm()`` once per process (numba kernels compiled or loaded from their disk cache).

    A failing warm-up is not an error here: the same problem is reported by the call on each file.
    """
    hook = getattr(func, "warm", None)
    if hook is None:
        return
    try:
        key = hash(func)
    except TypeError:
        key = id(func)
    with _WARM_LOCK:
        if key in _WARMED:
            return
        _WARMED.add(key)
        try:
            hook()
        except Exception:
            pass


@quiet_interrupt
def _init_process_worker(func=None, driver: int | None = None) -> None:
    """Process-pool initializer: SIGINT ignored and the worker tied to its driver (:func:`_follow_driver`), BLAS
    threads pinned to 1 (already so since exec, see _PinnedSpawnProcess), the allocator tuned for repeated large
    arrays (:mod:`longprofile._memory`), then the task warmed once."""
    global _NUMPY_BEFORE_INIT
    _follow_driver(driver)
    _NUMPY_BEFORE_INIT = "numpy" in sys.modules
    for name in BLAS_ENV:
        os.environ[name] = "1"
    tune_process_memory()
    if func is not None:
        _warm(func)


def _follow_driver(driver: int | None) -> None:
    """A pool worker answers to its driver only: SIGINT ignored (a terminal's Ctrl-C reaches the whole process group;
    each worker printed a traceback, session 35), and the worker ends when the driver is gone (kill -9 of the driver
    left its workers running), by :func:`_watch_driver` in a daemon thread."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):  # blocked from exec (_PinnedSpawnProcess); ignored from now on
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    if driver is None:
        return
    if os.getppid() != driver:  # the driver died while this worker started
        os._exit(1)
    threading.Thread(target=_watch_driver, args=(driver,), name="longprofile-watch-driver", daemon=True).start()


def _watch_driver(driver: int, period: float = _DRIVER_POLL_SECONDS) -> None:
    """End this process at once when its parent is no longer ``driver`` (the driver died: the worker was re-parented).

    Polling ``getppid`` rather than ``prctl(PR_SET_PDEATHSIG)``: the death signal follows the *thread* that started
    the worker (the one that called ``submit``, CPython 3.11), which may end long before the driver does.
    """
    while True:
        time.sleep(period)
        if os.getppid() != driver:
            os._exit(1)


def _worker_info(_path=None) -> dict:
    """Worker diagnostics: pid, the BLAS environment the process was started with, whether numpy was already
    imported when the initializer ran (True is harmless: the environment was set at exec) and the allocator
    tuning status."""
    from .._memory import memory_status

    return {"pid": os.getpid(), "numpy_before_init": _NUMPY_BEFORE_INIT, "allocator": memory_status(),
            **{name: _ENV_AT_START.get(name) for name in BLAS_ENV}}


#: The BLAS environment this interpreter started with (before anything here changed it).
_ENV_AT_START = {name: os.environ.get(name) for name in BLAS_ENV}
_ENV_LOCK = threading.Lock()


class _PinnedSpawnProcess(SpawnProcess):
    """A ``spawn`` process exec'd with the BLAS variables set to 1 and SIGINT blocked.

    Setting the variables in the initializer is too late when the parent's ``__main__`` (re-run by ``spawn``)
    imports numpy; so they are exported, under a lock, only for the instant of the exec, then restored here. SIGINT
    is blocked in this thread for that instant too: the child inherits the mask, so a Ctrl-C while it starts up
    (before its initializer ignores SIGINT) is never delivered to it; here it waits until the mask is restored.
    """

    def start(self):
        with _ENV_LOCK:
            saved = {name: os.environ.get(name) for name in BLAS_ENV}
            os.environ.update({name: "1" for name in BLAS_ENV})
            mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT}) if hasattr(signal, "pthread_sigmask") \
                else None
            try:
                super().start()
            finally:
                if mask is not None:
                    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
                for name, value in saved.items():
                    if value is None:
                        os.environ.pop(name, None)
                    else:
                        os.environ[name] = value


class _PinnedSpawnContext(SpawnContext):
    Process = _PinnedSpawnProcess


@dataclass(frozen=True)
class _Guarded:
    """Runs ``func(path)`` in the worker and turns any exception into a recorded message."""

    func: Callable

    def __call__(self, path):
        _warm(self.func)
        t0 = time.perf_counter()
        try:
            value = self.func(path)
        except Exception as exc:
            return None, error_message(exc), time.perf_counter() - t0
        return value, None, time.perf_counter() - t0


# ---- mapping ---------------------------------------------------------------------------------------------------

def _is_dask_client(executor) -> bool:
    return callable(getattr(executor, "gather", None)) and callable(getattr(executor, "scheduler_info", None))


def iter_files(func: Callable, paths: Iterable, executor=None) -> Iterator[FileResult]:
    """Apply ``func`` to each path and yield a :class:`FileResult` per file, in completion order.

    Parameters
    ----------
    func : callable
        ``func(path) -> value``; must be picklable for process pools and Dask (a module-level function or a
        frozen dataclass task such as :class:`longprofile.batch.IRITask`). If it has a ``warm()`` method,
        that is called once per worker process before its first file.
    paths : iterable of path-like
    executor : concurrent.futures.Executor, dask.distributed.Client or None
        Where to run: None = serially in this process; a ``ProcessPoolExecutor`` (see
        :func:`process_executor` for BLAS pinning), a ``ThreadPoolExecutor``, or a Dask client (duck-typed:
        anything with ``submit``, ``gather`` and ``scheduler_info``).

    Yields
    ------
    FileResult
        One per path. A file that raises gives a result with ``error`` set; the batch goes on. A worker that
        dies (a crashed process pool, a Dask ``KilledWorker``) gives the error of the lost futures.

    Notes
    -----
    Stopping the iteration early (an exception or ``KeyboardInterrupt`` in the consumer) cancels the files
    not yet started.
    """
    paths = [os.fspath(p) for p in paths]
    job = _Guarded(func)
    if executor is None:
        for i, p in enumerate(paths):
            yield _result(i, p, job(p))
        return
    if _is_dask_client(executor):
        yield from _iter_dask(executor, job, paths)
        return
    if not callable(getattr(executor, "submit", None)):
        raise InputError(f"executor must be a concurrent.futures.Executor, a dask.distributed.Client or None; "
                         f"got {type(executor).__name__}.")
    from concurrent.futures import as_completed

    pending = {}
    try:
        for i, p in enumerate(paths):
            pending[executor.submit(job, p)] = i
        for fut in as_completed(list(pending)):
            i = pending.pop(fut)
            yield _result(i, paths[i], _outcome(fut))
    finally:
        for fut in pending:
            fut.cancel()


#: Files per Dask task: enough tasks per worker for balance, few enough that the scheduler's per-task cost
#: (a few ms a round trip, against ~0.6 ms for a process pool) stays small beside the work.
DASK_TASKS_PER_WORKER = 8
DASK_MAX_FILES_PER_TASK = 8


@dataclass(frozen=True)
class _GuardedChunk:
    """Runs a guarded job on several files in one Dask task; one outcome per file (a failing file does not
    stop the others). The worker's allocator is tuned once first (:mod:`longprofile._memory`: Dask's nanny sets
    ``MALLOC_TRIM_THRESHOLD_``, which made every file page-fault its arrays in again; in-process workers tune
    the caller's process)."""

    job: _Guarded

    def __call__(self, paths):
        tune_process_memory()
        return [self.job(p) for p in paths]


def dask_files_per_task(n_files: int, n_workers: int) -> int:
    """Files grouped into one Dask task: ``ceil(n_files / (DASK_TASKS_PER_WORKER * n_workers))``, between 1 and
    ``DASK_MAX_FILES_PER_TASK``."""
    per = -(-n_files // max(1, DASK_TASKS_PER_WORKER * max(1, n_workers)))
    return max(1, min(DASK_MAX_FILES_PER_TASK, per))


def _iter_dask(client, job, paths) -> Iterator[FileResult]:
    from distributed import as_completed

    try:
        n_workers = len(client.scheduler_info().get("workers", {})) or 1
    except Exception:  # an unusual client: one file per task
        n_workers = len(paths)
    size = dask_files_per_task(len(paths), n_workers)
    chunks = [list(range(i, min(i + size, len(paths)))) for i in range(0, len(paths), size)]
    runner = _GuardedChunk(job)
    futures = [client.submit(runner, [paths[i] for i in c], pure=False) for c in chunks]
    index = {f.key: j for j, f in enumerate(futures)}
    try:
        for fut in as_completed(futures):
            j = index[fut.key]
            try:
                outcomes = fut.result()
            except Exception as exc:  # the worker itself failed (killed): every file of the task is lost
                outcomes = [(None, error_message(exc), float("nan"))] * len(chunks[j])
            futures[j] = None  # drop the reference: the values live in the results only
            fut.release()
            for i, out in zip(chunks[j], outcomes):
                yield _result(i, paths[i], out)
    finally:
        left = [f for f in futures if f is not None]
        if left:
            client.cancel(left)


def _outcome(fut):
    try:
        return fut.result()
    except Exception as exc:  # the worker itself failed (pool broken, worker killed): not the task
        return None, error_message(exc), float("nan")


def _result(index, path, outcome) -> FileResult:
    value, error, seconds = outcome
    return FileResult(index=index, path=path, value=value, error=error, seconds=seconds)


def map_files(func: Callable, paths: Iterable, executor=None) -> list[FileResult]:
    """Apply ``func`` to each path on ``executor``; the results come back in input order.

    Parameters and semantics as :func:`iter_files` (which yields them as they complete). A failing file gives
    a :class:`FileResult` with its ``error``, never an exception that stops the batch.

    Examples
    --------
    >>> from concurrent.futures import ThreadPoolExecutor
    >>> with ThreadPoolExecutor(2) as pool:                                  # doctest: +SKIP
    ...     results = map_files(IRITask(interval=100.0), paths, executor=pool)
    >>> [r.error for r in results if not r.ok]                                 # doctest: +SKIP
    """
    paths = list(paths)
    out: list[FileResult | None] = [None] * len(paths)
    for r in iter_files(func, paths, executor):
        out[r.index] = r
    return out  # type: ignore[return-value]


# ---- executors ---------------------------------------------------------------------------------------------

def default_workers() -> int:
    """CPUs this process may use (its affinity set where the platform has one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - macOS, Windows
        return max(1, os.cpu_count() or 1)


def process_executor(max_workers: int | None = None, *, warm=None):
    """A ``ProcessPoolExecutor`` whose workers run with one BLAS thread and a warmed numba cache.

    Workers are started with the ``spawn`` method (a fresh interpreter: no inherited locks or threads) with
    ``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS`` and ``MKL_NUM_THREADS`` set to 1 in their environment from
    the start (so before numpy is imported, even by a re-imported ``__main__``; this process's own environment
    is left as it was). Their initializer then calls ``warm.warm()`` once (e.g. a task run on a tiny synthetic
    profile, which compiles or loads the numba kernels) so the first file is not charged for it.

    The workers ignore SIGINT (Ctrl-C is this process's to answer) and end by themselves within a second when this
    process dies, even by ``kill -9``. A ``with`` block on the pool left by an exception (``KeyboardInterrupt``
    included) terminates the workers still computing instead of waiting for their files.

    As with any ``spawn`` pool, a script that creates one must guard its work with
    ``if __name__ == "__main__":``.

    Parameters
    ----------
    max_workers : int, optional
        Default: the CPUs available to this process.
    warm : object with a ``warm()`` method, optional
        Usually the task the pool will run.
    """
    workers = default_workers() if max_workers is None else _positive_workers(max_workers)
    return _StoppingPool(max_workers=workers, mp_context=_PinnedSpawnContext(), initializer=_init_process_worker,
                         initargs=(warm, os.getpid()))


class _StoppingPool(ProcessPoolExecutor):
    """A process pool whose ``with`` block, left by an exception, stops the workers at once (:func:`_stop_pool`)."""

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            return super().__exit__(exc_type, exc, tb)
        _stop_pool(self)
        return False


def _positive_workers(n) -> int:
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise InputError(f"workers must be an integer >= 1; got {n!r}.")
    return n


def dask_client(address: str, *, timeout: float = 10.0):
    """Connect a ``dask.distributed.Client`` to a running scheduler (``tcp://HOST:PORT``).

    Raises
    ------
    DependencyError
        Dask is not installed (``pip install longprofile[dask]``).
    InputError
        No scheduler answers at ``address`` within ``timeout`` seconds.
    """
    try:
        from distributed import Client
    except ImportError:
        raise DependencyError(f"scheduler {address} is a Dask scheduler and Dask is not installed; "
                              "install it with: pip install longprofile[dask] (or use --scheduler processes).") from None
    try:
        return Client(address, timeout=f"{timeout:g}s")
    except (OSError, TimeoutError) as exc:
        raise InputError(f"cannot connect to the Dask scheduler at {address} ({error_message(exc)}); start one with "
                         "`dask scheduler` and workers with `dask worker ADDRESS`, or use --scheduler processes.") from None


def check_scheduler(scheduler) -> None:
    """Refuse an unknown scheduler name before any work (a Dask address is checked when connecting)."""
    if scheduler is None or not isinstance(scheduler, str):
        return
    if scheduler not in SCHEDULERS and not scheduler.startswith(_DASK_PREFIXES):
        raise InputError(f"unknown scheduler {scheduler!r}; use one of {', '.join(SCHEDULERS)} or a Dask scheduler "
                         "address tcp://HOST:PORT.")


@contextmanager
def open_executor(scheduler: str = "processes", workers: int | None = None, *, warm=None):
    """Open the executor named by ``scheduler`` for the duration of a ``with`` block.

    Parameters
    ----------
    scheduler : str
        ``"processes"`` (a local :func:`process_executor`, the default), ``"threads"`` (a
        ``ThreadPoolExecutor``: the BLAS threads are those of this process), ``"serial"`` (None: in this
        process), or a Dask scheduler address ``tcp://HOST:PORT`` (:func:`dask_client`; ``workers`` is then
        the cluster's business).
    workers : int, optional
        Pool size (default: the CPUs available to this process).
    warm : object with a ``warm()`` method, optional
        Warmed once per process-pool worker at start.

    Yields
    ------
    concurrent.futures.Executor, dask.distributed.Client or None

    Notes
    -----
    Left normally, the pool is shut down once its calls are done; left by an exception (``KeyboardInterrupt``
    included), a process pool's workers still computing are terminated at once (:func:`_stop_pool`).
    """
    check_scheduler(scheduler)
    if workers is not None:
        _positive_workers(workers)
    if scheduler == "serial":
        yield None
        return
    if scheduler == "threads":
        from concurrent.futures import ThreadPoolExecutor

        ex = ThreadPoolExecutor(max_workers=workers or default_workers())
    elif scheduler == "processes":
        ex = process_executor(workers, warm=warm)
    else:
        client = dask_client(scheduler)
        try:
            yield client
        finally:
            client.close()
        return
    try:
        yield ex
    except BaseException:  # an error or Ctrl-C: the files in progress are abandoned, not waited for
        _stop_pool(ex)
        raise
    ex.shutdown(wait=True, cancel_futures=True)


def _stop_pool(ex, timeout: float = _STOP_SECONDS) -> None:
    """Shut ``ex`` down without waiting for the calls in progress: a process pool's workers are terminated (killed if
    still there after ``timeout`` s); a thread pool's running calls cannot be stopped and are waited for."""
    from multiprocessing.connection import wait

    if not isinstance(ex, ProcessPoolExecutor):
        ex.shutdown(wait=True, cancel_futures=True)
        return
    # ProcessPoolExecutor._processes and ._executor_manager_thread are private (CPython 3.8-3.14; 3.14's public
    # terminate_workers() does the same but waits for nothing): read before shutdown() drops them; missing, the
    # workers finish their files as before. The manager thread ends once the workers have; joined so that the
    # command's fast exit is not given up for it (cli/app.py, run).
    procs = list((getattr(ex, "_processes", None) or {}).values())
    manager = getattr(ex, "_executor_manager_thread", None)
    ex.shutdown(wait=False, cancel_futures=True)
    left = _signal_processes(procs)
    deadline = time.monotonic() + timeout
    while left and deadline > time.monotonic():  # a sentinel is ready once its process has ended
        for ended in wait(list(left), max(0.0, deadline - time.monotonic())):
            left.pop(ended)
    if left:
        _signal_processes(left.values(), kill=True)
    if manager is not None and manager.is_alive():
        manager.join(max(1.0, deadline - time.monotonic()))


def _signal_processes(procs, *, kill: bool = False) -> dict:
    """Terminate (or kill) each process still there; returns {sentinel: process} of those signalled.

    Their sentinels rather than ``join``: the pool's own manager thread reaps its workers too, and the thread that
    loses that race sees no exit status."""
    sent = {}
    for p in procs:
        try:
            if p.exitcode is None:
                (p.kill if kill else p.terminate)()
                sent[p.sentinel] = p
        except (OSError, ValueError):  # gone (ProcessLookupError), or the Process object already closed
            pass
    return sent
