"""Where the tests find ``../shared/reference-data`` (external data with known answers; see each SOURCE.md).

Looked for, in order: ``$LONGPROFILE_REFERENCE_DATA``; ``<repository>/../shared/reference-data``; and, for a
clone of a local checkout (``git clone /work/main "$(mktemp -d)"``), the same folder beside the repository it
was cloned from. When none exists, a test asking for a file is skipped with the places looked at printed
(``-ra``), the way the PostgreSQL tests skip without a server.
"""

from __future__ import annotations

import functools
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@functools.lru_cache(maxsize=1)
def _candidates() -> tuple[Path, ...]:
    found = []
    if os.environ.get("LONGPROFILE_REFERENCE_DATA"):
        found.append(Path(os.environ["LONGPROFILE_REFERENCE_DATA"]))
    found.append(ROOT.parent / "shared" / "reference-data")
    try:
        origin = subprocess.run(["git", "-C", str(ROOT), "config", "--get", "remote.origin.url"],
                                capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        origin = ""
    if origin and "://" not in origin and ":" not in origin.split("/")[0] and Path(origin).is_dir():
        found.append(Path(origin).resolve().parent / "shared" / "reference-data")
    return tuple(found)


def reference_file(*parts: str) -> Path:
    """Path of a reference-data file (e.g. ``reference_file("sorel-iri-profile", "profile_1.txt")``); skips if absent."""
    for base in _candidates():
        path = base.joinpath(*parts)
        if path.exists():
            return path
    pytest.skip(f"reference data {'/'.join(parts)} not found in {[str(c) for c in _candidates()]} "
                "(set LONGPROFILE_REFERENCE_DATA to the reference-data folder)")
