"""A real `longprofile batch` process pool stopped from outside: Ctrl-C twice, to the process group or to the driver
only, and kill -9 of the driver (session 35, a probe: tracebacks from every worker, a driver that hung in its
shutdown, workers left running after the driver's death). Linux: the processes are found in /proc."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from longprofile._interrupt import interrupt_once
from longprofile.batch import read_manifest

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="needs Linux /proc")

#: `python -m longprofile`, with SIGINT raising KeyboardInterrupt as in a terminal (a test runner's worker may have it
#: ignored, which the processes it starts would inherit)
_MAIN = ("import runpy, signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
         "runpy.run_module('longprofile', run_name='__main__', alter_sys=True)")
_N_FILES = 2


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """Two APL recordings, 20 km and 1 km: one worker of `batch reconstruct` is done with its file (and idle) while
    the other works on the long one for a few seconds more."""
    from longprofile.road.apl import apl_model, simulate_apl_recording

    folder = tmp_path_factory.mktemp("apl")
    rec = simulate_apl_recording("iso8608", apl_model(20.0, 0.05), length=20_000.0, road_class="B", rng=5)
    table = pd.DataFrame({"distance_m": rec.distance, "apl_m": rec.signal})
    table.to_parquet(folder / "long.parquet")
    table.iloc[:20_001].to_parquet(folder / "short.parquet")
    return folder


def _stat(pid: int) -> list[str] | None:
    """Fields of /proc/PID/stat after the command name (state first), None when the process is gone."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return text.rsplit(")", 1)[1].split()


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie does not)."""
    fields = _stat(pid)
    return fields is not None and fields[0] not in ("Z", "X")


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (the pool workers and multiprocessing's resource tracker)."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            fields = _stat(int(entry.name))
            if fields is not None and int(fields[1]) == pid:
                out.append(int(entry.name))
    return out


def _workers(pid: int) -> list[int]:
    """The pool workers among the children of ``pid`` (multiprocessing's ``spawn_main`` processes)."""
    out = []
    for child in _children(pid):
        try:
            if b"spawn_main" in Path(f"/proc/{child}/cmdline").read_bytes():
                out.append(child)
        except OSError:
            pass
    return out


def _cpu_seconds(pid: int) -> float:
    """CPU time used by ``pid`` so far (user + system), s; 0 when it is gone."""
    fields = _stat(pid)
    return 0.0 if fields is None else (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _start(folder: Path, out: Path, err: Path) -> subprocess.Popen:
    """`longprofile batch reconstruct` on the recordings with 2 workers, in its own process group."""
    args = [sys.executable, "-c", _MAIN, "batch", "reconstruct", str(folder / "*.parquet"), "-o", str(out),
            "--workers", "2"]
    with open(err, "w") as fh:
        return subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=fh, start_new_session=True,
                                env={**os.environ, "OPENBLAS_NUM_THREADS": "1", "COLUMNS": "200"})


def _wait_one_idle(proc: subprocess.Popen, out: Path, timeout: float = 60.0) -> list[int]:
    """The 2 workers' pids once one is idle (done with the short file: its CPU time stands still over 0.3 s) while
    the other computes (the long file)."""
    deadline, last = time.monotonic() + timeout, {}
    while time.monotonic() < deadline:
        assert proc.poll() is None, "the batch ended before it could be stopped"
        cpu = {w: _cpu_seconds(w) for w in _workers(proc.pid)}
        if len(cpu) == 2 and cpu.keys() == last.keys() and (out / "manifest.parquet").is_file():
            steps = sorted(cpu[w] - last[w] for w in cpu)
            if min(cpu.values()) > 0.5 and steps[0] < 0.03 and steps[1] > 0.05:
                return list(cpu)
        last = cpu
        time.sleep(0.3)
    raise AssertionError("the batch never had one worker idle and the other busy")


def _gone(pids, timeout: float) -> list[int]:
    """The pids still running after up to ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while any(map(_alive, pids)) and time.monotonic() < deadline:
        time.sleep(0.05)
    return [p for p in pids if _alive(p)]


def _cleanup(proc: subprocess.Popen, pids) -> None:
    """Whatever a failed test left running: the driver's process group, and the processes it started."""
    for pid in pids:
        if _alive(pid):
            os.kill(pid, signal.SIGKILL)
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(10)


def _send(send, pid: int) -> None:
    """``send(pid, SIGINT)``: ``os.kill`` or ``os.killpg``; a driver that has ended already is fine."""
    try:
        send(pid, signal.SIGINT)
    except ProcessLookupError:
        pass


def _interrupted_cleanly(proc, code, err: Path, out: Path, workers) -> None:
    """Exit 130, the one-line message and no traceback, a manifest of an incomplete run, no process left."""
    text = err.read_text()
    assert code == 130, text
    assert "Traceback" not in text and "KeyboardInterrupt" not in text, text
    assert f"of {_N_FILES} files: the results so far are in {out}" in text, text
    manifest, info = read_manifest(out)  # what finished, and that the run did not
    assert info["complete"] is False and len(manifest) < _N_FILES
    assert _gone(workers + _children(proc.pid), 5.0) == []


def test_double_ctrl_c_to_the_process_group_stops_the_batch_without_a_traceback(recordings, tmp_path):
    """A terminal's Ctrl-C reaches the workers too: they ignore it (an idle one printed a traceback, a busy one did
    at the second Ctrl-C); the driver stops the pool and writes the manifest."""
    out, err = tmp_path / "r", tmp_path / "stderr.txt"
    proc, workers = _start(recordings, out, err), []
    try:
        workers = _wait_one_idle(proc, out)
        for pid in workers:  # SIGINT (2) ignored: bit 1 of the kernel's mask of ignored signals
            status = Path(f"/proc/{pid}/status").read_text()
            assert int(status.split("SigIgn:")[1].split()[0], 16) & 1 << (signal.SIGINT - 1), status
        _send(os.killpg, proc.pid)
        time.sleep(0.05)  # the driver is stopping its pool (it takes 0.05-0.1 s)
        _send(os.killpg, proc.pid)
        code = proc.wait(timeout=20)
    finally:
        _cleanup(proc, workers)
    _interrupted_cleanly(proc, code, err, out, workers)


def test_a_second_ctrl_c_during_the_shutdown_does_not_hang_the_driver(recordings, tmp_path):
    """The second SIGINT is sent to the driver once it has written its manifest after the first, i.e. while it stops
    its pool (busy workers: the shutdown waited for their files, and the second interrupt hung it)."""
    out, err = tmp_path / "r", tmp_path / "stderr.txt"
    proc, workers = _start(recordings, out, err), []
    try:
        workers = _wait_one_idle(proc, out)
        before = (out / "manifest.parquet").stat()
        _send(os.kill, proc.pid)
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and proc.poll() is None:  # the manifest is replaced on the way out
            now = (out / "manifest.parquet").stat()
            if (now.st_ino, now.st_mtime_ns) != (before.st_ino, before.st_mtime_ns):
                break
            time.sleep(0.005)
        _send(os.kill, proc.pid)
        t0 = time.monotonic()
        code = proc.wait(timeout=20)
        assert time.monotonic() - t0 < 5.0
    finally:
        _cleanup(proc, workers)
    _interrupted_cleanly(proc, code, err, out, workers)


def test_kill_9_of_the_driver_ends_its_workers(recordings, tmp_path):
    """Nothing runs in the driver any more: each worker sees it is gone (its parent changed) and exits."""
    out, err = tmp_path / "r", tmp_path / "stderr.txt"
    proc, left = _start(recordings, out, err), []
    try:
        _wait_one_idle(proc, out)
        left = _children(proc.pid)  # the workers and the resource tracker
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        assert _gone(left, 5.0) == [], "processes of the killed driver still running"
    finally:
        _cleanup(proc, left)



def test_interrupt_once_raises_at_the_first_signal_and_ignores_the_next_until_the_block_ends():
    """What run_batch (SIGINT) and the batch command (SIGINT, SIGTERM; here SIGUSR1 stands for it) run under: a
    second Ctrl-C arriving while the first one's cleanup runs must not cut it short."""
    usr1 = signal.SIGUSR1
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, usr1)}
    signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a terminal
    signal.signal(usr1, signal.SIG_DFL)
    cleaned = []
    try:
        with pytest.raises(KeyboardInterrupt), interrupt_once(signal.SIGINT, usr1) as received:
            try:
                os.kill(os.getpid(), usr1)
                time.sleep(5.0)  # interrupted at once
            finally:
                os.kill(os.getpid(), signal.SIGINT)  # during the cleanup: counted, not raised
                time.sleep(0.01)
                cleaned.append(True)
        assert cleaned and received == [usr1, signal.SIGINT]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored: the process goes on
        assert signal.getsignal(usr1) == signal.SIG_DFL
        with pytest.raises(KeyboardInterrupt), interrupt_once(signal.SIGINT, usr1, keep_ignoring=True):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5.0)
        assert signal.getsignal(signal.SIGINT) == signal.getsignal(usr1) == signal.SIG_IGN  # a process that ends now
        with interrupt_once(signal.SIGINT):  # an ignored SIGINT (a background job) is left alone
            assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    finally:
        for s, handler in saved.items():
            signal.signal(s, handler)
