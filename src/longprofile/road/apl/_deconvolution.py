"""Kalman deconvolution of the APL signal (paper 000, §5), with the RTS smoother and ML tuning.

The instrument (any :class:`APLModel`) is realised as a cascade of second-order sections, the
road profile u gets a Wiener (random walk, eq. 7) or AR(1) model, and the augmented state
z_k = [x_k; u_k] (eqs. 9-12) is handed to the state-space engine. No filter loop lives here.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import linalg

from ..._validation import as_float_array, require_positive
from ...core import Profile
from ...errors import ConvergenceError, InputError, ModelError, NotDetectableError, ShapeError
from ...statespace import (
    StateSpaceModel,
    chunked_kalman_filter,
    filter_design,
    fixed_lag_smoother,
    kalman_filter,
    long_record_log_likelihood,
    long_record_smoother,
    rts_smoother,
    shared_covariance_smoother,
    sos_filtfilt,
)
from ._double_filter import double_filter
from ._gap_uncertainty import gap_error_variance
from ._instrument_uncertainty import InstrumentUncertainty, instrument_error_variance
from ._minimize import minimize_bounded
from ._model import APLModel, _check_profile_spacing
from ._short_waves import SHORT_WAVE_OPTIONS, RoadSpectrumRatio, estimate_road_spectrum_ratio, record_error_std

__all__ = [
    "instrument_state_space",
    "apl_deconvolution_model",
    "increment_deconvolution_model",
    "is_detectable",
    "detrend_profile",
    "fit_noise_variances",
    "NoiseFit",
    "smoother_error_std",
    "reconstruct_profile",
    "Reconstruction",
    "RECONSTRUCTION_METHODS",
    "default_fixed_lag",
    "FIXED_LAG_CORRELATION_LENGTH",
    "FIXED_LAG_TIME_CONSTANTS",
    "LONG_RECORD_SAMPLES",
]

#: Records longer than this many samples take the long-record path by default (``stationary=None``): exact
#: start, constant gains once converged, chunked, O(chunk) working memory. Both paths give the same profile.
LONG_RECORD_SAMPLES = 200_000
#: The coarse grid of :func:`fit_noise_variances` (which only brackets the optimum) is evaluated on at most this
#: many first samples.
GRID_SAMPLES = 1 << 15

RECONSTRUCTION_METHODS = ("smoother", "filter", "double", "fixed-lag")

#: Default AR(1) correlation length (m) of the road model for ``method="fixed-lag"`` (see docs/road-apl.md:
#: with the Wiener model the invisible quadratic of the triple zero at 1 is re-resolved at every sample and the
#: fixed-lag estimate converges only when the lag approaches the record length).
FIXED_LAG_CORRELATION_LENGTH = 2.0
#: Default lag of ``method="fixed-lag"``, in pendulum time constants (see :func:`default_fixed_lag`).
FIXED_LAG_TIME_CONSTANTS = 4.0
#: Impulse-response length of :func:`fixed_lag_error_std` with the record's road spectrum, samples: the default
#: 2^15 cuts the response of the AR(1) fixed-lag (closed-loop radius ~0.9998: ~4 % of its amplitude left 16 384
#: samples after the impulse), which matters where G H ~ 1 and the road is strong (long waves); 2^17 is converged
#: (the std of a Wiener road within 2e-10 relative of 2^18's).
FIXED_LAG_RECORD_FFT = 1 << 17
#: When the fixed-lag's printed std is calibrated, in detrending wavelengths of lag (named assumption, measured on two
#: configurations, docs/road-apl.md "The fixed-lag at 6 m/s"): at least FIXED_LAG_SHORT_LAGS; and where the trailer's
#: gain at half the detrending wavelength is below FIXED_LAG_LONG_WAVE_GAIN of its peak, at least
#: FIXED_LAG_CALIBRATED_LAGS. Table 1, 20 m/s (gain 0.98): lag 10 / 24 / 50 / 83 m -> 64 / 71 / 86 / 97 % coverage of the
#: 90 % band; 6 m/s (gain 0.13): 24 / 50 / 83 / 120 m -> 34 / 75 / 62 / 91 %.
FIXED_LAG_LONG_WAVE_GAIN = 0.5
FIXED_LAG_CALIBRATED_LAGS = 1.2
FIXED_LAG_SHORT_LAGS = 0.5


def default_fixed_lag(instrument: APLModel, *, n_time_constants: float = FIXED_LAG_TIME_CONSTANTS) -> float:
    """Default latency (m) of the fixed-lag reconstruction: a few pendulum time constants at the towing speed.

    Parameters
    ----------
    instrument : APLModel
        With ``dt`` and ``dx``. The pendulum is the complex pole pair of largest modulus (Table 1: |p1|
        = 0.9976 at 20 m/s, 5 cm); without complex poles, the slowest pole.
    n_time_constants : float
        Default 4 (measured error-vs-lag curve in docs/road-apl.md: about 3 % band error at 20 m/s).

    Returns
    -------
    float
        n_time_constants * tau * V in m, tau = -dt / ln|p1| (1.04 s at 20 m/s, 5 cm: 83 m).
    """
    if instrument.dx is None:
        raise InputError("the instrument has no spacing dx (bench model); give lag_m explicitly.")
    poles = np.asarray(instrument.poles)
    if not poles.size:
        raise InputError("the instrument has no poles; give lag_m explicitly.")
    cplx = poles[np.abs(poles.imag) > 1e-14]
    radius = float(np.abs(cplx if cplx.size else poles).max())
    tau = -instrument.dt / np.log(radius)
    speed = instrument.dx / instrument.dt
    return float(require_positive("n_time_constants", n_time_constants) * tau * speed)


def _minimal_sections(model: APLModel) -> list[tuple[np.ndarray, np.ndarray]]:
    """First/second-order sections (b, a) with exactly one state per pole (no dead-beat states).

    Complex pole pairs and pairs of real poles make 2nd-order sections, a last odd real pole a
    1st-order one; each section takes the unassigned zeros nearest its poles (at most its
    order), the sections closest to the unit circle first; the gain goes on the first section.
    ``scipy.signal.zpk2sos`` is not used here because it pads with poles at the origin, which
    would add unobservable dead-beat states (and a singular steady-state covariance).
    """
    poles = list(model.poles)
    groups = []
    cplx = sorted([p for p in poles if p.imag > 1e-14], key=lambda p: -abs(p))
    for p in cplx:
        groups.append([p, np.conj(p)])
    real = sorted([p.real for p in poles if abs(p.imag) <= 1e-14], key=lambda p: -abs(p))
    for i in range(0, len(real), 2):
        groups.append([complex(x) for x in real[i:i + 2]])
    groups.sort(key=lambda g: -max(abs(p) for p in g))
    zeros = list(model.zeros)
    sections = []
    for g in groups:
        chosen = []
        for _ in range(len(g)):
            if not zeros:
                break
            # prefer a conjugate-closed choice: take the nearest zero and, if complex, its conjugate
            i = int(np.argmin([min(abs(z - p) for p in g) for z in zeros]))
            z = zeros.pop(i)
            chosen.append(z)
            if abs(z.imag) > 1e-14:
                j = int(np.argmin([abs(w - np.conj(z)) for w in zeros]))
                chosen.append(zeros.pop(j))
            if len(chosen) >= len(g):
                break
        if len(chosen) > len(g):  # a complex pair did not fit a 1st-order section: put it back
            zeros.extend(chosen[len(g):])
            chosen = chosen[:len(g)]
        b = np.real(np.poly(chosen)) if chosen else np.array([1.0])
        a = np.real(np.poly(g))
        k = len(g)
        sections.append((np.pad(b, (0, k + 1 - b.size)), a))
    if zeros:
        raise ModelError("could not assign every zero to a section (more zeros than poles?).")
    if sections:
        sections[0] = (sections[0][0] * model.gain, sections[0][1])
    return sections


def instrument_state_space(model: APLModel) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A minimal, well-conditioned state-space realisation (A, B, C, D) of an instrument model.

    Each first- or second-order section b0 + b1 z^-1 (+ b2 z^-2) over 1 + a1 z^-1 (+ a2 z^-2) is
    realised in observer form (x1' = -a1 x1 + x2 + (b1 - a1 b0) v, x2' = -a2 x1 + (b2 - a2 b0) v,
    out = x1 + b0 v) and the sections are connected in series, after ``model.delay`` pure-delay
    states: n = order + delay states. The polynomial (companion) form of a 5th-order model with
    poles at 0.9976 is never formed.

    Returns
    -------
    A : (n, n) ndarray
    B : (n, 1) ndarray
    C : (1, n) ndarray
    D : (1, 1) ndarray
    """
    A = np.zeros((0, 0))
    B = np.zeros((0, 1))
    C = np.zeros((1, 0))
    D = np.ones((1, 1))
    blocks = []
    for _ in range(model.delay):
        blocks.append((np.zeros((1, 1)), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1))))
    if not model.poles.size:
        blocks.append((np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[model.gain]])))
    for b, a in _minimal_sections(model):
        if a.size == 2:
            b0, b1 = b
            a1 = a[1]
            blocks.append((np.array([[-a1]]), np.array([[b1 - a1 * b0]]), np.array([[1.0]]), np.array([[b0]])))
        else:
            b0, b1, b2 = b
            a1, a2 = a[1], a[2]
            blocks.append((np.array([[-a1, 1.0], [-a2, 0.0]]), np.array([[b1 - a1 * b0], [b2 - a2 * b0]]),
                           np.array([[1.0, 0.0]]), np.array([[b0]])))
    for A2, B2, C2, D2 in blocks:
        n1, n2 = A.shape[0], A2.shape[0]
        A = np.block([[A, np.zeros((n1, n2))], [B2 @ C, A2]])
        B = np.vstack([B, B2 @ D])
        C = np.hstack([D2 @ C, C2])
        D = D2 @ D
    return A, B, C, D


