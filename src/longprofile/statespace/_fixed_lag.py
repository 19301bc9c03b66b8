"""Fixed-lag smoother E[x_t | y_0..t+L]: a real-time smoother with a fixed latency of L samples.

Implemented on the engine's filters (:func:`kalman_filter`, :func:`steady_state_filter`): the
fixed-lag estimate is the filtered estimate plus a finite sum of the L future innovations, so no
new Kalman recursion is written here (Anderson & Moore, *Optimal Filtering*, 1979, §7.3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from .._validation import as_float_array
from ..errors import InputError
from ._fixed_lag_kernels import fixed_lag_window_sums
from ._kalman import kalman_filter
from ._model import StateSpaceModel
from ._results import FilterResult
from ._shared_cov import shared_covariance_smoother
from ._steady import steady_state_filter, steady_state_gain

__all__ = ["FixedLagResult", "fixed_lag_smoother"]


@dataclass(frozen=True, eq=False)
class FixedLagResult:
    """Output of :func:`fixed_lag_smoother`.

    Attributes
    ----------
    mean : (T, k) ndarray
        E[x_t[states] | y_0..min(t + lag, T - 1)]; (B, T, k) for a batch.
    cov : (T, k, k) ndarray
        The matching posterior covariances (read-only; shared by a batch).
    std : (T, k) ndarray
        Square roots of their diagonals.
    states : (k,) ndarray of int
        Indices of the states returned (all n by default).
    lag : int
        L, in samples: the estimate at t uses data up to t + L (the last L estimates use the data
        up to the end of the record, i.e. they are the fixed-interval smoother's).
    method : str
        ``"exact"`` (time-varying gains of :func:`kalman_filter`) or ``"steady-state"``.
    filtered : FilterResult
        The forward pass the estimate was built from.
    """

    mean: np.ndarray
    cov: np.ndarray
    std: np.ndarray
    states: np.ndarray
    lag: int
    method: str
    filtered: FilterResult


def _check_lag(lag) -> int:
    if isinstance(lag, bool) or not isinstance(lag, (int, np.integer)):
        raise InputError(f"lag must be a non-negative integer number of samples; got {lag!r}.")
    if lag < 0:
        raise InputError(f"lag must be >= 0 samples (0 = the Kalman filter); got {lag}.")
    return int(lag)


def _check_states(states, n: int) -> np.ndarray:
    if states is None:
        return np.arange(n)
    idx = np.atleast_1d(np.asarray(states))
    if idx.ndim != 1 or idx.size == 0 or not np.issubdtype(idx.dtype, np.integer):
        raise InputError(f"states must be a non-empty sequence of state indices (integers); got {states!r}.")
    if idx.min() < -n or idx.max() >= n:
        raise InputError(f"states {idx.tolist()} out of range for a model with n = {n} states.")
    return np.mod(idx, n)


def _whitened(H, S, e):
    """Whitened observation matrices and innovations on the observed rows o of each step.

    With S_oo = L L' (Cholesky): Hw_t = L^-1 H_o and ew_t = L^-1 e_o, zero rows where y is missing, so
    that H_o' S_oo^-1 H_o = Hw' Hw and H_o' S_oo^-1 e_o = Hw' ew. ``e`` is (B, T, m): B series sharing the missing
    pattern of the first. Returns Hw (T, m, n), ew (B, T, m).
    """
    B, T, m = e.shape
    n = H.shape[-1]
    Hw = np.zeros((T, m, n))
    ew = np.zeros((B, T, m))
    missing = np.isnan(e[0])
    patterns, which = np.unique(missing, axis=0, return_inverse=True)
    which = np.asarray(which).reshape(-1)
    for p, pattern in enumerate(patterns):
        o = np.flatnonzero(~pattern)
        if o.size == 0:
            continue  # nothing observed: no information at these steps
        t = np.flatnonzero(which == p)
        chol = np.linalg.cholesky(S[t][:, o[:, None], o[None, :]])
        Hw[t[:, None], o[None, :]] = np.linalg.solve(chol, H[t][:, o, :])
        ew[:, t[:, None], o[None, :]] = np.linalg.solve(chol, e[:, t][:, :, o, None])[..., 0]  # all series at once
    return Hw, ew


def _exact(model, Y, u, lag, states):
    batched = Y.ndim == 3
    if batched:
        if u is not None:
            raise InputError("a batch of series y (B, T, m) takes no known inputs u (the batch shares one "
                             "filter's covariances); call fixed_lag_smoother once per series with its u.")
        filt = shared_covariance_smoother(model, Y).filtered  # one covariance pass for the batch
        means, innov = filt.mean, filt.innovation
    else:
        filt = kalman_filter(model, Y, u=u, store_covariances=True)
        means, innov = filt.mean[None], filt.innovation[None]
    T, n = means.shape[1:]
    F = model.transition
    H = model.observation
    H = np.broadcast_to(H, (T, *H.shape)) if H.ndim == 2 else H
    Hw, ew = _whitened(H, filt.innovation_cov, innov)
    mean = means[:, :, states].copy()
    cov = filt.cov[:, states[:, None], states[None, :]].copy()
    L = min(lag, T - 1)
    if L > 0:
        # closed loop of the prediction error: eps_{t+1} = F_t (I - K_t H_t) eps_t + (noise), K_t H_t = P Hw' Hw
        HwT = np.ascontiguousarray(np.swapaxes(Hw, 1, 2))
        closed = np.eye(n) - (filt.pred_cov[:-1] @ HwT[:-1]) @ Hw[:-1]
        closed_T = np.ascontiguousarray(np.swapaxes(F @ closed, 1, 2))
        # Cov(x_t[states], eps_{t+i} | y_<t) = P_t|t-1[states, :] (closed_{t+i-1} ... closed_t)': the L future
        # innovations' gains, summed as compositions of maps (._fixed_lag_kernels, O(T n^3) for any L)
        g = np.ascontiguousarray((HwT[None] @ ew[..., None])[..., 0])  # H' S^-1 e, per series
        G = np.ascontiguousarray(HwT @ Hw)  # H' S^-1 H
        Ps = np.ascontiguousarray(filt.pred_cov[:, states, :])
        dmean, dcov = np.empty_like(mean), np.empty_like(cov)
        fixed_lag_window_sums(closed_T, g, G, Ps, L, dmean, dcov)
        mean += dmean
        cov -= dcov
    return filt, (mean if batched else mean[0]), cov


def _full_convolution(x: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``scipy.signal.fftconvolve(x, h, mode="full")`` of two real 1-D arrays, bit for bit, with scipy.fft.

    scipy's steps (the reference: scipy/signal/_signaltools.py, ``fftconvolve``): an input of one sample is a plain
    product; otherwise real FFTs (``rfftn`` / ``irfftn`` over axis 0) of the next fast length >= len(x) + len(h) - 1,
    cut to that length. Calling scipy.fft directly spares the ~0.5 s import of scipy.signal (issue 12, start-up);
    tested against scipy.signal.fftconvolve with ``np.array_equal``. Returns (len(x) + len(h) - 1,) float64.
    """
    from scipy import fft

    if x.size == 0 or h.size == 0:
        return np.zeros(0)
    if x.size == 1 or h.size == 1:
        return x * h
    size = x.size + h.size - 1
    n = [fft.next_fast_len(size, True)]
    return fft.irfftn(fft.rfftn(x, n, axes=[0]) * fft.rfftn(h, n, axes=[0]), n, axes=[0])[:size].copy()


def _stationary(model, Y, u, lag, states):
    ss = steady_state_gain(model)
    filt = steady_state_filter(model, Y, u=u, gain=ss)
    T = filt.mean.shape[0]
    F, H = model.transition, model.observation
    n, m = model.n_states, model.n_obs
    k = states.size
    S = ss.innovation_cov
    cS = cho_factor(S, lower=True)
    HtSi = cho_solve(cS, H).T  # H' S^-1 (n, m)
    closed_T = (F @ (np.eye(n) - ss.gain @ H)).T
    L = min(lag, T - 1)
    # W_i = Cov(x_t[states], e_{t+i}) S^-1 = P[states, :] (closed^i)' H' S^-1, i = 1..L
    W = np.empty((L + 1, k, m))
    reduction = np.zeros((L + 1, k, k))  # cumulative sum of W_i S W_i' (variance removed by L future samples)
    psi = ss.pred_cov[states, :]
    W[0] = psi @ HtSi
    for i in range(1, L + 1):
        psi = psi @ closed_T
        W[i] = psi @ HtSi
        reduction[i] = reduction[i - 1] + W[i] @ S @ W[i].T
    mean = filt.mean[:, states].copy()
    if L > 0:
        e = filt.innovation
        for a in range(k):
            for j in range(m):
                # sum_{i=1..L} W_i[a, j] e_{t+i, j} as a correlation; e beyond the record end is absent (0)
                c = _full_convolution(e[:, j], W[:0:-1, a, j])  # c[t + L] = sum_i W_i e_{t+i}
                mean[:T - 1, a] += c[L:L + T - 1]
    n_future = np.minimum(L, T - 1 - np.arange(T))
    cov = ss.cov[np.ix_(states, states)][None] - reduction[n_future]
    return filt, mean, cov


def fixed_lag_smoother(model: StateSpaceModel, y, lag: int, *, u=None, stationary: bool = False,
                       states=None) -> FixedLagResult:
    r"""Fixed-lag smoother: E[x_t | y_0..t+L], the best estimate available L samples after t.

    A real-time estimator with a constant latency of ``lag`` samples: unlike the fixed-interval
    (RTS) smoother it never uses data more than L samples ahead, so it can run on a stream.
    ``lag = 0`` is the Kalman filter; as L exceeds the memory of the smoother it tends to
    :func:`rts_smoother` (``stationary=False``) or :func:`steady_state_smoother` (True).

    Parameters
    ----------
    model : StateSpaceModel
        Linear-Gaussian model; time-varying terms are accepted with ``stationary=False``.
    y : (T,) or (T, m) or (B, T, m) array_like
        Observations; NaN = missing (``stationary=False`` only). A batch (B, T, m) of series sharing one
        missing pattern runs with ``stationary=False`` and without ``u``: one covariance pass for all
        (:func:`shared_covariance_smoother`'s filter), the lag sums per series.
    lag : int
        L >= 0, samples.
    u : (T, p) array_like, optional
        Known inputs, as in :func:`kalman_filter`.
    stationary : bool, default False
        False: exact, on :func:`kalman_filter` with per-step gains and covariances
        (O(T n^2) memory, O(T n^3) time for any L: the lag sums as compositions of maps,
        :mod:`._fixed_lag_kernels`). True: constant gains of :func:`steady_state_gain`
        on :func:`steady_state_filter` (time-invariant, detectable model, complete data; the
        first samples carry the steady-state filter's start-up transient; O(T n) memory, the L
        future innovations summed by FFT convolution: fast for long L and long records).
    states : sequence of int, optional
        Indices of the states to return (default all): the work and memory of the lag sum scale
        with their number k.

    Returns
    -------
    FixedLagResult
        ``mean`` (T, k), ``cov`` (T, k, k), ``std`` (T, k), with ``filtered`` the forward pass.

    Raises
    ------
    InputError, ShapeError
        Negative or non-integer lag, bad state indices, batched y.
    NotDetectableError, ModelError
        With ``stationary=True``, as :func:`steady_state_gain`.

    Notes
    -----
    With e_j the innovations, S_j their covariances and eps_j = x_j - E[x_j | y_<j], the
    innovations are independent, so (Anderson & Moore 1979, §7.3)

    .. math::

        E[x_t \mid y_{0..t+L}] = E[x_t \mid y_{0..t}]
            + \sum_{i=1}^{L} \operatorname{Cov}(x_t, e_{t+i}) S_{t+i}^{-1} e_{t+i}, \qquad
        \operatorname{Cov}(x_t, e_{t+i}) = P_{t|t-1} \Phi_{t,i}^\top H_{t+i}^\top,

    with Phi_{t,i} = A_{t+i-1} ... A_t, A_j = F_j (I - K_j H_j) the closed loop of the prediction
    error; the covariance loses sum_i Cov(x_t, e_{t+i}) S^-1 Cov(x_t, e_{t+i})'. Missing components
    contribute nothing (their rows of H and S are dropped). This is the same estimator as the
    steady-state filter of the model augmented with L delayed copies of the selected states (whose
    gain blocks are the W_i = Cov(x_t, e_{t+i}) S^-1), without its (n + kL)-dimensional state.
    """
    if not isinstance(model, StateSpaceModel):
        raise InputError(f"fixed_lag_smoother needs a StateSpaceModel; got {type(model).__name__}.")
    lag = _check_lag(lag)
    arr = as_float_array("y", y, ndim=(1, 2, 3))
    idx = _check_states(states, model.n_states)
    if stationary and arr.ndim == 3:
        raise InputError("a batch of series y (B, T, m) runs with the exact gains only (stationary=False); call "
                         "the stationary smoother once per series.")
    if stationary:
        filt, mean, cov = _stationary(model, arr, u, lag, idx)
        method = "steady-state"
    else:
        filt, mean, cov = _exact(model, arr, u, lag, idx)
        method = "exact"
    cov = 0.5 * (cov + np.swapaxes(cov, 1, 2))
    std = np.sqrt(np.clip(np.diagonal(cov, axis1=1, axis2=2), 0.0, None))
    for a in (mean, cov, std):
        a.setflags(write=False)
    return FixedLagResult(mean=mean, cov=cov, std=std, states=idx, lag=lag, method=method, filtered=filt)
