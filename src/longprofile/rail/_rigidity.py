r"""The Bayesian rigidity model of paper 004 (§4.2–4.4): dense reference and O(N) state-space version.

Unknowns at the N stations (sensors) x_1 < ... < x_N are the altitude z_i = f(x_i)
and the slope theta_i = f'(x_i) of the track. The prior penalises curvature,

    pi(f) ∝ exp(-||f''||^2 / r),     ||g||^2 = (1 / (x_N - x_1)) ∫ g^2,

which Lemma 4.1 turns into a quadratic form on X = (z, theta): between two
stations the minimiser is the cubic Hermite polynomial and its cost is

    ∫ f''^2 = 12/l^3 (dz - l (theta_i + theta_{i+1})/2)^2 + 1/l (theta_{i+1} - theta_i)^2.

Mapping to the engine: with e_i = (z_{i+1} - z_i - l theta_i, theta_{i+1} - theta_i),
the cost above equals e_i^T Qbar(l)^{-1} e_i with Qbar(l) = [[l^3/3, l^2/2], [l^2/2, l]],
i.e. the transition density of the integrated Wiener process theta' = w, z' = theta,
F(l) = [[1, l], [0, 1]], Q(l) = q Qbar(l). Matching exp(-(1/(r L)) Σ cost) with
exp(-1/2 Σ e^T Q^{-1} e) gives q = r L / 2, L = x_N - x_1. The posterior of the
paper is therefore exactly the RTS smoother of that model over the stations.

Beyond the paper, ``penalty_order=3`` penalises ||f'''||^2 instead: the state gains the
curvature, the process is the twice-integrated Wiener process (quintic Hermite between
stations), with the same q = r L / 2. It is the smoother prior that the likelihood prefers
for settlement bowls (docs/rail.md); the paper's order 2 stays the default of these functions.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from math import factorial

import numpy as np

from .._validation import as_float_array, require_positive
from ..errors import InputError, ShapeError
from ..statespace import (
    GroupedSmootherResult,
    StateSpaceModel,
    grouped_covariance_smoother,
    grouped_log_likelihood,
    posterior_sample,
    process_noise_energy,
    process_noise_moments,
    process_scale_log_likelihood,
    shared_covariance_log_likelihood,
    shared_covariance_smoother,
    smoother_noise_covariance,
)
from ._results import Z90, ProfilePosterior

__all__ = [
    "ProfilePosterior",
    "segment_rigidity_cost",
    "rigidity_cost_matrix",
    "rigidity_posterior_dense",
    "rigidity_model",
    "rigidity_posterior",
    "initial_profile_posterior_dense",
    "initial_profile_posterior",
    "sample_profiles",
    "max_settlement_monte_carlo",
    "max_settlement_interval",
    "max_settlement_from_draws",
    "MaxSettlement",
    "MAX_SETTLEMENT_INTERVALS",
    "MAX_SETTLEMENT_PROBABILITY",
    "measurement_std",
    "segment_process_energy",
    "segment_process_energy_levels",
    "rigidity_log_likelihood_rows",
    "rigidity_posterior_levels",
    "Z90",
]

#: Rigidity r of the paper (§4.1): typical mean-square curvature, m^-2 (the text's "1/r := 1e-8" is a misprint).
DEFAULT_RIGIDITY = 1e-8
#: Angle noise sigma of the paper (§4.2): 5e-3 degree, in radians.
DEFAULT_SIGMA = np.deg2rad(5e-3)
#: Anchor standard deviation sigma_z of the paper (§4.2), m.
DEFAULT_SIGMA_Z = 1e-5
#: Survey noise sigma_a of the paper (§4.4), m.
DEFAULT_SIGMA_A = 2e-3
#: Wide proper prior on the first slope (rad) replacing the paper's flat prior in the state-space form.
FIRST_SLOPE_PRIOR_STD = 1.0
#: Wide proper priors on the first altitude (m, after centring) and slope (rad) for §4.4 in the state-space
#: form: there the slopes are only known through altitude differences (precision ~1e6), so the slope
#: prior must be wider than for §4.2 to stay below 1e-9 m of the paper's flat prior.
FIRST_ALTITUDE_PRIOR_STD = 100.0
INITIAL_PROFILE_SLOPE_PRIOR_STD = 10.0
#: Wide proper prior on the first curvature (m^-1) of the quintic-spline prior (penalty_order=3).
FIRST_CURVATURE_PRIOR_STD = 0.1
#: Constructions of the maximum settlement's interval (:func:`max_settlement_from_draws`): "draws" (default since
#: 2026-12-06, issue 13): the band-shaped interval holding the maximum of a given share of the posterior draws;
#: "band": the interval implied by the simultaneous band of the whole profile (conservative; the printed one
#: until then).
MAX_SETTLEMENT_INTERVALS = ("draws", "band")
#: Share of the posterior draws whose maximum the printed 90 % interval holds (``interval="draws"``). Not 0.9: the
#: posterior of the maximum is over-confident on independent scenarios (at 0.9 it covered 72-84 % of the true
#: maxima, calibration seeds 300-399 of every family: the bowl centre shrunk by the prior, truth above; quiet days'
#: noise excursions, truth below), and 0.98 is the share that put every family's coverage inside 85-95 %, with the
#: largest margin and a mean over the families of 90.3 % (docs/rail.md, "The maximum-settlement interval, step 13").
MAX_SETTLEMENT_PROBABILITY = 0.98
#: Supported prior orders: 2 = the paper's ||f''||^2 (cubic Hermite between stations, Lemma 4.1);
#: 3 = ||f'''||^2 (quintic Hermite between stations; beyond the paper, for smooth settlement bowls).
PENALTY_ORDERS = (2, 3)


def _check_stations(x) -> np.ndarray:
    x = as_float_array("x (station positions)", x, ndim=1, allow_nan=False)
    if x.size < 2:
        raise InputError(f"the rigidity model needs at least 2 stations; got {x.size}.")
    if np.any(np.diff(x) <= 0):
        i = int(np.nonzero(np.diff(x) <= 0)[0][0])
        raise InputError(f"station positions must be strictly increasing; x[{i}] = {x[i]} and x[{i + 1}] = {x[i + 1]}. "
                         "Sort the sensors by position and merge duplicates.")
    return x


def segment_rigidity_cost(length: float) -> np.ndarray:
    r"""Quadratic form of Lemma 4.1 on one segment: ∫ f''^2 = v^T M v, v = (z_i, theta_i, z_{i+1}, theta_{i+1}).

    Parameters
    ----------
    length : float
        Segment length l = x_{i+1} - x_i, m.

    Returns
    -------
    (4, 4) ndarray
        Symmetric M with v^T M v = 4 l c^2 + 12 l^2 c d + 12 l^3 d^2 (paper 004, proof of Lemma 4.1).

    Notes
    -----
    The cubic coefficients are, correcting the paper's two misprints in the inverse
    matrix and in its expansion,
    c = 3 l^-2 (z_{i+1} - z_i) - l^-1 (2 theta_i + theta_{i+1}),
    d = -2 l^-3 (z_{i+1} - z_i) + l^-2 (theta_i + theta_{i+1}).
    """
    l = require_positive("segment length", length)
    # c = a . v, d = b . v
    a = np.array([-3.0 / l**2, -2.0 / l, 3.0 / l**2, -1.0 / l])
    b = np.array([2.0 / l**3, 1.0 / l**2, -2.0 / l**3, 1.0 / l**2])
    M = 4 * l * np.outer(a, a) + 6 * l**2 * (np.outer(a, b) + np.outer(b, a)) + 12 * l**3 * np.outer(b, b)
    return 0.5 * (M + M.T)


def rigidity_cost_matrix(x, *, rigidity: float = DEFAULT_RIGIDITY, segment_weights=None) -> np.ndarray:
    r"""Rigidity cost matrix C of paper 004 (§4.2), ordered X = (z_1..z_N, theta_1..theta_N).

    ``1/2 X^T C X = ||f''||^2 / r`` for the piecewise cubic Hermite f through X, i.e.
    C = 2 / (r (x_N - x_1)) Σ_i M_i with M_i from :func:`segment_rigidity_cost`; with
    ``segment_weights`` w_i the prior is space-varying, C = 2 / (r L) Σ_i M_i / w_i (r w_i on segment i).

    Parameters
    ----------
    x : (N,) array_like
        Strictly increasing station positions, m.
    rigidity : float, default 1e-8
        r, m^-2.
    segment_weights : (N-1,) array_like, optional
        Relative prior intensity of each segment (:func:`rigidity_model`); None = 1 everywhere (the paper).

    Returns
    -------
    (2N, 2N) ndarray
    """
    x = _check_stations(x)
    r = require_positive("rigidity", rigidity)
    N = x.size
    w = _segment_weights(segment_weights, N)
    C = np.zeros((2 * N, 2 * N))
    for i, l in enumerate(np.diff(x)):
        idx = [i, N + i, i + 1, N + i + 1]
        C[np.ix_(idx, idx)] += segment_rigidity_cost(l) / (1.0 if w is None else w[i])
    return C * (2.0 / (r * (x[-1] - x[0])))


def _noise_std(sigma, N):
    """``sigma`` as a float (one std for every station) or an (N,) float array (one per station), each > 0."""
    if np.ndim(sigma) == 0:
        return require_positive("sigma", sigma)
    s = as_float_array("sigma", sigma, ndim=1, allow_nan=False)
    if s.shape != (N,):
        raise ShapeError(f"sigma must be one number or one per station ({N},); got shape {s.shape}.")
    if not np.all(s > 0):
        raise InputError(f"sigma must be > 0 at every station; got min {s.min()!r}.")
    return s


def _segment_weights(weights, N):
    """None, or the (N-1,) float array of positive finite segment weights."""
    if weights is None:
        return None
    w = as_float_array("segment_weights", weights, ndim=1, allow_nan=False)
    if w.shape != (N - 1,):
        raise ShapeError(f"segment_weights must have one value per segment ({N - 1},); got shape {w.shape}.")
    if not np.all(w > 0):
        raise InputError(f"segment_weights must be > 0 on every segment; got min {w.min()!r}.")
    return w


def _as_profiles(name, values, N):
    arr = as_float_array(name, values, ndim=(1, 2))
    if arr.shape[-1] != N:
        raise ShapeError(f"{name} must have N = {N} columns (one per station); got shape {arr.shape}.")
    return arr


def rigidity_posterior_dense(x, slopes, *, sigma: float = DEFAULT_SIGMA, rigidity: float = DEFAULT_RIGIDITY,
                             sigma_z: float = DEFAULT_SIGMA_Z, z_ends=(0.0, 0.0),
                             first_slope_prior_std: float | None = None, segment_weights=None) -> ProfilePosterior:
    r"""The paper's dense posterior (§4.2), O(N^3): the reference implementation.

    Parameters
    ----------
    x : (N,) array_like
        Station positions, m.
    slopes : (N,) array_like
        Measured slopes m_i (rad); NaN for a sensor without a measurement.
    sigma : float or (N,) array_like
        Slope noise standard deviation, rad (paper: 5e-3 degree); one per station for sensors of
        unequal noise (the observation precision of station i is 1 / sigma_i^2).
    rigidity : float
        r, m^-2.
    sigma_z : float
        Standard deviation of the two end anchors, m (paper: 1e-5 m).
    z_ends : (2,) array_like
        Anchor altitudes (z_1^0, z_N^0), m.
    first_slope_prior_std : float, optional
        None (default) is the paper's improper (flat) prior on the slopes. A value, rad, adds the
        proper N(0, std^2) prior on the first slope that the O(N) state-space form needs to start its
        recursion (:func:`rigidity_model`, default 1 rad), so that both compute the same posterior.
    segment_weights : (N-1,) array_like, optional
        Space-varying prior (:func:`rigidity_cost_matrix`); None = the paper's stationary prior.

    Returns
    -------
    ProfilePosterior
        With ``full_cov`` set and ``cross_cov`` None.

    Notes
    -----
    Implements X | M ~ N(Sigma_X (P^T Sigma_theta^-1 M + A X^0), Sigma_X),
    Sigma_X = (P^T Sigma_theta^-1 P + C + A)^-1, where P (N_obs x 2N) selects the
    observed slopes and A is the anchor precision 1/sigma_z^2 on z_1 and z_N.
    The paper prints P Sigma^-1 P^T (dimensions do not match), omits A from
    Sigma_X and the mean, and writes 1/(2 sigma) and sigma^2 for 1/(2 sigma^2)
    and sigma_z^2 in the posterior density: corrected here (docs/rail.md).
    """
    x = _check_stations(x)
    N = x.size
    m = _as_profiles("slopes", slopes, N)
    if m.ndim != 1:
        raise ShapeError(f"rigidity_posterior_dense takes one profile of N slopes; got shape {m.shape}.")
    s = np.broadcast_to(_noise_std(sigma, N), (N,))
    sz = require_positive("sigma_z", sigma_z)
    z_ends = as_float_array("z_ends", z_ends, ndim=1, allow_nan=False)
    prec = rigidity_cost_matrix(x, rigidity=rigidity, segment_weights=segment_weights)
    rhs = np.zeros(2 * N)
    obs = np.isfinite(m)
    prec[N + np.nonzero(obs)[0], N + np.nonzero(obs)[0]] += 1.0 / s[obs] ** 2
    rhs[N:][obs] = m[obs] / s[obs] ** 2
    for i, z0 in ((0, z_ends[0]), (N - 1, z_ends[1])):
        prec[i, i] += 1.0 / sz**2
        rhs[i] += z0 / sz**2
    if first_slope_prior_std is not None:
        prec[N, N] += 1.0 / require_positive("first_slope_prior_std", first_slope_prior_std) ** 2
    cov = np.linalg.inv(prec)
    cov = 0.5 * (cov + cov.T)
    mean = cov @ rhs
    return _dense_result(x, mean, cov)


def _dense_result(x, mean, cov):
    N = x.size
    sc = np.empty((N, 2, 2))
    sc[:, 0, 0] = np.diag(cov)[:N]
    sc[:, 1, 1] = np.diag(cov)[N:]
    sc[:, 0, 1] = sc[:, 1, 0] = cov[np.arange(N), N + np.arange(N)]
    return ProfilePosterior(x=x, z_mean=mean[:N], slope_mean=mean[N:], z_std=np.sqrt(sc[:, 0, 0]),
                            slope_std=np.sqrt(sc[:, 1, 1]), station_cov=sc, cross_cov=None, full_cov=cov,
                            log_likelihood=None, method="dense")


def _iwp_terms(x, q, penalty_order: int = 2):
    """Transition F_i and process covariance Q_i of the integrated Wiener process over the station gaps.

    penalty_order 2: state (z, theta), the paper's cubic-spline prior (penalises f'');
    penalty_order 3: state (z, theta, kappa), the quintic-spline prior (penalises f''').
    Component a is the (n-1-a)-fold integral of a Brownian motion of diffusion q:
    Q_i[a, b] = q h_i^(e+1) / ((e+1) (n-1-a)! (n-1-b)!), e = 2n - 2 - a - b.
    """
    F, hpow, denom = _iwp_parts(np.ascontiguousarray(x, dtype=np.float64).tobytes(), int(penalty_order))
    return F, q * hpow / denom


@lru_cache(maxsize=16)
def _iwp_parts(x_bytes: bytes, n: int):
    """The parts of :func:`_iwp_terms` that do not depend on q, read-only, cached per station set (a search over r
    rebuilds the model of the same stations hundreds of times): F, h_i^(e+1) per entry, the denominators."""
    h = np.diff(np.frombuffer(x_bytes, dtype=np.float64))
    F = np.zeros((h.size, n, n))
    hpow = np.empty((h.size, n, n))
    denom = np.empty((n, n))
    for a in range(n):
        for b in range(a, n):
            F[:, a, b] = h ** (b - a) / factorial(b - a)
        for b in range(n):
            e = 2 * n - 2 - a - b
            hpow[:, a, b] = h ** (e + 1)
            denom[a, b] = (e + 1) * factorial(n - 1 - a) * factorial(n - 1 - b)
    for arr in (F, hpow, denom):
        arr.setflags(write=False)
    return F, hpow, denom


def _check_order(penalty_order) -> int:
    if penalty_order not in PENALTY_ORDERS:
        raise InputError(f"penalty_order must be 2 (the paper's cubic-spline prior, penalises f'') or 3 (the "
                         f"quintic-spline prior, penalises f'''); got {penalty_order!r}.")
    return int(penalty_order)


