"""Shared helpers for the benchmark modules."""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass


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
