"""``rail serve --demo`` without ``--db`` keeps its database in a temporary folder: gone when the demo stops.

A newcomer who stopped the demo with ``kill`` (SIGTERM) found its folder (the SQLite database) left in /tmp, one
more per run. Now SIGTERM stops the demo as Ctrl-C does, and a folder left by a demo killed with -9 is removed by
the next demo once its owner process is gone.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from longprofile.cli._rail_serve import DEMO_FOLDER_PREFIX, _remove_orphan_demo_folders
from longprofile.rail.service._serve import free_port


def _demo_folders(tmp: Path) -> list[Path]:
    return sorted(tmp.glob(f"{DEMO_FOLDER_PREFIX}*"))


def test_sigterm_stops_the_demo_and_removes_its_temporary_database(tmp_path):
    exe = str(Path(sys.executable).parent / "longprofile")
    env = dict(os.environ, TMPDIR=str(tmp_path), OPENBLAS_NUM_THREADS="1")
    proc = subprocess.Popen([exe, "rail", "serve", "--demo", "--port", str(free_port())], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob(f"{DEMO_FOLDER_PREFIX}*/site.db")):  # the demo has made its database
            assert proc.poll() is None and time.monotonic() < deadline, "the demo did not start"
            time.sleep(0.2)
        assert (_demo_folders(tmp_path)[0] / "pid").read_text() == str(proc.pid)
        time.sleep(1.0)  # the site is seeded and the replay is under way
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=60)
        print(f"the demo stopped {time.monotonic() - t0:.1f} s after SIGTERM")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert "Traceback" not in out, out
    assert _demo_folders(tmp_path) == [], "the demo's temporary database was left behind"


def test_a_folder_left_by_a_killed_demo_is_removed_once_its_owner_is_gone(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()  # reaped: its pid names no process (pids are not reused this quickly)
    orphan, alive, foreign = (tmp_path / f"{DEMO_FOLDER_PREFIX}{n}" for n in ("orphan", "alive", "foreign"))
    for folder in (orphan, alive, foreign):
        folder.mkdir()
        (folder / "site.db").write_bytes(b"x")
    (orphan / "pid").write_text(str(dead.pid))
    (alive / "pid").write_text(str(os.getpid()))  # a demo still running
    _remove_orphan_demo_folders(tmp_path)  # foreign: no pid file, not ours to judge
    assert _demo_folders(tmp_path) == sorted([alive, foreign])
