"""Fingerprints of arrays for "unchanged output" tests that must survive the last bits.

A sha256 of the bytes fails on a difference in the last bit, and the last bits move between a process that compiles
numba's kernels and one that loads them from the disk cache (docs/architecture.md, Known debts), or between BLAS
builds: a fresh clone in CI compiles. A fingerprint keeps, per array, its shape, the positions of its NaNs and three
weighted sums (fixed pseudo-random weights), so any change beyond round-off (one value off by 1e-9 relative of the
array's scale) fails the comparison, and round-off does not.
"""

from __future__ import annotations

import hashlib

import numpy as np


def fingerprint(arrays: dict) -> dict:
    """``{name: (shape, sha256 of the NaN mask (16 hex), [sum of w_j * a for 3 weight vectors w_j], sum of |a|)}``
    (NaN counted as 0 in the sums)."""
    out = {}
    for name in sorted(arrays):
        a = np.asarray(arrays[name], dtype=float)
        nan = np.isnan(a)
        finite = np.where(nan, 0.0, a)
        w = np.random.default_rng(12345).uniform(0.5, 1.5, (3,) + a.shape)
        sums = [float(np.sum(finite * wj)) for wj in w]
        out[name] = (list(a.shape), hashlib.sha256(np.packbits(nan).tobytes()).hexdigest()[:16], sums,
                     float(np.sum(np.abs(finite))))
    return out


def assert_same_fingerprint(got: dict, expected: dict, *, rtol: float = 1e-9) -> None:
    """Shapes and NaN masks equal; each weighted sum within ``rtol`` x 1.5 x (sum of |values|) of the expected one."""
    assert sorted(got) == sorted(expected)
    for name in expected:
        shape, mask, sums, scale = expected[name]
        g_shape, g_mask, g_sums, _ = got[name]
        assert list(g_shape) == list(shape), name
        assert g_mask == mask, name
        assert np.all(np.abs(np.subtract(g_sums, sums)) <= rtol * 1.5 * scale), (name, g_sums, sums)
