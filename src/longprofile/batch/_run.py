"""Run a task over a survey network into a results folder: a partitioned Parquet dataset plus a manifest.

Layout of a results folder::

    manifest.parquet                    one row per input (MANIFEST_COLUMNS); task and options in its metadata
    segments/route=<id>/part-0.parquet  the segment table of each input (Hive partitioning, id URL-encoded)
    profiles/route=<id>/part-0.parquet  per-sample tables (``reconstruct``: the reconstructed profile)

Crash safety: a partition is written to a hidden temporary name and renamed over ``part-0.parquet`` (atomic),
and a manifest row says ``ok`` only once its partition exists; the manifest itself is replaced atomically. An
interrupted run therefore leaves, at worst, partitions whose files ``--resume`` recomputes.
"""

from __future__ import annotations

import errno
import glob
import hashlib
import json
import os
import shutil
import signal
import time
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable, Iterable
from urllib.parse import quote

from .._interrupt import interrupt_once
from ..errors import InputError, InputFormatError, OutputError
from ._map import _WARM_LOCK, _WARMED, check_scheduler, error_message, iter_files, open_executor
from ._options import option_changes
from ._tasks import options_hash

__all__ = ["EXIT_SOME_FAILED", "MANIFEST", "MANIFEST_COLUMNS", "SEGMENTS", "PROFILES", "BatchSummary",
           "expand_paths", "run_batch", "read_manifest", "file_digest"]

#: Exit code of ``longprofile batch iri|reconstruct`` when the batch completed but some files failed
#: (2 stays "nothing was done": bad options, refused output folder).
EXIT_SOME_FAILED = 3
MANIFEST = "manifest.parquet"
SEGMENTS = "segments"
PROFILES = "profiles"
_PART = "part-0.parquet"
_META_KEY = b"longprofile.batch"
_FLUSH_SECONDS = 2.0

#: Manifest columns: name -> (pyarrow type name, meaning).
MANIFEST_COLUMNS = {
    "path": ("string", "input file, absolute path"),
    "route": ("string", "route id = partition key of the dataset (path relative to the inputs' common folder, "
                        "without suffix)"),
    "status": ("string", "ok (computed in this run), skipped (unchanged since an ok run: results kept), error"),
    "error": ("string", "why the file failed (one line), empty otherwise"),
    "warning": ("string", "a result to look at (implausible IRI, no complete segment), empty otherwise"),
    "sha256": ("string", "sha256 of the input's bytes when it was processed"),
    "size_bytes": ("int64", "input size"),
    "seconds": ("float64", "wall time of the task on this file in its worker, s"),
    "rows": ("int64", "segments written"),
    "task": ("string", "iri or reconstruct"),
    "options_hash": ("string", "hash of the task and its options (what --resume compares)"),
    "longprofile_version": ("string", "version that computed the row"),
    "finished_utc": ("string", "when the file was processed (ISO 8601, UTC)"),
    "metadata": ("string", "JSON facts from the task (IRI report metadata, fitted q and r...)"),
    "run": ("int64", "the run that last listed the file among its inputs (1 for a folder's first run, then one more "
                     "per `batch` command on the folder; the last run's number is ``run`` in the metadata)"),
}


@dataclass(frozen=True, eq=False)
class BatchSummary:
    """What a :func:`run_batch` call did.

    Attributes
    ----------
    output : Path
        The results folder.
    task : str
    n_inputs, n_ok, n_error, n_skipped : int
        Inputs, computed now, failed, kept from an earlier run (``--resume``).
    seconds : float
        Wall time of the call, s.
    failed : tuple of (path, error)
    warnings : tuple of (path, warning)
    """

    output: Path
    task: str
    n_inputs: int
    n_ok: int
    n_error: int
    n_skipped: int
    seconds: float
    failed: tuple[tuple[str, str], ...]
    warnings: tuple[tuple[str, str], ...]

    @property
    def ok(self) -> bool:
        """True when no file failed."""
        return self.n_error == 0

    def line(self) -> str:
        """One-line summary (the last line the CLI prints)."""
        text = (f"batch {self.task}: {self.n_ok} ok, {self.n_error} failed, {self.n_skipped} skipped of "
                f"{self.n_inputs} file(s) in {self.seconds:.1f} s -> {self.output}")
        if self.warnings:
            text += f"; {len(self.warnings)} with a warning"
        if self.failed:
            path, err = self.failed[0]
            err = err if len(err) <= 160 else err[:157] + "..."
            text += f"; first failure {Path(path).name}: {err} (all in {self.output / MANIFEST})"
        return text


