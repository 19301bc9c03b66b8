"""Filter designs of scipy.signal, kept on disk so that a later process need not import scipy.signal.

``filter_design("butter", 2, 0.01, btype="highpass", fs=20.0, output="sos")`` returns exactly what
``scipy.signal.butter(2, 0.01, btype="highpass", fs=20.0, output="sos")`` returns (same values to the bit, same
types). The first call with these arguments imports scipy.signal, calls it and stores the result; later calls, in
this or any later process, read it back (a few tens of microseconds) without importing scipy.signal, whose import
costs a command 0.35-0.7 s of start-up (issue 12). The design math stays scipy's: nothing here computes a filter.

Where: ``$LONGPROFILE_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/longprofile``, else ``~/.cache/longprofile``;
one small JSON file per call in its ``filter-design/`` folder, written atomically (a temporary file, then
``os.replace``: safe when processes of a pool store the same design at once). Any folder may be deleted at any time.

The key of a call is the function's name, every argument written exactly (``repr`` of floats, which round-trips;
arrays by dtype, shape and bytes; the type of each argument too: ``2`` and ``2.0`` are two keys), scipy's and
numpy's versions, the machine and the SIMD level numpy dispatches to (ASSUMPTION, named: with the same versions
and the same instruction set the design functions return the same bits; a cache folder shared by machines of
different CPUs gets one entry per kind of CPU). The file repeats the key and a SHA-256 of its values; a file that
does not parse, has another key, another checksum, a wrong shape or a non-finite value is ignored and rewritten.
A cache that cannot be read or written (no home, read-only folder, full disk) is never an error: the design is
computed with scipy.signal, as without a cache. A call that emits a warning, returns anything but float64 /
complex128 arrays and finite scalars, or has an argument of another type (e.g. a callable) is not stored.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import warnings
from pathlib import Path

import numpy as np

from ..errors import InputError, LongprofileError

__all__ = ["filter_design", "DESIGN_FUNCTIONS", "design_cache_dir"]

#: The scipy.signal functions :func:`filter_design` calls: filter designs and conversions between their forms.
DESIGN_FUNCTIONS = ("butter", "cheby1", "cheby2", "ellip", "bessel", "iirfilter", "bilinear", "bilinear_zpk",
                    "tf2sos", "zpk2sos", "zpk2tf", "tf2zpk", "sos2zpk", "sos2tf", "lp2hp_zpk", "lp2lp_zpk")
_FORMAT = 1
_MEMORY: dict[str, object] = {}  # this process's designs by key (read or computed once)
_MEMORY_SIZE = 1024
_ENVIRONMENT: str | None = None


class _Uncacheable(Exception):
    """An argument or result that the cache does not write exactly."""


def design_cache_dir() -> Path | None:
    """Folder of the cached designs (see the module notes), or None when no home folder can be found."""
    root = os.environ.get("LONGPROFILE_CACHE_DIR")
    if not root:
        xdg = os.environ.get("XDG_CACHE_HOME")
        try:
            base = Path(xdg) if xdg else Path.home() / ".cache"
        except (RuntimeError, KeyError):  # no home directory
            return None
        root = base / "longprofile"
    return Path(root) / "filter-design"


def _environment() -> str:
    """scipy's and numpy's versions, the machine and numpy's dispatched SIMD targets (part of every key)."""
    global _ENVIRONMENT
    if _ENVIRONMENT is None:
        import scipy

        try:
            from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

            simd = ",".join(f for f in __cpu_dispatch__ if __cpu_features__.get(f))
        except ImportError:  # pragma: no cover - another numpy layout: the versions and machine still key it
            simd = "?"
        machine = os.uname().machine if hasattr(os, "uname") else os.environ.get("PROCESSOR_ARCHITECTURE", "?")
        _ENVIRONMENT = f"scipy {scipy.__version__} numpy {np.__version__} {machine} simd {simd}"
    return _ENVIRONMENT


def _canonical(obj) -> str:
    """An exact text of one argument (type included); :class:`_Uncacheable` for anything else."""
    if obj is None or type(obj) in (bool, str):  # exact types: a subclass may write itself otherwise
        return repr(obj)
    if type(obj) in (int, float, complex):
        return f"{type(obj).__name__}:{obj!r}"
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind not in "biufc" or obj.dtype.hasobject:
            raise _Uncacheable
        return f"ndarray:{obj.dtype.str}:{obj.shape}:{np.ascontiguousarray(obj).tobytes().hex()}"
    if isinstance(obj, np.generic):
        return _canonical(np.asarray(obj)).replace("ndarray", "scalar", 1)
    if type(obj) in (list, tuple):
        return f"{type(obj).__name__}[{', '.join(_canonical(v) for v in obj)}]"
    raise _Uncacheable


def _call_key(name: str, args: tuple, kwargs: dict) -> str:
    """The cache key of ``scipy.signal.<name>(*args, **kwargs)`` in this environment."""
    text = ", ".join([_canonical(a) for a in args] + [f"{k}={_canonical(kwargs[k])}" for k in sorted(kwargs)])
    return f"scipy.signal.{name}({text}) | {_environment()}"


