"""filter_design: scipy.signal's designs, exactly, from an on-disk cache that never fails its caller.

Every test points ``LONGPROFILE_CACHE_DIR`` at its own temporary folder and empties the per-process memo, so each
call below either reads that folder or calls scipy.signal.
"""

import json
import warnings

import numpy as np
import pytest
import scipy.signal as ss

from longprofile.errors import InputError
from longprofile.statespace import _design_cache as dc
from longprofile.statespace import filter_design

CALLS = [
    ("butter", (2, 0.01), {"btype": "highpass", "fs": 20.0, "output": "sos"}),
    ("butter", (1, 100.0), {"btype": "low", "fs": 1000.0, "output": "sos"}),
    ("butter", (2, 9.42477796076938), {"btype": "low", "analog": True, "output": "zpk"}),
    ("butter", (5, [0.1, 0.3]), {"btype": "bandpass", "output": "sos"}),
    ("bilinear", ([355.3057584392169], [1.0, 15.079644737231007, 355.3057584392169]), {"fs": 1000.0}),
    ("tf2sos", ([1.0, 2.0, 1.0], [1.0, -0.5, 0.25]), {}),
    ("zpk2sos", (np.array([0.5 + 0.5j, 0.5 - 0.5j, 1.0]), np.array([0.3 + 0.1j, 0.3 - 0.1j, 0.9]), 0.25),
     {"pairing": "nearest"}),
]


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("LONGPROFILE_CACHE_DIR", str(folder))
    monkeypatch.setattr(dc, "_MEMORY", {})
    return folder / "filter-design"


def _same(a, b) -> bool:
    """Equal to the bit, same types (and dtypes), element by element for tuples."""
    if isinstance(a, tuple):
        return isinstance(b, tuple) and len(a) == len(b) and all(_same(u, v) for u, v in zip(a, b))
    if type(a) is not type(b):
        return False
    if isinstance(a, np.ndarray):
        return (a.dtype == b.dtype and a.shape == b.shape and a.strides == b.strides and np.array_equal(a, b)
                and all(np.array_equal(np.signbit(part(a)), np.signbit(part(b))) for part in (np.real, np.imag)))
    return a == b


def _forget(monkeypatch):
    """A new process, as far as the cache can tell: empty memo, and scipy.signal unreachable."""
    monkeypatch.setattr(dc, "_MEMORY", {})

    def no_scipy(*args):
        raise AssertionError("scipy.signal called although the design is on disk")

    monkeypatch.setattr(dc, "_compute", no_scipy)


@pytest.mark.parametrize("name,args,kwargs", CALLS, ids=[c[0] for c in CALLS])
def test_returns_exactly_scipys_result_then_reads_it_back(cache, monkeypatch, name, args, kwargs):
    want = getattr(ss, name)(*args, **kwargs)
    first = filter_design(name, *args, **kwargs)
    assert _same(first, want)
    assert len(list(cache.glob(f"{name}-*.json"))) == 1
    _forget(monkeypatch)
    assert _same(filter_design(name, *args, **kwargs), want)
    assert _same(filter_design(name, *args, **kwargs), want)  # from the memo


def test_results_are_fresh_copies(cache):
    a = filter_design("butter", 2, 0.2, output="sos")
    a[:] = 0.0
    assert np.array_equal(filter_design("butter", 2, 0.2, output="sos"), ss.butter(2, 0.2, output="sos"))


@pytest.mark.parametrize("damage", ["garbage", "empty", "value", "shape", "nan", "dtype", "key", "checksum"])
def test_a_corrupt_file_is_ignored_and_rewritten(cache, monkeypatch, damage):
    want = ss.butter(2, 0.01, btype="highpass", fs=20.0, output="sos")
    filter_design("butter", 2, 0.01, btype="highpass", fs=20.0, output="sos")
    (path,) = cache.glob("butter-*.json")
    stored = json.loads(path.read_text())
    res = stored["result"]
    if damage == "garbage":
        path.write_bytes(b"\x00{not json")
    elif damage == "empty":
        path.write_text("")
    else:
        if damage == "value":  # a changed number under the old checksum
            res["values"][0] = (2.0).hex()
        elif damage == "shape":
            res["shape"] = [2, 6]
        elif damage == "nan":
            res["values"][1] = "nan"
        elif damage == "dtype":
            res["array"] = "<i8"
        elif damage == "key":
            stored["call"] = stored["call"].replace("0.01", "0.02")
        elif damage == "checksum":
            stored["sha256"] = "0" * 64
        if damage in ("shape", "nan", "dtype"):  # checksum recomputed: the value checks must catch it
            stored["sha256"] = dc._digest(res)
        path.write_text(json.dumps(stored))
    monkeypatch.setattr(dc, "_MEMORY", {})
    assert _same(filter_design("butter", 2, 0.01, btype="highpass", fs=20.0, output="sos"), want)
    _forget(monkeypatch)  # the file was rewritten whole
    assert _same(filter_design("butter", 2, 0.01, btype="highpass", fs=20.0, output="sos"), want)


