"""Deterministic linear recursion x[k+1] = A_k x[k] + B_k u[k] (compiled kernel behind a validating wrapper).

This is the propagation step of every linear state-space simulation without noise: the
golden quarter car of the IRI (road), discretised filters, input responses. Domain modules
build the matrices; the loop lives here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._jit import njit
from .._validation import as_float_array
from ..errors import ShapeError

__all__ = ["LinearRecursionResult", "linear_recursion", "linear_recursion_columns"]


@dataclass(frozen=True, eq=False)
class LinearRecursionResult:
    """Output of :func:`linear_recursion`.

    Attributes
    ----------
    states : (T + 1, n) ndarray or None
        ``states[0] = x0`` and ``states[k + 1] = A_k states[k] + B_k u[k]``; None when not stored.
    outputs : (T, q) ndarray or None
        ``outputs[k] = C states[k + 1]`` (the output after step k); None without ``output_matrix``.
    final_state : (n,) ndarray
        ``x[T]``, to carry the recursion on over the next chunk of inputs.
    """

    states: np.ndarray | None
    outputs: np.ndarray | None
    final_state: np.ndarray


@njit(cache=True, nogil=True)
def _recursion_kernel(a, b, u, x0, c, a_step, b_step, store_states, store_outputs, states, outputs):  # pragma: no cover - compiled
    n = x0.shape[0]
    p = u.shape[1]
    q = c.shape[0]
    n_steps = u.shape[0]
    x = x0.copy()
    xn = np.empty(n)
    if store_states:
        for i in range(n):
            states[0, i] = x[i]
    for k in range(n_steps):
        ka = k * a_step
        kb = k * b_step
        for i in range(n):
            acc = 0.0
            for j in range(n):
                acc += a[ka, i, j] * x[j]
            for j in range(p):
                acc += b[kb, i, j] * u[k, j]
            xn[i] = acc
        for i in range(n):
            x[i] = xn[i]
        if store_states:
            for i in range(n):
                states[k + 1, i] = x[i]
        if store_outputs:
            for r in range(q):
                acc = 0.0
                for j in range(n):
                    acc += c[r, j] * x[j]
                outputs[k, r] = acc
    return x


@njit(cache=True, inline="always")
def _add_input_4(b, kb, u, k, y0, y1, y2, y3):
    """(y0, .., y3) + B[kb] u[k] for n = 4, input by input (the operation order of :func:`_recursion_kernel`)."""
    for j in range(u.shape[1]):
        ukj = u[k, j]
        y0 += b[kb, 0, j] * ukj
        y1 += b[kb, 1, j] * ukj
        y2 += b[kb, 2, j] * ukj
        y3 += b[kb, 3, j] * ukj
    return y0, y1, y2, y3


@njit(cache=True, inline="always")
def _put_4(arr, row, x0_, x1_, x2_, x3_):
    """arr[row, :4] = (x0_, x1_, x2_, x3_)."""
    arr[row, 0] = x0_
    arr[row, 1] = x1_
    arr[row, 2] = x2_
    arr[row, 3] = x3_


@njit(cache=True, inline="always")
def _store_4(k, x0_, x1_, x2_, x3_, c, store_states, store_outputs, states, outputs):
    """Row k + 1 of the states (the state after step k) and row k of the outputs C x, for n = 4."""
    if store_states:
        _put_4(states, k + 1, x0_, x1_, x2_, x3_)
    if store_outputs:
        for r in range(c.shape[0]):
            outputs[k, r] = c[r, 0] * x0_ + c[r, 1] * x1_ + c[r, 2] * x2_ + c[r, 3] * x3_


@njit(cache=True, inline="always")
def _vector_4(x0_, x1_, x2_, x3_):
    """The state held in four scalars as a (4,) array."""
    x = np.empty(4)
    x[0] = x0_
    x[1] = x1_
    x[2] = x2_
    x[3] = x3_
    return x


@njit(cache=True, nogil=True)
def _recursion_kernel_4(a, b, u, x0, c, a_step, b_step, store_states, store_outputs, states, outputs):  # pragma: no cover - compiled
    # Same recursion as _recursion_kernel for n = 4 with the state held in scalars (about 3x faster: the
    # golden quarter car of the IRI and other 4-state models). Same operation order per component.
    x0_ = x0[0]
    x1_ = x0[1]
    x2_ = x0[2]
    x3_ = x0[3]
    if store_states:
        _put_4(states, 0, x0_, x1_, x2_, x3_)
    for k in range(u.shape[0]):
        ka = k * a_step
        kb = k * b_step
        y0 = a[ka, 0, 0] * x0_ + a[ka, 0, 1] * x1_ + a[ka, 0, 2] * x2_ + a[ka, 0, 3] * x3_
        y1 = a[ka, 1, 0] * x0_ + a[ka, 1, 1] * x1_ + a[ka, 1, 2] * x2_ + a[ka, 1, 3] * x3_
        y2 = a[ka, 2, 0] * x0_ + a[ka, 2, 1] * x1_ + a[ka, 2, 2] * x2_ + a[ka, 2, 3] * x3_
        y3 = a[ka, 3, 0] * x0_ + a[ka, 3, 1] * x1_ + a[ka, 3, 2] * x2_ + a[ka, 3, 3] * x3_
        x0_, x1_, x2_, x3_ = _add_input_4(b, kb, u, k, y0, y1, y2, y3)
        _store_4(k, x0_, x1_, x2_, x3_, c, store_states, store_outputs, states, outputs)
    return _vector_4(x0_, x1_, x2_, x3_)


@njit(cache=True, nogil=True)
def _recursion_kernel_4_const(a, b, u, x0, c, store_states, store_outputs, states, outputs):  # pragma: no cover - compiled
    # n = 4 with constant A and B: A held in registers (the IRI golden car on a constant step).
    # Same operation order per component as the other kernels (identical results).
    a00, a01, a02, a03 = a[0, 0, 0], a[0, 0, 1], a[0, 0, 2], a[0, 0, 3]
    a10, a11, a12, a13 = a[0, 1, 0], a[0, 1, 1], a[0, 1, 2], a[0, 1, 3]
    a20, a21, a22, a23 = a[0, 2, 0], a[0, 2, 1], a[0, 2, 2], a[0, 2, 3]
    a30, a31, a32, a33 = a[0, 3, 0], a[0, 3, 1], a[0, 3, 2], a[0, 3, 3]
    x0_ = x0[0]
    x1_ = x0[1]
    x2_ = x0[2]
    x3_ = x0[3]
    if store_states:
        _put_4(states, 0, x0_, x1_, x2_, x3_)
    for k in range(u.shape[0]):
        y0 = a00 * x0_ + a01 * x1_ + a02 * x2_ + a03 * x3_
        y1 = a10 * x0_ + a11 * x1_ + a12 * x2_ + a13 * x3_
        y2 = a20 * x0_ + a21 * x1_ + a22 * x2_ + a23 * x3_
        y3 = a30 * x0_ + a31 * x1_ + a32 * x2_ + a33 * x3_
        x0_, x1_, x2_, x3_ = _add_input_4(b, 0, u, k, y0, y1, y2, y3)
        _store_4(k, x0_, x1_, x2_, x3_, c, store_states, store_outputs, states, outputs)
    return _vector_4(x0_, x1_, x2_, x3_)


@njit(cache=True, nogil=True)
def _columns_kernel(a, b, u, x0, c, outputs):  # pragma: no cover - compiled
    # K independent columns of one constant recursion, steps outer and columns inner (independent chains
    # the CPU overlaps). Same operation order per component as _recursion_kernel (identical results).
    n = a.shape[0]
    p = b.shape[1]
    q = c.shape[0]
    n_cols = x0.shape[0]
    x = x0.copy()
    xn = np.empty(n)
    for k in range(u.shape[0]):
        for m in range(n_cols):
            for i in range(n):
                acc = 0.0
                for j in range(n):
                    acc += a[i, j] * x[m, j]
                for j in range(p):
                    acc += b[i, j] * u[k, m, j]
                xn[i] = acc
            for i in range(n):
                x[m, i] = xn[i]
            for r in range(q):
                acc = 0.0
                for j in range(n):
                    acc += c[r, j] * x[m, j]
                outputs[k, m, r] = acc
    return x


@njit(cache=True, nogil=True)
def _columns_kernel_4_siso(a, b, u, x0, c, outputs):  # pragma: no cover - compiled
    # n = 4 with one input and one output (p = q = 1: the golden car), the states of the columns
    # stored component by component (s0[m], s1[m], ...) so that the loop over the columns vectorises (SIMD):
    # about 5x faster for 16 columns. Same operation order per component (identical results).
    n_cols = x0.shape[0]
    a00, a01, a02, a03 = a[0, 0], a[0, 1], a[0, 2], a[0, 3]
    a10, a11, a12, a13 = a[1, 0], a[1, 1], a[1, 2], a[1, 3]
    a20, a21, a22, a23 = a[2, 0], a[2, 1], a[2, 2], a[2, 3]
    a30, a31, a32, a33 = a[3, 0], a[3, 1], a[3, 2], a[3, 3]
    b0, b1, b2, b3 = b[0, 0], b[1, 0], b[2, 0], b[3, 0]
    c0, c1, c2, c3 = c[0, 0], c[0, 1], c[0, 2], c[0, 3]
    s0 = x0[:, 0].copy()
    s1 = x0[:, 1].copy()
    s2 = x0[:, 2].copy()
    s3 = x0[:, 3].copy()
    for k in range(u.shape[0]):
        uk = u[k]
        ok = outputs[k]
        for m in range(n_cols):
            x0_ = s0[m]
            x1_ = s1[m]
            x2_ = s2[m]
            x3_ = s3[m]
            ukj = uk[m, 0]
            y0 = a00 * x0_ + a01 * x1_ + a02 * x2_ + a03 * x3_ + b0 * ukj
            y1 = a10 * x0_ + a11 * x1_ + a12 * x2_ + a13 * x3_ + b1 * ukj
            y2 = a20 * x0_ + a21 * x1_ + a22 * x2_ + a23 * x3_ + b2 * ukj
            y3 = a30 * x0_ + a31 * x1_ + a32 * x2_ + a33 * x3_ + b3 * ukj
            s0[m] = y0
            s1[m] = y1
            s2[m] = y2
            s3[m] = y3
            ok[m, 0] = c0 * y0 + c1 * y1 + c2 * y2 + c3 * y3
    x = np.empty((n_cols, 4))
    x[:, 0] = s0
    x[:, 1] = s1
    x[:, 2] = s2
    x[:, 3] = s3
    return x


def linear_recursion(transition, input_matrix, inputs, x0, *, output_matrix=None,
                     store_states: bool | None = None) -> LinearRecursionResult:
    """Run the deterministic linear recursion ``x[k+1] = A_k x[k] + B_k u[k]``, k = 0..T-1.

    Parameters
    ----------
    transition : (n, n) or (T, n, n) array_like
        A: constant, or one matrix per step (``transition[k]`` maps step k to k + 1).
    input_matrix : (n, p) or (T, n, p) array_like
        B: constant, or one matrix per step.
    inputs : (T, p) array_like, or (T,) when p = 1
        u[k]; must be finite.
    x0 : (n,) array_like
        Initial state x[0].
    output_matrix : (q, n) array_like, optional
        C: if given, ``outputs[k] = C x[k + 1]`` is returned (T, q). Use it to keep only what you need of
        a long run (memory T q instead of T n).
    store_states : bool, optional
        Store all states (T + 1, n). Default: True without ``output_matrix``, False with it.

    Returns
    -------
    LinearRecursionResult
        ``states`` (T + 1, n) or None, ``outputs`` (T, q) or None, ``final_state`` (n,).

    Raises
    ------
    ShapeError
        A matrix has neither its base rank nor exactly one leading per-step axis of length T, or the
        dimensions n, p, q disagree.
    InputError
        Non-finite matrices, inputs or initial state.

    Notes
    -----
    Shape rule (style guide convention 5): a matrix at its base rank is constant; with one extra
    leading axis it is per-step and that axis must have length T (the number of inputs). The loop is a
    numba kernel (``cache=True``) in float64, O(T n (n + p)); a chunked run that passes
    ``final_state`` as the next ``x0`` gives the same numbers as one run.

    Examples
    --------
    >>> import numpy as np
    >>> res = linear_recursion(np.array([[0.5]]), np.array([[1.0]]), np.ones(3), np.array([0.0]))
    >>> res.states[:, 0]
    array([0.  , 1.  , 1.5 , 1.75])
    """
    u = as_float_array("inputs", inputs, ndim=(1, 2), allow_nan=False)
    if u.ndim == 1:
        u = u[:, None]
    n_steps, p = u.shape
    x = as_float_array("x0", x0, ndim=1, allow_nan=False)
    n = x.shape[0]
    a = as_float_array("transition", transition, ndim=(2, 3), allow_nan=False)
    b = as_float_array("input_matrix", input_matrix, ndim=(2, 3), allow_nan=False)
    a3, a_step = _per_step("transition", a, (n, n), n_steps)
    b3, b_step = _per_step("input_matrix", b, (n, p), n_steps)
    if output_matrix is not None:
        c = as_float_array("output_matrix", output_matrix, ndim=2, allow_nan=False)
        if c.shape[1] != n:
            raise ShapeError(f"output_matrix must be (q, {n}) for a state of dimension {n}; got shape {c.shape}.")
    else:
        c = np.zeros((0, n))
    keep_states = (output_matrix is None) if store_states is None else bool(store_states)
    keep_outputs = output_matrix is not None
    states = np.empty((n_steps + 1, n) if keep_states else (0, n))
    outputs = np.empty((n_steps, c.shape[0]) if keep_outputs else (0, 0))
    if n == 4 and a_step == 0 and b_step == 0:
        final = _recursion_kernel_4_const(a3, b3, np.ascontiguousarray(u), np.ascontiguousarray(x),
                                          np.ascontiguousarray(c), keep_states, keep_outputs, states, outputs)
        return LinearRecursionResult(states=states if keep_states else None,
                                     outputs=outputs if keep_outputs else None, final_state=final)
    kernel = _recursion_kernel_4 if n == 4 else _recursion_kernel
    final = kernel(a3, b3, np.ascontiguousarray(u), np.ascontiguousarray(x), np.ascontiguousarray(c),
                              a_step, b_step, keep_states, keep_outputs, states, outputs)
    return LinearRecursionResult(states=states if keep_states else None,
                                 outputs=outputs if keep_outputs else None, final_state=final)


def linear_recursion_columns(transition, input_matrix, inputs, x0, output_matrix) -> LinearRecursionResult:
    """Run K independent columns of one constant recursion ``x[k+1] = A x[k] + B u[k]`` in one compiled call.

    The same as one :func:`linear_recursion` per column (constant A, B and an output matrix C), with the
    validation and the kernel call done once: the batched form for many short runs of one model (the golden
    car of the IRI over several tracks or several candidate profiles).

    Parameters
    ----------
    transition : (n, n) array_like
        A, constant.
    input_matrix : (n, p) array_like
        B, constant.
    inputs : (T, K, p) array_like, or (T, K) when p = 1
        u[k] of each column; must be finite.
    x0 : (K, n) array_like
        Initial state of each column.
    output_matrix : (q, n) array_like
        C: ``outputs[k, m] = C x_m[k + 1]``.

    Returns
    -------
    LinearRecursionResult
        ``outputs`` (T, K, q), ``final_state`` (K, n) (``x_m[T]``, to carry the columns on over the next chunk),
        ``states`` None.

    Raises
    ------
    ShapeError
        A, B, C, the inputs or the initial states have the wrong rank, or n, p, q, K disagree.
    InputError
        Non-finite matrices, inputs or initial states.

    Notes
    -----
    Column m gives bit for bit the ``outputs`` and ``final_state`` of
    ``linear_recursion(A, B, inputs[:, m], x0[m], output_matrix=C)`` (same operation order; tested): the
    kernel runs the steps outer and the columns inner (independent recursions that the processor overlaps),
    O(T K n (n + p + q)) in float64. Units are those of the model (the engine is unit-free).

    Examples
    --------
    >>> import numpy as np
    >>> res = linear_recursion_columns(np.array([[0.5]]), np.array([[1.0]]), np.ones((3, 2)),
    ...                                np.array([[0.0], [2.0]]), np.array([[1.0]]))
    >>> res.outputs[:, :, 0]
    array([[1.  , 2.  ],
           [1.5 , 2.  ],
           [1.75, 2.  ]])
    """
    u = as_float_array("inputs", inputs, ndim=(2, 3), allow_nan=False)
    if u.ndim == 2:
        u = u[:, :, None]
    n_steps, n_cols, p = u.shape
    x = as_float_array("x0", x0, ndim=2, allow_nan=False)
    n = x.shape[1]
    if x.shape[0] != n_cols:
        raise ShapeError(f"x0 must be ({n_cols}, n): one initial state per column of the inputs; got shape {x.shape}.")
    a = as_float_array("transition", transition, ndim=2, allow_nan=False)
    b = as_float_array("input_matrix", input_matrix, ndim=2, allow_nan=False)
    c = as_float_array("output_matrix", output_matrix, ndim=2, allow_nan=False)
    if a.shape != (n, n) or b.shape != (n, p) or c.shape[1] != n:
        raise ShapeError(f"transition must be ({n}, {n}), input_matrix ({n}, {p}) and output_matrix (q, {n}) for "
                         f"a state of dimension {n} and {p} input(s); got {a.shape}, {b.shape}, {c.shape}.")
    outputs = np.empty((n_steps, n_cols, c.shape[0]))
    # the generic loop adds the products in the same order as the n = 4 unrolled kernels (identical results); only
    # the golden car's case (n = 4, one input, one output) has a vectorised kernel of its own
    kernel = _columns_kernel_4_siso if (n == 4 and p == 1 and c.shape[0] == 1) else _columns_kernel
    final = kernel(np.ascontiguousarray(a), np.ascontiguousarray(b), np.ascontiguousarray(u),
                   np.ascontiguousarray(x), np.ascontiguousarray(c), outputs)
    return LinearRecursionResult(states=None, outputs=outputs, final_state=final)


def _per_step(name: str, mat: np.ndarray, base: tuple[int, int], n_steps: int) -> tuple[np.ndarray, int]:
    """Return (contiguous (S, r, c) array, index step 0 or 1) after checking the shape rule."""
    if mat.ndim == 2:
        if mat.shape != base:
            raise ShapeError(f"{name} must be {base} (constant) or ({n_steps}, {base[0]}, {base[1]}) (per step); "
                             f"got shape {mat.shape}.")
        return np.ascontiguousarray(mat[None]), 0
    if mat.shape != (n_steps,) + base:
        raise ShapeError(f"{name} per step must be ({n_steps}, {base[0]}, {base[1]}) (one matrix per input); "
                         f"got shape {mat.shape}.")
    return np.ascontiguousarray(mat), 1
