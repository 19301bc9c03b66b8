"""Shared helpers for the benchmark modules."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class BenchRow:
    """One measured figure.

    ``value`` is the measured number in ``unit``; ``target`` the goal from the issue
    (None if only reported); ``higher_is_better`` says which way the target goes.
    """

    area: str
    name: str
    value: float
    unit: str
    target: float | None = None
    higher_is_better: bool = True
    detail: str = ""
    target_max: float | None = None  # with ``target``: the value must lie in [target, target_max] (a coverage band)

    @property
    def passed(self) -> bool | None:
        if self.target is None:
            return None
        if self.target_max is not None:
            return self.target <= self.value <= self.target_max
        return self.value >= self.target if self.higher_is_better else self.value <= self.target

    def as_dict(self) -> dict:
        d = asdict(self)
        d["passed"] = self.passed
        return d


def best_time(fn, *, repeat: int = 5, min_time: float = 0.0) -> float:
    """Best wall time (s) of ``fn()`` over ``repeat`` runs (runs at least once more if under ``min_time``)."""
    best = float("inf")
    total = 0.0
    i = 0
    while i < repeat or total < min_time:
        t0 = time.perf_counter()
        fn()
        dt = time.perf_counter() - t0
        best = min(best, dt)
        total += dt
        i += 1
        if i > 1000:
            break
    return best


#: z of the two-sided 90 % interval of a normal distribution.
Z90 = 1.6448536269514722


@dataclass
class CoverageScore:
    """Running tally of how often ``estimate +- Z90 std`` covers the truth (the calibration benchmarks).

    ``add(err, std)`` takes errors (estimate - truth) and the printed stds (broadcast to the errors; non-finite or
    non-positive stds skipped); ``coverage`` is the share of covered samples, ``rms_z`` the RMS of err/std,
    ``pit_shares`` the PIT = Phi(err/std) decile shares, ``by_draw`` the coverage of each ``add`` call, ``rms_error``
    the RMS of the errors themselves.
    """

    inside: int = 0
    n: int = 0
    z2: float = 0.0
    e2: float = 0.0
    pit: np.ndarray = field(default_factory=lambda: np.zeros(10))
    by_draw: list = field(default_factory=list)

    def add(self, err, std):
        from scipy.special import ndtr

        err = np.asarray(err, dtype=float)
        std = np.broadcast_to(np.asarray(std, dtype=float), err.shape)
        ok = np.isfinite(err) & np.isfinite(std) & (std > 0)
        if not ok.any():
            return
        z = err[ok] / std[ok]
        inside = int(np.sum(np.abs(z) <= Z90))
        self.inside += inside
        self.n += int(ok.sum())
        self.z2 += float(np.sum(z * z))
        self.e2 += float(np.sum(err[ok] ** 2))
        self.pit += np.bincount(np.minimum((ndtr(z) * 10).astype(int), 9), minlength=10)
        self.by_draw.append(inside / ok.sum())

    @property
    def coverage(self):
        return self.inside / self.n if self.n else float("nan")

    @property
    def rms_z(self):
        return float(np.sqrt(self.z2 / self.n)) if self.n else float("nan")

    @property
    def rms_error(self):
        return float(np.sqrt(self.e2 / self.n)) if self.n else float("nan")

    @property
    def pit_shares(self):
        return self.pit / max(self.pit.sum(), 1)

    def detail(self) -> str:
        """The calibration rows' detail: target, per-draw spread, RMS z, PIT deciles and sample count."""
        byd = 100 * np.array(self.by_draw)
        return (f"target 85-95 %; per draw min {byd.min():.0f} / median {np.median(byd):.0f} / max {byd.max():.0f} %; "
                f"RMS z {self.rms_z:.2f}; PIT deciles {' '.join(f'{100 * p:.0f}' for p in self.pit_shares)} %; "
                f"n = {self.n}")


def cli_wall_time(args: list[str], outputs: list[Path], *, repeat: int, warm: bool = True) -> tuple[float, float]:
    """Best wall time (s) of ``longprofile *args -o outputs[k]`` in a fresh process, and the load average before.

    Run k writes ``outputs[k]`` (one per run: the commands refuse to overwrite); run 0 is untimed when ``warm``
    (it fills the compiled cache if needed), so ``outputs`` needs ``repeat + 1`` paths.
    """
    exe = Path(sys.executable).parent / "longprofile"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    load = os.getloadavg()[0]
    best = float("inf")
    for k in range(0 if warm else 1, repeat + 1):
        t0 = time.perf_counter()
        proc = subprocess.run([str(exe), *args, "-o", str(outputs[k])], env=env, capture_output=True, text=True,
                              timeout=600)
        dt = time.perf_counter() - t0
        if proc.returncode != 0:
            raise RuntimeError(f"longprofile {' '.join(args)} failed (exit {proc.returncode}): {proc.stderr[-1500:]}")
        if k:
            best = min(best, dt)
    return best, load
