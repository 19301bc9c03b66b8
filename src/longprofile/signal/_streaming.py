"""Streaming (block-by-block) polynomial differentiator with O(1) work per sample (paper 002 "recursive")."""

from __future__ import annotations

from math import comb

import numpy as np

from .._validation import as_float_array, require_positive
from ..errors import InputError, ShapeError
from . import _coefficients as _coef
from ._kernels import moment_filter_kernel

__all__ = ["StreamingDerivative"]

_DESIGNS = {
    "ml": _coef._ml_design,
    "polyfit": _coef._polyfit_design,
    "backward": _coef._ml_design,  # N = d: the backward difference of Table 1a
}


class StreamingDerivative:
    r"""Causal polynomial differentiator fed block by block, O(degree^2) work per sample.

    Parameters
    ----------
    dt : float
        Sample interval (s).
    window : int
        N, the number of past samples (for ``method="backward"`` it must equal ``degree``).
    degree : int, default 2
        Motion-model degree d (N >= d).
    order : int, default 1
        Derivative order (1 <= order <= degree).
    method : {"ml", "polyfit", "backward"}, default "ml"
        Which taps (see :func:`derivative_ml`, :func:`derivative_polyfit`,
        :func:`derivative_backward`).
    refresh : int, optional
        Recompute the running moments exactly from the ring buffer every
        ``refresh`` samples (default N + 1, i.e. once per window: amortised
        d + 1 extra multiply-adds per sample). Must be >= 1.

    Notes
    -----
    The taps are polynomials in the lag, h[n] = sum_j c_j n^j (n >= 1), so
    y[k] = h[0] x[k] + sum_j c_j S_j[k] with running moments
    S_j[k] = sum_{n=1}^{N} n^j x[k-n], updated by
    S_j[k+1] = sum_{i<=j} C(j,i) (S_i[k] + [i=0] x[k] - N^i x[k-N]): the
    recursive form of the paper's estimators. That recursion is marginally
    stable (round-off grows like k^(d+1)), hence the periodic exact
    recomputation; samples are stored relative to the first finite sample so a
    large offset costs no precision. The state (ring buffer of N samples,
    d + 1 moments) is all that is kept between blocks, so the output does not
    depend on how the stream is cut into blocks. A NaN sample makes the next
    N + 1 outputs NaN, then the moments are recomputed and estimation resumes.
    The first N outputs are NaN (no full window).

    Examples
    --------
    >>> import numpy as np
    >>> est = StreamingDerivative(0.5, window=4, degree=1)
    >>> a = est.update(np.arange(3.0))
    >>> b = est.update(np.arange(3.0, 8.0))
    >>> np.round(np.concatenate([a, b]), 12).tolist()
    [nan, nan, nan, nan, 2.0, 2.0, 2.0, 2.0]
    """

    def __init__(self, dt: float, *, window: int | None = None, degree: int = 2, order: int = 1, method: str = "ml",
                 refresh: int | None = None, **others):
        if others:
            hint = (" (the Kalman differentiator is batch only: derivative(x, dt, method='kalman', ...))"
                    if method == "kalman" or "q_over_r" in others else "")
            raise InputError(f"StreamingDerivative does not take {', '.join(sorted(others))}; it takes dt, window, "
                             f"degree, order, method ({', '.join(sorted(_DESIGNS))}) and refresh{hint}.")
        if window is None:
            raise InputError("StreamingDerivative needs window=N (past samples per estimate), e.g. window=45.")
        self.dt = require_positive("dt", dt)
        if method not in _DESIGNS:
            batch = " (the Kalman differentiator is batch only: derivative(x, dt, method='kalman', ...))"
            raise InputError(f"method must be one of {sorted(_DESIGNS)} for streaming; got {method!r}"
                             f"{batch if method == 'kalman' else ''}.")
        window, degree, _ = _coef._check_design(window, degree, 1)
        order = _coef._check_int("order", order, 1)
        if order > degree:
            raise InputError(f"order must be <= degree ({degree}); got order={order}.")
        if method == "backward" and window != degree:
            raise InputError(f"the backward difference of order n uses window = n; got window={window}, "
                             f"degree={degree}. Use method='ml' for window > degree.")
        if refresh is None:
            refresh = window + 1
        self.refresh = _coef._check_int("refresh", refresh, 1)
        self.window, self.degree, self.order, self.method = window, degree, order, method
        h0, c = _DESIGNS[method](window, degree, order)
        self._taps = _coef._float_taps(h0, c, window)
        scale = self.dt ** order
        self._c = np.array([[float(cj) / scale for cj in c]])
        self._h0 = np.array([float(h0) / scale])
        self._gain = np.zeros(1)  # differentiators have zero static gain
        self._binom = np.array([[comb(j, i) for i in range(degree + 1)] for j in range(degree + 1)], dtype=float)
        self._npow = np.array([float(window) ** i for i in range(degree + 1)])
        self._n_channels: int | None = None
        self._vector = False

    @property
    def noise_gain(self) -> float:
        """sqrt(sum h^2) / dt**order: times the white-noise std of the samples, the std of every derivative estimate
        (the batch estimators' ``std="noise"``, the same taps). The total std of the batch estimators (their default,
        with the plug-in bias of a degree-(d+1) companion over 4 windows) is not streamed."""
        return float(np.sqrt(float(_coef.variance_gain(self._taps)))) / self.dt ** self.order

    def reset(self) -> None:
        """Forget the past: the next sample starts a new stream."""
        self._n_channels = None

    @property
    def n_seen(self) -> int:
        """Number of samples consumed since construction or :meth:`reset`."""
        return 0 if self._n_channels is None else int(self._n_seen[0])

    def _allocate(self, n_channels: int) -> None:
        w, d = self.window, self.degree
        self._n_channels = n_channels
        self._ring = np.zeros((n_channels, w))
        self._pos = np.zeros(n_channels, np.int64)
        self._sums = np.zeros((n_channels, d + 1))
        self._n_seen = np.zeros(n_channels, np.int64)
        self._last_nan = np.full(n_channels, -(1 << 62), np.int64)
        self._since = np.zeros(n_channels, np.int64)
        self._ref = np.zeros(n_channels)
        self._ref_set = np.zeros(n_channels, np.int64)

    def update(self, block) -> np.ndarray:
        """Consume the next samples and return their derivative estimates.

        Parameters
        ----------
        block : (T,) or (T, C) array_like
            The next T samples (of C channels); the shape after the first axis
            must stay the same for the whole stream.

        Returns
        -------
        ndarray, same shape as ``block``
            Derivative of order ``order`` (units of x per s**order); NaN until a
            full window of N + 1 samples is available and while a NaN is in it.
        """
        arr = as_float_array("block", block, ndim=(1, 2))
        vector = arr.ndim == 1
        n_channels = 1 if vector else arr.shape[1]
        if self._n_channels is None:
            self._allocate(n_channels)
            self._vector = vector
        elif n_channels != self._n_channels or vector != self._vector:
            raise ShapeError(f"block must keep the stream's shape (T,) if 1-D else (T, {self._n_channels}); "
                             f"got {arr.shape}. Call reset() to start a new stream.")
        series = np.ascontiguousarray(arr.reshape(arr.shape[0], n_channels).T)
        out = np.empty((1, n_channels, arr.shape[0]))
        moment_filter_kernel(series, self.window, self.degree, self._c, self._h0, self._gain,
                             np.zeros((1, n_channels)), self._binom,
                             self._npow, self.refresh, self._ring, self._pos, self._sums, self._n_seen,
                             self._last_nan, self._since, self._ref, self._ref_set, out)
        res = out[0].T
        return res[:, 0].copy() if vector else np.ascontiguousarray(res)
