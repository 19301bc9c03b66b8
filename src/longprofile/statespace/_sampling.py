"""Posterior sampling (forward-filter backward-sample) and simulation of linear-Gaussian models."""

from __future__ import annotations

import numbers

import numpy as np

from ..errors import InputError, ModelError
from . import _kernels
from ._kalman import kalman_filter, kernel_terms, smoother_arrays
from ._model import StateSpaceModel
from ._prepare import linear_inputs, prepare_observations

__all__ = ["posterior_sample", "simulate"]

# Eigenvalues of a covariance down to -_NEG_TOL * (largest eigenvalue) are round-off and set to 0;
# anything more negative means the recursion lost positive semi-definiteness and is an error.
_NEG_TOL = 1e-6
# Number of standard normal draws generated at once by posterior_sample (32 MB).
_CHUNK = 1 << 22


def _as_generator(rng) -> np.random.Generator:
    if rng is None or isinstance(rng, (numbers.Integral, np.random.SeedSequence)):
        return np.random.default_rng(rng)
    if isinstance(rng, np.random.Generator):
        return rng
    raise InputError(f"rng must be None, an integer seed or a numpy.random.Generator; got {type(rng).__name__}.")


def _count(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise InputError(f"{name} must be a positive integer; got {value!r}.")
    return int(value)


def psd_sqrt(cov: np.ndarray, what: str) -> np.ndarray:
    """Square-root factors ``S`` with ``S @ S.T == cov`` for a stack (..., n, n) of PSD matrices.

    Uses the symmetric eigen-decomposition, so rank-deficient covariances (e.g. a
    process noise acting on some states only) are handled exactly: the null
    directions get zero noise. Eigenvalues within round-off below zero are set to 0.
    """
    sym = 0.5 * (cov + np.swapaxes(cov, -1, -2))
    w, V = np.linalg.eigh(sym)
    scale = np.max(np.abs(w), axis=-1, keepdims=True)
    bad = w < -_NEG_TOL * np.maximum(scale, np.finfo(float).tiny)
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0][:-1])
        raise ModelError(f"{what} is not positive semi-definite (eigenvalue {w[bad].min():.3g} at index {idx}); "
                         "the model is too ill-conditioned for sampling. Rescale the states or check Q, R and P0.")
    # |eigenvalues| at the round-off level of the largest are exact zeros (e.g. a position fixed by the
    # next state): without this their square roots (~1e-8 relative) would blur deterministic constraints.
    w = np.where(w > 64.0 * np.finfo(float).eps * scale, w, 0.0)
    return V * np.sqrt(w)[..., None, :]


