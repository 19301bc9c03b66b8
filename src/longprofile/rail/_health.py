"""Sensor health (paper 004 §6): flag sensors whose readings are improbable under the rigidity model.

Every sensor ends with a status and a sentence; flagged sensors are excluded from the
settlement and listed in every output — never dropped silently.

Statuses
--------
ok          readings consistent with the model
dead        no readings, readings on fewer than half of the days, or a stuck value (robust spread of
            the raw readings below the sensors' 1e-4 deg resolution) from the first day
frozen      stuck within each of FROZEN_MIN_DAYS consecutive days (a channel that stopped updating
            mid-record: its readings before are real, after it the same value; left out as a dead one),
            also when it was stuck for most of the record after days of normal readings
late        no daily angle on the reference day (installed, or first read, after it)
reversed    its angle changes follow minus what its neighbours predict (mounted backwards): the
            reversal z of the daily changes when the day-to-day log-likelihood ratio or the all-days Bayes factor
            agrees (step 16: the z treats the days as independent), or the day-to-day log-likelihood ratio, or (with the
            all-days noise model) the all-days Bayes factor of "reversed" against "healthy"
            (:func:`all_days_reversal_evidence`, :func:`flag_reversed_all_days`), or the Bayes factor of a
            reversal with the sensor predicted by a dictionary of localised settlement shapes fitted to the other
            sensors (:func:`~longprofile.rail._shapes.shape_reversal_evidence`), the all-days statistics not against
drifting    its leave-one-out residual grows linearly with time
detached    its leave-one-out residual jumps once and stays (sensor came loose / moved): the
            day-to-day step statistic, or the pattern of an improbable sensor, or (with the all-days noise
            model) the all-days step log-likelihood ratio (:func:`all_days_step_evidence`,
            :func:`flag_detached_all_days`)

improbable  residuals far beyond the noise level without one of the patterns above
excluded    excluded by the user (``exclude``; ``rail settle --exclude``, the service's site setting
            ``exclude``): not tested, not a fault
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
from scipy.special import gammaincc

from ..errors import InputError
from ._results import ReversalEvidence, SensorHealth, StepEvidence
from ._rigidity import DEFAULT_SIGMA_Z, rigidity_posterior, rigidity_posterior_levels
from ._shapes import ShapeEvidence

__all__ = ["SensorHealth", "assess_sensors", "SENSOR_STATUSES", "loo_residuals", "ReversalEvidence", "StepEvidence",
           "all_days_step_evidence", "flag_detached_all_days",
           "all_days_reversal_evidence", "flag_reversed_all_days", "shape_candidates", "SHAPE_RULES",
           "REVERSAL_Z_RULES", "WITNESS_RULES", "step_witness_z", "site_reversal_null", "REVERSAL_NULLS",
           "record_length_factor", "REFERENCE_CHANGES", "UNUSABLE_STATUSES", "USER_EXCLUDED", "flag_limit",
           "n_flagged"]

SENSOR_STATUSES = ("ok", "dead", "frozen", "late", "reversed", "drifting", "detached", "improbable", "excluded")
#: Statuses of sensors whose record cannot enter the estimate, whatever the health tests say: no usable reading
#: ("dead": none, stuck; "frozen": stuck from some day on) or none on the reference day ("late": installed, or first
#: read, after it). The user's exclusions ("excluded") are not among them, and are not counted either where the health
#: tests count their flags (:func:`n_flagged`), nor among the sensors whose quarter they may flag (:func:`flag_limit`).
UNUSABLE_STATUSES = ("dead", "frozen", "late")
#: Status of a sensor the user excluded (``assess_sensors(exclude=...)``, ``rail settle --exclude``): not a health
#: test's verdict, so the service raises no health alarm for it.
USER_EXCLUDED = "excluded"
#: Resolution of the sensors (paper 004 §1.3), deg: a stuck sensor's readings spread less.
DEAD_SPREAD_DEG = 1e-4
#: Family-wise false-alarm probability of the chi-square test on a sensor's LOO residuals.
IMPROBABLE_P = 1e-6
#: ... and the mean squared standardised LOO residual must also exceed this (RMS z > 3). The
#: daily changes of one sensor share the reference day's error, so its days are not independent
#: and the chi-square test alone over-flags (seen on the farebersviller-like preset).
IMPROBABLE_SCORE = 14.0  # was 9; 14 on calibration seeds (faults 300-399, other families 300-311): drift FAs 7 -> 3
#: Reversal test: a sensor is flagged "reversed" when z_rev = -sum_d m_d mu_d / sqrt(sum_d mu_d^2 v_d) exceeds
#: this (m its changes, mu and v the leave-one-out prediction from the neighbours and its variance) and
#: sum (m + mu)^2 < 0.25 sum (m - mu)^2 (minus the prediction explains the changes). Set from
#: the healthy sensors of the "faults" scenario family (docs/rail.md, "Calibration on independent scenarios").
REVERSED_Z = 8.0
#: Gate of the reversal z (step 16, ``reversal_z_rule="gated"``): z_rev above :data:`REVERSED_Z` flags a sensor only
#: when its day-to-day reversal log-likelihood ratio (:data:`REVERSED_LLR`'s statistic) also exceeds this. z_rev treats
#: the days as independent, but a sensor's changes since day 0 share the reference day's error and accumulate its
#: random-walk drift, so their errors are strongly correlated over the days and Var(sum_d mu_d e_d) is many times
#: sum_d mu_d^2 v_d: on the no-settlement sites (faults-none, calibration seeds 300-339) the healthy sensors' z_rev has
#: a robust std of 2.9 instead of 1 and 32 of 1033 have |z_rev| > 8. The day-to-day changes remove the shared error and
#: whiten the random walk, so their ratio is the test that respects the dependence; the z test now only adds its power
#: where the increments point to a reversal too (odds above e^5 ~ 150), or, with the all-days model, where the all-days
#: log Bayes factor (the z's exact form with the errors correlated over days) exceeds :data:`REVERSED_ALL_DAYS_LBF`
#: (:func:`flag_reversed_all_days`). Calibration seeds (docs/rail.md, "Sensor health,
#: step 16"; faults 300-399 and the other ten families 300-339, 12 284 healthy sensors): of the grid {0, 5, 10, 15}
#: the largest gate that loses none of the 257 reversals found with the z alone; healthy flagged 131 -> 117 / 107 / 102
#: / 100 (10 and 15 lose faults-asymmetric seed 301's reversal, ratio 7.5). Checked after on faults-asymmetric and
#: faults-tilt 340-399: 46 -> 37 of 3176, none of the 65 reversals lost. The value of
#: :data:`REVERSED_SHAPE_GATE_INC_LLR`.
REVERSED_Z_GATE_LLR = 5.0
#: ``reversal_z_rule`` of :func:`assess_sensors` (``SettlementSettings.reversal_z_rule``): "gated" (the default,
#: step 16: z_rev counts only above :data:`REVERSED_Z_GATE_LLR`'s day-to-day ratio) or "alone" (z_rev on its own, the
#: rule until 2026-12-06).
REVERSAL_Z_RULES = ("alone", "gated")
#: ``witness_rule`` of :func:`assess_sensors` (``SettlementSettings.witness_rule``; docs/rail.md, "Sensor health on a
#: transition: the step's witnesses"): "off" (every test as before) or "steps": a sensor whose departure from its
#: neighbours' prediction grows in two separate steps of the same sign (:func:`step_witness_z` above
#: :data:`WITNESS_STEP_Z`), never steps back by as much, and whose changes minus the prediction does not explain (the
#: reversal z's condition) is kept as the witness of a localised movement of the track: the detachment-step,
#: LOO-score and all-days step tests do not flag it (the reversal tests still do).
#: "steps-ends": as "steps", and the end anchor's leave-one-out checks (:func:`~longprofile.rail._settle.
#: fit_end_anchor_all_days`) do not leave a witness out, so that one witness may carry the evidence that the ends moved.
WITNESS_RULES = ("off", "steps", "steps-ends")
#: Threshold of the second step (:func:`step_witness_z`): :data:`STEP_Z`, i.e. a second jump that alone would flag a
#: detachment. Calibration seeds (transition 300-339, faults 300-399, faults-joint-step and faults-none 300-339, first
#: health pass; docs/rail.md): 25 of the 40 flagged witnesses above it; 2 of the 96 flagged detached sensors of
#: faults (narrow-bowl sensors that also witness the bowl: several same-sign steps on the work nights plus the jump),
#: 2 of 38 on faults-joint-step, 0 of 39 on faults-none; no healthy sensor of drift or faults-none above it.
WITNESS_STEP_Z = 8.0
#: Day-to-day reversal log-likelihood ratio (:func:`_increment_tests`) above which a sensor is "reversed".
REVERSED_LLR = 25.0  # calibration seeds (faults 300-399): reversed 87/100, healthy flagged 10/2541 (15: 86, 11)
#: Relative error of the leave-one-out prediction of a day-to-day change (its shape error on a bowl the
#: neighbours sample coarsely): the variance of a day's residual is v + (PRED_REL_ERR dmu)^2.
PRED_REL_ERR = 0.15  # grid {0, 0.15, 0.25, 0.5} on calibration seeds (faults 300-399, others 300-311)
#: The day-to-day reversal test's noise of the prediction's changes: at least the spread of its smallest changes, the
#: 25 % quantile of |dmu - median dmu| over the days / PRED_NOISE_Q25 (the 25 % quantile of |N(0, 1)|, so that the
#: estimate is the std of Gaussian noise while most days move in bursts, and a steady movement, the median, does not
#: count as noise; docs/rail.md, "Sensor health, step 17").
PRED_NOISE_Q25 = 0.31863936396437514
#: ... the same in the step statistic.
STEP_PRED_REL_ERR = 0.15  # grid {0, 0.15, 0.25, 0.5} on calibration seeds (faults 300-399, others 300-311)
#: Step statistic (largest day-to-day LOO residual change in robust std) above which a sensor is "detached".
#: Calibration seeds (faults 300-399): detached 96/100 at 8, 91 at 10, 89 at 12; healthy flagged 12, 11, 10 of 2541.
STEP_Z = 8.0
#: A sensor is frozen when its raw readings spread less than DEAD_SPREAD_DEG within each of this many
#: consecutive days (one flat day can be a logger that repeated its last value; two in a row are not).
FROZEN_MIN_DAYS = 2
#: Fewest readings in a day for its within-day spread to count.
FROZEN_MIN_READINGS = 6
#: Day-to-day changes of the records the day-to-day reversal ratio's thresholds (:data:`REVERSED_LLR`,
#: :data:`REVERSED_Z_GATE_LLR`, :data:`REVERSED_ALL_DAYS_INC_LLR`) were set on (21-28 days: at most 27). A sensor with
#: more changes has them times (n / 27)^LENGTH_EXPONENT (:func:`record_length_factor`; docs/rail.md, "Sensor health,
#: step 18").
REFERENCE_CHANGES = 27
#: The healthy sensors' 99 % quantile of the ratio grew as n^0.26-0.46 on long records (session 31); 1/2 was tried:
#: 34 false alarms fewer of 9537 healthy sensors, 4 more of 120 reversals missed.
LENGTH_EXPONENT = 1.0 / 3.0
#: All-days reversal test (:func:`flag_reversed_all_days`): a sensor kept by :func:`assess_sensors` is "reversed" when
#: the log Bayes factor of "reversed" against "healthy" under the all-days model exceeds this ...
REVERSED_ALL_DAYS_LBF = 6.0
#: ... and its day-to-day reversal log-likelihood ratio (:data:`REVERSED_LLR`'s statistic) exceeds this (both point to
#: a reversal). Calibration seeds (faults 300-399, drift and drift-fronts 300-339; docs/rail.md, "Sensor health,
#: step 11"): reversed sensors the step-5 tests missed 13, found 8; healthy kept sensors flagged 2 of 2529 and 0 of 2213
#: (the log Bayes factor alone at 6: 6 and 3; at 7: 2 and 0 with 6 found).
REVERSED_ALL_DAYS_INC_LLR = 10.0
#: All-days step test (:func:`flag_detached_all_days`): a sensor kept by the tests above is "detached" when its all-days
#: step log-likelihood ratio (:func:`all_days_step_evidence`, its own noise factor fitted under each hypothesis) exceeds
#: this ...
DETACHED_ALL_DAYS_LLR = 10.5
#: ... and its day-to-day step statistic (:data:`STEP_Z`'s) exceeds this. Calibration seeds (faults 300-399, drift and
#: drift-fronts 300-339; docs/rail.md, "Sensor health, step 12"): detached sensors the other tests missed 4, all 4
#: above both (log LR 10.8-18.0, step z 6.1-8.0); largest healthy kept log LR 8.3, 10.3 and 9.0, none above both.
DETACHED_ALL_DAYS_STEP_Z = 5.0
#: Shape test (:func:`flag_reversed_all_days` with a :class:`~longprofile.rail._shapes.ShapeEvidence`): a kept sensor is
#: also "reversed" when its log Bayes factor of a reversal, predicted by the localised shapes fitted to the other
#: sensors (:func:`~longprofile.rail._shapes.shape_reversal_evidence`), exceeds this ...
REVERSED_SHAPE_EVIDENCE = 8.0
#: ... its all-days log Bayes factor (:data:`REVERSED_ALL_DAYS_LBF`'s statistic) exceeds this (not against) ...
REVERSED_SHAPE_GATE_LBF = -1.0
#: ... and its day-to-day reversal log-likelihood ratio exceeds this (:func:`shape_candidates`). Calibration seeds
#: (docs/rail.md, "Sensor health, step 14"; the statistics of the kept sensors at the last health pass): faults 300-449
#: (7 reversed sensors kept, 1 gained), drift, drift-fronts and faults-tilt 300-319, the other non-Gaussian shape families
#: (faults-*) 300-359, faults-asymmetric 300-379: the lowest threshold flagging none of their 13 219 healthy kept sensors
#: (at 6: 3).
REVERSED_SHAPE_GATE_INC_LLR = 5.0
#: Rules of the shape test (``SettlementSettings.shape_rule``): "threshold", the shape log Bayes factor alone against
#: :data:`REVERSED_SHAPE_EVIDENCE` (step 14); "sum", one score of the three reversal statistics, the all-days and the
#: shape log Bayes factors plus :data:`REVERSED_SUM_INC_WEIGHT` times the day-to-day ratio, against
#: :data:`REVERSED_SUM_LBF` (step 15).
SHAPE_RULES = ("threshold", "sum")
#: Sum rule (step 15): a kept sensor is also "reversed" when its score lbf + shape lbf + REVERSED_SUM_INC_WEIGHT * inc
#: exceeds this, its all-days log Bayes factor exceeds :data:`REVERSED_SHAPE_GATE_LBF` ...
REVERSED_SUM_LBF = 16.0
#: ... and its day-to-day reversal log-likelihood ratio exceeds this ...
REVERSED_SUM_GATE_INC_LLR = 2.0
#: ... with this weight of the day-to-day ratio in the score. Calibration seeds (docs/rail.md, "Sensor health, step
#: 15"; the statistics of the kept sensors at the last health pass): faults 300-699, drift, drift-fronts, lag-swings,
#: sparse-drift and the shape families (faults-*) 300-319 to 300-379, 21 484 healthy and 64 reversed kept sensors (20
#: on faults-tilt, found by no rule): weight 0 / 0.1 / 0.25 / 0.5 found 10 / 12 / 15 / 15 reversed at the lowest
#: threshold flagging 1 healthy sensor, 7 / 7 / 7 / 12 flagging none; 0.5 and 16: 14 and 1 (step 14's rule: 8 and the
#: same sensor).
REVERSED_SUM_INC_WEIGHT = 0.5


def loo_residuals(x, slopes, *, sigma, rigidity, sigma_z):
    r"""Standardised leave-one-out residuals of every slope measurement under the rigidity model.

    For a Gaussian linear model with noise sigma, the prediction of m_i from all other
    measurements has residual e_i = (m_i - mu_i) / (1 - h_i) and variance sigma^2 / (1 - h_i),
    h_i = Var(theta_i | M) / sigma^2 (the leverage), so one smoother run gives all N of them.

    Returns
    -------
    z : (D, N) ndarray
        Standardised LOO residuals (NaN where no measurement).
    pred : (D, N) ndarray
        LOO predictions m_i - e_i, rad.
    """
    post = rigidity_posterior(x, slopes, sigma=sigma, rigidity=rigidity, sigma_z=sigma_z)
    lev = np.clip(post.slope_std**2 / sigma**2, 0.0, 1.0 - 1e-12)
    e = (slopes - post.slope_mean) / (1.0 - lev)
    z = e / np.sqrt(sigma**2 / (1.0 - lev))
    return z, slopes - e


def _frozen_run(spread):
    """(first day, length) of the longest run of consecutive days whose within-day spread is below the resolution."""
    flat = np.nan_to_num(spread, nan=np.inf) < DEAD_SPREAD_DEG
    best, start, run = (0, 0), 0, 0
    for d, f in enumerate(flat):
        run = run + 1 if f else 0
        if run == 1:
            start = d
        if run > best[1]:
            best = (start, run)
    return best


def record_length_factor(n_changes) -> np.ndarray:
    """max(1, n / :data:`REFERENCE_CHANGES`)^:data:`LENGTH_EXPONENT` of each sensor's number ``n`` of day-to-day
    changes: the factor on the day-to-day reversal ratio's thresholds.

    The ratio is a sum over the days. Its thresholds were set on 3-4-week records; on longer ones the healthy sensors'
    ratios spread wider, the model's errors (drift rates that differ by sensor, thermal residuals shared along the
    track) adding up over the days: the 99 % quantile over healthy sensors went 8.4 / 11.5 / 15.2 / 19.6 at 27 / 89 /
    179 / 364 changes on ``drift`` (session 31, seeds 300-339, read hourly), and the fixed thresholds flagged 0.4 /
    1.2 / 2.5 / 4.7 % of them: the quantile grew as about n^(1/3) (a sum's spread grows as sqrt(n) when every term
    is misfit alike). Records no longer than the calibration's keep the thresholds as they were.
    """
    return np.maximum(1.0, np.asarray(n_changes, float) / REFERENCE_CHANGES) ** LENGTH_EXPONENT


def _robust_scale(q, axis=0):
    """1.4826 MAD of the finite values of ``q`` along ``axis`` (NaN where none)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns give NaN
        return 1.4826 * np.nanmedian(np.abs(q - np.nanmedian(q, axis=axis, keepdims=True)), axis=axis)


