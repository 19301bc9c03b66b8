"""Small survey networks for the batch tests, and picklable tasks that misbehave on purpose."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

from longprofile.batch import IRITask

#: Gd(n0) of the synthetic routes, m^3: good, fair and poor roads (ISO 8608 classes A..C).
ROUGHNESS = (2e-6, 6e-6, 20e-6)


def make_network(folder: Path, n: int = 5, *, length: float = 400.0, dx: float = 0.1, corrupt: bool = True) -> list[Path]:
    """``n`` two-track profiles (ERD, Parquet and CSV in turn) in two route folders, plus two corrupt files."""
    from longprofile.io import write_profile
    from longprofile.road import iso8608_profile

    files = []
    for i in range(n):
        p = iso8608_profile(length + 100.0 * (i % 3), dx, ROUGHNESS[i % 3], rng=i, tracks=("left", "right"))
        f = folder / f"R{i % 2 + 1}" / f"lane{i}.{('erd', 'parquet', 'csv')[i % 3]}"
        f.parent.mkdir(parents=True, exist_ok=True)
        files.append(write_profile(p, f, units="mm"))
    if corrupt:
        good = files[0].read_text()
        truncated = folder / "R1" / "truncated.erd"
        truncated.write_text(good[: len(good) // 2].rsplit("\n", 1)[0] + "\n")
        garbage = folder / "R2" / "garbage.csv"
        garbage.write_bytes(b"\x00\x01 not a table \xff\xfe\n,,,\n")
        files += [truncated, garbage]
    return sorted(files)


@dataclass(frozen=True)
class FailOnFlag(IRITask):
    """IRITask that raises while ``flag`` exists (a crash in the middle of a batch, switched off by removing it)."""

    flag: str = ""
    victim: str = ""

    def __call__(self, path):
        if self.flag and os.path.exists(self.flag) and Path(path).name == self.victim:
            raise RuntimeError("simulated crash")
        return super().__call__(path)


def boom(path):
    """A plain function that fails on some paths with a non-library error."""
    if "bad" in str(path):
        raise ZeroDivisionError("boom on " + str(path))
    return str(path).upper()


def busy_for_a_minute(path):
    """A worker busy with a long file: writes its pid to ``path`` (atomically), then sleeps 60 s."""
    tmp = f"{path}.tmp"
    Path(tmp).write_text(str(os.getpid()))
    os.replace(tmp, path)
    time.sleep(60.0)


def comparable(frame):
    """A results table without the columns that legitimately differ between runs (timings, clocks)."""
    return frame.drop(columns=[c for c in ("seconds", "finished_utc") if c in frame.columns]).reset_index(drop=True)


def expected_allocator_status() -> str:
    """What ``longprofile._memory.tune_process_memory`` must report in a worker here: tuned on glibc, unless the
    environment disables it."""
    if os.environ.get("LONGPROFILE_MALLOC_TUNING", "").strip().lower() in ("0", "off", "false", "no"):
        return "disabled"
    try:
        return "tuned" if os.confstr("CS_GNU_LIBC_VERSION") else "unsupported"
    except (AttributeError, ValueError, OSError):
        return "unsupported"