# ---- inputs ---------------------------------------------------------------------------------------------------

def expand_paths(patterns: Iterable[str]) -> list[Path]:
    """Files matched by glob patterns (``**`` = any depth), sorted per pattern, duplicates dropped.

    An argument that names an existing file is that file, even when its name holds ``[``, ``*`` or ``?``
    (``Route [7]/lane*1.csv``); any other with a wildcard is a pattern, and one without is a file name that must
    exist (assumption: a pattern that is also the name of an existing file means that file). Raises
    :class:`InputError` for a pattern matching no file or naming a folder. A symbolic link that cannot be followed
    (dangling, or a loop) is kept: the batch gives it a failed manifest row saying why (:func:`_link_problem`), where
    it used to vanish from the run.
    """
    if isinstance(patterns, (str, os.PathLike)):
        patterns = [patterns]
    out, seen = [], set()
    for pattern in patterns:
        pattern = os.fspath(pattern)
        if os.path.isfile(pattern) or (glob.has_magic(pattern) and os.path.islink(pattern)):
            found = [pattern]  # a file named with wildcard characters is itself, never a pattern
        elif glob.has_magic(pattern):
            found = sorted(p for p in glob.glob(pattern, recursive=True) if os.path.isfile(p) or _link_problem(p))
            found = [p for p in found if not _in_results_folder(p)]  # an earlier batch's output in the tree
            if not found:
                raise InputError(f"{pattern!r} matches no file; check the folder, and quote the pattern so that "
                                 "longprofile expands it ('surveys/**/*.erd').")
        elif os.path.isdir(pattern):
            raise InputError(f"{pattern} is a folder; give a pattern such as '{Path(pattern) / '**' / '*.erd'}'.")
        elif not os.path.isfile(pattern) and not _link_problem(pattern):
            raise InputError(f"{pattern}: no such file.")
        else:
            found = [pattern]
        for p in found:
            key = _input_path(p)
            if key not in seen:
                seen.add(key)
                out.append(Path(p))
    return out


def _in_results_folder(path: str) -> bool:
    """Whether a file lies in a batch results folder (one of its folders holds a manifest): a pattern over a survey
    tree that also holds an earlier run's output matched its partitions and manifest as surveys (session 35)."""
    for parent in _input_path(path).parents:
        if (parent / MANIFEST).is_file():
            return True
    return False


def _input_path(path) -> Path:
    """Absolute path of an input with its symbolic links followed; a link that cannot be followed (dangling, a loop)
    stays itself, in its resolved folder."""
    p = Path(path)
    try:
        return p.resolve(strict=True)
    except (OSError, RuntimeError):  # missing, dangling, or a loop (RuntimeError up to Python 3.12)
        return p.parent.resolve() / p.name


def _link_problem(path) -> str:
    """Why ``path``, a symbolic link, cannot be followed (one line); "" when it can or is no link.

    Followed link by link (``realpath``), not by the kernel: a folder's link to its parent, met by ``**`` 40 levels
    deep, exceeds the kernel's 40 links per path without being a loop."""
    if not os.path.islink(path):
        return ""
    try:
        os.path.realpath(path, strict=True)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return (f"{path}: symbolic link loop (it points to {os.readlink(path)}, and the chain of links never "
                    "reaches a file); fix or remove the link.")
        if exc.errno == errno.ENOENT:
            return (f"{path}: dangling symbolic link: {os.path.realpath(path)} does not exist; restore the target or "
                    "remove the link.")
        return f"{path}: the symbolic link to {os.readlink(path)} cannot be followed ({exc.strerror})."
    return ""