def posterior_sample(model: StateSpaceModel, y, n_samples: int, *, rng=None, u=None) -> np.ndarray:
    r"""Draw state trajectories from the smoothing posterior p(x_0..T-1 | y) (forward-filter backward-sample).

    Parameters
    ----------
    model : StateSpaceModel
        The linear-Gaussian model.
    y : (T,), (T, m) or (B, T, m) array_like
        Observations; NaN marks a missing component (as in :func:`kalman_filter`).
    n_samples : int
        Number of trajectories to draw (>= 1).
    rng : None, int or numpy.random.Generator, optional
        Source of randomness; an integer is a seed. Default: fresh OS entropy.
    u : (T, p) or (B, T, p) array_like, optional
        Known inputs.

    Returns
    -------
    (n_samples, T, n) ndarray
        Independent draws of the whole state trajectory; (n_samples, B, T, n) for batched ``y``.

    Raises
    ------
    ShapeError, InputError, ModelError
        As :func:`kalman_filter`; InputError also for a bad ``n_samples`` or ``rng``.

    See Also
    --------
    rts_smoother : the posterior means and covariances these draws scatter around.
    simulate : draws from the prior (the model itself).

    Notes
    -----
    Carter & Kohn (1994), Frühwirth-Schnatter (1994): after the Kalman filter,
    :math:`x_{T-1} \sim \mathcal N(\hat x_{T-1|T-1}, P_{T-1|T-1})` and backwards

    .. math::

        x_t \mid x_{t+1}, y &\sim \mathcal N\big(\hat x_{t|t} + G_t (x_{t+1} - \hat x_{t+1|t}),\;
        P_{t|t} - G_t P_{t+1|t} G_t^\top\big), \qquad G_t = P_{t|t} F_t^\top P_{t+1|t}^{-1}.

    The conditional covariance is often singular (an integrated random walk with
    noise on the velocity only fixes the position given the next state): it is
    factored by a symmetric eigen-decomposition with round-off clipping, never a
    Cholesky that would fail. The gains and factors are computed once per step and
    shared by all draws; the backward pass is a compiled loop.

    Examples
    --------
    >>> import numpy as np
    >>> from longprofile.statespace import StateSpaceModel, posterior_sample
    >>> model = StateSpaceModel([[1.0]], [[1.0]], [[0.1]], [[1.0]], [0.0], [[10.0]])
    >>> y = np.random.default_rng(0).normal(size=20)
    >>> posterior_sample(model, y, 100, rng=1).shape
    (100, 20, 1)
    """
    n_samples = _count("n_samples", n_samples)
    gen = _as_generator(rng)
    _Y, batched = prepare_observations(model, y)
    filtered = kalman_filter(model, y, u=u)
    _sm, _sc, _cc, gains = smoother_arrays(model, filtered, store_gains=True)
    mean = filtered.mean if batched else filtered.mean[None]
    cov = filtered.cov if batched else filtered.cov[None]
    pmean = filtered.pred_mean if batched else filtered.pred_mean[None]
    pcov = filtered.pred_cov if batched else filtered.pred_cov[None]
    nb, T, n = mean.shape
    out = np.empty((n_samples, nb, T, n))
    for b in range(nb):
        cond = np.empty((T, n, n))
        G = np.ascontiguousarray(gains[b])
        _kernels.backward_conditional_cov_kernel(np.ascontiguousarray(cov[b]), np.ascontiguousarray(pcov[b]),
                                                 G, cond)
        roots = np.ascontiguousarray(psd_sqrt(cond, "the backward conditional covariance"))
        args = (np.ascontiguousarray(mean[b]), np.ascontiguousarray(pmean[b]), G, roots)
        # standard normal draws in chunks of about _CHUNK numbers, so the noise never doubles the memory
        chunk = max(1, _CHUNK // (T * n))
        for s0 in range(0, n_samples, chunk):
            s1 = min(n_samples, s0 + chunk)
            z = gen.standard_normal((s1 - s0, T, n))
            if nb == 1:
                _kernels.backward_sample_kernel(*args, z, out[s0:s1, 0])  # contiguous when B = 1
            else:
                draws = np.empty((s1 - s0, T, n))
                _kernels.backward_sample_kernel(*args, z, draws)
                out[s0:s1, b] = draws
    return out if batched else out[:, 0]


def simulate(model: StateSpaceModel, n_steps: int, *, rng=None, u=None) -> tuple[np.ndarray, np.ndarray]:
    r"""Draw one state trajectory and its observations from the model.

    Parameters
    ----------
    model : StateSpaceModel
        The linear-Gaussian model (time-varying terms must have T-1 / T steps for T = ``n_steps``).
    n_steps : int
        Number of samples T (>= 1).
    rng : None, int or numpy.random.Generator, optional
        Source of randomness; an integer is a seed.
    u : (T, p) array_like, optional
        Known inputs; required when the model has input matrices.

    Returns
    -------
    x : (T, n) ndarray
        States, :math:`x_0 \sim \mathcal N(x_0^-, P_0^-)`, :math:`x_{k+1} = F_k x_k + B_k u_k + c_k + w_k`.
    y : (T, m) ndarray
        Observations :math:`y_k = H_k x_k + D_k u_k + d_k + v_k`.

    Raises
    ------
    ShapeError
        A time-varying term or ``u`` does not match ``n_steps``.
    InputError
        Bad ``n_steps`` or ``rng``.

    Notes
    -----
    Gaussian draws use symmetric square roots from an eigen-decomposition, so
    singular Q, R or P0 (noise on some directions only) are exact.

    Examples
    --------
    >>> from longprofile.statespace import StateSpaceModel, simulate
    >>> model = StateSpaceModel([[0.9]], [[1.0]], [[0.1]], [[1.0]], [0.0], [[1.0]])
    >>> x, y = simulate(model, 100, rng=0)
    >>> x.shape, y.shape
    ((100, 1), (100, 1))
    """
    T = _count("n_steps", n_steps)
    gen = _as_generator(rng)
    model.check_length(T)
    U = linear_inputs(model, u, T, 1)
    U = np.zeros((1, T, 0)) if U is None else U
    terms = kernel_terms(model)
    n, m = model.n_states, model.n_obs
    x0 = model.initial_mean + psd_sqrt(model.initial_cov, "initial_cov (P0)") @ gen.standard_normal(n)
    rq = psd_sqrt(terms["Q"], "process_cov (Q)")
    rr = psd_sqrt(terms["R"], "obs_cov (R)")
    zw = gen.standard_normal((max(T - 1, 0), n))
    zv = gen.standard_normal((T, m))
    w = np.einsum("tij,tj->ti", rq, zw) if rq.shape[0] > 1 else zw @ rq[0].T
    v = np.einsum("tij,tj->ti", rr, zv) if rr.shape[0] > 1 else zv @ rr[0].T
    x = np.empty((T, n))
    yy = np.empty((T, m))
    _kernels.simulate_kernel(terms["F"], terms["H"], terms["Bm"], terms["Dm"], terms["c"], terms["d"], U,
                             np.ascontiguousarray(x0), np.ascontiguousarray(w), np.ascontiguousarray(v), x, yy)
    return x, yy
