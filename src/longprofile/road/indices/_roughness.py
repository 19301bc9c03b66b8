"""Localised roughness (continuous short-interval IRI) and waveband energies of a profile."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..._validation import require_positive, true_runs
from ...core import Profile
from ...errors import InputError, UnitsError
from ._gaps import gaps_mode, run_slopes, valid_runs
from ._iri import MAX_IRI_STEP_M, PLAUSIBLE_IRI_M_PER_KM, REPORT_UNITS, _check_steps, _select_tracks, rectified_slope

__all__ = [
    "APL_BANDS",
    "RoughnessDefect",
    "LocalizedRoughness",
    "localized_roughness",
    "WavebandEnergy",
    "waveband_energy",
]

#: Wavelength bands (m) of the APL band grades (French practice: short, medium, long waves; each band
#: spans a factor 4 in wavelength). See docs/road-indices.md for the status of the source.
APL_BANDS: dict[str, tuple[float, float]] = {
    "short 0.7-2.8 m": (0.7, 2.8),
    "medium 2.8-11.3 m": (2.8, 11.3),
    "long 11.3-45.2 m": (11.3, 45.2),
}


@dataclass(frozen=True)
class RoughnessDefect:
    """One localised roughness defect: a run of stations where the continuous IRI exceeds the threshold.

    Attributes
    ----------
    track : str
    start, end : float
        First and last station (window centre) above the threshold, m.
    peak_station : float
        Station of the maximum, m.
    peak_iri : float
        Maximum continuous IRI in the run, m/km.
    """

    track: str
    start: float
    end: float
    peak_station: float
    peak_iri: float

    @property
    def length(self) -> float:
        return self.end - self.start


@dataclass(frozen=True, eq=False)
class LocalizedRoughness:
    """Continuous short-interval IRI and the defects above a threshold.

    Attributes
    ----------
    station : (M,) ndarray
        Window centres, m (the stations of the simulated profile whose window lies inside it).
    continuous_iri : (M, K) ndarray
        IRI over ``window`` metres centred on each station, m/km; columns ``tracks``.
    tracks : tuple of str
        Track names; with two tracks a third column ``"MRI"`` (their mean) is added.
    window : float
        Window length, m.
    threshold : float
        Threshold, m/km.
    defects : tuple of RoughnessDefect
        Sorted by track then station.
    """

    station: np.ndarray
    continuous_iri: np.ndarray
    tracks: tuple[str, ...]
    window: float
    threshold: float
    defects: tuple[RoughnessDefect, ...]

    def to_frame(self) -> pd.DataFrame:
        """The defect list: ``track, start_m, end_m, length_m, peak_station_m, peak_iri_m_per_km``."""
        return pd.DataFrame({
            "track": [d.track for d in self.defects],
            "start_m": [d.start for d in self.defects],
            "end_m": [d.end for d in self.defects],
            "length_m": [d.length for d in self.defects],
            "peak_station_m": [d.peak_station for d in self.defects],
            "peak_iri_m_per_km": [d.peak_iri for d in self.defects],
        })


def _check_threshold_unit(threshold: float) -> None:
    """Refuse a threshold above any road's IRI (:data:`PLAUSIBLE_IRI_M_PER_KM`): in/mi given as m/km (160 in/mi, a
    common localized-roughness limit, is 2.53 m/km; as 160 m/km nothing is ever flagged; session 36, a probe)."""
    hi = PLAUSIBLE_IRI_M_PER_KM[1]
    if threshold > hi:
        raise UnitsError(f"threshold {threshold:g} m/km is above any road's IRI ({hi:g} m/km): nothing would ever be "
                         f"flagged. In in/mi? {threshold:g} in/mi is {threshold / REPORT_UNITS['us']['iri_per_m_per_km']:.3g} m/km.")


def localized_roughness(profile: Profile, *, window: float = 25.0, threshold: float = 2.7, tracks=None,
                        lead_in: float = 11.0, moving_average: bool | None = None,
                        base_length: float = 0.25, gaps: str = "refuse") -> LocalizedRoughness:
    """Continuous short-interval IRI (sliding window) and the list of locations above a threshold.

    Parameters
    ----------
    profile : Profile
        Elevations in m (no NaN in the analysed tracks unless ``gaps="restart"``).
    window : float
        Length of the sliding IRI window, m (default 25).
    threshold : float
        Defect threshold, m/km (default 2.7, about the FHWA "poor" limit of 170 in/mi; an assumption,
        set it from your specification). Above any road's IRI (50 m/km) it is refused as in/mi given as m/km;
        ``numpy.inf`` asks for the curve alone.
    tracks, lead_in, moving_average, base_length
        As in :func:`longprofile.road.iri`.
    gaps : {"refuse", "restart"}
        As in :func:`longprofile.road.iri`. With ``"restart"`` each run of measured samples of a track is computed
        as its own profile and a window is evaluated only where it lies inside one run (the stations of all
        tracks' windows together; NaN where a track has none); with two tracks the "MRI" column is the mean of the
        two (NaN where either is). A defect never spans a gap.

    Returns
    -------
    LocalizedRoughness

    Notes
    -----
    One golden-car run over the whole profile (state carried, exactly as :func:`~longprofile.road.iri`),
    then ``CIRI(x) = (1/W) * integral_{x-W/2}^{x+W/2} RS(s) ds`` with RS piecewise constant over each step
    (the same quadrature as the IRI), evaluated at every station whose window lies inside the profile.
    A defect is a maximal run of consecutive stations with ``CIRI > threshold``; it is reported by its
    first and last window centre and its peak. This is the continuous-IRI "localized roughness" analysis of
    ProVAL's Smoothness Assurance module, with a user-chosen window (ProVAL's default is 25 ft = 7.62 m;
    25 m is asked here).
    """
    window = require_positive("window", window)
    if not (isinstance(threshold, (int, float, np.floating)) and np.isposinf(threshold)):
        threshold = require_positive("threshold", threshold, strict=False)
        _check_threshold_unit(threshold)
    if gaps_mode(gaps) == "restart":
        centres, ciri, names = _localized_gapped(profile, tracks, window, lead_in, moving_average, base_length)
    else:
        rs = rectified_slope(profile, tracks=tracks, lead_in=lead_in, moving_average=moving_average,
                             base_length=base_length)
        x = rs.station
        if x[-1] - x[0] < window:
            raise InputError(f"the profile ({x[-1] - x[0]:.2f} m) is shorter than the window ({window:g} m).")
        values = rs.rectified
        names = rs.tracks
        if values.shape[1] == 2:
            values = np.column_stack([values, values.mean(axis=1)])
            names = names + ("MRI",)
        centres, ciri = _window_iri(rs.station, rs.step, values, window)
    defects = []
    for j, name in enumerate(names):
        for a, b in true_runs(ciri[:, j] > threshold):
            k = a + int(np.argmax(ciri[a:b + 1, j]))
            defects.append(RoughnessDefect(track=name, start=float(centres[a]), end=float(centres[b]),
                                           peak_station=float(centres[k]), peak_iri=float(ciri[k, j])))
    return LocalizedRoughness(station=centres, continuous_iri=ciri, tracks=names, window=window,
                              threshold=threshold, defects=tuple(defects))


def _window_iri(x, step, values, window):
    """Window centres (the stations ``x`` whose window lies inside them) and the continuous IRI of ``values``
    (M - 1, K: the rectified slope per step) over ``window`` centred on each."""
    cum = np.concatenate([np.zeros((1, values.shape[1])), np.cumsum(step[:, None] * values, axis=0)])
    inside = (x - 0.5 * window >= x[0] - 1e-9) & (x + 0.5 * window <= x[-1] + 1e-9)
    centres = x[inside]
    ciri = np.empty((centres.size, values.shape[1]))
    for j in range(values.shape[1]):
        hi = np.interp(centres + 0.5 * window, x, cum[:, j])
        lo = np.interp(centres - 0.5 * window, x, cum[:, j])
        ciri[:, j] = (hi - lo) / window
    return centres, ciri


def _localized_gapped(profile, tracks, window, lead_in, moving_average, base_length):
    """``(centres, ciri, names)`` of :func:`localized_roughness` with ``gaps="restart"``: the windows inside each run
    of measured samples of each track (:mod:`._gaps`), on the union of the tracks' centres."""
    z, names = _select_tracks(profile, tracks, allow_nan=True)
    x = profile.distance
    _check_steps(x, gaps_allowed=True)
    missing = np.isnan(z)
    parts = []  # (column, centres, values)
    for j in range(z.shape[1]):
        runs = valid_runs(x, missing[:, j], max_step=MAX_IRI_STEP_M)
        kept, _ = run_slopes(x, z[:, [j]], [names[j]], runs, lead_in=lead_in, moving_average=moving_average,
                             base_length=base_length)
        parts += [(j, *_window_iri(rs.station, rs.step, rs.rectified, window)) for *_, rs, _m, _t in kept]
    centres = np.unique(np.concatenate([c for _, c, _ in parts])) if parts else np.zeros(0)
    if centres.size == 0:
        raise InputError(f"no run of measured elevations between the gaps is as long as the window ({window:g} m) "
                         "and the lead-in: no localised roughness can be computed; use a shorter window.")
    ciri = np.full((centres.size, z.shape[1]), np.nan)
    for j, c, v in parts:
        ciri[np.searchsorted(centres, c), j] = v[:, 0]
    if z.shape[1] == 2:
        return centres, np.column_stack([ciri, ciri.mean(axis=1)]), names + ("MRI",)
    return centres, ciri, names


