"""Filtering by cascaded second-order sections: causal (:func:`sos_filter`) and zero-phase (:func:`sos_filtfilt`).

The engine's counterpart of ``scipy.signal.sosfilt`` / ``sosfilt_zi`` / ``sosfiltfilt(padtype="odd")`` along
axis 0 (time first), written after scipy's algorithm (the reference: scipy/signal/_signaltools.py, _sosfilt.pyx)
in the same floating-point operations, so the outputs are bit for bit scipy's (tested with ``np.array_equal``
against scipy.signal, the oracle). Why not call scipy.signal: importing it costs a command 0.35-0.7 s of
start-up (it imports scipy.stats, scipy.interpolate, scipy.spatial ...; issue 12), and the recursion is a filter
loop, which lives in the engine. Filter *designs* (Butterworth, bilinear transform, zpk2sos) still come from
scipy.signal, through the on-disk cache :func:`filter_design`.

Section layout (scipy's): ``sos[s] = [b0, b1, b2, a0, a1, a2]`` with ``a0 = 1``; H(z) = prod_s B_s(z) / A_s(z).
Only real float64 coefficients and samples.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError, ShapeError

__all__ = ["sos_filter", "sos_filtfilt", "sos_filter_zi"]


def _check_sos(sos) -> np.ndarray:
    """``sos`` as a finite float64 (S, 6) array with a0 = 1 (scipy's rule)."""
    try:
        arr = np.asarray(sos, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"sos must be a real numeric (n_sections, 6) array; got {type(sos).__name__} ({exc}).") \
            from None
    if arr.ndim == 1 and arr.shape[0] == 6:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 6 or arr.shape[0] == 0:
        raise ShapeError(f"sos must have shape (n_sections, 6) with n_sections >= 1; got {arr.shape}.")
    if not np.all(np.isfinite(arr)):
        raise InputError("sos must be finite.")
    if not np.all(arr[:, 3] == 1):
        raise InputError("sos[:, 3] (a0 of every section) must be 1; normalise each section by its a0.")
    return arr


def _check_samples(x) -> np.ndarray:
    """``x`` as a float64 array with at least one axis (time first); non-finite samples are left to propagate."""
    if np.iscomplexobj(x):
        raise InputError("x must be real; complex samples are not supported.")
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"x must be a real numeric array; got {type(x).__name__} ({exc}).") from None
    if arr.ndim == 0:
        raise ShapeError("x must have at least one axis (time first); got a scalar.")
    return arr


