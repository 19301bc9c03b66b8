"""``njit``: numba's ``njit`` with a disk cache keyed by the sources of every kernel file (private).

numba's own ``cache=True`` checks only the source file of the cached function itself: after editing a
jitted *callee* in another file (a shared linear-algebra helper, a model function), the caller's cached
machine code is still loaded, with the old callee compiled into it. Here every cached function of the
package goes to a directory named after a digest of the source text of every ``.py`` file of the
package that uses numba (imports ``numba`` or this module)::

    <package>/__pycache__/numba-<digest>/<subpackage path>/<numba's usual .nbi/.nbc files>

so any edit of any kernel file selects a new, empty directory and everything recompiles; nothing stale
can be loaded and nothing has to be deleted by hand (directories of old digests are never read again
and may be removed at any time). When the package folder is not writable the same layout goes under
``$NUMBA_CACHE_DIR`` if set, else under numba's user-wide cache directory, as numba's own locators do.

Usage, in any module of the package: ``from longprofile._jit import njit`` (relative:
``from .._jit import njit``), then ``@njit``, ``@njit(cache=True, fastmath=True)``,
``njit(cache=True)(fn)`` exactly as with ``numba.njit``. The locator is registered when this module
is imported and only claims files inside this module's package (the folder holding this file).
The digest is computed once per process, at the first cached function, in a few milliseconds.

This module imports nothing from the package (so a copy of it in another folder keys that folder's
package instead, which is how ``tests/statespace/test_jit_cache.py`` exercises it).

Caveat (as with plain numba): a module-level *value* read by a kernel (numba freezes globals at
compile time) is covered only when it is defined in a file that uses numba.
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path

import numba
from numba.core import caching as _caching
from numba.core import config as _numba_config
from numba.misc.appdirs import AppDirs

__all__ = ["njit", "source_digest", "cache_root"]

_PACKAGE_DIR = os.path.dirname(os.path.realpath(__file__))
_USES_NUMBA = re.compile(rb"^[ \t]*(?:import[ \t]+numba\b|from[ \t]+numba\b|from[ \t]+[.\w]*_jit[ \t]+import\b"
                         rb"|import[ \t]+[.\w]*_jit\b|from[ \t]+[.\w]+[ \t]+import[ \t]+[^\n]*\b_jit\b)",
                         re.MULTILINE)
_DIGEST: str | None = None


def _kernel_files(package_dir: str = _PACKAGE_DIR) -> list[str]:
    """Sorted (relative "/"-separated path, source bytes) of the package's ``.py`` files that use numba."""
    found = []
    for folder, dirs, files in os.walk(package_dir):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__" and not d.startswith("."))
        for name in files:
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                with open(path, "rb") as fh:
                    text = fh.read()
                if (b"numba" in text or b"_jit" in text) and _USES_NUMBA.search(text):
                    found.append((os.path.relpath(path, package_dir).replace(os.sep, "/"), text))
    found.sort()
    return found


def source_digest() -> str:
    """sha256[:16] of the (relative path, source text) of every package file that uses numba.

    Computed once per process (at the first call), so all cached functions of one process agree.
    """
    global _DIGEST
    if _DIGEST is None:
        h = hashlib.sha256()
        for rel, text in _kernel_files():
            h.update(rel.encode())
            h.update(b"\0")
            h.update(hashlib.sha256(text).digest())
        _DIGEST = h.hexdigest()[:16]
    return _DIGEST


def cache_root() -> str:
    """The in-tree cache directory of this process: ``<package>/__pycache__/numba-<digest>``."""
    return os.path.join(_PACKAGE_DIR, "__pycache__", f"numba-{source_digest()}")


def _in_package(py_file: str) -> str | None:
    """The folder of ``py_file`` relative to the package ('' for the package itself), or None if outside."""
    try:
        path = os.path.realpath(py_file)
    except (OSError, ValueError):
        return None
    if not path.startswith(_PACKAGE_DIR + os.sep):
        return None
    return os.path.relpath(os.path.dirname(path), _PACKAGE_DIR)


