"""Derivative estimators on whole arrays, one calling convention, one registry (paper 002)."""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from math import comb, factorial
from types import MappingProxyType
from typing import Any, Callable, Mapping

import numpy as np

from .._validation import as_float_array, require_positive
from ..errors import InputError, ShapeError
from . import _coefficients as _coef
from ._kernels import moment_filter_kernel
from ._total_std import (
    _SPAN,
    bias_variance,
    check_std,
    kalman_bias_scale,
    kalman_impulse_gains,
    kalman_time_scale,
)

__all__ = [
    "DerivativeResult",
    "DerivativeMethod",
    "DERIVATIVE_METHODS",
    "check_derivative_options",
    "derivative",
    "derivative_ml",
    "derivative_polyfit",
    "derivative_backward",
    "derivative_kalman",
    "estimate_noise_std",
    "kalman_differentiator_model",
]

_IMPLEMENTATIONS = ("recursive", "fir")


@dataclass(frozen=True, eq=False)
class DerivativeResult:
    """Output of every derivative estimator (same type for every method).

    Attributes
    ----------
    value : ndarray, shape of ``x``
        Estimate of the signal itself at each sample (units of ``x``). For
        ``"ml"`` and ``"backward"`` this is x[k] (their model is anchored at the
        newest sample); ``"polyfit"`` and ``"kalman"`` smooth it.
    derivative : ndarray, shape of ``x``
        Estimate of the ``order``-th derivative (units of ``x`` per s**order).
        NaN where the estimator has no full window (the first ``window``
        samples of the FIR methods) or where the window holds a NaN input.
    derivative_std : ndarray, shape of ``x``
        Standard deviation of the error of ``derivative`` (same units). With
        ``std="total"`` (the default) the noise-induced part plus a plug-in
        estimate of the model (bias, lag) error; with ``std="noise"`` the
        noise-induced part only, from the variance gain and the noise standard
        deviation (FIR methods) or the state covariance (Kalman). NaN where
        ``derivative`` is NaN.
    method : str
        The registry name of the estimator.
    params : dict
        Every setting used, including the ``noise_std`` (given or estimated), and ``settled`` = (first, stop): the
        samples whose ``derivative_std`` has settled (outside: the estimator's start-up, the smoother's ends, where
        the band under-covers; docs/signal.md, assumption 3).
    """

    value: np.ndarray
    derivative: np.ndarray
    derivative_std: np.ndarray
    method: str
    params: dict = field(default_factory=dict)


#: A sample farther than this many times the signal's spread from its median leaves the other samples of its windows
#: below double precision's 16 significant digits (their contribution is lost in round-off), and beyond ~1e154 its
#: square overflows: such a value is corrupt (a logger's error code, a unit mix-up), never a signal's.
MAX_DYNAMIC_RANGE = 1e15
#: ... the spread measured on at most this many samples (strided): an O(1) cost next to the estimators'.
_RANGE_SAMPLES = 10_001


# --------------------------------------------------------------------------- helpers
def _prepare(x, dt, axis) -> tuple[np.ndarray, float, int]:
    arr = as_float_array("x", x)
    if arr.ndim == 0:
        raise ShapeError("x must have at least one dimension (the sample axis); got a scalar.")
    dt = require_positive("dt", dt)
    if isinstance(axis, bool) or not isinstance(axis, (int, np.integer)):
        raise InputError(f"axis must be an integer; got {axis!r}.")
    if not -arr.ndim <= axis < arr.ndim:
        raise ShapeError(f"axis {axis} is out of range for x of shape {arr.shape}.")
    _check_dynamic_range(arr)
    return arr, dt, int(axis) % arr.ndim


