"""APL reconstruction of survey-length records (issue 11): any length, same answer, bounded memory, CLI time.

Rows:
- ``long == short``: on a 10.5 km record (210 000 samples, above LONG_RECORD_SAMPLES and past the ~164 000-sample
  exact start) the default long-record path and the exact time-varying path (``stationary=False``), with the
  same q, r and with each path's own ML fit: RMS difference of the detrended profiles / RMS of the profile
  (target <= 1e-6).
- ``cli 10 km / 100 km (csv)``: ``longprofile road reconstruct rec.csv -o profile.csv`` with its defaults, as a
  user runs it (a fresh process: imports, file reading, ML fit, smoother, detrending, writing), wall time and peak
  resident memory of that process (targets for 100 km: <= 10 s, <= 1 GB).
- ``cli 1000 km (parquet)``: the same on 2e7 samples, Parquet in and out (target <= 120 s; memory reported per
  sample: it is O(T) for the arrays a user gets back, O(chunk) for the filter and smoother).
- ``in-process 100 km``: ``reconstruct_profile`` alone.
The recordings are simulated once (ISO 8608 class C, 20 m/s, 5 cm, 2 % noise) into a temporary folder; that
time is not counted. Quick mode: the equality row with fixed q, r, and the CLI on 10 km.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks road_long [--quick]``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks._common import BenchRow

AREA = "road_long"
DX = 0.05


def _simulate(path: Path, length_m: float, seed: int) -> None:
    import pandas as pd

    from longprofile.io import write_table
    from longprofile.road.apl import apl_model, simulate_apl_recording

    rec = simulate_apl_recording("iso8608", apl_model(20.0, DX), length=length_m, road_class="C",
                                 noise_fraction=0.02, rng=seed)
    write_table(pd.DataFrame(dict(distance_m=rec.distance, true_m=rec.true_elevation, apl_m=rec.signal)), path)


_CHILD = ("import sys\nfrom longprofile.cli.app import main\nrc = main(sys.argv[1:])\n"
          "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].split()[1]\n"
          "sys.stderr.write(f'\\nVmHWM_kB={hwm}\\n')\nsys.exit(rc)")


def _cli(args: list[str]) -> tuple[float, float]:
    """Wall time (s) and peak RSS (MB) of one ``longprofile`` process (the console script's ``main``).

    The peak is the process's own VmHWM read at its end: ``ru_maxrss`` is not used because on Linux it survives
    fork + execve, so a child of this (large) benchmark process would report its parent's peak.
    """
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _CHILD, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          env=env, check=False)
    wall = time.perf_counter() - t0
    err = proc.stderr.decode(errors="replace")
    if proc.returncode != 0:
        raise RuntimeError(f"longprofile {' '.join(args)} failed: {err[-500:]}")
    hwm = float(err.rsplit("VmHWM_kB=", 1)[1].split()[0])
    return wall, hwm / 1024.0


def _equality_rows(fit: bool) -> list[BenchRow]:
    from longprofile.road.apl import apl_model, reconstruct_profile, simulate_apl_recording

    m = apl_model(20.0, DX)
    y = simulate_apl_recording("iso8608", m, length=10_500.0, road_class="C", noise_fraction=0.02, rng=5).signal
    kw = {} if fit else dict(q=2.4e-6, r=7.8e-8)
    t0 = time.perf_counter()
    long_ = reconstruct_profile(y, m, **kw)
    t_long = time.perf_counter() - t0
    t0 = time.perf_counter()
    short = reconstruct_profile(y, m, stationary=False, **kw)
    t_short = time.perf_counter() - t0
    a, b = long_.profile.elevation[:, 0], short.profile.elevation[:, 0]
    rel = float(np.sqrt(np.mean((a - b) ** 2)) / np.std(b))
    what = "ML-fitted q, r (each path its own fit)" if fit else "fixed q, r"
    rows = [BenchRow(AREA, f"long == short, 10.5 km, {what}", rel, "of profile RMS", target=1e-6,
                     higher_is_better=False,
                     detail=f"long path {t_long:.2f} s, exact time-varying path {t_short:.2f} s"
                            + (f"; q {long_.q:.4g} vs {short.q:.4g} m^2" if fit else ""))]
    return rows


def run(quick: bool) -> list[BenchRow]:
    rows = _equality_rows(fit=False)
    if not quick:
        rows += _equality_rows(fit=True)
    lengths = [10_000.0] if quick else [10_000.0, 100_000.0]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        _cli(["road", "simulate", "--length", "200", "-o", str(tmp / "warm.csv")])  # warm the numba cache
        _cli(["road", "reconstruct", str(tmp / "warm.csv"), "-o", str(tmp / "warm_out.csv")])
        for length in lengths:
            rec = tmp / f"rec_{int(length)}.csv"
            _simulate(rec, length, seed=1)
            wall, rss = _cli(["road", "reconstruct", str(rec), "-o", str(tmp / f"profile_{int(length)}.csv")])
            km = length / 1000.0
            rows.append(BenchRow(AREA, f"cli reconstruct {km:g} km (csv in/out), wall", wall, "s",
                                 target=10.0 if km == 100 else None, higher_is_better=False,
                                 detail=f"{int(length / DX) + 1} samples, defaults (ML fit, smoother)"))
            rows.append(BenchRow(AREA, f"cli reconstruct {km:g} km (csv in/out), peak memory", rss, "MB",
                                 target=1024.0 if km == 100 else None, higher_is_better=False,
                                 detail=f"{rss * 1e6 / (length / DX):.0f} B/sample"))
        if not quick:
            from longprofile.road.apl import apl_model, reconstruct_profile, simulate_apl_recording

            y = simulate_apl_recording("iso8608", apl_model(20.0, DX), length=100_000.0, road_class="C",
                                       noise_fraction=0.02, rng=2).signal
            t0 = time.perf_counter()
            reconstruct_profile(y, apl_model(20.0, DX))
            rows.append(BenchRow(AREA, "in-process reconstruct_profile 100 km", time.perf_counter() - t0, "s",
                                 detail="2e6 samples, ML fit + long-record smoother + detrending"))
            del y
            rec = tmp / "rec_1000000.parquet"
            _simulate(rec, 1_000_000.0, seed=3)
            wall, rss = _cli(["road", "reconstruct", str(rec), "-o", str(tmp / "profile_1000000.parquet")])
            rows.append(BenchRow(AREA, "cli reconstruct 1000 km (parquet in/out), wall", wall, "s", target=120.0,
                                 higher_is_better=False, detail="2e7 samples, defaults"))
            rows.append(BenchRow(AREA, "cli reconstruct 1000 km (parquet in/out), peak memory", rss, "MB",
                                 detail=f"{rss * 1e6 / 2e7:.0f} B/sample (the output table itself is 40 B/sample)"))
    return rows