def _input_dynamics(input_model: str, dx: float, correlation_length: float | None) -> float:
    if input_model == "wiener":
        return 1.0
    if input_model == "ar1":
        if correlation_length is None:
            raise InputError("input_model='ar1' needs correlation_length (m), e.g. 500.")
        L = require_positive("correlation_length", correlation_length)
        return float(np.exp(-dx / L))
    raise InputError(f"input_model must be 'wiener' or 'ar1'; got {input_model!r}.")


def apl_deconvolution_model(instrument: APLModel, q: float, r: float, *, input_model: str = "wiener",
                            correlation_length: float | None = None, dx: float | None = None) -> StateSpaceModel:
    r"""The augmented state-space model of §5.1 (eqs. 9-12): instrument state plus road elevation.

    Parameters
    ----------
    instrument : APLModel
        The trailer model (eq. 1, or identified).
    q : float
        Variance of the elevation increment v_k per sample, m^2 (eq. 7).
    r : float
        Variance of the measurement noise e_k, in the signal's units squared (m^2).
    input_model : {"wiener", "ar1"}
        ``"wiener"`` (paper, eq. 7): u_{k+1} = u_k + v_k. ``"ar1"`` (§5.2, option 1):
        u_{k+1} = phi u_k + v_k with phi = exp(-dx / correlation_length), which makes the
        augmented pair detectable.
    correlation_length : float, optional
        For ``"ar1"``, m.
    dx : float, optional
        Spacing, m (default ``instrument.dx``; for a bench model without dx, give it).

    Returns
    -------
    StateSpaceModel
        State z_k = [x_k (n); u_k] (n + 1), observation y_k = C x_k + D u_k + e_k.
        Transition [[A, B], [0, phi]], process_cov diag(0, ..., 0, q), obs_cov [[r]].
        Prior: the elevation at the first sample is the reference (u_0 = 0 exactly: elevations
        are reported relative to the first station, since the APL cannot see a level) and the
        instrument state is at its stationary distribution around the steady state M u_0,
        M = (I - A)^{-1} B (see Notes).

    Notes
    -----
    Paper 000 augments with u_{k-1} and an instrument driven by u_{k-1}, then shifts the
    estimate by one sample; we augment with u_k itself (equivalent, no shift needed, and it
    also allows a direct feed-through D != 0 as in eq. 1).

    With the ``"wiener"`` input model and an instrument having an exact zero at z = 1 (eq. 1 has
    three), the integrator of the input cancels against a differentiator: the pair (F, H) is
    not detectable (§5.2) and no stationary Kalman filter exists (see :func:`is_detectable`).
    The time-varying filter and smoother still run. The initial instrument-state covariance is
    the stationary covariance of xi = x - M u, which obeys xi' = A xi - M v (solved by a discrete
    Lyapunov equation), for the Wiener model; for AR(1) the joint stationary covariance of
    [x; u] conditioned on u_0 = 0.
    """
    if not isinstance(instrument, APLModel):
        raise InputError(f"instrument must be an APLModel; got {type(instrument).__name__}.")
    if not instrument.is_stable:
        raise ModelError(f"the instrument model {instrument.name!r} is unstable (max |pole| = "
                         f"{np.abs(instrument.poles).max():.4f}); deconvolution needs a stable instrument.")
    q = require_positive("q", q)
    r = require_positive("r", r)
    h = dx if dx is not None else instrument.dx
    if h is None:
        raise InputError("the instrument has no spacing dx (bench model); pass dx=... in m.")
    h = require_positive("dx", h)
    phi = _input_dynamics(input_model, h, correlation_length)
    A, B, C, D = instrument_state_space(instrument)
    n = A.shape[0]
    F = np.block([[A, B], [np.zeros((1, n)), np.array([[phi]])]])
    H = np.hstack([C, D])
    Q = np.zeros((n + 1, n + 1))
    Q[n, n] = q
    M = np.linalg.solve(np.eye(n) - A, B)  # steady state of x per unit level
    # xi = x - M u obeys xi' = A xi + (A M + B - phi M) u - M v; for phi = 1 the u term vanishes.
    if phi == 1.0:
        Pxi = linalg.solve_discrete_lyapunov(A, q * (M @ M.T))
    else:
        # stationary joint covariance of [x; u], then condition on u = 0
        P = linalg.solve_discrete_lyapunov(F, Q)
        Pxi = P[:n, :n] - np.outer(P[:n, n], P[n, :n]) / P[n, n]
    P0 = np.zeros((n + 1, n + 1))
    P0[:n, :n] = 0.5 * (Pxi + Pxi.T)
    return StateSpaceModel(F, H, Q, np.array([[r]]), np.zeros(n + 1), P0)


def increment_deconvolution_model(instrument: APLModel, q: float, r: float, *, dx: float | None = None) -> StateSpaceModel:
    r"""The Wiener model of :func:`apl_deconvolution_model` in a detectable form: instrument state and elevation step.

    For an instrument with a zero at z = 1 (eq. 1 has three), the Wiener model (eq. 7) is not detectable and has
    no stationary Kalman filter (§5.2). It is rewritten here, exactly, with the deviation of the instrument state
    from its steady state, xi_k = x_k - M u_k (M = (I - A)^{-1} B), and the elevation increment
    v_{k-1} = u_k - u_{k-1}:

        xi_{k+1} = A xi_k - M v_k,    y_k = C xi_k + H(1) u_k + e_k,    H(1) = C M + D = 0,

    so the state s_k = [xi_k; v_{k-1}] (n + 1) has the transition [[A, 0], [0, 0]] (stable: the eigenvalues of
    A and 0), process noise q g g' with g = [-M; 1], and the observation [C, 0]. The elevation is recovered as
    u_k = sum_{j=1..k} s_j[n] (u_0 = 0, the reference), and E[u_k | y] is the same sum of E[s_j[n] | y]: the
    smoothed elevation of this model equals that of the Wiener model (linear estimation commutes with sums).
    The prior xi_0 ~ N(0, Pxi) is the one of :func:`apl_deconvolution_model`, so the two models give the same
    distribution of y and the same likelihood.

    Parameters
    ----------
    instrument : APLModel
        Stable, with H(1) = 0 to working precision (:class:`ModelError` otherwise: such an instrument's Wiener
        model is detectable and needs no rewriting).
    q, r, dx
        As :func:`apl_deconvolution_model`.

    Returns
    -------
    StateSpaceModel
        n + 1 states, one observation; the elevation increment is the last state.
    """
    q = require_positive("q", q)
    r = require_positive("r", r)
    h = dx if dx is not None else instrument.dx
    if h is None:
        raise InputError("the instrument has no spacing dx (bench model); pass dx=... in m.")
    require_positive("dx", h)
    if not instrument.is_stable:
        raise ModelError(f"the instrument model {instrument.name!r} is unstable; deconvolution needs a stable one.")
    A, B, C, D = instrument_state_space(instrument)
    n = A.shape[0]
    M = np.linalg.solve(np.eye(n) - A, B)
    dc = float((C @ M + D)[0, 0])
    if abs(dc) > 1e-9 * max(float(np.abs(M).max()), 1.0):
        raise ModelError(f"the instrument {instrument.name!r} has a static gain H(1) = {dc:.3g} (no zero at z = 1): "
                         "its Wiener model is detectable as it is; use apl_deconvolution_model.")
    F = np.zeros((n + 1, n + 1))
    F[:n, :n] = A
    g = np.vstack([-M, [[1.0]]])
    H = np.hstack([C, np.zeros((1, 1))])
    Pxi = linalg.solve_discrete_lyapunov(A, q * (M @ M.T))
    P0 = np.zeros((n + 1, n + 1))
    P0[:n, :n] = 0.5 * (Pxi + Pxi.T)
    return StateSpaceModel(F, H, q * (g @ g.T), np.array([[r]]), np.zeros(n + 1), P0)


