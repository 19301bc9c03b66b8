"""Evidence of a reversal under a prior whose slope is smooth (docs/rail.md, "Sensor health, step 20").

Beyond paper 004 (§6 flags improbable sensors). The health tests predict a sensor from its neighbours through the
paper's order-2 prior (π(f) ∝ exp(−‖f″‖²/r): the slope is a Brownian path along the track), which interpolates a
flank sensor's slope change almost linearly between its neighbours: on a narrow bowl it under-predicts the flank, and
a reversed flank sensor shows little evidence (issue 13's missed reversals). The order-3 prior (π(f) ∝
exp(−‖f‴‖²/r), the twice-integrated Wiener process of docs/rail.md, "Two priors for the change") has a smooth slope
and follows the flank's curvature: on the benchmark's missed reversals the information Σ μ²/v rose from 6–9 to
11–33 on four of eight. Its predictions are over-confident where the settlement is not that smooth (asymmetric
bowls, a ramp's kinks), so its healthy tail is heavy: each all-days mode's predictive variance is scaled by what the
site's own kept sensors' leave-one-out residuals show (their median squared standardised residual over the median
of chi-square(1), at least 1), and the test only adds a reversal far above every healthy calibration sensor
(:data:`REVERSED_SMOOTH_LBF`), with the day-to-day ratio agreeing (:data:`REVERSED_SMOOTH_INC_LLR`).
"""

from __future__ import annotations

import numpy as np

from ._health import _flag_worst, _mode_loo
from ._results import ReversalEvidence, SensorHealth
from ._rigidity import DEFAULT_SIGMA_Z, rigidity_log_likelihood_rows

__all__ = ["smooth_reversal_evidence", "smooth_candidates", "flag_reversed_smooth", "REVERSED_SMOOTH_LBF",
           "REVERSED_SMOOTH_INC_LLR"]

#: A kept sensor is "reversed" when its calibrated smooth-slope log Bayes factor (:func:`smooth_reversal_evidence`)
#: exceeds this ... Calibration seeds (docs/rail.md, "Sensor health, step 20"; the statistics of the kept sensors at the
#: last all-days health pass, faults 300-499, faults-asymmetric 300-379, faults-two-bowls and faults-ramp 300-339,
#: 8 949 healthy kept sensors): the largest healthy value with the day-to-day ratio above 5 was 18.4 (an asymmetric
#: bowl); 20 is the round number above it. Of the 20 reversals the other tests kept there it flags one (faults seed 415,
#: 26.1, ratio 9.7).
REVERSED_SMOOTH_LBF = 20.0
#: ... and its day-to-day reversal log-likelihood ratio exceeds this (times the record-length factor,
#: :func:`~longprofile.rail._health.record_length_factor`): the work nights' changes point to a reversal too (the
#: value of :data:`~longprofile.rail._health.REVERSED_Z_GATE_LLR` and of the shape test's gate).
REVERSED_SMOOTH_INC_LLR = 5.0
#: Median of chi-square with one degree of freedom: a healthy sensor's squared standardised residual's median.
_CHI2_1_MEDIAN = 0.45493642311957283
#: Grid of r (m⁻⁴) searched for the order-3 prior's maximum likelihood over the all-days modes (3 per decade).
_RIGIDITY_GRID = np.geomspace(1e-16, 1e-4, 37)


def _smooth_rigidity(x, Y, mode_noise, f, sigma_z) -> float:
    """r of the order-3 prior maximising the marginal likelihood of all the modes' data (one r for every mode, as the
    all-days model's ``DayModes.rigidity``), on :data:`_RIGIDITY_GRID`: one engine call."""
    K = Y.shape[0]
    loglik = rigidity_log_likelihood_rows(x, Y, levels=mode_noise, sigma_z=sigma_z, penalty_order=3, sensor_factors=f)
    G = _RIGIDITY_GRID.size
    ll = np.asarray(loglik(np.tile(np.arange(K), G), np.repeat(_RIGIDITY_GRID, K)), float).reshape(G, K).sum(axis=1)
    return float(_RIGIDITY_GRID[int(np.argmax(np.nan_to_num(ll, nan=-np.inf)))])