def _encode(value):
    """JSON form of a result: float64 / complex128 arrays and finite float scalars, exactly (hex floats)."""
    if type(value) is tuple:
        return {"tuple": [_encode(v) for v in value]}
    if type(value) is np.ndarray and value.dtype in (np.float64, np.complex128):
        if not np.all(np.isfinite(value)):
            raise _Uncacheable
        flat = np.ascontiguousarray(value).reshape(-1)
        if value.dtype == np.complex128:
            flat = flat.view(np.float64)
        return {"array": value.dtype.str, "shape": list(value.shape), "values": [float(v).hex() for v in flat]}
    if type(value) in (float, np.float64) and math.isfinite(value):
        return {type(value).__name__: float(value).hex()}
    raise _Uncacheable


def _decode(obj):
    """The result written by :func:`_encode`; ValueError / TypeError / KeyError on anything else."""
    if "tuple" in obj:
        return tuple(_decode(v) for v in obj["tuple"])
    if "array" in obj:
        dtype = np.dtype(obj["array"])
        shape = tuple(int(n) for n in obj["shape"])
        if dtype not in (np.float64, np.complex128):
            raise ValueError("dtype")
        flat = np.array([float.fromhex(v) for v in obj["values"]], dtype=np.float64)
        if dtype == np.complex128:
            if flat.size % 2:
                raise ValueError("an odd number of parts for complex values")
            flat = flat.view(np.complex128)
        if flat.size != math.prod(shape) or not np.all(np.isfinite(flat)):
            raise ValueError("shape or non-finite values")
        return flat.reshape(shape)
    (kind, text), = obj.items()
    value = float.fromhex(text)
    if kind not in ("float", "float64") or not math.isfinite(value):
        raise ValueError("scalar")
    return value if kind == "float" else np.float64(value)


def _digest(result_json) -> str:
    return hashlib.sha256(json.dumps(result_json, sort_keys=True).encode()).hexdigest()


def _path(key: str, name: str) -> Path | None:
    folder = design_cache_dir()
    return None if folder is None else folder / f"{name}-{hashlib.sha256(key.encode()).hexdigest()[:32]}.json"


def _read(path: Path, key: str):
    """The stored result of ``key`` at ``path``, or None (missing, unreadable, corrupt, another key)."""
    try:
        stored = json.loads(path.read_text(encoding="utf-8"))
        if stored.get("format") != _FORMAT or stored.get("call") != key or _digest(stored["result"]) != stored.get(
                "sha256"):
            return None
        return _decode(stored["result"])
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return None


def _write(path: Path, key: str, result) -> None:
    """Store ``result`` atomically; any failure (unwritable folder, full disk, uncacheable result) is ignored."""
    from .._atomic import atomic_write_bytes

    try:
        encoded = _encode(result)
        text = json.dumps({"format": _FORMAT, "call": key, "result": encoded, "sha256": _digest(encoded)})
        atomic_write_bytes(path, text.encode("utf-8"))
    except (_Uncacheable, OSError, LongprofileError):  # a cache never fails its caller
        pass


def _copy(result):
    """A fresh copy (callers may modify what they get, as with scipy's own fresh arrays)."""
    if isinstance(result, tuple):
        return tuple(_copy(v) for v in result)
    return result.copy() if isinstance(result, np.ndarray) else result


def _compute(name: str, args: tuple, kwargs: dict):
    """``scipy.signal.<name>(*args, **kwargs)`` and whether it emitted a warning (warnings re-issued as they came)."""
    import scipy.signal

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = getattr(scipy.signal, name)(*args, **kwargs)
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
    return result, bool(caught)


def filter_design(name: str, *args, **kwargs):
    """``scipy.signal.<name>(*args, **kwargs)`` for a filter design function, from the on-disk cache when possible.

    Parameters
    ----------
    name : str
        One of :data:`DESIGN_FUNCTIONS` (e.g. ``"butter"``, ``"bilinear"``, ``"tf2sos"``, ``"zpk2sos"``).
    *args, **kwargs
        The function's arguments exactly as scipy.signal takes them (frequencies in Hz with ``fs=`` in Hz, or
        normalised, as scipy defines them).

    Returns
    -------
    The function's result, bit for bit and of the same types: e.g. an (S, 6) float64 array of second-order
    sections for ``output="sos"``, a tuple ``(b, a)`` of float64 arrays for ``bilinear``, ``(z, p, k)`` with
    complex128 arrays for ``output="zpk"``. Arrays are fresh copies.

    Notes
    -----
    Cache location, key and validation: see the module notes (:mod:`longprofile.statespace._design_cache`).
    Errors of scipy (bad arguments) are raised as scipy raises them, on every call (nothing is stored).
    """
    if name not in DESIGN_FUNCTIONS:
        raise InputError(f"filter_design calls one of {', '.join(DESIGN_FUNCTIONS)}; got {name!r}.")
    try:
        key = _call_key(name, args, kwargs)
    except _Uncacheable:
        return _compute(name, args, kwargs)[0]
    if key in _MEMORY:
        return _copy(_MEMORY[key])
    path = _path(key, name)
    result = None if path is None else _read(path, key)
    if result is None:
        result, warned = _compute(name, args, kwargs)
        if warned:
            return result
        if path is not None:
            _write(path, key, result)
    if len(_MEMORY) >= _MEMORY_SIZE:  # a loop over many distinct designs (perturbed instruments) stays bounded
        _MEMORY.clear()
    _MEMORY[key] = _copy(result)
    return result
