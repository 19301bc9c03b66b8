"""The road's short-wave content, estimated from the APL record itself (issue 13; paper 000, §5).

The printed std of a Kalman reconstruction (:func:`smoother_error_std`, :func:`fixed_lag_error_std`) is the error
spectrum of the estimate integrated through the detrending. Where the trailer resolves the road (|H|^2 S_u >> r)
that error is the noise seen through the inverse filter, r / |H|^2, whatever the road; where it does not -- beyond
the damper's low-pass, shorter than about 0.35 m at 20 m/s -- the error *is* the road's content there, and the
model's prior S_u (paper 000, eq. 7: the Wiener road, S_u = q / |1 - e^{-jw}|^2, the n^-2 law of ISO 8608 continued
up to the sampling's Nyquist wavenumber) stands in for it. Roads with no waves shorter than the APL resolves (ISO
8608's generator range stops at 2.83 cycles/m; a profile sampled at 0.25 m) then get a band about twice their error.

Here the road's spectrum relative to the model's, c(w) = S_road / S_model, is measured on the record where the
record can show it, and continued beyond:

1. The record's spectrum by Welch's method (Hann segments of :data:`SHORT_WAVE_SEGMENT` samples, half overlap,
   segments with a missing sample left out; the segment's three lowest bins are not used). For a linear instrument with white noise, E[P_y] = |H|^2 S_road + r.
2. In fractional-octave bands (:data:`SHORT_WAVE_BANDS_PER_OCTAVE`), the moment estimate
   c_b = sum(P_y - r) / sum(|H|^2 S_model) (clipped at 0), kept where the model's signal-to-noise ratio
   s_b = mean(|H|^2 S_model) / r is at least :data:`SHORT_WAVE_MIN_SNR` (the resolved bands; there the relative
   error of c_b is about (1 + s_b) / (s_b sqrt(dof))).
3. Beyond the last resolved band the road is assumed to continue the log-log slope of c over the last resolved
   half octave, never rising (a road spectrum falls at least as fast as the model's n^-2 law at short waves; a
   rising slope is taken as flat), and no steeper than the record supports: the fitted slope plus
   :data:`SHORT_WAVE_SLOPE_SIGNIFICANCE` standard errors, c(w) = c_last (w / w_last)^min(slope + 2 se, 0) (since
   2026-12-06; before, the fitted slope once it passed that test). Below the first resolved band, c = its value.

The printed error variance of a linear estimate u_hat = G y under the estimated road (the plug-in, mismatched-filter
form of paper 000's smoother error, the Wiener-filter error spectrum of an estimator built on another spectrum):

    S_e(w) = |G H - 1|^2 c(w) S_model(w) + |G|^2 r,

which is the model's own S_model r / (r + |H|^2 S_model) for the smoother when c = 1. The tuning constants were
chosen on generator seeds 1000-1007 of ``benchmarks road_calibration``'s families (the reported rows use seed 0);
docs/road-apl.md, "Short waves from the record".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._model import APLModel

__all__ = ["SHORT_WAVE_SEGMENT", "SHORT_WAVE_BANDS_PER_OCTAVE", "SHORT_WAVE_MIN_SNR", "SHORT_WAVE_SLOPE_OCTAVES",
           "SHORT_WAVE_NOISE_FLOOR_SNR", "SHORT_WAVE_NOISE_FLOOR_RANGE", "SHORT_WAVE_OPTIONS",
           "RoadSpectrumRatio", "estimate_road_spectrum_ratio", "record_error_std"]

#: Welch segment, samples (204.8 m at 5 cm: the shortest wavenumber is 0.005 cycles/m).
SHORT_WAVE_SEGMENT = 4096
#: At most this many Welch segments (evenly spread over a long record; O(segments x segment) memory).
SHORT_WAVE_MAX_SEGMENTS = 256
#: Bands per octave of the ratio estimate.
SHORT_WAVE_BANDS_PER_OCTAVE = 6
#: The model signal-to-noise ratio above which a band counts as resolved (tuned on seeds 1000-1007).
SHORT_WAVE_MIN_SNR = 0.3
#: The slope continued beyond the resolved bands is fitted over their last this-many octaves.
SHORT_WAVE_SLOPE_OCTAVES = 0.5
#: ... continued at this many standard errors above the fitted slope, when that is still negative (else the model's
#: slope): the least steep decline the record supports.
SHORT_WAVE_SLOPE_SIGNIFICANCE = 2.0
#: The noise floor: wavenumbers where the model's |H|^2 S_model / r is below this.
SHORT_WAVE_NOISE_FLOOR_SNR = 0.01
#: The estimate is used only when the noise floor's power over r is in this range (tuned on seeds 1000-1001 of the
#: calibration families: white noise with the ML r gave 0.99-1.21, AR(1) noise of correlation 0.5-5 m 0.88-0.93).
SHORT_WAVE_NOISE_FLOOR_RANGE = (0.95, 1.5)
#: Fewest noise-floor bins for the whiteness check.
_NOISE_FLOOR_BINS = 16
#: Welch periodogram bins per independent degree of freedom (Hann window, half overlap; an approximation).
_WELCH_CORRELATION = 1.5
#: The lowest Welch bin used (1 = the segment's fundamental; 4 = 0.02 cycles/m at 5 cm): below it c is held at the
#: first band's value (the lowest bins are biased by the Hann window's leakage and the segment mean: at 6 m/s they
#: gave c ~ 10^3 at 0.005 cycles/m on ISO roads, which have nothing below 0.011 cycles/m; tuned on seeds 1000-1001).
_LOWEST_BIN = 4
#: Floor of c in the log-slope fit.
_RATIO_FLOOR = 1e-3
#: ``reconstruct_profile(short_waves=...)``: "record" (the estimate here, default) or "prior" (the model's spectrum
#: everywhere, the printed std before 2026-12-06).
SHORT_WAVE_OPTIONS = ("record", "prior")


@dataclass(frozen=True)
class RoadSpectrumRatio:
    """The road's spectrum relative to a reconstruction model's, estimated from a record.

    Attributes
    ----------
    frequency : (B,) ndarray
        Centres of the resolved bands, rad/sample (w = 2 pi n dx).
    ratio : (B,) ndarray
        c_b = S_road / S_model in each resolved band (>= 0).
    snr : (B,) ndarray
        The model's |H|^2 S_model / r in each resolved band.
    level : float
        c at the last resolved band's centre as continued beyond it (the fitted line's value there).
    slope : float
        d log c / d log w continued beyond the last resolved band (<= 0).
    n_segments : int
        Welch segments used.
    noise_floor_ratio : float
        Mean power of the record at the wavenumbers where the model's road is below
        :data:`SHORT_WAVE_NOISE_FLOOR_SNR` of the noise, over r: ~1 for white noise (1.0 when there are no such
        wavenumbers).
    """

    frequency: np.ndarray
    ratio: np.ndarray
    snr: np.ndarray
    level: float
    slope: float
    n_segments: int
    noise_floor_ratio: float = 1.0

    @property
    def white_noise(self) -> bool:
        """The noise check: the record's power where the road is invisible, over r, is within
        :data:`SHORT_WAVE_NOISE_FLOOR_RANGE`. Below it the noise is red (weaker at short waves than its white ML
        level, and at long waves indistinguishable from road); above it the record is noisier than the model's r
        (e.g. an r given by hand). Either way the estimate, which subtracts r, is not used."""
        lo, hi = SHORT_WAVE_NOISE_FLOOR_RANGE
        return lo <= self.noise_floor_ratio <= hi

    def at(self, w) -> np.ndarray:
        """c(w) on any grid (rad/sample): interpolated in log w between resolved bands, the first band's value below
        them, level (w / w_last)^slope above them."""
        w = np.asarray(w, dtype=float)
        lw = np.log(np.maximum(w, 1e-300))
        lf = np.log(self.frequency)
        c = np.interp(lw, lf, self.ratio)
        above = lw > lf[-1]
        c[above] = self.level * np.exp(self.slope * (lw[above] - lf[-1]))
        return c


def _welch(y: np.ndarray, segment: int) -> tuple[np.ndarray, np.ndarray, int]:
    """(w, mean periodogram P with E[P] = S(w) for var = (1/pi) int_0^pi S dw, segments used); segments with NaN
    left out."""
    n = y.size
    seg = int(min(segment, 1 << int(np.floor(np.log2(max(n, 2))))))
    rows = np.lib.stride_tricks.sliding_window_view(y, seg)[::seg // 2]
    if rows.shape[0] > SHORT_WAVE_MAX_SEGMENTS:  # a long record: evenly spread segments are plenty
        rows = rows[np.linspace(0, rows.shape[0] - 1, SHORT_WAVE_MAX_SEGMENTS).round().astype(int)]
    rows = rows[~np.isnan(rows).any(axis=1)]
    used = rows.shape[0]
    win = np.hanning(seg)
    acc = np.zeros(seg // 2)
    if used:
        x = (rows - rows.mean(axis=1, keepdims=True)) * win
        acc = np.sum(np.abs(np.fft.rfft(x, axis=1)[:, 1:seg // 2 + 1]) ** 2, axis=0)
    w = 2 * np.pi * np.arange(1, seg // 2 + 1) / seg
    return w, acc / max(used, 1) / np.sum(win ** 2), used


def estimate_road_spectrum_ratio(y, instrument: APLModel, r: float, model_spectrum, *,
                                 segment: int = SHORT_WAVE_SEGMENT,
                                 bands_per_octave: int = SHORT_WAVE_BANDS_PER_OCTAVE,
                                 min_snr: float = SHORT_WAVE_MIN_SNR,
                                 slope_octaves: float = SHORT_WAVE_SLOPE_OCTAVES,
                                 significance: float = SHORT_WAVE_SLOPE_SIGNIFICANCE,
                                 noise=None) -> RoadSpectrumRatio | None:
    """Estimate c(w) = S_road / S_model from an APL record (module docstring; paper 000 eq. 1 for H, eq. 7 for the
    Wiener model spectrum).

    Parameters
    ----------
    y : (T,) array_like
        The APL signal, m (NaN: missing; segments holding one are left out).
    instrument : APLModel
        The trailer model of the reconstruction (its ``dt`` sets the frequency of w).
    r : float
        White-noise variance of the reconstruction, m^2.
    model_spectrum : callable
        w (rad/sample) -> the reconstruction's road spectrum S_model(w), m^2 (var = (1/pi) int_0^pi S dw).
    noise : callable, optional
        w (rad/sample) -> the expected power of the record's noise, m^2 (var = (1/pi) int_0^pi N dw), where it is not
        white of variance r: a time-sampled record taken at every dx by linear interpolation (its noise averaged
        between the file's samples: ``reconstruct_time_sampled``). It replaces r in the band estimates, their
        signal-to-noise ratio and the noise check. Default None: white noise of variance r.

    Returns
    -------
    RoadSpectrumRatio or None
        None when no complete segment or no resolved band exists (the caller keeps the model's spectrum).
    """
    y = np.asarray(y, dtype=float).reshape(-1)
    w, P, used = _welch(y, segment)
    if used == 0:
        return None
    H2 = np.abs(instrument.response_at(w / (2 * np.pi * instrument.dt))) ** 2
    Sm = np.asarray(model_spectrum(w), dtype=float)
    signal_m = H2 * Sm
    N = r if noise is None else np.asarray(noise(w), dtype=float)
    low = np.arange(w.size) < _LOWEST_BIN - 1  # the lowest bins: biased by the Hann window and the segment mean
    edges = w[0] * 2.0 ** (np.arange(0, np.log2(np.pi / w[0]) * bands_per_octave + 2) / bands_per_octave)
    idx = np.searchsorted(edges, w, side="right") - 1
    cen, rat, snr, err = [], [], [], []
    for b in np.unique(idx):
        m = (idx == b) & ~low
        if not m.any():
            continue
        Nb = r if noise is None else float(np.mean(N[m]))
        s = float(np.mean(signal_m[m]) / Nb)
        if s < min_snr or not np.isfinite(s):
            continue
        c = max(float(np.sum(P[m] - (r if noise is None else N[m])) / np.sum(signal_m[m])), 0.0)
        dof = m.sum() * used / _WELCH_CORRELATION
        cen.append(float(np.exp(np.mean(np.log(w[m])))))
        rat.append(c)
        snr.append(s)
        err.append((c * s + 1.0) / (s * np.sqrt(dof)))  # std of c_b: that of sum(P) over sum(|H|^2 S_model)
    if not cen:
        return None
    cen, rat, snr, err = map(np.array, (cen, rat, snr, err))
    level, slope = _continuation(cen, rat, err, slope_octaves, significance)
    return RoadSpectrumRatio(frequency=cen, ratio=rat, snr=snr, level=level, slope=slope, n_segments=used,
                             noise_floor_ratio=_noise_floor_ratio(P, signal_m / N, N))


def _noise_floor_ratio(P, snr, r) -> float:
    """Mean power of the record where the model's road is invisible (snr below :data:`SHORT_WAVE_NOISE_FLOOR_SNR`)
    over the white-noise variance r (or over the noise's expected power there, an array ``r``): ~1 (or a little
    above, the road's residue) for white noise; 1.0 with fewer than :data:`_NOISE_FLOOR_BINS` such bins."""
    floor = snr < SHORT_WAVE_NOISE_FLOOR_SNR
    if floor.sum() < _NOISE_FLOOR_BINS:
        return 1.0
    if np.ndim(r):
        return float(np.mean(P[floor]) / np.mean(r[floor]))
    return float(np.mean(P[floor]) / r)


def _continuation(cen, rat, err, octaves, significance) -> tuple[float, float]:
    """(c at the last resolved band, slope d log c / d log w beyond it) from a weighted least-squares line of log c_b
    over the last ``octaves`` of resolved bands (weights 1 / var(log c_b) from the std of each c_b). The slope
    continued is the least steep decline the record supports, the fitted slope plus ``significance`` standard errors
    (the line through the bands' weighted centroid), when that is still negative; otherwise the model's own slope
    (slope 0) at the weighted mean level of those bands. (Before 2026-12-06 the fitted slope itself was continued
    once it passed the same test: a slope just past the test, e.g. a chance one on a road that goes on at the model's
    n^-2 law, was extrapolated over the 2-3 octaves to the Nyquist wavenumber; docs/road-apl.md, "The noise-levels
    cell and the short-wave continuation".)"""
    last = cen >= cen[-1] / 2.0 ** octaves
    c = np.maximum(rat[last], _RATIO_FLOOR)
    x, lc = np.log(cen[last]), np.log(c)
    wts = (c / np.maximum(err[last], 1e-12)) ** 2
    xm, ym = np.sum(wts * x) / np.sum(wts), np.sum(wts * lc) / np.sum(wts)
    sxx = np.sum(wts * (x - xm) ** 2)
    if last.sum() >= 2 and sxx > 0:
        bound = float(np.sum(wts * (x - xm) * (lc - ym)) / sxx + significance / np.sqrt(sxx))
        if bound < 0:
            return float(np.exp(ym + bound * (x[-1] - xm))), bound
    return float(np.exp(ym)), 0.0


def record_error_std(G: np.ndarray, H: np.ndarray, model_spectrum: np.ndarray, r: float, weight: np.ndarray,
                     w: np.ndarray, ratio: RoadSpectrumRatio) -> tuple[float, float]:
    """(std, short-wave std), m, of the linear estimate u_hat = G y under the estimated road c(w) S_model(w):
    sqrt((1/pi) int W (|G H - 1|^2 c S_model + |G|^2 r) dw) (module docstring), and the part of it that comes from
    beyond the last resolved band, sqrt((1/pi) int_{w > w_last} W |G H - 1|^2 c S_model dw) (0 when the record
    shows no content there)."""
    c = ratio.at(w)
    road = np.abs(G * H - 1.0) ** 2 * c * model_spectrum
    Se = road + np.abs(G) ** 2 * r
    beyond = w > ratio.frequency[-1]
    total = float(np.sqrt(np.trapezoid(weight * Se, w) / np.pi))
    short = float(np.sqrt(max(np.trapezoid(np.where(beyond, weight * road, 0.0), w) / np.pi, 0.0)))
    return total, short
