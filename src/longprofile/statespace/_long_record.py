"""Exact filter, smoother and likelihood of a detectable time-invariant model on records of any length.

A record of 10^6-10^8 samples cannot keep per-sample covariances (O(T n^2) memory), and the steady-state
recursions of :mod:`._steady` differ from the exact filter during the start-up transient. Here the two are
joined: the exact time-varying filter runs until its covariance has converged to the stationary one (to a
relative ``tol``), the constant-gain recursion takes over from the exact predicted mean, and the smoother is
the constant-gain RTS pass over the converged part followed by the exact RTS pass over the start. The forward
pass keeps only one state vector per chunk (checkpoints); the backward pass re-runs the (causal) filter chunk by
chunk from its checkpoint and continues the RTS recursion from the smoothed mean of the chunk to its right, so
chunking changes nothing. Working memory is O(chunk_size n) for the constant-gain part and O(E n^2) for an
exact start of E samples, plus the requested output columns; the means equal those of :func:`kalman_filter` /
:func:`rts_smoother` to round-off (and to ``tol`` in the gains at the switch).

Missing samples (NaN rows) are bridged exactly: at the first missing sample of a stretch the constant-gain filter
hands its predicted mean, with the stationary predicted covariance it has (to ``tol``), back to the exact
time-varying filter, which runs through the gap(s), chunk by chunk, until a complete chunk finds its covariance
stationary again; the smoother then runs the exact RTS pass over those chunks. The answer is that of
:func:`kalman_filter` / :func:`rts_smoother` on the whole record with its gaps, to ``tol``, and the working memory
stays O(chunk).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ._kalman import kalman_filter, kalman_filter_final_cov, rts_smoother
from ._model import StateSpaceModel
from ._steady import (
    _prepare,
    _require_time_invariant,
    _run_filter,
    _smoother_gain,
    gain_from_pred_cov,
    steady_state_gain,
)
from ._steady_kernels import smooth_kernel

__all__ = ["LongRecordResult", "long_record_filter", "long_record_smoother", "long_record_log_likelihood",
           "ChunkedFilterResult", "chunked_kalman_filter"]

#: Default chunk of the constant-gain part, samples (8 MB of state means per chunk for n = 8).
DEFAULT_CHUNK = 1 << 17
#: Default chunk of the exact (time-varying) start, samples (the convergence is checked at each chunk end).
EXACT_CHUNK = 1 << 15
#: Default longest exact start, samples.
MAX_EXACT = 1 << 21


@dataclass(frozen=True, eq=False)
class LongRecordResult:
    """Means of selected states over a long record, with the exact log-likelihood.

    Attributes
    ----------
    mean : (T, k) ndarray or None
        Filtered (:func:`long_record_filter`) or smoothed (:func:`long_record_smoother`) means of the states
        ``states``; None from :func:`long_record_log_likelihood`.
    states : tuple of int
        Indices of the states in ``mean`` (negative indices resolved).
    log_likelihood : float
        Exact Gaussian log-likelihood (time-varying start, stationary after convergence).
    quadratic_form : float
        Sum over the steps of e_k' S_k^-1 e_k (for concentrating a common variance scale out).
    log_det_sum : float
        Sum over the steps of log det S_k.
    n_observed : int
        Number of scalar observations.
    n_exact : int
        Number of first samples filtered with the exact time-varying gains.
    converged : bool
        Whether the exact start reached the stationary covariance (to ``tol``) before ``max_exact`` (or the end),
        and so did every exact stretch around missing samples (before ``max_exact`` samples or the end).
    n_bridged : int
        Number of samples after the start filtered with the exact gains because of missing samples (the gaps and
        the re-convergence after each); 0 for a complete record.
    """

    mean: np.ndarray | None
    states: tuple[int, ...]
    log_likelihood: float
    quadratic_form: float
    log_det_sum: float
    n_observed: int
    n_exact: int
    converged: bool
    n_bridged: int = 0


def _checked(model, y, states, chunk_size, what):
    if model.input_transition is not None or model.input_observation is not None:
        raise InputError(f"{what} does not take known inputs (B, D); fold them into the offsets or use kalman_filter.")
    Y, batched, U, terms = _prepare(model, y, None, what, allow_nan=True)
    if batched:
        raise InputError(f"{what} runs one series at a time; got a batch of {Y.shape[0]}.")
    nan = np.isnan(Y[0])
    if (nan.any(axis=1) != nan.all(axis=1)).any():
        first = int(np.flatnonzero(nan.any(axis=1) != nan.all(axis=1))[0])
        raise InputError(f"{what} bridges samples missing entirely (every component NaN); the observation at index "
                         f"{first} is missing in part only: use kalman_filter / rts_smoother.")
    n = model.n_states
    if states is None:
        idx = tuple(range(n))
    else:
        idx = tuple(int(s) for s in np.atleast_1d(states))
        if any(not -n <= s < n for s in idx):
            raise InputError(f"states {list(idx)} out of range for a model with {n} states.")
        idx = tuple(s % n for s in idx)
    chunk_size = int(chunk_size)
    if chunk_size < 1:
        raise InputError(f"chunk_size must be >= 1; got {chunk_size}.")
    return Y[0], U[0], terms, idx, chunk_size


def _exact_sums(e, S):
    """Sums of e' S^-1 e and of log det S over the observed steps of an exact filter (rows entirely observed or
    entirely missing, :func:`_checked`)."""
    seen = ~np.isnan(e[:, 0])
    if not seen.all():
        e, S = e[seen], S[seen]
    if S.shape[-1] == 1:
        s = S[:, 0, 0]
        return float(np.sum(e[:, 0] * e[:, 0] / s)), float(np.sum(np.log(s)))
    quad = float(np.einsum("ti,ti->", e, np.linalg.solve(S, e[..., None])[..., 0]))
    return quad, float(np.linalg.slogdet(S)[1].sum())


class _Forward:
    """The exact chunked start, then the chunked constant-gain pass with checkpoints, handing over to the exact filter
    around missing samples (one forward sweep)."""

    def __init__(self, model, Y, U, terms, tol, chunk_size, exact_chunk, max_exact):
        self.model, self.Y, self.U, self.terms, self.chunk = model, Y, U, terms, chunk_size
        self.tol, self.exact_chunk, self.max_exact = float(tol), int(exact_chunk), int(max_exact)
        self.ss = steady_state_gain(model)
        self.missing = np.isnan(Y).any(axis=1)
        T, m = Y.shape
        self.n_obs = int(T * m - np.isnan(Y).sum())
        self.const = m * np.log(2 * np.pi) + float(np.linalg.slogdet(self.ss.innovation_cov)[1])
        self.scale = max(float(np.abs(self.ss.pred_cov).max()), np.finfo(float).tiny)
        self.quad = 0.0
        self.logdet = 0.0
        # (a, b, prior mean, prior cov) of each chunk in record order; prior cov None for a constant-gain chunk,
        # whose prior mean is its checkpoint (the predicted mean at a)
        self.pieces = []
        self.E = 0
        self.n_bridged = 0
        self.converged = False

    def _predict(self, mean, cov=None):
        F = self.model.transition
        c = self.model.state_offset
        x = F @ mean + (0.0 if c is None else c)
        if cov is None:
            return x
        P = F @ cov @ F.T + self.model.process_cov
        return x, 0.5 * (P + P.T)

    def run_chunk(self, a, b, x0):
        """Constant-gain filtered means (b - a, n) over [a, b) from the predicted mean x0 at a; also the quadratic
        form of the innovations and the predicted mean at b."""
        mean, _p, _i, _s, ll = _run_filter(self.model, self.ss, self.Y[None, a:b], self.U[None, a:b], self.terms,
                                           False, x0=x0)
        quad = -2.0 * float(ll[0]) - (b - a) * self.const
        return mean[0], quad, self._predict(mean[0, -1])

    def exact_model(self, m0, P0):
        return replace(self.model, initial_mean=m0, initial_cov=P0)

    def _exact_run(self, a, m0, P0, chunk, on_chunk):
        """The exact filter chunk by chunk from a (prior m0, P0) until a complete chunk (full length, no missing
        sample) leaves the predicted covariance stationary to ``tol``, or ``max_exact`` samples, or the end.
        Returns (end, predicted mean and covariance there, converged)."""
        T = self.Y.shape[0]
        # distance of the Riccati iterate to its limit from its change over one exact chunk: the iterate contracts
        # like rho^2 per step (rho from the DARE solution, accurate enough for this estimate)
        decay = float(self.ss.closed_loop_radius) ** (2 * chunk)
        start = a
        while a < T:
            b = min(a + chunk, T)
            res, Pf = kalman_filter_final_cov(self.model if a == 0 else self.exact_model(m0, P0), self.Y[a:b])
            self.pieces.append((a, b, m0, P0))
            q, ld = _exact_sums(res.innovation, res.innovation_cov)
            self.quad += q
            self.logdet += ld
            if on_chunk is not None:
                on_chunk(a, b, res.mean)
            P_before = P0
            m0, P0 = self._predict(res.mean[-1], Pf)
            complete = b - a == chunk and not self.missing[a:b].any()
            a = b
            change = float(np.abs(P0 - P_before).max()) / self.scale
            if complete and change / max(1.0 - decay, 1e-300) <= self.tol:
                return a, m0, P0, True
            if a - start >= self.max_exact:
                break
        return a, m0, P0, False

    def _gap_chunk(self):
        """Chunk of the exact stretches around missing samples: about a quarter of the samples the Riccati iterate
        needs to contract by ``tol`` (rho^2 per step), a power of 2 in [512, exact_chunk]."""
        rho = min(float(self.ss.closed_loop_radius), 1.0 - 1e-12)
        k = np.log(self.tol) / (2.0 * np.log(rho)) / 4.0 if rho > 0 else 1.0
        return int(min(max(2 ** int(np.ceil(np.log2(max(k, 1.0)))), 512), self.exact_chunk))

    def forward(self, on_chunk=None):
        """One sweep; ``on_chunk(a, b, filtered means)`` sees every chunk in order."""
        T = self.Y.shape[0]
        a, x0, P0, self.converged = self._exact_run(0, self.model.initial_mean, self.model.initial_cov,
                                                    self.exact_chunk, on_chunk)
        self.E = a
        if a < T:
            # the constant gain is the one of the converged iterate itself: the DARE solution of a filter whose
            # closed loop is close to 1 can be a few 1e-7 off (error ~ residual / (1 - rho^2))
            self.ss = gain_from_pred_cov(self.model, P0)
            self.const = self.Y.shape[1] * np.log(2 * np.pi) + float(np.linalg.slogdet(self.ss.innovation_cov)[1])
        logdet_ss = float(np.linalg.slogdet(self.ss.innovation_cov)[1])
        gaps = np.flatnonzero(self.missing)
        gap_chunk = self._gap_chunk()
        while a < T:
            i = int(np.searchsorted(gaps, a))
            g = int(gaps[i]) if i < gaps.size else T
            for s in range(a, g, self.chunk):
                b = min(s + self.chunk, g)
                self.pieces.append((s, b, x0, None))
                mean, quad, x0 = self.run_chunk(s, b, x0)
                self.quad += quad
                self.logdet += (b - s) * logdet_ss
                if on_chunk is not None:
                    on_chunk(s, b, mean)
            if g < T:  # a missing sample: the exact filter from the stationary prediction, until re-converged
                a, x0, _P, done = self._exact_run(g, x0, self.ss.pred_cov, gap_chunk, on_chunk)
                self.n_bridged += a - g
                self.converged = self.converged and (done or a >= T)
            else:
                a = T

    @property
    def log_likelihood(self):
        return -0.5 * (self.n_obs * np.log(2 * np.pi) + self.logdet + self.quad)


def _result(fw, mean, idx):
    return LongRecordResult(mean=mean, states=idx, log_likelihood=float(fw.log_likelihood),
                            quadratic_form=float(fw.quad), log_det_sum=float(fw.logdet), n_observed=int(fw.n_obs),
                            n_exact=int(fw.E), converged=bool(fw.converged), n_bridged=int(fw.n_bridged))


_COMMON_PARAMETERS = """model : StateSpaceModel
        Time-invariant, detectable (a stationary Kalman filter exists), without known inputs, R > 0.
    y : (T,) or (T, m) array_like
        Observations; a row of NaN is a missing sample, bridged by the exact filter (module docstring): the answer
        is that of :func:`kalman_filter` / :func:`rts_smoother` with the same gaps. A row missing in part only is
        refused.
    tol : float
        The exact time-varying filter runs, chunk by chunk, until its predicted covariance is within ``tol``
        (max-abs, relative) of its limit, estimated from its change over a chunk; the constant gain of that
        converged iterate takes over from there. Default 1e-7: on the APL deconvolution model the smoothed profile
        then differs from the exact one by ~2e-9 of its RMS (docs/road-apl.md).
    chunk_size : int
        Samples per chunk of the constant-gain part (working memory about 16 chunk_size n bytes).
    exact_chunk : int
        Samples per chunk of the exact part (the convergence is checked at each chunk's end).
    max_exact : int
        Longest exact start, samples; past it the constant gain takes over even if not converged
        (``converged`` False in the result)."""


def _with_common_parameters(fn):
    """Put the parameters shared by the three long-record functions into ``fn``'s docstring."""
    fn.__doc__ = fn.__doc__.replace("{common}", _COMMON_PARAMETERS)
    return fn


def _forward(model, y, states, tol, chunk_size, exact_chunk, max_exact, what):
    Y, U, terms, idx, chunk_size = _checked(model, y, states, chunk_size, what)
    return _Forward(model, Y, U, terms, tol, chunk_size, exact_chunk, max_exact), idx


@_with_common_parameters
def long_record_log_likelihood(model: StateSpaceModel, y, *, tol: float = 1e-7, chunk_size: int = DEFAULT_CHUNK,
                               exact_chunk: int = EXACT_CHUNK, max_exact: int = MAX_EXACT) -> LongRecordResult:
    """Exact Gaussian log-likelihood of a record of any length in bounded memory (``mean`` is None).

    Parameters
    ----------
    {common}

    Returns
    -------
    LongRecordResult
        ``log_likelihood``, and its parts ``quadratic_form`` and ``log_det_sum`` (to concentrate a common
        scale of the covariances out), ``n_exact``.
    """
    fw, idx = _forward(model, y, None, tol, chunk_size, exact_chunk, max_exact, "long_record_log_likelihood")
    fw.forward()
    return _result(fw, None, idx)


@_with_common_parameters
def long_record_filter(model: StateSpaceModel, y, *, states=None, tol: float = 1e-7, chunk_size: int = DEFAULT_CHUNK,
                       exact_chunk: int = EXACT_CHUNK, max_exact: int = MAX_EXACT) -> LongRecordResult:
    """Kalman filter of a record of any length: exact start, constant gain once converged, exact around gaps.

    Parameters
    ----------
    {common}
    states : int or sequence of int, optional
        State indices to return (default all): the output takes 8 T k bytes.

    Returns
    -------
    LongRecordResult
        Filtered means E[x_t | y_0..t] of ``states`` (T, k); the exact log-likelihood.

    Raises
    ------
    NotDetectableError
        No stationary filter exists (:func:`steady_state_gain`); use :func:`chunked_kalman_filter`.
    InputError
        A row of y missing in part only, a batch, known inputs, bad ``states``.
    """
    fw, idx = _forward(model, y, states, tol, chunk_size, exact_chunk, max_exact, "long_record_filter")
    out = np.empty((fw.Y.shape[0], len(idx)))

    def keep(a, b, mean):
        out[a:b] = mean[:, idx]

    fw.forward(keep)
    return _result(fw, out, idx)


def _with_terminal(filt, x_smoothed, pred_mean, pred_cov):
    """``filt`` over [a, b) extended by the entry b: predicted moments at b, and the *smoothed* mean at b in place
    of the filtered one, so that :func:`rts_smoother` on it starts from the smoothed mean at b."""
    return replace(filt, mean=np.vstack([filt.mean, x_smoothed]), cov=np.concatenate([filt.cov, pred_cov[None]]),
                   pred_mean=np.vstack([filt.pred_mean, pred_mean]),
                   pred_cov=np.concatenate([filt.pred_cov, pred_cov[None]]))


@_with_common_parameters
def long_record_smoother(model: StateSpaceModel, y, *, states=None, tol: float = 1e-7,
                         chunk_size: int = DEFAULT_CHUNK, exact_chunk: int = EXACT_CHUNK, max_exact: int = MAX_EXACT) -> LongRecordResult:
    """Fixed-interval (RTS) smoother of a record of any length (gaps bridged) in bounded working memory.

    Parameters
    ----------
    {common}
    states : int or sequence of int, optional
        State indices to return (default all).

    Returns
    -------
    LongRecordResult
        Smoothed means E[x_t | y_0..T-1] of ``states`` (T, k); the exact log-likelihood.

    Notes
    -----
    1. Forward: the exact :func:`kalman_filter` chunk by chunk (each chunk's prior the previous chunk's
       prediction) until the predicted covariance is stationary to ``tol`` (sample E), then the constant-gain
       filter from the exact predicted mean at E, keeping only the predicted mean at each chunk start.
    2. Backward over the constant-gain part, last chunk first: the filter is re-run from the chunk's checkpoint
       (exactly: it is causal), and the constant-gain RTS pass runs over the chunk from the smoothed mean of the
       chunk to its right.
    3. Backward over the exact part, last chunk first: the chunk's exact filter is re-run with covariances,
       extended by the next chunk's first prediction with the smoothed mean there, and :func:`rts_smoother`
       gives the exact time-varying RTS means.
    4. Missing samples: at the first missing sample after the start the constant-gain filter hands its predicted
       mean and the stationary predicted covariance to the exact filter, which runs chunk by chunk (chunks of about
       a quarter of the samples the Riccati iterate needs to contract by ``tol``) until a complete chunk leaves the
       covariance stationary again; steps 2-3 then treat those chunks as exact chunks.
    About two filter passes and one smoother pass; the means equal :func:`rts_smoother` on the whole record to
    round-off (and to ``tol`` in the gains at the switches).
    """
    fw, idx = _forward(model, y, states, tol, chunk_size, exact_chunk, max_exact, "long_record_smoother")
    fw.forward()
    Y, U = fw.Y, fw.U
    T, n = Y.shape[0], model.n_states
    out = np.empty((T, len(idx)))
    xs_next = pm_next = None  # smoothed mean and predicted mean at the start of the chunk to the right
    if any(P0 is None for *_r, P0 in fw.pieces):
        G = _smoother_gain(model, fw.ss)
        B, _D, c, _d = fw.terms
        I_GF = np.ascontiguousarray(np.eye(n) - G @ model.transition)
        GB = np.ascontiguousarray(G @ B)
        Gc = np.ascontiguousarray(G @ c)
        G = np.ascontiguousarray(G)
        buf = np.empty((fw.chunk + 1, n))
    for a, b, m0, P0 in reversed(fw.pieces):
        if P0 is None:  # constant gain: the filter re-run from its checkpoint, then the constant-gain RTS pass
            mean, _q, _x = fw.run_chunk(a, b, m0)
            k = b - a
            span = buf[:k + (xs_next is not None)]
            span[:k] = mean
            if xs_next is not None:  # the kernel starts from its last row: the smoothed mean at b, exactly
                span[k] = xs_next
            smooth_kernel(I_GF, G, GB, Gc, U[a:a + span.shape[0]], span, span)
            out[a:b] = span[:k][:, idx]
            xs_next, pm_next = span[0].copy(), m0
            continue
        filt = kalman_filter(model if a == 0 else fw.exact_model(m0, P0), Y[a:b])
        if xs_next is None:  # the last chunk of the record
            sm = rts_smoother(model, filt).mean
        else:
            # the predicted covariance at b: the exact one (F P F' + Q), not the stationary approximation
            _x, pc_next = fw._predict(filt.mean[-1], filt.cov[-1])
            sm = rts_smoother(model, _with_terminal(filt, xs_next, pm_next, pc_next)).mean[:-1]
        out[a:b] = sm[:, idx]
        xs_next, pm_next = sm[0].copy(), filt.pred_mean[0]
    return _result(fw, out, idx)


@dataclass(frozen=True, eq=False)
class ChunkedFilterResult:
    """Filtered means and variances of selected states (:func:`chunked_kalman_filter`).

    Attributes
    ----------
    mean, var : (T, k) ndarray
        E[x_t | y_0..t] and Var(x_t | y_0..t) of the states ``states``.
    states : tuple of int
    log_likelihood : float
    """

    mean: np.ndarray
    var: np.ndarray
    states: tuple[int, ...]
    log_likelihood: float


def chunked_kalman_filter(model: StateSpaceModel, y, *, states=None, chunk_size: int = 1 << 16) -> ChunkedFilterResult:
    """The exact time-varying Kalman filter run chunk by chunk: O(chunk_size n^2) memory for any record length.

    Each chunk's prior is the previous chunk's last prediction (F m, F P F' + Q), so the result is the one of
    :func:`kalman_filter` on the whole record (to round-off); detectability is not needed (an unobservable
    random walk keeps a growing variance) and NaN samples are missing as usual.

    Parameters
    ----------
    model : StateSpaceModel
        Time-invariant, without known inputs or offsets.
    y : (T,) or (T, m) array_like
    states : int or sequence of int, optional
        States to return (default all).
    chunk_size : int

    Returns
    -------
    ChunkedFilterResult
    """
    _require_time_invariant(model, "chunked_kalman_filter")
    if any(getattr(model, f) is not None for f in ("input_transition", "input_observation", "state_offset",
                                                       "obs_offset")):
        raise InputError("chunked_kalman_filter takes models without inputs or offsets.")
    Y = np.asarray(y, dtype=float)
    Y = Y[:, None] if Y.ndim == 1 else Y
    n = model.n_states
    idx = tuple(range(n)) if states is None else tuple(int(s) % n for s in np.atleast_1d(states))
    chunk_size = int(chunk_size)
    if chunk_size < 1:
        raise InputError(f"chunk_size must be >= 1; got {chunk_size}.")
    T = Y.shape[0]
    mean = np.empty((T, len(idx)))
    var = np.empty((T, len(idx)))
    F, Q = model.transition, model.process_cov
    part = model
    ll = 0.0
    for a in range(0, T, chunk_size):
        b = min(a + chunk_size, T)
        filt = kalman_filter(part, Y[a:b])
        mean[a:b] = filt.mean[:, idx]
        var[a:b] = filt.cov[:, idx, idx]
        ll += float(filt.log_likelihood)
        P = F @ filt.cov[-1] @ F.T + Q
        part = replace(model, initial_mean=F @ filt.mean[-1], initial_cov=0.5 * (P + P.T))
    return ChunkedFilterResult(mean=mean, var=var, states=idx, log_likelihood=ll)
