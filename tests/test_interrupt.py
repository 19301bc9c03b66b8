"""Ctrl-C reaching a worker process while its pool's initializer runs (longprofile._interrupt): no traceback."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

_SCRIPT = textwrap.dedent("""
    import multiprocessing, os, signal, sys, time
    from concurrent.futures import ProcessPoolExecutor
    from longprofile._interrupt import quiet_interrupt

    def slow_init(path):
        open(path, "w").close()  # the parent waits for this file: the worker is inside its initializer
        time.sleep(30)

    @quiet_interrupt  # decorated where defined, as in the package: a spawn pool pickles the initializer by name
    def quiet_init(path):
        slow_init(path)

    def wait_for(path):
        for _ in range(3000):
            if os.path.exists(path):
                return
            time.sleep(0.01)
        raise SystemExit("the worker never started")

    if __name__ == "__main__":
        # as in a terminal: SIGINT raises KeyboardInterrupt (a test runner's worker may have it ignored, which the
        # processes it starts would inherit)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        quiet, path = sys.argv[1] == "quiet", sys.argv[2]
        init = quiet_init if quiet else slow_init
        pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context({ctx!r}), initializer=init,
                                   initargs=(path,))
        fut = pool.submit(abs, -1)
        wait_for(path)
        (worker,) = pool._processes.values()
        os.kill(worker.pid, signal.SIGINT)
        worker.join(20)
        # the pool's own management thread reaps a dead worker too: the thread that loses the race for waitpid sees
        # no status yet (exitcode None) until the winner has stored it in the shared Process object
        for _ in range(500):
            if worker.exitcode is not None:
                break
            time.sleep(0.01)
        print("exitcode", worker.exitcode)
        try:
            fut.result(timeout=20)
        except Exception as exc:  # the pool is broken: its only worker is gone
            print("parent sees", type(exc).__name__)
        pool.shutdown(wait=True, cancel_futures=True)
""")


@pytest.mark.parametrize("ctx", ["fork", "spawn"])
@pytest.mark.parametrize("quiet", [True, False])
def test_interrupted_initializer_prints_nothing(tmp_path, ctx, quiet):
    script = tmp_path / "pool.py"
    script.write_text(_SCRIPT.format(ctx=ctx))
    proc = subprocess.run([sys.executable, str(script), "quiet" if quiet else "plain", str(tmp_path / "started")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    if quiet:
        assert "exitcode 130" in proc.stdout
        assert "Traceback" not in proc.stderr and "KeyboardInterrupt" not in proc.stderr, proc.stderr
    else:  # the control: concurrent.futures prints the interrupted initializer's traceback
        assert "Exception in initializer" in proc.stderr
    assert "parent sees BrokenProcessPool" in proc.stdout


def test_worker_initializers_are_quiet():
    """The figure helper's and the batch pool's initializers are the wrapped ones."""
    from longprofile.batch._map import _init_process_worker
    from longprofile.report._render import _warm

    for init in (_warm, _init_process_worker):
        assert init.__wrapped__ is not None
        assert init.__code__ is not init.__wrapped__.__code__
