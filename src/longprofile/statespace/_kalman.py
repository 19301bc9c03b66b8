"""Kalman filter and RTS smoother for :class:`StateSpaceModel`.

This module holds the public entry points: validation (once), shaping to
C-contiguous float64 batches and the dispatch to the compiled loops of
:mod:`._kernels`, which are the only linear filter/smoother loops in the package.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import InputError, ShapeError
from . import _kernels
from ._model import StateSpaceModel
from ._prepare import linear_inputs, prepare_observations, series_covariances
from ._results import FilterResult, SmootherResult
from ._status import raise_status

__all__ = ["kalman_filter", "rts_smoother", "log_likelihood"]


def _readonly(a: np.ndarray) -> np.ndarray:
    """A read-only, C-contiguous float64 view (one numba specialisation for every caller)."""
    a = np.ascontiguousarray(a, dtype=np.float64).view()
    a.setflags(write=False)
    return a


def _term(model: StateSpaceModel, name: str, base: int, default_shape: tuple) -> np.ndarray:
    """Model term with a leading time axis (length 1 when constant); zeros of ``default_shape`` if absent."""
    arr = getattr(model, name)
    if arr is None:
        return _readonly(np.zeros((1,) + default_shape))
    return _readonly(arr[None] if arr.ndim == base else arr)


def kernel_terms(model: StateSpaceModel) -> dict[str, np.ndarray]:
    """The model's terms in the kernels' layout (leading time axis, absent terms as zeros, p may be 0)."""
    n, m, p = model.n_states, model.n_obs, model.n_inputs
    return dict(
        F=_term(model, "transition", 2, (n, n)),
        H=_term(model, "observation", 2, (m, n)),
        Q=_term(model, "process_cov", 2, (n, n)),
        R=_term(model, "obs_cov", 2, (m, m)),
        Bm=_term(model, "input_transition", 2, (n, p)),
        Dm=_term(model, "input_observation", 2, (m, p)),
        c=_term(model, "state_offset", 1, (n,)),
        d=_term(model, "obs_offset", 1, (m,)),
        x0=_readonly(model.initial_mean),
        P0=_readonly(model.initial_cov),
    )


def _carve(*shapes) -> list[np.ndarray]:
    """Uninitialised float64 arrays of the given shapes, carved from ONE allocation.

    One large block instead of several medium ones: NumPy asks the kernel for huge
    pages on blocks of a few MB, which makes first-touch page faults ~20x cheaper
    (they otherwise dominate a 4-state filter). The arrays share the block as base.
    """
    sizes = [int(np.prod(s)) for s in shapes]
    block = np.empty(sum(sizes))
    out, start = [], 0
    for shape, size in zip(shapes, sizes):
        out.append(block[start:start + size].reshape(shape))
        start += size
    return out


def _raise_status(status: np.ndarray, batched: bool) -> None:
    raise_status(status[2], status[1], "kalman", series=status[0] if batched else None)


def kalman_filter(model: StateSpaceModel, y, *, u=None, store_covariances: bool = True,
                  series_cov: dict | None = None) -> FilterResult:
    r"""Kalman filter with missing data (NaN) and a Joseph-form covariance update.

    Parameters
    ----------
    model : StateSpaceModel
        The linear-Gaussian model.
    y : (T,), (T, m) or (B, T, m) array_like
        Observations in the units of the model; NaN marks a missing component
        (the update then uses only the observed rows of H and R). A 3-D array is
        a batch of B independent series of the same model. (T,) is accepted for m = 1.
    u : (T, p) or (B, T, p) array_like, optional
        Known inputs; ``u[k]`` enters the observation at step k and the
        transition k -> k+1. A (T, p) input is shared by every series of a batch.
        Required exactly when the model has input matrices.
    store_covariances : bool, default True
        If False, only means, innovations and the likelihood are returned
        (``cov``, ``pred_cov``, ``innovation_cov`` are None): O(T n) memory,
        for very long signals.
    series_cov : dict, optional
        Noise and initial covariances that differ between the series of a batch (B, T, m) ``y``, replacing
        the model's: ``"process_cov"`` (B, n, n) or (B, T-1, n, n), ``"obs_cov"`` (B, m, m) or (B, T, m, m),
        ``"initial_cov"`` (B, n, n); each finite, symmetric, positive semi-definite. Every series then runs
        its own covariance recursion in the same compiled loop (e.g. one smoother per station and candidate
        process noise in one call, ``rail.smooth_through_time``). :func:`rts_smoother` needs nothing more
        (it uses the filtered covariances and F).

    Returns
    -------
    FilterResult
        ``mean``/``pred_mean`` (T, n), ``cov``/``pred_cov`` (T, n, n),
        ``innovation`` (T, m) (NaN where missing), ``innovation_cov`` (T, m, m),
        ``log_likelihood`` (float), ``log_likelihood_steps`` (T,), ``n_observed``
        (int); every per-step field gains a leading axis B for batched ``y``, and
        ``log_likelihood``/``n_observed`` become (B,) arrays.

    Raises
    ------
    ShapeError
        ``y`` or ``u`` do not match the model, or a time-varying term does not
        have T-1 (transition side) or T (observation side) steps.
    InputError
        ``y`` has infinite values, ``u`` has NaN or infinite values.
    ModelError
        The innovation covariance of the observed components is not positive definite.

    See Also
    --------
    rts_smoother, log_likelihood

    Notes
    -----
    Prediction and update (Kalman 1960; Joseph form of the covariance update,
    Bucy & Joseph 1968), with :math:`o` the observed components of step k:

    .. math::

        S_k &= H_o P_k^- H_o^\top + R_{oo}, \qquad K_k = P_k^- H_o^\top S_k^{-1}
        \quad\text{(Cholesky solve, no inverse)} \\
        x_k &= x_k^- + K_k (y_{k,o} - H_o x_k^- - D_o u_k - d_o) \\
        P_k &= (I - K_k H_o) P_k^- (I - K_k H_o)^\top + K_k R_{oo} K_k^\top \\
        x_{k+1}^- &= F_k x_k + B_k u_k + c_k, \qquad P_{k+1}^- = F_k P_k F_k^\top + Q_k

    Covariances are symmetrised after every step. The log-likelihood is the
    prediction-error decomposition over the observed components only; a step
    with every component missing is a pure prediction contributing 0.

    Timing convention: ``model.initial_mean`` is the prior of x_0 before y_0,
    ``pred_mean[t]`` = E[x_t | y_<t], ``mean[t]`` = E[x_t | y_<=t].

    Examples
    --------
    >>> import numpy as np
    >>> from longprofile.statespace import StateSpaceModel, kalman_filter
    >>> model = StateSpaceModel([[1.0]], [[1.0]], [[0.1]], [[1.0]], [0.0], [[10.0]])
    >>> y = np.random.default_rng(0).normal(size=50)
    >>> res = kalman_filter(model, y)
    >>> res.mean.shape, res.cov.shape
    ((50, 1), (50, 1, 1))
    """
    return _kalman_filter(model, y, u, store_covariances, None, series_cov)


def kalman_filter_final_cov(model: StateSpaceModel, y) -> tuple[FilterResult, np.ndarray, np.ndarray]:
    """Means-only :func:`kalman_filter` of one series that also keeps the innovation covariances (T, m, m) and
    returns the last step's filtered covariance P_(T-1|T-1): a chunk of a long record, to be continued."""
    final: list = []
    res = _kalman_filter(model, y, None, False, final)
    return replace(res, innovation_cov=final[2]), final[0]