def test_an_unwritable_or_impossible_folder_only_costs_the_cache(tmp_path, monkeypatch):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("LONGPROFILE_CACHE_DIR", str(blocker / "cache"))  # its parent is a file: mkdir fails
    monkeypatch.setattr(dc, "_MEMORY", {})
    want = ss.butter(3, 0.1, output="sos")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _same(filter_design("butter", 3, 0.1, output="sos"), want)
        monkeypatch.setattr(dc, "_MEMORY", {})
        assert _same(filter_design("butter", 3, 0.1, output="sos"), want)
    assert blocker.read_text() == "not a folder"


def test_no_home_folder_only_costs_the_cache(monkeypatch):
    for var in ("LONGPROFILE_CACHE_DIR", "XDG_CACHE_HOME", "HOME"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setattr(dc.Path, "home", classmethod(lambda cls: (_ for _ in ()).throw(RuntimeError("no home"))))
    monkeypatch.setattr(dc, "_MEMORY", {})
    assert dc.design_cache_dir() is None
    assert _same(filter_design("butter", 2, 0.3, output="sos"), ss.butter(2, 0.3, output="sos"))


def test_cache_folder_precedence(tmp_path, monkeypatch):
    monkeypatch.setenv("LONGPROFILE_CACHE_DIR", str(tmp_path / "a"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "b"))
    assert dc.design_cache_dir() == tmp_path / "a" / "filter-design"
    monkeypatch.delenv("LONGPROFILE_CACHE_DIR")
    assert dc.design_cache_dir() == tmp_path / "b" / "longprofile" / "filter-design"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert dc.design_cache_dir() == tmp_path / "home" / ".cache" / "longprofile" / "filter-design"


def test_the_key_changes_with_every_argument_and_the_environment(monkeypatch):
    base = ("butter", (2, 0.01), {"btype": "highpass", "fs": 20.0, "output": "sos"})
    variants = [
        ("cheby1", (2, 0.01), base[2]),
        ("butter", (3, 0.01), base[2]),
        ("butter", (2.0, 0.01), base[2]),  # same value, another type
        ("butter", (2, np.nextafter(0.01, 1.0)), base[2]),  # one ulp
        ("butter", (2, np.float64(0.01)), base[2]),
        ("butter", (2, 0.01), {**base[2], "btype": "lowpass"}),
        ("butter", (2, 0.01), {**base[2], "fs": np.nextafter(20.0, 0.0)}),
        ("butter", (2, 0.01), {**base[2], "output": "zpk"}),
        ("butter", (2, 0.01), {**base[2], "analog": False}),
        ("butter", (2, [0.01]), base[2]),
        ("butter", (2, (0.01,)), base[2]),
        ("butter", (2, np.array([0.01])), base[2]),
        ("butter", (2, np.array([0.01], dtype=np.float32)), base[2]),
    ]
    key = dc._call_key(*base)
    keys = [dc._call_key(*v) for v in variants]
    assert key not in keys and len(set(keys)) == len(keys)
    assert dc._call_key(*base) == key
    arr = np.array([0.5 + 0.5j, 0.5 - 0.5j])
    bumped = arr.copy()
    bumped[1] = complex(0.5, np.nextafter(-0.5, 0.0))
    assert dc._call_key("zpk2sos", (arr, arr, 1.0), {}) != dc._call_key("zpk2sos", (arr, bumped, 1.0), {})
    monkeypatch.setattr(dc, "_ENVIRONMENT", dc._environment().replace("scipy ", "scipy 0.0.0-"))
    assert dc._call_key(*base) != key


def test_a_warning_is_passed_on_and_the_call_not_stored(cache):
    b, a = [1e-20, 1.0], [1.0, 0.5]
    with pytest.warns(ss.BadCoefficients):
        want = ss.tf2zpk(b, a)
    with pytest.warns(ss.BadCoefficients):
        got = filter_design("tf2zpk", b, a)
    assert _same(got, want)
    assert not list(cache.glob("*.json")) if cache.exists() else True


def test_scipys_errors_pass_and_unknown_functions_are_refused(cache):
    with pytest.raises(ValueError):
        filter_design("butter", 2, 1.5, output="sos")  # digital cut-off above Nyquist: scipy's own error
    with pytest.raises(InputError, match="filter_design"):
        filter_design("sosfilt", [[1, 0, 0, 1, 0, 0]], [1.0])
    with pytest.raises(dc._Uncacheable):
        dc._canonical(object())
    # an argument the key cannot write exactly: computed by scipy, nothing stored
    assert _same(filter_design("butter", 2, 0.2, output="sos", btype=_Low()), ss.butter(2, 0.2, output="sos"))
    assert not cache.exists() or not list(cache.glob("*.json"))


class _Low(str):
    """A str subclass scipy accepts for ``btype`` (not a plain str, so the key refuses it)."""

    def __new__(cls):
        return super().__new__(cls, "low")

    def __repr__(self):  # pragma: no cover - only to show that its text is not trusted
        return "'low'"
