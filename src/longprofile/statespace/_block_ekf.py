"""Decentralised (block-diagonal) extended Kalman filter: several local EKFs run in lock-step.

The state is partitioned into blocks (e.g. the four corners of a car, thesis 003 §3.1). Each block keeps
its own covariance and is corrected only by the observation components assigned to it; the blocks are
coupled through the MEANS only: the transition ``f`` and observation ``h`` are evaluated on the whole
stacked state, so each local filter sees the other blocks' current estimates as known inputs. This is the
decomposition the thesis uses to make a full-car EKF affordable on an ECU (one 4N x 4N inversion replaced
by four N x N ones).

Mathematically it equals :func:`extended_kalman_filter` on the same model with every cross-block entry of
the Jacobians, Q, R and P0 set to zero (the covariance then stays block-diagonal) — the test-suite checks
that identity — at a cost linear, not cubic, in the number of blocks.

Speed: when every block has the same numbers of states and observations, the block routines are compiled
with those sizes as constants (unrolled loops); the model's optional fused, allocation-free steps
(``NonlinearStateSpaceModel.transition_step`` / ``observation_step``) compute a function and its Jacobian
in one call.
"""

from __future__ import annotations

import functools

import numpy as np
from numba import typeof, types

from .._jit import njit
from .._validation import as_float_array
from ..errors import InputError, ShapeError
from ._ekf import NonlinearStateSpaceModel, check_functions, check_model_steps, model_function_types, model_functions
from ._ekf_kernels import model_eval
from ._linalg_kernels import all_finite1, copy1, copy2, gather_block, joseph_entry, matmul_into
from ._prepare import check_inputs, covariance_storage, noise_terms
from ._results import FilterResult
from ._status import COVARIANCE_NOT_FINITE, NOT_PD, OBSERVATION_NOT_FINITE, OK, TRANSITION_NOT_FINITE, raise_status

__all__ = ["block_extended_kalman_filter"]

_LOG2PI = float(np.log(2.0 * np.pi))


@njit(cache=True, inline="always")
def _block_update(x, P, Jh, yhat, yk, R, si, ns, oi, no, innov_k, icov_k, store,
                  Pb, Hb, PHt, S_all, L, K, A, AP, KR, obs, e, w):
    """Joseph-form update of one block in place (scratch arrays given). Returns (status, n observed, loglik)."""
    gather_block(P, si, si, ns, ns, Pb)
    gather_block(Jh, oi, si, no, ns, Hb)
    matmul_into(Pb, Hb.T, ns, ns, no, PHt)  # P H'
    for a in range(no):
        for b in range(a, no):
            t = 0.5 * (R[oi[a], oi[b]] + R[oi[b], oi[a]])
            for i in range(ns):
                t += Hb[a, i] * PHt[i, b]
            S_all[a, b] = t
            S_all[b, a] = t
    if store:
        for a in range(no):
            for b in range(no):
                icov_k[oi[a], oi[b]] = S_all[a, b]
    mo = 0
    for a in range(no):
        if not np.isnan(yk[oi[a]]):
            obs[mo] = a  # position inside the block
            mo += 1
    if mo == 0:
        return OK, 0, 0.0
    for a in range(mo):
        e[a] = yk[oi[obs[a]]] - yhat[oi[obs[a]]]
        if not np.isfinite(e[a]):
            return OBSERVATION_NOT_FINITE, 0, 0.0
    # Cholesky of the observed part of S
    for a in range(mo):
        for b in range(a + 1):
            t = S_all[obs[a], obs[b]]
            for q in range(b):
                t -= L[a, q] * L[b, q]
            if a == b:
                if not t > 0.0:
                    return NOT_PD, 0, 0.0
                L[a, a] = np.sqrt(t)
            else:
                L[a, b] = t / L[b, b]
    quad = 0.0
    logdet = 0.0
    for a in range(mo):
        t = e[a]
        for q in range(a):
            t -= L[a, q] * w[q]
        w[a] = t / L[a, a]
        quad += w[a] * w[a]
        logdet += 2.0 * np.log(L[a, a])
    for i in range(ns):
        for a in range(mo):
            t = PHt[i, obs[a]]
            for q in range(a):
                t -= L[a, q] * K[i, q]
            K[i, a] = t / L[a, a]
        for a in range(mo - 1, -1, -1):
            t = K[i, a]
            for q in range(a + 1, mo):
                t -= L[q, a] * K[i, q]
            K[i, a] = t / L[a, a]
    for i in range(ns):
        t = 0.0
        for a in range(mo):
            t += K[i, a] * e[a]
        x[si[i]] += t
    for i in range(ns):
        for j in range(ns):
            t = 1.0 if i == j else 0.0
            for a in range(mo):
                t -= K[i, a] * Hb[obs[a], j]
            A[i, j] = t
    matmul_into(A, Pb, ns, ns, ns, AP)
    for i in range(ns):
        for a in range(mo):
            t = 0.0
            for b in range(mo):
                t += K[i, b] * 0.5 * (R[oi[obs[b]], oi[obs[a]]] + R[oi[obs[a]], oi[obs[b]]])
            KR[i, a] = t
    for i in range(ns):
        for j in range(i, ns):
            t = joseph_entry(AP, A, KR, K, i, j, ns, mo)
            P[si[i], si[j]] = t
            P[si[j], si[i]] = t
    for a in range(mo):
        innov_k[oi[obs[a]]] = e[a]
    return OK, mo, -0.5 * (mo * _LOG2PI + logdet + quad)


