"""Localised settlement shapes and the evidence of a reversed sensor (issue 13; docs/rail.md, "Sensor health, step 14").

Beyond paper 004. The all-days reversal evidence (:func:`~longprofile.rail._health.all_days_reversal_evidence`)
predicts a sensor's slope changes from its neighbours through the smooth, nonparametric change prior of §4.2: a
sensor on the flank of a narrow bowl is predicted poorly from neighbours 2-6 m away, so a reversal there shows little.
Settlement from nearby works is localised: a dip of some centre and width, whose depth grows over the days. A
dictionary of such shapes, fitted to the other sensors all along the track (both flanks of the dip pin its centre and
width), predicts the flank much better — without assuming any one shape: the dictionary holds several families (a
Gaussian, a Cauchy dip, a Gaussian of different widths on each side, a flat-bottomed dip with smooth edges), and
every fit also has a uniform slope change (a tilt of the whole span). Used by ``estimate_settlement`` with
``SettlementSettings(shape_evidence=True)`` (off by default; docs/rail.md step 14 says why).

Model of the all-days modes (module :mod:`~longprofile.rail._joint`: the modes k are independent, sensor i of mode k
has noise std sqrt(nu_k) f_i): y_ik = a_k g(x_i) + b_k + e_ik, g one shape's slope profile of the dictionary, a_k, b_k
free per mode (weighted least squares, weights w_i = 1/f_i^2). For sensor j the shapes are weighed by the *other*
sensors: shape g gets the weight exp L_j(g), their profile likelihood sum_k [-(n-1)/2 log s_k^2 - Q_k^(-j) / (2 s_k^2)],
Q_k^(-j) their weighted residual sum of squares and s_k^2 = max(Q_k^(-j) / (n - 1), nu_k) (the noise of a mode is at
least the all-days model's; a shape that fits the settlement badly inflates it). Each shape predicts sensor j's mode
data with mean mu_jk(g) and variance v_jk(g) = S_k^2 / (w_j (1 - h_jj)) + (SHAPE_REL_ERR mu_jk)^2,
S_k^2 = max(Q_k^(-j) / (n - 3), nu_k) (the others' noise through the fit, and the shape's own error), and

    log BF_j = log sum_g e^{L_j(g)} prod_k N(-y_jk; mu_jk, v_jk) - log sum_g e^{L_j(g)} prod_k N(y_jk; mu_jk, v_jk),

the Bayes factor of the two discrete alternatives under the dictionary's mixture (a flat prior over the shapes, each
at its best amplitudes: the evidence is shared among the shapes that fit the others about as well, so one shape's
extrapolation does not decide). Sensor j's own data weigh no shape: a sensor next to the centre of a dip, whose sign only
says on which side of it it sits, gets a spread prediction and little evidence either way. ``information`` is
sum_k mu_jk^2 / v_jk of the best-weighted shape. All sensors and shapes from one weighted least-squares fit per shape
(deletion identities: the leave-one-out residual r_j / (1 - h_jj), Q^(-j) = Q - w_j r_j^2 / (1 - h_jj)). Only dense
algebra over the stations; no recursion (the modes come from the engine's all-days fit).
"""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

from ._results import ShapeEvidence

__all__ = ["DICTIONARY_FAMILIES", "ShapeEvidence", "localized_slope_shapes", "shape_reversal_evidence"]

#: Families of the shape dictionary (:func:`localized_slope_shapes`).
DICTIONARY_FAMILIES = ("gaussian", "cauchy", "asymmetric", "flat-bottom")
#: Widths (m) of the dictionary: log-spaced over this range ...
SHAPE_WIDTHS_M = (1.5, 30.0)
#: ... on this many values (the asymmetric family uses every other one on each side).
SHAPE_N_WIDTHS = 10
#: Step of the centres over the span, m.
SHAPE_CENTRE_STEP_M = 0.5
#: Relative error of a shape's prediction (no dictionary shape is the settlement's): the predictive variance of a
#: sensor's mode data gets (SHAPE_REL_ERR mu)^2, as the day-to-day test's PRED_REL_ERR (:mod:`~longprofile.rail._health`).
SHAPE_REL_ERR = 0.15
#: Shapes fitted per chunk (memory: chunk x K x N doubles).
_CHUNK = 1024