def _small_spread(q):
    """Std of Gaussian noise from the smallest quarter of the deviations of ``q`` from its median along axis 0
    (:data:`PRED_NOISE_Q25`), ignoring NaN; each column needs a finite value."""
    return np.nanquantile(np.abs(q - np.nanmedian(q, axis=0)), 0.25, axis=0) / PRED_NOISE_Q25


def _increment_tests(M, pred, bad):
    """Reversal log-likelihood ratio and step statistic of every sensor from the day-to-day changes.

    With dm the sensor's daily changes, dmu those of its leave-one-out prediction and v the robust
    variance of the residual under whichever hypothesis fits better (the smaller MAD of dm - dmu and
    dm + dmu: a reversed sensor's dm - dmu is ~ -2 dmu on every moving day, so its own spread would
    hide the reversal; std floored at half the site's), each day contributes -2 dm dmu w (log-likelihood
    ratio of "m follows -mu" against "m follows +mu") with the empirical-Bayes weight
    w = tau^2 / (v_d (s^2 + tau^2)), tau^2 = max(0, dmu^2 - s^2), v_d = v + (PRED_REL_ERR dmu)^2, where s^2,
    the noise variance of the prediction's changes, is the larger of v / 2 and the squared spread of the
    prediction's own smallest changes about their median (:func:`_small_spread`): days when the neighbours did not move (dmu
    within its noise) carry almost no weight, so the product of two noises does not pose as evidence. (Until
    2026-12-06, session 30, s^2 = v / 2: half the residual's variance, which under-states the prediction's
    noise where a quiet sensor sits among noisier ones; docs/rail.md, "Sensor health, step 17".)

    The step statistic is the largest |dm - dmu| over the days, in units of the robust std of the
    other days' (same floor and shape term): a detached sensor jumps once. Sensors with fewer than 5
    day-to-day changes get NaN (and step day -1). All sensors at once, as (D - 1, N) arrays.
    """
    N = M.shape[1]
    dm, dmu = np.diff(M, axis=0), np.diff(pred, axis=0)
    de = dm - dmu
    ok = np.isfinite(de)
    kept = de[:, ~bad]
    site = 1.4826 * np.nanmedian(np.abs(kept)) if np.isfinite(kept).any() else np.nan
    use = (ok.sum(axis=0) >= 5) & np.isfinite(site)
    llr = np.full(N, np.nan)
    step = np.full(N, np.nan)
    step_day = np.full(N, -1)
    if not use.any():
        return llr, step, step_day
    a = np.where(ok, dm, np.nan)[:, use]
    b = np.where(ok, dmu, np.nan)[:, use]
    c = de[:, use]
    v = np.maximum(np.fmin(_robust_scale(c), _robust_scale(a + b)), 0.5 * site) ** 2
    vd = v + (PRED_REL_ERR * b) ** 2  # the prediction's shape error grows with the change it predicts
    s2 = np.maximum(0.5 * v, _small_spread(b) ** 2)
    tau2 = np.maximum(0.0, b**2 - s2)
    llr[use] = np.nansum(-2.0 * a * b * tau2 / (vd * (s2 + tau2)), axis=0)
    ratio = np.abs(c) / np.sqrt(v + (STEP_PRED_REL_ERR * b) ** 2)
    i = np.argmax(np.where(np.isfinite(ratio), ratio, -np.inf), axis=0)  # the first largest, as a loop finds it
    cols = np.arange(c.shape[1])
    rest = c.copy()
    rest[i, cols] = np.nan
    step[use] = np.abs(c[i, cols]) / np.sqrt(np.maximum(_robust_scale(rest), 0.5 * site) ** 2
                                             + (STEP_PRED_REL_ERR * b[i, cols]) ** 2)
    step_day[use] = i + 1
    return llr, step, step_day