@njit(cache=True, inline="always")
def _block_predict(P, Jf, Q, si, ns, Fb, Pb, AP):
    """Covariance prediction F P F' + Q of one block in place (scratch arrays given)."""
    gather_block(Jf, si, si, ns, ns, Fb)
    gather_block(P, si, si, ns, ns, Pb)
    matmul_into(Fb, Pb, ns, ns, ns, AP)
    for i in range(ns):
        for j in range(i, ns):
            t = 0.5 * (Q[si[i], si[j]] + Q[si[j], si[i]])
            for q in range(ns):
                t += AP[i, q] * Fb[j, q]
            P[si[i], si[j]] = t
            P[si[j], si[i]] = t


@njit(cache=True, inline="always")
def _clear_step(innov_k, icov_k, store):
    """A step's innovation to NaN (components no block observes stay missing) and, if stored, its covariance to 0."""
    for a in range(innov_k.shape[0]):
        innov_k[a] = np.nan
    if store:
        for a in range(icov_k.shape[0]):
            for b in range(icov_k.shape[1]):
                icov_k[a, b] = 0.0


@njit(cache=True)
def _update_all(x, P, Jh, yhat, yk, R, sidx, scount, oidx, ocount, innov_k, icov_k, store,
                Pb, Hb, PHt, S, L, K, A, AP, KR, obs, e, w):
    """Update every block (their state sets are disjoint, so the order does not matter)."""
    _clear_step(innov_k, icov_k, store)
    ll = 0.0
    n_obs = 0
    for b in range(sidx.shape[0]):
        status, mo, llb = _block_update(x, P, Jh, yhat, yk, R, sidx[b], scount[b], oidx[b], ocount[b], innov_k,
                                        icov_k, store, Pb, Hb, PHt, S, L, K, A, AP, KR, obs, e, w)
        if status != OK:
            return status, n_obs, ll
        ll += llb
        n_obs += mo
    return OK, n_obs, ll


@njit(cache=True)
def _predict_all(P, Jf, Q, sidx, scount, Fb, Pb, AP):
    for b in range(sidx.shape[0]):
        _block_predict(P, Jf, Q, sidx[b], scount[b], Fb, Pb, AP)


@njit(cache=True)
def _init_cov(P0, sidx, scount, P):
    for i in range(P.shape[0]):
        for j in range(P.shape[1]):
            P[i, j] = 0.0
    for b in range(sidx.shape[0]):
        for i in range(scount[b]):
            for j in range(scount[b]):
                P[sidx[b, i], sidx[b, j]] = P0[sidx[b, i], sidx[b, j]]


_update_all_inline = njit(inline="always")(_update_all.py_func)
_predict_all_inline = njit(inline="always")(_predict_all.py_func)


@njit(inline="always")
def _blocks_finite(J, ridx, rcount, cidx, ccount):
    """True if the diagonal blocks J[ridx[b], cidx[b]] (the entries the local filters use) are finite."""
    for b in range(ridx.shape[0]):
        for i in range(rcount[b]):
            for j in range(ccount[b]):
                if not np.isfinite(J[ridx[b, i], cidx[b, j]]):
                    return False
    return True


