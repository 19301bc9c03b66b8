"""Exact coefficients of paper 002: Table 1 rows, §3 closed forms, scipy oracles, exactness on polynomials."""

from fractions import Fraction as Fr

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import savgol_coeffs

from longprofile.errors import InputError
from longprofile.signal import (
    backward_difference_coefficients,
    backward_difference_coefficients_float,
    frequency_response,
    ml_coefficients,
    ml_coefficients_float,
    ml_model_variance,
    polyfit_coefficients,
    polyfit_coefficients_float,
    polynomial_bias,
    power_sum,
    static_gain,
    variance_gain,
)


def _row(denominator, *numerators):
    return tuple(Fr(n, denominator) for n in numerators)


# Paper 002, Table 1. Rows legible in the OCR text are quoted; the denominators partly
# garbled by the OCR are the ones that make the rows valid differentiators (sum 0, slope 1).
TABLE_1A = {  # backward differences of order n
    1: _row(1, 1, -1),
    2: _row(2, 3, -4, 1),
    3: _row(6, 11, -18, 9, -2),
    4: _row(12, 25, -48, 36, -16, 3),
}
TABLE_1B = {  # constant velocity, N = 1..4
    1: _row(1, 1, -1),
    2: _row(5, 3, -1, -2),
    3: _row(14, 6, -1, -2, -3),
    4: _row(30, 10, -1, -2, -3, -4),
}
TABLE_1C = {  # constant acceleration, N = 2, 3
    2: _row(2, 3, -4, 1),
    3: _row(38, 42, -31, -26, 15),
}


@pytest.mark.parametrize("n", sorted(TABLE_1A))
def test_table_1a_backward_differences(n):
    assert backward_difference_coefficients(n) == TABLE_1A[n]
    # the square ML system (N = d) is the same operator (paper §2.2 footnote 2)
    assert ml_coefficients(n, n) == TABLE_1A[n]


@pytest.mark.parametrize("window", sorted(TABLE_1B))
def test_table_1b_constant_velocity(window):
    assert ml_coefficients(window, 1) == TABLE_1B[window]


@pytest.mark.parametrize("window", sorted(TABLE_1C))
def test_table_1c_constant_acceleration(window):
    assert ml_coefficients(window, 2) == TABLE_1C[window]


def test_second_derivative_eq3():
    # paper eq. (3): x''(nT) T^2 ~ x[n] - 2x[n-1] + x[n-2]
    assert backward_difference_coefficients(2, order=2) == (1, -2, 1)
    assert ml_coefficients(2, 2, order=2) == (1, -2, 1)


# --------------------------------------------------------------------------- power sums (§3)
P_CLOSED = {
    1: lambda n: Fr(n * (n + 1), 2),
    2: lambda n: Fr(n * (n + 1) * (2 * n + 1), 6),
    3: lambda n: Fr(n ** 2 * (n + 1) ** 2, 4),  # printed N^3 (N+1)^2 / 4 in the paper: misprint
    4: lambda n: Fr(n * (n + 1) * (2 * n + 1) * (3 * n ** 2 + 3 * n - 1), 30),
    5: lambda n: Fr(n ** 2 * (n + 1) ** 2 * (2 * n ** 2 + 2 * n - 1), 12),
    6: lambda n: Fr(n * (n + 1) * (2 * n + 1) * (3 * n ** 4 + 6 * n ** 3 - 3 * n + 1), 42),
}


@settings(max_examples=40, deadline=None)
@given(n=st.integers(0, 3000))
def test_power_sums_closed_forms(n):
    for j, closed in P_CLOSED.items():
        assert power_sum(n, j) == closed(n)
    if n <= 200:
        assert power_sum(n, 7) == sum(k ** 7 for k in range(1, n + 1))


def _p(n):
    return {j: P_CLOSED[j](n) for j in P_CLOSED}


