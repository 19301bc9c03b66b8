"""``longprofile.statespace`` loads its submodules lazily (PEP 562): a light import stays light."""

import json
import os
import subprocess
import sys

import longprofile.statespace as ss

_PROBE = """\
import json, sys
from longprofile.statespace import linear_recursion
print(json.dumps(sorted(m for m in sys.modules if m.startswith(("longprofile", "scipy.signal", "scipy.stats",
                                                                "scipy.optimize")))))
"""


def test_linear_recursion_alone_loads_no_filter_module_nor_scipy_signal():
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, check=True,
                         timeout=120)
    loaded = set(json.loads(out.stdout.strip().splitlines()[-1]))
    assert "longprofile.statespace._propagate" in loaded
    for name in ("_ekf", "_block_ekf", "_steady", "_fixed_lag", "_mle", "_observer", "_kalman"):
        assert f"longprofile.statespace.{name}" not in loaded
    assert not {m for m in loaded if m.startswith(("scipy.signal", "scipy.stats", "scipy.optimize"))}


def test_every_public_name_resolves_and_is_listed():
    assert set(ss._LAZY) == set(ss.__all__)
    for name in ss.__all__:
        assert getattr(ss, name).__name__ == name
    assert set(ss.__all__) <= set(dir(ss))