@dataclass(frozen=True, eq=False)
class WavebandEnergy:
    """Mean-square elevation per segment in wavelength bands.

    Attributes
    ----------
    segment_start, segment_end : (S,) ndarray
        Segment limits, m (complete segments).
    energy : (S, K, J) ndarray
        Mean square of the band-passed elevation over the segment, mm^2, for track k and band j.
    tracks : tuple of str
    bands : dict of str -> (float, float)
        Band name -> (shortest, longest) wavelength, m.
    """

    segment_start: np.ndarray
    segment_end: np.ndarray
    energy: np.ndarray
    tracks: tuple[str, ...]
    bands: dict

    def to_frame(self) -> pd.DataFrame:
        """One row per segment, columns ``start_m, end_m, <track> <band> [mm2]``."""
        cols = {"start_m": self.segment_start, "end_m": self.segment_end}
        for k, t in enumerate(self.tracks):
            for j, b in enumerate(self.bands):
                cols[f"{t} {b} [mm2]"] = self.energy[:, k, j]
        return pd.DataFrame(cols)


def waveband_energy(profile: Profile, *, bands: dict | None = None, segment_length: float = 200.0,
                    tracks=None) -> WavebandEnergy:
    """Energy (mean square, mm^2) of the profile per segment in wavelength bands.

    Parameters
    ----------
    profile : Profile
        Regularly spaced profile, elevations in m, no NaN.
    bands : dict of name -> (shortest, longest) wavelength in m, optional
        Default :data:`APL_BANDS` (0.7-2.8 m, 2.8-11.3 m, 11.3-45.2 m).
    segment_length : float
        Segment length, m (default 200, the length of the French APL band grades; assumption, see docs).
    tracks : str or sequence of str, optional
        Tracks to analyse (default all).

    Returns
    -------
    WavebandEnergy

    Notes
    -----
    The whole track is linearly detrended and band-passed by an ideal (brick-wall) zero-phase filter in the
    Fourier domain keeping ``1/longest <= n <= 1/shortest`` cycles/m; the energy of a segment is the mean
    square of the band-passed elevation over the samples of the segment (Parseval: the integral of the PSD
    over the band, localised per segment). The Fourier band-pass treats the record as periodic; the first
    and last half-longest-wavelength are therefore less reliable (assumption: acceptable for reporting, as
    in the APL practice of analysing whole runs). Grades (notes 1..10) derived from these energies by the
    APL method are not computed: their conversion tables could not be confirmed from a public source.
    """
    bands = dict(APL_BANDS if bands is None else bands)
    if not bands:
        raise InputError("bands must contain at least one (shortest, longest) wavelength pair.")
    for name, (lo, hi) in bands.items():
        lo = require_positive(f"bands[{name!r}] shortest wavelength", lo)
        hi = require_positive(f"bands[{name!r}] longest wavelength", hi)
        if hi <= lo:
            raise InputError(f"band {name!r} must be (shortest, longest) wavelength with shortest < longest; "
                             f"got ({lo}, {hi}).")
    segment_length = require_positive("segment_length", segment_length)
    dx = profile.spacing
    if dx is None:
        raise InputError("waveband_energy needs a constant station spacing; this profile is irregular. Interpolate "
                         "it onto a regular grid first (e.g. numpy.interp) and state it in your report.")
    names = profile.tracks if tracks is None else ((tracks,) if isinstance(tracks, str) else tuple(tracks))
    z = np.column_stack([profile.track(t) for t in names])
    if np.isnan(z).any():
        raise InputError("waveband_energy: the elevation has NaN (missing) samples, and the band-pass filters the "
                         "whole record (no per-run computation): fill or cut them out first.")
    for name, (lo, _hi) in bands.items():
        if lo < 2 * dx:
            raise InputError(f"band {name!r} starts at {lo:g} m, shorter than twice the spacing ({2 * dx:g} m): "
                             "the profile cannot resolve it. Use a finer profile or drop the band.")
    n = z.shape[0]
    x = profile.distance
    t = (x - x.mean())
    coef = np.polyfit(t, z, 1)
    detrended = z - (np.outer(t, coef[0]) + coef[1])
    spec = np.fft.rfft(detrended, axis=0)
    freq = np.fft.rfftfreq(n, d=dx)
    x0 = x[0]
    n_seg = int(np.floor((x[-1] - x0) / segment_length + 1e-9))
    bounds = x0 + segment_length * np.arange(n_seg + 1)
    idx = np.searchsorted(bounds, x, side="right") - 1
    idx[np.isclose(x, bounds[-1]) & (idx == n_seg)] = n_seg - 1
    inside = (idx >= 0) & (idx < n_seg)
    counts = np.bincount(idx[inside], minlength=n_seg)
    energy = np.zeros((n_seg, len(names), len(bands)))
    for j, (lo, hi) in enumerate(bands.values()):
        keep = (freq >= 1.0 / hi) & (freq <= 1.0 / lo)
        band = np.fft.irfft(spec * keep[:, None], n=n, axis=0) * 1000.0  # mm
        for k in range(len(names)):
            energy[:, k, j] = np.bincount(idx[inside], weights=band[inside, k] ** 2, minlength=n_seg) / counts
    return WavebandEnergy(segment_start=bounds[:-1], segment_end=bounds[1:], energy=energy, tracks=names,
                          bands=bands)
