"""One place for the wrappers' input checks: observations, known inputs ``u``, time-varying terms (private).

Every public function of the engine validates its data here before a kernel runs, so the same input
gets the same error (and message) whichever filter it is passed to.

* ``y``: (T,) when m = 1, (T, m) or (B, T, m); NaN = missing component (kept).
* ``u``: (T,) for p = 1, (T, p), or (B, T, p) where a function takes batches; finite.
* time-varying terms: transition side (F, B, c, Q) has T-1 steps (term k maps step k to k+1),
  observation side (H, D, d, R) has T (one per sample).
"""

from __future__ import annotations

import numpy as np

from .._validation import as_float_array, require_symmetric_psd
from ..errors import InputError, ShapeError

__all__ = ["as_observation_batch", "prepare_observations", "check_inputs", "linear_inputs", "prepare_inputs",
           "nonlinear_inputs", "noise_terms", "covariance_storage"]


def as_observation_batch(y, m: int) -> tuple[np.ndarray, bool]:
    """Shape-check ``y`` for m observations per step; return a C-contiguous (B, T, m) float64 array and
    whether it was batched.

    ``y`` may be (T,) when m = 1, (T, m), or (B, T, m). NaN marks a missing component (kept).
    """
    arr = as_float_array("y", y, ndim=(1, 2, 3))
    batched = arr.ndim == 3
    if arr.ndim == 1:
        if m != 1:
            raise ShapeError(f"y is 1-D, which is only accepted for m = 1 observation; the model has m = {m}. "
                             "Pass y with shape (T, m).")
        arr = arr[:, None]
    if arr.ndim == 2:
        arr = arr[None]
    if arr.shape[-1] != m:
        raise ShapeError(f"y must have m = {m} columns (one per observation of the model); got shape {np.shape(y)}.")
    if arr.shape[1] < 1:
        raise ShapeError("y has no samples.")
    if arr.shape[0] < 1:
        raise ShapeError(f"y is a batch of 0 series (shape {np.shape(y)}); pass at least one series.")
    return np.ascontiguousarray(arr), batched


def prepare_observations(model, y) -> tuple[np.ndarray, bool]:
    """Validate ``y`` against a linear ``model`` (its time-varying terms too); return a (B, T, m) float64
    array and whether it was batched.

    ``y`` may be (T,) when m = 1, (T, m), or (B, T, m). NaN marks a missing component.
    """
    arr, batched = as_observation_batch(y, model.n_obs)
    model.check_length(arr.shape[1])
    return arr, batched


def check_inputs(u, n_steps: int, *, n_inputs: int | None = None, n_batch: int | None = None) -> np.ndarray:
    """Validate known inputs ``u`` (finite) for a series of ``n_steps`` samples.

    ``n_inputs`` None accepts any p. ``n_batch`` None: one series, (T,) or (T, p) -> (T, p). Otherwise a
    batch of ``n_batch`` series: (T,), (T, p) shared by the batch -> (1, T, p), or (B, T, p) -> (B, T, p).
    """
    arr = as_float_array("u", u, ndim=(1, 2) if n_batch is None else (1, 2, 3), allow_nan=False)
    if arr.ndim == 1:
        arr = arr[:, None]
    p = "p" if n_inputs is None else n_inputs
    if n_batch is None:
        ok = arr.shape[0] == n_steps and n_inputs in (None, arr.shape[1])
        want = f"(T, p) = ({n_steps}, {p})"
    else:
        if arr.ndim == 2:
            arr = arr[None]
        ok = arr.shape[1] == n_steps and n_inputs in (None, arr.shape[2]) and arr.shape[0] in (1, n_batch)
        want = f"(T, p) = ({n_steps}, {p}) or (B, T, p) = ({n_batch}, {n_steps}, {p})"
    if not ok:
        raise ShapeError(f"u must have shape {want}; got {np.shape(u)}.")
    return np.ascontiguousarray(arr)


def linear_inputs(model, u, n_steps: int, n_batch: int) -> np.ndarray | None:
    """``u`` of a linear model: (1, T, p) when shared by the batch, (B, T, p) per series, or None (p = 0)."""
    p = model.n_inputs
    if u is None:
        if p:
            raise ShapeError(f"the model has p = {p} known inputs (B or D is set); pass u with shape (T, {p}).")
        return None
    if not p:
        raise ShapeError("u was given but the model has no input matrices (input_transition / input_observation).")
    return check_inputs(u, n_steps, n_inputs=p, n_batch=n_batch)