def rigidity_model(x, *, sigma: float = DEFAULT_SIGMA, rigidity: float = DEFAULT_RIGIDITY,
                   sigma_z: float = DEFAULT_SIGMA_Z, z_start: float = 0.0,
                   first_slope_prior_std: float = FIRST_SLOPE_PRIOR_STD, penalty_order: int = 2,
                   segment_weights=None) -> StateSpaceModel:
    r"""State-space form of the rigidity prior over the stations (paper 004 §4.2, Lemma 4.1).

    State x_i = (z_i, theta_i) at station i ("time" = station index); observation
    y_i = (measured slope, anchored altitude), H = [[0, 1], [1, 0]], R = diag(sigma^2, sigma_z^2).
    Put the end anchor z_N^0 in ``y[N-1, 1]`` and NaN in the other altitude rows.

    Parameters
    ----------
    x : (N,) array_like
        Station positions, m (irregular spacing allowed: F and Q vary per segment).
    sigma : float or (N,) array_like
        As in :func:`rigidity_posterior_dense` (one per station: R varies along the stations).
    rigidity, sigma_z : float
        As in :func:`rigidity_posterior_dense`.
    z_start : float
        Anchor altitude z_1^0 of the first station, m (the prior mean of z_1).
    first_slope_prior_std : float, default 1 rad
        The paper's prior is flat in theta_1; a state-space filter needs a proper
        prior, so theta_1 ~ N(0, (1 rad)^2), a physical bound whose precision (1)
        is ~1e8 times smaller than one slope measurement's.
    penalty_order : {2, 3}, default 2
        2: the paper's prior exp(-||f''||^2 / r) (cubic Hermite between stations).
        3: exp(-||f‴||^2 / r) (beyond the paper): the state gains the curvature kappa_i = f''(x_i),
        F_i = [[1, h, h^2/2], [0, 1, h], [0, 0, 1]], Q_i = q [[h^5/20, h^4/8, h^3/6], [h^4/8, h^3/3, h^2/2],
        [h^3/6, h^2/2, h]] (integrated integrated Wiener process; between stations the minimiser of
        ∫ f‴^2 is the quintic Hermite polynomial, and e^T Qbar^-1 e is its cost, tested against
        scipy's BPoly). r is then in m^-4, and kappa_1 ~ N(0, (0.1 m^-1)^2).
    segment_weights : (N-1,) array_like, optional
        Beyond the paper: a space-varying prior, Q_i = q w_i Qbar(h_i) on segment i (r w_i there), e.g. larger
        where the track moves (:func:`~longprofile.rail.segment_prior_weights`). None = 1 on every segment.

    Returns
    -------
    StateSpaceModel
        F_i = [[1, h_i], [0, 1]], Q_i = q [[h_i^3/3, h_i^2/2], [h_i^2/2, h_i]], q = r (x_N - x_1) / 2
        (penalty_order 2; the observation matrix gains a zero column for the curvature with 3).
    """
    x = _check_stations(x)
    s = _noise_std(sigma, x.size)
    sz = require_positive("sigma_z", sigma_z)
    r = require_positive("rigidity", rigidity)
    sp = require_positive("first_slope_prior_std", first_slope_prior_std)
    n = _check_order(penalty_order)
    q = r * (x[-1] - x[0]) / 2.0
    F, Q = _iwp_terms(x, q, n)
    w = _segment_weights(segment_weights, x.size)
    if w is not None:
        Q = Q * w[:, None, None]
    H = np.zeros((2, n))
    H[0, 1] = H[1, 0] = 1.0
    P0 = np.diag([sz**2, sp**2, FIRST_CURVATURE_PRIOR_STD**2][:n])
    m0 = np.zeros(n)
    m0[0] = float(z_start)
    if np.ndim(s) == 0:
        R = np.diag([s**2, sz**2])
    else:  # one slope-noise variance per station: a time-varying R of the engine
        R = np.zeros((x.size, 2, 2))
        R[:, 0, 0] = s**2
        R[:, 1, 1] = sz**2
    # Q_i (a positive multiple of the IWP Gram matrix, weights > 0), R and P0 (positive diagonals) are PSD by
    # construction: skip the eigenvalue checks, which cost more than a likelihood evaluation in searches over r
    return StateSpaceModel(transition=F, observation=H, process_cov=Q, obs_cov=R, initial_mean=m0, initial_cov=P0,
                           check_psd=False)


