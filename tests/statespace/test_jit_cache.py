"""The digest-keyed numba disk cache of ``longprofile._jit``.

Each case runs fresh interpreters on a throw-away package holding a copy of ``_jit.py`` (the module
keys the package it sits in), so the real package's cache is never touched.
"""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import longprofile._jit as jit

_CALLER = """\
{import_line}
from .callee import callee


@njit(cache=True)
def caller(x):
    return callee(x) + 0.0
"""
_CALLEE = """\
{import_line}


@njit
def callee(x):
    return {value}.0 * x
"""
_PROBE = """\
import json
from pkg.caller import caller
out = {{"value": caller(1.0), "path": caller._cache.cache_path, "hits": sum(caller.stats.cache_hits.values())}}
try:
    from pkg._jit import source_digest
    out["digest"] = source_digest()
except ImportError:
    out["digest"] = None
print(json.dumps(out))
"""


def _make_package(root: Path, ours: bool, value: int = 1) -> Path:
    pkg = root / "pkg"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    if ours:
        shutil.copy(jit.__file__, pkg / "_jit.py")
    line = "from ._jit import njit" if ours else "from numba import njit"
    (pkg / "caller.py").write_text(_CALLER.format(import_line=line))
    _write_callee(pkg, ours, value)
    return pkg


def _write_callee(pkg: Path, ours: bool, value: int) -> None:
    line = "from ._jit import njit" if ours else "from numba import njit"
    (pkg / "callee.py").write_text(_CALLEE.format(import_line=line, value=value))


def _probe(root: Path, cache_dir: Path | None = None) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CACHE")}
    env.update(PYTHONPATH=str(root), PYTHONDONTWRITEBYTECODE="1", OPENBLAS_NUM_THREADS="1")
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = str(cache_dir)
    run = subprocess.run([sys.executable, "-c", _PROBE.format()], env=env, cwd=root, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.strip().splitlines()[-1])


def test_cache_goes_to_digest_directory_and_is_reused(tmp_path):
    pkg = _make_package(tmp_path, ours=True)
    first = _probe(tmp_path)
    assert first["value"] == 1.0 and first["hits"] == 0
    expected = pkg / "__pycache__" / f"numba-{first['digest']}"
    assert Path(first["path"]) == expected
    assert list(expected.glob("caller.caller-*.nbi")) and list(expected.glob("caller.caller-*.nbc"))
    assert not list((pkg / "__pycache__").glob("*.nbi"))  # nothing at numba's default place
    second = _probe(tmp_path)
    assert second["digest"] == first["digest"] and second["hits"] == 1  # warm: loaded, not recompiled


def test_numba_cache_dir_is_honoured(tmp_path):
    _make_package(tmp_path, ours=True)
    cache_dir = tmp_path / "user-cache"
    out = _probe(tmp_path, cache_dir=cache_dir)
    assert Path(out["path"]) == cache_dir / f"pkg-{out['digest']}"
    assert list(Path(out["path"]).glob("caller.caller-*.nbi"))


def test_editing_a_callee_in_another_file_recompiles_the_caller(tmp_path):
    pkg = _make_package(tmp_path, ours=True, value=1)
    before = _probe(tmp_path)
    assert before["value"] == 1.0
    _write_callee(pkg, ours=True, value=2)
    after = _probe(tmp_path)
    assert after["digest"] != before["digest"]
    assert after["value"] == 2.0 and after["hits"] == 0


def test_plain_numba_cache_loads_a_stale_callee(tmp_path):
    """What the digest fixes: plain ``cache=True`` keeps the caller's machine code after a callee edit."""
    pkg = _make_package(tmp_path, ours=False, value=1)
    assert _probe(tmp_path)["value"] == 1.0
    _write_callee(pkg, ours=False, value=2)
    after = _probe(tmp_path)
    if after["value"] == 2.0:
        pytest.skip("this numba version tracks callees itself")
    assert after["value"] == 1.0 and after["hits"] == 1


def test_digest_is_stable_across_processes(monkeypatch):
    code = "from longprofile._jit import source_digest; print(source_digest())"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    runs = [subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True,
                           timeout=120).stdout.strip() for _ in range(2)]
    monkeypatch.setattr(jit, "_DIGEST", None)  # recompute now (this process may have hashed older sources)
    assert runs[0] == runs[1] == jit.source_digest()
    assert len(runs[0]) == 16


def test_digest_covers_every_kernel_file():
    files = [rel for rel, _ in jit._kernel_files()]
    assert "_jit.py" in files and "statespace/_linalg_kernels.py" in files and "statespace/_kernels.py" in files
    assert "statespace/_kalman.py" not in files  # no numba there: editing it keeps the cache


def test_only_package_files_are_claimed():
    assert jit._in_package(os.path.join(os.path.dirname(jit.__file__), "statespace", "_kernels.py")) == "statespace"
    assert jit._in_package(os.path.abspath("elsewhere.py")) is None


def test_engine_kernels_use_the_digest_cache():
    from longprofile.statespace import _linalg_kernels

    assert Path(_linalg_kernels.at._cache.cache_path) == Path(jit.cache_root()) / "statespace"