# --------------------------------------------------------------------------- §3.1 constant velocity
@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 400))
def test_constant_velocity_closed_forms(n):
    h = ml_coefficients(n, 1)
    assert h[0] == Fr(3, 2 * n + 1)
    assert all(h[k] == -Fr(6 * k, n * (n + 1) * (2 * n + 1)) for k in range(1, n + 1))
    assert variance_gain(h) == Fr(3 * (n + 2) * (3 * n + 1), n * (n + 1) * (2 * n + 1) ** 2)
    p = _p(n)
    assert variance_gain(h) == (p[1] ** 2 + p[2]) / p[2] ** 2
    assert ml_model_variance(n, 1) == 1 / p[2]  # eq. (5): Var = sigma^2 / P2
    assert static_gain(h) == 0


# --------------------------------------------------------------------------- §3.2 constant acceleration
@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 300))
def test_constant_acceleration_closed_forms(n):
    p = _p(n)
    det = p[2] * p[4] - p[3] ** 2
    v = ml_coefficients(n, 2, order=1)
    assert v[0] == (p[1] * p[4] - p[2] * p[3]) / det
    assert all(v[k] == (p[3] * k ** 2 - p[4] * k) / det for k in range(1, n + 1))
    a = ml_coefficients(n, 2, order=2)  # gamma T^2 = 2 * (gamma T^2 / 2) of the paper
    assert a[0] == 2 * (p[1] * p[3] - p[2] ** 2) / det
    assert all(a[k] == 2 * (p[2] * k ** 2 - p[3] * k) / det for k in range(1, n + 1))
    assert ml_model_variance(n, 2, order=1) == p[4] / det
    assert ml_model_variance(n, 2, order=2) == 4 * p[2] / det
    assert static_gain(v) == 0 and static_gain(a) == 0


# --------------------------------------------------------------------------- §3.3 constant jerk
@settings(max_examples=20, deadline=None)
@given(n=st.integers(3, 200))
def test_constant_jerk_closed_forms(n):
    p = _p(n)
    det = p[2] * p[4] * p[6] - p[2] * p[5] ** 2 - p[3] ** 2 * p[6] + 2 * p[3] * p[4] * p[5] - p[4] ** 3
    v = ml_coefficients(n, 3)
    for k in range(1, n + 1):
        num = -(p[4] * p[6] - p[5] ** 2) * k + (p[3] * p[6] - p[4] * p[5]) * k ** 2 - (p[3] * p[5] - p[4] ** 2) * k ** 3
        assert v[k] == num / det
    assert v[0] == -sum(v[1:])
    assert ml_model_variance(n, 3) == (p[4] * p[6] - p[5] ** 2) / det


# --------------------------------------------------------------------------- external oracles
@pytest.mark.parametrize("window,degree,order", [(5, 1, 1), (10, 2, 1), (10, 2, 2), (30, 3, 1), (30, 3, 3),
                                                 (7, 4, 2), (3, 3, 1)])
