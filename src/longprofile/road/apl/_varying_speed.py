"""Kalman deconvolution of an APL record towed at a varying speed (paper 000 §5 with a time-varying instrument).

Paper 000's trailer (eq. 1, Table 1) is a mechanical system in time discretised at ONE towing speed, dt = dx / V.
A record towed at a varying speed v_k (traffic: 61-83 km/h; stop-and-go) is sampled every dx of distance but the
time between two stations, dt_k, varies: the augmented model of eqs. 9-12 then has one transition per step,

    z_{k+1} = [[A_k, B_k], [0, phi]] z_k + w_k,   A_k = exp(A_c dt_k),  B_k = (A_k - I)(A - I)^-1 B,

with A_c the continuous-time form of the instrument (:func:`step_transitions`, the re-discretisation of
:func:`resample_model` step by step) and the road a random walk (or AR(1)) in DISTANCE, whose increment variance q is
per station as in the constant-speed model. The state-space engine runs it as a time-varying model (``F`` of shape
(T-1, n, n)): q and r by maximum likelihood (:func:`fit_noise_variances` with ``steps``), the RTS smoother or the
filter, and the detrending of the constant-speed path. The printed std (``profile.std``) is the constant-speed
path's stationary error of the detrended estimate evaluated at each station's own speed (the instrument
re-discretised at dt = dx / v_k, the road spectrum the record shows), plus what missing samples add; for a
time-sampled record, on the file's own grid at that speed (the instrument at the file's step, samples v dt apart),
the road spectrum estimated with the noise the record's interpolation at every dx leaves (not white of variance r).

Assumptions (docs/road-apl.md, "Varying towing speed"): the trailer's dynamics in time do not depend on the speed
(the Table 1 configuration nearest the record's median speed, or the ``--model`` file, is re-discretised at every
step); the speed varies slowly against the smoother's memory (about a pendulum time constant, 1 s) for the printed
std (quasi-stationary); the speed column is the speed over the step (dt_k = dx (1/v_k + 1/v_{k+1}) / 2); the
variance missing samples add is the constant-speed path's Monte Carlo (:func:`gap_error_variance`) on the
time-varying model.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg

from ..._validation import as_float_array
from ...core import Profile
from ...errors import ConvergenceError, InputError
from ...statespace import StateSpaceModel, kalman_filter, rts_smoother, shared_covariance_smoother
from ._deconvolution import (
    LONG_RECORD_SAMPLES,
    Reconstruction,
    _check_record,
    _input_dynamics,
    detrend_profile,
    fit_noise_variances,
    smoother_error_std,
)
from ._gap_uncertainty import gap_error_variance
from ._model import APLModel
from ._resample import _rediscretised, step_transitions
from ._short_waves import SHORT_WAVE_MAX_SEGMENTS, SHORT_WAVE_SEGMENT, estimate_road_spectrum_ratio

__all__ = ["VARYING_SPEED_METHODS", "station_steps", "varying_speed_model", "reconstruct_varying_speed",
           "reconstruct_time_sampled", "STD_SPEED_STEP"]

#: The methods that take a varying speed (the double filter and the fixed-lag assume one instrument).
VARYING_SPEED_METHODS = ("smoother", "filter")
#: Relative spacing of the speeds at which the printed std is evaluated (then interpolated in log speed).
STD_SPEED_STEP = 0.02
#: Slowest speed, m/s, taken for a step (a stop between two stations of a distance-sampled record: the trailer
#: settles, exp(A_c dt) -> 0) and for the printed std (below it the station is a stop's).
_SLOWEST = 1e-3
_STD_SLOWEST = 1.0


def station_steps(speed, dx: float) -> np.ndarray:
    """Time between consecutive stations ``dx`` apart, s: dx (1/v_k + 1/v_{k+1}) / 2 (trapezoidal rule of dt/dx =
    1/v; speeds below 1 mm/s taken as 1 mm/s).

    Parameters
    ----------
    speed : (T,) array_like
        Towing speed at each station, m/s (finite).
    dx : float
        Spacing, m.

    Returns
    -------
    (T-1,) ndarray
    """
    v = as_float_array("speed", speed, ndim=1, allow_nan=False)
    slow = 1.0 / np.maximum(v, _SLOWEST)
    return dx * 0.5 * (slow[1:] + slow[:-1])


def varying_speed_model(instrument: APLModel, steps, q: float, r: float, *, input_model: str = "wiener",
                        correlation_length: float | None = None, dx: float | None = None,
                        distance_steps=None) -> StateSpaceModel:
    """The augmented model of :func:`apl_deconvolution_model` (paper 000 eqs. 9-12) with one transition per step.

    Parameters
    ----------
    instrument : APLModel
        The trailer at its own step (e.g. Table 1 at 20 m/s), delay 0 or 1.
    steps : (T-1,) array_like
        Duration of each step between stations, s (:func:`station_steps`).
    q, r, input_model, correlation_length, dx
        As :func:`apl_deconvolution_model` (q per station of the road, in distance).
    distance_steps : (T-1,) array_like, optional
        Distance of each step in stations (distance / dx; 0 at a stop): a record sampled in TIME, whose road
        increment over step k has the variance q x distance_steps[k] (the Wiener road; Q_k of shape (T-1, ...)).
        Default None: every step is one station.

    Returns
    -------
    StateSpaceModel
        Transition (T-1, n+1, n+1) [[A_k, B_k], [0, phi]] (:func:`step_transitions`), observation [C, D], process
        covariance diag(0, ..., q), obs_cov [[r]]; prior u_0 = 0 and the instrument state at its stationary
        distribution at the first step (as the constant-speed model).
    """
    h = dx if dx is not None else instrument.dx
    if h is None:
        raise InputError("the instrument has no spacing dx (bench model); pass dx=... in m.")
    phi = _input_dynamics(input_model, h, correlation_length)
    A, B, C, D = step_transitions(instrument, steps)
    k, n = A.shape[0], A.shape[1]
    F = np.zeros((k, n + 1, n + 1))
    F[:, :n, :n] = A
    F[:, :n, n:] = B
    F[:, n, n] = phi
    Q = np.zeros((n + 1, n + 1))
    Q[n, n] = q
    if distance_steps is not None:
        if input_model != "wiener":
            raise InputError("a record sampled in time is reconstructed with the Wiener road (input_model='wiener').")
        scale = as_float_array("distance_steps", distance_steps, ndim=1, allow_nan=False)
        Qk = Q[None] * np.maximum(scale, 0.0)[:, None, None]
    if k == 0:
        raise InputError("a record towed at a varying speed needs at least two stations.")
    A0 = A[0]
    M = np.linalg.solve(np.eye(n) - A0, B[0])  # the same at every step (step_transitions)
    if phi == 1.0:
        Pxi = linalg.solve_discrete_lyapunov(A0, q * (M @ M.T))
    else:
        P = linalg.solve_discrete_lyapunov(F[0], Q)
        Pxi = P[:n, :n] - np.outer(P[:n, n], P[n, :n]) / P[n, n]
    P0 = np.zeros((n + 1, n + 1))
    P0[:n, :n] = 0.5 * (Pxi + Pxi.T)
    return StateSpaceModel(F, np.hstack([C, D]), Q if distance_steps is None else Qk, np.array([[r]]),
                           np.zeros(n + 1), P0, check_psd=distance_steps is None)


def reconstruct_varying_speed(signal_: Profile, speed, instrument: APLModel, *, method: str = "smoother",
                              q: float | None = None, r: float | None = None, input_model: str | None = None,
                              correlation_length: float | None = None, highpass_wavelength: float | None = 100.0,
                              min_length: float | None = None) -> Reconstruction:
    """Reconstruct the road profile from an APL record towed at a varying speed.

    Parameters
    ----------
    signal_ : Profile
        The APL signal, m, at stations ``dx`` apart (NaN: missing, bridged).
    speed : (T,) array_like
        The towing speed at each station, m/s (finite; a time-sampled record taken at every dx gives it).
    instrument : APLModel
        The trailer at its own step, with ``dx`` (e.g. :func:`apl_model` (20, 0.05)): re-discretised at every step.
    method : {"smoother", "filter"}
        RTS smoother (default) or the causal filter (:data:`VARYING_SPEED_METHODS`).
    q, r : float, optional
        Both or neither; neither: maximum likelihood with the time-varying model (:func:`fit_noise_variances` with
        ``steps``).
    input_model, correlation_length, highpass_wavelength, min_length
        As :func:`reconstruct_profile`.

    Returns
    -------
    Reconstruction
        As :func:`reconstruct_profile`'s; ``profile.std`` (smoother with a ``highpass_wavelength``) is the
        stationary std of the detrended error at each station's own speed (module docstring), plus the variance a
        missing sample adds; ``warnings`` empty.

    Raises
    ------
    InputError
        A method other than the smoother or the filter; a speed of another length than the signal or not finite;
        a record of more than LONG_RECORD_SAMPLES samples (the time-varying smoother keeps every covariance); the
        errors of :func:`reconstruct_profile`.
    ConvergenceError
        The ML estimate of q/r on its search bound.
    """
    input_model = "wiener" if input_model is None else input_model
    if not isinstance(signal_, Profile) or signal_.spacing is None or signal_.elevation.shape[1] != 1:
        raise InputError("signal_ must be a one-track Profile at stations dx apart.")
    dx = float(signal_.spacing)
    y = signal_.elevation[:, 0]
    v = as_float_array("speed", speed, ndim=1, allow_nan=False)
    if v.size != y.size:
        raise InputError(f"speed has {v.size} values for {y.size} stations; give one per station.")
    if y.size > LONG_RECORD_SAMPLES:
        raise InputError(f"{signal_.name or 'the record'}: {y.size} samples; a record towed at a varying speed is "
                         f"reconstructed in one piece of at most {LONG_RECORD_SAMPLES} samples "
                         f"({LONG_RECORD_SAMPLES * dx / 1000:g} km at {dx:g} m): cut it into parts.")
    _check_record(y, dx, min_length, highpass_wavelength)
    steps = station_steps(v, dx)
    kw = dict(input_model=input_model, correlation_length=correlation_length, dx=dx)
    model, fit, q, r, mean, var = _estimate(instrument, y, steps, None, q, r, method, kw)
    elevation = detrend_profile(mean, dx, highpass_wavelength=highpass_wavelength)
    std = None
    if method == "smoother" and highpass_wavelength is not None:
        std = np.sqrt(_local_std(instrument, v, y, q, r, highpass_wavelength, **kw) ** 2
                      + _gap_variance(model, y, dx, highpass_wavelength))
    return _result(signal_, elevation, std, mean, var, (q, r, fit), method, highpass_wavelength, v, kw)


def reconstruct_time_sampled(samples, signal_: Profile, speed, instrument: APLModel, *, method: str = "smoother",
                             q: float | None = None, r: float | None = None,
                             highpass_wavelength: float | None = 100.0, min_length: float | None = None,
                             **options) -> Reconstruction:
    """Reconstruct a time-sampled APL record at its own time step, then read the estimate at every dx.

    The trailer runs at the file's step (A_k = exp(A_c (t_{k+1} - t_k))), the road is a random walk in distance
    whose increment over a step has the variance q x (distance of the step) / dx (zero at a stop, where the trailer
    settles while the signal is still observed): session 39's feasibility run, with q and r by maximum likelihood.

    Parameters
    ----------
    samples : (time, distance, signal)
        The file's samples (``longprofile.io.read_apl_record``'s ``time_samples``): s, m, m; complete (no NaN).
    signal_ : Profile
        The record taken at every dx (its stations are the output's).
    speed : (T,) array_like
        The speed at those stations, m/s (for the printed std, as :func:`reconstruct_varying_speed`).
    instrument, method, q, r, highpass_wavelength, min_length
        As :func:`reconstruct_varying_speed` (the Wiener road only).

    Returns
    -------
    Reconstruction
        On ``signal_``'s stations: ``raw_elevation`` and ``raw_std`` the smoother's at the file's samples, linear in
        distance between them; ``profile.std`` the stationary std of the detrended error at each station's speed on
        the file's own grid (samples v dt apart, the trailer at the file's step; :func:`_local_std`), the road's
        spectrum ratio estimated with the expected power of the interpolated noise (:func:`_interpolated_noise`);
        no gap term (the file has none).
    """
    if options.get("input_model") not in (None, "wiener"):
        raise InputError("a time-sampled record is reconstructed at its own step with the Wiener road only; leave out "
                         "--input-model.")
    t, x, y = (np.asarray(a, float) for a in samples)
    dx = float(signal_.spacing)
    if y.size > LONG_RECORD_SAMPLES:
        raise InputError(f"{signal_.name or 'the record'}: {y.size} time samples; a time-sampled record is "
                         f"reconstructed in one piece of at most {LONG_RECORD_SAMPLES} samples: cut it into parts.")
    _check_record(signal_.elevation[:, 0], dx, min_length, highpass_wavelength)
    kw = dict(input_model="wiener", correlation_length=None, dx=dx)
    _, fit, q, r, mean_t, var_t = _estimate(instrument, y, np.diff(t), np.diff(x) / dx, q, r, method, kw)
    moved = np.concatenate([[True], np.diff(x) > 0])  # at a stop: the last sample before moving on
    moved[:-1] &= ~(np.diff(x) == 0)
    moved[-1] = True
    grid = signal_.distance
    mean = np.interp(grid, x[moved], mean_t[moved])
    var = np.interp(grid, x[moved], var_t[moved])
    v = as_float_array("speed", speed, ndim=1, allow_nan=False)
    elevation = detrend_profile(mean, dx, highpass_wavelength=highpass_wavelength)
    std = None
    if method == "smoother" and highpass_wavelength is not None:
        y_dx = signal_.elevation[:, 0]
        std = _local_std(instrument, v, y_dx, q, r, highpass_wavelength,
                         noise=_interpolated_noise(x[moved], grid, np.isnan(y_dx), r),
                         time_step=float(np.median(np.diff(t))), **kw)
    return _result(signal_, elevation, std, mean, var, (q, r, fit), method, highpass_wavelength, v, kw)


def _estimate(instrument, y, steps, distance_steps, q, r, method, kw):
    """(model, ML fit or None, q, r, mean, variance of the elevation) of the time-varying model over ``y``."""
    if method not in VARYING_SPEED_METHODS:
        raise InputError(f"a record towed at a varying speed is reconstructed by the "
                         f"{' or the '.join(VARYING_SPEED_METHODS)} (the instrument changes at every station); "
                         f"--method {method} assumes a constant speed.")
    if (q is None) != (r is None):
        raise InputError("give both q and r (m^2), or neither to estimate them by maximum likelihood.")
    fit = None
    if q is None:
        fit = fit_noise_variances(y, instrument, steps=steps, distance_steps=distance_steps, **kw)
        if not fit.converged:
            raise ConvergenceError(f"the ML estimate of q/r hit its search bound (q = {fit.q:.3g}, r = {fit.r:.3g} "
                                   "m^2); the signal may not match the instrument model. Give q and r explicitly.")
        q, r = fit.q, fit.r
    model = varying_speed_model(instrument, steps, q, r, distance_steps=distance_steps, **kw)
    filt = kalman_filter(model, y)
    if method == "smoother":
        sm = rts_smoother(model, filt)
        return model, fit, q, r, sm.mean[:, -1], sm.cov[:, -1, -1]
    return model, fit, q, r, filt.mean[:, -1], filt.cov[:, -1, -1]


def _result(signal_, elevation, std, mean, var, noise, method, highpass_wavelength, v, kw) -> Reconstruction:
    """The :class:`Reconstruction` of a varying-speed record (``noise``: q, r and the ML fit or None)."""
    q, r, fit = noise
    prof = Profile(signal_.distance, elevation, std=std, name=f"{method} reconstruction of {signal_.name}".strip())
    return Reconstruction(profile=prof, raw_elevation=mean, raw_std=np.sqrt(np.maximum(var, 0.0)), method=method,
                          q=float(q), r=float(r), noise_fit=fit, input_model=kw["input_model"],
                          highpass_wavelength=highpass_wavelength,
                          correlation_length=kw["correlation_length"] if kw["input_model"] == "ar1" else None,
                          speed_range=(float(v.min()), float(np.median(v)), float(v.max())))


def _local_std(instrument: APLModel, v, y, q, r, highpass_wavelength, *, input_model, correlation_length, dx,
               noise=None, time_step: float | None = None):
    """The constant-speed path's printed std (:func:`smoother_error_std` under the road the record shows) at each
    station's own speed: evaluated every :data:`STD_SPEED_STEP` of speed between the slowest and the fastest, the
    instrument re-discretised there, then interpolated in log speed.

    Distance-sampled (``time_step`` None): on the stations' grid, the instrument at dt = dx / v. Time-sampled
    (``time_step``, s, the file's step; ``noise``, the expected power of its noise once taken at every dx, for
    :func:`estimate_road_spectrum_ratio`): on the file's own grid at that speed, samples h = v time_step apart, the
    instrument at the file's step, the road's variance q h / dx per sample, r per sample, the road's spectrum ratio
    at the same wavenumbers: the stationary error of the smoother the record is reconstructed by (ASSUMPTION,
    docs/road-apl.md, "Varying towing speed", 4)."""
    phi = _input_dynamics(input_model, dx, correlation_length)

    def road(w):
        return q / np.abs(1.0 - phi * np.exp(-1j * w)) ** 2

    median = float(np.median(v[v > _STD_SLOWEST])) if np.any(v > _STD_SLOWEST) else _STD_SLOWEST
    ratio = estimate_road_spectrum_ratio(y, _rediscretised(instrument, dx / median, dx=dx), r, road, noise=noise)
    ratio = ratio if ratio is not None and ratio.white_noise else None
    lv = np.log(np.maximum(v, _STD_SLOWEST))
    n = max(2, int(np.ceil((lv.max() - lv.min()) / np.log1p(STD_SPEED_STEP))) + 1)
    grid = np.linspace(lv.min(), lv.max(), n)
    options = dict(input_model=input_model, correlation_length=correlation_length,
                   highpass_wavelength=highpass_wavelength)

    def at_speed(speed):
        if time_step is None:
            return smoother_error_std(_rediscretised(instrument, dx / speed, dx=dx), q, r, dx=dx, road_ratio=ratio,
                                      **options)
        h = speed * time_step
        on_file = None if ratio is None else dataclasses.replace(ratio, frequency=ratio.frequency * h / dx)
        return smoother_error_std(_rediscretised(instrument, time_step, dx=h), q * h / dx, r, dx=h,
                                  road_ratio=on_file, **options)

    return np.interp(lv, grid, [at_speed(np.exp(g)) for g in grid])


def _interpolated_noise(x, grid, missing, r: float, *, segment: int = SHORT_WAVE_SEGMENT):
    """The expected power of white noise of variance ``r`` at the file's sample positions ``x`` (increasing) once
    taken at the stations ``grid`` by linear interpolation, as the record's signal was: w (rad/sample) -> m^2 on the
    Welch segments :func:`estimate_road_spectrum_ratio` uses (those without a ``missing`` station; the segment mean's
    removal, which touches only the lowest bins, neglected); None when every station is a sample (white noise of
    variance r).

    Exactly: with n = W e, E|sum_j h_j n_j e^{-iwj}|^2 = r sum_l e^{-iwl} sum_j h_j h_{j+l} (W W^T)_{j,j+l}, W W^T
    banded (two stations share a sample only when they lie in the same or adjacent intervals). Linear interpolation
    averages neighbouring samples, so this is below r at short waves: the record taken at every dx is not white of
    variance r, and the short-wave estimate taken with r failed its noise check (the band about twice as wide as the
    error: docs/road-apl.md, "Varying towing speed")."""
    n = grid.size
    a = np.clip(np.searchsorted(x, grid, side="right") - 1, 0, x.size - 2)
    f = np.clip((grid - x[a]) / (x[a + 1] - x[a]), 0.0, 1.0)  # weight of sample a + 1
    lags = [(1.0 - f) ** 2 + f ** 2]  # (W W^T)_{j, j+l}, l = 0, 1, ...
    while lags[-1].any() and len(lags) <= n - 1:
        lag = len(lags)
        same, next_ = a[lag:] == a[:-lag], a[lag:] == a[:-lag] + 1
        lags.append(np.where(same, (1 - f[:-lag]) * (1 - f[lag:]) + f[:-lag] * f[lag:], 0.0)
                    + np.where(next_, f[:-lag] * (1 - f[lag:]), 0.0))
    lags = lags[:-1] if len(lags) > 1 and not lags[-1].any() else lags
    if len(lags) == 1 and np.all(lags[0] == 1.0):
        return None
    seg = int(min(segment, 1 << int(np.floor(np.log2(max(n, 2))))))
    starts = np.arange(0, n - seg + 1, seg // 2)
    if starts.size > SHORT_WAVE_MAX_SEGMENTS:
        starts = starts[np.linspace(0, starts.size - 1, SHORT_WAVE_MAX_SEGMENTS).round().astype(int)]
    starts = [s0 for s0 in starts if not missing[s0:s0 + seg].any()]
    if not starts:
        return None
    win = np.hanning(seg)
    cov = np.zeros(len(lags))  # sum over segments of sum_j h_j h_{j+l} (W W^T)_{j,j+l}
    for s0 in starts:
        for lag, band in enumerate(lags):
            cov[lag] += np.sum(win[:seg - lag] * win[lag:] * band[s0:s0 + seg - lag])
    cov = r * cov / (len(starts) * np.sum(win ** 2))

    def noise(w):
        w = np.asarray(w, dtype=float)
        return np.full(w.shape, cov[0]) + 2.0 * sum(c * np.cos(w * lag) for lag, c in enumerate(cov[1:], start=1))

    return noise


def _gap_variance(model: StateSpaceModel, y, dx: float, highpass_wavelength: float) -> np.ndarray | float:
    """Per-sample variance (m^2) the missing samples add to the error of the detrended estimate: the constant-speed
    path's Monte Carlo (:func:`gap_error_variance`) on each gap's window of the time-varying model; 0 without."""
    missing = np.isnan(y)
    if not missing.any():
        return 0.0

    def window_model(lo, hi):
        return dataclasses.replace(model, transition=model.transition[lo:hi - 1])

    def estimate(Y, wmodel):
        return shared_covariance_smoother(wmodel, Y).mean[..., -1]

    def detrend(E):
        return detrend_profile(E, dx, highpass_wavelength=highpass_wavelength)

    margin = int(np.ceil(2 * highpass_wavelength / dx))
    return gap_error_variance(missing, model, estimate, detrend, margin, window_model=window_model)