def smooth_reversal_evidence(x, mode_slopes, mode_noise, *, sensor_factors=None,
                             sigma_z: float = DEFAULT_SIGMA_Z) -> ReversalEvidence:
    r"""Log Bayes factor of "sensor i is reversed" against "healthy" under the smooth-slope (order-3) prior, its
    predictive variance calibrated on the site's own sensors.

    As :func:`~longprofile.rail._health.all_days_reversal_evidence` (the all-days modes y_ik, leave-one-out mean
    mu_ik and variance v_ik from the other sensors) with the order-3 prior at its maximum-likelihood r over the modes,
    and each mode's variance times c_k = max(1, median_i (y_ik - mu_ik)^2 / v_ik / 0.4549) over the kept sensors
    (0.4549: the median of chi-square(1), so that c_k = 1 where the prior predicts the healthy sensors as it says):

        log BF_i = -2 sum_k y_ik mu_ik / (c_k v_ik),  information I_i = sum_k mu_ik^2 / (c_k v_ik).

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    mode_slopes : (K, N) ndarray
        The modes' data (``DayModes.to_modes @ slopes[1:]``, rad; NaN columns = excluded sensors).
    mode_noise : (K,) ndarray
        sqrt(nu_k) of each mode (``DayModes.noise``), rad.
    sensor_factors : (N,) array_like, optional
        f_i (default 1).
    sigma_z : float
        End-anchor std, m.

    Returns
    -------
    ReversalEvidence
        NaN for excluded sensors.
    """
    Y = np.asarray(mode_slopes, float)
    K, N = Y.shape
    f = np.ones(N) if sensor_factors is None else np.asarray(sensor_factors, float)
    noise = np.asarray(mode_noise, float)
    r = _smooth_rigidity(x, Y, noise, f, sigma_z)
    mus, preds, own = _mode_loo(x, Y, noise, f, rigidity=r, penalty_order=3, segment_weights=None, sigma_z=sigma_z)
    v = preds + own * f**2
    gone = np.isnan(Y).all(axis=0)
    with np.errstate(invalid="ignore"):
        ratio = np.where(gone[None, :], np.nan, (Y - mus) ** 2 / v)
    c = np.maximum(1.0, np.nanmedian(ratio, axis=1) / _CHI2_1_MEDIAN)[:, None] if (~gone).any() else np.ones((K, 1))
    lbf = np.sum(-2.0 * Y * mus / (c * v), axis=0)
    info = np.sum(mus**2 / (c * v), axis=0)
    return ReversalEvidence(log_bayes_factor=np.where(gone, np.nan, lbf), information=np.where(gone, np.nan, info))


def smooth_candidates(health: SensorHealth) -> np.ndarray:
    """(N,) bool: the kept sensors whose day-to-day reversal log-likelihood ratio exceeds
    :data:`REVERSED_SMOOTH_INC_LLR` times their record-length factor: the only ones the smooth-slope test can flag
    (the caller computes its evidence only when there is one)."""
    N = health.status.size
    if health.reversal_llr is None:
        return np.zeros(N, bool)
    inc = np.nan_to_num(health.reversal_llr, nan=-np.inf)
    lf = np.ones(N) if health.reversal_llr_scale is None else np.asarray(health.reversal_llr_scale, float)
    return ~np.asarray(health.excluded, bool) & (inc > REVERSED_SMOOTH_INC_LLR * lf)


def flag_reversed_smooth(health: SensorHealth, evidence: ReversalEvidence,
                         max_flagged: int | None = None) -> tuple[SensorHealth, int | None]:
    """Flag the kept candidate (:func:`smooth_candidates`) of largest smooth-slope log Bayes factor
    (:func:`smooth_reversal_evidence`) if it exceeds :data:`REVERSED_SMOOTH_LBF`: status "reversed", excluded; one
    sensor at a time and the limits of :func:`~longprofile.rail._health.flag_reversed_all_days`.

    Returns
    -------
    health : SensorHealth
        With the flagged sensor's status, detail and exclusion.
    flagged : int or None
        Index of the flagged sensor.
    """
    lbf = np.nan_to_num(np.asarray(evidence.log_bayes_factor, float), nan=-np.inf)
    inc = np.nan_to_num(health.reversal_llr, nan=-np.inf) if health.reversal_llr is not None else lbf * np.nan
    passes = smooth_candidates(health) & (lbf > REVERSED_SMOOTH_LBF)

    def detail(j):
        return (f"all days, with a smooth-slope settlement prior (order 3, its predictive variance scaled to this "
                f"site's sensors): log Bayes factor of 'reversed' against 'healthy' {lbf[j]:.3g} (threshold "
                f"{REVERSED_SMOOTH_LBF:g}; information {evidence.information[j]:.3g}), day-to-day reversal "
                f"log-likelihood ratio {inc[j]:.3g} (> {REVERSED_SMOOTH_INC_LLR:g})")

    return _flag_worst(health, lbf, passes, "reversed", detail, max_flagged)