def _route_ids(paths: list[Path]) -> list[str]:
    """Path relative to the inputs' common folder, without suffix (with it where two would clash)."""
    if not paths:
        return []
    base = Path(os.path.commonpath([str(p.parent) for p in paths]))
    rel = [p.relative_to(base) for p in paths]
    ids = [r.with_suffix("").as_posix() for r in rel]
    counts: dict[str, int] = {}
    for i in ids:
        counts[i] = counts.get(i, 0) + 1
    return [r.as_posix() if counts[i] > 1 else i for i, r in zip(ids, rel)]


def file_digest(path) -> tuple[str, int]:
    """sha256 (hex) and size in bytes of a file's content."""
    with open(path, "rb") as fh:
        digest = hashlib.file_digest(fh, "sha256").hexdigest()
        size = os.fstat(fh.fileno()).st_size
    return digest, size


@dataclass(frozen=True)
class _Job:
    """Worker side of one file: the task, then the hash of the bytes it read."""

    task: object

    def warm(self):
        self.task.warm()

    def __call__(self, path):
        problem = _link_problem(path)
        if problem:  # the task would say "FileNotFoundError" or "OSError: [Errno 40]" about the link's target
            raise InputError(problem)
        out = self.task(path)
        digest, size = file_digest(path)
        return digest, size, out


# ---- the manifest ---------------------------------------------------------------------------------------------

def _manifest_schema(meta: dict):
    import pyarrow as pa

    types = {"string": pa.string(), "int64": pa.int64(), "float64": pa.float64()}
    return pa.schema([(k, types[t]) for k, (t, _) in MANIFEST_COLUMNS.items()],
                     metadata={_META_KEY: json.dumps(meta, sort_keys=True).encode()})


