"""Exact coefficients of the causal polynomial differentiators of paper 002, and their properties.

Every differentiator here is a causal FIR filter on the N+1 samples
x[k], x[k-1], ..., x[k-N]:

    x^(r)(k dt) * dt^r  ~=  sum_{n=0}^{N} h[n] x[k-n]

``h[n]`` multiplies ``x[k-n]`` (so ``h[0]`` is the newest sample) and is given in
*sample units* (the paper's ``v[k] T_e``, ``gamma[k] T_e^2``); divide by ``dt**r`` for SI.
"""

from __future__ import annotations

from fractions import Fraction
from functools import lru_cache
from math import comb, factorial
from typing import Sequence

import numpy as np

from ..errors import InputError

__all__ = [
    "power_sum",
    "ml_coefficients",
    "ml_coefficients_float",
    "ml_model_variance",
    "polyfit_coefficients",
    "polyfit_coefficients_float",
    "backward_difference_coefficients",
    "backward_difference_coefficients_float",
    "variance_gain",
    "static_gain",
    "frequency_response",
    "polynomial_bias",
]

_MAX_DEGREE = 6


# --------------------------------------------------------------------------- validation
def _check_int(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InputError(f"{name} must be an integer; got {value!r} ({type(value).__name__}).")
    value = int(value)
    if value < minimum:
        raise InputError(f"{name} must be >= {minimum}; got {value}.")
    return value


def _check_design(window, degree, order) -> tuple[int, int, int]:
    """Validate (window N, degree d, derivative order r): 1 <= d <= 6, N >= d, 0 <= r <= d."""
    degree = _check_int("degree", degree, 1)
    if degree > _MAX_DEGREE:
        raise InputError(f"degree must be <= {_MAX_DEGREE} (1 = constant velocity, 2 = constant "
                         f"acceleration, 3 = constant jerk); got {degree}.")
    window = _check_int("window", window, 1)
    if window < degree:
        raise InputError(
            f"window (N, the number of past samples) must be >= degree (paper 002 §3: N >= d) so that the "
            f"N equations determine the d unknown derivatives; got window={window}, degree={degree}. "
            f"Use window >= {degree} (window == degree gives the backward difference of Table 1a).")
    order = _check_int("order", order, 0)
    if order > degree:
        raise InputError(f"order (derivative order) must be <= degree: a degree-{degree} motion model has no "
                         f"derivative of order {order}; got order={order}. Raise degree or lower order.")
    return window, degree, order


# --------------------------------------------------------------------------- exact algebra
@lru_cache(maxsize=None)
def _bernoulli(m: int) -> Fraction:
    """Bernoulli number B_m with the B_1 = +1/2 convention (Faulhaber)."""
    b = [Fraction(1)]
    for i in range(1, m + 1):
        b.append(-sum(comb(i + 1, j) * b[j] for j in range(i)) / (i + 1))
    out = b[m]
    return -out if m == 1 else out


def power_sum(n_max: int, power: int) -> int:
    """P_j(N) = sum_{n=1}^{N} n^j, exact (Faulhaber's formula).

    Parameters
    ----------
    n_max : int
        N >= 0.
    power : int
        j >= 0.

    Returns
    -------
    int
        The exact sum (paper 002 §3: P_1 ... P_6).
    """
    n_max = _check_int("n_max", n_max, 0)
    power = _check_int("power", power, 0)
    total = sum(comb(power + 1, i) * _bernoulli(i) * Fraction(n_max) ** (power + 1 - i)
                for i in range(power + 1)) / (power + 1)
    if total.denominator != 1:  # pragma: no cover - Faulhaber always gives an integer
        raise ArithmeticError("non-integer power sum")
    return int(total)


def _inverse_row(matrix: list[list[Fraction]], row: int) -> list[Fraction]:
    """Row ``row`` of the inverse of a small exact matrix (Gauss-Jordan on Fractions)."""
    size = len(matrix)
    a = [[Fraction(v) for v in r] + [Fraction(int(i == j)) for j in range(size)] for i, r in enumerate(matrix)]
    for col in range(size):
        piv = next(i for i in range(col, size) if a[i][col] != 0)
        a[col], a[piv] = a[piv], a[col]
        p = a[col][col]
        a[col] = [v / p for v in a[col]]
        for i in range(size):
            if i != col and a[i][col] != 0:
                f = a[i][col]
                a[i] = [vi - f * vc for vi, vc in zip(a[i], a[col])]
    return [a[row][size + j] for j in range(size)]


@lru_cache(maxsize=256)
def _ml_design(window: int, degree: int, order: int) -> tuple[Fraction, tuple[Fraction, ...]]:
    """(h0, c) with h[n] = sum_{j=0}^{d} c[j] n^j for n >= 1 and h[0] = h0 (paper's ML estimator)."""
    if order == 0:  # the anchored model passes through x[k]: the value estimate is x[k] itself
        return Fraction(1), tuple(Fraction(0) for _ in range(degree + 1))
    p = [power_sum(window, j) for j in range(2 * degree + 1)]
    # Normal matrix of Y = H X + W, H[n-1, j-1] = (-n)^j, X_j = x^(j)[k] T^j / j!  (j = 1..d)
    normal = [[(-1) ** (i + j) * p[i + j] for j in range(1, degree + 1)] for i in range(1, degree + 1)]
    w = _inverse_row(normal, order - 1)
    c = [Fraction(0)] + [factorial(order) * (-1) ** j * w[j - 1] for j in range(1, degree + 1)]
    h0 = -sum(c[j] * p[j] for j in range(1, degree + 1))
    return h0, tuple(c)


@lru_cache(maxsize=256)
def _polyfit_design(window: int, degree: int, order: int) -> tuple[Fraction, tuple[Fraction, ...]]:
    """(h0, c) of the unanchored least-squares fit on n = 0..N: h[n] = sum_j c[j] n^j for all n."""
    p = [power_sum(window, j) for j in range(2 * degree + 1)]
    normal = [[(-1) ** (i + j) * (p[i + j] + (1 if i + j == 0 else 0)) for j in range(degree + 1)]
              for i in range(degree + 1)]
    w = _inverse_row(normal, order)
    c = tuple(factorial(order) * (-1) ** j * w[j] for j in range(degree + 1))
    return c[0], c


def _exact_taps(h0: Fraction, c: Sequence[Fraction], window: int) -> tuple[Fraction, ...]:
    taps = [h0]
    for n in range(1, window + 1):
        taps.append(sum((cj * n ** j for j, cj in enumerate(c)), Fraction(0)))
    return tuple(taps)


def _float_taps(h0: Fraction, c: Sequence[Fraction], window: int) -> np.ndarray:
    n = np.arange(1, window + 1, dtype=np.float64)
    taps = np.empty(window + 1)
    taps[0] = float(h0)
    acc = np.zeros(window)
    for cj in reversed(c):  # Horner in n
        acc = acc * n + float(cj)
    taps[1:] = acc
    return taps


def ml_coefficients(window: int, degree: int, order: int = 1) -> tuple[Fraction, ...]:
    r"""Exact taps of the maximum-likelihood polynomial differentiator of paper 002 §3.

    Parameters
    ----------
    window : int
        N, the number of past samples; the filter uses the N+1 samples
        x[k], ..., x[k-N]. Must be >= ``degree``.
    degree : int
        d, the motion model: 1 constant velocity (§3.1), 2 constant acceleration
        (§3.2), 3 constant jerk (§3.3); up to 6.
    order : int, default 1
        r, the derivative estimated (0 <= r <= d). ``order=0`` returns the
        model's value estimate, which is x[k] itself (the model is anchored at x[k]).

    Returns
    -------
    tuple of Fraction, length N+1
        ``h[n]`` multiplies ``x[k-n]``; the estimate is
        :math:`x^{(r)}(k\,dt)\,dt^r \approx \sum_n h[n]\,x[k-n]`.

    Raises
    ------
    InputError
        ``window < degree``, ``order > degree``, non-integer arguments.

    Notes
    -----
    The model (paper 002 §3) is, for n = 1..N,

    .. math:: x[k-n] - x[k] = \sum_{j=1}^{d} (-n)^j\,\frac{x^{(j)}[k]\,T_e^j}{j!} + w[k-n]

    solved by least squares (the ML estimate under white Gaussian w),
    :math:`\hat X = (H^\top H)^{-1} H^\top Y` (eq. 4). The normal matrix holds the
    power sums :math:`P_j = \sum_{n=1}^N n^j`. The newest sample x[k] is the
    reference of the regression, so :math:`h[0] = -\sum_{n\ge1} h[n]`. With
    N = d the system is square and the taps are the backward differences of
    Table 1a.

    Examples
    --------
    >>> [str(c) for c in ml_coefficients(2, 1)]   # Table 1b, N = 2
    ['3/5', '-1/5', '-2/5']
    >>> [str(c) for c in ml_coefficients(2, 2)]   # Table 1c, N = 2
    ['3/2', '-2', '1/2']
    """
    window, degree, order = _check_design(window, degree, order)
    h0, c = _ml_design(window, degree, order)
    return _exact_taps(h0, c, window)


def ml_coefficients_float(window: int, degree: int, order: int = 1) -> np.ndarray:
    """Float64 taps of :func:`ml_coefficients` ((N+1,) ndarray, ``h[n]`` multiplies ``x[k-n]``).

    Evaluated from the exact polynomial ``h[n] = sum_j c_j n^j`` (fast for large N).
    """
    window, degree, order = _check_design(window, degree, order)
    h0, c = _ml_design(window, degree, order)
    return _float_taps(h0, c, window)


def ml_model_variance(window: int, degree: int, order: int = 1) -> Fraction:
    r"""Variance factor of the paper's ML estimate under the paper's own model (§3, eq. 5).

    Returns :math:`(r!)^2\,[(H^\top H)^{-1}]_{rr}`, so that
    :math:`\mathrm{Var}[\hat x^{(r)} T_e^r] = \sigma^2 \times` this factor when only the
    past samples x[k-n], n >= 1, carry the noise (x[k] is the exact reference).
    Constant velocity: :math:`1/P_2`. This is *not* the variance under white noise
    on every sample; for that use :func:`variance_gain` of the taps.
    """
    window, degree, order = _check_design(window, degree, order)
    if order == 0:
        return Fraction(0)
    p = [power_sum(window, j) for j in range(2 * degree + 1)]
    normal = [[(-1) ** (i + j) * p[i + j] for j in range(1, degree + 1)] for i in range(1, degree + 1)]
    return factorial(order) ** 2 * _inverse_row(normal, order - 1)[order - 1]


def polyfit_coefficients(window: int, degree: int, order: int = 1) -> tuple[Fraction, ...]:
    r"""Exact taps of the causal (end-point) least-squares polynomial fit on the N+1 samples.

    Unlike :func:`ml_coefficients`, x[k] is a noisy sample like the others: a degree-d
    polynomial with free value is fitted to x[k-N..k] and differentiated at the newest
    sample (the causal Savitzky-Golay end-point filter). This is the Gauss-Markov
    (minimum-variance unbiased) linear estimator under white noise on every sample.
    ``order=0`` gives the smoothed value. Same arguments, layout and errors as
    :func:`ml_coefficients`.

    Examples
    --------
    >>> [str(c) for c in polyfit_coefficients(2, 1)]
    ['1/2', '0', '-1/2']
    """
    window, degree, order = _check_design(window, degree, order)
    h0, c = _polyfit_design(window, degree, order)
    return _exact_taps(h0, c, window)


def polyfit_coefficients_float(window: int, degree: int, order: int = 1) -> np.ndarray:
    """Float64 taps of :func:`polyfit_coefficients` ((N+1,) ndarray)."""
    window, degree, order = _check_design(window, degree, order)
    h0, c = _polyfit_design(window, degree, order)
    return _float_taps(h0, c, window)


@lru_cache(maxsize=64)
def _backward_exact(accuracy: int, order: int) -> tuple[Fraction, ...]:
    # Taylor / Lagrange route (paper 002 §2.2): sum_m h[m] (-m)^j = r! delta_{jr}, j = 0..n.
    size = accuracy + 1
    vander = [[Fraction((-m) ** j) for m in range(size)] for j in range(size)]
    rhs = [Fraction(factorial(order) if j == order else 0) for j in range(size)]
    aug = [row + [b] for row, b in zip(vander, rhs)]
    for col in range(size):
        piv = next(i for i in range(col, size) if aug[i][col] != 0)
        aug[col], aug[piv] = aug[piv], aug[col]
        p = aug[col][col]
        aug[col] = [v / p for v in aug[col]]
        for i in range(size):
            if i != col and aug[i][col] != 0:
                f = aug[i][col]
                aug[i] = [vi - f * vc for vi, vc in zip(aug[i], aug[col])]
    return tuple(aug[m][size] for m in range(size))


def backward_difference_coefficients(accuracy: int, order: int = 1) -> tuple[Fraction, ...]:
    r"""Exact taps of the backward difference of Table 1a (Lagrange / Taylor of order n).

    Parameters
    ----------
    accuracy : int
        n >= 1, the order of the Taylor expansion / Lagrange polynomial; the
        operator uses the n+1 samples x[k], ..., x[k-n] and is exact on
        polynomials of degree <= n.
    order : int, default 1
        Derivative order r, 1 <= r <= n.

    Returns
    -------
    tuple of Fraction, length n+1
        ``h[m]`` multiplies ``x[k-m]``, in sample units (multiply by ``dt**-r``).

    Notes
    -----
    Solves the Taylor system :math:`\sum_m h_m (-m)^j = r!\,\delta_{jr}`, j = 0..n
    (paper 002 eq. 1-3). Order 1, n = 2 gives eq. (1): (3x[k] - 4x[k-1] + x[k-2])/2;
    order 2, n = 2 gives eq. (3): x[k] - 2x[k-1] + x[k-2].

    Examples
    --------
    >>> [str(c) for c in backward_difference_coefficients(3)]
    ['11/6', '-3', '3/2', '-1/3']
    """
    accuracy = _check_int("accuracy", accuracy, 1)
    if accuracy > _MAX_DEGREE:
        raise InputError(f"accuracy must be <= {_MAX_DEGREE}; got {accuracy}.")
    order = _check_int("order", order, 1)
    if order > accuracy:
        raise InputError(f"order must be <= accuracy (n = {accuracy} samples beyond x[k] cannot give a "
                         f"derivative of order {order}); got order={order}.")
    return _backward_exact(accuracy, order)


def backward_difference_coefficients_float(accuracy: int, order: int = 1) -> np.ndarray:
    """Float64 taps of :func:`backward_difference_coefficients`."""
    return np.array([float(c) for c in backward_difference_coefficients(accuracy, order)])


# --------------------------------------------------------------------------- properties
def _as_taps(coefficients) -> list:
    taps = list(coefficients)
    if not taps:
        raise InputError("coefficients must have at least one tap; got an empty sequence.")
    return taps


def variance_gain(coefficients):
    r"""Noise variance gain :math:`\sum_n h[n]^2` of an FIR (exact for Fractions).

    With white noise of variance :math:`\sigma^2` on every sample, the estimate's
    noise variance is :math:`\sigma^2 \sum h^2 / dt^{2r}`. For the constant-velocity
    ML estimator (paper 002 §3.1), :math:`3(N+2)(3N+1)/(N(N+1)(2N+1)^2)`.
    """
    taps = _as_taps(coefficients)
    return sum((t * t for t in taps), type(taps[0])(0))


def static_gain(coefficients):
    """Static (zero-frequency) gain :math:`H(0) = \\sum_n h[n]`; 0 for every differentiator."""
    taps = _as_taps(coefficients)
    return sum(taps, type(taps[0])(0))


def frequency_response(coefficients, dt: float, *, order: int = 1, n_freqs: int = 512):
    """Frequency response of a differentiator in SI units (via :func:`scipy.signal.freqz`).

    Parameters
    ----------
    coefficients : (L,) array_like
        Taps in sample units, ``h[n]`` multiplies ``x[k-n]``.
    dt : float
        Sample interval (s).
    order : int, default 1
        Derivative order r; the response is divided by ``dt**r``.
    n_freqs : int, default 512
        Number of frequencies from 0 to the Nyquist frequency (excluded).

    Returns
    -------
    freq : (n_freqs,) ndarray
        Frequencies (Hz).
    response : (n_freqs,) complex ndarray
        H(f); compare with the ideal differentiator ``(2j*pi*freq)**order``.
    """
    from scipy.signal import freqz

    from .._validation import require_positive

    dt = require_positive("dt", dt)
    order = _check_int("order", order, 0)
    n_freqs = _check_int("n_freqs", n_freqs, 1)
    b = np.asarray([float(c) for c in _as_taps(coefficients)]) / dt ** order
    freq, response = freqz(b, 1.0, worN=n_freqs, fs=1.0 / dt)
    return freq, response


def polynomial_bias(coefficients, polynomial, *, order: int = 1, dt=1, t=0):
    r"""Bias of a differentiator on a polynomial signal, exact for Fraction/int inputs.

    Parameters
    ----------
    coefficients : sequence
        Taps in sample units (``h[n]`` multiplies ``x[k-n]``).
    polynomial : sequence
        :math:`p_0, p_1, \dots` with :math:`x(t) = \sum_i p_i t^i`.
    order : int, default 1
        Derivative order r.
    dt : number, default 1
        Sample interval.
    t : number, default 0
        Time of the newest sample x[k].

    Returns
    -------
    number
        :math:`\sum_n h[n]\,x(t - n\,dt)/dt^r - x^{(r)}(t)`; 0 for every
        polynomial of degree <= d when the taps come from a degree-d design.
    """
    taps = _as_taps(coefficients)
    poly = list(polynomial)
    order = _check_int("order", order, 0)

    def value(tt):
        acc = 0
        for coef in reversed(poly):
            acc = acc * tt + coef
        return acc

    estimate = sum(h * value(t - n * dt) for n, h in enumerate(taps)) / dt ** order
    true = 0
    for i, coef in enumerate(poly):
        if i >= order:
            true += coef * (factorial(i) // factorial(i - order)) * t ** (i - order)
    return estimate - true