def _run(sos: np.ndarray, x: np.ndarray, zi: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The cascade on checked arrays: x (T, ...), zi (S, 2, ...) or None (rest) -> y (T, ...), final state.

    The outputs have the memory layout of scipy's (time the last axis of a C-ordered buffer, returned as a view with
    time first): numpy's reductions of a result, downstream, then sum in scipy's order too (a layout changes the
    order of a pairwise sum, hence its last bits)."""
    from ._sos_kernels import sos_cascade

    n_s = sos.shape[0]
    tail = x.shape[1:]
    n_k = int(np.prod(tail, dtype=np.int64))
    rows = np.array(np.moveaxis(x, 0, -1).reshape(n_k, x.shape[0]), dtype=np.float64, order="C")  # (K, T), a copy
    if zi is None:
        state = np.zeros((n_k, n_s, 2))
    else:  # (S, 2, ...) -> (..., S, 2) -> (K, S, 2), a copy: zi is not modified
        state = np.ascontiguousarray(np.moveaxis(zi, (0, 1), (-2, -1)).reshape(n_k, n_s, 2)).copy()
    sos_cascade(np.ascontiguousarray(sos), rows, state)
    y = np.moveaxis(rows.reshape(tail + (x.shape[0],)), -1, 0)
    return y, np.moveaxis(state.reshape(tail + (n_s, 2)), (-2, -1), (0, 1))


def sos_filter(sos, x, *, zi=None):
    """Filter ``x`` along axis 0 by the second-order sections ``sos`` (causal): ``scipy.signal.sosfilt(sos, x,
    axis=0, zi=zi)``, bit for bit.

    Parameters
    ----------
    sos : (S, 6) array_like
        Second-order sections ``[b0, b1, b2, 1, a1, a2]`` (scipy's layout), finite, real.
    x : (T, ...) array_like
        Samples, time first (any unit; the output has the same unit times the filter's gain). Non-finite samples
        propagate through the recursion as in scipy.
    zi : (S, 2, ...) array_like, optional
        Initial state of each section's two delays, shaped as scipy's ``zi`` for ``axis=0``: ``(S, 2) +
        x.shape[1:]`` (e.g. ``sos_filter_zi(sos)[:, :, None] * x[0]`` for a steady start on a step of height
        ``x[0]``). Default: rest (zeros).

    Returns
    -------
    y : (T, ...) ndarray
        The filtered samples (float64, the shape of ``x``).
    zf : (S, 2, ...) ndarray
        Only when ``zi`` is given (as scipy): the final state, shaped like ``zi``, to carry on over the next block.
    """
    sos = _check_sos(sos)
    arr = _check_samples(x)
    if zi is None:
        return _run(sos, arr, None)[0]
    state = np.asarray(zi, dtype=np.float64)
    want = (sos.shape[0], 2) + arr.shape[1:]
    if state.shape != want:
        raise ShapeError(f"zi must have shape (n_sections, 2) + x.shape[1:] = {want}; got {state.shape}.")
    return _run(sos, arr, state)


def sos_filter_zi(sos) -> np.ndarray:
    """Initial state (S, 2) of :func:`sos_filter` in the steady state of a unit step: ``scipy.signal.sosfilt_zi``.

    Section by section (scipy's construction): the steady state of section s under a constant input is the
    solution of ``(I - A_s^T) z = b_s[1:] - a_s[1:] b_s[0]`` with A_s the companion matrix of its denominator, times
    the DC gain of the sections before it (the product of ``sum(b) / sum(a)``). Solved with numpy as scipy does, so
    the values are bit for bit scipy's. Dimensionless (per unit of the step).
    """
    sos = _check_sos(sos)
    return _steady_state(sos)


def _steady_state(sos: np.ndarray) -> np.ndarray:
    """:func:`sos_filter_zi` on checked sections."""
    zi = np.empty((sos.shape[0], 2))
    scale = 1.0
    for s in range(sos.shape[0]):
        b = sos[s, :3]
        a = sos[s, 3:]
        companion = np.zeros((2, 2))
        companion[0, :] = -a[1:] / (1.0 * a[0:1])
        companion[1, 0] = 1.0
        lhs = np.eye(2) - companion.T
        rhs = b[1:] - a[1:] * b[0]
        zi[s] = scale * np.linalg.solve(lhs, rhs)
        scale *= np.sum(b) / np.sum(a)
    return zi


def _default_padlen(sos: np.ndarray) -> int:
    """scipy's default pad of ``sosfiltfilt``: 3 x (2 S + 1 - the sections' trailing zero coefficients)."""
    ntaps = 2 * sos.shape[0] + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    return 3 * ntaps


def _odd_extension(x: np.ndarray, n: int) -> np.ndarray:
    """``x`` with ``n`` samples reflected about each end point (``2 x[0] - x[n:0:-1]`` before, likewise after)."""
    if n == 0:
        return x
    left = 2 * x[:1] - x[n:0:-1]
    right = 2 * x[-1:] - x[-2:-(n + 2):-1]
    return np.concatenate((left, x, right), axis=0)


def sos_filtfilt(sos, x, *, padlen: int | None = None) -> np.ndarray:
    """Zero-phase filtering of ``x`` along axis 0: forward, then backward, by the sections ``sos`` —
    ``scipy.signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=padlen)``, bit for bit.

    The record is extended by ``padlen`` samples at each end by odd (point) reflection about its end samples;
    each pass starts in the steady state of a step at its first sample (:func:`sos_filter_zi`); the extension is
    then cut off. The gain is |H|^2, the phase zero.

    Parameters
    ----------
    sos : (S, 6) array_like
        Second-order sections (see :func:`sos_filter`).
    x : (T, ...) array_like
        Samples, time first.
    padlen : int, optional
        Samples of odd extension at each end, 0 <= padlen < T; default scipy's ``3 * (2 S + 1 - min(number of
        sections with b2 = 0, number with a2 = 0))``.

    Returns
    -------
    (T, ...) ndarray
        The filtered samples (float64).
    """
    sos = _check_sos(sos)
    arr = _check_samples(x)
    edge = _default_padlen(sos) if padlen is None else int(padlen)
    if padlen is not None and (edge != padlen or edge < 0):
        raise InputError(f"padlen must be a non-negative integer; got {padlen!r}.")
    if arr.shape[0] <= edge:
        raise ShapeError(f"x needs more samples than padlen = {edge} along axis 0; got {arr.shape[0]}.")
    ext = _odd_extension(arr, edge)
    zi = _steady_state(sos).reshape((sos.shape[0], 2) + (1,) * (arr.ndim - 1))
    y = _run(sos, ext, zi * ext[:1])[0]
    y = _run(sos, y[::-1], zi * y[-1:])[0][::-1]
    return y[edge:-edge] if edge > 0 else y  # a view, as scipy's (see _run)
