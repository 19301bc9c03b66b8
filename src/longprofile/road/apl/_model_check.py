"""Does the trailer model fit the record? An innovation diagnostic (issue 13; paper 000, §5).

The printed std of a Kalman reconstruction (paper 000, §5: the filter/smoother of the model y = H u + e with the
trailer's H(z) of eq. (1)) holds when the model holds. A trailer whose pendulum or damper frequency differs from the
model file's (speed, wear, calibration) gives an estimate whose error the std does not contain; with the tolerance
declared (``instrument_uncertainty``) the std includes it, without it the std under-covers (``benchmarks
road_calibration``, "trailer mismatch, tolerance not declared": 50.8 % / 64.8 % of the 90 % band).

Here the record itself is asked whether the model fits, by the whiteness of the filter's innovations (Mehra, "On the
identification of variances and adaptive Kalman filtering", IEEE TAC 15, 1970; the normalised innovation squared of
Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to Tracking and Navigation*, 2001, §5.4): under the
model the normalised innovations nu_k = e_k / sqrt(S_k) of the filter the reconstruction runs are white with unit
variance, so their spectrum is flat. With maximum-likelihood q and r the *overall* NIS is 1 by construction (r is
concentrated out as mean e_k^2 / S_k), so the overall NIS cannot see a mismatch; its *spectral shape* can: a wrong
pendulum or damper frequency tilts the innovation spectrum across the wavenumbers the trailer resolves.

The test (a homogeneity test of the NIS per band):

1. Welch's spectrum of nu (Hann, :data:`MODEL_CHECK_SEGMENT` samples, half overlap, after the first
   :data:`MODEL_CHECK_SKIP` samples of the filter's start-up; missing samples dropped).
2. In half-octave bands of the wavenumbers where the model resolves the road (|H|^2 S_model / r >=
   :data:`MODEL_CHECK_MIN_SNR`; from the segment's third bin up to :data:`MODEL_CHECK_MAX_WAVENUMBER`), the band NIS
   n_b = mean P_b / 2 (two-sided; 1 for white unit innovations) with k_b ~ 2 (bins) (segments) / 1.5 degrees of
   freedom (:data:`_WELCH_CORRELATION`; an approximation: own-model records give X well below its dof, but on white
   unit innovations of 40 000 samples the test rejects about 0.5 % of records at alpha = 1e-3 and p < 0.05 on 11 %:
   anti-conservative in the tail, measured 2026-12-06, tests/road/apl/test_model_check.py).
3. X = sum_b (k_b / 2) (ln n_b - m)^2 with m the k-weighted mean of ln n_b: for white innovations ln n_b has
   variance ~ 2 / k_b, so X ~ chi^2(B - 1). The model is rejected when the p-value is below
   :data:`MODEL_CHECK_ALPHA`.

A flat but wrong level (white or coloured noise of the same level at every tested band; a road rougher than the model)
is not what this test looks at: only the shape.

**A diagnostic, not a guard (negative result, 2026-12-06).** For a stationary Gaussian model the innovations are the
record through the model's whitening filter, so their spectrum is S_y / S_y,model with S_y = |H|^2 S_road + r: the
trailer's |H| and the road's spectrum enter only as their product, and the phase of H not at all. The test therefore
rejects a trailer whose frequencies differ from the model's (6 of 8 draws of ``road_calibration``'s "trailer
mismatch" at seed 0) *and* a real road whose spectrum is not the model's n^-2 law (8 of 8 draws of the measured
Sroubek-Sorel road, X = 512-616 against 3-233 on the mismatch draws), and it cannot tell which. Wired into the printed
std (adding the instrument-uncertainty term at a default tolerance when rejected) it would have moved the measured-road
row out of 85-95 % and left the mismatch row under 85 %; it is therefore not used by :func:`reconstruct_profile`
(docs/road-apl.md, "An undeclared trailer mismatch: what the innovations can tell"). Assumptions (named): Gaussian
innovations, approximately independent Welch bands. :data:`MODEL_CHECK_MAX_WAVENUMBER` was chosen on generator seed
1000 of ``benchmarks road_calibration`` (the rows quoted above: seed 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal, stats

from ._model import APLModel

__all__ = ["MODEL_CHECK_SEGMENT", "MODEL_CHECK_SKIP", "MODEL_CHECK_MIN_SNR", "MODEL_CHECK_ALPHA",
           "MODEL_CHECK_MAX_WAVENUMBER", "MODEL_CHECK_MIN_BANDS", "InnovationCheck", "innovation_check"]

#: Welch segment of the innovation spectrum, samples.
MODEL_CHECK_SEGMENT = 1024
#: Samples left out at the start (the filter's start-up).
MODEL_CHECK_SKIP = 2048
#: A band counts as resolved where the model's |H|^2 S_model / r is at least this.
MODEL_CHECK_MIN_SNR = 1.0
#: Highest wavenumber tested, cycles/m: inside ISO 8608's single power law (n^-2 between 0.011 and 2.83 cycles/m), so
#: that a road of that law gives a flat ratio there (seed 1000: up to the Nyquist wavenumber, the ISO generator's
#: roll-off, coloured noise and drift were rejected too; up to 1 cycle/m, no trailer mismatch was; 2 cycles/m
#: separated the synthetic families: 6 of 8 mismatches rejected, none of 48 draws of own model, classes, noise levels,
#: coloured noise, drift and low speed).
MODEL_CHECK_MAX_WAVENUMBER = 2.0
#: Rejection level of the test.
MODEL_CHECK_ALPHA = 1e-3
#: Fewest bands for a test (else no verdict: not rejected).
MODEL_CHECK_MIN_BANDS = 4
#: Welch periodogram bins per independent degree of freedom (Hann window, half overlap; an approximation).
_WELCH_CORRELATION = 1.5
#: Lowest Welch bin used.
_LOWEST_BIN = 2


@dataclass(frozen=True)
class InnovationCheck:
    """The innovation test of :func:`innovation_check`.

    Attributes
    ----------
    statistic : float
        X = sum_b (k_b / 2) (ln n_b - m)^2 (chi^2 with ``dof`` degrees of freedom under the model).
    dof : int
        Bands minus one.
    p_value : float
        P(chi^2_dof >= X); 1.0 without a verdict.
    rejected : bool
        p_value < alpha: the innovations' spectrum is not flat across the resolved band -- the model does not fit.
    wavenumber : (B,) ndarray
        Band centres, cycles/m.
    band_nis : (B,) ndarray
        Normalised innovation squared per band (1 under the model).
    overall_nis : float
        mean nu_k^2 (1 under the model; 1 by construction with ML q and r).
    """

    statistic: float
    dof: int
    p_value: float
    rejected: bool
    wavenumber: np.ndarray
    band_nis: np.ndarray
    overall_nis: float


def innovation_check(innovation, innovation_var, instrument: APLModel, r: float, model_spectrum, dx: float, *,
                     alpha: float = MODEL_CHECK_ALPHA) -> InnovationCheck:
    """Test the whiteness of a Kalman filter's innovations across the wavenumbers the trailer resolves.

    Parameters
    ----------
    innovation, innovation_var : (T,) array_like
        The filter's innovations e_k (m) and their predicted variances S_k (m^2); NaN where the sample is missing.
    instrument : APLModel
        The trailer model of the reconstruction (paper 000, eq. 1).
    r : float
        White-noise variance of the model, m^2.
    model_spectrum : callable
        w (rad/sample) -> the model's road spectrum S_model (m^2 per rad/sample, paper 000 eq. 7 for the Wiener road).
    dx : float
        Sample spacing, m.
    alpha : float
        Rejection level (default :data:`MODEL_CHECK_ALPHA`).

    Returns
    -------
    InnovationCheck
        The method is the module's: Welch spectrum of nu_k = e_k / sqrt(S_k), half-octave band NIS over the resolved
        wavenumbers, chi^2 homogeneity of their logarithms (Mehra 1970; Bar-Shalom et al. 2001, §5.4).
    """
    e = np.asarray(innovation, dtype=float).reshape(-1)
    s = np.asarray(innovation_var, dtype=float).reshape(-1)
    nu = (e / np.sqrt(s))[MODEL_CHECK_SKIP:]
    nu = nu[np.isfinite(nu)]
    empty = InnovationCheck(0.0, 0, 1.0, False, np.zeros(0), np.zeros(0),
                            float(np.mean(nu ** 2)) if nu.size else float("nan"))
    if nu.size < 4 * MODEL_CHECK_SEGMENT:
        return empty
    f, P = signal.welch(nu, nperseg=MODEL_CHECK_SEGMENT, detrend=False)  # f in cycles/sample, one-sided
    n_seg = 2 * nu.size / MODEL_CHECK_SEGMENT - 1
    w = 2 * np.pi * f
    h = instrument.response_at(f / instrument.dt)
    snr = np.abs(h) ** 2 * model_spectrum(np.maximum(w, 1e-12)) / r
    idx = np.flatnonzero((np.arange(f.size) >= _LOWEST_BIN) & (snr >= MODEL_CHECK_MIN_SNR)
                     & (f / dx <= MODEL_CHECK_MAX_WAVENUMBER))
    if idx.size == 0:
        return empty
    edges = f[idx[0]] * 2.0 ** (0.5 * np.arange(0, 40))
    centres, nis, dofs = [], [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        b = idx[(f[idx] >= lo) & (f[idx] < hi)]
        if b.size == 0:
            if lo > f[idx[-1]]:
                break
            continue
        centres.append(np.sqrt(lo * hi) / dx)
        nis.append(P[b].mean() / 2)
        dofs.append(2 * b.size * n_seg / _WELCH_CORRELATION)
    if len(nis) < MODEL_CHECK_MIN_BANDS:
        return empty
    ln, k = np.log(np.asarray(nis)), np.asarray(dofs)
    m = np.sum(k * ln) / np.sum(k)
    x = float(np.sum(k / 2 * (ln - m) ** 2))
    dof = len(nis) - 1
    p = float(stats.chi2.sf(x, dof))
    return InnovationCheck(x, dof, p, p < alpha, np.asarray(centres), np.exp(ln), float(np.mean(nu ** 2)))