class _DigestLocatorBase(_caching._SourceFileBackedLocatorMixin, _caching._CacheLocator):
    """Cache locator of the package's files: one directory per digest of all kernel sources."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        rel = _in_package(py_file)
        self._cache_path = os.path.join(self._base(), rel) if rel not in (None, ".") else self._base()

    def get_cache_path(self):
        return self._cache_path

    @classmethod
    def from_function(cls, py_func, py_file):
        if _in_package(py_file) is None or not os.path.exists(py_file):
            return None
        return super().from_function(py_func, py_file)


class _InTreeDigestLocator(_DigestLocatorBase):
    """``<package>/__pycache__/numba-<digest>/<subpackage>/`` (writable source tree)."""

    @staticmethod
    def _base():
        return cache_root()

    @classmethod
    def from_function(cls, py_func, py_file):
        if _numba_config.CACHE_DIR:  # the user asked for a cache folder: honour it (next locator)
            return None
        return super().from_function(py_func, py_file)


class _UserDigestLocator(_DigestLocatorBase):
    """``$NUMBA_CACHE_DIR`` or numba's user-wide cache: ``<dir>/<package>-<digest>/<subpackage>/``."""

    @staticmethod
    def _base():
        root = _numba_config.CACHE_DIR or AppDirs(appname="numba", appauthor=False).user_cache_dir
        return os.path.join(root, f"{Path(_PACKAGE_DIR).name}-{source_digest()}")


def _register() -> None:
    impl = getattr(_caching, "CacheImpl", None) or _caching._CacheImpl  # older numba: _CacheImpl
    classes = impl._locator_classes
    for cls in (_UserDigestLocator, _InTreeDigestLocator):  # final order: in-tree, then user-wide
        if cls not in classes:
            classes.insert(0, cls)


_register()


class _KeyedCacheFile(_caching.IndexDataCacheFile):
    """numba's index + data cache files, with one data file per index key.

    numba numbers a function's data files 1, 2, ... in the order its overloads are saved, from the index as the
    saving process last read it. Two processes that compile different overloads of one function at the same time
    (process-pool workers, parallel test runs) both pick ``.1.nbc``: the index keeps one key, the data file holds
    the other process's code, and every later process loads that wrong machine code for the key (seen on the
    planar EKF closures of two vehicles: silently wrong estimates). Here a data file is named after a hash of its
    key, so a file only ever holds the overload of its own key; a save racing another one can at worst drop an
    index entry (a recompile later), never pair a key with another key's code. The data is written before the index
    names it.
    """

    def _keyed_name(self, key) -> str:
        tag = hashlib.sha256(repr(key).encode()).hexdigest()[:16]
        return self._data_name_pattern.replace("{number:d}", tag)

    def save(self, key, data):
        data_name = self._keyed_name(key)
        self._save_data(data_name, data)
        overloads = self._load_index()
        if overloads.get(key) != data_name:
            overloads[key] = data_name
            self._save_index(overloads)


def _keyed_cache(dispatcher):
    """Give a caching dispatcher the per-key data files of :class:`_KeyedCacheFile`."""
    cache = getattr(dispatcher, "_cache", None)
    old = getattr(cache, "_cache_file", None)
    if isinstance(old, _caching.IndexDataCacheFile) and not isinstance(old, _KeyedCacheFile):
        new = _KeyedCacheFile.__new__(_KeyedCacheFile)
        new.__dict__.update(old.__dict__)
        cache._cache_file = new
    return dispatcher


def _tag_closure(fn):
    """Rename a closure after the values it captures, so each cached variant has symbols of its own.

    numba names compiled symbols (the function, its Python wrapper, its environment) after the qualified name
    plus a counter that is per process. Two variants of one factory's closure (the planar EKF model of two
    vehicles) compiled by two processes can get the same counter: their cached machine code then defines the same
    symbols, and a process loading both resolves the second one's references to the first's (seen: the EKF of
    one vehicle run with another vehicle's environment, a crash "NRT_adapt_ndarray_to_python: descr is NULL"
    or, earlier, silently wrong estimates). A qualified name ending in a digest of the captured values (what
    numba keys the cache on, ``serialize.dumps`` of the cells) makes the symbols of different variants differ;
    numba's cache files are then one index per variant too.
    """
    cells = getattr(fn, "__closure__", None)
    if not cells or not callable(fn):
        return fn
    try:
        from numba.core.serialize import dumps

        data = dumps(tuple(c.cell_contents for c in cells))
    except Exception:  # an uncacheable closure: numba itself will say so
        return fn
    fn.__qualname__ = f"{fn.__qualname__}_v{hashlib.sha256(data).hexdigest()[:12]}"
    return fn


def njit(*args, **kwargs):
    """``numba.njit`` (same arguments, bare ``@njit`` too); ``cache=True`` uses the digest-keyed cache, with one
    data file per compiled overload (:class:`_KeyedCacheFile`: safe when several processes compile at once), and
    closures named after the values they capture (:func:`_tag_closure`). Signatures given to the decorator are
    compiled eagerly by numba, before the per-key files apply; the package passes none."""
    if not kwargs.get("cache"):
        return numba.njit(*args, **kwargs)
    if args and callable(args[0]):
        return _keyed_cache(numba.njit(_tag_closure(args[0]), *args[1:], **kwargs))
    out = numba.njit(*args, **kwargs)
    return lambda fn: _keyed_cache(out(_tag_closure(fn)))