def _write_atomic(table, path: Path) -> None:
    """Write a pyarrow table to Parquet at ``path`` through a hidden temporary file and an atomic rename.

    A failed write (a full disk, a read-only file system) leaves ``path`` as it was and no temporary file, and raises
    :class:`OutputError` (one line: the CLI's ``error:``, exit 2), where it gave a traceback (session 37).
    """
    import pyarrow.parquet as pq

    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            pq.write_table(table, fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass
        raise _write_error(path, exc) from None


def _write_error(path, exc: OSError) -> OutputError:
    """The one line of a write that failed: what, why (the system's words), and what to do."""
    why = exc.strerror or str(exc)
    hint = "free space on that disk" if exc.errno in (errno.ENOSPC, errno.EDQUOT) else "make it writable"
    return OutputError(f"cannot write {path}: {why}; {hint}, or choose another output folder (-o), then run the same "
                       "command with --resume.")


def read_manifest(folder) -> tuple:
    """The manifest of a results folder: ``(DataFrame, info)`` with info = task, options, options_hash, version,
    n_inputs, complete and ``run`` (the last run's number; absent before session 38).

    A manifest written before session 38 has no ``run`` column nor ``run`` in its metadata: ASSUMPTION (docs/batch.md)
    every row was seen by the last run (as it was counted before): the column is filled with 0, the next run is 1.

    Raises :class:`InputError` when the folder has no manifest, :class:`InputFormatError` when it is damaged.
    """
    import pyarrow.parquet as pq

    path = Path(folder) / MANIFEST
    if not path.is_file():
        raise InputError(f"{folder} is not a longprofile batch results folder (no {MANIFEST}); give the -o folder "
                         "of a `longprofile batch iri|reconstruct` run.")
    try:
        table = pq.read_table(path)
        info = json.loads((table.schema.metadata or {})[_META_KEY])
    except Exception as exc:
        raise InputFormatError(f"{path} cannot be read ({error_message(exc)}); the folder is damaged: rerun the "
                               "batch with --overwrite.") from None
    frame = table.to_pandas()
    if "run" not in frame.columns:  # written before session 38: every row taken as seen by the last run
        frame["run"] = int(info.get("run", 0))
    return frame, info


class _Manifest:
    """Rows by input path, rewritten atomically (at most every few seconds, and at the end)."""

    def __init__(self, folder: Path, info: dict, rows: dict[str, dict]):
        self.path = folder / MANIFEST
        self.info = info
        self.rows = rows
        self._last = float("-inf")

    def set(self, row: dict) -> None:
        self.rows[row["path"]] = row

    def flush(self, force: bool = False) -> None:
        now = time.monotonic()
        if not force and now - self._last < _FLUSH_SECONDS:
            return
        import pyarrow as pa

        schema = _manifest_schema(self.info)
        rows = sorted(self.rows.values(), key=lambda r: r["route"])  # deterministic, whatever the completion order
        cols = {k: [r.get(k) for r in rows] for k in MANIFEST_COLUMNS}
        _write_atomic(pa.table(cols, schema=schema), self.path)
        self._last = now


def _row(path, route, status, *, task, opts_hash, version, run, error="", warning="", digest="", size=0,
         seconds=float("nan"), rows=0, metadata=None) -> dict:
    return {"path": path, "route": route, "status": status, "error": error, "warning": warning, "sha256": digest,
            "size_bytes": int(size), "seconds": float(seconds), "rows": int(rows), "task": task,
            "options_hash": opts_hash, "longprofile_version": version,
            "finished_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "metadata": json.dumps(metadata or {}, sort_keys=True, default=_json_default), "run": int(run)}


def _json_default(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return str(v)


# ---- partitions -----------------------------------------------------------------------------------------------

def partition_file(folder, route: str, kind: str = SEGMENTS) -> Path:
    """Path of a route's partition file in a results folder (Hive layout, route URL-encoded)."""
    return Path(folder) / kind / f"route={quote(route, safe='')}" / _PART


def _write_partition(folder: Path, route: str, kind: str, frame, metadata: dict) -> None:
    """One route's table, with the task's metadata as JSON under the Parquet schema key ``b"longprofile"`` (the
    key :func:`longprofile.io.read_report_table` reads)."""
    import pyarrow as pa

    path = partition_file(folder, route, kind)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _write_error(path.parent, exc) from None
    table = pa.Table.from_pandas(frame, preserve_index=False)
    meta = dict(table.schema.metadata or {})
    meta[b"longprofile"] = json.dumps(metadata, sort_keys=True, default=_json_default).encode()
    _write_atomic(table.replace_schema_metadata(meta), path)


def _remove_partitions(folder: Path, route: str) -> None:
    for kind in (SEGMENTS, PROFILES):
        path = partition_file(folder, route, kind)
        try:
            path.unlink(missing_ok=True)
        except OSError as exc:
            raise _write_error(path, exc) from None


def _store(folder: Path, route: str, path: str, output) -> None:
    """Profile partition, then segment partition (the manifest row comes after both)."""
    if output.profile is not None:
        _write_partition(folder, route, PROFILES, output.profile, output.metadata)
    seg = output.segments.copy()
    seg.attrs = {}
    seg.insert(0, "file", path)
    _write_partition(folder, route, SEGMENTS, seg, output.metadata)


# ---- output folder checks -------------------------------------------------------------------------------------

def _check_output(out: Path, inputs: list[Path], resume: bool, overwrite: bool):
    """Refuse what would overwrite a user's files or mix runs; return the existing manifest (or None)."""
    if resume and overwrite:
        raise InputError("--resume and --overwrite exclude each other: resume continues the results in the folder, "
                         "overwrite replaces them; pass one.")
    if out.exists() and not out.is_dir():
        raise OutputError(f"output {out} is a file; the batch writes a folder, e.g. -o {out.with_suffix('')}_results/.")
    root = out.resolve()
    for p in inputs:  # resolved by run_batch (_input_path)
        if root in p.parents:
            raise OutputError(f"input {p} is inside the output folder {out}; choose an output folder outside the "
                              "inputs (inputs are never overwritten).")
    if not (out.is_dir() and any(out.iterdir())):
        return None
    if not (out / MANIFEST).is_file():
        raise OutputError(f"output folder {out} exists and is not a longprofile batch results folder (no {MANIFEST}); "
                          "choose a new or empty folder.")
    if not (resume or overwrite):
        raise OutputError(f"output folder {out} already holds batch results; pass --resume to continue them (files "
                          "already done are skipped) or --overwrite to replace them.")
    return None if overwrite else read_manifest(out)


def _clear(out: Path) -> None:
    """--overwrite: remove what a batch wrote (and only that)."""
    for kind in (SEGMENTS, PROFILES):
        if (out / kind).is_dir():
            shutil.rmtree(out / kind)
    (out / MANIFEST).unlink(missing_ok=True)


# ---- the run --------------------------------------------------------------------------------------------------

def _warm_checked(job: _Job) -> None:
    """Warm the task in this process, letting its errors through (options checked before any work)."""
    job.warm()
    with _WARM_LOCK:
        _WARMED.add(hash(job))


def run_batch(task, paths: Iterable, output, *, executor=None, workers: int | None = None, resume: bool = False,
              overwrite: bool = False, on_start: Callable[[int], None] | None = None,
              on_result: Callable[[dict], None] | None = None) -> BatchSummary:
    """Run ``task`` on every input and write the results folder (dataset + manifest).

    Parameters
    ----------
    task : IRITask, ReconstructTask or compatible
        A picklable callable ``task(path) -> TaskOutput`` with ``name``, ``options()`` and ``warm()``.
    paths : iterable of path-like
        Input files (see :func:`expand_paths` for glob patterns).
    output : path-like
        Results folder. A folder that already holds results needs ``resume`` or ``overwrite``; a non-empty
        folder that is not a results folder is refused.
    executor : str, concurrent.futures.Executor, dask.distributed.Client or None
        None = serial in this process; a scheduler name for :func:`open_executor` (``"processes"``,
        ``"threads"``, ``"serial"``, ``"tcp://HOST:PORT"``), opened and closed here; or an executor object
        (used as is, not closed).
    workers : int, optional
        Pool size when ``executor`` is a name.
    resume : bool
        Skip inputs whose manifest row is ok with the same content hash and options (and whose partition is
        there); recompute the others. The folder's task and options must be those of ``task``.
    overwrite : bool
        Remove the folder's previous results first (only the manifest and the dataset folders).
    on_start : callable, optional
        Called with the number of inputs once the checks passed and the executor is open (start a progress bar).
    on_result : callable, optional
        Called with each manifest row (a dict) as files finish or are skipped (progress bars).

    Returns
    -------
    BatchSummary

    Raises
    ------
    InputError, OutputError, DependencyError
        Before any work: no input, bad options, refused output folder, different task/options on resume, an
        unknown scheduler, no Dask scheduler at the address (or Dask not installed).
    KeyboardInterrupt
        Ctrl-C: raised once the manifest of the files done is written and a pool opened here is stopped (its workers
        terminated, not waited for); a further Ctrl-C meanwhile is ignored.
    """
    t0 = time.perf_counter()
    inputs = [_input_path(p) for p in paths]
    if not inputs:
        raise InputError("no input file; give at least one file or glob pattern.")
    if len({str(p) for p in inputs}) != len(inputs):
        raise InputError("the same input file is given twice; remove the duplicate.")
    if isinstance(executor, str):
        check_scheduler(executor)
    out = Path(output)
    # a second Ctrl-C must not cut short the cleanup of the first (manifest, pool): it hung the driver (session 35)
    with interrupt_once(signal.SIGINT), _output_lock(out):
        return _locked_run(task, inputs, out, executor, workers, resume, overwrite, on_start, on_result, t0)


@contextmanager
def _output_lock(out: Path):
    """Hold an exclusive lock on the output folder for the whole run (a hidden file beside it, removed at the end):
    two runs writing one results folder lost results (two --resume runs at once: 159 of 211 files missing from the
    manifest; session 35, a probe). POSIX advisory locks (fcntl); where there are none, no lock. The lock is keyed on
    the folder's real path (symbolic links followed): ``-o results`` and ``-o link_to_results`` are one folder and
    take one lock (each took its own; session 37)."""
    try:
        import fcntl
    except ImportError:  # not POSIX
        yield
        return
    real = out.resolve()  # one lock per folder, whatever the path to it: a link to the folder got its own (session 37)
    lock = real.parent / f".{real.name}.longprofile-lock"
    try:
        lock.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(lock, os.O_CREAT | os.O_RDWR, 0o644)
    except OSError as exc:
        raise OutputError(f"cannot create the lock file {lock} beside the output folder {out}: "
                          f"{exc.strerror or exc}; choose another folder.") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise OutputError(f"another `longprofile batch` run is writing to {out} (lock {lock}); wait for it to "
                              "finish, or choose another output folder.") from None
        try:
            yield
        finally:
            lock.unlink(missing_ok=True)
    finally:
        os.close(fd)


def _locked_run(task, inputs, out, executor, workers, resume, overwrite, on_start, on_result, t0) -> BatchSummary:
    """:func:`run_batch` once the output folder is locked."""
    name, opts = task.name, task.options()
    opts_hash = options_hash(name, opts)
    existing = _check_output(out, inputs, resume, overwrite)
    if existing is not None:
        old, info = existing
        if info.get("options_hash") != opts_hash:
            raise InputError(f"{out} holds results made with other options ({option_changes(info, task)}); --resume "
                             "needs the same task and options: run with those of the results, pass --overwrite to "
                             "replace them, or choose another output folder.")
        rows = {r["path"]: r for r in old.to_dict("records")}
        run = int(info.get("run", 0)) + 1
    else:
        rows, run = {}, 1
    job = _Job(task)
    _warm_checked(job)  # bad options fail here, once, before anything is written
    with ExitStack() as stack:
        ex = stack.enter_context(open_executor(executor, workers, warm=job)) if isinstance(executor, str) else executor
        summary = _run(job, inputs, out, rows, ex, run=run, resume=resume, overwrite=overwrite, on_start=on_start,
                       on_result=on_result, t0=t0)
    return summary


def _run(job, inputs, out, rows, executor, *, run, resume, overwrite, on_start, on_result, t0) -> BatchSummary:
    from .. import __version__

    task = job.task
    name, opts = task.name, task.options()
    opts_hash = options_hash(name, opts)
    try:
        if overwrite:
            _clear(out)
        out.mkdir(parents=True, exist_ok=True)
        for stale in out.rglob(".*.tmp"):  # a killed run's temporary partition or manifest (_write_atomic)
            stale.unlink(missing_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot prepare the output folder {out}: {exc.strerror or exc}; choose another folder.") from None
    # n_inputs and complete: a report on an interrupted run says so (it said "195 / 195 done" of 211; session 35)
    # run: which rows the last run listed (the report counts only those; session 38: rows kept by --resume of files
    # not given again were counted). A known input's row is stamped now, whether it is then computed, skipped or fails
    info = {"task": name, "options": opts, "options_hash": opts_hash, "version": __version__,
            "n_inputs": len(inputs), "complete": False, "run": run}
    for p in inputs:
        if str(p) in rows:
            rows[str(p)] = dict(rows[str(p)], run=run)
    manifest = _Manifest(out, info, rows)
    manifest.flush(force=True)  # the folder is a results folder from now on (resumable even if killed now)
    routes = _assign_routes(inputs, rows)
    if on_start is not None:
        on_start(len(inputs))

    common = dict(task=name, opts_hash=opts_hash, version=__version__, run=run)
    todo: list[int] = []
    n_skipped = 0
    for i, p in enumerate(inputs):
        prev = rows.get(str(p))
        if resume and prev is not None and prev["status"] in ("ok", "skipped") \
                and _has_results(out, routes[i]) and _same_content(p, prev["sha256"]):
            row = dict(prev, status="skipped")
            manifest.set(row)
            n_skipped += 1
            if on_result is not None:
                on_result(row)
        else:
            todo.append(i)

    failed, warnings = [], []
    n_ok = 0
    try:
        for result in iter_files(job, [str(inputs[i]) for i in todo], executor) if todo else ():
            i = todo[result.index]
            path, route = str(inputs[i]), routes[i]
            if result.ok:
                digest, size, output = result.value
                _store_or_forget(out, route, path, output, manifest)
                row = _row(path, route, "ok", digest=digest, size=size, seconds=result.seconds,
                           rows=len(output.segments), warning=output.warning, metadata=output.metadata, **common)
                n_ok += 1
                if output.warning:
                    warnings.append((path, output.warning))
            else:
                _remove_partitions(out, route)
                try:
                    digest, size = file_digest(path)
                except OSError:
                    digest, size = "", 0
                row = _row(path, route, "error", error=result.error, digest=digest, size=size,
                           seconds=result.seconds, **common)
                failed.append((path, result.error))
            manifest.set(row)
            manifest.flush()
            if on_result is not None:
                on_result(row)
        info["complete"] = True
        warnings += _flag_same_content(manifest.rows)
    except BaseException:
        try:  # the files done so far (Ctrl-C, a full disk): resumable; a second write error must not hide the first
            manifest.flush(force=True)
        except OutputError:
            pass
        raise
    manifest.flush(force=True)
    return BatchSummary(output=out, task=name, n_inputs=len(inputs), n_ok=n_ok, n_error=len(failed),
                        n_skipped=n_skipped, seconds=time.perf_counter() - t0, failed=tuple(failed),
                        warnings=tuple(warnings))


def _flag_same_content(rows: dict) -> list:
    """A warning on each done input whose content (sha256) equals an earlier one's: the same survey under two names
    would be counted twice in the network (session 35). Returns the new (path, warning) pairs."""
    first, new = {}, []
    for row in sorted(rows.values(), key=lambda r: r["path"]):
        if row["status"] not in ("ok", "skipped") or not row.get("sha256"):
            continue
        other = first.setdefault(row["sha256"], row["path"])
        note = f"same content as {other}: the same survey counted twice?"
        if other != row["path"] and note not in (row.get("warning") or ""):
            row["warning"] = "; ".join(w for w in (row.get("warning") or "", note) if w)
            new.append((row["path"], note))
    return new


def _assign_routes(inputs: list[Path], rows: dict) -> list[str]:
    """Route ids: the one recorded in the manifest for a known input, else a new unique one."""
    used = {r["route"] for r in rows.values()}
    routes = []
    for p, proposed in zip(inputs, _route_ids(inputs)):
        prev = rows.get(str(p))
        if prev is not None:
            routes.append(prev["route"])
            continue
        route, k = proposed, 2
        while route in used:
            route, k = f"{proposed}~{k}", k + 1
        used.add(route)
        routes.append(route)
    return routes


def _store_or_forget(out: Path, route: str, path: str, output, manifest: _Manifest) -> None:
    """:func:`_store`; when it fails (a full disk), the route's partitions and manifest row are removed before the
    error goes up, so that the manifest lists as done only routes whose partitions were written (``--resume``
    computes the route again)."""
    try:
        _store(out, route, path, output)
    except OutputError:
        manifest.rows.pop(path, None)
        try:
            _remove_partitions(out, route)
        except OutputError:
            pass
        raise


def _has_results(out: Path, route: str) -> bool:
    """Whether a route's partitions exist and can be read (as ``batch report`` reads them): ``--resume`` recomputes a
    route whose partition is missing or damaged, as the report's message says (it was skipped; session 37)."""
    import pyarrow.parquet as pq

    try:
        pq.read_table(partition_file(out, route, SEGMENTS))
        if (out / PROFILES).is_dir():
            pq.read_metadata(partition_file(out, route, PROFILES))
    except Exception:  # missing, truncated, not Parquet: computed again
        return False
    return True


def _same_content(path: Path, digest: str) -> bool:
    try:
        return file_digest(path)[0] == digest
    except OSError:
        return False