def _posterior_from_smoother(x, sm, batched):
    mean, cov, cc = sm.mean, sm.cov, sm.cross_cov
    if batched:
        D = mean.shape[0]
        cov = np.broadcast_to(cov, (D,) + cov.shape)
        cc = np.broadcast_to(cc, (D,) + cc.shape)
    return ProfilePosterior(x=x, z_mean=mean[..., 0], slope_mean=mean[..., 1],
                            z_std=np.sqrt(cov[..., 0, 0]), slope_std=np.sqrt(cov[..., 1, 1]),
                            station_cov=cov, cross_cov=cc, full_cov=None,
                            log_likelihood=sm.filtered.log_likelihood, method="state-space")


def _pattern_groups(pattern: np.ndarray):
    """[(row indices, pattern row)] of the distinct NaN patterns of a (D, N) bool array, in first-seen order."""
    if (pattern == pattern[0]).all():
        return [(np.arange(pattern.shape[0]), pattern[0])]
    groups: dict = {}
    packed = np.packbits(pattern, axis=1)
    for d in range(pattern.shape[0]):
        groups.setdefault(packed[d].tobytes(), []).append(d)
    return [(np.array(rows), pattern[rows[0]]) for rows in groups.values()]


def rigidity_posterior(x, slopes, *, sigma: float = DEFAULT_SIGMA, rigidity: float = DEFAULT_RIGIDITY,
                       sigma_z: float = DEFAULT_SIGMA_Z, z_ends=(0.0, 0.0), penalty_order: int = 2,
                       segment_weights=None) -> ProfilePosterior:
    r"""Posterior of the rigidity model for one or many profiles, in O(N) per profile (RTS smoother).

    Parameters
    ----------
    x : (N,) array_like
        Station positions, m.
    slopes : (N,) or (D, N) array_like
        Measured slopes (rad) per profile (e.g. one row per day); NaN = no measurement.
    sigma, rigidity, sigma_z, z_ends
        As in :func:`rigidity_posterior_dense` (anchors shared by all profiles).
    penalty_order : {2, 3}, default 2
        2 = the paper's prior; 3 = the smoother ||f‴||^2 prior (:func:`rigidity_model`), whose
        station covariances are 3 x 3 (altitude, slope, curvature).
    segment_weights : (N-1,) array_like, optional
        Space-varying prior intensity per segment (:func:`rigidity_model`).

    Returns
    -------
    ProfilePosterior
        ``method="state-space"``; per-profile fields gain a leading D axis for 2-D ``slopes``.

    Notes
    -----
    Same posterior as the paper's dense formula (§4.2), computed by the Kalman
    filter + RTS smoother of :func:`rigidity_model` (module docstring: the mapping
    q = r L / 2). Profiles sharing a missing pattern share one covariance pass
    (:func:`longprofile.statespace.shared_covariance_smoother`), so D profiles of N
    stations cost O(N + D N).
    """
    x = _check_stations(x)
    N = x.size
    m = _as_profiles("slopes", slopes, N)
    batched = m.ndim == 2
    M = m if batched else m[None]
    z_ends = as_float_array("z_ends", z_ends, ndim=1, allow_nan=False)
    model = rigidity_model(x, sigma=sigma, rigidity=rigidity, sigma_z=sigma_z, z_start=z_ends[0],
                           penalty_order=penalty_order, segment_weights=segment_weights)
    n = model.n_states
    Y = _slope_observations(M, z_ends[1])
    D = M.shape[0]
    pattern = np.isnan(M)
    if (pattern == pattern[0]).all():  # the usual case: one covariance pass, shared (read-only views)
        sm = shared_covariance_smoother(model, Y)
        sc = np.broadcast_to(sm.cov, (D,) + sm.cov.shape)
        cc = np.broadcast_to(sm.cross_cov, (D,) + sm.cross_cov.shape)
        zstd = np.broadcast_to(np.sqrt(sm.cov[:, 0, 0]), (D, N))
        tstd = np.broadcast_to(np.sqrt(sm.cov[:, 1, 1]), (D, N))
        zm, tm, ll = sm.mean[..., 0], sm.mean[..., 1], sm.filtered.log_likelihood
        if not batched:
            zm, tm, sc, cc, ll, zstd, tstd = zm[0], tm[0], sc[0], cc[0], float(ll[0]), zstd[0], tstd[0]
        return ProfilePosterior(x=x, z_mean=zm, slope_mean=tm, z_std=zstd, slope_std=tstd, station_cov=sc,
                                cross_cov=cc, full_cov=None, log_likelihood=ll, method="state-space")
    zm = np.empty((D, N)); tm = np.empty((D, N))
    sc = np.empty((D, N, n, n)); cc = np.empty((D, N - 1, n, n)); ll = np.empty(D)
    for rows, _pat in _pattern_groups(pattern):
        sm = shared_covariance_smoother(model, Y[rows])
        zm[rows] = sm.mean[..., 0]
        tm[rows] = sm.mean[..., 1]
        sc[rows] = sm.cov
        cc[rows] = sm.cross_cov
        ll[rows] = sm.filtered.log_likelihood
    if not batched:
        zm, tm, sc, cc, ll = zm[0], tm[0], sc[0], cc[0], float(ll[0])
    return ProfilePosterior(x=x, z_mean=zm, slope_mean=tm, z_std=np.sqrt(sc[..., 0, 0]),
                            slope_std=np.sqrt(sc[..., 1, 1]), station_cov=sc, cross_cov=cc, full_cov=None,
                            log_likelihood=ll, method="state-space")