def test_concurrent_saves_of_two_overloads_never_pair_a_key_with_the_other_code(tmp_path):
    """Two processes saving different overloads of one function from the same (stale) view of the index: numba's
    numbered data files put both in ``.1.nbc`` (the key kept by the index can then load the other's code); the
    package's per-key data files keep each overload in its own file."""
    from numba.core.caching import IndexDataCacheFile

    from longprofile._jit import _KeyedCacheFile

    def two_writers(cls):
        a, b = (cls(cache_path=str(tmp_path / cls.__name__), filename_base="f-1.py311", source_stamp=(1.0, 10))
                for _ in range(2))
        (tmp_path / cls.__name__).mkdir()
        stale = a._load_index()  # both read the index before either saved: the race
        a._load_index = b._load_index = lambda: dict(stale)
        a.save("key-A", "code-A")
        b.save("key-B", "code-B")
        del a._load_index
        return a

    numbered = two_writers(IndexDataCacheFile)
    assert numbered._load_index()["key-B"].endswith(".1.nbc")
    assert numbered._load_data(numbered._data_name(1)) == "code-B"  # key-A's file now holds key-B's code
    keyed = two_writers(_KeyedCacheFile)
    assert keyed.load("key-B") == "code-B"  # the index entry that survived loads its own code
    assert keyed._load_data(keyed._keyed_name("key-A")) == "code-A"  # and the other overload was not overwritten
    assert keyed._keyed_name("key-A") != keyed._keyed_name("key-B")


def test_cached_package_functions_use_per_key_data_files():
    from longprofile._jit import _KeyedCacheFile, njit

    @njit(cache=True)
    def add_one(x):
        return x + 1

    assert isinstance(add_one._cache._cache_file, _KeyedCacheFile)
    assert add_one(1) == 2


# ---- closures of one factory compiled by different processes (the planar EKF's per-vehicle model functions) ----

_FACTORY = """\
{import_line}
import numpy as np


def make(a):
    p = np.array([float(a)])

    @njit(cache=True)
    def f(x):
        y = np.empty(2)
        y[0] = p[0] * x
        y[1] = -p[0]
        return y

    return f
"""
_USE = """\
import json, sys
from pkg.factory import make
out = {{}}
for a in sys.argv[1:]:
    f = make(int(a))
    out[a] = f(1.0).tolist()
    del f  # the first closure goes; the second must keep its own code and environment
print(json.dumps(out))
"""


def _use(root: Path, *values) -> tuple[int, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CACHE")}
    env.update(PYTHONPATH=str(root), PYTHONDONTWRITEBYTECODE="1", OPENBLAS_NUM_THREADS="1")
    run = subprocess.run([sys.executable, "-c", _USE.format(), *map(str, values)], env=env, cwd=root,
                         capture_output=True, text=True, timeout=300)
    return run.returncode, run.stdout.strip().splitlines()[-1] if run.returncode == 0 else run.stderr


def _closure_package(root: Path, ours: bool) -> Path:
    pkg = root / "pkg"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    if ours:
        shutil.copy(jit.__file__, pkg / "_jit.py")
    (pkg / "factory.py").write_text(_FACTORY.format(import_line="from ._jit import njit" if ours
                                                    else "from numba import njit"))
    return pkg


def _closure_symbols(root: Path) -> list[set]:
    """The environment symbols of the closure ``f`` in each cached data file under ``root`` (one set per file)."""
    import re

    out = []
    for path in sorted(root.rglob("*.nbc")):
        if "make.locals.f" in path.name:
            out.append(set(re.findall(rb"NumbaEnv3pkg7factory4make12_3clocals_3e[0-9]+f[A-Za-z0-9_]*?B[0-9]+v[0-9]+B",
                                      path.read_bytes())))
    return out


@pytest.mark.parametrize("ours", [False, True], ids=["numba's cache", "longprofile._jit"])
def test_closures_cached_by_different_processes_get_symbols_of_their_own(ours, tmp_path):
    """Two fresh processes each compile one variant of a closure. numba numbers functions per process, so both
    variants get the same symbol names (the hazard: a process loading both may resolve the second's references to
    the first's code or environment -- seen on the planar EKF closures of two vehicles, a crash 'descr is NULL'
    and, earlier, silently wrong estimates). ``_jit`` names each cached closure after the values it captures."""
    _closure_package(tmp_path, ours)
    assert _use(tmp_path, 1)[0] == 0 and _use(tmp_path, 2)[0] == 0  # each variant compiled in its own process
    symbols = _closure_symbols(tmp_path)
    assert len(symbols) == 2 and all(symbols), symbols
    if ours:
        assert not (symbols[0] & symbols[1]), symbols  # no symbol shared between the two variants
        code, out = _use(tmp_path, 1, 2)  # both loaded from the cache in one process
        assert code == 0, out
        assert json.loads(out) == {"1": [1.0, -1.0], "2": [2.0, -2.0]}
    else:  # numba's own naming (this fails if numba changes it: then _tag_closure may go)
        assert symbols[0] == symbols[1], symbols