def _kalman_filter(model, y, u, store_covariances, final, series_cov=None):
    Y, batched = prepare_observations(model, y)
    nb, T, m = Y.shape
    U = linear_inputs(model, u, T, nb)
    if U is None:
        U = np.zeros((1, T, 0))
    terms = kernel_terms(model)
    if series_cov and not batched:
        raise ShapeError("series_cov gives covariances per series of a batch: pass y as (B, T, m).")
    per = series_covariances(model, nb, T, dict(series_cov or {}))
    # the kernel's noise and initial covariances carry a leading series axis: 1 (shared) or nb
    Q = _readonly(per["process_cov"]) if "process_cov" in per else terms["Q"][None]
    R = _readonly(per["obs_cov"]) if "obs_cov" in per else terms["R"][None]
    P0 = _readonly(per["initial_cov"]) if "initial_cov" in per else terms["P0"][None]
    n = model.n_states
    store = bool(store_covariances)
    cshape = (nb, T) if store else (1, 1)
    ishape = (nb, T) if store or final is not None else (1, 1)
    mean, pmean, innov, ll, cov, pcov, icov = _carve(
        (nb, T, n), (nb, T, n), (nb, T, m), (nb, T), cshape + (n, n), cshape + (n, n), ishape + (m, m))
    nobs = np.empty(nb, dtype=np.int64)
    status = np.empty(3, dtype=np.int64)
    _kernels.kalman_filter_kernel(
        terms["F"], terms["H"], Q, R, terms["Bm"], terms["Dm"], terms["c"], terms["d"],
        terms["x0"], P0, _readonly(Y), _readonly(U), store,
        mean, cov, pmean, pcov, innov, icov, ll, nobs, status)
    _raise_status(status, batched)
    if final is not None:  # means-only: the last step's covariances, from the kernel's scratch; the S_k
        final.extend([cov[0, 0].copy(), pcov[0, 0].copy(), icov[0]])
    if not batched:
        mean, pmean, innov, ll = mean[0], pmean[0], innov[0], ll[0]
        if store:
            cov, pcov, icov = cov[0], pcov[0], icov[0]
    return FilterResult(
        mean=mean, cov=cov if store else None,
        pred_mean=pmean, pred_cov=pcov if store else None,
        innovation=innov, innovation_cov=icov if store else None,
        log_likelihood=ll.sum(axis=-1) if batched else float(ll.sum()),
        log_likelihood_steps=ll, n_observed=nobs if batched else int(nobs[0]), method="joseph")