def _slope_observations(M, z_end: float) -> np.ndarray:
    """(D, N, 2) observations of :func:`rigidity_model`: the slopes, and the end anchor in the last altitude row."""
    Y = np.full(M.shape + (2,), np.nan)
    Y[:, :, 0] = M
    Y[:, -1, 1] = z_end
    return Y


def rigidity_log_likelihood(x, slopes, *, sigma: float = DEFAULT_SIGMA, rigidity: float = DEFAULT_RIGIDITY,
                            sigma_z: float = DEFAULT_SIGMA_Z, z_ends=(0.0, 0.0), penalty_order: int = 2,
                            segment_weights=None):
    r"""Marginal log-likelihood of each profile under the rigidity model: :func:`rigidity_posterior`'s
    ``log_likelihood`` without the posterior.

    Parameters
    ----------
    x, slopes, sigma, rigidity, sigma_z, z_ends, penalty_order, segment_weights
        As in :func:`rigidity_posterior`.

    Returns
    -------
    float or (D,) ndarray
        log p(m_d | r, sigma) of each profile (Kalman-filter prediction-error decomposition of
        :func:`rigidity_model`), bit for bit the value :func:`rigidity_posterior` reports.

    Notes
    -----
    The quantity paper 004's rigidity is fitted by (maximum marginal likelihood, docs/rail.md). Profiles sharing a
    missing pattern share one forward covariance pass (:func:`longprofile.statespace.shared_covariance_log_likelihood`);
    no RTS pass, no posterior arrays: what a search over r evaluates a hundred times per recompute.
    """
    batched, D, model, groups = _likelihood_inputs(x, slopes, z_ends, sigma=sigma, rigidity=rigidity, sigma_z=sigma_z,
                                                   penalty_order=penalty_order, segment_weights=segment_weights)
    ll = np.empty(D)
    for rows, Y in groups:
        ll[rows] = shared_covariance_log_likelihood(model, Y)
    return ll if batched else float(ll[0])