def localized_slope_shapes(x) -> tuple[np.ndarray, np.ndarray]:
    """Slope profiles g(x_i) (derivative of a unit dip) of the shape dictionary, each scaled to max |g| = 1.

    Families (:data:`DICTIONARY_FAMILIES`), u = (x - c) / w, centres c every :data:`SHAPE_CENTRE_STEP_M` over the span,
    widths w on :data:`SHAPE_N_WIDTHS` log-spaced values over :data:`SHAPE_WIDTHS_M`: the Gaussian exp(-u^2/2); the
    Cauchy dip 1 / (1 + u^2) (heavier flanks); the Gaussian with one width left of c and another right (every other
    width of the grid, each pair); the flat-bottomed dip (tanh(u + h) - tanh(u - h)) / 2, half-length h in
    {0.5, 1, 2, 4} widths (a trough, or a long one: a step at each end).

    Returns
    -------
    g : (S, N) ndarray
        One shape per row; rows with no slope at any station are dropped.
    family : (S,) ndarray of int
        Index into :data:`DICTIONARY_FAMILIES`.
    """
    x = np.asarray(x, float)
    c = np.arange(x[0], x[-1] + 1e-9, SHAPE_CENTRE_STEP_M)
    w = np.geomspace(*SHAPE_WIDTHS_M, SHAPE_N_WIDTHS)
    d = x[None, None, :] - c[:, None, None]  # (C, 1, N)
    u = d / w[None, :, None]  # (C, W, N)
    out = [u * np.exp(-0.5 * u**2), u / (1.0 + u**2) ** 2]
    ws = w[::2]
    d4 = d[:, :, None, :]  # (C, 1, 1, N)
    ua = d4 / np.where(d4 < 0, ws[None, :, None, None], ws[None, None, :, None])  # (C, Wl, Wr, N)
    out.append((ua * np.exp(-0.5 * ua**2)).reshape(c.size, -1, x.size))
    for h in (0.5, 1.0, 2.0, 4.0):
        out.append(1.0 / np.cosh(u - h) ** 2 - 1.0 / np.cosh(u + h) ** 2)
    g = np.concatenate([np.concatenate([o.reshape(-1, x.size) for o in out[:3]]),
                        np.concatenate([o.reshape(-1, x.size) for o in out[3:]])])
    fam = np.concatenate([np.full(out[0][..., 0].size, 0), np.full(out[1][..., 0].size, 1),
                          np.full(out[2][..., 0].size, 2), np.full(sum(o[..., 0].size for o in out[3:]), 3)])
    scale = np.max(np.abs(g), axis=1)
    keep = scale > 1e-6
    return g[keep] / scale[keep, None], fam[keep]


def shape_reversal_evidence(x, mode_slopes, mode_noise, sensor_factors=None, shapes=None,
                            sensors=None) -> ShapeEvidence:
    """Log Bayes factor of "sensor j is reversed" against "healthy" for every sensor, its slope changes predicted from
    the other sensors through a dictionary of localised settlement shapes fitted in each all-days mode (module
    docstring).

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    mode_slopes : (K, N) ndarray
        The all-days modes' data (``DayModes.to_modes @ slopes[1:]``, rad; NaN columns = excluded sensors).
    mode_noise : (K,) array_like
        sqrt(nu_k) of each mode (``DayModes.noise``), rad: the least noise std of a sensor of factor 1.
    sensor_factors : (N,) array_like, optional
        f_i (default 1): sensor i's noise std relative to the others'.
    shapes : (S, N) ndarray, optional
        The dictionary (default :func:`localized_slope_shapes` of ``x``, then its families are reported).
    sensors : (N,) bool array_like, optional
        The sensors whose evidence is wanted (default all; the others get NaN; every kept sensor is fitted).

    Returns
    -------
    ShapeEvidence
    """
    Y = np.asarray(mode_slopes, float)
    K, N = Y.shape
    ok = np.isfinite(Y).all(axis=0)
    f = np.ones(N) if sensor_factors is None else np.asarray(sensor_factors, float)
    fam = None
    if shapes is None:
        shapes, fam = localized_slope_shapes(x)
    g = np.asarray(shapes, float)[:, ok]
    y, w = Y[:, ok], 1.0 / f[ok] ** 2
    want = np.ones(N, bool) if sensors is None else np.asarray(sensors, bool)
    cand = np.nonzero(want[ok])[0]
    floor = np.asarray(mode_noise, float) ** 2
    acc = np.full((3, cand.size), -np.inf)  # log-sum-exp over the shapes of the data as read, flipped; best weight
    info, arg = np.full(cand.size, np.nan), np.full(cand.size, -1)
    cols = np.arange(cand.size)
    for s0 in range(0, g.shape[0], _CHUNK):
        L, lp, lm, i = _chunk_loo(g[s0:s0 + _CHUNK], y, w, cand, floor)
        acc[0] = np.logaddexp(acc[0], logsumexp(L + lp, axis=0))
        acc[1] = np.logaddexp(acc[1], logsumexp(L + lm, axis=0))
        top = np.argmax(L, axis=0)
        better = L[top, cols] > acc[2]
        acc[2] = np.where(better, L[top, cols], acc[2])
        info, arg = np.where(better, i[top, cols], info), np.where(better, s0 + top, arg)
    lbf = acc[1] - acc[0]
    out = np.full((3, N), np.nan)
    idx = np.nonzero(ok)[0][cand]
    out[0, idx], out[1, idx] = lbf, info
    family = np.full(N, -1)
    if fam is not None:
        family[idx] = fam[arg]
    return ShapeEvidence(log_bayes_factor=out[0], information=out[1], family=family)