def _long_record_model(instrument, q, r, input_model, correlation_length, dx):
    """The model the long-record path runs, and whether its last state is the elevation step (True) or the
    elevation itself (False)."""
    model = apl_deconvolution_model(instrument, q, r, input_model=input_model,
                                    correlation_length=correlation_length, dx=dx)
    if input_model == "wiener" and not is_detectable(model):
        return increment_deconvolution_model(instrument, q, r, dx=dx), True
    return model, False


def _elevation_from_last_state(last, increments: bool) -> np.ndarray:
    """u_k from the last state's estimates: itself, or the running sum of the steps (u_0 = 0)."""
    if not increments:
        return np.ascontiguousarray(last)
    u = np.empty_like(last)
    u[0] = 0.0
    np.cumsum(last[1:], out=u[1:])
    return u


def is_detectable(model: StateSpaceModel, *, tol: float = 1e-9) -> bool:
    """PBH test: every mode with |lambda| >= 1 of the transition is observable through H.

    A mode is declared unobservable when the smallest singular value of [lambda I - F; H],
    relative to the norm of F, is below ``tol``. Zeros "slightly off 1" (§5.2, option 2) pass
    this test, with a small margin that the returned boolean does not quantify.
    """
    F, H = np.asarray(model.transition), np.asarray(model.observation)
    if F.ndim != 2 or H.ndim != 2:
        raise ModelError("is_detectable needs a time-invariant model.")
    n = F.shape[0]
    scale = max(np.linalg.norm(F, 2), 1.0)
    for lam in np.linalg.eigvals(F):
        if abs(lam) < 1.0 - 1e-12:
            continue
        s = np.linalg.svd(np.vstack([lam * np.eye(n) - F, H]), compute_uv=False)
        if s[-1] < tol * scale:
            return False
    return True


def detrend_profile(elevation, dx: float, *, highpass_wavelength: float | None = 100.0, axis: int = 0) -> np.ndarray:
    """Remove what the APL cannot see: a degree-2 polynomial, then long waves by a zero-phase high-pass.

    Parameters
    ----------
    elevation : array_like
        Profile (relative elevations), m; detrended along ``axis``.
    dx : float
        Spacing, m.
    highpass_wavelength : float or None
        Cut-off wavelength, m (default 100). None: only the polynomial is removed.

    Returns
    -------
    ndarray, same shape

    Notes
    -----
    The triple differentiator of the APL makes any polynomial of degree <= 2 invisible
    (§5.2, "Limitations"), and its high-pass sections leave almost nothing of wavelengths much
    longer than V / 0.3 Hz (~ 67 m at 20 m/s). Step 1: least-squares removal of a quadratic in
    distance (exact for the invisible part, no end effects). Step 2: a 2nd-order Butterworth
    high-pass in second-order sections applied forward and backward (``sosfiltfilt``, zero phase,
    |G|^2 = 1 / (1 + (lambda / highpass_wavelength)^4)). At the default 100 m, the gain at 50 m
    (the long end of the roughness band 0.5-50 m) is 0.94 and at 25 m 0.996; waves of 200 m and
    longer are attenuated by > 94 %. Pads with odd reflection of 3 x the cut-off wavelength.
    """
    z = np.moveaxis(as_float_array("elevation", elevation, allow_nan=False), axis, 0)
    dx = require_positive("dx", dx)
    n = z.shape[0]
    if n < 3:
        raise ShapeError(f"detrending needs at least 3 samples; got {n}.")
    # least-squares quadratic in normalised distance s in [-1, 1], by 3x3 normal equations built from
    # running sums (O(1) extra memory: a Vandermonde matrix of a 2e7-sample record would take 480 MB)
    flat = z.reshape(n, -1)
    s = np.linspace(-1.0, 1.0, n)
    s2 = s * s
    G = np.array([[n, s.sum(), s2.sum()], [s.sum(), s2.sum(), s @ s2], [s2.sum(), s @ s2, s2 @ s2]])
    rhs = np.stack([flat.sum(axis=0), s @ flat, s2 @ flat])
    coef = np.linalg.solve(G, rhs)
    out = flat - coef[0]
    out -= np.outer(s, coef[1])
    out -= np.outer(s2, coef[2])
    del s, s2
    out = out.reshape(z.shape)
    if highpass_wavelength is not None:
        lam = require_positive("highpass_wavelength", highpass_wavelength)
        fc = 1.0 / lam
        if fc >= 0.5 / dx:
            raise InputError(f"highpass_wavelength {lam} m is shorter than 2 dx = {2 * dx} m.")
        sos = filter_design("butter", 2, fc, btype="highpass", fs=1.0 / dx, output="sos")
        padlen = min(n - 1, int(3 * lam / dx))
        out = sos_filtfilt(sos, out, padlen=padlen)
    return np.moveaxis(out, 0, axis)


@dataclass(frozen=True)
class NoiseFit:
    """Maximum-likelihood q and r of the deconvolution model.

    Attributes
    ----------
    q, r : float
        Estimates, m^2.
    log_likelihood : float
        Maximised log-likelihood.
    ratio_std_log10 : float
        Approximate standard error of log10(q / r) from the curvature of the profile likelihood.
    n_evaluations : int
        Number of filter runs.
    converged : bool
    """

    q: float
    r: float
    log_likelihood: float
    ratio_std_log10: float
    n_evaluations: int
    converged: bool


def _concentrated_ll(instrument, y, log10_ratio, input_model, correlation_length, dx, stationary, steps=None,
                     distance_steps=None):
    lam = 10.0 ** log10_ratio
    if steps is not None:  # a varying towing speed: one transition per step (engine's time-varying model)
        from ._varying_speed import varying_speed_model

        model = varying_speed_model(instrument, steps[:y.size - 1], lam, 1.0, input_model=input_model,
                                    correlation_length=correlation_length, dx=dx,
                                    distance_steps=None if distance_steps is None else distance_steps[:y.size - 1])
    elif stationary:
        model, _ = _long_record_model(instrument, lam, 1.0, input_model, correlation_length, dx)
        res = long_record_log_likelihood(model, y)
        r_hat = res.quadratic_form / res.n_observed
        ll = -0.5 * (res.n_observed * (np.log(2 * np.pi * r_hat) + 1.0) + res.log_det_sum)
        return float(ll), float(r_hat)
    else:
        model = apl_deconvolution_model(instrument, lam, 1.0, input_model=input_model,
                                        correlation_length=correlation_length, dx=dx)
    res = kalman_filter(model, y)
    obs = ~np.isnan(res.innovation[:, 0])
    e = res.innovation[obs, 0]
    s = res.innovation_cov[obs, 0, 0]
    nobs = e.size
    r_hat = float(np.mean(e * e / s))
    ll = -0.5 * (nobs * (np.log(2 * np.pi * r_hat) + 1.0) + np.sum(np.log(s)))
    return float(ll), r_hat