def prepare_inputs(model, u, n_steps: int, n_batch: int) -> np.ndarray | None:
    """Validate known inputs ``u``: (T, p) shared by all series, or (B, T, p). Returns (B, T, p) or None."""
    arr = linear_inputs(model, u, n_steps, n_batch)
    if arr is None:
        return None
    return np.ascontiguousarray(np.broadcast_to(arr, (n_batch,) + arr.shape[1:]))


def nonlinear_inputs(u, n_steps: int, n_batch: int) -> np.ndarray:
    """``u`` passed row by row to f and h: a writeable C-contiguous (B, T, p) array ((B, T, 0) when None)."""
    if u is None:
        return np.zeros((n_batch, n_steps, 0))
    arr = check_inputs(u, n_steps, n_batch=n_batch)
    U = np.ascontiguousarray(np.broadcast_to(arr, (n_batch,) + arr.shape[1:]))
    if not U.flags.writeable:  # a broadcast view: the compiled loops are typed for writeable arrays
        U = U.copy()
    return U


def noise_terms(Q: np.ndarray, R: np.ndarray, n_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Q (n, n) or (T-1, n, n) and R (m, m) or (T, m, m) checked against T and returned with a leading
    time axis (length 1 when constant; a (1, n, n) zero Q when T = 1), C-contiguous."""
    T = n_steps
    if Q.ndim == 3 and Q.shape[0] != T - 1:
        raise ShapeError(f"process_cov (Q) is time-varying with {Q.shape[0]} steps but y has T = {T} samples; "
                         f"it needs T-1 = {T - 1} (Q[k] is the noise of the step k -> k+1).")
    if R.ndim == 3 and R.shape[0] != T:
        raise ShapeError(f"obs_cov (R) is time-varying with {R.shape[0]} steps but y has T = {T} samples; it needs T.")
    Q3 = np.ascontiguousarray(Q if Q.ndim == 3 else Q[None])
    R3 = np.ascontiguousarray(R if R.ndim == 3 else R[None])
    if Q3.shape[0] == 0:
        Q3 = np.zeros((1,) + Q3.shape[1:])
    return Q3, R3


#: Covariances a batch may give per series (:func:`series_covariances`): name -> the side whose time axis a
#: time-varying array has ("transition": T-1 steps, "observation": T), None for the initial covariance.
SERIES_COVARIANCES = {"process_cov": "transition", "obs_cov": "observation", "initial_cov": None}


def series_covariances(model, n_batch: int, n_steps: int, given: dict) -> dict:
    """Validate per-series covariances of a batch of ``n_batch`` series of ``n_steps`` samples.

    ``given`` maps "process_cov", "obs_cov", "initial_cov" to arrays with a leading series axis: (B, n, n) /
    (B, m, m) constant in time, or (B, T-1, n, n) (process) / (B, T, m, m) (observation) time-varying; the
    initial covariance is (B, n, n). Each must be finite, symmetric and positive semi-definite. Returns the
    arrays with a time axis of length 1 when constant (initial: no time axis), C-contiguous float64.
    """
    sizes = {"process_cov": model.n_states, "obs_cov": model.n_obs, "initial_cov": model.n_states}
    out = {}
    for name, arr in given.items():
        if name not in SERIES_COVARIANCES:
            raise ShapeError(f"unknown per-series term {name!r}; known: {sorted(SERIES_COVARIANCES)}.")
        if arr is None:
            continue
        k = sizes[name]
        side = SERIES_COVARIANCES[name]
        a = as_float_array(name, arr, ndim=(3,) if side is None else (3, 4))
        steps = None if side is None else (n_steps - 1 if side == "transition" else n_steps)
        want = [(n_batch, k, k)] + ([] if side is None else [(n_batch, steps, k, k)])
        if a.shape not in want:
            raise ShapeError(f"per-series {name} must have shape {' or '.join(map(str, want))} (one per series of "
                             f"the batch of {n_batch}); got {a.shape}.")
        require_symmetric_psd(f"per-series {name}", a)
        if side is not None and a.ndim == 3:
            a = a[:, None]
        out[name] = np.ascontiguousarray(a)
    return out


def covariance_storage(store_covariances) -> tuple[bool, bool]:
    """(store the covariances and Jacobians, store the filtered variances only) of an EKF's ``store_covariances``.

    True: every covariance and Jacobian, O(T n^2) memory (what a smoother needs); False: means only;
    ``"variances"``: means and the diagonal of the filtered covariances, O(T n).
    """
    if isinstance(store_covariances, str):
        if store_covariances != "variances":
            raise InputError(f"store_covariances must be True, False or 'variances'; got {store_covariances!r}.")
        return False, True
    return bool(store_covariances), False
