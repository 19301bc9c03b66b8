"""map_files on every executor: input order, recorded errors, BLAS pinning, Dask optional."""

import sys
from concurrent.futures import ThreadPoolExecutor

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.batch import IRITask, ReconstructTask, error_message, map_files, open_executor, process_executor
from longprofile.batch._map import _worker_info
from longprofile.errors import DependencyError, InputError, UnitsError

from ._helpers import boom, busy_for_a_minute, expected_allocator_status


@settings(max_examples=40)
@given(st.lists(st.booleans(), max_size=30), st.sampled_from(["serial", "threads"]))
def test_results_in_input_order_and_errors_exactly_where_files_fail(bad, scheduler):
    paths = [f"{'bad' if b else 'good'}-{i}" for i, b in enumerate(bad)]
    with open_executor(scheduler, 3) as ex:
        res = map_files(boom, paths, executor=ex)
    assert [r.index for r in res] == list(range(len(paths)))
    assert [r.path for r in res] == paths
    for r, b in zip(res, bad):
        assert r.ok is (not b)
        if b:
            assert r.value is None and r.error == f"ZeroDivisionError: boom on {r.path}"
        else:
            assert r.value == r.path.upper() and r.seconds >= 0


def test_error_messages_library_error_verbatim_others_typed_one_line():
    assert error_message(UnitsError("bad unit\n  in column x")) == "bad unit in column x"
    assert error_message(KeyError("k")) == "KeyError: 'k'"
    assert error_message(RuntimeError()) == "RuntimeError"
    assert len(error_message(ValueError("x" * 10_000))) <= 2000


def test_process_pool_pins_blas_threads_to_one_and_keeps_order(monkeypatch):
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "7")  # the parent's own setting must not leak into workers
    with process_executor(2) as ex:
        res = map_files(_worker_info, [f"p{i}" for i in range(6)], executor=ex)
    assert all(r.ok for r in res)
    for r in res:
        assert r.value["OPENBLAS_NUM_THREADS"] == r.value["OMP_NUM_THREADS"] == r.value["MKL_NUM_THREADS"] == "1"
    assert len({r.value["pid"] for r in res}) <= 2
    assert {r.value["allocator"] for r in res} == {expected_allocator_status()}  # tuned in every worker (glibc)
    import os

    assert os.environ["OPENBLAS_NUM_THREADS"] == "7"  # and the parent's environment is left as it was


def test_allocator_tuning_can_be_switched_off_and_is_never_applied_to_the_caller(monkeypatch):
    from longprofile import _memory as _alloc

    monkeypatch.setenv(_alloc.TUNING_ENV, "off")  # inherited by the spawned workers
    with process_executor(2) as ex:
        res = map_files(_worker_info, ["a", "b", "c"], executor=ex)
    assert {r.value["allocator"] for r in res} == {"disabled"}
    monkeypatch.setattr(_alloc, "_STATE", {})  # this process as if nothing had tuned it yet
    with ThreadPoolExecutor(2) as ex:  # threads run in this process: the batch leaves its allocator alone
        res = map_files(IRITask(), ["missing.erd"], executor=ex)
        res += map_files(_worker_info, ["a", "b"], executor=ex)
    assert {r.value["allocator"] for r in res[1:]} == {None} and _alloc.memory_status() is None
    monkeypatch.setattr(_alloc, "_STATE", {})
    assert _alloc.tune_process_memory() == "disabled" and _alloc.tune_process_memory() == "disabled"  # once, then cached


@pytest.mark.parametrize("pool", ["open_executor", "process_executor"])
def test_a_pool_left_by_an_exception_stops_its_busy_workers_at_once(tmp_path, pool):
    """Ctrl-C (or an error) in the driver: the workers still computing are terminated, not waited for; the shutdown
    waited for their files (minutes for a long survey), and a second Ctrl-C in that wait hung the driver (session 35)."""
    import os
    import time

    started = tmp_path / "pid"
    with pytest.raises(KeyboardInterrupt), (open_executor("processes", 1) if pool == "open_executor"
                                            else process_executor(1)) as ex:
        ex.submit(busy_for_a_minute, str(started))
        deadline = time.monotonic() + 60.0
        while not started.is_file() and time.monotonic() < deadline:
            time.sleep(0.02)
        pid, t0 = int(started.read_text()), time.monotonic()
        raise KeyboardInterrupt
    assert time.monotonic() - t0 < 10.0  # SIGTERM: at once; the pool would have waited 60 s
    while time.monotonic() - t0 < 10.0:  # and the worker is gone (reaped by the pool)
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)
    raise AssertionError(f"worker {pid} still running")