def _likelihood_inputs(x, slopes, z_ends, **model_options):
    """Checked inputs of the likelihood functions: (batched, D, :func:`rigidity_model`, [(rows, observations)] per
    missing pattern)."""
    x = _check_stations(x)
    m = _as_profiles("slopes", slopes, x.size)
    M = m if m.ndim == 2 else m[None]
    z_ends = as_float_array("z_ends", z_ends, ndim=1, allow_nan=False)
    model = rigidity_model(x, z_start=z_ends[0], **model_options)
    Y = _slope_observations(M, z_ends[1])
    return m.ndim == 2, M.shape[0], model, [(rows, Y[rows]) for rows, _pat in _pattern_groups(np.isnan(M))]


def rigidity_log_likelihood_function(x, slopes, *, sigma: float = DEFAULT_SIGMA, sigma_z: float = DEFAULT_SIGMA_Z,
                                     z_ends=(0.0, 0.0), penalty_order: int = 2, segment_weights=None):
    r""":func:`rigidity_log_likelihood` as a function of r alone: ``loglik(r)``, float or (D,) ndarray.

    Q_i = q w_i Qbar(h_i) with q = r (x_N - x_1) / 2 is linear in r (Lemma 4.1 of paper 004, :func:`rigidity_model`),
    so the model is built and checked once, at r = 1, and each evaluation scales its process covariance
    (:func:`longprofile.statespace.process_scale_log_likelihood`): what the maximum-likelihood searches over r
    (:func:`~longprofile.rail.fit_change_prior`, the per-day prior fits) evaluate tens of times per profile.
    Equal to :func:`rigidity_log_likelihood` to round-off (r Q_1 against Q built at r).
    """
    batched, D, model, groups = _likelihood_inputs(x, slopes, z_ends, sigma=sigma, rigidity=1.0, sigma_z=sigma_z,
                                                   penalty_order=penalty_order, segment_weights=segment_weights)
    parts = [(rows, process_scale_log_likelihood(model, Y)) for rows, Y in groups]

    def loglik(r):
        ll = np.empty(D)
        for rows, f in parts:
            ll[rows] = f(r)
        return ll if batched else float(ll[0])

    return loglik


def _level_obs_cov(levels, sensor_factors, sigma_z: float, N: int) -> np.ndarray:
    """R of :func:`rigidity_model` for each noise level s_g (station noise s_g, or s_g f_i with per-sensor factors):
    (G, 2, 2) or (G, N, 2, 2), the same floating-point operations as the model's own R."""
    sz = require_positive("sigma_z", sigma_z)
    lv = as_float_array("noise levels", levels, ndim=1, allow_nan=False)
    if not np.all(lv > 0):
        raise InputError("the noise levels must be > 0.")
    if sensor_factors is None:
        R = np.zeros((lv.size, 2, 2))
        R[:, 0, 0] = [float(v) ** 2 for v in lv]
    else:
        R = np.zeros((lv.size, N, 2, 2))
        R[:, :, 0, 0] = (lv[:, None] * np.asarray(sensor_factors, float)[None, :]) ** 2
    R[..., 1, 1] = sz**2
    return R


def rigidity_log_likelihood_rows(x, slopes, *, levels, sigma_z: float = DEFAULT_SIGMA_Z, penalty_order: int = 2,
                                 sensor_factors=None, segment_weights=None, univariate: bool = False):
    r"""Log-likelihood of each profile at its own rigidity and noise level, as ``loglik(index, r)``.

    Profile d (row d of ``slopes``) has the slope noise std ``levels[d]`` (times f_i per station with
    ``sensor_factors``); ``loglik(index, r)`` returns log p(m_{index[j]} | r_j) for every j in one engine call
    (:func:`longprofile.statespace.grouped_log_likelihood`, each candidate its own group, Q linear in r as in
    :func:`rigidity_log_likelihood_function`). Equal bit for bit to
    ``rigidity_log_likelihood_function(x, slopes[d:d+1], sigma=levels[d] f)(r)`` (tested): what the per-day
    prior fits (:func:`~longprofile.rail.increment_rigidity`) evaluate for every day and candidate r together.
    ``univariate``: the engine's univariate treatment of the (diagonal) slope and anchor noises, about five times
    faster, equal to round-off.
    """
    x = _check_stations(x)
    M = _as_profiles("slopes", slopes, x.size)
    M = M if M.ndim == 2 else M[None]
    model = rigidity_model(x, sigma=1.0, rigidity=1.0, sigma_z=sigma_z, penalty_order=penalty_order,
                           segment_weights=segment_weights)
    R = _level_obs_cov(levels, sensor_factors, sigma_z, x.size)
    if R.shape[0] != M.shape[0]:
        raise ShapeError(f"levels must have one value per profile ({M.shape[0]},); got {R.shape[0]}.")
    Y = _slope_observations(M, 0.0)

    def loglik(index, r):
        index = np.asarray(index, dtype=np.int64)
        return grouped_log_likelihood(model, Y[index], np.arange(index.size), process_scale=r, obs_cov=R[index],
                                      univariate=univariate)

    return loglik


def rigidity_posterior_levels(x, slopes, group, *, levels, rigidity: float, sigma_z: float = DEFAULT_SIGMA_Z,
                              penalty_order: int = 2, sensor_factors=None, segment_weights=None,
                              noise_std: bool = False) -> tuple[StateSpaceModel, GroupedSmootherResult]:
    r"""The rigidity posterior of profiles in groups, group g with the slope noise std ``levels[g]`` (times f_i).

    One engine call (:func:`longprofile.statespace.grouped_covariance_smoother`) for what
    :func:`rigidity_posterior` gives group by group with ``sigma=levels[g] f``: each group's covariance pass, and
    its profiles' means through it, equal to round-off. With ``noise_std`` the result's ``noise_cov`` is each group's
    covariance from the slope noise alone (:func:`measurement_std`). Returns the model (its F, Q and P0 are every
    group's; its R is replaced by each group's) and the grouped result.
    """
    x = _check_stations(x)
    M = _as_profiles("slopes", slopes, x.size)
    M = M if M.ndim == 2 else M[None]
    model = rigidity_model(x, sigma=1.0, rigidity=rigidity, sigma_z=sigma_z, penalty_order=penalty_order,
                           segment_weights=segment_weights)
    R = _level_obs_cov(levels, sensor_factors, sigma_z, x.size)
    noise = None
    if noise_std:  # as measurement_std forms it
        noise = np.zeros(R.shape[:1] + (x.size, 2, 2))
        lv = np.asarray(levels, float)[:, None]
        noise[:, :, 0, 0] = (np.broadcast_to(lv, (lv.size, x.size)) if sensor_factors is None
                             else lv * np.asarray(sensor_factors, float)[None, :]) ** 2
    res = grouped_covariance_smoother(model, _slope_observations(M, 0.0), group, obs_cov=R, noise_cov=noise)
    return model, res