def log_likelihood(model: StateSpaceModel, y, *, u=None, series_cov: dict | None = None) -> float | np.ndarray:
    """Gaussian log-likelihood of ``y`` under ``model`` (prediction-error decomposition).

    Parameters
    ----------
    model : StateSpaceModel
        The linear-Gaussian model.
    y : (T,), (T, m) or (B, T, m) array_like
        Observations; NaN components are missing and do not count.
    u : (T, p) or (B, T, p) array_like, optional
        Known inputs.
    series_cov : dict, optional
        Per-series noise and initial covariances of a batch (:func:`kalman_filter`).

    Returns
    -------
    float or (B,) ndarray
        :math:`\\sum_k \\log \\mathcal N(y_{k,o}; \\hat y_{k,o}, S_k)` over the observed components.

    Notes
    -----
    Runs the means-only filter (no covariance storage); see :func:`kalman_filter`.
    """
    return kalman_filter(model, y, u=u, store_covariances=False, series_cov=series_cov).log_likelihood


def smoother_arrays(model: StateSpaceModel, filtered: FilterResult, *, store_gains: bool = False):
    """Validate ``filtered`` against ``model`` and run the RTS kernel.

    Returns (mean, cov, cross_cov, gains) with a leading batch axis always;
    ``gains`` (B, T-1, n, n) holds G_t = P_t|t F_t' (P_t+1|t)^{-1} when ``store_gains``.
    """
    if not isinstance(filtered, FilterResult):
        raise InputError(f"filtered must be the FilterResult returned by kalman_filter; got {type(filtered).__name__}.")
    if filtered.cov is None or filtered.pred_cov is None:
        raise ShapeError("rts_smoother needs the filtered covariances; run kalman_filter with store_covariances=True.")
    mean = filtered.mean if filtered.mean.ndim == 3 else filtered.mean[None]
    n = model.n_states
    if mean.ndim != 3 or mean.shape[-1] != n:
        raise ShapeError(f"filtered.mean has shape {filtered.mean.shape}, which does not match the model's "
                         f"n = {n} states; smooth with the model the filter was run with.")
    nb, T, _ = mean.shape
    model.check_length(T)

    def b3(a, tail):
        a = a if a.ndim == len(tail) + 2 else a[None]
        if a.shape != (nb, T) + tail:
            raise ShapeError(f"filtered result is inconsistent: expected shape {(nb, T) + tail}, got {a.shape}.")
        return _readonly(a)

    args = (b3(filtered.mean, (n,)), b3(filtered.cov, (n, n)), b3(filtered.pred_mean, (n,)),
            b3(filtered.pred_cov, (n, n)))
    sm, sc, cc = _carve((nb, T, n), (nb, T, n, n), (nb, max(T - 1, 0), n, n))
    gains = np.empty((nb, max(T - 1, 0), n, n) if store_gains else (1, 1, n, n))
    _kernels.rts_smoother_kernel(kernel_terms(model)["F"], *args, bool(store_gains), sm, sc, cc, gains)
    return sm, sc, cc, (gains if store_gains else None)


def rts_smoother(model: StateSpaceModel, filtered: FilterResult) -> SmootherResult:
    r"""Rauch–Tung–Striebel smoother on the output of :func:`kalman_filter`.

    Parameters
    ----------
    model : StateSpaceModel
        The model the filter was run with.
    filtered : FilterResult
        Output of :func:`kalman_filter` with covariances stored (one series or a batch).

    Returns
    -------
    SmootherResult
        ``mean`` (T, n), ``cov`` (T, n, n) and lag-one cross-covariances
        ``cross_cov`` (T-1, n, n), ``cross_cov[t] = Cov(x_t, x_{t+1} | y)``;
        a leading batch axis B when the filter ran on a batch.

    Raises
    ------
    ShapeError
        The filter ran without covariances, or its shapes do not match the model.

    Notes
    -----
    Rauch, Tung & Striebel (1965):

    .. math::

        G_t &= P_{t|t} F_t^\top P_{t+1|t}^{-1} \quad\text{(Cholesky solve; eigen pseudo-inverse if singular)} \\
        \hat x_{t|T} &= \hat x_{t|t} + G_t (\hat x_{t+1|T} - \hat x_{t+1|t}) \\
        P_{t|T} &= P_{t|t} + G_t (P_{t+1|T} - P_{t+1|t}) G_t^\top, \qquad
        \operatorname{Cov}(x_t, x_{t+1} \mid y) = G_t P_{t+1|T}

    (the cross-covariance identity is de Jong 1989 / Shumway & Stoffer's lag-one
    covariance written as a true covariance, not a second moment).
    """
    sm, sc, cc, _ = smoother_arrays(model, filtered)
    if filtered.mean.ndim == 2:
        sm, sc, cc = sm[0], sc[0], cc[0]
    return SmootherResult(mean=sm, cov=sc, cross_cov=cc, filtered=filtered)