@njit(inline="always")
def _update_all_uniform(x, P, Jh, yhat, yk, R, sidx, ns, oidx, no, innov_k, icov_k, store,
                        Pb, Hb, PHt, S, L, K, A, AP, KR, obs, e, w):
    """:func:`_update_all` for blocks of equal sizes ``ns``, ``no`` (compile-time constants: unrolled loops)."""
    _clear_step(innov_k, icov_k, store)
    ll = 0.0
    n_obs = 0
    for b in range(sidx.shape[0]):
        status, mo, llb = _block_update(x, P, Jh, yhat, yk, R, sidx[b], ns, oidx[b], no, innov_k,
                                        icov_k, store, Pb, Hb, PHt, S, L, K, A, AP, KR, obs, e, w)
        if status != OK:
            return status, n_obs, ll
        ll += llb
        n_obs += mo
    return OK, n_obs, ll


@njit(inline="always")
def _predict_all_uniform(P, Jf, Q, sidx, ns, Fb, Pb, AP):
    for b in range(sidx.shape[0]):
        _block_predict(P, Jf, Q, sidx[b], ns, Fb, Pb, AP)


@njit
def _block_kernel(f, h, fjac, hjac, fstep, hstep, params, Q3, R3, x0, P0, y, u, sidx, scount, oidx, ocount, store,
                  mean, cov, pmean, pcov, innov, icov, ll_steps, Fj, Hj, state, store_var, var, ns_uniform,
                  no_uniform):
    """The lock-step loop of the local filters.

    The model enters as in :func:`._ekf_kernels.ekf_kernel`: separate functions (``fstep``, ``hstep``
    None; ``fjac``/``hjac`` None = finite differences) or fused in-place steps (the others None),
    evaluated through :func:`._ekf_kernels.model_eval`, with the model's ``params`` (None: none) after k. When every block has ``ns_uniform`` states and
    ``no_uniform`` observations (> 0; passed as numba literals, so the block loops have compile-time
    trip counts and are unrolled), the uniform block routines are used. ``store_var``: the diagonal of each
    filtered covariance is written to ``var[k, :n]`` and that of the (block-diagonal) innovation covariance to
    ``var[k, n:]`` (``var`` is (T, n + m); a dummy otherwise).
    """
    T, m = y.shape
    n = x0.shape[0]
    x = np.empty(n)
    copy1(x0, x)
    P = np.empty((n, n))
    _init_cov(P0, sidx, scount, P)
    Jf = np.zeros((n, n))
    Jh = np.zeros((m, n))
    y_hat = np.zeros(m)
    x_next = np.zeros(n)
    xw = np.empty(n)
    smax, omax = sidx.shape[1], oidx.shape[1]
    Pb, Hb, PHt = np.empty((smax, smax)), np.empty((omax, smax)), np.empty((smax, omax))
    S, L, K = np.empty((omax, omax)), np.zeros((omax, omax)), np.empty((smax, omax))
    A, AP, KR = np.empty((smax, smax)), np.empty((smax, smax)), np.empty((smax, omax))
    obs, e, w = np.empty(omax, np.int64), np.empty(omax), np.empty(omax)
    n_obs = 0
    store_s = store or store_var  # the innovation covariance is written (to icov[0] unless store)
    for k in range(T):
        uk = u[k]
        R = R3[k if R3.shape[0] > 1 else 0]
        copy1(x, pmean[k])
        if store:
            copy2(P, pcov[k])
        yhat = model_eval(h, hjac, hstep, params, x, uk, k, xw, y_hat, Jh)
        if not _blocks_finite(Jh, oidx, ocount, sidx, scount):
            state[0] = OBSERVATION_NOT_FINITE
            state[1] = k
            return n_obs
        if store:
            copy2(Jh, Hj[k])
        if ns_uniform > 0:
            status, mo, ll = _update_all_uniform(x, P, Jh, yhat, y[k], R, sidx, ns_uniform, oidx, no_uniform,
                                                 innov[k], icov[k if store else 0], store_s, Pb, Hb, PHt, S, L, K,
                                                 A, AP, KR, obs, e, w)
        else:
            status, mo, ll = _update_all_inline(x, P, Jh, yhat, y[k], R, sidx, scount, oidx, ocount, innov[k],
                                                icov[k if store else 0], store_s, Pb, Hb, PHt, S, L, K, A, AP, KR,
                                                obs, e, w)
        if status != OK:
            state[0] = status
            state[1] = k
            return n_obs
        n_obs += mo
        ll_steps[k] = ll
        copy1(x, mean[k])
        if store:
            copy2(P, cov[k])
        if store_var:
            for i in range(n):
                var[k, i] = P[i, i]
            for a in range(m):
                var[k, n + a] = icov[0 if not store else k][a, a]
        if k < T - 1:
            xn = model_eval(f, fjac, fstep, params, x, uk, k, xw, x_next, Jf)
            if not (all_finite1(xn) and _blocks_finite(Jf, sidx, scount, sidx, scount)):
                state[0] = TRANSITION_NOT_FINITE
                state[1] = k
                return n_obs
            if ns_uniform > 0:
                _predict_all_uniform(P, Jf, Q3[k if Q3.shape[0] > 1 else 0], sidx, ns_uniform, A, Pb, AP)
            else:
                _predict_all_inline(P, Jf, Q3[k if Q3.shape[0] > 1 else 0], sidx, scount, A, Pb, AP)
            for i in range(n):
                if not np.isfinite(P[i, i]):
                    state[0] = COVARIANCE_NOT_FINITE
                    state[1] = k
                    return n_obs
            if store:
                copy2(Jf, Fj[k])
            copy1(xn, x)
    state[0] = OK
    return n_obs