def fit_noise_variances(signal_, instrument: APLModel, *, input_model: str = "wiener",
                        correlation_length: float | None = None, dx: float | None = None,
                        bounds_log10_ratio: tuple[float, float] = (-8.0, 4.0), stationary: bool = False,
                        steps=None, distance_steps=None) -> NoiseFit:
    """Estimate q and r by maximum likelihood (prediction-error decomposition of the Kalman filter).

    Parameters
    ----------
    signal_ : (T,) array_like
        APL signal, m (NaN = missing sample).
    instrument : APLModel
    input_model, correlation_length, dx
        As in :func:`apl_deconvolution_model`.
    bounds_log10_ratio : (float, float)
        Search interval for log10(q / r).
    stationary : bool
        Use the long-record likelihood (:func:`longprofile.statespace.long_record_log_likelihood`: exact
        start, constant gain once converged, O(chunk) memory) on the detectable form of the model
        (:func:`increment_deconvolution_model` for the Wiener model of an instrument with a zero at 1); NaN
        samples are bridged by the exact filter. It equals the exact likelihood to round-off. Default False: the
        exact time-varying filter (NaN allowed).
    steps : (T-1,) array_like, optional
        A record towed at a varying speed: the duration of each step between stations, s
        (:func:`station_steps`); the likelihood is then that of :func:`varying_speed_model` (the instrument
        re-discretised at every step), with the exact filter (``stationary`` must be False). Default None: the
        instrument at its own step throughout.
    distance_steps : (T-1,) array_like, optional
        With ``steps``, a record sampled in time: the distance of each step in stations
        (:func:`varying_speed_model`).

    Returns
    -------
    NoiseFit

    Raises
    ------
    ConvergenceError
        If the likelihood cannot be evaluated anywhere in the interval. An optimum on a bound is
        not an error here but is flagged (``converged`` False); :func:`reconstruct_profile` raises
        :class:`ConvergenceError` for it.

    Notes
    -----
    With u_0 fixed and the instrument-state prior proportional to q, every covariance of the
    model scales with r for a fixed ratio q / r, so r is concentrated out in closed form
    (r_hat = mean of e_k^2 / s_k over the innovations of the r = 1 filter) and only log10(q / r)
    is searched: a 13-point grid over ``bounds_log10_ratio`` brackets the optimum (on the first
    ``GRID_SAMPLES`` (32 768) samples of a longer record, with the bracket widened until the whole record's
    optimum is strictly inside it), then a bounded scalar minimisation (Brent 1973, ch. 5; xatol 1e-3) on the
    whole record (each ratio evaluated once: the optimum's likelihood is not recomputed). This replaces
    the paper's hand tuning (§5.3, q = 10 or 100 with r = 1).
    """
    y = as_float_array("signal", signal_, ndim=1)
    if steps is not None:
        steps = as_float_array("steps", steps, ndim=1, allow_nan=False)
        if steps.size != y.size - 1 or stationary:
            raise InputError(f"steps needs T - 1 = {y.size - 1} durations (got {steps.size}) and stationary=False.")
    lo, hi = bounds_log10_ratio
    count = [0]
    whole = {}  # log10 ratio -> (log-likelihood, r_hat) on the whole record

    def neg(t, data=y):
        t = float(t)
        if data is y and t in whole:
            return -whole[t][0]
        count[0] += 1
        try:
            ll_r = _concentrated_ll(instrument, data, t, input_model, correlation_length, dx, stationary, steps,
                                    distance_steps)
        except NotDetectableError:
            # the Riccati equation is numerically unsolvable at this extreme ratio: treat it as infeasible
            return np.inf
        if data is y:
            whole[t] = ll_r
        return -ll_r[0]

    grid = np.linspace(lo, hi, 13)
    # the coarse grid only brackets the optimum: on a long record it is evaluated on the first GRID_SAMPLES
    # samples (whatever the path, so both paths fit the same q, r); the bracket is widened until the whole
    # record's optimum lies strictly inside it
    vals = np.array([neg(t, y[:GRID_SAMPLES]) for t in grid])
    if not np.isfinite(vals).any():
        raise ConvergenceError("the likelihood could not be evaluated at any q/r ratio in the search interval.")
    i = int(np.argmin(vals))
    ia, ib = max(i - 1, 0), min(i + 1, grid.size - 1)
    while True:
        a, b = grid[ia], grid[ib]
        res = minimize_bounded(neg, a, b, xatol=1e-3)  # Brent 1973; not scipy.optimize (start-up, issue 12)
        t = float(res.x)
        widen_lo = ia > 0 and t - a < 0.01
        widen_hi = ib < grid.size - 1 and b - t < 0.01
        if y.size <= GRID_SAMPLES or not (widen_lo or widen_hi):
            break
        ia, ib = ia - widen_lo, ib + widen_hi
    if neg(t) == np.inf:
        raise ConvergenceError(f"the likelihood cannot be evaluated at the optimum q/r = 10^{t:.3f} of the whole record.")
    ll, r_hat = whole[t]
    h = 0.05
    curv = (neg(t + h) - 2 * (-ll) + neg(t - h)) / h ** 2
    std = float(1.0 / np.sqrt(curv)) if curv > 0 else float("inf")
    on_bound = (t - lo) < 0.01 or (hi - t) < 0.01
    return NoiseFit(q=r_hat * 10.0 ** t, r=r_hat, log_likelihood=ll, ratio_std_log10=std,
                    n_evaluations=count[0] + 1, converged=bool(res.success and not on_bound))


def smoother_error_std(instrument: APLModel, q: float, r: float, *, band: tuple[float, float] | None = None,
                       input_model: str = "wiener", correlation_length: float | None = None,
                       dx: float | None = None, highpass_wavelength: float | None = None,
                       n_points: int = 200_001, road_ratio: RoadSpectrumRatio | None = None) -> float:
    r"""Stationary posterior std of the smoothed elevation error in a waveband (spectral formula).

    Parameters
    ----------
    band : (float, float), optional
        Wavelength band (shortest, longest), m; the error is band-passed by a sharp (ideal) filter.
    highpass_wavelength : float, optional
        Alternatively, the error seen through :func:`detrend_profile`'s high-pass.
    road_ratio : RoadSpectrumRatio, optional
        The road's spectrum relative to the model's, estimated from the record
        (:func:`estimate_road_spectrum_ratio`): the error of the same smoother under the road c(w) S_u(w) instead of
        S_u, |G H - 1|^2 c S_u + |G|^2 r with G = conj(H) S_u / (|H|^2 S_u + r) (equal to the formula below for
        c = 1). Default None: the model's own road, as before.

    Returns
    -------
    float
        m.

    Notes
    -----
    Away from the ends of a record the fixed-interval smoother is the non-causal Wiener
    smoother, whose error spectrum is S_err = S_u r / (r + |H|^2 S_u) with
    S_u(w) = q / |1 - phi e^{-jw}|^2; the returned value is sqrt((1/pi) int_0^pi W(w) S_err dw)
    with W the band's power response.
    """
    h = dx if dx is not None else instrument.dx
    h = require_positive("dx", h)
    phi = _input_dynamics(input_model, h, correlation_length)
    w = np.linspace(0.0, np.pi, int(n_points))[1:]
    Hm = np.abs(instrument.response_at(w / (2 * np.pi * instrument.dt))) ** 2
    Su = q / np.abs(1.0 - phi * np.exp(-1j * w)) ** 2
    W = _error_weight(w, h, band, highpass_wavelength)
    if road_ratio is not None:
        H = instrument.response_at(w / (2 * np.pi * instrument.dt))
        return record_error_std(np.conj(H) * Su / (Hm * Su + r), H, Su, r, W, w, road_ratio)[0]
    Serr = Su * r / (r + Hm * Su)
    return float(np.sqrt(np.trapezoid(W * Serr, w) / np.pi))


def _error_weight(w, h, band, highpass_wavelength):
    """Power response applied to the error: a sharp waveband and/or :func:`detrend_profile`'s high-pass."""
    n_cyc = w / (2 * np.pi * h)  # cycles per m
    W = np.ones_like(w)
    if band is not None:
        lo, hi = band
        W = ((n_cyc >= 1.0 / hi) & (n_cyc <= 1.0 / lo)).astype(float)
    if highpass_wavelength is not None:
        fc = 1.0 / highpass_wavelength
        W = W * (1.0 / (1.0 + (fc / n_cyc) ** 4)) ** 2
    return W


