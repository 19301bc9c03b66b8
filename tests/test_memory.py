"""The memory settings of the processes longprofile owns (longprofile._memory): applied by the command, not by import."""

import os
import subprocess
import sys

import pytest

_PROBE = """
import sys
import numpy as np
from longprofile import _memory
{action}
before = np._core.multiarray._set_madvise_hugepage(True)  # returns the setting it replaces
print(_memory.memory_status(), before)
"""


def _probe(action: str, **env) -> list[str]:
    out = subprocess.run([sys.executable, "-c", _PROBE.format(action=action)], capture_output=True, text=True,
                         env={**os.environ, **env}, check=True, timeout=120)
    return out.stdout.splitlines()[-1].split()


def test_importing_the_library_changes_nothing():
    assert _probe("import longprofile.road, longprofile.io") == ["None", "True"]


def test_the_command_tunes_its_process():
    status, hugepages = _probe("from longprofile.cli.app import main\nmain(['--version'])")
    expected = "tuned" if os.confstr("CS_GNU_LIBC_VERSION") else "unsupported"
    assert (status, hugepages) == (expected, "False")


@pytest.mark.parametrize("value", ["0", "off"])
def test_the_tuning_can_be_switched_off(value):
    assert _probe("from longprofile.cli.app import main\nmain(['--version'])",
                  LONGPROFILE_MALLOC_TUNING=value) == ["disabled", "True"]
