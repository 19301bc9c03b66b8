"""Kalman filter + RTS smoother for a batch of series that share one model and one missing pattern.

When every series of a batch has the same model and the same NaN pattern, the
covariances, gains and smoother gains do not depend on the data: they are
computed once (one pass over T) and the means of all B series are then pushed
through the same linear recursions. This is what a daily posterior over many
days needs (e.g. the rail rigidity model of paper 004: B = days, T = stations).

Numerically it is the same Joseph-form filter and RTS smoother as
:func:`longprofile.statespace.kalman_filter` / :func:`rts_smoother`; the tests
check both agree to round-off.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit
from .._validation import require_positive
from ..errors import ModelError, ShapeError
from ._linalg_kernels import (
    cholesky_lower,
    copy2,
    gather_block,
    inverse_diagonal,
    joseph_update,
    sandwich_sym,
    solve_rows,
)
from ._model import StateSpaceModel
from ._prepare import prepare_observations
from ._results import FilterResult, SmootherResult

__all__ = ["process_scale_log_likelihood", "shared_covariance_log_likelihood", "shared_covariance_smoother",
           "smoother_noise_covariance"]

_LOG2PI = float(np.log(2.0 * np.pi))


def _per_step(model: StateSpaceModel, name: str, length: int, base_shape: tuple) -> np.ndarray:
    arr = getattr(model, name)
    if arr is None:
        return np.zeros((length,) + base_shape)
    if arr.ndim == len(base_shape):
        return np.ascontiguousarray(np.broadcast_to(arr, (length,) + base_shape))
    return np.ascontiguousarray(arr)


@njit(cache=True)
def _filter_cov_pass(F, Q, H, R, P0, obs):
    """Data-independent part of the filter: predicted/filtered covariances, gains, innovation precisions.

    Small fixed-size loops (the engine's ``_linalg_kernels``: no LAPACK call, no allocation per step): the
    observed block of S = H P H' + R by Cholesky, its inverse by two triangular solves, the Joseph-form update.
    The last output is the first step whose observed block of S is not positive definite (-1: none)."""
    T, m, n = H.shape
    Pp = np.empty((T, n, n))
    Pf = np.empty((T, n, n))
    K = np.zeros((T, n, m))
    S = np.empty((T, m, m))
    Sinv = np.zeros((T, m, m))
    logdet = np.zeros(T)
    P = P0.copy()
    PHt = np.empty((n, m))
    Sk = np.empty((m, m))
    L = np.empty((m, m))
    Si = np.empty((m, m))
    Ho = np.empty((m, n))
    Ro = np.empty((m, m))
    Ko = np.empty((n, m))
    KR = np.empty((n, m))
    A = np.empty((n, n))
    AP = np.empty((n, n))
    FP = np.empty((n, n))
    dinv = np.empty(m)
    work = np.empty(m)
    idx = np.empty(m, dtype=np.int64)
    for k in range(T):
        copy2(P, Pp[k])
        sandwich_sym(H[k], P, R[k], PHt, Sk)  # Sk = H P H' + (R + R')/2, PHt = P H'
        copy2(Sk, S[k])
        no = 0
        for j in range(m):
            if obs[k, j]:
                idx[no] = j
                no += 1
        if no > 0:
            gather_block(Sk, idx, idx, no, no, L)
            if not cholesky_lower(L, no, 0.0):
                return Pp, Pf, K, S, Sinv, logdet, k
            inverse_diagonal(L, no, dinv)
            for a in range(no):  # Si = (L L')^-1, row by row from the identity
                for b in range(no):
                    Si[a, b] = 1.0 if a == b else 0.0
            solve_rows(L, dinv, no, Si, no, work)
            ld = 0.0
            for a in range(no):
                ld += 2.0 * np.log(L[a, a])
                for b in range(a + 1, no):
                    s = 0.5 * (Si[a, b] + Si[b, a])
                    Si[a, b] = s
                    Si[b, a] = s
            logdet[k] = ld
            for i in range(n):  # Ko = P Ho' Si
                for a in range(no):
                    s = 0.0
                    for b in range(no):
                        s += PHt[i, idx[b]] * Si[b, a]
                    Ko[i, a] = s
            for a in range(no):
                for j in range(n):
                    Ho[a, j] = H[k, idx[a], j]
            gather_block(R[k], idx, idx, no, no, Ro)
            joseph_update(P, Ko, Ho, Ro, n, no, A, AP, KR)
            for a in range(no):
                for i in range(n):
                    K[k, i, idx[a]] = Ko[i, a]
                for b in range(no):
                    Sinv[k, idx[a], idx[b]] = Si[a, b]
        copy2(P, Pf[k])
        if k < T - 1:
            sandwich_sym(F[k], P, Q[k], FP, P)  # P <- F P F' + (Q + Q')/2
    return Pp, Pf, K, S, Sinv, logdet, -1


def read_only(*arrays):
    """Read-only views of ``arrays`` (no copy), for a compiled kernel's inputs.

    numba compiles one overload per argument type, and an array's type includes whether it is writeable: an input
    that is sometimes a fresh array and sometimes a read-only one (a cached term, or ``np.ascontiguousarray`` of a
    broadcast that needed no copy) would load a second overload from the disk cache (~15 ms each at start-up);
    passed read-only every time, it always takes the same one. The kernels never write their inputs (numba
    refuses to compile a write to a read-only array)."""
    out = []
    for a in arrays:
        if a.flags.writeable:
            a = a.view()
            a.flags.writeable = False
        out.append(a)
    return out


def _filter_covariances(F, Q, H, R, P0, obs):
    """:func:`_filter_cov_pass`, raising :class:`ModelError` where an observed block of S is not positive
    definite: (Pp, Pf, K, S, Sinv, logdet)."""
    *out, bad = _filter_cov_pass(*read_only(F, Q, H, R, P0, obs))
    if bad >= 0:
        raise _not_positive_definite()
    return tuple(out)


@njit(cache=True)
def _smoother_cov_pass(F, Pp, Pf):
    """Data-independent part of the RTS smoother: smoothed covariances, smoother gains, lag-one cross-covariances."""
    T, n = Pf.shape[0], Pf.shape[1]
    Ps = np.empty((T, n, n))
    G = np.zeros((max(T - 1, 1), n, n))
    cc = np.empty((max(T - 1, 0), n, n))
    Ps[T - 1] = Pf[T - 1]
    for k in range(T - 2, -1, -1):
        Gk = np.linalg.solve(Pp[k + 1], F[k] @ Pf[k]).T
        G[k] = Gk
        Psk = Pf[k] + Gk @ (Ps[k + 1] - Pp[k + 1]) @ Gk.T
        Ps[k] = 0.5 * (Psk + Psk.T)
        cc[k] = Gk @ Ps[k + 1]
    return Ps, G, cc


def _cov_pass(F, Q, H, R, P0, obs):
    """Data-independent part of filter and smoother: (Pp, Pf, K, S, Sinv, logdet, Ps, G, cc)."""
    Pp, Pf, K, S, Sinv, logdet = _filter_covariances(F, Q, H, R, P0, obs)
    return (Pp, Pf, K, S, Sinv, logdet) + _smoother_cov_pass(F, Pp, Pf)


@njit(cache=True, inline="always")
def _mean_update(y_k, d_k, H_k, K_k, Sinv_k, obs_k, x, e):  # pragma: no cover - compiled
    """Filter update of one mean through the shared gain: e = innovation (0 where missing), x += K e; e' S^-1 e."""
    m, n = H_k.shape
    for j in range(m):
        if obs_k[j]:
            acc = y_k[j] - d_k[j]
            for i in range(n):
                acc -= H_k[j, i] * x[i]
            e[j] = acc
        else:
            e[j] = 0.0
    quad = 0.0
    for j in range(m):
        if obs_k[j]:
            for jj in range(m):
                quad += e[j] * Sinv_k[j, jj] * e[jj]
    for i in range(n):
        acc = 0.0
        for j in range(m):
            acc += K_k[i, j] * e[j]
        x[i] += acc
    return quad


@njit(cache=True, inline="always")
def _mean_predict(F_k, c_k, x, xn):  # pragma: no cover - compiled
    """x <- F x + c (through the scratch vector xn)."""
    n = x.shape[0]
    for i in range(n):
        acc = c_k[i]
        for jj in range(n):
            acc += F_k[i, jj] * x[jj]
        xn[i] = acc
    for i in range(n):
        x[i] = xn[i]


@njit(cache=True)
def _mean_pass(Y, F, c, H, d, x0, K, Sinv, logdet, G, obs, n_obs_step, store):  # pragma: no cover - compiled
    """Means of every series through the shared gains (filter then smoother) and the per-step log-likelihood terms
    (B, T); with ``store`` False only the latter (the filter's mean recursion, no means kept, no smoother pass).
    No allocation inside the loops."""
    B, T, m = Y.shape
    n = x0.shape[0]
    Bs = B if store else 0
    mf = np.empty((Bs, T, n))
    mp = np.empty((Bs, T, n))
    ms = np.empty((Bs, T, n))
    innov = np.full((Bs, T, m), np.nan)
    ll = np.zeros((B, T))
    e = np.zeros(m)
    x = np.empty(n)
    xn = np.empty(n)
    for b in range(B):
        for i in range(n):
            x[i] = x0[i]
        for k in range(T):
            if store:
                for i in range(n):
                    mp[b, k, i] = x[i]
            if n_obs_step[k] > 0:
                quad = _mean_update(Y[b, k], d[k], H[k], K[k], Sinv[k], obs[k], x, e)
                if store:
                    for j in range(m):
                        if obs[k, j]:
                            innov[b, k, j] = e[j]
                ll[b, k] = -0.5 * (n_obs_step[k] * 1.8378770664093453 + logdet[k] + quad)
            if store:
                for i in range(n):
                    mf[b, k, i] = x[i]
            if k < T - 1:
                _mean_predict(F[k], c[k], x, xn)
        if not store:
            continue
        for i in range(n):
            ms[b, T - 1, i] = mf[b, T - 1, i]
        for k in range(T - 2, -1, -1):
            for i in range(n):
                acc = mf[b, k, i]
                for jj in range(n):
                    acc += G[k, i, jj] * (ms[b, k + 1, jj] - mp[b, k + 1, jj])
                ms[b, k, i] = acc
    return mf, mp, ms, innov, ll


def _shared_terms(model: StateSpaceModel, y, name: str):
    """Checked observations and per-step model terms of a shared-covariance batch:
    (Y with NaN as 0, batched, obs (T, m) bool, F, Q, c, H, R, d)."""
    if model.n_inputs:
        raise ShapeError(f"{name} does not take known inputs (the model has B or D); "
                         "use kalman_filter / rts_smoother instead.")
    Y, batched = prepare_observations(model, y)
    B, T, m = Y.shape
    n = model.n_states
    nan = np.isnan(Y)
    if B > 1 and (nan != nan[0]).any():
        bad = int(np.nonzero((nan != nan[0]).any(axis=(1, 2)))[0][0])
        raise ShapeError(f"every series must have NaN at the same places to share covariances; series {bad} "
                         "differs from series 0. Group the series by missing pattern, or use kalman_filter.")
    F = _per_step(model, "transition", max(T - 1, 1), (n, n))
    Q = _per_step(model, "process_cov", max(T - 1, 1), (n, n))
    c = _per_step(model, "state_offset", max(T - 1, 1), (n,))
    H = _per_step(model, "observation", T, (m, n))
    R = _per_step(model, "obs_cov", T, (m, m))
    d = _per_step(model, "obs_offset", T, (m,))
    return np.where(nan, 0.0, Y), batched, np.ascontiguousarray(~nan[0]), F, Q, c, H, R, d


def _not_positive_definite() -> ModelError:
    return ModelError("an innovation or predicted covariance is not positive definite; obs_cov (R) must be "
                      "positive definite on the observed components and the prior proper.")


def shared_covariance_smoother(model: StateSpaceModel, y) -> SmootherResult:
    r"""Kalman filter and RTS smoother of a batch of series sharing one model and one missing pattern.

    Parameters
    ----------
    model : StateSpaceModel
        Linear-Gaussian model without known inputs (offsets ``state_offset`` /
        ``obs_offset`` are allowed); constant or time-varying terms.
    y : (T, m) or (B, T, m) array_like
        Observations; NaN marks a missing component. Every series of the batch
        must have NaN at the same places (the covariances are then shared).

    Returns
    -------
    SmootherResult
        ``mean`` (B, T, n) (or (T, n) for unbatched ``y``); ``cov`` (T, n, n) and
        ``cross_cov`` (T-1, n, n) are SHARED by every series (not repeated B
        times). ``filtered`` is a :class:`FilterResult` with per-series means,
        innovations and log-likelihoods and shared ``cov``, ``pred_cov`` and
        ``innovation_cov``; its ``method`` is ``"shared-covariance"``.

    Raises
    ------
    ShapeError
        If the model has known inputs, or the series do not share one NaN pattern.
    ModelError
        If an innovation covariance is not positive definite on the observed components.

    Notes
    -----
    The covariance recursion of the Kalman filter (Joseph form) and of the RTS
    smoother does not involve the observations, only which components are
    observed. It is run once, in O(T n^3), and the B mean recursions reuse its
    gains, in O(B T n m): for B = 365 days of T = 10 000 stations this is what
    makes a year of daily posteriors take well under a second. Same timing
    convention as :func:`kalman_filter`.
    """
    Yz, batched, obs, F, Q, c, H, R, d = _shared_terms(model, y, "shared_covariance_smoother")
    B, T = Yz.shape[:2]
    try:
        Pp, Pf, K, S, Sinv, logdet, Ps, G, cc = _cov_pass(F, Q, H, R, np.ascontiguousarray(model.initial_cov), obs)
    except np.linalg.LinAlgError:
        raise _not_positive_definite() from None
    n_obs_step = obs.sum(axis=1).astype(np.int64)
    mf, mp, ms, innov, ll = _mean_pass(Yz, F, c, H, d, np.ascontiguousarray(model.initial_mean), K, Sinv, logdet,
                                       G, obs, n_obs_step, True)
    if not batched:
        mf, mp, ms, innov, ll = mf[0], mp[0], ms[0], innov[0], ll[0]
    n_observed = int(obs.sum())
    filtered = FilterResult(
        mean=mf, cov=Pf, pred_mean=mp, pred_cov=Pp, innovation=innov, innovation_cov=S,
        log_likelihood=ll.sum(axis=-1) if batched else float(ll.sum()), log_likelihood_steps=ll,
        n_observed=np.full(B, n_observed) if batched else n_observed, method="shared-covariance")
    return SmootherResult(mean=ms, cov=Ps, cross_cov=cc[: max(T - 1, 0)], filtered=filtered)


def shared_covariance_log_likelihood(model: StateSpaceModel, y) -> float | np.ndarray:
    r"""Log-likelihood of each series of a batch sharing one model and one missing pattern (filter only).

    Parameters
    ----------
    model : StateSpaceModel
        As in :func:`shared_covariance_smoother`.
    y : (T, m) or (B, T, m) array_like
        As in :func:`shared_covariance_smoother` (one NaN pattern for the whole batch).

    Returns
    -------
    float or (B,) ndarray
        log p(y_b) of each series: equal, bit for bit, to ``shared_covariance_smoother(model, y)
        .filtered.log_likelihood``.

    Raises
    ------
    ShapeError, ModelError
        As :func:`shared_covariance_smoother`.

    Notes
    -----
    The prediction-error decomposition needs only the forward pass: the filter's covariance
    recursion once (no RTS backward pass, no smoother gains) and, per series, the mean recursion
    through the shared gains accumulating -(m_k log 2 pi + log det S_k + e_k^T S_k^-1 e_k) / 2, with no
    means, innovations or smoothed states stored. This is what a maximum-likelihood search over a
    model's parameters evaluates many times (e.g. the rigidity of paper 004's prior over a year of days).
    """
    Yz, batched, obs, F, Q, c, H, R, d = _shared_terms(model, y, "shared_covariance_log_likelihood")
    try:
        _, _, K, _, Sinv, logdet = _filter_covariances(F, Q, H, R, np.ascontiguousarray(model.initial_cov), obs)
    except np.linalg.LinAlgError:
        raise _not_positive_definite() from None
    no_gains = np.zeros((0, K.shape[1], K.shape[1]))  # the smoother's gains are not used without ``store``
    ll = _mean_pass(Yz, F, c, H, d, np.ascontiguousarray(model.initial_mean), K, Sinv, logdet, no_gains, obs,
                    obs.sum(axis=1).astype(np.int64), False)[-1]
    return ll.sum(axis=-1) if batched else float(ll[0].sum())


def process_scale_log_likelihood(model: StateSpaceModel, y):
    r"""The log-likelihood of each series as a function of a scale s of the process covariance, Q -> s Q.

    Parameters
    ----------
    model : StateSpaceModel
        As in :func:`shared_covariance_smoother` (its ``process_cov`` is the s = 1 term).
    y : (T, m) or (B, T, m) array_like
        As in :func:`shared_covariance_smoother` (one NaN pattern for the whole batch).

    Returns
    -------
    callable
        ``loglik(s)`` for a finite s > 0: float or (B,) ndarray, :func:`shared_covariance_log_likelihood` of
        ``model.replace(process_cov=s * model.process_cov)`` (equal to round-off: s Q is formed in the kernel's
        input, not rebuilt by the caller).

    Raises
    ------
    ShapeError, ModelError
        As :func:`shared_covariance_smoother` (when built; ``loglik`` raises ModelError where an innovation
        covariance is not positive definite and InputError for an s that is not finite and > 0).

    Notes
    -----
    What a maximum-likelihood search over one intensity evaluates tens of times per series (e.g. the rigidity of
    paper 004's prior, q = r L / 2, Lemma 4.1: Q is linear in r): the model is checked and its per-step terms
    prepared once, so an evaluation is the forward covariance pass and the mean recursion only.

    Examples
    --------
    >>> import numpy as np
    >>> from longprofile.statespace import (StateSpaceModel, process_scale_log_likelihood,
    ...                                     shared_covariance_log_likelihood)
    >>> m = StateSpaceModel([[1.0]], [[1.0]], [[0.1]], [[1.0]], [0.0], [[1.0]])
    >>> y = np.array([[0.3], [0.1], [-0.2]])
    >>> f = process_scale_log_likelihood(m, y)
    >>> bool(np.isclose(f(2.0), shared_covariance_log_likelihood(m.replace(process_cov=[[0.2]]), y)))
    True
    """
    Yz, batched, obs, F, Q, c, H, R, d = _shared_terms(model, y, "process_scale_log_likelihood")
    P0 = np.ascontiguousarray(model.initial_cov)
    x0 = np.ascontiguousarray(model.initial_mean)
    n_obs_step = obs.sum(axis=1).astype(np.int64)
    no_gains = np.zeros((0, model.n_states, model.n_states))

    def loglik(s):
        s = require_positive("process covariance scale s", s)
        _, _, K, _, Sinv, logdet = _filter_covariances(F, s * Q, H, R, P0, obs)
        ll = _mean_pass(Yz, F, c, H, d, x0, K, Sinv, logdet, no_gains, obs, n_obs_step, False)[-1]
        return ll.sum(axis=-1) if batched else float(ll[0].sum())

    return loglik


@njit(cache=True)
def _noise_cov_pass(F, H, K, G, Rn):  # pragma: no cover - compiled
    """Covariance of the RTS-smoothed mean driven by observation noise alone (fixed truth), O(T n^3)."""
    T, m, n = H.shape
    eye = np.eye(n)
    Pf = np.empty((T, n, n))
    A = np.zeros((T, n, n))
    P = K[0] @ Rn[0] @ K[0].T
    Pf[0] = 0.5 * (P + P.T)
    for k in range(1, T):
        A[k] = (eye - K[k] @ H[k]) @ F[k - 1]
        P = A[k] @ Pf[k - 1] @ A[k].T + K[k] @ Rn[k] @ K[k].T
        Pf[k] = 0.5 * (P + P.T)
    S = np.empty((T, n, n))
    S[T - 1] = Pf[T - 1]
    Nk = eye.copy()  # d xs[k+1] / d xf[k+1]
    for k in range(T - 2, -1, -1):
        M = Nk @ A[k + 1]  # d xs[k+1] / d xf[k]
        B = eye - G[k] @ F[k]
        X = B @ Pf[k] @ M.T @ G[k].T
        Sk = B @ Pf[k] @ B.T + G[k] @ S[k + 1] @ G[k].T + X + X.T
        S[k] = 0.5 * (Sk + Sk.T)
        Nk = B + G[k] @ M
    return S


def smoother_noise_covariance(model: StateSpaceModel, y, *, noise_cov=None) -> np.ndarray:
    r"""Covariance of the RTS-smoothed mean caused by the observation noise alone, for a fixed true state path.

    The smoothed mean is linear in the observations, x_s = A y + b; for a fixed truth its
    error from the noise v ~ N(0, R_n) has covariance A R_n A^T (the frequentist, "measurement"
    covariance of the estimate), whereas the smoother's ``cov`` is the Bayesian posterior
    covariance (which also counts the prior's uncertainty). Computed by forward and backward
    covariance recursions through the shared gains, O(T n^3), no matrix A formed.

    Parameters
    ----------
    model : StateSpaceModel
        As in :func:`shared_covariance_smoother` (its ``obs_cov`` sets the gains).
    y : (T, m) array_like
        Only the NaN pattern matters (which components are observed).
    noise_cov : (m, m) or (T, m, m) array_like, optional
        Covariance R_n of the noise actually driving the estimate; default the model's ``obs_cov``.
        E.g. zero on components that are exact constraints.

    Returns
    -------
    (T, n, n) ndarray
        Cov(x_s[t] | true path), t = 0..T-1.

    Notes
    -----
    With A_k = (I - K_k H_k) F_{k-1} the filtered mean's noise covariance is
    P_k = A_k P_{k-1} A_k^T + K_k R_n K_k^T; backwards, with B_k = I - G_k F_k and
    N_k = d x_s[k] / d x_f[k] (N_{T-1} = I, N_k = B_k + G_k N_{k+1} A_{k+1}),
    S_k = B P_k B^T + G_k S_{k+1} G_k^T + (B P_k A_{k+1}^T N_{k+1}^T G_k^T + its transpose).
    """
    if model.n_inputs:
        raise ShapeError("smoother_noise_covariance does not take known inputs (the model has B or D).")
    Y, batched = prepare_observations(model, y)
    if batched:
        raise ShapeError("smoother_noise_covariance takes one (T, m) pattern; got a batch.")
    _, T, m = Y.shape
    n = model.n_states
    obs = np.ascontiguousarray(~np.isnan(Y[0]))
    F = _per_step(model, "transition", max(T - 1, 1), (n, n))
    Q = _per_step(model, "process_cov", max(T - 1, 1), (n, n))
    H = _per_step(model, "observation", T, (m, n))
    R = _per_step(model, "obs_cov", T, (m, m))
    if noise_cov is None:
        Rn = R
    else:
        Rn = np.asarray(noise_cov, dtype=float)
        if Rn.shape == (m, m):
            Rn = np.broadcast_to(Rn, (T, m, m))
        if Rn.shape != (T, m, m):
            raise ShapeError(f"noise_cov must have shape ({m}, {m}) or ({T}, {m}, {m}); got {np.shape(noise_cov)}.")
        Rn = np.ascontiguousarray(Rn)
    try:
        _, _, K, _, _, _, _, G, _ = _cov_pass(F, Q, H, R, np.ascontiguousarray(model.initial_cov), obs)
    except np.linalg.LinAlgError:
        raise ModelError("an innovation or predicted covariance is not positive definite.") from None
    return _noise_cov_pass(F, H, K, np.ascontiguousarray(G), Rn)
