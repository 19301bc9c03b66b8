"""Batch processing of a survey network: serial vs threads vs a process pool vs a Dask LocalCluster.

Network: 200 synthetic two-track ISO 8608 profiles of 10 km at 5 cm (ERD files, the profilers' text format, ~3 MB
each; Gd(n0) cycling over good/fair/poor roads), generated once into a temporary folder. Task: ``batch iri`` (the
IRI report of each file, 100 m segments) into a results folder per scheduler, with ``longprofile.batch.run_batch``.
The pools are started and warmed (numba kernels loaded) before the timing: their start-up is a separate row, it is
paid once per run of thousands of files. The machine may be shared: serial and process-pool runs are interleaved and
the best of two is kept, and the Dask run is timed twice, alternating with runs of a second process pool (the
overhead row compares those side-by-side runs). Pool and Dask workers tune glibc's allocator
(``longprofile._memory``); the serial run, in this process, does not (what ``--scheduler serial`` gives), and
a last serial run with this process tuned gives the speed-up without the allocator's share.
Identity: the segment tables read back are compared bit for bit.
Quick mode: 8 files of 1 km, Dask workers in process (its figures only show that everything runs).

Run: ``.venv/bin/python -m benchmarks batch`` (full) or ``--quick``.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path

from benchmarks._common import BenchRow

AREA = "batch"
WORKERS = 2
_ROUGHNESS = (3e-6, 8e-6, 20e-6)  # Gd(n0), m^3: good, fair, poor


def _generate(folder: Path, n: int, length: float) -> list[Path]:
    from longprofile.io import write_profile
    from longprofile.road import iso8608_profile

    files = []
    for i in range(n):
        p = iso8608_profile(length, 0.05, _ROUGHNESS[i % 3], rng=i, tracks=("left", "right"))
        files.append(write_profile(p, folder / f"route{i // 2:03d}" / f"lane{i % 2 + 1}.erd", units="mm"))
    return files


def _timed(task, files, out, executor) -> float:
    from longprofile.batch import run_batch

    t0 = time.perf_counter()
    summary = run_batch(task, files, out, executor=executor)
    dt = time.perf_counter() - t0
    if summary.n_ok != len(files):
        raise RuntimeError(f"benchmark batch failed: {summary.line()}")
    return dt


def _warm(task):
    task.warm()
    return True


def _peak_rss_mb(_=None) -> float:
    """Peak resident memory of the calling process, MB (Linux: ru_maxrss in KiB)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run(quick: bool) -> list[BenchRow]:
    from concurrent.futures import ThreadPoolExecutor

    import pandas as pd

    from longprofile.batch import IRITask, process_executor, read_results

    n, length = (8, 1000.0) if quick else (200, 10_000.0)
    task = IRITask()
    tmp = Path(tempfile.mkdtemp(prefix="bench-batch-"))
    rows: list[BenchRow] = []
    try:
        t0 = time.perf_counter()
        files = _generate(tmp / "surveys", n, length)
        t_gen = time.perf_counter() - t0
        size = sum(f.stat().st_size for f in files) / 1e6
        what = f"{n} files x {length / 1000:g} km x 2 tracks at 5 cm (ERD, {size:.0f} MB)"
        task.warm()
        load = os.getloadavg()[0]
        best: dict[str, float] = {}

        per_file: dict[str, float] = {}
        rss: dict[str, float] = {}

        def timed(name, executor, rep):
            dt = _timed(task, files, tmp / f"{name}-{rep}", executor)
            if dt < best.get(name, float("inf")):
                best[name] = dt
                per_file[name] = float(read_results(tmp / f"{name}-{rep}").manifest["seconds"].mean())

        try:
            from distributed import Client, LocalCluster
        except ImportError:
            LocalCluster = None
        t0 = time.perf_counter()
        with process_executor(WORKERS, warm=task) as pool:
            for f in [pool.submit(_warm, task) for _ in range(WORKERS)]:  # both workers spawned and warmed
                f.result()
            t_start = time.perf_counter() - t0
            # interleaved, best of two: the machine is shared, a neighbour's job must not decide a ratio
            for rep in range(1 if quick else 2):
                timed("serial", None, rep)
                timed("processes", pool, rep)
            rss["processes"] = max(f.result() for f in [pool.submit(_peak_rss_mb) for _ in range(4 * WORKERS)])
        with ThreadPoolExecutor(WORKERS) as ex:
            timed("threads", ex, 0)
        if LocalCluster is not None:
            t0 = time.perf_counter()
            # quick (a CI smoke test): in-process Dask workers, which start in a fraction of a second
            with LocalCluster(n_workers=WORKERS, threads_per_worker=1, processes=not quick,
                              dashboard_address=None) as cluster, Client(cluster) as client:
                client.run(_warm, task)
                t_dask_start = time.perf_counter() - t0
                if quick:
                    timed("dask", client, 0)
                else:  # the pool again, alternating with the Dask runs: the overhead compares runs made side by side
                    with process_executor(WORKERS, warm=task) as pool:
                        for f in [pool.submit(_warm, task) for _ in range(WORKERS)]:
                            f.result()
                        for rep in range(2):
                            timed("beside", pool, rep)
                            timed("dask", client, rep)
                rss["dask"] = max(client.run(_peak_rss_mb).values())
        if not quick:  # the serial run again with this process's allocator tuned as the workers' are
            from longprofile._memory import tune_process_memory

            tuned = tune_process_memory()
            timed("serial-tuned", None, 0)
        times = best
        reference = read_results(tmp / "serial-0").segments
        identical, runs = 1.0, sorted(p.name for p in tmp.iterdir() if p.name != "surveys")
        for name in runs:
            try:
                pd.testing.assert_frame_equal(read_results(tmp / name).segments, reference, check_exact=True)
            except AssertionError:
                identical = 0.0
        compared = ", ".join(runs)
        rows += [
            BenchRow(AREA, "segment tables identical bit for bit", identical, "bool", target=1.0,
                     detail=f"{compared}; {len(reference)} segments"),
            BenchRow(AREA, "serial throughput", n / times["serial"], "files/s",
                     detail=f"{what}: {times['serial']:.2f} s; load average before {load:.2f}"),
            BenchRow(AREA, f"processes ({WORKERS} workers) speed-up vs serial", times["serial"] / times["processes"],
                     "x", target=1.7, detail=f"{times['processes']:.2f} s vs {times['serial']:.2f} s; pool start-up "
                                             "excluded (row below)"),
            *([BenchRow(AREA, f"processes ({WORKERS} workers) speed-up vs serial, both with the allocator tuned",
                        times["serial-tuned"] / times["processes"], "x",
                        detail=f"{times['processes']:.2f} s vs {times['serial-tuned']:.2f} s (serial run last, this "
                               f"process tuned: {tuned}); the parallel efficiency without the allocator's share")]
              if "serial-tuned" in times else []),
            BenchRow(AREA, "mean time per file inside the workers, processes / serial",
                     per_file["processes"] / per_file["serial"], "x", higher_is_better=False,
                     detail=f"{per_file['processes']:.3f} s vs {per_file['serial']:.3f} s: above 1 = the workers got "
                            f"less CPU than the serial run (other jobs), not batch overhead; load after "
                            f"{os.getloadavg()[0]:.2f}"),
            BenchRow(AREA, f"processes ({WORKERS} workers) throughput", n / times["processes"], "files/s",
                     detail=f"{n * length / 1000 / times['processes']:.0f} km/s of two-track profile"),
            BenchRow(AREA, f"threads ({WORKERS}) speed-up vs serial", times["serial"] / times["threads"], "x",
                     detail="reported only (reading and pandas hold the GIL)"),
            BenchRow(AREA, f"process pool start-up ({WORKERS} workers: spawn, imports, warm-up)", t_start, "s",
                     higher_is_better=False, detail="paid once per run"),
            BenchRow(AREA, "network generation (synthetic profiles + ERD writing)", t_gen, "s", higher_is_better=False,
                     detail="not part of the batch"),
        ]
        if "dask" in times:
            peer = "beside" if "beside" in times else "processes"
            overhead = 100.0 * (times["dask"] / times[peer] - 1.0)
            rows += [
                BenchRow(AREA, "Dask LocalCluster overhead vs the process pool", overhead, "%", target=15.0,
                         higher_is_better=False, detail=f"{times['dask']:.2f} s vs {times[peer]:.2f} s ({WORKERS} worker "
                                                        f"{'threads, in process' if quick else 'processes'} x 1 thread; best of "
                                                        f"{1 if quick else 2}, alternating with a pool run); per file in the "
                                                        f"workers {per_file['dask']:.3f} s vs {per_file[peer]:.3f} s"),
                BenchRow(AREA, f"Dask LocalCluster start-up ({WORKERS} workers + warm-up)", t_dask_start, "s",
                         higher_is_better=False, detail="paid once per run"),
                BenchRow(AREA, "peak memory of a worker, Dask / process pool", rss["dask"] / rss["processes"], "x",
                         higher_is_better=False,
                         detail=f"{rss['dask']:.0f} MB vs {rss['processes']:.0f} MB (largest worker, ru_maxrss; both "
                                f"with the batch's allocator tuning, longprofile._memory)"),
            ]
        rows += _report_rows(tmp, files, quick)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return rows


