"""Calibration harness: does the settlement estimator's uncertainty hold on independent scenarios? (issue 13)

For each draw of a scenario family (:mod:`longprofile.rail._scenarios`, a simulator written
apart from the estimator's own noise model) the site is validated and estimated with the same
call ``rail settle`` makes (:func:`~longprofile.rail.estimate_settlement`), and every interval
the tool prints is scored against the truth:

* the daily settlement 90 % band dz -/+ 1.645 dz_std (``dz_lower90_m``/``dz_upper90_m``);
* the through-time (smoothed) settlement band and the daily-rate band (``smoothed_std_m``,
  ``rate_std_m_per_day``), true rate = difference of the true settlement of consecutive days;
* the maximum settlement max_i(-dz_i) against max_i(-s_i): coverage of the printed 90 % interval
  (``max_settlement_lower``/``upper``: by default the interval holding 98 % of the draws' maxima, docs/rail.md
  step 13), PIT and RMS z of the Monte Carlo mean and
  std (§4.3).

Scores: empirical coverage of the 90 % interval, the PIT histogram u = Phi(z) with
z = (estimate - truth) / std (uniform when calibrated), the RMS of z (1 when calibrated), the
settlement RMS error, and the sensor-health detection and false-alarm rates. Day 0 (the
reference, zero change by construction) is left out.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.special import ndtr

from ._data import validate_site
from ._rigidity import Z90
from ._scenarios import SCENARIO_FAMILIES, SHAPE_FAMILIES, ScenarioFamily, simulate_scenario
from ._settle import estimate_settlement

__all__ = ["IntervalScore", "FamilyCalibration", "score_intervals", "interval_hits", "calibrate_family", "PIT_BINS"]

#: Number of equal bins of the PIT histogram.
PIT_BINS = 10


@dataclass(frozen=True)
class IntervalScore:
    """Scores of one printed interval over all draws of a family.

    Attributes
    ----------
    coverage : float
        Share of (draw, day, station) cases whose truth lies inside the 90 % interval, pooled.
    coverage_by_draw : tuple of float
        The same per draw (its spread says how noisy one site's coverage is).
    pit : tuple of float
        Share of cases in each of :data:`PIT_BINS` equal bins of Phi(z) (1/PIT_BINS each when calibrated).
    rms_z : float
        RMS of the standardised errors z (1 when calibrated).
    n : int
        Number of cases.
    """

    coverage: float
    coverage_by_draw: tuple
    pit: tuple
    rms_z: float
    n: int


@dataclass(frozen=True)
class FamilyCalibration:
    """Calibration of the estimator on one scenario family.

    Attributes
    ----------
    family : str
    seeds : tuple of int
    intervals : dict of str -> IntervalScore
        Keys "daily", "smoothed", "rate", "max_settlement" (those the result carries).
    rms_mm_by_draw : tuple of float
        Settlement RMS error (daily posterior mean vs truth, all stations, days >= 1) per draw, mm.
    detected : dict of str -> (int, int)
        Fault kind -> (faulty sensors flagged, faulty sensors).
    false_alarms : (int, int)
        (healthy sensors flagged, healthy sensors).
    options : dict
        Keyword options passed to :func:`estimate_settlement`.
    missed : tuple of (seed, sensor_id, kind, mm, z)
        Every faulty sensor not flagged, with what the miss costs: the largest change of the daily
        settlement (days >= 1, any station) when that sensor is excluded as well, in mm and in units of
        the band std (``dz_std``) of the result that kept it.
    faults : tuple of (seed, sensor_id, kind, flagged, snr)
        Every faulty sensor, whether it was flagged and the signal-to-noise ratio of its fault: the largest true
        |slope change| at its station over the days divided by the estimator's noise std of the last day
        (``sigma_by_day[-1]``) — how much a reversal can show (docs/rail.md, sensor health).
    control_checks : tuple of (seed, disagree, daily_coverage)
        For a family with control surveys (``ScenarioFamily.control_surveys``): whether the estimate's
        :attr:`~longprofile.rail.SettlementResult.control_check` said the surveys disagree, and the site's own
        coverage of the daily 90 % band (what the check should catch: a site whose bands are wrong).
    """

    family: str
    seeds: tuple
    intervals: dict
    rms_mm_by_draw: tuple
    detected: dict
    false_alarms: tuple
    options: dict = field(default_factory=dict)
    missed: tuple = ()
    faults: tuple = ()
    control_checks: tuple = ()

    def detection_by_snr(self, kind: str, edges=(2.0, 4.0, 8.0)) -> list[tuple[float, float, int, int]]:
        """(low, high, flagged, total) of the faults of ``kind`` by SNR bins (``faults``; edges inclusive below)."""
        bounds = (0.0, *edges, np.inf)
        out = []
        for lo, hi in zip(bounds[:-1], bounds[1:]):
            sel = [f for f in self.faults if f[2] == kind and lo <= f[4] < hi]
            out.append((lo, hi, sum(bool(f[3]) for f in sel), len(sel)))
        return out

    def harmful_misses(self, z: float = 1.0) -> list:
        """The missed faults whose exclusion moves the settlement by more than ``z`` band std somewhere."""
        return [m for m in self.missed if m[4] > z]

    @property
    def detection_rate(self) -> float:
        hit = sum(h for h, _ in self.detected.values())
        tot = sum(t for _, t in self.detected.values())
        return hit / tot if tot else float("nan")

    @property
    def false_alarm_rate(self) -> float:
        return self.false_alarms[0] / self.false_alarms[1] if self.false_alarms[1] else float("nan")


def _z(err, std):
    ok = np.isfinite(err) & np.isfinite(std) & (std > 0)
    return err[ok] / std[ok]


def score_intervals(scenario, result) -> dict:
    """Standardised errors of every printed interval of one estimate against its scenario's truth.

    Returns
    -------
    dict of str -> (n,) ndarray
        z = (estimate - truth) / std for "daily", "smoothed", "rate", "max_settlement"; days >= 1.
    """
    s = scenario.truth.settlement
    out = {"daily": _z(result.dz[1:] - s[1:], result.dz_std[1:])}
    if result.smoothed is not None:
        out["smoothed"] = _z(result.smoothed.mean[1:] - s[1:], result.smoothed.std[1:])
        out["rate"] = _z(result.smoothed.rate[1:] - np.diff(s, axis=0), result.smoothed.rate_std[1:])
    if np.isfinite(result.max_settlement_mean).any():
        out["max_settlement"] = _z(result.max_settlement_mean[1:] - np.max(-s[1:], axis=1),
                                   result.max_settlement_std[1:])
    return out


def interval_hits(scenario, result) -> dict:
    """Whether the truth lies inside the printed intervals that are not mean -/+ 1.645 std, days >= 1.

    Returns
    -------
    dict of str -> (n,) bool ndarray
        "max_settlement": ``max_settlement_lower <= max_i(-s_i) <= max_settlement_upper`` (when the result
        carries that interval and the Monte Carlo ran).
    """
    lo, hi = result.max_settlement_lower, result.max_settlement_upper
    if lo is None or hi is None or not np.isfinite(lo).any():
        return {}
    truth = np.max(-scenario.truth.settlement[1:], axis=1)
    ok = np.isfinite(lo[1:]) & np.isfinite(hi[1:])
    return {"max_settlement": ((lo[1:] <= truth) & (truth <= hi[1:]))[ok]}


def _interval_score(zs, hits=None) -> IntervalScore:
    allz = np.concatenate(zs) if zs else np.array([])
    if allz.size == 0:
        return IntervalScore(float("nan"), (), (), float("nan"), 0)
    pit = np.histogram(ndtr(allz), bins=PIT_BINS, range=(0.0, 1.0))[0] / allz.size
    if hits:  # the printed interval is not mean -/+ 1.645 std: its own coverage
        return IntervalScore(coverage=float(np.mean(np.concatenate(hits))),
                             coverage_by_draw=tuple(float(np.mean(h)) for h in hits if h.size),
                             pit=tuple(float(p) for p in pit), rms_z=float(np.sqrt(np.mean(allz**2))),
                             n=int(allz.size))
    return IntervalScore(coverage=float(np.mean(np.abs(allz) <= Z90)),
                         coverage_by_draw=tuple(float(np.mean(np.abs(z) <= Z90)) for z in zs if z.size),
                         pit=tuple(float(p) for p in pit), rms_z=float(np.sqrt(np.mean(allz**2))), n=int(allz.size))


def calibrate_family(family: ScenarioFamily | str, seeds, **options) -> FamilyCalibration:
    """Estimate every draw of a scenario family and score the printed intervals against the truth.

    Parameters
    ----------
    family : ScenarioFamily or str
        A member of :data:`~longprofile.rail.SCENARIO_FAMILIES` or its name.
    seeds : iterable of int
        One draw per seed (:func:`~longprofile.rail.simulate_scenario`).
    **options
        Passed to :func:`estimate_settlement` (default: the options ``rail settle`` uses by default).

    Returns
    -------
    FamilyCalibration
    """
    fam = {**SCENARIO_FAMILIES, **SHAPE_FAMILIES}[family] if isinstance(family, str) else family
    seeds = tuple(int(s) for s in seeds)
    zs: dict = {}
    hits: dict = {}
    rms, detected, fa, n_ok, missed, faults, checks = [], {}, 0, 0, [], [], []
    for seed in seeds:
        sc = simulate_scenario(fam, seed)
        site = validate_site(sc.sensors, sc.readings, sc.survey, sc.controls)
        res = estimate_settlement(site, **options)
        for k, z in score_intervals(sc, res).items():
            zs.setdefault(k, []).append(z)
        if res.control_check is not None:
            daily = (res.dz[1:] - sc.truth.settlement[1:]) / res.dz_std[1:]
            checks.append((seed, bool(res.control_check.disagree), float(np.mean(np.abs(daily) <= Z90))))
        for k, h in interval_hits(sc, res).items():
            hits.setdefault(k, []).append(h)
        err = res.dz[1:] - sc.truth.settlement[1:]
        rms.append(float(1e3 * np.sqrt(np.mean(err**2))))
        flagged = {sid for sid, _, _ in res.health.flagged()}
        snr = np.max(np.abs(sc.truth.slope_change), axis=0) / float(res.sigma_by_day[-1])
        for sid, kind in sc.truth.faults.items():
            faults.append((seed, sid, kind, sid in flagged, float(snr[res.sensor_ids.index(sid)])))
            h, t = detected.get(kind, (0, 0))
            detected[kind] = (h + (sid in flagged), t + 1)
            if sid not in flagged:
                missed.append((seed, sid, kind, *_cost_of_missing(site, res, flagged | {sid}, options)))
        healthy = set(res.sensor_ids) - set(sc.truth.faults)
        fa += len(flagged & healthy)
        n_ok += len(healthy)
    return FamilyCalibration(family=fam.name, seeds=seeds, intervals={k: _interval_score(v, hits.get(k)) for k, v in zs.items()},
                             rms_mm_by_draw=tuple(rms), detected=detected, false_alarms=(fa, n_ok),
                             options=dict(options), missed=tuple(missed), faults=tuple(faults),
                             control_checks=tuple(checks))


def _cost_of_missing(site, res, exclude, options) -> tuple[float, float]:
    """(mm, band std) of the largest change of the daily settlement when ``exclude`` are all left out."""
    opts = {**options, "n_monte_carlo": 0, "check_health": False, "exclude_sensors": tuple(sorted(exclude))}
    other = estimate_settlement(site, **opts)
    d = np.abs(res.dz[1:] - other.dz[1:])
    with np.errstate(divide="ignore", invalid="ignore"):
        z = d / res.dz_std[1:]
    return float(1e3 * np.nanmax(d)), float(np.nanmax(z))
