"""Kalman filter + RTS smoother of many groups of series in one compiled call, each group its own noise levels.

:mod:`._shared_cov` runs one covariance pass for a batch of series sharing one model. Some problems have many such
batches that differ only in the scale of the process covariance and in the observation covariance: the rail
all-days model (paper 004's rigidity prior, one group per day mode or per noise level, docs/rail.md step 10) runs
hundreds of them per estimate, and a search over a per-day prior intensity evaluates one log-likelihood per day and
candidate. Here every group g has Q -> s_g Q and its own R_g; each group's filter covariance pass is the same
compiled code as :func:`~longprofile.statespace.shared_covariance_smoother`'s (Joseph form), its smoother and
noise-covariance recursions the same recursions in small loops without allocation per step (LAPACK's LU and numpy
products per step cost 6-8 times more for n <= 3), all groups in one compiled loop, so each group costs its
O(T n^3) pass and nothing else (no Python call, no model validation per group). The log-likelihoods equal the
shared-covariance functions run group by group bit for bit (``univariate=False``); the smoothed moments equal them
to round-off (tested).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._jit import njit
from .._validation import as_float_array
from ..errors import InputError, ShapeError
from ._linalg_kernels import FASTMATH, cholesky_lower, copy2, inverse_diagonal, matmul_into, solve_rows
from ._model import StateSpaceModel
from ._shared_cov import (
    _filter_cov_pass,
    _mean_pass,
    _not_positive_definite,
    _shared_terms,
    read_only,
)

__all__ = ["GroupedSmootherResult", "grouped_covariance_smoother", "grouped_log_likelihood"]


@dataclass(frozen=True, eq=False)
class GroupedSmootherResult:
    """Output of :func:`grouped_covariance_smoother`. B series, G groups, T steps, n states.

    Attributes
    ----------
    mean : (B, T, n) ndarray
        Smoothed means of every series.
    cov : (G, T, n, n) ndarray
        Smoothed covariances, shared by the series of a group (``cov[group[b]]`` is series b's).
    cross_cov : (G, T-1, n, n) ndarray
        Lag-one smoothed cross-covariances Cov(x_t, x_{t+1} | y) of each group.
    log_likelihood : (B,) ndarray
        log p(y_b) of every series (prediction-error decomposition, summed over the steps as
        :func:`~longprofile.statespace.shared_covariance_smoother` sums them).
    group : (B,) ndarray of int
        The group of each series.
    noise_cov : (G, T, n, n) ndarray or None
        With ``noise_cov`` given: :func:`~longprofile.statespace.smoother_noise_covariance` of each group.
    """

    mean: np.ndarray
    cov: np.ndarray
    cross_cov: np.ndarray
    log_likelihood: np.ndarray
    group: np.ndarray
    noise_cov: np.ndarray | None


@njit(cache=True)
def _smoother_cov_loops(F, Pp, Pf, Ps, G, cc):  # pragma: no cover - compiled
    """The RTS smoother's covariance recursion in small loops, no allocation per step (``_linalg_kernels``):
    G_k = Pf_k F_k' Pp_{k+1}^-1 by a Cholesky factor of Pp_{k+1}, Ps_k = Pf_k + G_k (Ps_{k+1} - Pp_{k+1}) G_k'
    (symmetrised), cc_k = G_k Ps_{k+1}. Mathematically :func:`._shared_cov._smoother_cov_pass` (LU through LAPACK
    and an allocation per step: 6-8 times slower for n <= 3, measured); equal to round-off. False where Pp_{k+1}
    is not positive definite."""
    T, n = Pf.shape[0], Pf.shape[1]
    L = np.empty((n, n))
    dinv = np.empty(n)
    work = np.empty(n)
    X = np.empty((n, n))
    D = np.empty((n, n))
    copy2(Pf[T - 1], Ps[T - 1])
    for k in range(T - 2, -1, -1):
        matmul_into(Pf[k], F[k].T, n, n, n, G[k])  # Pf F' (Pf symmetric)
        copy2(Pp[k + 1], L)
        if not cholesky_lower(L, n, 0.0):
            return False
        inverse_diagonal(L, n, dinv)
        solve_rows(L, dinv, n, G[k], n, work)
        for a in range(n):
            for b in range(n):
                D[a, b] = Ps[k + 1, a, b] - Pp[k + 1, a, b]
        matmul_into(G[k], D, n, n, n, X)
        for a in range(n):
            for b in range(a, n):
                s = Pf[k, a, b] + Pf[k, b, a]
                for c in range(n):
                    s += X[a, c] * G[k, b, c] + X[b, c] * G[k, a, c]
                Ps[k, a, b] = 0.5 * s
                Ps[k, b, a] = 0.5 * s
        matmul_into(G[k], Ps[k + 1], n, n, n, cc[k])
    return True


@njit(cache=True)
def _noise_cov_loops(F, H, K, G, Rn, out):  # pragma: no cover - compiled
    """:func:`._shared_cov._noise_cov_pass` (the smoothed mean's covariance from the observation noise alone) in
    small loops without allocation per step; equal to round-off."""
    T, m, n = H.shape
    A = np.zeros((T, n, n))
    Pf = np.empty((T, n, n))
    KR = np.empty((n, m))
    W = np.empty((n, n))
    B = np.empty((n, n))
    M = np.empty((n, n))
    X = np.empty((n, n))
    Nk = np.eye(n)
    Nn = np.empty((n, n))
    for k in range(T):
        matmul_into(K[k], Rn[k], n, m, m, KR)
        if k > 0:
            for a in range(n):  # A_k = (I - K_k H_k) F_{k-1}
                for b in range(n):
                    W[a, b] = (1.0 if a == b else 0.0)
                    for j in range(m):
                        W[a, b] -= K[k, a, j] * H[k, j, b]
            matmul_into(W, F[k - 1], n, n, n, A[k])
            matmul_into(A[k], Pf[k - 1], n, n, n, W)
        for a in range(n):
            for b in range(a, n):
                s = 0.0
                for j in range(m):
                    s += KR[a, j] * K[k, b, j] + KR[b, j] * K[k, a, j]
                if k > 0:
                    for c in range(n):
                        s += W[a, c] * A[k, b, c] + W[b, c] * A[k, a, c]
                Pf[k, a, b] = 0.5 * s
                Pf[k, b, a] = 0.5 * s
    copy2(Pf[T - 1], out[T - 1])
    for k in range(T - 2, -1, -1):
        matmul_into(Nk, A[k + 1], n, n, n, M)  # d xs[k+1] / d xf[k]
        for a in range(n):
            for b in range(n):
                B[a, b] = (1.0 if a == b else 0.0)
                for c in range(n):
                    B[a, b] -= G[k, a, c] * F[k, c, b]
        matmul_into(B, Pf[k], n, n, n, W)  # B Pf
        matmul_into(W, M.T, n, n, n, Nn)  # B Pf M'
        matmul_into(Nn, G[k].T, n, n, n, X)  # X = B Pf M' G'
        matmul_into(G[k], out[k + 1], n, n, n, Nn)  # G S
        for a in range(n):  # S_k = B Pf B' + G S G' + X + X', symmetrised
            for b in range(a, n):
                s = 2.0 * (X[a, b] + X[b, a])
                for c in range(n):
                    s += W[a, c] * B[b, c] + W[b, c] * B[a, c] + Nn[a, c] * G[k, b, c] + Nn[b, c] * G[k, a, c]
                out[k, a, b] = 0.5 * s
                out[k, b, a] = 0.5 * s
        for a in range(n):  # N_k = B + G M
            for b in range(n):
                s = B[a, b]
                for c in range(n):
                    s += G[k, a, c] * M[c, b]
                Nn[a, b] = s
        copy2(Nn, Nk)
    return out


@njit(cache=True, fastmath=FASTMATH)
def _univariate_loglik(y, F, c, H, d, x0, Qg, s, R, P0, obs, ll):  # pragma: no cover - compiled
    """Log-likelihood terms (T,) of one series into ``ll`` by the univariate treatment of a diagonal R (Durbin &
    Koopman 2012, §6.4): each observed component in turn, a scalar Joseph-form update, no matrix inverse; Q -> s Q.
    Returns False where an innovation variance is not positive."""
    T, m, n = H.shape
    P = P0.copy()
    x = x0.copy()
    PHt = np.empty(n)
    Kg = np.empty(n)
    A = np.empty((n, n))
    AP = np.empty((n, n))
    FP = np.empty((n, n))
    xn = np.empty(n)
    for k in range(T):
        acc_ll = 0.0
        for j in range(m):
            if not obs[k, j]:
                continue
            r = R[k, j, j]
            for i in range(n):
                t = 0.0
                for q in range(n):
                    t += P[i, q] * H[k, j, q]
                PHt[i] = t
            v = r
            e = y[k, j] - d[k, j]
            for i in range(n):
                v += H[k, j, i] * PHt[i]
                e -= H[k, j, i] * x[i]
            if not v > 0.0:
                return False
            for i in range(n):
                Kg[i] = PHt[i] / v
                x[i] += Kg[i] * e
            acc_ll += -0.5 * (1.8378770664093453 + np.log(v) + e * e / v)
            for i in range(n):  # Joseph form: (I - K h) P (I - K h)' + K r K'
                for q in range(n):
                    A[i, q] = (1.0 if i == q else 0.0) - Kg[i] * H[k, j, q]
            for i in range(n):
                for q in range(n):
                    t = 0.0
                    for a in range(n):
                        t += A[i, a] * P[a, q]
                    AP[i, q] = t
            for i in range(n):
                for q in range(i, n):
                    t = Kg[i] * r * Kg[q]
                    for a in range(n):
                        t += AP[i, a] * A[q, a]
                    P[i, q] = t
                    P[q, i] = t
        ll[k] = acc_ll
        if k < T - 1:
            for i in range(n):
                for q in range(n):
                    t = 0.0
                    for a in range(n):
                        t += F[k, i, a] * P[a, q]
                    FP[i, q] = t
            for i in range(n):
                for q in range(i, n):
                    t = 0.5 * s * (Qg[k, i, q] + Qg[k, q, i])
                    for a in range(n):
                        t += FP[i, a] * F[k, q, a]
                    P[i, q] = t
                    P[q, i] = t
            for i in range(n):
                t = c[k, i]
                for a in range(n):
                    t += F[k, i, a] * x[a]
                xn[i] = t
            for i in range(n):
                x[i] = xn[i]
    return True


@njit(cache=True)
def _univariate_pass(Yz, F, c, H, d, x0, Q, scale, R, P0, obs, group):  # pragma: no cover - compiled
    """:func:`_univariate_loglik` of every series with its group's scale, R and pattern: (ll (B, T), first failing
    series or -1)."""
    B, T, m = Yz.shape
    ll = np.zeros((B, T))
    for b in range(B):
        g = group[b]
        if not _univariate_loglik(Yz[b], F, c, H, d, x0, Q, scale[g], R[g], P0, obs[g], ll[b]):
            return ll, b
    return ll, -1


@njit(cache=True)
def _grouped_pass(Yz, F, c, H, d, x0, Q, scale, R, P0, obs, order, start, store, Rn):  # pragma: no cover - compiled
    """Every group's covariance pass (Q scaled, its own R) and its series' means through the shared gains.

    ``order[start[g]:start[g+1]]`` are the series of group g; ``obs[g]`` its observed pattern. Returns the smoothed
    means (B, T, n), per-group smoothed and cross covariances, the per-step log-likelihood terms (B, T), the
    per-group noise covariances (when ``Rn`` has G rows) and the first group whose innovation covariance is not
    positive definite (-1: none)."""
    B, T, m = Yz.shape
    n = x0.shape[0]
    G = scale.shape[0]
    Gs = G if store else 0
    mean = np.empty((B if store else 0, T, n))
    cov = np.empty((Gs, T, n, n))
    cross = np.empty((Gs, max(T - 1, 0), n, n))
    noise = np.empty((Rn.shape[0], T, n, n))
    ll = np.zeros((B, T))
    Qg = np.empty_like(Q)
    no_gains = np.zeros((0, n, n))
    for g in range(G):
        for k in range(Q.shape[0]):
            for a in range(n):
                for b in range(n):
                    Qg[k, a, b] = scale[g] * Q[k, a, b]
        Pp, Pf, K, S, Sinv, logdet, bad = _filter_cov_pass(F, Qg, H, R[g], P0, obs[g])
        if bad >= 0:
            return mean, cov, cross, ll, noise, g
        rows = order[start[g]:start[g + 1]]
        n_obs_step = np.zeros(T, dtype=np.int64)
        for k in range(T):
            for j in range(m):
                if obs[g, k, j]:
                    n_obs_step[k] += 1
        if store:
            Gk = np.zeros((max(T - 1, 1), n, n))
            if not _smoother_cov_loops(F, Pp, Pf, cov[g], Gk, cross[g]):
                return mean, cov, cross, ll, noise, g
            ms = _mean_pass(Yz[rows], F, c, H, d, x0, K, Sinv, logdet, Gk, obs[g], n_obs_step, True)
            for i in range(rows.size):
                mean[rows[i]] = ms[2][i]
                ll[rows[i]] = ms[4][i]
            if Rn.shape[0] > 0:
                _noise_cov_loops(F, H, K, Gk, Rn[g], noise[g])
        else:
            lg = _mean_pass(Yz[rows], F, c, H, d, x0, K, Sinv, logdet, no_gains, obs[g], n_obs_step, False)[-1]
            for i in range(rows.size):
                ll[rows[i]] = lg[i]
    return mean, cov, cross, ll, noise, -1


def _group_terms(model: StateSpaceModel, y, group, process_scale, obs_cov, name: str):
    """Checked inputs of the grouped functions: (Yz, F, c, H, d, Q, scale (G,), R (G, T, m, m), obs (G, T, m),
    order, start, group (B,))."""
    if model.n_inputs:
        raise ShapeError(f"{name} does not take known inputs (the model has B or D).")
    arr = as_float_array("y", y, ndim=3)
    B, T, m = arr.shape
    if m != model.n_obs:
        raise ShapeError(f"y must be (B, T, {model.n_obs}); got shape {arr.shape}.")
    grp = np.asarray(group)
    if grp.shape != (B,) or not np.issubdtype(grp.dtype, np.integer) or (B and grp.min() < 0):
        raise InputError(f"group must be ({B},) non-negative integers; got shape {grp.shape}, dtype {grp.dtype}.")
    G = int(grp.max()) + 1 if B else 0
    for arr_ in (process_scale, obs_cov):  # their leading axis is the group; checked below
        if arr_ is not None and np.ndim(arr_) > 0:
            G = max(G, int(np.shape(arr_)[0]))
    # the model's own terms (and its per-step checks) through the shared-covariance preparation, one series
    _, _, _, F, Q, c, H, R0, d = _shared_terms(model, np.where(np.isnan(arr[:1]), 0.0, arr[:1]) if B else
                                               np.zeros((1, T, m)), name)
    scale = np.ones(G) if process_scale is None else as_float_array("process_scale", process_scale, ndim=1,
                                                                      allow_nan=False)
    if scale.shape != (G,) or not np.all(scale > 0):
        raise InputError(f"process_scale must be ({G},) values > 0; got shape {scale.shape}.")
    if obs_cov is None:
        R = np.ascontiguousarray(np.broadcast_to(R0, (G, T, m, m)))
    else:
        Rg = as_float_array("obs_cov", obs_cov, ndim=(3, 4), allow_nan=False)
        if Rg.shape not in ((G, m, m), (G, T, m, m)):
            raise ShapeError(f"obs_cov must be ({G}, {m}, {m}) or ({G}, {T}, {m}, {m}); got {Rg.shape}.")
        R = np.ascontiguousarray(np.broadcast_to(Rg[:, None] if Rg.ndim == 3 else Rg, (G, T, m, m)))
    nan = np.isnan(arr)
    order = np.argsort(grp, kind="stable").astype(np.int64)
    start = np.searchsorted(grp[order], np.arange(G + 1)).astype(np.int64)
    obs = np.ones((G, T, m), dtype=bool)
    if B:
        first = order[start[grp[order]]]  # the first series of each series' group
        bad = (nan[order] != nan[first]).any(axis=(1, 2))
        if bad.any():
            raise ShapeError(f"the series of group {int(grp[order][bad][0])} must have NaN at the same places (they "
                             "share covariances).")
        used = start[:-1] < start[1:]
        obs[used] = ~nan[order[start[:-1][used]]]
    return (np.where(nan, 0.0, arr), F, c, H, d, Q, scale, R, obs, order, start, grp.astype(np.int64))


def _run(model, terms, store, noise_cov=None):
    Yz, F, c, H, d, Q, scale, R, obs, order, start, grp = terms
    G, T, m = obs.shape
    Rn = np.zeros((0, T, m, m))
    if noise_cov is not None:
        Rn = as_float_array("noise_cov", noise_cov, ndim=(3, 4), allow_nan=False)
        if Rn.shape not in ((G, m, m), (G, T, m, m)):
            raise ShapeError(f"noise_cov must be ({G}, {m}, {m}) or ({G}, {T}, {m}, {m}); got {Rn.shape}.")
        Rn = np.ascontiguousarray(np.broadcast_to(Rn[:, None] if Rn.ndim == 3 else Rn, (G, T, m, m)))
    try:
        x0, P0 = np.ascontiguousarray(model.initial_mean), np.ascontiguousarray(model.initial_cov)
        Yz, F, c, H, d, x0, Q, scale, R, P0, obs, order, start, Rn = read_only(Yz, F, c, H, d, x0, Q, scale, R, P0, obs,
                                                                               order, start, Rn)
        out = _grouped_pass(Yz, F, c, H, d, x0, Q, scale, R, P0, obs, order, start, store, Rn)
    except np.linalg.LinAlgError:
        raise _not_positive_definite() from None
    if out[-1] >= 0:
        raise _not_positive_definite()
    return out


def grouped_covariance_smoother(model: StateSpaceModel, y, group, *, process_scale=None, obs_cov=None,
                                noise_cov=None) -> GroupedSmootherResult:
    r"""Kalman filter and RTS smoother of groups of series, group g with Q -> s_g Q and its own R_g.

    Parameters
    ----------
    model : StateSpaceModel
        Linear-Gaussian model without known inputs (offsets allowed); its ``process_cov`` is the s = 1 term and its
        ``obs_cov`` the default of every group.
    y : (B, T, m) array_like
        Observations; NaN = missing. The series of one group share one NaN pattern; groups may differ.
    group : (B,) array_like of int
        Group of each series, 0..G-1 (G: the largest group + 1, or the length of ``process_scale`` / ``obs_cov``).
    process_scale : (G,) array_like, optional
        s_g > 0 (default 1): Q_t -> s_g Q_t in group g (formed in the kernel, as
        :func:`~longprofile.statespace.process_scale_log_likelihood` does).
    obs_cov : (G, m, m) or (G, T, m, m) array_like, optional
        R of each group (constant or per step); default the model's.
    noise_cov : (G, m, m) or (G, T, m, m) array_like, optional
        Covariance of the noise actually driving each group's estimate: also return
        :func:`~longprofile.statespace.smoother_noise_covariance` of each group.

    Returns
    -------
    GroupedSmootherResult

    Raises
    ------
    ShapeError
        Known inputs, wrong shapes, or a group whose series differ in their NaN pattern.
    ModelError
        If an innovation covariance is not positive definite on the observed components.

    Notes
    -----
    Group by group the same Joseph-form filter and RTS smoother covariance recursions as
    :func:`~longprofile.statespace.shared_covariance_smoother` (one pass per group, O(T n^3); the smoother gain by a
    Cholesky factor of the predicted covariance in small loops, where the shared smoother calls LAPACK's LU) and the
    same mean recursions through its gains (O(T n m) per series), all groups in one compiled loop: each group's
    results equal ``shared_covariance_smoother(model.replace(process_cov=s_g Q, obs_cov=R_g), y[group == g])`` to
    round-off, its log-likelihoods bit for bit.
    """
    terms = _group_terms(model, y, group, process_scale, obs_cov, "grouped_covariance_smoother")
    mean, cov, cross, ll, noise, _ = _run(model, terms, True, noise_cov)
    return GroupedSmootherResult(mean=mean, cov=cov, cross_cov=cross, log_likelihood=ll.sum(axis=-1),
                                 group=terms[-1], noise_cov=None if noise_cov is None else noise)


def grouped_log_likelihood(model: StateSpaceModel, y, group, *, process_scale=None, obs_cov=None,
                           univariate: bool = False) -> np.ndarray:
    r"""Log-likelihood of every series of :func:`grouped_covariance_smoother`'s groups, forward pass only.

    Parameters
    ----------
    model, y, group, process_scale, obs_cov
        As in :func:`grouped_covariance_smoother`.
    univariate : bool, default False
        Every series its own covariance recursion in the univariate treatment of the observations (Durbin & Koopman
        2012, §6.4: the observed components one at a time, scalar Joseph-form updates, in small fastmath loops): about
        five times faster for small state sizes, equal to the default to round-off (not bit for bit). Needs every
        R_g diagonal (independent observation noises).

    Returns
    -------
    (B,) ndarray
        log p(y_b) under its group's model: by default equal, bit for bit, to
        ``process_scale_log_likelihood(model.replace(obs_cov=R_g), y[group == g])(s_g)`` group by group.

    Raises
    ------
    ShapeError, ModelError
        As :func:`grouped_covariance_smoother`; InputError for ``univariate`` with a non-diagonal R_g.

    Notes
    -----
    What a search of one scalar per series (e.g. the prior intensity of each day, paper 004's rigidity, docs/rail.md
    step 10) evaluates: every series its own candidate in one compiled call, instead of one call per series and
    candidate.
    """
    terms = _group_terms(model, y, group, process_scale, obs_cov, "grouped_log_likelihood")
    if not univariate:
        return _run(model, terms, False)[3].sum(axis=-1)
    Yz, F, c, H, d, Q, scale, R, obs, _, _, grp = terms
    m = R.shape[-1]
    if np.any(R[..., ~np.eye(m, dtype=bool)] != 0.0):
        raise InputError("univariate=True needs a diagonal obs_cov (independent observation noises) in every group.")
    ll, bad = _univariate_pass(Yz, F, c, H, d, np.ascontiguousarray(model.initial_mean), Q, scale, R,
                               np.ascontiguousarray(model.initial_cov), obs, grp)
    if bad >= 0:
        raise _not_positive_definite()
    return ll.sum(axis=-1)