def segment_process_energy_levels(x, slopes, group, *, levels, rigidity: float, sigma_z: float = DEFAULT_SIGMA_Z,
                                  penalty_order: int = 2, sensor_factors=None, segment_weights=None) -> np.ndarray:
    r""":func:`segment_process_energy` of profiles in groups of one noise level each (``levels[g]`` times f_i), in one
    engine call: (D, N-1), row d the expected cost of profile d under its group's posterior."""
    model, res = rigidity_posterior_levels(x, slopes, group, levels=levels, rigidity=rigidity, sigma_z=sigma_z,
                                           penalty_order=penalty_order, sensor_factors=sensor_factors,
                                           segment_weights=segment_weights)
    x = np.asarray(x, float)
    _, Qbar = _iwp_terms(x, rigidity * (x[-1] - x[0]) / 2.0, _check_order(penalty_order))
    return process_noise_energy(model, res, np.linalg.inv(Qbar))


def segment_process_energy(x, slopes, *, sigma: float = DEFAULT_SIGMA, rigidity: float = DEFAULT_RIGIDITY,
                           sigma_z: float = DEFAULT_SIGMA_Z, penalty_order: int = 2, segment_weights=None) -> np.ndarray:
    r"""Posterior expected prior cost of each segment, E[e_i^T (q Qbar(l_i))^{-1} e_i | m], per profile.

    e_i = x_{i+1} - F(l_i) x_i is the process noise of segment i (module docstring: for penalty order 2 its cost
    e_i^T Qbar^{-1} e_i is ∫ f''^2 over the segment, Lemma 4.1 of paper 004), q = r L / 2 the stationary
    intensity. Under the prior with ``segment_weights`` w the expectation is k w_i (k = penalty_order, the state
    dimension), so this is the E-step statistic of an EM update of w (:func:`~longprofile.rail.segment_prior_weights`).

    Parameters
    ----------
    x : (N,) array_like
    slopes : (N,) or (D, N) array_like
        Measured slopes (rad), NaN = none.
    sigma, rigidity, sigma_z, penalty_order, segment_weights
        As in :func:`rigidity_posterior` (the posterior is taken under ``segment_weights``).

    Returns
    -------
    (N-1,) or (D, N-1) ndarray
        Dimensionless expected cost (k w_i on average when the prior is right).
    """
    x = _check_stations(x)
    N = x.size
    m = _as_profiles("slopes", slopes, N)
    batched = m.ndim == 2
    M = m if batched else m[None]
    model = rigidity_model(x, sigma=sigma, rigidity=rigidity, sigma_z=sigma_z, penalty_order=penalty_order,
                           segment_weights=segment_weights)
    _, Qbar = _iwp_terms(x, rigidity * (x[-1] - x[0]) / 2.0, _check_order(penalty_order))
    Qinv = np.linalg.inv(Qbar)
    Y = _slope_observations(M, 0.0)
    out = np.empty((M.shape[0], N - 1))
    for rows, _pat in _pattern_groups(np.isnan(M)):
        sm = shared_covariance_smoother(model, Y[rows])
        out[rows] = np.einsum("iab,diba->di", Qinv, process_noise_moments(model, sm))
    return out if batched else out[0]


def initial_profile_posterior_dense(x, altitudes, *, sigma_a: float = DEFAULT_SIGMA_A,
                                    rigidity: float = DEFAULT_RIGIDITY) -> ProfilePosterior:
    r"""Initial altitudes and angles from a survey at the stations, dense reference (paper 004 §4.4).

    pi(X | a) ∝ exp(-1/2 X^T C X - 1/(2 sigma_a^2) Σ (z_i - a_i)^2).

    Parameters
    ----------
    x : (N,) array_like
        Station positions, m.
    altitudes : (N,) array_like
        Surveyed altitudes a_i at the stations, m (NaN = not surveyed).
    sigma_a : float, default 2e-3
        Survey noise, m.
    rigidity : float
        r, m^-2.
    """
    x = _check_stations(x)
    N = x.size
    a = _as_profiles("altitudes", altitudes, N)
    sa = require_positive("sigma_a", sigma_a)
    obs = np.isfinite(a)
    if obs.sum() < 2:
        raise InputError("the initial profile needs at least 2 surveyed altitudes.")
    prec = rigidity_cost_matrix(x, rigidity=rigidity)
    idx = np.nonzero(obs)[0]
    prec[idx, idx] += 1.0 / sa**2
    rhs = np.zeros(2 * N)
    rhs[idx] = a[obs] / sa**2
    cov = np.linalg.inv(prec)
    cov = 0.5 * (cov + cov.T)
    return _dense_result(x, cov @ rhs, cov)


def initial_profile_posterior(x, survey_x, survey_z, *, sigma_a: float = DEFAULT_SIGMA_A,
                              rigidity: float = DEFAULT_RIGIDITY) -> ProfilePosterior:
    r"""Initial altitudes and slopes at the stations from a survey on any grid (paper 004 §4.4), O(N).

    Parameters
    ----------
    x : (N,) array_like
        Station (sensor) positions, m.
    survey_x, survey_z : (S,) array_like
        Survey positions and altitudes, m; any grid (e.g. every 10 m), at least 2 points.
    sigma_a : float, default 2e-3
        Survey noise, m.
    rigidity : float
        r, m^-2 (the normalising length L is the span of the stations and survey points).

    Returns
    -------
    ProfilePosterior
        At the N stations x: altitude and slope (the initial angles, arctan of the slope) with bands.

    Notes
    -----
    Instead of interpolating a coarse survey to the sensors (paper §5.1), the
    survey points become extra stations of the same rigidity model with observed
    altitude only; the RTS smoother then gives the altitudes and slopes at the
    sensors with bands that grow between survey points. When the survey is at the
    sensors this is the paper's §4.4 posterior (tested against the dense form).
    Altitudes are centred on the survey mean before filtering, and the first
    station gets the wide proper prior N(0, (100 m)^2) x N(0, (10 rad)^2).
    """
    x = _check_stations(x)
    sx = as_float_array("survey_x", survey_x, ndim=1, allow_nan=False)
    szv = as_float_array("survey_z", survey_z, ndim=1, allow_nan=False)
    if sx.shape != szv.shape or sx.size < 2:
        raise InputError(f"survey_x and survey_z must have the same length >= 2; got {sx.shape} and {szv.shape}.")
    sa = require_positive("sigma_a", sigma_a)
    r = require_positive("rigidity", rigidity)
    order = np.argsort(sx, kind="stable")
    sx, szv = sx[order], szv[order]
    if np.any(np.diff(sx) == 0):
        raise InputError("the survey has two altitudes at the same position; keep one per position.")
    allx = np.union1d(x, sx)
    center = float(szv.mean())
    q = r * (allx[-1] - allx[0]) / 2.0
    F, Q = _iwp_terms(allx, q)
    model = StateSpaceModel(transition=F, observation=np.array([[1.0, 0.0]]), process_cov=Q,
                            obs_cov=np.array([[sa**2]]), initial_mean=np.zeros(2),
                            initial_cov=np.diag([FIRST_ALTITUDE_PRIOR_STD**2, INITIAL_PROFILE_SLOPE_PRIOR_STD**2]))
    y = np.full((allx.size, 1), np.nan)
    y[np.searchsorted(allx, sx), 0] = szv - center
    sm = shared_covariance_smoother(model, y)
    at = np.searchsorted(allx, x)
    cov = sm.cov[at]
    # cross-covariances between consecutive sensors through intermediate survey stations:
    # Cov(x_a, x_b) = G_a G_{a+1} ... G_{b-1} P_b with G_k = cross_cov[k] P_{k+1}^{-1}
    G = np.linalg.solve(sm.cov[1:], np.swapaxes(sm.cross_cov, 1, 2))
    G = np.swapaxes(G, 1, 2)
    cc = np.empty((x.size - 1, 2, 2))
    for i in range(x.size - 1):
        A = np.eye(2)
        for k in range(at[i], at[i + 1]):
            A = A @ G[k]
        cc[i] = A @ sm.cov[at[i + 1]]
    mean = sm.mean[at]
    return ProfilePosterior(x=x, z_mean=mean[:, 0] + center, slope_mean=mean[:, 1], z_std=np.sqrt(cov[:, 0, 0]),
                            slope_std=np.sqrt(cov[:, 1, 1]), station_cov=cov, cross_cov=cc, full_cov=None,
                            log_likelihood=float(sm.filtered.log_likelihood), method="state-space")


