"""Steady-state (constant-gain) Kalman filter and zero-lag smoother for time-invariant models."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.linalg import LinAlgError, LinAlgWarning, cho_factor, cho_solve, solve_discrete_are, solve_discrete_lyapunov

from ..errors import InputError, ModelError, NotDetectableError, ShapeError
from ._model import StateSpaceModel
from ._prepare import prepare_inputs, prepare_observations
from ._results import FilterResult, SmootherResult
from ._steady_kernels import filter_kernel, smooth_kernel

__all__ = ["SteadyStateGain", "steady_state_gain", "steady_state_filter", "steady_state_smoother",
           "steady_state_smoothed_cov"]

_LOG2PI = float(np.log(2.0 * np.pi))
# Relative tolerance of the PBH rank tests and of "on the unit circle".
_PBH_RTOL = 1e-9
# Largest accepted relative residual of the DARE / Lyapunov solutions (max |residual| / max |P|).
_DARE_RTOL = 1e-8


@dataclass(frozen=True, eq=False)
class SteadyStateGain:
    """Stationary solution of the Kalman filter of a time-invariant model.

    Attributes
    ----------
    gain : (n, m) ndarray
        Filter gain K of the measurement update x[k|k] = x[k|k-1] + K e[k].
    pred_cov : (n, n) ndarray
        Stationary predicted covariance P = Cov(x_k | y_<k), the stabilising DARE solution.
    cov : (n, n) ndarray
        Stationary filtered covariance Cov(x_k | y_<=k) = (I - K H) P (Joseph form).
    innovation_cov : (m, m) ndarray
        Stationary innovation covariance S = H P H' + R.
    closed_loop_radius : float
        Spectral radius rho of the filter's closed loop (I - K H) F. The start-up transient of
        the constant-gain filter (where it differs from :func:`kalman_filter`) decays like rho^k:
        about ln(1e-8) / ln(rho) samples to 1e-8. Close to 1 means a slow, nearly undetectable mode.
    """

    gain: np.ndarray
    pred_cov: np.ndarray
    cov: np.ndarray
    innovation_cov: np.ndarray
    closed_loop_radius: float = float("nan")


def _sym(a):
    return 0.5 * (a + a.T)


def _require_time_invariant(model: StateSpaceModel, what: str) -> None:
    if not isinstance(model, StateSpaceModel):
        raise InputError(f"{what} needs a StateSpaceModel; got {type(model).__name__}.")
    if model.is_time_varying():
        raise ModelError(f"{what} needs a time-invariant model (every term at its base rank); this model has a "
                         "time axis on at least one term. Use kalman_filter / rts_smoother for time-varying models.")


def _psd_sqrt(Q):
    w, V = np.linalg.eigh(_sym(Q))
    return V * np.sqrt(np.clip(w, 0.0, None))


def _pbh_failures(F, M, *, unit_circle_only: bool, side: str):
    """Eigenvalues lambda of F (|lambda| >= 1, or only |lambda| = 1) that fail the PBH rank test.

    side "rows": rank [F - lambda I; M] < n (detectability, M = H);
    side "cols": rank [F - lambda I, M] < n (stabilisability, M = Q^1/2).
    Returns a list of (eigenvalue, direction) with the unreached direction (unit vector).
    """
    n = F.shape[0]
    scale = max(np.linalg.norm(F, 2), np.linalg.norm(M, 2) if M.size else 0.0, np.finfo(float).tiny)
    out = []
    seen = []
    for lam in np.linalg.eigvals(F):
        if any(abs(lam - s) <= 1e-8 * max(1.0, abs(s)) for s in seen):
            continue  # repeated eigenvalue: one rank test covers it
        seen.append(lam)
        mod = abs(lam)
        if unit_circle_only:
            if abs(mod - 1.0) > 1e-8:
                continue
        elif mod < 1.0 - 1e-8:
            continue
        A = F - lam * np.eye(n)
        block = np.vstack([A, M]) if side == "rows" else np.hstack([A, M]).conj().T
        _u, s, vh = np.linalg.svd(block)
        if s[-1] <= _PBH_RTOL * scale:
            v = vh[-1].conj()
            v = v / v[np.argmax(np.abs(v))]
            out.append((lam, np.real_if_close(v, tol=1e6) + 0.0))
    return out


def _fmt_mode(lam, v):
    lam_s = f"{lam.real:.6g}" if abs(lam.imag) < 1e-12 else f"{lam:.6g}"
    with np.printoptions(precision=4, suppress=True):
        return f"eigenvalue {lam_s} (|.| = {abs(lam):.6g}), direction {np.asarray(v)}"


def _dare_doubling(F, H, Q, R, *, max_iter: int = 200, rtol: float = 1e-15):
    """Filtering DARE P = F P (I + H' R^-1 H P)^-1 F' + Q by the structure-preserving doubling algorithm.

    E. K.-W. Chu, H.-Y. Fan, W.-W. Lin, "A structure-preserving doubling algorithm for continuous-time algebraic
    Riccati equations", Linear Algebra Appl. 396 (2005) (the discrete-time form, their eq. (2.3)): with
    A_0 = F', G_0 = H' R^-1 H, H_0 = Q, W = I + G_k H_k,
    A_{k+1} = A_k W^-1 A_k, G_{k+1} = G_k + A_k W^-1 G_k A_k', H_{k+1} = H_k + A_k' H_k W^-1 A_k, and H_k -> P
    quadratically for a detectable, stabilisable model. Returns None if it does not converge.
    """
    n = F.shape[0]
    A = F.T.copy()
    G = H.T @ np.linalg.solve(R, H)
    X = Q.copy()
    eye = np.eye(n)
    for _ in range(max_iter):
        W = eye + G @ X
        try:
            WA = np.linalg.solve(W, A)
            WG = np.linalg.solve(W, G)
        except np.linalg.LinAlgError:
            return None
        X_new = X + A.T @ X @ WA
        G = G + A @ WG @ A.T
        A = A @ WA
        G = 0.5 * (G + G.T)
        X_new = 0.5 * (X_new + X_new.T)
        if not np.all(np.isfinite(X_new)):
            return None
        done = np.abs(X_new - X).max() <= rtol * max(np.abs(X_new).max(), np.finfo(float).tiny)
        X = X_new
        if done:
            return X
    return None


def steady_state_gain(model: StateSpaceModel) -> SteadyStateGain:
    """Stationary Kalman gain and covariances of a time-invariant model (discrete algebraic Riccati equation).

    Parameters
    ----------
    model : StateSpaceModel
        Time-invariant model (F, H, Q, R constant). ``obs_cov`` (R) must be
        positive definite. Inputs and offsets do not affect the gain.

    Returns
    -------
    SteadyStateGain
        ``gain`` K (n, m), ``pred_cov`` P (n, n), ``cov`` (n, n), ``innovation_cov`` S (m, m).

    Raises
    ------
    ModelError
        If the model is time-varying or R is not positive definite.
    NotDetectableError
        If no stabilising DARE solution exists: a mode of F with |lambda| >= 1
        that the observations cannot see ((F, H) not detectable — e.g. an
        integrator the sensor is blind to), a mode on the unit circle that the
        process noise does not excite ((F, Q^1/2) not stabilisable on the unit
        circle), or scipy's DARE solver fails / returns a non-stabilising solution.
        The message names the offending eigenvalue and state direction.

    Notes
    -----
    The predicted covariance is the stabilising solution of the filtering DARE

    .. math:: P = F P F^T - F P H^T (H P H^T + R)^{-1} H P F^T + Q,

    the dual of the control DARE solved by :func:`scipy.linalg.solve_discrete_are`,
    so it is called with ``a = F.T``, ``b = H.T``, ``q = Q``, ``r = R`` (no
    cross-covariance between process and measurement noise). Then
    S = H P H' + R, K = P H' S^-1 (Cholesky solve), and the filtered covariance
    is the Joseph form (I - K H) P (I - K H)' + K R K'. The solution is checked:
    the closed loop (I - K H) F must have spectral radius < 1.

    Existence (Anderson & Moore, *Optimal Filtering*, 1979, §4.4): with R > 0 a
    stabilising solution exists iff (F, H) is detectable and (F, Q^1/2) has no
    uncontrollable mode on the unit circle. Both are tested with the
    Popov-Belevitch-Hautus rank test before the solver runs, so the error names
    the mode. The usual cure for an unobservable integrator (e.g. the absolute
    elevation of a profile measured by an inertial profiler) is to remove the
    state, give it a leak (|lambda| < 1, a high-pass) or add a weak pseudo-observation.
    """
    _require_time_invariant(model, "steady_state_gain")
    F, H, Q, R = model.transition, model.observation, model.process_cov, model.obs_cov
    try:
        np.linalg.cholesky(R)
    except np.linalg.LinAlgError:
        raise ModelError(f"steady_state_gain needs obs_cov (R) positive definite; its eigenvalues are "
                         f"{np.linalg.eigvalsh(R)}. Add a small measurement noise variance.") from None
    bad = _pbh_failures(F, H, unit_circle_only=False, side="rows")
    if bad:
        modes = "; ".join(_fmt_mode(lam, v) for lam, v in bad)
        raise NotDetectableError(
            f"no steady-state Kalman filter: (F, H) is not detectable — mode(s) with |eigenvalue| >= 1 that the "
            f"observations cannot see: {modes}. The error on this state combination grows without bound, so the "
            "Riccati equation has no stabilising solution. Remove the unobservable state, give it a leak "
            "(|eigenvalue| < 1, i.e. high-pass it) or add a pseudo-observation; or use kalman_filter, which "
            "runs with a growing covariance.")
    bad = _pbh_failures(F, _psd_sqrt(Q), unit_circle_only=True, side="cols")
    if bad:
        modes = "; ".join(_fmt_mode(lam, v) for lam, v in bad)
        raise NotDetectableError(
            f"no stabilising steady-state Kalman filter: (F, Q^1/2) is not stabilisable — mode(s) on the unit "
            f"circle not excited by process noise: {modes}. The filter's gain on this mode tends to 0, so it "
            "is never stable. Add process noise on that mode or make it strictly stable.")
    try:
        P = solve_discrete_are(F.T, H.T, Q, R)
    except (LinAlgError, ValueError, np.linalg.LinAlgError) as exc:
        # scipy's QZ-based solver can fail on ill-conditioned pencils (e.g. a state with eigenvalue 0 beside poles
        # near 1); the structure-preserving doubling algorithm needs no reordering and is checked the same way
        P = _dare_doubling(F, H, Q, R)
        if P is None:
            raise NotDetectableError(f"the discrete algebraic Riccati equation has no stabilising solution for "
                                     f"this model (scipy.linalg.solve_discrete_are: {exc}; the doubling algorithm "
                                     "did not converge either). Check that (F, H) is detectable and Q excites "
                                     "every marginally stable mode.") from None
    P = _sym(P)
    S = _sym(H @ P @ H.T + R)
    try:
        cS = cho_factor(S, lower=True)
    except np.linalg.LinAlgError:
        raise NotDetectableError("the Riccati solution gives a non-positive-definite innovation covariance; the "
                                 "model is too ill-conditioned for a steady-state filter.") from None
    resid = F @ P @ F.T - F @ P @ H.T @ cho_solve(cS, H @ P @ F.T) + Q - P
    scale = max(float(np.abs(P).max()), float(np.abs(Q).max()), np.finfo(float).tiny)
    if not np.all(np.isfinite(P)) or float(np.abs(resid).max()) > _DARE_RTOL * scale:
        raise NotDetectableError(f"the Riccati solution is inaccurate (relative residual "
                                 f"{float(np.abs(resid).max()) / scale:.3g} > {_DARE_RTOL:g}): the model is close to "
                                 "undetectable or badly scaled. Rescale the states, or use kalman_filter.")
    ss = gain_from_pred_cov(model, P)
    if ss.closed_loop_radius >= 1.0:
        raise NotDetectableError(f"the Riccati solution is not stabilising (spectral radius of (I - K H) F = "
                                 f"{ss.closed_loop_radius:.6g} >= 1); the model is not detectable/stabilisable to "
                                 "working precision.")
    return ss


def gain_from_pred_cov(model: StateSpaceModel, P: np.ndarray) -> SteadyStateGain:
    """The constant-gain filter of a predicted covariance P (the DARE solution, or a converged Riccati iterate).

    S = H P H' + R, K = P H' S^-1 (Cholesky), Joseph-form filtered covariance, closed-loop spectral radius.
    """
    F, H, R = model.transition, model.observation, model.obs_cov
    n = model.n_states
    P = _sym(np.array(P, dtype=float))
    S = _sym(H @ P @ H.T + R)
    K = cho_solve(cho_factor(S, lower=True), H @ P).T
    IKH = np.eye(n) - K @ H
    rho = float(np.max(np.abs(np.linalg.eigvals(IKH @ F)), initial=0.0))
    Pf = _sym(IKH @ P @ IKH.T + K @ R @ K.T)
    for arr in (K, P, Pf, S):
        arr.setflags(write=False)
    return SteadyStateGain(gain=K, pred_cov=P, cov=Pf, innovation_cov=S, closed_loop_radius=rho)


def _smoother_gain(model: StateSpaceModel, ss: SteadyStateGain) -> np.ndarray:
    """Constant RTS gain G = P_f F' P_p^-1 (equilibrated solve; minimum-norm solution if P_p is singular)."""
    F = model.transition
    Pp = ss.pred_cov
    rhs = F @ ss.cov  # = (P_f F')', so G' solves P_p G' = rhs
    target = float(np.abs(rhs).max()) or 1.0
    d = np.sqrt(np.diag(Pp))
    if np.all(d > 0):
        # equilibrate (states of very different scales) before the solve
        try:
            Gt = np.linalg.solve(Pp / np.outer(d, d), rhs / d[:, None]) / d[:, None]
            if float(np.abs(Pp @ Gt - rhs).max()) <= 1e-10 * target:
                return Gt.T
        except np.linalg.LinAlgError:
            pass
    # singular P_p (deterministic state combinations): minimum-norm solution, directions of zero
    # predicted variance carry no smoothing correction
    return (np.linalg.pinv(Pp, rcond=1e-13, hermitian=True) @ rhs).T


def steady_state_smoothed_cov(model: StateSpaceModel) -> np.ndarray:
    """Constant smoothed covariance Cov(x_k | y) far from both ends of a long series.

    Parameters
    ----------
    model : StateSpaceModel
        Time-invariant model with a steady-state filter (see :func:`steady_state_gain`).

    Returns
    -------
    (n, n) ndarray
        P_s solving P_s = P_f + G (P_s - P_p) G', the fixed point of the RTS
        covariance recursion with the constant smoother gain G = P_f F' P_p^-1.
        This is the covariance of :func:`steady_state_smoother`'s means (whose
        ``cov`` field is None because it is the same at every step).

    Raises
    ------
    NotDetectableError
        As :func:`steady_state_gain`, or if the smoother gain is not stable.

    Notes
    -----
    Solved as the discrete Lyapunov equation P_s - G P_s G' = P_f - G P_p G'
    (:func:`scipy.linalg.solve_discrete_lyapunov`).
    """
    _require_time_invariant(model, "steady_state_smoothed_cov")
    ss = steady_state_gain(model)
    G = _smoother_gain(model, ss)
    rho = float(np.max(np.abs(np.linalg.eigvals(G)), initial=0.0))
    if rho >= 1.0:
        raise NotDetectableError(f"the steady-state smoother gain is not stable (spectral radius {rho:.6g} >= 1), "
                                 "so the smoothed covariance has no fixed point.")
    C = _sym(ss.cov - G @ ss.pred_cov @ G.T)
    with warnings.catch_warnings():
        # scipy warns on the ill-conditioned Kronecker system when rho(G) is close to 1 (slow smoother
        # modes, e.g. the APL model); the residual check below decides instead.
        warnings.simplefilter("ignore", LinAlgWarning)
        Ps = solve_discrete_lyapunov(G, C, method="direct" if G.shape[0] <= 12 else "bilinear")
    Ps = _sym(Ps)
    resid = float(np.abs(Ps - G @ Ps @ G.T - C).max())
    if not np.all(np.isfinite(Ps)) or resid > _DARE_RTOL * max(float(np.abs(Ps).max()), np.finfo(float).tiny):
        raise NotDetectableError(f"the steady-state smoothed covariance could not be solved accurately (relative "
                                 f"Lyapunov residual {resid / max(float(np.abs(Ps).max()), 1e-300):.3g}; smoother "
                                 f"gain spectral radius {rho:.8g}). Use rts_smoother's covariance instead.")
    Ps.setflags(write=False)
    return Ps


def _gain(model, gain):
    if gain is None:
        return steady_state_gain(model)
    if not isinstance(gain, SteadyStateGain):
        raise InputError(f"gain must be a SteadyStateGain from steady_state_gain(model); got {type(gain).__name__}.")
    if gain.gain.shape != (model.n_states, model.n_obs):
        raise ShapeError(f"gain has shape {gain.gain.shape} but the model needs (n, m) = "
                         f"({model.n_states}, {model.n_obs}); compute it with steady_state_gain(model).")
    return gain


def _prepare(model, y, u, what, allow_nan=False):
    _require_time_invariant(model, what)
    Y, batched = prepare_observations(model, y)
    nb, T, m = Y.shape
    if not allow_nan and np.isnan(Y).any():
        idx = tuple(int(i) for i in np.argwhere(np.isnan(Y))[0])
        raise InputError(f"{what} needs complete data: y has {int(np.isnan(Y).sum())} missing (NaN) value(s), "
                         f"first at index {idx if batched else idx[1:]}. A constant gain is not optimal across "
                         "gaps; use kalman_filter (store_covariances=False keeps memory O(T n)) / rts_smoother, "
                         "or fill the gaps explicitly.")
    U = prepare_inputs(model, u, T, nb)
    n = model.n_states
    p = model.n_inputs
    B = model.input_transition if model.input_transition is not None else np.zeros((n, p))
    D = model.input_observation if model.input_observation is not None else np.zeros((m, p))
    c = model.state_offset if model.state_offset is not None else np.zeros(n)
    d = model.obs_offset if model.obs_offset is not None else np.zeros(m)
    if U is None:
        U = np.empty((nb, T, 0))
    return Y, batched, U, (np.ascontiguousarray(B), np.ascontiguousarray(D), np.ascontiguousarray(c),
                           np.ascontiguousarray(d))


def _run_filter(model, ss, Y, U, terms, store_extra, x0=None):
    """Run the compiled constant-gain filter on every series of Y (B, T, m), from the predicted mean ``x0``
    (default: the model's initial mean).

    Returns mean (B, T, n), pmean (B, T, n), innov (B, T, m), ll_steps (B, T) — the last three
    None unless ``store_extra`` — and the total log-likelihoods ll (B,).
    """
    nb, T, m = Y.shape
    n = model.n_states
    B, D, c, d = terms
    S = ss.innovation_cov
    Sinv = cho_solve(cho_factor(S, lower=True), np.eye(m))
    const = m * _LOG2PI + float(np.linalg.slogdet(S)[1])
    F = model.transition
    K = ss.gain
    FK = F @ K
    # closed loop x[k+1|k] = A x[k|k-1] + G y[k] + Bc u[k] + cc (see _steady_kernels._filter_impl)
    A, G, Bc, cc = F - FK @ model.observation, FK, B - FK @ D, c - FK @ d
    A, G, Bc, cc, K, H, x0 = (np.ascontiguousarray(a) for a in (A, G, Bc, cc, K, model.observation,
                                                                 model.initial_mean if x0 is None else x0))
    mean = np.empty((nb, T, n))
    if store_extra:
        pmean, innov, ll_steps = np.empty((nb, T, n)), np.empty((nb, T, m)), np.empty((nb, T))
    else:  # not written by the kernel
        pmean, innov, ll_steps = np.empty((nb, 1, n)), np.empty((nb, 1, m)), np.empty((nb, 1))
    ll = np.empty(nb)
    for b in range(nb):
        quad = filter_kernel(A, G, Bc, cc, K, H, D, d, Sinv, x0, Y[b], U[b], const, mean[b], pmean[b], innov[b],
                             ll_steps[b], store_extra)
        ll[b] = -0.5 * (T * const + quad)
    if not store_extra:
        pmean = innov = ll_steps = None
    return mean, pmean, innov, ll_steps, ll


def _filter_result(mean, pmean, innov, ll_steps, ll, batched, m):
    T = mean.shape[1]

    def pick(a):
        return a if batched or a is None else a[0]

    nobs = np.full(mean.shape[0], T * m) if batched else T * m
    return FilterResult(mean=pick(mean), cov=None, pred_mean=pick(pmean), pred_cov=None, innovation=pick(innov),
                        innovation_cov=None, log_likelihood=ll if batched else float(ll[0]),
                        log_likelihood_steps=pick(ll_steps), n_observed=nobs, method="steady-state")


def steady_state_filter(model: StateSpaceModel, y, *, u=None, gain: SteadyStateGain | None = None,
                        store_predictions: bool = True) -> FilterResult:
    """Kalman filter with the constant steady-state gain, run as a compiled LTI recursion.

    Parameters
    ----------
    model : StateSpaceModel
        Time-invariant model with R positive definite.
    y : (T,), (T, m) or (B, T, m) array_like
        Observations, complete (no NaN). A 3-D array is a batch of series.
    u : (T, p) or (B, T, p) array_like, optional
        Known inputs, as in :func:`kalman_filter`.
    gain : SteadyStateGain, optional
        The result of ``steady_state_gain(model)``, to skip solving the DARE
        again when the same model filters many series. Must belong to ``model``
        (only its shapes can be checked).
    store_predictions : bool, default True
        Keep the one-step predictions and what derives from them:
        ``pred_mean``, ``innovation`` and ``log_likelihood_steps``. With False
        those three fields are None and only the filtered means and the total
        log-likelihood are kept: 8 T n bytes instead of 8 T (2n + m + 1) per
        series (0.48 GB instead of 1.1 GB for T = 1e7, n = 6, m = 1), and
        faster (less memory to write).

    Returns
    -------
    FilterResult
        ``mean`` (T, n), ``pred_mean`` (T, n), ``innovation`` (T, m),
        ``log_likelihood`` and ``log_likelihood_steps`` computed with the
        constant innovation covariance (``pred_mean``, ``innovation`` and
        ``log_likelihood_steps`` None with ``store_predictions=False``);
        ``cov``, ``pred_cov`` and ``innovation_cov`` are None because they are
        the constant matrices of :func:`steady_state_gain`.
        ``method = "steady-state"``.

    Raises
    ------
    InputError
        If ``y`` contains NaN: a constant gain is not the optimal filter across
        gaps, so the function refuses rather than guessing; use
        :func:`kalman_filter` (``store_covariances=False`` for O(T n) memory).
    NotDetectableError, ModelError
        As :func:`steady_state_gain`.

    Notes
    -----
    Closed loop: x[k|k] = (I - K H) (F x[k-1|k-1] + B u[k-1] + c) + K (y[k] - D u[k] - d),
    started from x[0|-1] = ``initial_mean``. The gain is the stationary one
    from the first sample on, so the first samples (a transient of a few time
    constants of (I - K H) F) differ from :func:`kalman_filter`, which starts
    from ``initial_cov``; afterwards the two agree to round-off. The
    likelihood is the asymptotic (stationary) one, exact only after that transient.

    The loop runs in closed-loop form, x[k+1|k] = F (I - K H) x[k|k-1] + F K y[k]
    + (B - F K D) u[k] + c - F K d, so that one n x n product is carried from
    step to step; the innovation and x[k|k] = x[k|k-1] + K e[k] are computed
    beside it (equal to the textbook order to round-off, ~1.4x faster).
    """
    Y, batched, U, terms = _prepare(model, y, u, "steady_state_filter")
    ss = _gain(model, gain)
    out = _run_filter(model, ss, Y, U, terms, bool(store_predictions))
    return _filter_result(*out, batched, model.n_obs)


def steady_state_smoother(model: StateSpaceModel, y, *, u=None, store_filtered: bool = True,
                          gain: SteadyStateGain | None = None) -> SmootherResult:
    """Fixed-interval (zero-lag) smoother with the constant steady-state gains, in O(T n) memory.

    Parameters
    ----------
    model : StateSpaceModel
        Time-invariant model with R positive definite.
    y : (T,), (T, m) or (B, T, m) array_like
        Observations, complete (no NaN).
    u : (T, p) or (B, T, p) array_like, optional
        Known inputs.
    store_filtered : bool, default True
        Keep the forward pass in ``result.filtered`` (means, predicted means,
        innovations). With False the backward pass overwrites the forward means
        in place and ``result.filtered`` is None: peak memory is then one
        (T, n) array plus the data (e.g. 0.96 GB for T = 2e7, n = 6).
    gain : SteadyStateGain, optional
        Precomputed ``steady_state_gain(model)`` (see :func:`steady_state_filter`).

    Returns
    -------
    SmootherResult
        ``mean`` (T, n) smoothed means; ``cov`` and ``cross_cov`` are None —
        the smoothed covariance is the constant of
        :func:`steady_state_smoothed_cov` far from the ends; ``filtered`` as above.

    Raises
    ------
    InputError
        If ``y`` contains NaN (see :func:`steady_state_filter`).
    NotDetectableError, ModelError
        As :func:`steady_state_gain`.

    Notes
    -----
    Rauch-Tung-Striebel backward pass with the constant gain G = P_f F' P_p^-1:
    x_s[k] = x[k|k] + G (x_s[k+1] - F x[k|k] - B u[k] - c). Being a forward
    and a backward (anti-causal) LTI pass it has zero phase lag. It equals
    :func:`rts_smoother` except near the start, where the time-varying gains
    of the exact filter differ from the stationary ones.
    """
    Y, batched, U, terms = _prepare(model, y, u, "steady_state_smoother")
    ss = _gain(model, gain)
    G = _smoother_gain(model, ss)
    mean, pmean, innov, ll_steps, ll = _run_filter(model, ss, Y, U, terms, store_filtered)
    B, _D, c, _d = terms
    n = model.n_states
    I_GF = np.ascontiguousarray(np.eye(n) - G @ model.transition)
    GB = np.ascontiguousarray(G @ B)
    Gc = np.ascontiguousarray(G @ c)
    G = np.ascontiguousarray(G)
    if store_filtered:
        smoothed = np.empty_like(mean)
        filtered = _filter_result(mean, pmean, innov, ll_steps, ll, batched, model.n_obs)
    else:
        smoothed = mean
        filtered = None
    for b in range(mean.shape[0]):
        smooth_kernel(I_GF, G, GB, Gc, U[b], mean[b], smoothed[b])
    return SmootherResult(mean=smoothed if batched else smoothed[0], cov=None, cross_cov=None, filtered=filtered)