def step_witness_z(M, pred, bad) -> tuple[np.ndarray, np.ndarray]:
    """Second step and largest step back of each sensor's departure from its neighbours' prediction, in the units of
    the step statistic (:func:`_increment_tests`): (second, back), (N,) arrays, NaN for sensors with fewer than 5
    day-to-day changes.

    Beyond paper 004 (§6 flags improbable sensors). With c_d = dm_d - dmu_d the day-to-day departures and i the day of
    the largest |c_d| (the step statistic's jump, sign S), each day's departure is standardised as the step statistic
    does, z_d = S c_d / sqrt(s^2 + (STEP_PRED_REL_ERR dmu_d)^2), s the robust std of the other days (floored at half the
    site's). ``second`` = max z_d and ``back`` = max -z_d over the days at least two days from i (a jump during a day
    shows in that day's median or the next's, so the neighbouring day is not a second step). A detached sensor jumps
    once: its other days are noise, both small. A sensor that sees the track settle on several work nights (the only
    witness of a step at a joint or a transition, which its neighbours' smooth prediction cannot show) has a second
    step of the same sign (``second`` large) and none back.
    """
    dm, dmu = np.diff(M, axis=0), np.diff(pred, axis=0)
    c = dm - dmu
    ok = np.isfinite(c)
    N = M.shape[1]
    kept = c[:, ~bad]
    site = 1.4826 * np.nanmedian(np.abs(kept)) if np.isfinite(kept).any() else np.nan
    second, back = np.full(N, np.nan), np.full(N, np.nan)
    use = (ok.sum(axis=0) >= 5) & np.isfinite(site)
    if not use.any():
        return second, back
    cu, bu = c[:, use], dmu[:, use]
    cols = np.arange(cu.shape[1])
    i = np.argmax(np.where(np.isfinite(cu), np.abs(cu), -np.inf), axis=0)
    rest = cu.copy()
    rest[i, cols] = np.nan
    s2 = np.maximum(_robust_scale(rest), 0.5 * site) ** 2
    z = np.sign(cu[i, cols]) * cu / np.sqrt(s2 + (STEP_PRED_REL_ERR * bu) ** 2)
    far = (np.abs(np.arange(cu.shape[0])[:, None] - i[None, :]) >= 2) & np.isfinite(z)
    second[use] = np.max(np.where(far, z, -np.inf), axis=0)
    back[use] = np.max(np.where(far, -z, -np.inf), axis=0)
    return second, back