def _chunk_loo(g, y, w, cand, floor):
    """For a chunk of shapes g (S, n) on data y (K, n), weights w (n,), and each sensor j of ``cand``: the other
    sensors' profile log-likelihood L (S, c), the log predictive density of sensor j's data as read and with its sign
    flipped, and the information (S, c each) (module docstring; deletion identities from the fit of all the sensors)."""
    n = y.shape[1]
    a11, a12, a22 = (g**2) @ w, g @ w, float(w.sum())
    det = a11 * a22 - a12**2
    flat = det <= 1e-9 * a11 * a22  # a shape (nearly) constant over the kept stations: a tilt, already fitted
    det = np.where(flat, 1.0, det)
    u1, u2 = (g * w) @ y.T, y @ w  # (S, K), (K,)
    Q = (y**2) @ w - (a22 * u1**2 - 2.0 * a12[:, None] * u1 * u2 + a11[:, None] * u2**2) / det[:, None]  # (S, K)
    b1 = (a22 * u1 - a12[:, None] * u2[None]) / det[:, None]
    b0 = (a11[:, None] * u2[None] - a12[:, None] * u1) / det[:, None]
    gc, yc, wc = g[:, cand], y[:, cand], w[cand]
    lev = np.minimum(wc[None] * (a22 * gc**2 - 2.0 * a12[:, None] * gc + a11[:, None]) / det[:, None], 1.0 - 1e-9)
    e = (yc[None] - b1[:, :, None] * gc[:, None, :] - b0[:, :, None]) / (1.0 - lev)[:, None, :]  # (S, K, c) LOO
    Qm = np.maximum(Q[:, :, None] - wc * e**2 * (1.0 - lev)[:, None, :], 0.0)  # the others' residual sum of squares
    fl = np.maximum(floor, 1e-300)[None, :, None]
    var = np.maximum(Qm / (n - 1), fl)
    L = np.sum(-0.5 * (n - 1) * np.log(var) - 0.5 * Qm / var, axis=1)  # (S, c)
    mu = yc[None] - e
    # predictive variance of y_jk: the others' noise through the fit, and the shape's own error on the prediction
    v = np.maximum(Qm / max(n - 3, 1), fl) / (wc * (1.0 - lev))[:, None, :] + (SHAPE_REL_ERR * mu) ** 2
    base = -0.5 * np.sum(np.log(2.0 * np.pi * v) + (yc**2)[None] / v + mu**2 / v, axis=1)
    cross = np.sum(yc[None] * mu / v, axis=1)
    drop = flat[:, None] | ~np.isfinite(L) | ~np.isfinite(base) | ~np.isfinite(cross)
    return (np.where(drop, -np.inf, L), np.where(drop, 0.0, base + cross), np.where(drop, 0.0, base - cross),
            np.where(drop, 0.0, np.sum(mu**2 / v, axis=1)))
