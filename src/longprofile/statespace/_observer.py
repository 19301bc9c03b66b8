"""Luenberger observer: gain by pole placement and a compiled run over logged data."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from .._jit import njit
from .._validation import as_float_array, require_positive
from ..errors import InputError, ModelError, ShapeError
from ._prepare import check_inputs

__all__ = ["ObserverResult", "luenberger_gain", "luenberger_observer"]


@dataclass(frozen=True, eq=False)
class ObserverResult:
    """Output of :func:`luenberger_observer`.

    Attributes
    ----------
    state : (T, n) ndarray
        Observer state x_hat[k], the estimate at sample k before y[k] is used.
    output_error : (T, m) ndarray
        Output injection error y[k] - C x_hat[k].
    transition : (n, n) ndarray
        The discrete closed-loop matrix Phi of x_hat[k+1] = Phi x_hat[k] + G_u u[k] + G_y y[k]
        (A - L C for a discrete model; expm((A - L C) dt) for a continuous one).
        Its eigenvalues set the decay of the estimation error.
    """

    state: np.ndarray
    output_error: np.ndarray
    transition: np.ndarray


def _matrices(A, C, B=None):
    A = as_float_array("A", A, ndim=2, allow_nan=False)
    C = as_float_array("C", C, ndim=(1, 2), allow_nan=False)
    n = A.shape[0]
    if A.shape != (n, n):
        raise ShapeError(f"A must be square (n, n); got {A.shape}.")
    if C.ndim == 1:
        C = C[None]
    if C.shape[1] != n:
        raise ShapeError(f"C must have shape (m, {n}) to match A; got {C.shape}.")
    if B is None:
        return A, C, np.zeros((n, 0))
    B = as_float_array("B", B, ndim=(1, 2), allow_nan=False)
    if B.ndim == 1:
        B = B[:, None]
    if B.shape[0] != n:
        raise ShapeError(f"B must have shape ({n}, p) to match A; got {B.shape}.")
    return A, C, B


def luenberger_gain(A, C, poles, *, discrete: bool = False) -> np.ndarray:
    """Observer gain L placing the eigenvalues of A - L C at ``poles``.

    Parameters
    ----------
    A : (n, n) array_like
        State matrix (continuous-time dx/dt = A x + B u, or discrete x[k+1] = A x[k] + B u[k]).
    C : (m, n) array_like
        Output matrix, y = C x.
    poles : (n,) array_like
        Desired observer poles; complex poles must come in conjugate pairs.
        Continuous: Re(p) < 0 (rad/s). Discrete: |p| < 1.
    discrete : bool, default False
        Whether A (and the poles) are discrete-time.

    Returns
    -------
    (n, m) ndarray
        The gain L.

    Raises
    ------
    InputError
        If the poles are not stable for the chosen time domain, or are not n of them.
    ModelError
        If the poles cannot be placed ((A, C) not observable, or a pole repeated
        more often than rank(C) allows).

    Notes
    -----
    Pole placement on the dual system (A', C') with :func:`scipy.signal.place_poles`
    (Tits-Yang / KNV0): A - L C = (A' - C' L')', so L = K', K the state-feedback
    gain of the dual. Paper 001 §II places the slope observer's poles this way. With one output
    and distinct poles the gain is unique and comes from Ackermann's formula (the same gain, without
    importing scipy.signal); the placed eigenvalues are checked either way.
    """
    A, C, _ = _matrices(A, C)
    n = A.shape[0]
    p = np.atleast_1d(np.asarray(poles, dtype=complex))
    if p.shape != (n,):
        raise InputError(f"poles must have n = {n} entries (one per state); got shape {p.shape}.")
    if not np.all(np.isfinite(p)):
        raise InputError("poles must be finite.")
    if discrete and np.any(np.abs(p) >= 1.0):
        raise InputError(f"discrete observer poles must lie inside the unit circle (|p| < 1); got {p}.")
    if not discrete and np.any(p.real >= 0.0):
        raise InputError(f"continuous observer poles must have negative real parts (rad/s); got {p}. "
                         "For a discrete-time model pass discrete=True.")
    if np.all(p.imag == 0):
        p = p.real
    want = np.sort_complex(np.asarray(p, dtype=complex))
    tol = 1e-9 * max(1.0, float(np.abs(want).max()))

    def placed(L):
        # the computed eigenvalues of a non-normal A - L C are only as good as kappa eps ||A - L C|| (kappa: the
        # eigenvector condition number): a gain right to 1e-9 read 5e-4 off at kappa 4e7, ||A - L C|| 6.5e4
        M = A - L @ C
        w, V = np.linalg.eig(M)
        try:
            kappa = float(np.max(np.linalg.norm(V, axis=0) * np.linalg.norm(np.linalg.inv(V), axis=1)))
        except np.linalg.LinAlgError:
            return False  # defective: no basis of eigenvectors, the placement cannot be checked this way
        slack = 100.0 * np.finfo(float).eps * kappa * np.linalg.norm(M, 2)
        return np.allclose(np.sort_complex(w), want, rtol=1e-6, atol=tol + slack)

    L = _single_output_gain(A, C, p) if C.shape[0] == 1 and np.unique(p).size == n else None
    if L is not None and placed(L):
        return L
    try:
        from scipy.signal import place_poles  # scipy.signal costs 0.5-1 s to import: only MIMO observers pay it

        res = place_poles(A.T, C.T, p)
    except ValueError as exc:
        obs_rank = np.linalg.matrix_rank(np.vstack([C @ np.linalg.matrix_power(A, k) for k in range(n)]))
        raise ModelError(f"cannot place the observer poles {p}: {exc} (rank of the observability matrix: "
                         f"{obs_rank} of {n}; unobservable modes cannot be moved).") from None
    L = res.gain_matrix.T.copy()
    if not placed(L):
        got = np.sort_complex(np.linalg.eigvals(A - L @ C))
        raise ModelError(f"pole placement is inaccurate (placed {got}, requested {want}); the problem is badly "
                         "conditioned — choose less extreme or less clustered poles, or rescale the states.")
    return L


def _single_output_gain(A, C, poles):
    """Ackermann's formula for one output: L = phi(A) O^-1 e_n, phi(s) = prod (s - p_i), O = [C; C A; ...].

    With one output the gain placing n distinct poles is unique, so this is the gain
    ``scipy.signal.place_poles`` finds (compared in the tests), without importing scipy.signal on the
    start-up path of every command with an observer. None when O is singular (not observable: the
    place_poles path then explains it). Well conditioned for the small n of the models here; the caller
    checks the placed eigenvalues and falls back to place_poles otherwise.
    """
    n = A.shape[0]
    O = np.vstack([C @ np.linalg.matrix_power(A, k) for k in range(n)])
    coef = np.real(np.poly(poles))  # [1, a_1, ..., a_n]
    phi = sum(c * np.linalg.matrix_power(A, n - i) for i, c in enumerate(coef))
    e = np.zeros((n, 1))
    e[-1, 0] = 1.0
    try:
        return phi @ np.linalg.solve(O, e)
    except np.linalg.LinAlgError:
        return None


@njit(cache=True)
def _observer_kernel(Phi, Gu, Gy, C, x0, u, y, state, err):
    T, m = y.shape
    n = x0.shape[0]
    p = u.shape[1]
    x = x0.copy()
    xn = np.empty(n)
    for k in range(T):
        for i in range(n):
            state[k, i] = x[i]
        for j in range(m):
            s = y[k, j]
            for i in range(n):
                s -= C[j, i] * x[i]
            err[k, j] = s
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += Phi[i, j] * x[j]
            for j in range(p):
                s += Gu[i, j] * u[k, j]
            for j in range(m):
                s += Gy[i, j] * y[k, j]
            xn[i] = s
        for i in range(n):
            x[i] = xn[i]


def _zoh(M, G, dt):
    """Exact zero-order-hold discretisation of dx/dt = M x + G z: (expm(M dt), int_0^dt expm(M s) ds G)."""
    n, q = G.shape
    blk = np.zeros((n + q, n + q))
    blk[:n, :n] = M * dt
    blk[:n, n:] = G * dt
    E = expm(blk)
    return E[:n, :n], E[:n, n:]


def luenberger_observer(A, B, C, L, y, *, u=None, x0=None, dt=None) -> ObserverResult:
    """Run a Luenberger observer over sampled data.

    Parameters
    ----------
    A : (n, n) array_like
        State matrix (continuous-time when ``dt`` is given, discrete otherwise).
    B : (n, p) array_like or None
        Input matrix; None when there are no inputs.
    C : (m, n) array_like
        Output matrix.
    L : (n, m) array_like
        Observer gain, e.g. from :func:`luenberger_gain`.
    y : (T,) or (T, m) array_like
        Measured outputs, complete (no NaN).
    u : (T, p) array_like, optional
        Known inputs (required when B has columns).
    x0 : (n,) array_like, optional
        Initial observer state; zeros by default.
    dt : float, optional
        Sample interval (s) of a continuous-time model. None: A, B, L are discrete-time.

    Returns
    -------
    ObserverResult
        ``state`` (T, n), ``output_error`` (T, m) and the discrete closed-loop ``transition``.

    Raises
    ------
    ShapeError, InputError
        On inconsistent shapes, NaN in y or u, or dt <= 0.

    Notes
    -----
    Discrete model: x_hat[k+1] = A x_hat[k] + B u[k] + L (y[k] - C x_hat[k]).

    Continuous model (``dt`` given): the observer ODE
    dx_hat/dt = (A - L C) x_hat + B u + L y is integrated exactly over each
    sample interval with u and y held constant (zero-order hold), using one
    matrix exponential of the augmented matrix [[A - L C, B, L], [0, 0, 0]] dt
    (:func:`scipy.linalg.expm`). The discrete observer matrix is then
    expm((A - L C) dt): its eigenvalues are exp(p dt) for the placed poles p, so
    the error decays at the designed rates at any sample rate (unlike a forward
    Euler step, which is unstable when |p| dt > 2). The sample-and-hold of y
    adds a half-sample delay, negligible at 1 kHz for the slope observer of paper 001.
    """
    A, C, B = _matrices(A, C, B)
    n, m, p = A.shape[0], C.shape[0], B.shape[1]
    L = as_float_array("L", L, ndim=(1, 2), allow_nan=False)
    if L.ndim == 1:
        L = L[:, None]
    if L.shape != (n, m):
        raise ShapeError(f"L must have shape (n, m) = ({n}, {m}); got {L.shape}.")
    Y = as_float_array("y", y, ndim=(1, 2))
    if Y.ndim == 1:
        Y = Y[:, None]
    if Y.shape[1] != m:
        raise ShapeError(f"y must have m = {m} columns (rows of C); got shape {np.shape(y)}.")
    if np.isnan(Y).any():
        raise InputError(f"y contains {int(np.isnan(Y).sum())} NaN value(s), first at row "
                         f"{int(np.argwhere(np.isnan(Y))[0][0])}; the observer needs every sample. Interpolate "
                         "short gaps or use a Kalman filter, which handles missing data.")
    T = Y.shape[0]
    if p:
        if u is None:
            raise ShapeError(f"B has p = {p} columns; pass u with shape (T, {p}).")
        U = check_inputs(u, T, n_inputs=p)
    else:
        if u is not None and np.size(u):
            raise ShapeError("u was given but B is None (or has no columns).")
        U = np.zeros((T, 0))
    x0 = np.zeros(n) if x0 is None else as_float_array("x0", x0, ndim=1, allow_nan=False)
    if x0.shape != (n,):
        raise ShapeError(f"x0 must have shape ({n},); got {x0.shape}.")
    M = A - L @ C
    if dt is None:
        Phi, Gu, Gy = M, B, L
    else:
        h = require_positive("dt", dt)
        Phi, G = _zoh(M, np.hstack([B, L]), h)
        Gu, Gy = G[:, :p], G[:, p:]
    state = np.empty((T, n))
    err = np.empty((T, m))
    _observer_kernel(np.ascontiguousarray(Phi), np.ascontiguousarray(Gu), np.ascontiguousarray(Gy),
                     np.ascontiguousarray(C), np.ascontiguousarray(x0), np.ascontiguousarray(U),
                     np.ascontiguousarray(Y), state, err)
    Phi = np.array(Phi)
    Phi.setflags(write=False)
    return ObserverResult(state=state, output_error=err, transition=Phi)