def _classify(m, pred, z):
    """Pattern of a flagged sensor from its measurements m, LOO predictions and standardised residuals (over days)."""
    ok = np.isfinite(m) & np.isfinite(pred)
    m, pred, z = m[ok], pred[ok], z[ok]
    if m.size < 3:
        return "improbable", "too few days to tell the pattern"
    if np.sum(pred**2) > 0 and np.sum((m + pred) ** 2) < 0.25 * np.sum((m - pred) ** 2):
        b = float(np.dot(m, pred) / np.dot(pred, pred))
        return "reversed", f"angle changes follow {b:+.2f} x the neighbours' prediction (expected +1)"
    t = np.arange(z.size, dtype=float)
    tot = float(np.sum((z - z.mean()) ** 2)) or 1e-300
    A = np.vstack([np.ones_like(t), t]).T
    res_lin = float(np.sum((z - A @ np.linalg.lstsq(A, z, rcond=None)[0]) ** 2))
    cs = np.cumsum(z)
    best_step = np.inf
    for k in range(1, z.size):
        m1, m2 = cs[k - 1] / k, (cs[-1] - cs[k - 1]) / (z.size - k)
        r = float(np.sum((z[:k] - m1) ** 2) + np.sum((z[k:] - m2) ** 2))
        best_step = min(best_step, r)
    r2_lin, r2_step = 1 - res_lin / tot, 1 - best_step / tot
    if r2_lin > 0.6 and r2_lin >= r2_step:
        return "drifting", f"residual trend explains {100 * r2_lin:.0f} % of its variance"
    if r2_step > 0.6:
        return "detached", f"one jump explains {100 * r2_step:.0f} % of its residual variance"
    return "improbable", "residuals far beyond the noise without a clear pattern"


def assess_sensors(x, slopes, *, sigma, rigidity, sigma_z, raw_spread_deg=None, exclude=(), max_flagged=None,
                   fit=None, raw_day_spread_deg=None, fit_anchor=None,
                   reversal_z_rule: str = "gated", witness_rule: str = "off",
                   reversal_null: str = "site") -> tuple[SensorHealth, float, float]:
    """Flag dead, frozen and improbable sensors, iteratively (worst first), re-fitting the noise after each exclusion.

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    slopes : (D, N) ndarray
        Daily slope changes, rad (NaN = no data).
    sigma, rigidity : float
        Starting values (or fixed values when ``fit`` is None).
    sigma_z : float
        Anchor std, m.
    raw_spread_deg : (N,) ndarray, optional
        Robust spread of each sensor's raw readings (dead-sensor test).
    exclude : iterable of int
        Sensors excluded by the user (status "excluded", :data:`USER_EXCLUDED`; detail "excluded by the user").
    max_flagged : int, optional
        Stop after this many LOO exclusions (default :func:`flag_limit`: a quarter of the sensors the tests examine,
        i.e. all but the user's ``exclude``).
    fit : callable, optional
        ``fit(slopes_masked, sigma, rigidity, sigma_z) -> (sigma, rigidity)`` re-estimates the noise after each
        exclusion.
    raw_day_spread_deg : (D, N) ndarray, optional
        Robust within-day spread of the raw readings (``DailyAngles.raw_day_spread_deg``), NaN on days with
        too few readings (fewer than :data:`FROZEN_MIN_READINGS`): frozen-sensor test, a sensor is "frozen"
        when it spreads less than :data:`DEAD_SPREAD_DEG` within each of :data:`FROZEN_MIN_DAYS` consecutive days.
    fit_anchor : callable, optional
        ``fit_anchor(slopes_masked) -> sigma_z`` re-estimates the end-anchor std of the prediction from the kept
        sensors before each pass (:func:`~longprofile.rail._settle.fit_end_anchor`); None: ``sigma_z`` throughout.
    reversal_z_rule : {"gated", "alone"}, default "gated"
        :data:`REVERSAL_Z_RULES`: "gated", the reversal z (:data:`REVERSED_Z`) flags a sensor only when its day-to-day
        reversal log-likelihood ratio exceeds :data:`REVERSED_Z_GATE_LLR` (docs/rail.md, "Sensor health, step 16"; the
        all-days stage may flag it later, :func:`flag_reversed_all_days`); "alone", on its own (the rule until
        2026-12-06).
    witness_rule : {"off", "steps", "steps-ends"}, default "off"
        :data:`WITNESS_RULES`: with "steps" (or "steps-ends", the same here) a sensor whose departure grows in two
        separate same-sign steps
        (:func:`step_witness_z` above :data:`WITNESS_STEP_Z`, no step back as large) and whose changes minus the
        prediction does not explain is not flagged by the detachment-step and LOO-score tests
        (``SensorHealth.witness``); docs/rail.md, "Sensor health on a transition: the step's witnesses".
    reversal_null : {"site", "model"}, default "site"
        :data:`REVERSAL_NULLS`: "site", the day-to-day reversal ratio's thresholds times :func:`record_length_factor`
        of each sensor's number of changes (records longer than the calibration's; docs/rail.md, "Sensor health, step
        18"); "model", the thresholds as set (the rule until session 31).

    Returns
    -------
    health : SensorHealth
    sigma, rigidity : float
        Final values (re-fitted if ``fit`` was given).
    """
    _check_rules(reversal_z_rule=reversal_z_rule, witness_rule=witness_rule, reversal_null=reversal_null)
    D, N = slopes.shape
    status, detail = _dead_sensors(slopes, raw_spread_deg, raw_day_spread_deg)
    for j in exclude:
        status[j], detail[j] = USER_EXCLUDED, "excluded by the user"
    max_flagged = flag_limit(status) if max_flagged is None else max_flagged
    score = np.full(N, np.nan)
    rev = np.full(N, np.nan)
    llr = np.full(N, np.nan)
    step = np.full(N, np.nan)
    witness = None
    excluded_witness = np.zeros(N, bool)
    n_flag = 0
    lf = np.ones(N)
    while True:
        bad = status != "ok"
        M = np.where(bad[None, :], np.nan, slopes)
        if fit_anchor is not None:
            sigma_z = fit_anchor(M)
        if fit is not None:
            sigma, rigidity = fit(M, sigma, rigidity, sigma_z)
        z, pred = loo_residuals(x, M, sigma=sigma, rigidity=rigidity, sigma_z=sigma_z)
        k = np.isfinite(z).sum(axis=0)
        score = np.where(k > 0, np.nansum(z**2, axis=0) / np.maximum(k, 1), np.nan)
        pval = np.where(k > 0, gammaincc(np.maximum(k, 1) / 2.0, score * k / 2.0), 1.0)  # chi-square sf
        rev, looks_reversed = _reversal_z(M, pred, z, k)
        llr, step, step_day = _increment_tests(M, pred, bad)
        if reversal_null == "site":  # step 18: thresholds grown with the record's length
            lf = record_length_factor(np.isfinite(np.diff(M, axis=0) - np.diff(pred, axis=0)).sum(axis=0))
        # exceedance of each test over its threshold; the worst sensor (largest ratio) goes first
        r_imp = np.where((pval < IMPROBABLE_P / N) & (score > IMPROBABLE_SCORE), score / IMPROBABLE_SCORE, 0.0)
        r_rev = _reversal_ratio(rev, llr, lf, reversal_z_rule)
        r_step = np.nan_to_num(step, nan=0.0) / STEP_Z
        if witness_rule != "off":  # a witness of a localised movement: only the reversal tests may flag it
            witness = _witnesses(M, pred, bad, looks_reversed)
            r_imp, r_step = np.where(witness, 0.0, r_imp), np.where(witness, 0.0, r_step)
        ratio = np.where(bad, 0.0, np.maximum.reduce([r_imp, r_rev, r_step]))
        if not (ratio > 1.0).any() or n_flag >= max_flagged or (~bad).sum() <= 3:
            break
        j = int(np.argmax(ratio))
        n_flag += 1
        base = f"mean squared LOO z-score {score[j]:.3g} over {k[j]} days"
        if r_rev[j] >= max(r_imp[j], r_step[j]):
            status[j], detail[j] = "reversed", _reversal_detail(M[:, j], pred[:, j], llr[j], rev[j], lf[j],
                                                                reversal_z_rule, base)
            continue
        # a step or score exclusion: was its record a witness's? (SensorHealth.excluded_witness)
        excluded_witness[j] = (witness if witness is not None else _witnesses(M, pred, bad, looks_reversed))[j]
        if r_step[j] >= r_imp[j]:
            status[j] = "detached"
            detail[j] = (f"its leave-one-out residual jumps on day {step_day[j]}: {step[j]:.3g} robust std of its "
                         f"day-to-day changes (threshold {STEP_Z:g}); {base}")
        else:
            kind, why = _classify(slopes[:, j], pred[:, j], z[:, j])
            status[j] = kind
            detail[j] = f"{why}; {base} (> {IMPROBABLE_SCORE:g} and p < {IMPROBABLE_P:g}/N)"
    health = SensorHealth(sensor_ids=list(range(N)), status=np.array(status, dtype=str),
                          detail=np.array(detail, dtype=str), excluded=status != "ok", loo_score=score,
                          reversal_z=rev, reversal_llr=llr, step_z=step, anchor_std=float(sigma_z),
                          witness=None if witness is None else witness & (status == "ok"),
                          excluded_witness=excluded_witness, reversal_llr_scale=lf)
    return health, float(sigma), float(rigidity)


