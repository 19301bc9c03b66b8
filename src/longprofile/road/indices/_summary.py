"""One call that runs every roughness analysis a road report needs."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core import Profile
from ...errors import InputError
from ._gaps import MIN_VALID_FRACTION
from ._iri import IRIResult, iri
from ._iso8608 import ISO8608Fit, ProfilePSD, fit_iso8608, profile_psd
from ._roughness import APL_BANDS, LocalizedRoughness, WavebandEnergy, localized_roughness, waveband_energy

__all__ = ["RoughnessAnalysis", "analyse_roughness"]


@dataclass(frozen=True, eq=False)
class RoughnessAnalysis:
    """Everything a roughness report shows, for one profile.

    Attributes
    ----------
    profile : Profile
        The analysed profile (selected tracks).
    iri : IRIResult
        IRI per segment and section (MRI/HRI with two tracks).
    localized : LocalizedRoughness
        Continuous short-interval IRI and defects.
    psd : ProfilePSD or None
        Welch PSD (None if the stations are irregular; see ``notes``).
    iso8608 : tuple of ISO8608Fit or None
        One fit per track (None when the PSD is not available or too short).
    waveband : WavebandEnergy or None
        Waveband energies (None if irregular or the profile is too coarse for the bands).
    notes : tuple of str
        Why an optional part is missing, in plain words.
    """

    profile: Profile
    iri: IRIResult
    localized: LocalizedRoughness
    psd: ProfilePSD | None
    iso8608: tuple[ISO8608Fit, ...] | None
    waveband: WavebandEnergy | None
    notes: tuple[str, ...]


def _tracks_of(profile: Profile, names) -> Profile:
    """The profile reduced to the tracks ``names`` (in that order), with their std."""
    return Profile(distance=profile.distance, elevation=np.column_stack([profile.track(t) for t in names]),
                   tracks=names, std=None if profile.std is None else profile.std[:, [profile.tracks.index(t) for t in names]],
                   name=profile.name)


def analyse_roughness(profile: Profile, *, segment_length: float = 100.0, tracks=None, window: float = 25.0,
                      threshold: float = 2.7, bands: dict | None = None, band_segment_length: float = 200.0,
                      lead_in: float = 11.0, gaps: str = "refuse",
                      min_valid: float = MIN_VALID_FRACTION) -> RoughnessAnalysis:
    """IRI, localised roughness, PSD with ISO 8608 class and waveband energies of a profile.

    Parameters
    ----------
    profile : Profile
        Elevations in m.
    segment_length : float
        IRI segment length, m (default 100).
    tracks : str or sequence of str, optional
        Tracks to analyse (default all).
    window, threshold : float
        Localised roughness window (m, default 25) and threshold (m/km, default 2.7).
    bands : dict, optional
        Waveband definition (default :data:`APL_BANDS`).
    band_segment_length : float
        Segment length for waveband energies, m (default 200).
    lead_in : float
        IRI initialisation length, m (default 11).
    gaps : {"refuse", "restart"}, min_valid : float
        Missing elevations (NaN): refused (default), or ``"restart"``: each run of measured samples computed as its
        own profile -- the IRI per segment over the measured parts (NaN below ``min_valid``, default 0.8, of the
        segment measured; :func:`~longprofile.road.iri`), the localised roughness in windows inside one run, the
        PSD from the Welch segments inside the runs; the waveband energies (a band-pass of the whole record) are
        not computed. A note names the gaps. A dead track (no measured run of the lead-in, :mod:`._gaps`) has no
        IRI; the PSD and ISO 8608 fit are those of the other tracks (``psd.tracks``), with a note.

    Returns
    -------
    RoughnessAnalysis
        The IRI and localised roughness are always computed; PSD, ISO 8608 fit and waveband energies are
        None with an explanation in ``notes`` when the profile does not allow them (irregular stations,
        too short, too coarse, gaps for the waveband energies).
    """
    names = profile.tracks if tracks is None else ((tracks,) if isinstance(tracks, str) else tuple(tracks))
    if not names:
        raise InputError("tracks must name at least one track.")
    sub = _tracks_of(profile, names)
    notes = []
    iri_res = iri(sub, segment_length=segment_length, lead_in=lead_in, gaps=gaps, min_valid=min_valid)
    if iri_res.gaps is not None and iri_res.gaps.any:
        notes.append(f"Gaps: {iri_res.gaps.message()} Localised roughness: windows inside one measured run only; "
                     "PSD: the Welch segments inside the measured runs.")
    if iri_res.iri.shape[0] == 0:
        notes.append(f"The profile is shorter than one {segment_length:g} m segment: only the section IRI is given.")
    loc = localized_roughness(sub, window=window, threshold=threshold, lead_in=lead_in, gaps=gaps)
    psd = fits = wave = None
    if sub.spacing is None:
        notes.append("Stations are irregular: the PSD, ISO 8608 class and waveband energies need a constant step and "
                     "are not computed (interpolate onto a regular grid explicitly to get them).")
    else:
        dead = iri_res.gaps.dead if iri_res.gaps is not None else ()
        live = sub if not dead else _tracks_of(sub, tuple(t for t in names if t not in dead))
        if dead:
            notes.append(f"PSD and ISO 8608 class: track(s) {', '.join(dead)} have no measured run (computed for the "
                         "other track(s) only).")
        try:
            psd = profile_psd(live, gaps=gaps)
            fits = tuple(fit_iso8608(psd.wavenumber, psd.psd[:, k]) for k in range(len(psd.tracks)))
        except InputError as exc:
            notes.append(f"ISO 8608 fit not computed: {exc}")
            fits = None
        try:
            wave = waveband_energy(sub, bands=bands if bands is not None else APL_BANDS,
                                   segment_length=band_segment_length)
        except InputError as exc:
            notes.append(f"Waveband energies not computed: {exc}")
    return RoughnessAnalysis(profile=sub, iri=iri_res, localized=loc, psd=psd, iso8608=fits, waveband=wave,
                             notes=tuple(notes))