def _report_rows(tmp: Path, files: list[Path], quick: bool) -> list[BenchRow]:
    """``batch report`` on a continuous-IRI network (a window every step): its throughput in windows/s, in this
    process and as the whole command in a fresh one, and its ratio against reading the same dataset with pyarrow."""
    import pyarrow.dataset as ds

    from benchmarks._common import cli_wall_time
    from longprofile.batch import IRITask, read_results, run_batch, summarize_network
    from longprofile.report import write_network_report

    # full: 40 files x 10 km, a 7.62 m window every 0.3 m (1.33 million windows, the size that took 45 s in session
    # 37); quick: 8 files x 1 km, a window every sample (0.05 m, 160 000 windows)
    subset, task = (files, IRITask(mode="continuous")) if quick else (files[:40], IRITask(mode="continuous", step=0.3))
    results = tmp / "report-network"
    summary = run_batch(task, subset, results, executor=None if quick else "processes", workers=WORKERS)
    if summary.n_ok != len(subset):
        raise RuntimeError(f"benchmark batch report: the continuous run failed: {summary.line()}")
    load = os.getloadavg()[0]
    t_report, t_read = float("inf"), float("inf")
    for rep in range(2):  # alternating, best of two: the machine is shared
        t0 = time.perf_counter()
        write_network_report(summarize_network(read_results(results)), tmp / f"report-{rep}")
        t_report = min(t_report, time.perf_counter() - t0)
        t0 = time.perf_counter()
        n = ds.dataset(results / "segments", partitioning="hive").to_table().num_rows
        t_read = min(t_read, time.perf_counter() - t0)
    repeat = 1 if quick else 2
    wall, _ = cli_wall_time(["batch", "report", str(results)], [tmp / f"report-cli-{k}" for k in range(repeat + 1)],
                            repeat=repeat)
    what = f"{n} windows over {len(subset)} routes, continuous IRI"
    return [
        BenchRow(AREA, "batch report throughput (read_results + summarize_network + write_network_report)",
                 n / t_report, "windows/s", target=None if quick else 150_000.0,
                 detail=f"{what}: {t_report:.2f} s in this process (best of 2); 1.3 million windows took 44.8 s "
                        f"before session 38 (about 30 000 windows/s); load average before {load:.2f}"),
        BenchRow(AREA, "batch report / reading the dataset with pyarrow", t_report / t_read, "x",
                 higher_is_better=False,
                 detail=f"{t_report:.2f} s vs {t_read:.3f} s (pyarrow.dataset over segments/, best of 2, alternating)"),
        BenchRow(AREA, "longprofile batch report, whole command (fresh process)", wall, "s", higher_is_better=False,
                 detail=f"{what}; best of {repeat} after a warm-up run; imports and the PNG and HTML writing included"),
    ]