@functools.cache
def _cached_kernel():
    """:func:`_block_kernel` compiled for first-class function types (typed by the model functions'
    signature, not their identity), so numba caches it on disk: compiled once per machine, not per
    process (see :func:`._ekf.model_function_types`)."""
    return njit(cache=True)(_block_kernel.py_func)


def _labels(name, labels, size):
    arr = np.asarray(labels)
    if arr.shape != (size,) or not np.issubdtype(arr.dtype, np.integer):
        raise ShapeError(f"{name} must be {size} integer block labels (one per component); got {np.shape(labels)} "
                         f"of dtype {arr.dtype}.")
    return arr.astype(np.int64)


def block_extended_kalman_filter(model: NonlinearStateSpaceModel, y, *, state_blocks, obs_blocks, u=None,
                                 store_covariances: bool | str = True) -> FilterResult:
    """Decentralised EKF: one local EKF per state block, coupled through the means (lock-step).

    Parameters
    ----------
    model : NonlinearStateSpaceModel
        Stacked model; ``f`` and ``h`` see the whole state. Only the diagonal blocks of the Jacobians,
        Q, R and P0 are used (cross-block entries are ignored: the other blocks act as known inputs).
    y : (T, m) array_like
        Observations; NaN = missing component. (One series; no batch axis.)
    state_blocks : (n,) int array_like
        Block label of each state (labels 0..B-1, every block non-empty).
    obs_blocks : (m,) int array_like
        Block label of each observation component: the local filter it corrects.
    u : (T, p) array_like, optional
        Known inputs, row k passed to f and h at step k.
    store_covariances : bool or "variances"
        If False, the covariance fields and Jacobians of the result are None; ``"variances"``: the same, but the
        diagonal of each filtered covariance is kept (``FilterResult.variance``, (T, n): O(T n) memory instead
        of the O(T n^2) of the five covariance and Jacobian histories), and that of each innovation covariance
        (``FilterResult.innovation_variance``, (T, m)). The filtered numbers are the same in all three modes
        (only what is copied out differs).

    Returns
    -------
    FilterResult
        ``method = "block-ekf"``; ``cov``/``pred_cov`` are (T, n, n) block-diagonal; ``innovation_cov``
        block-diagonal (components of different blocks are treated as independent);
        ``log_likelihood`` sums the local filters' contributions.

    Raises
    ------
    ShapeError, InputError
        On inconsistent shapes or block labels.
    ModelError
        If an innovation covariance loses positive definiteness or a model function returns non-finite values.

    Notes
    -----
    Per step: ``yhat = h(x[k|k-1])`` once; for each block b, with its observed components o_b:
    ``S_b = H_bb P_b H_bb' + R_bb``, ``K_b = P_b H_bb' S_b^-1``, ``x_b += K_b (y_o - yhat_o)``,
    Joseph update of P_b. Then ``x[k+1|k] = f(x[k|k])`` (all blocks, coupled) and
    ``P_b <- F_bb P_b F_bb' + Q_bb``. Thesis 003 (Plancke), §3.1 eq. (3.3): the per-corner filters of a car.
    The compiled loop calls the model's numba-jitted functions (plain Python functions are compiled by the
    model): its fused steps when it has them (``transition_step``/``observation_step`` of
    :class:`NonlinearStateSpaceModel`; only the diagonal blocks of the Jacobians they write are used and
    checked), else f, h and the Jacobians (None = central finite differences).
    """
    if not isinstance(model, NonlinearStateSpaceModel):
        raise InputError(f"block_extended_kalman_filter needs a NonlinearStateSpaceModel; got {type(model).__name__}.")
    n, m = model.n_states, model.n_obs
    Y = as_float_array("y", y, ndim=(1, 2))
    if Y.ndim == 1:
        Y = Y[:, None]
    if Y.shape[1] != m or Y.shape[0] < 1:
        raise ShapeError(f"y must have shape (T, {m}); got {np.shape(y)}.")
    T = Y.shape[0]
    sb = _labels("state_blocks", state_blocks, n)
    ob = _labels("obs_blocks", obs_blocks, m)
    nb = int(sb.max()) + 1
    if sb.min() < 0 or set(np.unique(sb)) != set(range(nb)):
        raise InputError(f"state_blocks must use every label 0..B-1; got labels {sorted(set(sb.tolist()))}.")
    if ob.min() < 0 or ob.max() >= nb:
        raise InputError(f"obs_blocks must use labels of state blocks (0..{nb - 1}); got {sorted(set(ob.tolist()))}.")
    smax = int(np.bincount(sb).max())
    omax = max(int(np.bincount(ob, minlength=nb).max()), 1)
    sidx = np.zeros((nb, smax), np.int64)
    oidx = np.zeros((nb, omax), np.int64)
    scount = np.zeros(nb, np.int64)
    ocount = np.zeros(nb, np.int64)
    for b in range(nb):
        s_i = np.flatnonzero(sb == b)
        o_i = np.flatnonzero(ob == b)
        sidx[b, :s_i.size], scount[b] = s_i, s_i.size
        oidx[b, :o_i.size], ocount[b] = o_i, o_i.size
    Q3, R3 = noise_terms(model.process_cov, model.obs_cov, T)
    U = np.zeros((T, 0)) if u is None else check_inputs(u, T)
    store, store_var = covariance_storage(store_covariances)
    mean, pmean = np.empty((T, n)), np.empty((T, n))
    innov, ll_steps = np.empty((T, m)), np.zeros(T)
    if store:
        cov, pcov, icov = np.empty((T, n, n)), np.empty((T, n, n)), np.empty((T, m, m))
        Fj, Hj = np.empty((max(T - 1, 1), n, n)), np.empty((T, m, n))
    else:
        cov, pcov, icov = np.empty((1, n, n)), np.empty((1, n, n)), np.empty((1, m, m))
        Fj, Hj = np.empty((1, n, n)), np.empty((1, m, n))
    state = np.zeros(2, np.int64)
    var = np.empty((T, n + m) if store_var else (1, n + m))
    fns = model_functions(model)
    data = (model.kernel_params(), Q3, R3, np.ascontiguousarray(model.initial_mean), np.ascontiguousarray(model.initial_cov),
            np.ascontiguousarray(Y), U if U.flags.writeable else U.copy(), sidx, scount, oidx, ocount, store, mean,
            cov, pmean, pcov, innov, icov, ll_steps, Fj, Hj, state, store_var, var)
    # equal block sizes: passed as numba literals, the block loops get compile-time trip counts (unrolled)
    uniform = bool(np.all(scount == smax) and np.all(ocount == omax))
    sizes = (smax, omax) if uniform else (0, 0)
    size_types = tuple(types.literal(v) if uniform else types.int64 for v in sizes)
    same_block = (sb[:, None] == sb[None, :], ob[:, None] == sb[None, :])
    check_functions(model, U[0])
    check_model_steps(model, U[0], jacobian_mask=same_block)
    fn_types = model_function_types(model)
    if fn_types is not None:
        entry = _cached_kernel().compile(fn_types + tuple(typeof(a) for a in data) + size_types)
        n_obs = entry(*fns, *data, *sizes)
    else:  # model functions with other signatures: compile the loop for these functions (per process)
        n_obs = _block_kernel(*fns, *data, 0, 0)
    raise_status(state[0], state[1], "block_ekf")
    return FilterResult(
        mean=mean, cov=cov if store else None, pred_mean=pmean, pred_cov=pcov if store else None,
        innovation=innov, innovation_cov=icov if store else None, log_likelihood=float(ll_steps.sum()),
        log_likelihood_steps=ll_steps, n_observed=int(n_obs), method="block-ekf",
        transition_jacobians=Fj[:T - 1] if store else None, observation_jacobians=Hj if store else None,
        variance=var[:, :n] if store_var else None, innovation_variance=var[:, n:] if store_var else None)
