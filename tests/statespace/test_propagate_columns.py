"""linear_recursion_columns: K columns in one call equal one linear_recursion per column, bit for bit."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, ShapeError
from longprofile.statespace import linear_recursion, linear_recursion_columns


def _stable(rng, n):
    a = rng.normal(size=(n, n))
    return 0.9 * a / max(1.0, np.abs(np.linalg.eigvals(a)).max())


@settings(max_examples=40, deadline=None)
@given(n=st.sampled_from([1, 2, 4, 5]), p=st.integers(1, 3), q=st.integers(1, 3), t=st.integers(0, 60),
       k=st.integers(1, 6), seed=st.integers(0, 2**31 - 1))
def test_columns_equal_one_linear_recursion_per_column_bit_for_bit(n, p, q, t, k, seed):
    rng = np.random.default_rng(seed)
    a, b, c = _stable(rng, n), rng.normal(size=(n, p)), rng.normal(size=(q, n))
    u = rng.normal(size=(t, k, p))
    x0 = rng.normal(size=(k, n))
    res = linear_recursion_columns(a, b, u, x0, c)
    assert res.outputs.shape == (t, k, q) and res.final_state.shape == (k, n) and res.states is None
    for m in range(k):
        one = linear_recursion(a, b, u[:, m], x0[m], output_matrix=c)
        np.testing.assert_array_equal(res.outputs[:, m], one.outputs)
        np.testing.assert_array_equal(res.final_state[m], one.final_state)


def test_golden_car_columns_from_2d_inputs_and_chunks():
    # the IRI use: n = 4, p = 1 given as (T, K) inputs, chunked with the final state carried
    from longprofile.road.indices._iri import _C_RV, golden_car_matrices

    st_, pr = golden_car_matrices(0.025)
    rng = np.random.default_rng(1)
    u = rng.normal(size=(500, 3)) * 1e-3
    x0 = np.column_stack([u[0], np.zeros(3), u[0], np.zeros(3)])
    whole = linear_recursion_columns(st_, pr[:, None], u, x0, _C_RV)
    first = linear_recursion_columns(st_, pr[:, None], u[:200], x0, _C_RV)
    rest = linear_recursion_columns(st_, pr[:, None], u[200:], first.final_state, _C_RV)
    np.testing.assert_array_equal(np.concatenate([first.outputs, rest.outputs]), whole.outputs)
    for m in range(3):
        one = linear_recursion(st_, pr[:, None], u[:, m], x0[m], output_matrix=_C_RV)
        np.testing.assert_array_equal(whole.outputs[:, m], one.outputs)


def test_columns_shape_and_finiteness_errors():
    a, b, c = np.eye(2) * 0.5, np.ones((2, 1)), np.ones((1, 2))
    with pytest.raises(ShapeError):
        linear_recursion_columns(a, b, np.ones((5, 3)), np.zeros((2, 2)), c)  # 3 columns, 2 initial states
    with pytest.raises(ShapeError):
        linear_recursion_columns(a, np.ones((2, 2)), np.ones((5, 3)), np.zeros((3, 2)), c)  # p disagrees
    with pytest.raises(ShapeError):
        linear_recursion_columns(a, b, np.ones((5, 3)), np.zeros((3, 2)), np.ones((1, 3)))
    with pytest.raises(ShapeError):
        linear_recursion_columns(a, b, np.ones(5), np.zeros((1, 2)), c)
    with pytest.raises(InputError):
        linear_recursion_columns(a, b, np.array([[1.0, np.nan]]), np.zeros((2, 2)), c)