def test_unknown_executor_and_scheduler_are_refused():
    with pytest.raises(InputError, match="executor must be"):
        map_files(boom, ["a"], executor=object())
    with pytest.raises(InputError, match="unknown scheduler 'cluster'"):
        with open_executor("cluster"):
            pass
    with pytest.raises(InputError, match="workers must be"):
        with open_executor("threads", 0):
            pass


def test_dask_scheduler_without_dask_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    with pytest.raises(DependencyError, match=r"pip install longprofile\[dask\]"):
        with open_executor("tcp://127.0.0.1:8786"):
            pass


def test_dask_scheduler_that_does_not_answer_is_one_clear_error():
    pytest.importorskip("distributed", reason="dask[distributed] not installed (pip install longprofile[dask])")
    import socket

    with socket.socket() as s:  # a free loopback port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    from longprofile.batch import dask_client

    with pytest.raises(InputError, match=f"cannot connect to the Dask scheduler at tcp://127.0.0.1:{port}"):
        dask_client(f"tcp://127.0.0.1:{port}", timeout=1.0)


def test_bad_task_options_fail_at_construction():
    with pytest.raises(InputError, match="units must be 'si'"):
        IRITask(units="mm")
    with pytest.raises(InputError, match="interval must be"):
        IRITask(interval=-1.0)
    with pytest.raises(InputError, match="moving_average"):
        IRITask(moving_average="maybe")
    with pytest.raises(InputError, match="method must be one of"):
        ReconstructTask(method="magic")
    assert IRITask(units="us").interval == 528.0 and IRITask().interval == 100.0


def test_tasks_are_picklable_and_hashable_with_stable_options():
    import pickle

    t = IRITask(tracks=["left", "right"], start=5)
    assert pickle.loads(pickle.dumps(t)) == t and hash(t) == hash(pickle.loads(pickle.dumps(t)))
    assert t.options()["tracks"] == ["left", "right"] and t.options()["start"] == 5.0
    with ThreadPoolExecutor(1) as ex:  # a user's own pool works too
        assert map_files(boom, ["x"], executor=ex)[0].value == "X"


def test_package_exports_are_documented_and_importing_it_does_not_import_numpy():
    import inspect
    import subprocess

    import longprofile.batch as batch

    assert batch.__doc__.strip() and len(set(batch.__all__)) == len(batch.__all__)
    for name in batch.__all__:
        obj = getattr(batch, name)
        if inspect.isfunction(obj) or inspect.isclass(obj):
            assert (obj.__doc__ or "").strip(), name
    # spawned workers unpickle the task (this package) before pinning BLAS threads: no numpy at import
    code = "import sys, longprofile.batch; print('numpy' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stdout.strip() == "False"


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 5000), st.integers(1, 64))
def test_dask_files_per_task_keeps_enough_tasks_per_worker_and_a_bounded_size(n_files, n_workers):
    from longprofile.batch._map import DASK_MAX_FILES_PER_TASK, DASK_TASKS_PER_WORKER, dask_files_per_task

    size = dask_files_per_task(n_files, n_workers)
    assert 1 <= size <= DASK_MAX_FILES_PER_TASK
    limit = DASK_TASKS_PER_WORKER * n_workers
    if size < DASK_MAX_FILES_PER_TASK:  # not capped: at most `limit` tasks ...
        assert -(-n_files // size) <= limit
    if size > 1:  # ... and the smallest size that gives so few (one file less per task would exceed it)
        assert -(-n_files // (size - 1)) > limit


def test_dask_groups_files_per_task_yet_records_each_file_own_outcome():
    distributed = pytest.importorskip("distributed", reason="dask[distributed] not installed "
                                                            "(pip install longprofile[dask])")
    from longprofile.batch._map import dask_files_per_task

    paths = [f"{'bad' if i % 3 == 1 else 'good'}-{i}" for i in range(37)]  # 1 worker: tasks of 5, a short last one
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") \
            as cluster, distributed.Client(cluster) as client:
        submitted = []
        submit = client.submit

        def spy(func, *args, **kwargs):
            submitted.append(len(args[0]))
            return submit(func, *args, **kwargs)

        client.submit = spy
        res = map_files(boom, paths, executor=client)
    size = dask_files_per_task(37, 1)
    assert size == 5 and submitted == [5] * 7 + [2]  # grouped: 8 tasks, not 37
    assert [r.path for r in res] == paths
    for i, r in enumerate(res):
        if i % 3 == 1:
            assert r.error == f"ZeroDivisionError: boom on {r.path}" and r.value is None
        else:
            assert r.ok and r.value == r.path.upper()