def fixed_lag_error_std(instrument: APLModel, q: float, r: float, lag_m: float, *,
                        correlation_length: float | None = None, dx: float | None = None,
                        highpass_wavelength: float | None = 100.0, band: tuple[float, float] | None = None,
                        n_fft: int = 1 << 15, road_ratio: RoadSpectrumRatio | None = None,
                        noise_variance: float | None = None, road_spectrum=None) -> float:
    r"""Stationary std of the fixed-lag estimate's error, seen through the detrending (or a waveband), m.

    In steady state the fixed-lag smoother of ``reconstruct_profile(method="fixed-lag")`` is a linear filter
    u_hat = G y (E[u_k | y_0..k+L]), measured here as its response to an impulse. With y = H u + v and the
    model's own road (AR(1): S_u = q / |1 - phi e^{-jw}|^2, white noise r) the error spectrum is

    .. math::  S_e(w) = |G(w) H(w) - 1|^2 S_u(w) + |G(w)|^2 r,

    and its power through :func:`detrend_profile`'s high-pass (``W``, as in :func:`smoother_error_std`) gives the
    std, sqrt((1/pi) int_0^pi W S_e dw). The per-sample posterior variance of the fixed-lag smoother is that of
    the *undetrended* estimate (``raw_std``), dominated by waves the detrending removes. Measured coverage of the
    90 % band (``benchmarks road_calibration``; a Wiener road: 88-91 %; ISO 8608 roads of classes A-E: 96-98 %,
    whose generator has no waves shorter than ~0.3 m that the model expects) is in docs/road-apl.md. Valid away
    from the record's ends (a stationary estimate). With ``road_ratio`` (the road the record shows,
    ``reconstruct_profile``'s default since 2026-12-06) pass ``n_fft`` >= 2^17: the AR(1) fixed-lag's response
    decays slowly and 2^15 samples cut it, over-stating the long-wave error (docs/road-apl.md, "Short waves from the
    record"); the default 2^15 is kept for the output of before.

    Parameters
    ----------
    lag_m : float
        Latency of the smoother, m (rounded to whole samples).
    correlation_length : float, optional
        Of the AR(1) model the smoother ran with (default ``FIXED_LAG_CORRELATION_LENGTH``).
    n_fft : int
        Impulse-response length, samples (the frequency grid).
    road_ratio : RoadSpectrumRatio, optional
        The road's spectrum relative to the AR(1) model's, estimated from the record
        (:func:`estimate_road_spectrum_ratio`): S_u is replaced by c(w) S_u in S_e. Default None: the model's road.
    noise_variance : float, optional
        The white-noise variance of the record in the |G|^2 term, m^2, when it is not the r the estimator was built
        with (the fixed-lag's G is always that of (q, r)). Default None: r.
    road_spectrum : callable, optional
        w (rad/sample) -> the road's spectrum S_road(w), m^2, in place of the model's (e.g. paper 000's Wiener road,
        eq. 7, q_W / |1 - e^{-jw}|^2); not with ``road_ratio``. Default None.

    Notes
    -----
    ``reconstruct_profile`` passes ``noise_variance`` and ``road_spectrum`` when the record's noise check on the
    fixed-lag's own AR(1) fit fails (docs/road-apl.md, "The fixed-lag's std when its own fit fails the noise check").
    """
    if road_ratio is not None and road_spectrum is not None:
        raise InputError("give road_ratio or road_spectrum, not both.")
    h = require_positive("dx", dx if dx is not None else instrument.dx)
    lag = int(round(require_positive("lag_m", lag_m, strict=False) / h))
    ell = FIXED_LAG_CORRELATION_LENGTH if correlation_length is None else correlation_length
    model = apl_deconvolution_model(instrument, q, r, input_model="ar1", correlation_length=ell, dx=h)
    stationary = is_detectable(model)
    j = n_fft // 2
    impulse = np.zeros(n_fft)
    impulse[j] = 1.0
    g = (fixed_lag_smoother(model, impulse, lag, stationary=stationary, states=[-1]).mean[:, 0]
         - fixed_lag_smoother(model, np.zeros(n_fft), lag, stationary=stationary, states=[-1]).mean[:, 0])
    w = 2 * np.pi * np.arange(1, n_fft // 2 + 1) / n_fft
    G = np.exp(1j * w * j) * np.fft.rfft(g)[1:]  # u_hat_k = sum_m g[j - k + ...]: G(w) = sum_m g_m e^{jwm}
    H = instrument.response_at(w / (2 * np.pi * instrument.dt))
    Su = q / np.abs(1.0 - _input_dynamics("ar1", h, ell) * np.exp(-1j * w)) ** 2
    W = _error_weight(w, h, band, highpass_wavelength)
    noise = r if noise_variance is None else require_positive("noise_variance", noise_variance)
    if road_ratio is not None:
        return record_error_std(G, H, Su, noise, W, w, road_ratio)[0]
    road = Su if road_spectrum is None else np.asarray(road_spectrum(w), dtype=float)
    Se = np.abs(G * H - 1.0) ** 2 * road + np.abs(G) ** 2 * noise
    return float(np.sqrt(np.trapezoid(W * Se, w) / np.pi))


@dataclass(frozen=True, eq=False)
class Reconstruction:
    """A road profile reconstructed from an APL signal.

    Attributes
    ----------
    profile : Profile
        The reconstructed elevation after :func:`detrend_profile` (what the APL can see), m;
        ``profile.std`` is the stationary posterior std of that detrended elevation, with the declared
        instrument uncertainty and, in and around gaps, the variance the gaps add (None for ``"double"``
        and ``"filter"``).
    raw_elevation : (T,) ndarray
        The estimate before detrending (relative to the first station), m.
    raw_std : (T,) ndarray or None
        Per-sample posterior std of ``raw_elevation`` from the filter or smoother (grows with
        distance: it includes the long waves the trailer cannot see), m.
    method : str
        ``"smoother"``, ``"filter"`` or ``"double"``.
    q, r : float or None
        Noise variances used, m^2 (None for ``"double"``).
    noise_fit : NoiseFit or None
        The ML fit, when q and r were estimated.
    input_model : str or None
    highpass_wavelength : float or None
    lag_m : float or None
        ``"fixed-lag"`` only: the latency used, m (``raw_elevation[k]`` uses the signal up to
        distance[k] + lag_m).
    correlation_length : float or None
        AR(1) correlation length used, m (None for the Wiener model).
    instrument_uncertainty : InstrumentUncertainty or None
        The declared instrument uncertainty included in ``profile.std`` (None: not included).
    instrument_std : (T,) ndarray or None
        Its part of ``profile.std`` alone, m (``profile.std``^2 = posterior std^2 + instrument_std^2; None
        without an instrument uncertainty).
    road_spectrum : RoadSpectrumRatio or None
        The road's spectrum relative to the model's as estimated from the record, which ``profile.std`` was computed
        under (``short_waves="record"``); None: the model's own spectrum.
    warnings : tuple of str
        What the caller should know about the printed std (e.g. :func:`fixed_lag_calibration_warning`).
    speed_range : (float, float, float) or None
        A record towed at a varying speed (:func:`reconstruct_varying_speed`): the slowest, median and fastest speed
        of its stations, m/s, at which the instrument was re-discretised; None: one speed (the instrument's).
    std_noise_fit : NoiseFit or None
        ``"fixed-lag"`` with ``short_waves="record"`` only: when the record's noise check fails on the fixed-lag's own
        AR(1) fit, the fit of paper 000's Wiener model (eq. 7) whose r (and, when that r passes the check, the road
        the record shows) ``profile.std`` was computed under (:func:`_fixed_lag_record_std`); None otherwise.
    """

    profile: Profile
    raw_elevation: np.ndarray
    raw_std: np.ndarray | None
    method: str
    q: float | None
    r: float | None
    noise_fit: NoiseFit | None
    input_model: str | None
    highpass_wavelength: float | None
    lag_m: float | None = None
    correlation_length: float | None = None
    instrument_uncertainty: InstrumentUncertainty | None = None
    instrument_std: np.ndarray | None = None
    road_spectrum: RoadSpectrumRatio | None = None
    warnings: tuple[str, ...] = ()
    std_noise_fit: NoiseFit | None = None
    speed_range: tuple | None = None

    def to_frame(self):
        """The ``road reconstruct`` table: ``distance_m, elevation_m, std_m, raw_m, raw_std_m`` (NaN where a std
        was not computed)."""
        import pandas as pd

        nan = np.full(self.profile.n_samples, np.nan)
        std = self.profile.std
        return pd.DataFrame(dict(distance_m=self.profile.distance, elevation_m=self.profile.elevation[:, 0],
                                 std_m=nan if std is None else std[:, 0], raw_m=self.raw_elevation,
                                 raw_std_m=nan if self.raw_std is None else self.raw_std))

    def to_profile(self, name: str | None = None) -> Profile:
        """The reconstructed (detrended) elevation as a one-track Profile ``elevation`` (what ``road reconstruct``
        writes to ERD; no std). ``name`` defaults to ``profile.name``."""
        return Profile(self.profile.distance, self.profile.elevation[:, 0], tracks=("elevation",),
                       name=self.profile.name if name is None else name)


def _signal_of(signal_, instrument):
    if isinstance(signal_, Profile):
        dx = _check_profile_spacing(signal_, instrument)
        if signal_.elevation.shape[1] != 1:
            raise ShapeError(f"reconstruct one track at a time; the signal has tracks {list(signal_.tracks)}.")
        return signal_.elevation[:, 0], dx, signal_.distance, signal_.name
    y = as_float_array("signal", signal_, ndim=1)
    if instrument.dx is None:
        raise InputError("a bare array needs an instrument with a spacing dx; pass a Profile or build the model "
                         "with apl_model(speed, dx).")
    return y, instrument.dx, np.arange(y.size) * instrument.dx, ""


def reconstruct_profile(signal_, instrument: APLModel, *, method: str = "smoother", q: float | None = None,
                        r: float | None = None, input_model: str | None = None,
                        correlation_length: float | None = None, highpass_wavelength: float | None = 100.0,
                        min_length: float | None = None, stationary: bool | None = None,
                        lag_m: float | None = None,
                        instrument_uncertainty: InstrumentUncertainty | str | None = None,
                        short_waves: str | None = None) -> Reconstruction:
    """Reconstruct the road profile from an APL signal.

    Parameters
    ----------
    signal_ : Profile or (T,) array_like
        The APL signal, m, at the instrument's spacing. NaN samples are missing and are bridged
        by the Kalman methods (the posterior std grows there); ``"double"`` refuses them.
    instrument : APLModel
        Trailer model (eq. 1 via :func:`apl_model`, or identified).
    method : {"smoother", "filter", "double", "fixed-lag"}
        RTS smoother (offline, default), causal Kalman filter (the paper's §5), the paper's
        double filtering (§3), or the fixed-lag smoother E[u_k | y_0..k+lag] (real time with a
        constant latency of ``lag_m``; :func:`longprofile.statespace.fixed_lag_smoother`).
    q, r : float, optional
        Elevation-increment and noise variances, m^2; both None (default) -> maximum likelihood
        (:func:`fit_noise_variances`); give both or neither.
    input_model, correlation_length
        Road model, see :func:`apl_deconvolution_model`. Default (None): ``"wiener"`` for the
        smoother and the filter; ``"ar1"`` with ``correlation_length`` = FIXED_LAG_CORRELATION_LENGTH
        (2 m) for ``"fixed-lag"`` (also when ``"ar1"`` is given without a correlation length).
    highpass_wavelength : float or None
        Detrending cut-off, m (see :func:`detrend_profile`).
    min_length : float, optional
        Shortest accepted record, m (default: one highpass_wavelength, and at least 200 samples).
    stationary : bool or None
        True: the long-record path — exact start, constant gains once the filter has converged, chunked
        (:func:`longprofile.statespace.long_record_smoother`; O(chunk) working memory; NaN samples bridged by
        the exact filter and smoother, which take over around each gap until the gains are stationary again), on the
        detectable form of the model (:func:`increment_deconvolution_model` for the Wiener model of an
        instrument with a zero at 1); the causal ``"filter"`` runs the exact filter in chunks
        (:func:`longprofile.statespace.chunked_kalman_filter`). False: exact time-varying filter/RTS smoother
        with per-sample covariances (O(T n^2) memory, NaN bridged). None (default): the long-record path
        above LONG_RECORD_SAMPLES (200 000) samples. Both paths give the same profile (to round-off, with or
        without gaps) and work with the same models; only ``raw_std`` differs (None on the long-record smoother
        path). ``"fixed-lag"`` on the long-record path needs a complete signal (refused otherwise).
    lag_m : float, optional
        ``"fixed-lag"`` only: latency, m (rounded to whole samples; 0 = the filter). Default: the longer of
        :func:`default_fixed_lag` (4 pendulum time constants: 83 m, 4.2 s at 20 m/s) and
        :func:`fixed_lag_calibrated_lag` (the shortest lag measured with a calibrated std: 50 m, or 120 m where the
        trailer barely sees 50 m waves, e.g. Table 1 at 6 m/s, 20 s). A shorter lag gets a warning
        (``Reconstruction.warnings``).
    instrument_uncertainty : InstrumentUncertainty or str, optional
        The declared relative 1-sigma of the trailer model's natural frequencies and gain (a string is read by
        :meth:`InstrumentUncertainty.parse`, e.g. ``"freq=0.115,gain=0.029"``). ``"smoother"`` and
        ``"fixed-lag"`` with a ``highpass_wavelength`` only (the methods that print ``profile.std``): the
        reconstruction is rerun once per uncertain parameter with that parameter perturbed by its sigma (same
        q, r, latency) and the square of the change of the detrended estimate (per sample, or averaged over
        ``window_m``) is added to the variance (:func:`instrument_error_variance`; assumptions: linearisation,
        independent parameters; docs/road-apl.md "Calibration" for the measured coverage). Default None:
        the std is the posterior std alone, as before.
    short_waves : {"record", "prior"} or None
        The road spectrum the printed std (``profile.std``, ``"smoother"`` and ``"fixed-lag"``) is computed under.
        ``"record"``: the model's spectrum scaled by the ratio the record shows where the trailer resolves the road,
        continued beyond (:func:`estimate_road_spectrum_ratio`; the estimate is in ``Reconstruction.road_spectrum``).
        ``"prior"``: the model's own spectrum at every wavenumber (the printed std before 2026-12-06: for the
        smoother about twice the error on roads without waves shorter than the APL resolves; the fixed-lag's also
        with its impulse response cut at 2^15 samples, kept so that ``"prior"`` gives the output of before). Default
        None: ``"record"`` (since 2026-12-06; docs/road-apl.md, "Short waves from the record"). For ``"fixed-lag"``,
        when the record's noise check rejects its AR(1) fit or the given r (a drifting sensor, red noise), the std is
        computed under the noise of paper 000's Wiener model fitted to the record (``Reconstruction.std_noise_fit``;
        docs/road-apl.md, "The fixed-lag's std when its own fit fails the noise check").

    Returns
    -------
    Reconstruction

    Raises
    ------
    InputError
        Unknown method, too short a record, q without r, NaN with ``"double"``, an invalid instrument
        uncertainty or one with a method that prints no std.
    UnitsError
        Signal spacing differs from the instrument's dx.
    ConvergenceError
        The ML estimate of q/r lies on its search bound.

    Notes
    -----
    On the long-record path the smoother's ``raw_std`` is None (the per-sample std of the undetrended
    elevation grows without bound with the Wiener model and would need the cross-covariances of all the
    increments); ``profile.std``, the std of what the user gets, is the same on both paths. ``"fixed-lag"`` returns
    the per-sample fixed-lag posterior std of the undetrended estimate in ``raw_std`` and, in ``profile.std``, the
    stationary std of the detrended estimate's error (:func:`fixed_lag_error_std`); its ``profile`` is detrended
    like the others, which is an offline (zero-phase) step: the real-time output is ``raw_elevation``.
    """
    if method not in RECONSTRUCTION_METHODS:
        raise InputError(f"method must be one of {RECONSTRUCTION_METHODS}; got {method!r}.")
    if short_waves is None:
        short_waves = "record"
    if short_waves not in SHORT_WAVE_OPTIONS:
        raise InputError(f"short_waves must be one of {SHORT_WAVE_OPTIONS}; got {short_waves!r}.")
    if lag_m is not None and method != "fixed-lag":
        raise InputError(f"lag_m applies to method='fixed-lag' only; got method={method!r} with lag_m={lag_m}.")
    if input_model is None:
        input_model = "ar1" if method == "fixed-lag" else "wiener"
    if method == "fixed-lag" and input_model == "ar1" and correlation_length is None:
        correlation_length = FIXED_LAG_CORRELATION_LENGTH
    uncertainty = _instrument_uncertainty_of(instrument_uncertainty, method, highpass_wavelength)
    y, dx, distance, name = _signal_of(signal_, instrument)
    if method == "fixed-lag":
        lag_m = _fixed_lag_latency(instrument, lag_m, highpass_wavelength)
    _check_record(y, dx, min_length, highpass_wavelength)
    run = _Run(instrument=instrument, method=method, y=y, dx=dx, distance=distance, name=name,
               input_model=input_model, correlation_length=correlation_length,
               highpass_wavelength=highpass_wavelength, lag_m=lag_m, uncertainty=uncertainty,
               short_waves=short_waves)
    if method == "double":
        return _reconstruct_double(run)
    return _reconstruct_kalman(run, q, r, stationary)


# -- reconstruct_profile in named stages: checks, then one function per method (dispatch table) ----------------


@dataclass(frozen=True, eq=False)
class _Run:
    """What every reconstruction method needs: the instrument, the record and the resolved options."""

    instrument: APLModel
    method: str
    y: np.ndarray
    dx: float
    distance: np.ndarray
    name: str
    input_model: str
    correlation_length: float | None
    highpass_wavelength: float | None
    lag_m: float | None
    uncertainty: InstrumentUncertainty | None = None
    short_waves: str = "prior"


def _instrument_uncertainty_of(value, method: str, highpass_wavelength) -> InstrumentUncertainty | None:
    """The checked ``instrument_uncertainty`` of :func:`reconstruct_profile` (None when not given)."""
    if value is None:
        return None
    if isinstance(value, str):
        value = InstrumentUncertainty.parse(value)
    elif not isinstance(value, InstrumentUncertainty):
        raise InputError(f"instrument_uncertainty must be an InstrumentUncertainty or a string like "
                         f"'freq=0.115,gain=0.029'; got {type(value).__name__}.")
    if method not in ("smoother", "fixed-lag") or highpass_wavelength is None:
        raise InputError(f"instrument_uncertainty enters the printed std, which method='smoother' and 'fixed-lag' "
                         f"with a highpass_wavelength print; got method={method!r}, "
                         f"highpass_wavelength={highpass_wavelength}.")
    return value


def _fixed_lag_latency(instrument: APLModel, lag_m: float | None, highpass_wavelength: float | None) -> float:
    """The fixed-lag latency, m: the checked ``lag_m``, or by default the longer of :func:`default_fixed_lag` and
    :func:`fixed_lag_calibrated_lag` (so that the default's printed std is one measured calibrated)."""
    if lag_m is None:
        lag_m = max(default_fixed_lag(instrument), fixed_lag_calibrated_lag(instrument, highpass_wavelength)[0])
    elif not np.isfinite(lag_m) or lag_m < 0:
        raise InputError(f"lag_m must be a finite latency >= 0 m; got {lag_m}.")
    return float(lag_m)


def _check_record(y: np.ndarray, dx: float, min_length: float | None, highpass_wavelength: float | None) -> None:
    """Refuse a record shorter than ``min_length`` (default one high-pass wavelength, >= 200 samples) or all NaN."""
    n_min = 200
    if min_length is None and highpass_wavelength is not None:
        n_min = max(n_min, int(np.ceil(highpass_wavelength / dx)))
    elif min_length is not None:
        n_min = int(np.ceil(require_positive("min_length", min_length) / dx))
    if y.size < n_min:
        raise InputError(f"the signal has {y.size} samples ({y.size * dx:g} m); need at least {n_min} "
                         f"({n_min * dx:g} m) for a reconstruction with highpass_wavelength={highpass_wavelength} m.")
    if np.all(np.isnan(y)):
        raise InputError("the signal is entirely missing (NaN).")


def _reconstruct_double(run: _Run) -> Reconstruction:
    """``method="double"``: the paper's zero-phase double filtering (§3), no noise model."""
    y = run.y
    if np.isnan(y).any():
        raise InputError(f"the signal has {int(np.isnan(y).sum())} missing sample(s); double filtering needs "
                         "a continuous record: cut it at the gaps, or use the smoother (--method smoother; it bridges "
                         "gaps in records of any length).")
    raw = double_filter(y, run.instrument)
    prof = Profile(run.distance, detrend_profile(raw, run.dx, highpass_wavelength=run.highpass_wavelength),
                   name=f"double-filtered {run.name}".strip())
    return Reconstruction(profile=prof, raw_elevation=raw, raw_std=None, method=run.method, q=None, r=None,
                          noise_fit=None, input_model=None, highpass_wavelength=run.highpass_wavelength)


def _noise_variances(run: _Run, q, r, stationary: bool) -> tuple[float, float, NoiseFit | None]:
    """(q, r, fit): the given variances, or their maximum-likelihood estimate (:func:`fit_noise_variances`)."""
    if q is not None:
        return q, r, None
    fit = fit_noise_variances(run.y, run.instrument, input_model=run.input_model,
                              correlation_length=run.correlation_length, dx=run.dx, stationary=stationary)
    if not fit.converged:
        raise ConvergenceError(f"the ML estimate of q/r hit its search bound (q = {fit.q:.3g}, r = {fit.r:.3g} "
                               "m^2); the signal may not match the instrument model. Give q and r explicitly.")
    return fit.q, fit.r, fit


def _fixed_lag_pass(run: _Run, model: StateSpaceModel, q, r, stationary: bool):
    """``"fixed-lag"``: E[u_k | y_0..k+lag] and its variance (any record length)."""
    lag = int(round(run.lag_m / run.dx))
    # a stationary fixed-lag smoother needs a detectable model; the Wiener model of an instrument with a
    # zero at 1 runs with the exact gains (its elevation is not a running sum of fixed-lag increments)
    fl = fixed_lag_smoother(model, run.y, lag, stationary=bool(stationary and is_detectable(model)), states=[-1])
    return fl.mean[:, 0], fl.cov[:, 0, 0], lag * run.dx


def _filter_pass(run: _Run, model: StateSpaceModel, q, r, stationary: bool):
    """``"filter"``: the causal Kalman filter (exact; in chunks on the long-record path)."""
    if stationary:
        # the causal estimate of u_k is not a running sum of causal increment estimates: the exact filter of
        # the model as it is, in chunks (O(chunk n^2) memory), whatever its detectability
        res = chunked_kalman_filter(model, run.y, states=[-1])
        return res.mean[:, 0], res.var[:, 0], None
    filt = kalman_filter(model, run.y)
    return filt.mean[:, -1], filt.cov[:, -1, -1], None


def _smoother_pass(run: _Run, model: StateSpaceModel, q, r, stationary: bool):
    """``"smoother"``: the RTS smoother, or the long-record smoother on the detectable form of the model."""
    if stationary:
        lr_model, increments = _long_record_model(run.instrument, q, r, run.input_model, run.correlation_length,
                                                  run.dx)
        mean = _elevation_from_last_state(long_record_smoother(lr_model, run.y, states=[-1]).mean[:, 0], increments)
        return mean, None, None
    filt = kalman_filter(model, run.y)
    sm = rts_smoother(model, filt)
    return sm.mean[:, -1], sm.cov[:, -1, -1], None


#: The state-space passes of :func:`reconstruct_profile` by method: ``(run, model, q, r, stationary) ->
#: (mean, variance or None, fixed-lag latency in m or None)``.
_KALMAN_PASSES = {"smoother": _smoother_pass, "filter": _filter_pass, "fixed-lag": _fixed_lag_pass}


def _kalman_estimate(run: _Run, q, r, stationary: bool):
    """The augmented model and the method's pass: (mean, variance or None, latency or None, detrended mean)."""
    model = apl_deconvolution_model(run.instrument, q, r, input_model=run.input_model,
                                    correlation_length=run.correlation_length, dx=run.dx)
    mean, cov, lag_m = _KALMAN_PASSES[run.method](run, model, q, r, stationary)
    return mean, cov, lag_m, detrend_profile(mean, run.dx, highpass_wavelength=run.highpass_wavelength)


def _instrument_std(run: _Run, q, r, stationary: bool, elevation: np.ndarray) -> np.ndarray | None:
    """Per-sample std (m) of the error the declared instrument uncertainty causes: the same estimate
    (:func:`_kalman_estimate`, same q, r and latency) rerun with each parameter perturbed
    (:func:`instrument_error_variance`). None without an uncertainty."""
    if run.uncertainty is None:
        return None

    def rerun(instrument: APLModel) -> np.ndarray:
        return _kalman_estimate(replace(run, instrument=instrument, uncertainty=None), q, r, stationary)[3]

    var = instrument_error_variance(run.instrument, run.uncertainty, elevation, rerun, run.dx)
    return None if var is None else np.sqrt(var)


def fixed_lag_calibrated_lag(instrument: APLModel, highpass_wavelength: float | None) -> tuple[float, float]:
    """The shortest lag (m) at which the fixed-lag's printed std was measured calibrated, and the trailer's gain.

    The printed std of the fixed-lag comes from its AR(1) road model, which has little power at long waves; the
    error at those waves shrinks only with about a wavelength of look-ahead, the more so where the trailer barely
    sees them. Returns (FIXED_LAG_SHORT_LAGS x the detrending wavelength, or FIXED_LAG_CALIBRATED_LAGS x it where the
    trailer's gain at half the detrending wavelength -- the long end of the 0.5-50 m roughness band at the default
    100 m -- is below FIXED_LAG_LONG_WAVE_GAIN of its peak; that gain). (0, nan) without detrending or spacing. A
    named assumption from two configurations (docs/road-apl.md, "The fixed-lag at 6 m/s").
    """
    if highpass_wavelength is None or instrument.dx is None:
        return 0.0, float("nan")
    speed = instrument.dx / instrument.dt
    grid = np.geomspace(1e-3, 0.5 / instrument.dt, 2000)
    gain = float(np.abs(instrument.response_at(speed / (highpass_wavelength / 2)))
                 / np.abs(instrument.response_at(grid)).max())
    lags = FIXED_LAG_CALIBRATED_LAGS if gain < FIXED_LAG_LONG_WAVE_GAIN else FIXED_LAG_SHORT_LAGS
    return lags * highpass_wavelength, gain


def fixed_lag_calibration_warning(instrument: APLModel, lag_m: float, highpass_wavelength: float | None) -> str | None:
    """A warning when ``lag_m`` is shorter than :func:`fixed_lag_calibrated_lag` (the printed std too narrow), else
    None."""
    shortest, gain = fixed_lag_calibrated_lag(instrument, highpass_wavelength)
    if lag_m >= shortest:
        return None
    speed = instrument.dx / instrument.dt
    if gain >= FIXED_LAG_LONG_WAVE_GAIN:
        return (f"with a lag of {lag_m:g} m (under {shortest:g} m) the fixed-lag's std_m is too narrow (measured at "
                f"20 m/s: 64-71 % coverage of the 90 % band at 10-24 m, 97 % at the default 83 m; docs/road-apl.md). "
                f"Use a longer lag, or the smoother.")
    return (f"the trailer sees {highpass_wavelength / 2:g} m waves at {100 * gain:.0f} % of its peak gain at "
            f"{speed:g} m/s: with a lag of {lag_m:g} m the fixed-lag's std_m is too narrow (measured at 6 m/s: 34 % "
            f"coverage of the 90 % band with a 24 m lag, 87-91 % at 120 m; docs/road-apl.md). Use the smoother, or a "
            f"lag of at least {shortest:g} m.")


def _gap_variance(run: _Run, q, r) -> np.ndarray | None:
    """Variance (m^2) the record's gaps add to the error of the detrended estimate, per sample, by Monte Carlo on the
    reconstruction's own model and pass (:func:`._gap_uncertainty.gap_error_variance`); None without gaps."""
    missing = np.isnan(run.y)
    if not missing.any() or run.highpass_wavelength is None:
        return None
    model = apl_deconvolution_model(run.instrument, q, r, input_model=run.input_model,
                                    correlation_length=run.correlation_length, dx=run.dx)
    if run.method == "fixed-lag":
        lag = int(round(run.lag_m / run.dx))

        def estimate(Y):
            return fixed_lag_smoother(model, Y, lag, states=[-1]).mean[..., 0]
    else:
        def estimate(Y):
            return shared_covariance_smoother(model, Y).mean[..., -1]

    def detrend(E):
        return detrend_profile(E, run.dx, highpass_wavelength=run.highpass_wavelength)

    margin = int(np.ceil(2 * run.highpass_wavelength / run.dx))
    return gap_error_variance(missing, model, estimate, detrend, margin)


def _road_spectrum(run: _Run, q, r) -> RoadSpectrumRatio | None:
    """The road's spectrum relative to the reconstruction model's, from the record (``short_waves="record"``, for the
    methods that print a std), or None (the model's own spectrum)."""
    if run.short_waves != "record" or run.method not in ("smoother", "fixed-lag") or run.highpass_wavelength is None:
        return None
    phi = _input_dynamics(run.input_model, run.dx, run.correlation_length)
    est = estimate_road_spectrum_ratio(run.y, run.instrument, r, lambda w: q / np.abs(1.0 - phi * np.exp(-1j * w)) ** 2)
    return est if est is not None and est.white_noise else None


def _fixed_lag_record_std(run: _Run, q, r, lag_m, stationary: bool):
    """The fixed-lag's printed std under ``short_waves="record"``: (std, road ratio or None, Wiener fit or None).

    The fixed-lag's AR(1) 2 m road is a device that pins the trend the trailer cannot see (docs/road-apl.md); its ML
    fit cannot put long-wave power (a drifting sensor, red noise) into that road and puts it into r instead, so its
    r can be far above the record's noise (signal drift: the record's power where the road is invisible is 0.00-0.02
    r). When the noise check rejects the fixed-lag's own fit, the record is described as the smoother describes it:
    paper 000's Wiener road (eq. 7) fitted by ML, whose r the same check then judges. If it passes, the std is the
    error of the same fixed-lag estimate (its G, from q and r) under that noise level r_W and the road the record shows
    with it (:func:`estimate_road_spectrum_ratio` with r_W, relative to the AR(1) spectrum as on the default path);
    if it fails too (noise not white), under the Wiener fit's road and noise, the smoother's own fallback. Without a
    converged Wiener fit, the AR(1) model's own spectrum (at the converged impulse-response length).
    """
    phi = _input_dynamics(run.input_model, run.dx, run.correlation_length)

    def ar1_spectrum(w):
        return q / np.abs(1.0 - phi * np.exp(-1j * w)) ** 2

    est = estimate_road_spectrum_ratio(run.y, run.instrument, r, ar1_spectrum)
    kw = dict(correlation_length=run.correlation_length, dx=run.dx, highpass_wavelength=run.highpass_wavelength,
              n_fft=FIXED_LAG_RECORD_FFT)
    if est is None:  # no complete segment or no resolved band: the model's spectrum, as before
        return fixed_lag_error_std(run.instrument, q, r, lag_m, **{**kw, "n_fft": 1 << 15}), None, None
    if est.white_noise:
        return fixed_lag_error_std(run.instrument, q, r, lag_m, road_ratio=est, **kw), est, None
    try:
        fit = fit_noise_variances(run.y, run.instrument, input_model="wiener", dx=run.dx, stationary=stationary)
    except (ConvergenceError, NotDetectableError):
        fit = None
    if fit is None or not fit.converged:
        return fixed_lag_error_std(run.instrument, q, r, lag_m, **kw), None, None
    q_w, r_w = fit.q, fit.r

    def wiener_spectrum(w):
        return q_w / np.abs(1.0 - np.exp(-1j * w)) ** 2

    check = estimate_road_spectrum_ratio(run.y, run.instrument, r_w, wiener_spectrum)
    if check is not None and check.white_noise:
        est_w = estimate_road_spectrum_ratio(run.y, run.instrument, r_w, ar1_spectrum)
        if est_w is not None:
            return fixed_lag_error_std(run.instrument, q, r, lag_m, road_ratio=est_w, noise_variance=r_w, **kw), \
                est_w, fit
    return fixed_lag_error_std(run.instrument, q, r, lag_m, road_spectrum=wiener_spectrum, noise_variance=r_w,
                               **kw), None, fit


def _std_warnings(run: _Run, lag_m) -> tuple[str, ...]:
    """The warnings of a Kalman reconstruction's printed std (:func:`fixed_lag_calibration_warning`)."""
    if run.method != "fixed-lag" or lag_m is None:
        return ()
    w = fixed_lag_calibration_warning(run.instrument, lag_m, run.highpass_wavelength)
    return () if w is None else (w,)


def _reconstruct_kalman(run: _Run, q, r, stationary: bool | None) -> Reconstruction:
    """The Kalman methods: noise variances, the augmented model, the method's pass, detrending and the std."""
    y = run.y
    if (q is None) != (r is None):
        raise InputError("give both q and r (m^2), or neither to estimate them by maximum likelihood.")
    if stationary is None:
        stationary = y.size > LONG_RECORD_SAMPLES
    if stationary and run.method == "fixed-lag" and np.isnan(y).any():
        first = int(np.flatnonzero(np.isnan(y))[0])
        raise InputError(f"the signal has {int(np.isnan(y).sum())} missing sample(s), the first at "
                         f"{run.distance[first]:.3f} m; the fixed-lag reconstruction of a record of more than "
                         f"{LONG_RECORD_SAMPLES} samples needs it complete: use the smoother (--method smoother, which "
                         "bridges gaps in records of any length), or cut the record at the gap(s).")
    q, r, fit = _noise_variances(run, q, r, stationary)
    mean, cov, lag_m, elevation = _kalman_estimate(run, q, r, stationary)
    std = None
    std_fit = None
    ratio = None
    if run.method == "smoother" and run.highpass_wavelength is not None:
        ratio = _road_spectrum(run, q, r)
        s = smoother_error_std(run.instrument, q, r, input_model=run.input_model,
                               correlation_length=run.correlation_length, dx=run.dx,
                               highpass_wavelength=run.highpass_wavelength, road_ratio=ratio)
        std = np.broadcast_to(s, y.shape)
    elif (run.method == "fixed-lag" and run.highpass_wavelength is not None and run.short_waves == "record"
          and run.input_model == "ar1"):
        s, ratio, std_fit = _fixed_lag_record_std(run, q, r, lag_m, stationary)
        std = np.broadcast_to(s, y.shape)
    elif run.method == "fixed-lag" and run.highpass_wavelength is not None:
        ratio = _road_spectrum(run, q, r)
        s = fixed_lag_error_std(run.instrument, q, r, lag_m, correlation_length=run.correlation_length, dx=run.dx,
                                highpass_wavelength=run.highpass_wavelength, road_ratio=ratio,
                                **({} if ratio is None else {"n_fft": FIXED_LAG_RECORD_FFT}))
        std = np.broadcast_to(s, y.shape)
    instrument_std = _instrument_std(run, q, r, stationary, elevation)
    if instrument_std is not None:
        std = np.sqrt(std ** 2 + instrument_std ** 2)
    gap_var = None if std is None else _gap_variance(run, q, r)
    if gap_var is not None:
        std = np.sqrt(std ** 2 + gap_var)
    prof = Profile(run.distance, elevation, std=std, name=f"{run.method} reconstruction of {run.name}".strip())
    raw_std = None if cov is None else np.sqrt(np.maximum(cov, 0.0))
    return Reconstruction(profile=prof, raw_elevation=mean, raw_std=raw_std, method=run.method,
                          q=float(q), r=float(r), noise_fit=fit, input_model=run.input_model,
                          highpass_wavelength=run.highpass_wavelength, lag_m=lag_m,
                          correlation_length=run.correlation_length if run.input_model == "ar1" else None,
                          instrument_uncertainty=run.uncertainty, instrument_std=instrument_std,
                          warnings=_std_warnings(run, lag_m), road_spectrum=ratio, std_noise_fit=std_fit)