def flag_limit(status) -> int:
    """How many sensors the health tests may flag at most (``max_flagged``'s default): a quarter of the sensors they
    examine, at least one.

    The sensors examined are all but the user's exclusions (:data:`USER_EXCLUDED`): a dead, frozen or late sensor was
    examined (and is not counted among the flags, :func:`n_flagged`); an excluded one was not, so excluding sensors one
    knows are bad leaves the tests the same room to find the others (docs/rail.md, "Sensor health": the limit, an
    assumption). Without exclusions, ``max(1, N // 4)`` as before.
    """
    status = np.asarray(status)
    return max(1, int((status != USER_EXCLUDED).sum()) // 4)


def n_flagged(status) -> int:
    """How many sensors the health tests flagged as faulty: neither "ok", nor unusable (:data:`UNUSABLE_STATUSES`,
    not counted toward :func:`flag_limit`), nor excluded by the user (:data:`USER_EXCLUDED`, never counted)."""
    status = np.asarray(status)
    return int(((status != "ok") & ~np.isin(status, UNUSABLE_STATUSES) & (status != USER_EXCLUDED)).sum())


def _reversal_z(M, pred, z, k):
    """The reversal z of :func:`assess_sensors` (:data:`REVERSED_Z`) from the changes ``M``, their leave-one-out
    prediction ``pred`` and standardised residuals ``z`` ((D, N) each; ``k`` finite residuals per sensor), NaN unless
    minus the prediction explains the changes (not a drift or a jump); and that condition, (N,) bool."""
    with np.errstate(invalid="ignore", divide="ignore"):
        e = M - pred
        v = np.where(np.abs(z) > 0, (e / np.where(z == 0, 1.0, z)) ** 2, np.nan)  # LOO variance sigma^2/(1-h)
        rev = -np.nansum(M * pred, axis=0) / np.sqrt(np.nansum(pred**2 * v, axis=0))
        looks_reversed = np.nansum((M + pred) ** 2, axis=0) < 0.25 * np.nansum((M - pred) ** 2, axis=0)
    return np.where((k > 0) & looks_reversed, rev, np.nan), looks_reversed


def _reversal_ratio(rev, llr, length_factor, reversal_z_rule) -> np.ndarray:
    """Exceedance of the reversal tests of :func:`assess_sensors` over their thresholds (0 where none applies): the
    larger of z_rev / :data:`REVERSED_Z` (with ``reversal_z_rule="gated"``, step 16, only where the day-to-day ratio
    exceeds :data:`REVERSED_Z_GATE_LLR`) and the ratio / :data:`REVERSED_LLR`, the ratio's thresholds times
    ``length_factor`` (:func:`record_length_factor`)."""
    llr_, rev_ = np.nan_to_num(llr, nan=-np.inf), np.nan_to_num(rev, nan=-np.inf)
    if reversal_z_rule == "gated":  # z_rev only where the day-to-day changes point to a reversal too
        rev_ = np.where(llr_ > REVERSED_Z_GATE_LLR * length_factor, rev_, -np.inf)
    return np.nan_to_num(np.maximum(rev_ / REVERSED_Z, llr_ / (REVERSED_LLR * length_factor)), neginf=0.0)


def _check_rules(**rules) -> None:
    """One clear error for a rule name that is not one of its choices (:func:`assess_sensors`' keywords)."""
    choices = {"reversal_z_rule": REVERSAL_Z_RULES, "witness_rule": WITNESS_RULES, "reversal_null": REVERSAL_NULLS}
    for name, value in rules.items():
        if value not in choices[name]:
            raise InputError(f"{name} must be one of {choices[name]}; got {value!r}.")


def _reversal_detail(m, pred, llr, rev, length_factor, reversal_z_rule, base) -> str:
    """The detail of a sensor :func:`assess_sensors` flags "reversed" (its changes ``m`` and prediction ``pred``;
    ``length_factor``, its :func:`record_length_factor`)."""
    gate = f" with the ratio > {REVERSED_Z_GATE_LLR * length_factor:.3g}" if reversal_z_rule == "gated" else ""
    return (f"angle changes follow {np.nansum(m * pred) / np.nansum(pred ** 2):+.2f} x the neighbours' prediction "
            f"(expected +1): day-to-day reversal log-likelihood ratio {llr:.3g} (threshold "
            f"{REVERSED_LLR * length_factor:.3g}), reversal z {np.nan_to_num(rev):.3g} (threshold {REVERSED_Z:g}{gate}); "
            f"{base}")


def _dead_sensors(slopes, raw_spread_deg, raw_day_spread_deg):
    """(status, detail) object arrays of :func:`assess_sensors` before its tests: "dead" for a sensor without readings,
    with readings on fewer than half the days or stuck (raw spread under the resolution) from its first day; "frozen"
    for one stuck from some day on (:func:`_frozen_run`; after days of normal readings, also when its raw spread over
    the record is under the resolution);
    "late" for one without a daily angle on the reference day (day 0); "ok" otherwise.

    A late sensor (installed, or first read, after the reference day) has changes only from its own first day: taken
    as changes since the reference day they claimed that the track did not move before it (session 36: a sensor
    added to a site during the works, an operator's probe). Its change since the reference day is unknown, so it is
    left out, saying how to take it in (a later reference day)."""
    D, N = slopes.shape
    status = np.array(["ok"] * N, dtype=object)
    detail = np.array([""] * N, dtype=object)
    have = np.isfinite(slopes).sum(axis=0)
    for j in range(N):
        if have[j] == 0:
            status[j], detail[j] = "dead", "no usable readings (none with both an angle and a temperature)"
        elif not np.isfinite(slopes[0, j]):
            first = int(np.flatnonzero(np.isfinite(slopes[:, j]))[0])
            status[j], detail[j] = "late", (f"no daily angle on the reference day (its first on day {first} of {D}, "
                                            "days counted from 0): its change since the reference day is unknown; "
                                            "readings from a later first day (rail settle) or a later baseline "
                                            "(the service) take it in")
        elif have[j] < 0.5 * D:
            status[j], detail[j] = "dead", f"readings on {have[j]} of {D} days"
        else:
            d0, run = (0, 0) if raw_day_spread_deg is None else _frozen_run(raw_day_spread_deg[:, j])
            # stuck over most of the record after reading normally (a day before the run spread beyond the
            # resolution): frozen, although its robust spread over the record is that of a stuck sensor
            moved_first = run >= FROZEN_MIN_DAYS and bool(np.any(raw_day_spread_deg[:d0, j] >= DEAD_SPREAD_DEG))
            if raw_spread_deg is not None and raw_spread_deg[j] < DEAD_SPREAD_DEG and not moved_first:
                status[j], detail[j] = "dead", (f"stuck: spread of raw readings {raw_spread_deg[j]:.1e} deg < 1e-4 deg "
                                                "resolution")
            elif run >= FROZEN_MIN_DAYS:
                status[j], detail[j] = "frozen", (f"frozen: its raw readings spread less than the 1e-4 deg resolution "
                                                  f"within each of {run} consecutive days from day {d0} on "
                                                  f"(>= {FROZEN_MIN_DAYS})")
    return status, detail


def _witnesses(M, pred, bad, looks_reversed) -> np.ndarray:
    """(N,) bool: the kept sensors of ``witness_rule="steps"`` (:func:`assess_sensors`): a second same-sign step above
    :data:`WITNESS_STEP_Z`, no step back as large, and minus the prediction does not explain the changes
    (``looks_reversed``, the reversal z's condition: a reversed sensor's departure is -2 x its prediction, several
    same-sign steps on the work nights too)."""
    second, back = step_witness_z(M, pred, bad)
    return (~bad & (np.nan_to_num(second, nan=-np.inf) > WITNESS_STEP_Z)
            & (np.nan_to_num(back, nan=np.inf) < WITNESS_STEP_Z) & ~np.asarray(looks_reversed, bool))


#: The healthy sensors' standardised all-days reversal evidence s = (log BF + 2 I) / (2 sqrt I) (N(0, 1) under the
#: model) on the 3-4-week records the thresholds were set on: median ~0.5, robust spread ~1.2 (session 31, seeds
#: 300-339 of drift, lag-swings and faults at 28 days: 0.49 / 1.23, 0.57 / 1.13, 0.70 / 1.16). The thresholds absorb
#: them; :func:`site_reversal_null` corrects only what a site shows beyond them (docs/rail.md, "Sensor health, step 18").
NULL_BASELINE_MEDIAN = 0.5
NULL_BASELINE_SPREAD = 1.2
#: Reversal nulls (:func:`site_reversal_null`): "site", the site's kept sensors' own spread beyond the baseline;
#: "model", the all-days model's own (the rule until session 31).
REVERSAL_NULLS = ("site", "model")


def site_reversal_null(evidence: ReversalEvidence, kept) -> ReversalEvidence:
    r"""The all-days reversal evidence against the spread the site's own sensors show (an empirical null).

    Beyond paper 004. Under the all-days model a healthy sensor's standardised evidence
    s_i = (log BF_i + 2 I_i) / (2 sqrt I_i) is N(0, 1) (:class:`ReversalEvidence`). On long records it is not: the
    model's one noise covariance for all sensors (up to a factor) under-states the errors of some (drift rates differ
    by sensor, thermal residuals shared along the track) and the neighbours' prediction follows their errors, so the
    healthy sensors' s grows in centre and spread with the record (session 31, seeds 300-339, 28 / 90 / 180 / 365
    days read hourly: median 0.49 / 1.12 / 1.79 / 2.74 and spread 1.2 / 1.6 / 1.8 / 2.3 on ``drift``; healthy
    sensors flagged 0.4 / 1.2 / 2.5 / 4.7 %). Most sensors of a site are healthy: the median d and robust spread l
    (1.4826 MAD) of s over the ``kept`` sensors estimate that null. What exceeds the baseline the thresholds were set
    on (:data:`NULL_BASELINE_MEDIAN`, :data:`NULL_BASELINE_SPREAD`) by more than two standard errors,
    shift = max(0, d - 0.5 - 2 se_d) and scale = max(1, (l - 2 se_l) / 1.2) (se_d = 1.2533 l / sqrt n,
    se_l = 1.166 l / sqrt n), is taken out: log BF'_i = (log BF_i - 2 sqrt(I_i) shift) / scale^2 and
    I'_i = I_i / scale^2, i.e. the evidence of the model with the errors' variance times scale^2 and the healthy
    centre moved back (s'_i = (s_i - shift) / scale). A reversed sensor's evidence, ~ +2 I, stays far above.

    Parameters
    ----------
    evidence : ReversalEvidence
        Of :func:`all_days_reversal_evidence`.
    kept : (N,) array_like of bool
        The sensors the health tests keep (the null is theirs; a reversed sensor among them is one outlier of many).

    Returns
    -------
    ReversalEvidence
        The corrected evidence with ``null_shift`` and ``null_scale`` set (the input itself when fewer than 8 kept
        sensors have evidence, or nothing exceeds the baseline).
    """
    lbf = np.asarray(evidence.log_bayes_factor, float)
    info = np.asarray(evidence.information, float)
    use = np.asarray(kept, bool) & np.isfinite(lbf) & np.isfinite(info) & (info > 0)
    n = int(use.sum())
    if n < 8:
        return evidence
    s = (lbf[use] + 2.0 * info[use]) / (2.0 * np.sqrt(info[use]))
    d = float(np.median(s))
    spread = 1.4826 * float(np.median(np.abs(s - d)))
    shift = max(0.0, d - NULL_BASELINE_MEDIAN - 2.0 * 1.2533 * spread / np.sqrt(n))
    scale = max(1.0, (spread - 2.0 * 1.166 * spread / np.sqrt(n)) / NULL_BASELINE_SPREAD)
    if shift == 0.0 and scale == 1.0:
        return evidence
    with np.errstate(invalid="ignore"):
        corrected = (lbf - 2.0 * np.sqrt(np.maximum(info, 0.0)) * shift) / scale**2
    return ReversalEvidence(log_bayes_factor=corrected, information=info / scale**2, null_shift=shift,
                            null_scale=scale)


def all_days_reversal_evidence(x, mode_slopes, mode_noise, *, rigidity: float, penalty_order: int = 2,
                               sensor_factors=None, segment_weights=None,
                               sigma_z: float = DEFAULT_SIGMA_Z) -> ReversalEvidence:
    r"""Log Bayes factor of "sensor i is reversed" against "healthy" for every sensor, combining all days.

    Beyond paper 004 (§6 flags improbable sensors; the prior of §4.2). A reversed sensor reads -theta_i where a
    healthy one reads theta_i: the two hypotheses differ only by the sign of sensor i's data, so the Bayes factor is
    p(-m_i | others) / p(m_i | others) under the all-days model (:mod:`~longprofile.rail._joint`: errors correlated
    over the days with covariance f_i^2 R, settlement increments with a per-day prior). Its modes (generalised
    eigenvectors of R and the prior's day covariance) are independent, so with y_ik = (V^T m_i)_k the data of mode
    k, mu_ik and v_ik its leave-one-out predictive mean and variance from the other sensors (one smoother run per
    mode: :func:`loo_residuals`' identity e = (y - mean)/(1 - h), v = s^2/(1 - h), s = sqrt(nu_k) f_i)

        log BF_i = sum_k [log N(-y_ik; mu_ik, v_ik) - log N(y_ik; mu_ik, v_ik)] = -2 sum_k y_ik mu_ik / v_ik.

    This is the exact evidence ratio of the two discrete alternatives under the model; the day-to-day test of
    :func:`assess_sensors` approximates it with independent increments.

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    mode_slopes : (K, N) ndarray
        The modes' data ``DayModes.to_modes @ slopes[1:]`` (rad; NaN columns = excluded sensors).
    mode_noise : (K,) ndarray
        sqrt(nu_k) of each mode (``DayModes.noise``), rad.
    rigidity : float
        r of every mode's spatial prior (``DayModes.rigidity``).
    penalty_order, segment_weights, sigma_z
        As in :func:`~longprofile.rail.rigidity_posterior`.
    sensor_factors : (N,) array_like, optional
        f_i (default 1).

    Returns
    -------
    ReversalEvidence
    """
    Y = np.asarray(mode_slopes, float)
    N = Y.shape[1]
    f = np.ones(N) if sensor_factors is None else np.asarray(sensor_factors, float)
    mus, preds, own = _mode_loo(x, Y, mode_noise, f, rigidity=rigidity, penalty_order=penalty_order,
                                segment_weights=segment_weights, sigma_z=sigma_z)
    v = preds + own * f**2
    lbf = np.sum(-2.0 * Y * mus / v, axis=0)
    info = np.sum(mus**2 / v, axis=0)
    gone = np.isnan(Y).all(axis=0)
    return ReversalEvidence(log_bayes_factor=np.where(gone, np.nan, lbf), information=np.where(gone, np.nan, info))


def _mode_loo(x, Y, mode_noise, f, *, rigidity, penalty_order, segment_weights, sigma_z):
    """Leave-one-out predictive mean mu_ik and variance p_ik of theta_ik (without sensor i's own noise) of every mode
    k and sensor i, and nu_k, as (K, N), (K, N), (K, 1): one smoother run per mode (:func:`loo_residuals`' identity)."""
    K, N = Y.shape
    _, post = rigidity_posterior_levels(x, Y, np.arange(K), levels=mode_noise, rigidity=rigidity, sigma_z=sigma_z,
                                        penalty_order=penalty_order, sensor_factors=f, segment_weights=segment_weights)
    sig = np.asarray(mode_noise, float)[:, None] * f[None, :]
    lev = np.clip(np.sqrt(post.cov[:, :, 1, 1]) ** 2 / sig**2, 0.0, 1.0 - 1e-12)
    mus = Y - (Y - post.mean[..., 1]) / (1.0 - lev)
    preds = sig**2 / (1.0 - lev) - sig**2
    return mus, preds, (np.asarray(mode_noise, float) ** 2)[:, None]


#: Range of a sensor's own noise factor f searched by :func:`all_days_step_evidence` (the bounds of the all-days
#: factors, f^2 in [1/16, 64]), on PROFILE_FACTOR_GRID log-spaced values.
PROFILE_FACTOR_BOUNDS = (0.25, 8.0)
PROFILE_FACTOR_GRID = 121


def shape_candidates(health: SensorHealth, evidence: ReversalEvidence, rule: str = "threshold") -> np.ndarray:
    """(N,) bool: the kept sensors whose all-days log Bayes factor exceeds :data:`REVERSED_SHAPE_GATE_LBF` and whose
    day-to-day reversal log-likelihood ratio exceeds :data:`REVERSED_SHAPE_GATE_INC_LLR` (``rule`` "threshold") or
    :data:`REVERSED_SUM_GATE_INC_LLR` ("sum"): the only ones the shape test can flag (the caller computes their shape
    evidence only)."""
    if rule not in SHAPE_RULES:
        raise InputError(f"rule must be one of {SHAPE_RULES}; got {rule!r}.")
    N = health.status.size
    lbf = np.nan_to_num(evidence.log_bayes_factor, nan=-np.inf)
    inc = np.nan_to_num(health.reversal_llr, nan=-np.inf) if health.reversal_llr is not None else np.full(N, -np.inf)
    gate = REVERSED_SHAPE_GATE_INC_LLR if rule == "threshold" else REVERSED_SUM_GATE_INC_LLR
    return ~np.asarray(health.excluded, bool) & (lbf > REVERSED_SHAPE_GATE_LBF) & (inc > gate)


def flag_reversed_all_days(health: SensorHealth, evidence: ReversalEvidence, max_flagged: int | None = None,
                           shape: ShapeEvidence | None = None, shape_rule: str = "threshold",
                           reversal_z_rule: str = "gated") -> tuple[SensorHealth, int | None]:
    """Flag the kept sensor with the largest all-days evidence of a reversal, if any passes either test.

    A sensor still "ok" is flagged "reversed" when its log Bayes factor (:func:`all_days_reversal_evidence`) exceeds
    :data:`REVERSED_ALL_DAYS_LBF` and its day-to-day reversal log-likelihood ratio (``health.reversal_llr``) exceeds
    :data:`REVERSED_ALL_DAYS_INC_LLR`; or, with ``shape``, when its localised-shape log Bayes factor
    (:func:`~longprofile.rail._shapes.shape_reversal_evidence`) exceeds :data:`REVERSED_SHAPE_EVIDENCE` and it is one
    of the :func:`shape_candidates` (both all-days statistics above their lower gates). With ``shape_rule="sum"``
    (docs/rail.md, "Sensor health, step 15") the shape test is instead one score of the three statistics, all-days log
    BF + shape log BF + :data:`REVERSED_SUM_INC_WEIGHT` x day-to-day ratio, above :data:`REVERSED_SUM_LBF`, for the
    ``shape_candidates(..., rule="sum")``. The three weigh the same data under three predictions of the sensor (the
    smooth all-days prior of paper 004 §4.2, the localised shapes, independent day-to-day changes): the score is not a
    likelihood ratio, and its threshold was set on the healthy sensors' tail on calibration seeds. With
    ``reversal_z_rule="gated"`` (step 16) a kept sensor whose reversal z (``health.reversal_z``) exceeds
    :data:`REVERSED_Z` (the gate of :func:`assess_sensors` stopped it there) is also "reversed" when its all-days log
    Bayes factor exceeds :data:`REVERSED_ALL_DAYS_LBF`: that Bayes factor is the same projection of the sensor's
    changes on the neighbours' prediction with the errors' correlation over the days accounted for (the all-days form
    of the z).
    The worst by the sum of the two log Bayes factors.
    One sensor at a time (the caller re-fits the noise model without it and asks again), and none once
    ``max_flagged`` sensors (default :func:`flag_limit`, a quarter of the sensors examined; dead ones and the user's
    exclusions not counted, :func:`n_flagged`) are excluded or only 3 are left.

    Returns
    -------
    health : SensorHealth
        With ``reversal_evidence`` (and ``shape_evidence``) set, and the flagged sensor's status, detail and exclusion.
    flagged : int or None
        Index of the flagged sensor.
    """
    _check_rules(reversal_z_rule=reversal_z_rule)
    lbf = np.nan_to_num(evidence.log_bayes_factor, nan=-np.inf)
    N = health.status.size
    inc = np.nan_to_num(health.reversal_llr, nan=-np.inf) if health.reversal_llr is not None else np.full(N, -np.inf)
    glr = np.full(N, np.nan) if shape is None else np.asarray(shape.log_bayes_factor, float)
    g = np.nan_to_num(glr, nan=-np.inf)
    shape_score, shape_thr = ((g, REVERSED_SHAPE_EVIDENCE) if shape_rule == "threshold" else
                              (lbf + g + REVERSED_SUM_INC_WEIGHT * inc, REVERSED_SUM_LBF))
    by_shape = shape_candidates(health, evidence, shape_rule) & (shape_score > shape_thr)
    z = np.nan_to_num(health.reversal_z, nan=-np.inf) if health.reversal_z is not None else np.full(N, -np.inf)
    lf = np.ones(N) if health.reversal_llr_scale is None else np.asarray(health.reversal_llr_scale, float)
    by_inc = (lbf > REVERSED_ALL_DAYS_LBF) & (inc > REVERSED_ALL_DAYS_INC_LLR * lf)
    by_z = (lbf > REVERSED_ALL_DAYS_LBF) & (z > REVERSED_Z) & (reversal_z_rule == "gated")  # step 16
    passes = by_inc | by_z | by_shape

    def detail(j):
        why = (f"reversal z {z[j]:.3g} (> {REVERSED_Z:g}; day-to-day reversal log-likelihood ratio {inc[j]:.3g})"
               if by_z[j] and not by_inc[j] else
               f"day-to-day reversal log-likelihood ratio {inc[j]:.3g} (> {REVERSED_ALL_DAYS_INC_LLR * lf[j]:.3g})")
        text = (f"all days: log Bayes factor of 'reversed' against 'healthy' {lbf[j]:.3g} (threshold "
                f"{REVERSED_ALL_DAYS_LBF:g}; information {evidence.information[j]:.3g}{_null_text(evidence)}), {why}")
        if np.isfinite(glr[j]):
            rule = (f"threshold {REVERSED_SHAPE_EVIDENCE:g}" if shape_rule == "threshold" else
                    f"score with the all-days one and the day-to-day ratio "
                    f"{lbf[j] + glr[j] + REVERSED_SUM_INC_WEIGHT * inc[j]:.3g}, threshold {REVERSED_SUM_LBF:g}, with the "
                    f"all-days one > {REVERSED_SHAPE_GATE_LBF:g} and the ratio > {REVERSED_SUM_GATE_INC_LLR:g}")
            text += (f"; with a localised settlement shape fitted to the other sensors, log Bayes factor {glr[j]:.3g} "
                     f"({rule}; information {shape.information[j]:.3g})")
        return text

    return _flag_worst(replace(health, reversal_evidence=evidence, shape_evidence=shape),
                       lbf + np.nan_to_num(glr, nan=0.0), passes, "reversed", detail, max_flagged)


def _null_text(evidence: ReversalEvidence) -> str:
    """The site's null of :func:`site_reversal_null`, for a flagged sensor's detail ('' when none was applied)."""
    if evidence.null_shift == 0.0 and evidence.null_scale == 1.0:
        return ""
    return (f"; against this site's healthy sensors: centre moved {evidence.null_shift:.2g}, spread x"
            f"{evidence.null_scale:.3g}")


def _flag_worst(health: SensorHealth, score, passes, status_name: str, detail, max_flagged: int | None):
    """Flag the kept sensor of largest ``score`` among those that ``passes`` (both thresholds of an all-days test):
    ``status_name`` and ``detail(j)``, excluded; none once ``max_flagged`` sensors (default :func:`flag_limit`; dead
    ones and the user's exclusions not counted, :func:`n_flagged`) are excluded or only 3 are left. Returns (health,
    index or None)."""
    max_flagged = flag_limit(health.status) if max_flagged is None else max_flagged
    ok = ~np.asarray(health.excluded)
    cand = ok & passes
    if not cand.any() or n_flagged(health.status) >= max_flagged or ok.sum() <= 3:
        return health, None
    j = int(np.argmax(np.where(cand, score, -np.inf)))
    status = np.array(health.status, dtype=object)
    details = np.array(health.detail, dtype=object)
    status[j] = status_name
    details[j] = detail(j)
    excluded = np.array(health.excluded, dtype=bool)
    excluded[j] = True
    return replace(health, status=np.array(status, dtype=str), detail=np.array(details, dtype=str),
                   excluded=excluded), j


def all_days_step_evidence(x, mode_slopes, mode_noise, to_modes, *, rigidity: float, penalty_order: int = 2,
                           sensor_factors=None, segment_weights=None,
                           sigma_z: float = DEFAULT_SIGMA_Z) -> StepEvidence:
    r"""Generalised log-likelihood ratio of "sensor i's readings jumped by a on day d and stayed" against "healthy".

    Beyond paper 004 (§6 flags improbable sensors; the all-days model of :mod:`~longprofile.rail._joint`). A detached
    sensor reads theta_i + a 1[day >= d]. In the all-days modes (``to_modes`` = V^T) the step is u_d = V^T 1[>= d],
    and with mu_ik, p_ik the leave-one-out predictive mean and variance of theta_ik from the other sensors
    (:func:`all_days_reversal_evidence`), v_ik(f) = p_ik + nu_k f^2 and r_ik = y_ik - mu_ik,

        log LR_i = max_{d, f_s} [L_i(f_s) + (sum_k u_dk r_ik / v_ik)^2 / (2 sum_k u_dk^2 / v_ik)] - max_{f_h} L_i(f_h),

    L_i(f) = sum_k log N(r_ik; 0, v_ik(f)). Sensor i's own noise factor f is fitted under each hypothesis (on the
    grid of :data:`PROFILE_FACTOR_BOUNDS`): a detached sensor's jump inflates the factor fitted from its residuals,
    which hides the jump from a test at that factor.

    Parameters
    ----------
    x, mode_slopes, mode_noise, rigidity, penalty_order, sensor_factors, segment_weights, sigma_z
        As :func:`all_days_reversal_evidence` (``sensor_factors`` only sets the other sensors' noise).
    to_modes : (K, K) ndarray
        ``DayModes.to_modes``.

    Returns
    -------
    StepEvidence
    """
    Y = np.asarray(mode_slopes, float)
    K, N = Y.shape
    f = np.ones(N) if sensor_factors is None else np.asarray(sensor_factors, float)
    mus, preds, own = _mode_loo(x, Y, mode_noise, f, rigidity=rigidity, penalty_order=penalty_order,
                                segment_weights=segment_weights, sigma_z=sigma_z)
    g = np.geomspace(*PROFILE_FACTOR_BOUNDS, PROFILE_FACTOR_GRID)
    U = np.asarray(to_modes, float) @ np.tril(np.ones((K, K)))  # column d - 1: V^T 1[day >= d]
    best = _step_maxima(U, Y - mus, np.maximum(preds, 0.0), own, g)
    gone = np.isnan(Y).all(axis=0)
    with np.errstate(invalid="ignore"):  # excluded sensors: -inf - -inf, 0 / 0
        llr = np.where(gone, np.nan, best["L1"] - best["L0"])
        size = np.where(gone, np.nan, best["A"] / best["B"])
    return StepEvidence(log_likelihood_ratio=llr, day=np.where(gone, -1, best["d"] + 1), size=size,
                        factor_healthy=np.where(gone, np.nan, g[best["g0"]]),
                        factor_step=np.where(gone, np.nan, g[best["g1"]]))


#: Factor values of :func:`all_days_step_evidence` evaluated together (a few MB of (G, K, N) arrays per block).
_STEP_FACTOR_BLOCK = 8


def _step_maxima(U, r, preds, own, g) -> dict:
    """max over (f, d) of L_i(f) + (u_d' r_i / v)^2 / (2 u_d'^2 / v) and max over f of L_i(f)
    (:func:`all_days_step_evidence`), with the first maximising indices and the step's sums A, B there, over blocks of factor values (the same values
    and ties as over all of them at once: each block's products are the same BLAS calls, a later block wins only
    when strictly larger)."""
    N = r.shape[1]
    cols = np.arange(N)
    best = {"L1": np.full(N, -np.inf), "L0": np.full(N, -np.inf), "d": np.zeros(N, int), "g1": np.zeros(N, int),
            "g0": np.zeros(N, int), "A": np.full(N, np.nan), "B": np.full(N, np.nan)}
    U2T = (U**2).T
    for lo in range(0, g.size, _STEP_FACTOR_BLOCK):
        gb = g[lo:lo + _STEP_FACTOR_BLOCK]
        var = preds[None] + own[None] * (gb**2)[:, None, None]  # (G, K, N)
        with np.errstate(invalid="ignore"):
            L0 = -0.5 * np.sum(np.log(var) + r[None] ** 2 / var, axis=1)  # (G, N)
            A = np.matmul(U.T, r[None] / var)  # (G, D-1, N): sum_k u_dk r_ik / v_ik (BLAS, one product per factor)
            B = np.matmul(U2T, 1.0 / var)
            L1 = L0[:, None, :] + 0.5 * A**2 / B  # (G, D-1, N)
        L0, L1 = np.nan_to_num(L0, nan=-np.inf), np.nan_to_num(L1, nan=-np.inf)
        flat = L1.reshape(-1, N)
        k1 = np.argmax(flat, axis=0)
        v1 = flat[k1, cols]
        gi, di = np.unravel_index(k1, L1.shape[:2])
        up = v1 > best["L1"]
        if lo == 0:
            up[:] = True
        best["L1"] = np.where(up, v1, best["L1"])
        best["d"] = np.where(up, di, best["d"])
        best["g1"] = np.where(up, lo + gi, best["g1"])
        best["A"] = np.where(up, A[gi, di, cols], best["A"])
        best["B"] = np.where(up, B[gi, di, cols], best["B"])
        k0 = np.argmax(L0, axis=0)
        v0 = L0[k0, cols]
        up0 = (v0 > best["L0"]) | (lo == 0)
        best["L0"] = np.where(up0, v0, best["L0"])
        best["g0"] = np.where(up0, lo + k0, best["g0"])
    return best


def flag_detached_all_days(health: SensorHealth, evidence: StepEvidence,
                           max_flagged: int | None = None) -> tuple[SensorHealth, int | None]:
    """Flag the kept sensor with the largest all-days step evidence, if any passes both thresholds.

    A sensor still "ok" is flagged "detached" when its step log-likelihood ratio (:func:`all_days_step_evidence`)
    exceeds :data:`DETACHED_ALL_DAYS_LLR` and its day-to-day step statistic (``health.step_z``) exceeds
    :data:`DETACHED_ALL_DAYS_STEP_Z`, unless it is one of ``health.witness`` (``witness_rule="steps"`` of
    :func:`assess_sensors`: its departure grew in separate same-sign steps). One sensor at a time and the same limits
    as :func:`flag_reversed_all_days`.

    Returns
    -------
    health : SensorHealth
        With ``step_evidence`` set, and the flagged sensor's status, detail and exclusion.
    flagged : int or None
        Index of the flagged sensor.
    """
    llr = np.nan_to_num(evidence.log_likelihood_ratio, nan=-np.inf)
    N = health.status.size
    step = np.nan_to_num(health.step_z, nan=-np.inf) if health.step_z is not None else np.full(N, -np.inf)
    witness = np.zeros(N, bool) if health.witness is None else np.asarray(health.witness, bool)
    return _flag_worst(
        replace(health, step_evidence=evidence), llr,
        (llr > DETACHED_ALL_DAYS_LLR) & (step > DETACHED_ALL_DAYS_STEP_Z) & ~witness,
        "detached", lambda j: (f"all days: a step of {np.rad2deg(evidence.size[j]):.2g} deg from day {evidence.day[j]} "
                               f"on, log-likelihood ratio against 'healthy' {llr[j]:.3g} (threshold "
                               f"{DETACHED_ALL_DAYS_LLR:g}; noise factor {evidence.factor_healthy[j]:.2g} healthy, "
                               f"{evidence.factor_step[j]:.2g} with the step), day-to-day step statistic "
                               f"{step[j]:.3g} (> {DETACHED_ALL_DAYS_STEP_Z:g})"),
        max_flagged)