def _check_dynamic_range(arr: np.ndarray) -> None:
    """Refuse a sample beyond :data:`MAX_DYNAMIC_RANGE` times the signal's spread (the 1-99 % quantile range of a
    strided subsample of all its finite values) from its median, or beyond 1e150 in magnitude (its square overflows).
    A signal whose subsample does not vary (spread 0) is only checked for overflow. Two reductions over ``x``, no copy
    (one more to name the sample when refusing)."""
    flat = arr.ravel()
    if flat.size == 0:
        return
    top, bottom = float(np.fmax.reduce(flat)), float(np.fmin.reduce(flat))  # NaN only when every sample is NaN
    if not (np.isfinite(top) and np.isfinite(bottom)):
        return  # infinities are the estimators' own error (they say which sample); NaN are gaps
    sub = flat[:: max(1, flat.size // _RANGE_SAMPLES)]
    sub = sub[np.isfinite(sub)]
    lo, mid, hi = np.percentile(sub, [1.0, 50.0, 99.0]) if sub.size else (0.0, 0.0, 0.0)
    worst = max(top - mid, mid - bottom)
    if max(top, -bottom) > 1e150 or (hi > lo and worst > MAX_DYNAMIC_RANGE * (hi - lo)):
        k = int(np.nanargmax(np.abs(flat - mid)))
        where = f"sample {k}" if arr.ndim == 1 else f"element {np.unravel_index(k, arr.shape)}"
        with np.errstate(over="ignore"):
            ratio = np.float64(worst) / (hi - lo) if hi > lo else np.inf
        how = (f"{ratio:.3g} times the signal's spread ({hi - lo:.3g}, its 1-99 % range) from its median"
               if ratio > MAX_DYNAMIC_RANGE else "beyond 1e150, whose square overflows")
        raise InputError(f"x: {where} is {flat[k]:.6g}, {how}: a corrupt value (a logger's error code, a unit mix-up); "
                         "remove it or leave it empty (NaN).")


def _to_series(arr: np.ndarray, axis: int) -> tuple[np.ndarray, tuple[int, ...]]:
    moved = np.moveaxis(arr, axis, -1)
    return np.ascontiguousarray(moved.reshape(-1, moved.shape[-1])), moved.shape


def _from_series(series: np.ndarray, moved_shape: tuple[int, ...], axis: int) -> np.ndarray:
    return np.moveaxis(series.reshape(moved_shape), -1, axis)


def estimate_noise_std(x, *, axis: int = 0, difference_order: int = 3):
    r"""Robust estimate of the white-noise standard deviation of a sampled signal.

    Parameters
    ----------
    x : array_like
        Signal, samples along ``axis``; NaN samples are ignored.
    axis : int, default 0
        Sample axis.
    difference_order : int, default 3
        p, the order of the differences used; they cancel any local polynomial
        of degree < p, so the smooth part of a finely sampled signal contributes
        little.

    Returns
    -------
    float or ndarray
        :math:`\hat\sigma = 1.4826\,\mathrm{MAD}(\Delta^p x) / \sqrt{\binom{2p}{p}}`,
        one value per series (a float for 1-D ``x``).

    Raises
    ------
    InputError
        Fewer than ``difference_order + 2`` finite samples in a series.

    Notes
    -----
    Assumes white noise: :math:`\mathrm{Var}[\Delta^p w] = \binom{2p}{p}\sigma^2`.
    The median absolute deviation makes it robust to outliers and steps.
    Over-estimates the noise when the signal itself is rough at the sample scale.
    """
    arr = as_float_array("x", x)
    if arr.ndim == 0:
        raise ShapeError("x must have at least one dimension; got a scalar.")
    p = _coef._check_int("difference_order", difference_order, 1)
    if isinstance(axis, bool) or not isinstance(axis, (int, np.integer)) or not -arr.ndim <= axis < arr.ndim:
        raise ShapeError(f"axis {axis!r} is out of range for x of shape {arr.shape}.")
    series, moved_shape = _to_series(arr, int(axis) % arr.ndim)
    out = np.empty(series.shape[0])
    for i, row in enumerate(series):
        d = np.diff(row, n=p)
        d = d[np.isfinite(d)]
        if d.size < 2:
            raise InputError(f"cannot estimate the noise level: series {i} has {d.size} finite "
                             f"{p}-th differences (needs >= 2 runs of {p + 1} consecutive finite samples); "
                             "give noise_std explicitly.")
        mad = np.median(np.abs(d - np.median(d)))
        out[i] = 1.4826 * mad / np.sqrt(comb(2 * p, p))
    if arr.ndim == 1:
        return float(out[0])
    return out.reshape(moved_shape[:-1])


def _noise_std(noise_std, arr: np.ndarray, axis: int) -> np.ndarray:
    """Noise std broadcast to the series shape (moved shape without the sample axis)."""
    other = tuple(s for i, s in enumerate(arr.shape) if i != axis)
    if noise_std is None:
        est = estimate_noise_std(arr, axis=axis)
        return np.broadcast_to(np.asarray(est, dtype=float), other)
    ns = as_float_array("noise_std", noise_std, allow_nan=False)
    if np.any(ns < 0):
        raise InputError(f"noise_std must be >= 0; got {noise_std!r}.")
    try:
        return np.broadcast_to(ns, other)
    except ValueError:
        raise ShapeError(f"noise_std must be a scalar or broadcast to the non-sample shape {other}; "
                         f"got shape {ns.shape}.") from None


def _check_order(order, upper: int, what: str) -> int:
    order = _coef._check_int("order", order, 1)
    if order > upper:
        raise InputError(f"order must be <= {upper} for {what}; got order={order}.")
    return order


def _check_implementation(implementation) -> str:
    if implementation not in _IMPLEMENTATIONS:
        raise InputError(f"implementation must be one of {_IMPLEMENTATIONS}; got {implementation!r}.")
    return implementation


def _run_fir(series: np.ndarray, window: int, degree: int, outputs, implementation: str,
             refresh: int | None = None) -> list[np.ndarray]:
    """Apply FIR outputs [(h0, c, scale, const)] to series (B, T).

    Output = (taps (h0, c) applied to x) / scale + const (const: (B,) or None), NaN
    where the window is not full or holds a NaN.
    """
    n_series, n_steps = series.shape
    n_out = len(outputs)
    consts = np.zeros((n_out, n_series))
    for o, (_, _, _, const) in enumerate(outputs):
        if const is not None:
            consts[o] = const
    if implementation == "fir":
        from scipy.signal import lfilter

        results = []
        for o, (h0, c, scale, _) in enumerate(outputs):
            taps = _coef._float_taps(h0, c, window) / scale
            y = lfilter(taps, 1.0, series, axis=-1) + consts[o][:, None]
            y[:, :window] = np.nan
            results.append(y)
        return results
    c_arr = np.zeros((n_out, degree + 1))
    h0_arr = np.empty(n_out)
    gain = np.empty(n_out)
    for o, (h0, c, scale, _) in enumerate(outputs):
        c_arr[o] = [float(cj) / scale for cj in c]
        h0_arr[o] = float(h0) / scale
        g = h0 + sum(cj * _coef.power_sum(window, j) for j, cj in enumerate(c))
        gain[o] = float(g) / scale
    binom = np.array([[comb(j, i) for i in range(degree + 1)] for j in range(degree + 1)], dtype=float)
    npow = np.array([float(window) ** i for i in range(degree + 1)])
    refresh = window + 1 if refresh is None else refresh
    out = np.empty((n_out, n_series, n_steps))
    moment_filter_kernel(series, window, degree, c_arr, h0_arr, gain, consts, binom, npow, refresh,
                         np.zeros((n_series, window)), np.zeros(n_series, np.int64),
                         np.zeros((n_series, degree + 1)), np.zeros(n_series, np.int64),
                         np.full(n_series, -(1 << 62), np.int64), np.zeros(n_series, np.int64),
                         np.zeros(n_series), np.zeros(n_series, np.int64), out)
    return [out[o] for o in range(n_out)]


def _fir_bias_var(series, dt, window, degree, order, kind, implementation, noise_var) -> np.ndarray:
    """Plug-in squared bias (B, T) of a degree-d FIR from its difference with the degree-(d+1) estimator.

    The companion is the same kind of fit (``kind`` "ml" or "polyfit") of degree d + 1 on the same window (on
    max(N, d + 1) past samples: N = d + 1 when N = d); ``noise_var`` (B,) the noise variance of the samples.
    """
    design = _coef._polyfit_design if kind == "polyfit" else _coef._ml_design
    h0, c = design(window, degree, order)
    wide = max(window, degree + 1)
    h0_c, c_c = design(wide, degree + 1, order)
    taps = np.zeros(wide + 1)
    taps[:window + 1] = _coef._float_taps(h0, c, window)
    taps -= _coef._float_taps(h0_c, c_c, wide)
    if wide == window:  # a polynomial in the lag: the running-moment kernel (or lfilter) on the same window
        diff_c = tuple(a - b for a, b in zip(tuple(c) + (Fraction(0),), c_c))
        delta = _run_fir(series, window, degree + 1, [(h0 - h0_c, diff_c, dt ** order, None)], implementation)[0]
    else:  # N = d: a handful of taps
        from scipy.signal import lfilter

        delta = lfilter(taps / dt ** order, 1.0, series, axis=-1)
        delta[:, :wide] = np.nan
    return bias_variance(delta, noise_var * float(np.sum(taps ** 2)) / dt ** (2 * order), window + 1, centred=False)


def _fir_result(arr, dt, axis, window, degree, order, value_design, deriv_design, taps_exact, noise_std,
                method, params, implementation, std_option="noise", kind="ml") -> DerivativeResult:
    if arr.shape[axis] < window + 1:
        raise InputError(f"x has {arr.shape[axis]} samples along axis {axis}, fewer than the window of "
                         f"{window + 1} samples (N = {window} past samples + the current one) that one estimate "
                         "needs; use a smaller window or a longer record.")
    series, moved_shape = _to_series(arr, axis)
    ns = _noise_std(noise_std, arr, axis)
    gain = float(_coef.variance_gain(taps_exact))
    std_series = np.ascontiguousarray(np.broadcast_to(ns, moved_shape[:-1])).reshape(-1) * np.sqrt(gain) / dt ** order
    zero = (Fraction(0), (Fraction(0),) * (degree + 1))
    value, deriv, std = _run_fir(series, window, degree,
                                 [(*value_design, 1.0, None), (*deriv_design, dt ** order, None),
                                  (*zero, 1.0, std_series)], implementation)
    if std_option == "total":
        noise_var = np.ascontiguousarray(np.broadcast_to(ns, moved_shape[:-1])).reshape(-1) ** 2
        total = _fir_bias_var(series, dt, window, degree, order, kind, implementation, noise_var)
        total += np.square(std, out=std)  # in place: std is replaced below
        std = np.sqrt(total, out=total)
        params = dict(params, std="total")
    else:
        params = dict(params, std="noise")
    noise_param = float(ns.flat[0]) if ns.size == 1 and np.all(ns == ns.flat[0]) else ns.copy()
    return DerivativeResult(value=_from_series(value, moved_shape, axis),
                            derivative=_from_series(deriv, moved_shape, axis),
                            derivative_std=_from_series(std, moved_shape, axis), method=method,
                            params=dict(params, order=order, noise_std=noise_param,
                                        variance_gain=gain, implementation=implementation,
                                        settled=_settled_fir(arr.shape[axis], window, degree, std_option)))


def _settled_fir(n: int, window: int, degree: int, std_option: str) -> tuple[int, int]:
    """(first, stop) samples whose derivative_std is settled: the first full window on (std="noise"); for "total"
    also the trailing moving mean of the bias term full (its 4 (N + 1) samples after the companion's first)."""
    if std_option != "total":
        return min(window, n), n
    wide = max(window, degree + 1)
    return min(wide + max(int(np.ceil(_SPAN * (window + 1))), 1) - 1, n), n


def _settled_kalman(n: int, dt: float, q_over_r: float, degree: int, smooth: bool) -> tuple[int, int]:
    """(first, stop) samples whose derivative_std is settled: outside the start-up of the filter (its moving mean of
    the bias term, 4 time scales, full) and, for the smoother, outside half of that span at each end."""
    width = max(int(np.ceil(_SPAN * kalman_time_scale(dt, q_over_r, degree))), 1)
    if smooth:
        return min(width // 2, n), max(n - (width - width // 2) + 1, 0)
    return min(width - 1, n), n


# --------------------------------------------------------------------------- estimators
def derivative_ml(x, dt, *, window: int, degree: int = 2, order: int = 1, noise_std=None, axis: int = 0,
                  implementation: str = "recursive", std: str = "total") -> DerivativeResult:
    r"""Maximum-likelihood polynomial differentiator of paper 002 §3 (causal, recursive).

    Parameters
    ----------
    x : array_like
        Signal sampled every ``dt``; samples along ``axis``. NaN = missing (every
        estimate whose window holds a NaN is NaN).
    dt : float
        Sample interval (s).
    window : int
        N, the number of past samples; each estimate uses x[k-N..k] (N+1
        samples, the interval of validity T = N dt of the motion model). N >= degree.
    degree : int, default 2
        Motion model: 1 constant velocity, 2 constant acceleration, 3 constant jerk.
    order : int, default 1
        Derivative order, 1 <= order <= degree.
    noise_std : float or array_like, optional
        Standard deviation of the white measurement noise (units of x), one per
        series or a scalar; estimated with :func:`estimate_noise_std` when None.
        Only used for ``derivative_std``.
    axis : int, default 0
        Sample axis.
    implementation : {"recursive", "fir"}, default "recursive"
        ``"recursive"``: O(degree^2) operations per sample from running moments
        (compiled, independent of N, moments recomputed exactly every N+1
        samples). ``"fir"``: :func:`scipy.signal.lfilter` with the N+1 taps.
        Both give the same numbers to round-off.
    std : {"total", "noise"}, default "total"
        What ``derivative_std`` covers. ``"noise"``: the white-noise part only,
        ``noise_std * sqrt(sum h^2) / dt**order`` (constant; the only std before
        issue 13). ``"total"``: its square plus a plug-in squared bias, the
        moving mean (trailing, 4(N+1) samples) of the squared difference from the
        degree-(d+1) estimate on the same window minus that difference's own
        noise variance (Fan & Gijbels 1996, §3.2-3.3; see docs/signal.md,
        "Calibration"). Estimates are the same for both.

    Returns
    -------
    DerivativeResult
        ``derivative`` NaN on the first ``window`` samples (no full window:
        never extrapolated); ``value`` is x[k] (NaN on the same samples).

    Raises
    ------
    InputError
        window < degree, order outside 1..degree, dt <= 0, infinite samples,
        std not "total" or "noise".

    See Also
    --------
    ml_coefficients, derivative_polyfit, derivative_kalman, StreamingDerivative

    Notes
    -----
    Paper 002 §3, eq. (4) and its constant-acceleration / constant-jerk
    counterparts (eq. 6): least squares on x[k-n] - x[k] = sum_j (-n)^j x^(j)[k] T^j/j! + w,
    n = 1..N. The estimator is ML when x[k] is exact and the past samples are
    noisy; with white noise on *every* sample :func:`derivative_polyfit` has a
    lower variance (see docs/signal.md).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(200) * 0.01
    >>> res = derivative_ml(3.0 * t + 1.0, 0.01, window=10, degree=1, noise_std=0.0)
    >>> bool(np.allclose(res.derivative[10:], 3.0))
    True
    """
    arr, dt, axis = _prepare(x, dt, axis)
    window, degree, _ = _coef._check_design(window, degree, 1)
    order = _check_order(order, degree, f"a degree-{degree} motion model")
    implementation = _check_implementation(implementation)
    std = check_std(std)
    taps = _coef.ml_coefficients(window, degree, order)
    return _fir_result(arr, dt, axis, window, degree, order, _coef._ml_design(window, degree, 0),
                       _coef._ml_design(window, degree, order), taps, noise_std, "ml",
                       {"window": window, "degree": degree}, implementation, std, "ml")


def derivative_polyfit(x, dt, *, window: int, degree: int = 2, order: int = 1, noise_std=None, axis: int = 0,
                       implementation: str = "recursive", std: str = "total") -> DerivativeResult:
    r"""Causal least-squares polynomial fit on the N+1 newest samples (Savitzky-Golay end point).

    Same parameters, returns and errors as :func:`derivative_ml`; ``value`` is the
    fitted (smoothed) signal at the newest sample.

    Notes
    -----
    Least squares on x[k-n] = sum_{j=0}^{d} (-n)^j x^(j)[k] T^j/j! + w, n = 0..N,
    i.e. the paper's model of §3 with x[k] treated as a noisy sample too. Under
    white noise on every sample this is the minimum-variance unbiased linear
    estimator (Gauss-Markov); its taps equal
    ``scipy.signal.savgol_coeffs(N + 1, d, deriv=r, pos=N)`` reversed.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(100) * 0.1
    >>> res = derivative_polyfit(t ** 2, 0.1, window=8, degree=2, noise_std=0.0)
    >>> bool(np.allclose(res.derivative[8:], 2 * t[8:]))
    True
    """
    arr, dt, axis = _prepare(x, dt, axis)
    window, degree, _ = _coef._check_design(window, degree, 1)
    order = _check_order(order, degree, f"a degree-{degree} polynomial")
    implementation = _check_implementation(implementation)
    taps = _coef.polyfit_coefficients(window, degree, order)
    return _fir_result(arr, dt, axis, window, degree, order, _coef._polyfit_design(window, degree, 0),
                       _coef._polyfit_design(window, degree, order), taps, noise_std, "polyfit",
                       {"window": window, "degree": degree}, implementation, check_std(std), "polyfit")


def derivative_backward(x, dt, *, degree: int = 1, order: int = 1, noise_std=None, axis: int = 0,
                        implementation: str = "recursive", std: str = "total") -> DerivativeResult:
    r"""Backward difference of order n = ``degree`` (paper 002 Table 1a, eq. 1 and 3).

    Uses the n+1 samples x[k-n..k]; exact on polynomials of degree <= n; NaN on
    the first n samples. ``value`` is x[k]. Other parameters as :func:`derivative_ml`.

    Notes
    -----
    Identical to :func:`derivative_ml` with ``window = degree`` (the square case
    of §3); kept as its own method because it is the classical reference.

    Examples
    --------
    >>> import numpy as np
    >>> res = derivative_backward(np.arange(5.0) ** 2, 1.0, degree=2, noise_std=0.0)
    >>> res.derivative.tolist()
    [nan, nan, 4.0, 6.0, 8.0]
    """
    arr, dt, axis = _prepare(x, dt, axis)
    degree = _coef._check_int("degree", degree, 1)
    if degree > _coef._MAX_DEGREE:
        raise InputError(f"degree (backward-difference order n) must be <= {_coef._MAX_DEGREE}; got {degree}.")
    order = _check_order(order, degree, f"a backward difference of order {degree}")
    implementation = _check_implementation(implementation)
    taps = _coef.backward_difference_coefficients(degree, order)
    # the ML design with N = d has exactly these taps (tested); it supplies the moment form.
    return _fir_result(arr, dt, axis, degree, degree, order, _coef._ml_design(degree, degree, 0),
                       _coef._ml_design(degree, degree, order), taps, noise_std, "backward",
                       {"window": degree, "degree": degree}, implementation, check_std(std), "ml")


def kalman_differentiator_model(dt: float, *, q_over_r: float, noise_std: float = 1.0, degree: int = 2,
                                initial_mean=None, initial_cov=None):
    r"""State-space model of the Kalman differentiator (paper 002 §2.3), in SI units.

    Parameters
    ----------
    dt : float
        Sample interval (s).
    q_over_r : float
        q/r: variance of the white (degree+1)-th derivative (the jerk for
        ``degree=2``, units of x^2/s^6) over the measurement noise variance
        r (units of x^2); so its unit is s^-(2 degree + 2). The filter gains
        depend only on the dimensionless ``q_over_r * dt**(2 degree + 2)``.
    noise_std : float, default 1.0
        sqrt(r); scales the covariances only.
    degree : int, default 2
        Number of derivatives in the state: 2 gives the paper's model
        (position, velocity, acceleration driven by a random jerk).
    initial_mean : (degree+1,) array_like, optional
        Prior mean of the state at the first sample; zeros when None.
    initial_cov : (degree+1, degree+1) array_like, optional
        Prior covariance; ``1e6 * r * I`` scaled per derivative when None.

    Returns
    -------
    StateSpaceModel
        State (x, x', ..., x^(d)); F the Taylor transition, Q = q G G^T with
        G_i = dt^(d+1-i)/(d+1-i)!, H = (1, 0, ..., 0), R = r.

    Notes
    -----
    For degree 2 this is the paper's model with its state (x, v T, gamma T^2)
    rescaled to (x, v, gamma): X[k+1] = [[1,1,1/2],[0,1,1],[0,0,1]] X[k] + (1/6, 1/2, 1)^T delta T^3.
    """
    from ..statespace import StateSpaceModel

    dt = require_positive("dt", dt)
    q_over_r = require_positive("q_over_r", q_over_r)
    noise_std = require_positive("noise_std", noise_std)
    degree = _coef._check_int("degree", degree, 1)
    if degree > 4:
        raise InputError(f"degree must be <= 4 for the Kalman differentiator; got {degree}.")
    n = degree + 1
    F = np.zeros((n, n))
    for i in range(n):
        for j in range(i, n):
            F[i, j] = dt ** (j - i) / factorial(j - i)
    G = np.array([dt ** (n - i) / factorial(n - i) for i in range(n)])
    r = noise_std ** 2
    Q = q_over_r * r * np.outer(G, G)
    m0 = np.zeros(n) if initial_mean is None else initial_mean
    if initial_cov is None:
        initial_cov = np.diag([1e6 * r / dt ** (2 * i) for i in range(n)])
    return StateSpaceModel(F, np.eye(1, n), Q, [[r]], m0, initial_cov)


def derivative_kalman(x, dt, *, q_over_r: float, degree: int = 2, order: int = 1, noise_std=None,
                      smooth: bool = False, steady_state: bool = False, axis: int = 0,
                      std: str = "total") -> DerivativeResult:
    r"""Kalman differentiator (paper 002 §2.3) on the state-space engine.

    Parameters
    ----------
    x : array_like
        Signal; samples along ``axis``; NaN = missing (handled by the filter).
    dt : float
        Sample interval (s).
    q_over_r : float
        The paper's single tuning parameter: random-jerk variance over
        measurement-noise variance (s^-6 for degree 2); see
        :func:`kalman_differentiator_model`.
    degree : int, default 2
        State (x, x', ..., x^(degree)); 2 is the paper's constant-acceleration /
        random-jerk model.
    order : int, default 1
        Derivative order, 1 <= order <= degree.
    noise_std : float or array_like, optional
        Measurement-noise std, one per series or scalar; estimated with
        :func:`estimate_noise_std` when None. Sets r; only ``derivative_std`` and
        the prior depend on it.
    smooth : bool, default False
        False: causal filter (estimates use samples up to k). True: RTS
        smoother (non-causal, uses the whole record).
    steady_state : bool, default False
        Use the constant (stationary) gains instead of the exact time-varying
        filter: :func:`~longprofile.statespace.steady_state_filter` /
        :func:`~longprofile.statespace.steady_state_smoother`, an LTI recursion
        with O(T) memory for very long records. The first samples (the filter's
        start-up transient) then differ from the exact filter, ``derivative_std``
        is the constant stationary value, and NaN samples are refused (InputError).
    axis : int, default 0
        Sample axis.
    std : {"total", "noise"}, default "total"
        What ``derivative_std`` covers. ``"noise"``: the posterior std of the
        model (the only std before issue 13), which leaves out the lag/bias of
        a mistuned q/r. ``"total"``: its square plus a plug-in squared bias,
        the moving mean (4 time scales; trailing for the filter, centred for
        the smoother) of the squared difference from a companion estimate with
        q/r x 2^(2 degree + 2) (half the time scale) minus that difference's
        own noise variance (variance matching, Mehra 1972; see docs/signal.md,
        "Calibration"). Runs the filter twice. Estimates are the same for both.

    Returns
    -------
    DerivativeResult
        ``value`` the filtered/smoothed signal, ``derivative`` the state
        component ``order``, ``derivative_std`` its posterior std (time-varying,
        large during the start-up transient), with the bias term for
        ``std="total"``.

    Notes
    -----
    Every series is referenced to its first finite sample and filtered from a
    broad prior: mean 0, covariance diag(1e6 r / dt^(2i)) (position within about
    1000 noise std of the first sample, i-th derivative correspondingly), so
    the first few estimates are dominated by the data. Runs
    :func:`longprofile.statespace.kalman_filter` (and
    :func:`~longprofile.statespace.rts_smoother`) on the whole batch of series;
    covariances are stored, so memory is about 200 bytes per sample.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(500) * 0.01
    >>> res = derivative_kalman(np.sin(t), 0.01, q_over_r=1e4, noise_std=1e-3)
    >>> bool(abs(res.derivative[-1] - np.cos(t[-1])) < 1e-2)
    True
    """
    arr, dt, axis = _prepare(x, dt, axis)
    q_over_r = require_positive("q_over_r", q_over_r)
    degree = _coef._check_int("degree", degree, 1)
    if degree > 4:
        raise InputError(f"degree must be <= 4 for the Kalman differentiator; got {degree}.")
    order = _check_order(order, degree, f"a Kalman state of degree {degree}")
    for flag_name, flag in (("smooth", smooth), ("steady_state", steady_state)):
        if not isinstance(flag, (bool, np.bool_)):
            raise InputError(f"{flag_name} must be True or False; got {flag!r}.")
    std_option = check_std(std)
    ns = _noise_std(noise_std, arr, axis)
    if np.any(ns <= 0):
        raise InputError("noise_std must be > 0 for the Kalman differentiator (r = noise_std**2 is the "
                         f"measurement variance); got {noise_std!r} (or an estimate of 0: constant or "
                         "quantised data; give noise_std explicitly).")
    series, moved_shape = _to_series(arr, axis)
    if steady_state and not np.isfinite(series).all():
        k = int(np.flatnonzero(~np.isfinite(series).all(axis=0))[0])
        raise InputError(f"x has a missing sample (NaN) at sample {k} along axis {axis}: the steady-state filter "
                         "cannot skip one; use steady_state=False (the time-varying filter treats it as missing).")
    ns_series = np.ascontiguousarray(np.broadcast_to(ns, moved_shape[:-1])).reshape(-1)
    value = np.empty_like(series)
    deriv = np.empty_like(series)
    std = np.empty_like(series)
    options = dict(dt=dt, degree=degree, order=order, smooth=bool(smooth), steady_state=bool(steady_state))
    # group series by noise level (one model per distinct r; usually one)
    for level in np.unique(ns_series):
        idx = np.nonzero(ns_series == level)[0]
        value[idx], deriv[idx], std[idx] = _kalman_block(series[idx], q_over_r, float(level), **options)
    if std_option == "total":
        std = np.sqrt(_kalman_total_var(series, deriv, std, q_over_r, ns_series, **options))
    noise_param = float(ns.flat[0]) if ns.size == 1 and np.all(ns == ns.flat[0]) else ns.copy()
    return DerivativeResult(
        value=_from_series(value, moved_shape, axis), derivative=_from_series(deriv, moved_shape, axis),
        derivative_std=_from_series(std, moved_shape, axis), method="kalman",
        params={"q_over_r": q_over_r, "degree": degree, "order": order, "noise_std": noise_param,
                "smooth": bool(smooth), "steady_state": bool(steady_state), "std": std_option,
                "settled": _settled_kalman(arr.shape[axis], dt, q_over_r, degree, bool(smooth))})


def _kalman_block(block, q_over_r, level, *, dt, degree, order, smooth, steady_state):
    """(value, derivative, noise-only std) of the Kalman differentiator on series (B, T) sharing noise std ``level``."""
    from ..statespace import (
        kalman_filter,
        rts_smoother,
        steady_state_filter,
        steady_state_gain,
        steady_state_smoothed_cov,
        steady_state_smoother,
    )

    finite = np.isfinite(block)
    if not finite.any(axis=1).all():
        raise InputError("a series of x has no finite sample; the Kalman differentiator needs data.")
    first = np.argmax(finite, axis=1)
    ref = block[np.arange(block.shape[0]), first]
    model = kalman_differentiator_model(dt, q_over_r=q_over_r, noise_std=level, degree=degree)
    y = (block - ref[:, None])[:, :, None]
    if steady_state:
        gain = steady_state_gain(model)
        post = steady_state_smoother(model, y, gain=gain) if smooth else steady_state_filter(model, y, gain=gain)
        cov = steady_state_smoothed_cov(model) if smooth else gain.cov
        std = np.full(block.shape, np.sqrt(max(cov[order, order], 0.0)))
    else:
        filtered = kalman_filter(model, y)
        post = rts_smoother(model, filtered) if smooth else filtered
        std = np.sqrt(np.maximum(post.cov[:, :, order, order], 0.0))
    return post.mean[:, :, 0] + ref[:, None], post.mean[:, :, order], std


def _kalman_total_var(series, deriv, post_std, q_over_r, ns_series, *, dt, degree, order, smooth, steady_state):
    """Total error variance (B, T) of the Kalman derivative: white-noise part plus a plug-in squared bias.

    The model's posterior variance holds the noise part and the model's own (random-jerk) bias; the latter is
    replaced by the plug-in one: the converged filter's (posterior variance - white-noise variance) is subtracted
    from the posterior variance (whose excess over its converged value, at the start-up and the smoother's ends,
    is kept), and the squared bias is estimated from the difference with a companion filter, the same model
    with q/r x ``_KALMAN_SPEEDUP``^(2 degree + 2) (time scale that many times shorter), whose noise variance is
    noise_std^2 x the sum of squares of its impulse response, and scaled by :func:`._total_std.kalman_bias_scale`
    (the bias the companion keeps).
    """
    from ._total_std import _KALMAN_SPEEDUP

    fast_q = q_over_r * _KALMAN_SPEEDUP ** (2 * degree + 2)
    options = dict(dt=dt, degree=degree, order=order, smooth=smooth, steady_state=steady_state)
    fast = np.empty_like(deriv)
    for level in np.unique(ns_series):
        idx = np.nonzero(ns_series == level)[0]
        fast[idx] = _kalman_block(series[idx], fast_q, float(level), **options)[1]
    scale = kalman_time_scale(dt, q_over_r, degree)
    noise_gain, delta_gain, post_gain = kalman_impulse_gains(
        kalman_differentiator_model(dt, q_over_r=q_over_r, degree=degree),
        kalman_differentiator_model(dt, q_over_r=fast_q, degree=degree), order, smooth, scale)
    bias2 = bias_variance(deriv - fast, ns_series ** 2 * delta_gain, scale, centred=smooth)
    # the converged posterior's random-jerk part, post_gain - noise_gain (x r), is replaced by the plug-in bias; the
    # posterior's excess over its converged value (the start-up of the filter, both ends of the smoother: few data)
    # is kept whole (scaling it by noise_gain / post_gain covered 52 % on the filter's first 100 samples)
    model_part = ns_series ** 2 * max(0.0, post_gain - noise_gain)
    noise_var = np.maximum(post_std * post_std - model_part[:, None], 0.0)
    return noise_var + bias2 * kalman_bias_scale(degree, order, smooth) ** 2


# --------------------------------------------------------------------------- registry
@dataclass(frozen=True)
class DerivativeMethod:
    """A registered derivative estimator.

    Attributes
    ----------
    function : callable
        ``f(x, dt, *, <parameters>, axis=0) -> DerivativeResult``.
    parameters : tuple of str
        Keyword options it accepts (besides ``axis``).
    required : tuple of str
        Options without a default.
    causal : bool or None
        True when estimates use only past and present samples (None: depends on ``smooth``).
    description : str
        One line for help texts.
    """

    function: Callable[..., DerivativeResult]
    parameters: tuple[str, ...]
    required: tuple[str, ...]
    causal: bool | None
    description: str


DERIVATIVE_METHODS: Mapping[str, DerivativeMethod] = MappingProxyType({
    "ml": DerivativeMethod(derivative_ml, ("window", "degree", "order", "noise_std", "implementation", "std"),
                           ("window",), True,
                           "paper 002 §3 maximum-likelihood polynomial differentiator (anchored at x[k])"),
    "polyfit": DerivativeMethod(derivative_polyfit, ("window", "degree", "order", "noise_std", "implementation",
                                                     "std"),
                                ("window",), True,
                                "causal least-squares polynomial fit on N+1 samples (Savitzky-Golay end point)"),
    "backward": DerivativeMethod(derivative_backward, ("degree", "order", "noise_std", "implementation", "std"),
                                 (), True, "backward difference of order n = degree (paper 002 Table 1a)"),
    "kalman": DerivativeMethod(derivative_kalman, ("q_over_r", "degree", "order", "noise_std", "smooth",
                                                   "steady_state", "std"),
                               ("q_over_r",), None,
                               "Kalman differentiator, random-jerk model (paper 002 §2.3); smooth=True for RTS"),
})


#: How to ask for each required option: (library hint, command-line hint, example value).
_REQUIRED_HINTS = {
    "window": ("window=45 (N past samples)", "--window N (past samples per estimate)", "45"),
    "q_over_r": ("q_over_r=1e6", "--q-over-r (jerk variance / noise variance)", "1e6"),
}


def check_derivative_options(method: str, options: Mapping[str, Any], *, flags: bool = False) -> dict:
    """Validate the options of a derivative method once, from :data:`DERIVATIVE_METHODS`.

    Parameters
    ----------
    method : str
        A registry name ("ml", "polyfit", "backward", "kalman").
    options : mapping of str -> value
        Options by name; None means "not given" (the method's default).
    flags : bool, default False
        Phrase a missing required option as its command-line flag (``--window N``) instead of its keyword.

    Returns
    -------
    dict
        The given options (None dropped), ready for the method's function.

    Raises
    ------
    InputError
        Unknown method, an option the method does not take, a missing required option, a ``std`` other than
        "total" or "noise".

    Examples
    --------
    >>> check_derivative_options("ml", {"window": 45, "q_over_r": None})
    {'window': 45}
    """
    if method not in DERIVATIVE_METHODS:
        raise InputError(f"unknown derivative method {method!r}; choose one of {sorted(DERIVATIVE_METHODS)}.")
    spec = DERIVATIVE_METHODS[method]
    kwargs: dict[str, Any] = {}
    for name, val in options.items():
        if val is None:
            continue
        if name not in spec.parameters:
            raise InputError(f"method {method!r} does not take {name}={val!r}; its options are "
                             f"{list(spec.parameters)}.")
        kwargs[name] = val
    if "std" in kwargs:
        check_std(kwargs["std"])
    missing = [name for name in spec.required if name not in kwargs]
    if not missing:
        return kwargs
    if flags:
        _, flag, example = _REQUIRED_HINTS[missing[0]]
        raise InputError(f"--method {method} requires {missing[0]}: pass {flag}, e.g. "
                         f"--{missing[0].replace('_', '-')} {example}.")
    raise InputError(f"method {method!r} requires {', '.join(missing)}; e.g. "
                     + _REQUIRED_HINTS["window" if "window" in missing else "q_over_r"][0])


def derivative(x, dt, *, method: str = "ml", window: int | None = None, degree: int | None = None,
               order: int = 1, axis: int = 0, noise_std=None, q_over_r: float | None = None,
               smooth: bool | None = None, steady_state: bool | None = None,
               implementation: str | None = None, std: str | None = None) -> DerivativeResult:
    """Estimate the derivative of a noisy sampled signal with any registered method.

    Parameters
    ----------
    x : array_like
        Signal sampled every ``dt`` s, samples along ``axis``.
    dt : float
        Sample interval (s).
    method : {"ml", "polyfit", "backward", "kalman"}, default "ml"
        See :data:`DERIVATIVE_METHODS`.
    window : int, optional
        N (past samples) for "ml" and "polyfit" (required there; not accepted by
        the other methods).
    degree : int, optional
        Motion-model degree (method default when None: 2 for ml, polyfit and
        kalman, 1 for backward, where it is the order n of Table 1a).
    order : int, default 1
        Derivative order.
    axis : int, default 0
        Sample axis.
    noise_std : float or array_like, optional
        Measurement-noise std (estimated when None).
    q_over_r : float, optional
        Kalman tuning (required for "kalman").
    smooth : bool, optional
        Kalman only: RTS smoother instead of the causal filter.
    steady_state : bool, optional
        Kalman only: constant-gain (stationary) filter/smoother for long records.
    implementation : {"recursive", "fir"}, optional
        FIR methods only.
    std : {"total", "noise"}, optional
        What ``derivative_std`` covers (default "total": noise and model error;
        "noise": the white-noise part only). See :func:`derivative_ml` and
        :func:`derivative_kalman`.

    Returns
    -------
    DerivativeResult

    Raises
    ------
    InputError
        Unknown method, an option the method does not take, a missing required
        option, or any error of the method itself.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(100) * 0.01
    >>> res = derivative(t ** 2, 0.01, method="ml", window=5, degree=2, noise_std=0.0)
    >>> bool(np.allclose(res.derivative[5:], 2 * t[5:]))
    True
    """
    kwargs = check_derivative_options(method, {"window": window, "degree": degree, "noise_std": noise_std,
                                               "q_over_r": q_over_r, "smooth": smooth, "steady_state": steady_state,
                                               "implementation": implementation, "std": std})
    return DERIVATIVE_METHODS[method].function(x, dt, axis=axis, order=order, **kwargs)