def sample_profiles(x, slopes, n_samples: int, *, sigma: float = DEFAULT_SIGMA, rigidity: float = DEFAULT_RIGIDITY,
                    sigma_z: float = DEFAULT_SIGMA_Z, z_ends=(0.0, 0.0), rng=None, penalty_order: int = 2,
                    segment_weights=None) -> np.ndarray:
    r"""Draw altitude profiles from the rigidity posterior (forward-filter backward-sample on the engine).

    Parameters
    ----------
    x : (N,) array_like
        Stations, m.
    slopes : (N,) or (D, N) array_like
        Measured slopes, rad (NaN = none); one row per profile.
    n_samples : int
        Draws per profile.
    sigma, rigidity, sigma_z, z_ends, penalty_order, segment_weights
        As in :func:`rigidity_posterior`.
    rng : None, int or numpy.random.Generator

    Returns
    -------
    (n_samples, N) or (n_samples, D, N) ndarray
        Altitude draws, m.

    Notes
    -----
    Calls :func:`longprofile.statespace.posterior_sample` on :func:`rigidity_model`; the draws
    have the posterior mean and covariance of :func:`rigidity_posterior_dense` (tested).
    """
    x = _check_stations(x)
    N = x.size
    m = _as_profiles("slopes", slopes, N)
    z_ends = as_float_array("z_ends", z_ends, ndim=1, allow_nan=False)
    model = rigidity_model(x, sigma=sigma, rigidity=rigidity, sigma_z=sigma_z, z_start=z_ends[0],
                           penalty_order=penalty_order, segment_weights=segment_weights)
    Y = np.full(m.shape + (2,), np.nan)
    Y[..., 0] = m
    Y[..., -1, 1] = z_ends[1]
    return posterior_sample(model, Y, n_samples, rng=rng)[..., 0]


def max_settlement_monte_carlo(x, slopes, n_samples: int = 2000, *, sigma: float = DEFAULT_SIGMA,
                               rigidity: float = DEFAULT_RIGIDITY, sigma_z: float = DEFAULT_SIGMA_Z, rng=None,
                               penalty_order: int = 2, segment_weights=None):
    r"""Mean and std of the maximum settlement max_i(-dz_i) by posterior sampling (paper 004 §4.3).

    Parameters
    ----------
    x : (N,) array_like
        Stations, m.
    slopes : (N,) or (D, N) array_like
        Slope changes since the reference day, rad (ends anchored at 0).
    n_samples : int, default 2000
    sigma, rigidity, sigma_z, penalty_order, segment_weights
        As in :func:`rigidity_posterior`.
    rng : None, int or numpy.random.Generator

    Returns
    -------
    mean, std : float or (D,) ndarray
        Of the (non-Gaussian) maximum settlement, m (positive = downwards).
    """
    draws = sample_profiles(x, slopes, n_samples, sigma=sigma, rigidity=rigidity, sigma_z=sigma_z, rng=rng,
                            penalty_order=penalty_order, segment_weights=segment_weights)
    mx = -draws.min(axis=-1)
    mean, std = mx.mean(axis=0), mx.std(axis=0, ddof=1)
    return (float(mean), float(std)) if np.ndim(mean) == 0 else (mean, std)


@dataclass(frozen=True, eq=False)
class MaxSettlement:
    """The maximum settlement max_i(-dz_i) of each profile (day) from posterior draws (:func:`max_settlement_interval`).

    Attributes
    ----------
    mean, std : (D,) ndarray
        Monte Carlo mean and std of the maximum settlement, m (positive = downwards), as
        :func:`max_settlement_monte_carlo`.
    lower, upper : (D,) ndarray
        The interval of the maximum, m: max_i(-mu_i - c s_i) and max_i(-mu_i + c s_i).
    band_z : (D,) ndarray
        c, the half-width of the band in posterior stds.
    level : float
        Nominal level of the interval (0.9 for the printed 90 % interval).
    interval : str
        Its construction (:data:`MAX_SETTLEMENT_INTERVALS`): "draws" or "band".
    probability : float
        ``interval="draws"``: the share of the draws whose maximum the interval holds (:data:`MAX_SETTLEMENT_PROBABILITY`
        for the 90 % interval); ``interval="band"``: the probability of the simultaneous band (= ``level``).
    """

    mean: np.ndarray
    std: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    band_z: np.ndarray
    level: float
    interval: str = "band"
    probability: float = float("nan")


def max_settlement_interval(x, slopes, n_samples: int = 2000, *, sigma: float = DEFAULT_SIGMA,
                            rigidity: float = DEFAULT_RIGIDITY, sigma_z: float = DEFAULT_SIGMA_Z, rng=None,
                            penalty_order: int = 2, segment_weights=None, level: float = 0.9,
                            interval: str = "draws", probability: float | None = None) -> MaxSettlement:
    r"""Maximum settlement of each profile with an interval that holds wherever the maximum is (beyond §4.3).

    Paper 004 §4.3 estimates the maximum settlement max_i(-z_i) by posterior sampling; its mean ∓ 1.645 std is
    not a 90 % interval: the maximum of a Gaussian vector is skewed, and on a day without change (true maximum
    0, on every station) every draw's maximum is a positive noise excursion, so the truth lies below all draws
    (and so below any quantile of the draws' maxima). The interval here has the shape of a band around the
    posterior mean (mu, s: posterior mean and std at the stations): since max is monotone,

        [L(c), U(c)] = [max_i(-mu_i - c s_i), max_i(-mu_i + c s_i)]

    holds the maximum of every profile inside the band [mu - c s, mu + c s], whatever station carries it; on a
    quiet day its lower end is <= 0 unless the posterior mean dips below -c s somewhere. Two choices of c
    (``interval``, :func:`max_settlement_from_draws`): "draws" (default), the smallest c for which the maximum of
    a share ``probability`` of the posterior draws lies in [L(c), U(c)]; "band", the ``level`` quantile over
    draws of max_i |z_i - mu_i| / s_i, i.e. the simultaneous band of the whole profile, of probability >=
    ``level`` for the maximum (conservative: the two ends need not be reached by one draw; the printed interval
    until 2026-12-06).

    Parameters
    ----------
    x, slopes, n_samples, sigma, rigidity, sigma_z, rng, penalty_order, segment_weights
        As in :func:`max_settlement_monte_carlo`.
    level : float, default 0.9
        Nominal level, 0 < level < 1 (``interval="band"``: the probability of the simultaneous band).
    interval : {"draws", "band"}, default "draws"
    probability : float or None
        ``interval="draws"``: the share of draws whose maximum the interval holds; None gives
        :data:`MAX_SETTLEMENT_PROBABILITY` (0.98, calibrated for ``level=0.9`` only: other levels need it given).

    Returns
    -------
    MaxSettlement
        (D,) arrays (a single profile gives (1,) arrays).
    """
    _check_max_interval(level, interval, probability)
    m = np.atleast_2d(np.asarray(slopes, float))
    post = rigidity_posterior(x, m, sigma=sigma, rigidity=rigidity, sigma_z=sigma_z, penalty_order=penalty_order,
                              segment_weights=segment_weights)
    draws = sample_profiles(x, m, n_samples, sigma=sigma, rigidity=rigidity, sigma_z=sigma_z, rng=rng,
                            penalty_order=penalty_order, segment_weights=segment_weights)  # (S, D, N)
    return max_settlement_from_draws(draws, post.z_mean, post.z_std, level=level, interval=interval,
                                     probability=probability)