def test_polyfit_equals_scipy_savgol_end_point(window, degree, order):
    expected = savgol_coeffs(window + 1, degree, deriv=order, pos=window, use="dot")[::-1]
    np.testing.assert_allclose(polyfit_coefficients_float(window, degree, order), expected, rtol=1e-9, atol=1e-12)
    exact = np.array([float(c) for c in polyfit_coefficients(window, degree, order)])
    np.testing.assert_allclose(exact, expected, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("n,order", [(1, 1), (2, 1), (2, 2), (3, 1), (3, 3), (4, 2), (6, 1)])
def test_backward_equals_scipy_interpolating_savgol(n, order):
    expected = savgol_coeffs(n + 1, n, deriv=order, pos=n, use="dot")[::-1]
    np.testing.assert_allclose(backward_difference_coefficients_float(n, order), expected, rtol=1e-9, atol=1e-9)


@settings(max_examples=25, deadline=None)
@given(window=st.integers(1, 2000), degree=st.integers(1, 3), data=st.data())
def test_float_taps_match_exact(window, degree, data):
    if window < degree:
        window = degree
    order = data.draw(st.integers(1, degree))
    exact = np.array([float(c) for c in ml_coefficients(window, degree, order)]) if window <= 300 else None
    fl = ml_coefficients_float(window, degree, order)
    assert fl.shape == (window + 1,)
    assert abs(fl.sum()) <= 1e-12 * np.abs(fl).sum()
    if exact is not None:
        np.testing.assert_allclose(fl, exact, rtol=1e-11, atol=1e-14 * np.abs(exact).max())


# --------------------------------------------------------------------------- exactness on polynomials
FAMILIES = {
    "ml": lambda n, d, r: ml_coefficients(n, d, r),
    "polyfit": lambda n, d, r: polyfit_coefficients(n, d, r),
    "backward": lambda n, d, r: backward_difference_coefficients(d, r),
}

fractions = st.fractions(min_value=-50, max_value=50, max_denominator=20)


@pytest.mark.parametrize("family", sorted(FAMILIES))
@settings(max_examples=25, deadline=None)
@given(data=st.data())
def test_exact_on_polynomials_up_to_degree(family, data):
    degree = data.draw(st.integers(1, 4))
    window = data.draw(st.integers(degree, 25))
    order = data.draw(st.integers(1, degree))
    taps = FAMILIES[family](window, degree, order)
    poly = data.draw(st.lists(fractions, min_size=1, max_size=degree + 1))
    t = data.draw(fractions)
    dt = data.draw(st.fractions(min_value=Fr(1, 100), max_value=10, max_denominator=100))
    assert polynomial_bias(taps, poly, order=order, dt=dt, t=t) == 0
    # one degree more is not reproduced: the bias of t^(d+1) is nonzero
    assert polynomial_bias(taps, [0] * (degree + 1) + [1], order=order, dt=dt, t=t) != 0


def test_value_filters():
    # order 0: ML value is x[k] (anchored model), polyfit value is the smoothed fit (static gain 1)
    assert ml_coefficients(4, 2, order=0) == (1, 0, 0, 0, 0)
    assert static_gain(polyfit_coefficients(9, 2, order=0)) == 1


# --------------------------------------------------------------------------- frequency response
def test_frequency_response_matches_dtft_and_ideal_at_low_frequency():
    dt = 1e-3
    taps = ml_coefficients_float(20, 2)
    freq, resp = frequency_response(taps, dt, n_freqs=256)
    assert freq[0] == 0 and freq[-1] < 0.5 / dt
    n = np.arange(taps.size)
    dtft = np.array([np.sum(taps * np.exp(-2j * np.pi * f * n * dt)) for f in freq]) / dt
    np.testing.assert_allclose(resp, dtft, rtol=1e-10, atol=1e-9)
    assert abs(resp[0]) < 1e-9  # zero static gain (round-off of the float taps)
    low = 1  # 1.95 Hz << fs / N
    assert abs(resp[low] / (2j * np.pi * freq[low]) - 1) < 1e-2


def test_frequency_response_second_derivative_scaling():
    dt = 0.01
    freq, resp = frequency_response(ml_coefficients(30, 3, 2), dt, order=2, n_freqs=512)
    assert abs(resp[1] / (2j * np.pi * freq[1]) ** 2 - 1) < 1e-2


# --------------------------------------------------------------------------- validation
@pytest.mark.parametrize("args,match", [
    ((1, 2), "window .* must be >= degree"),
    ((0, 1), "window must be >= 1"),
    ((5, 0), "degree must be >= 1"),
    ((5, 7), "degree must be <= 6"),
    ((5.0, 1), "window must be an integer"),
    ((5, 2, 3), "order .* must be <= degree"),
])
def test_design_errors(args, match):
    with pytest.raises(InputError, match=match):
        ml_coefficients(*args)


def test_other_errors():
    with pytest.raises(InputError, match="order must be <= accuracy"):
        backward_difference_coefficients(2, order=3)
    with pytest.raises(InputError, match="dt must be finite and > 0"):
        frequency_response([1, -1], 0.0)
    with pytest.raises(InputError, match="at least one tap"):
        variance_gain([])