def _check_max_interval(level, interval, probability) -> float:
    """Validate the interval options; the share of draws to hold (the band's level for "band")."""
    if not 0.0 < level < 1.0:
        raise InputError(f"level must be in (0, 1); got {level!r}.")
    if interval not in MAX_SETTLEMENT_INTERVALS:
        raise InputError(f"interval must be one of {MAX_SETTLEMENT_INTERVALS}; got {interval!r}.")
    if interval == "band":
        if probability is not None:
            raise InputError("probability applies to interval='draws' only; the band's probability is level.")
        return float(level)
    if probability is None:
        if level != 0.9:
            raise InputError(f"interval='draws' is calibrated for level 0.9 only (probability "
                             f"{MAX_SETTLEMENT_PROBABILITY}); give probability= for level {level!r}.")
        return MAX_SETTLEMENT_PROBABILITY
    if not 0.0 < probability < 1.0:
        raise InputError(f"probability must be in (0, 1); got {probability!r}.")
    return float(probability)


def max_settlement_from_draws(draws, mean, std, *, level: float = 0.9, interval: str = "draws",
                              probability: float | None = None) -> MaxSettlement:
    r"""The maximum settlement and its interval (:func:`max_settlement_interval`) from given draws.

    Parameters
    ----------
    draws : (S, D, N) array_like
        Posterior draws of D profiles at N stations, m.
    mean, std : (D, N) array_like
        Their posterior means and stds, m (stations of std 0 do not widen the band).
    level, interval, probability
        As in :func:`max_settlement_interval`.

    Returns
    -------
    MaxSettlement

    Notes
    -----
    ``interval="draws"``: with M_j = max_i(-z_ij) the maximum of draw j, M_j <= U(c) iff c >= min_i (M_j + mu_i)/s_i
    (or a station of std 0 has -mu_i >= M_j) and M_j >= L(c) iff c >= max_i (-mu_i - M_j)/s_i, so draw j is held
    from c_j = max(0, both bounds) on; c is the ceil(p S)-th smallest c_j (the fraction of draws held is
    non-decreasing in c), the smallest c holding a share >= p of the draws. It is <= the band's c at the same
    probability: a draw inside the band has its maximum inside [L, U].
    """
    p = _check_max_interval(level, interval, probability)
    draws = np.asarray(draws, float)
    mu, sd = np.asarray(mean, float), np.asarray(std, float)
    mx = -draws.min(axis=-1)  # (S, D)
    pos = sd > 0
    if interval == "band":
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(pos, np.abs(draws - mu) / sd, 0.0).max(axis=-1)  # (S, D)
        c = np.quantile(t, level, axis=0)
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            up = np.where(pos, (mx[..., None] + mu) / sd, np.where(-mu >= mx[..., None], 0.0, np.inf)).min(axis=-1)
            low = np.where(pos, (-mu - mx[..., None]) / sd, np.where(-mu <= mx[..., None], 0.0, np.inf)).max(axis=-1)
        cj = np.maximum(np.maximum(up, low), 0.0)  # (S, D)
        k = max(int(np.ceil(p * cj.shape[0] - 1e-9)) - 1, 0)
        c = np.partition(cj, k, axis=0)[k]
    return MaxSettlement(mean=mx.mean(axis=0), std=mx.std(axis=0, ddof=1),
                         lower=np.max(-mu - c[:, None] * sd, axis=-1), upper=np.max(-mu + c[:, None] * sd, axis=-1),
                         band_z=c, level=float(level), interval=interval, probability=p)


def measurement_std(x, slopes, *, sigma: float = DEFAULT_SIGMA, rigidity: float = DEFAULT_RIGIDITY,
                    sigma_z: float = DEFAULT_SIGMA_Z, penalty_order: int = 2, segment_weights=None) -> np.ndarray:
    r"""Std of the posterior-mean altitude due to the slope measurement noise alone, at every station.

    The posterior mean is linear in the slopes, mu_z = A m (+ anchor terms), so for a given
    true profile its error from the measurement noise has covariance sigma^2 A A^T. This is the
    frequentist ("measurement") uncertainty of the estimate for a FIXED true profile: it leaves out
    the smoothing bias and the prior's uncertainty about the track between sensors, which the
    posterior std (:class:`ProfilePosterior`) includes. It is a lower bound of the error, reported
    as an extra column; the bands use the posterior std (docs/rail.md).

    Parameters
    ----------
    x : (N,) array_like
    slopes : (N,) or (D, N) array_like
        Only the NaN pattern (which sensors measured) matters.
    sigma, rigidity, sigma_z, penalty_order, segment_weights
        As in :func:`rigidity_posterior`.

    Returns
    -------
    (N,) or (D, N) ndarray
        sigma * sqrt(diag(A A^T)), m, in O(N) per missing pattern
        (:func:`longprofile.statespace.smoother_noise_covariance`; the end anchor is an exact
        constraint of the truth, so only the slope noise drives the error).
    """
    x = _check_stations(x)
    N = x.size
    m = _as_profiles("slopes", slopes, N)
    batched = m.ndim == 2
    M = m if batched else m[None]
    s = _noise_std(sigma, N)
    model = rigidity_model(x, sigma=s, rigidity=rigidity, sigma_z=sigma_z, penalty_order=penalty_order,
                           segment_weights=segment_weights)
    noise = np.zeros((N, 2, 2))
    noise[:, 0, 0] = np.broadcast_to(s, (N,)) ** 2
    pattern = np.isnan(M)
    out = np.empty(M.shape)
    for rows, pat in _pattern_groups(pattern):
        y = np.full((N, 2), np.nan)
        y[:, 0] = np.where(pat, np.nan, 0.0)
        y[-1, 1] = 0.0
        S = smoother_noise_covariance(model, y, noise_cov=noise)
        out[rows] = np.sqrt(np.maximum(S[:, 0, 0], 0.0))
    return out if batched else out[0]
