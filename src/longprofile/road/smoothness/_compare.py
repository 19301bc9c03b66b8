"""Profile comparison and profiler certification: Karamihas' cross-correlation method (AASHTO R 56 practice).

Two profiles are compared after the filter of the index they serve (the IRI's golden car by default, or a
band-pass), by the normalised cross-correlation maximised over a distance offset (DMI misalignment). The
golden-car filter runs in the state-space engine (:func:`longprofile.statespace.linear_recursion`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from itertools import combinations

import numpy as np
import pandas as pd

from ..._validation import require_positive
from ...core import Profile
from ...errors import InputError
from ...statespace import filter_design, linear_recursion, sos_filtfilt
from ..indices._iri import golden_car_matrices, iri

__all__ = ["R56_THRESHOLDS", "MIN_REFERENCE_COVERAGE", "CertificationResult", "ProfileComparison", "certify_profiler", "compare_profiles",
           "filter_for_comparison", "resample_profile"]

#: Pass/fail thresholds of profiler certification on the IRI-filtered cross-correlation (AASHTO R 56-14,
#: Section 7 / Appendix X1, as recalled: repeatability >= 0.92 among repeated runs, accuracy >= 0.90 against
#: the reference). ASSUMPTION: not confirmed against the text of R 56 here (see docs/road-acceptance.md);
#: both are configurable.
R56_THRESHOLDS = {"repeatability": 0.92, "accuracy": 0.90}
#: Default half-width of the distance-offset search, m (a longprofile choice: a DMI error of 0.5 % over 1 km is
#: 5 m; configurable).
DEFAULT_MAX_OFFSET = 5.0
_C_RATE = np.array([[1.0, 0.0, -1.0, 0.0]])


@dataclass(frozen=True, eq=False)
class ProfileComparison:
    """Agreement of a profile with a reference profile.

    Attributes
    ----------
    correlation : float
        Normalised cross-correlation of the filtered profiles at the best offset (1 = identical shape, whatever
        the amplitudes).
    rating : float
        Karamihas' rating at the best offset: ``correlation`` times the smaller over the larger RMS of the two
        filtered profiles (1 = identical shape and amplitude; a run at half the reference's amplitude rates at most
        0.5). What certification judges (ASSUMPTION on the exact form, docs/road-acceptance.md).
    offset : float
        Distance to add to the run's stations to align it with the reference, m (a multiple of the step).
    correlation_at_zero : float
        The same at the nominal (station) alignment, no offset.
    amplitude_ratio : float
        RMS of the filtered run / RMS of the filtered reference over the overlap at the best offset.
    overlap : float
        Length compared at the best offset, m.
    lags : (L,) ndarray
        Offsets searched, m; ``curve`` (L,) the correlation at each, ``rating_curve`` (L,) the rating.
    track, filter : str
    outside : tuple of float, optional
        ``(offset, rating)`` of an alignment beyond ``max_offset`` (searched up to :data:`OUTSIDE_SEARCH` times as
        far) that rates better than the best within by more than 0.05: the stations are further apart than the
        search allowed (widen it). None otherwise.
    """

    correlation: float
    offset: float
    correlation_at_zero: float
    amplitude_ratio: float
    overlap: float
    lags: np.ndarray
    curve: np.ndarray
    track: str
    filter: str
    rating: float = float("nan")
    rating_curve: np.ndarray | None = None
    outside: tuple | None = None


@dataclass(frozen=True, eq=False)
class CertificationResult:
    """Repeatability and accuracy of repeated profiler runs (AASHTO R 56 practice).

    Attributes
    ----------
    runs : pandas.DataFrame
        One row per run: ``run, track, offset_m, accuracy_correlation, correlation_at_zero, amplitude_ratio,
        iri_m_per_km, coverage`` (accuracy against the reference; ``coverage`` the share of the reference's length the
        run overlaps at its best offset).
    pairs : pandas.DataFrame
        One row per pair of runs: ``run_a, run_b, track, offset_m, correlation``.
    repeatability : dict
        Per track: mean correlation over all pairs of runs (NaN with a single run).
    accuracy : dict
        Per track: mean correlation of the runs against the reference.
    reference_iri : dict
        Per track: IRI of the reference over the whole profile, m/km.
    thresholds : dict
    passed : bool
        At least two runs, every track meets both thresholds (on Karamihas' rating, amplitude included) and every
        run covers at least :data:`MIN_REFERENCE_COVERAGE` of the reference.
    metadata : dict
    comparisons : dict
        ``{(run, track): ProfileComparison}`` of each run against the reference (correlation curves).
    warnings : tuple of str
        What the verdict leaves out or may have missed: a reference track not in every run, a best offset at the
        edge of the search, a single run.
    """

    runs: pd.DataFrame
    pairs: pd.DataFrame
    repeatability: dict
    accuracy: dict
    reference_iri: dict
    thresholds: dict
    passed: bool
    metadata: dict = field(default_factory=dict)
    comparisons: dict = field(default_factory=dict)
    warnings: tuple = ()


#: How far beyond ``max_offset`` a comparison looks for a better alignment to name (a multiple of it): a start
#: offset the search missed is then reported with the fix instead of a bare FAIL (session 36, a probe).
OUTSIDE_SEARCH = 4

#: A run certified against a reference must overlap this share of the reference's length (a longprofile
#: assumption): a 2 km run passed against a 10 km reference on the 2 km it covers, without a word (session 35).
MIN_REFERENCE_COVERAGE = 0.9


def resample_profile(profile: Profile, spacing: float, *, start: float | None = None) -> Profile:
    """Linear interpolation of a profile onto a regular grid of ``spacing`` m (an explicit resampling).

    The grid starts at ``start`` (default the first station) and ends at the last station it reaches.
    """
    spacing = require_positive("spacing (m)", spacing)
    x = profile.distance
    x0 = float(x[0]) if start is None else float(start)
    if x0 < x[0] - 1e-9 or x0 >= x[-1]:
        raise InputError(f"start {x0:g} m lies outside the profile ({x[0]:g} .. {x[-1]:g} m).")
    n = int(np.floor((x[-1] - x0) / spacing + 1e-9)) + 1
    if n < 2:
        raise InputError(f"spacing {spacing:g} m is longer than the profile ({x[-1] - x0:g} m).")
    grid = x0 + spacing * np.arange(n)
    z = np.column_stack([np.interp(grid, x, profile.elevation[:, j]) for j in range(profile.elevation.shape[1])])
    return Profile(distance=grid, elevation=z, tracks=profile.tracks, name=profile.name)


def _regular(profile: Profile, what: str) -> float:
    dx = profile.spacing
    if dx is None:
        raise InputError(f"{what} has irregular stations; pass spacing=... (CLI: --spacing) to resample every "
                         "profile explicitly onto one regular grid.")
    return dx


def filter_for_comparison(profile: Profile, track: str, *, filter: str = "iri",
                          band: tuple[float, float] | None = None, base_length: float = 0.25,
                          lead_in: float = 11.0) -> np.ndarray:
    """The filtered profile that the comparison correlates, one value per sample interval (constant step).

    Parameters
    ----------
    profile : Profile
        Constant step, m.
    track : str
    filter : {"iri", "bandpass", "none"}
        ``"iri"``: the IRI filter -- the golden-car output ``zs' - zu'`` (m/m, unrectified) after the 250 mm
        moving average when ``round(0.25 / dx) >= 2`` (ASTM E1926 / WTP-46), as in Karamihas' method for the
        IRI. ``"bandpass"``: elevation filtered by a zero-phase 2nd-order Butterworth band-pass (the engine's
        ``sos_filtfilt``, scipy's ``sosfiltfilt`` bit for bit) keeping wavelengths ``band = (shortest, longest)``
        m, for indices other than the IRI.
        ``"none"``: elevation minus its mean.
    band : (float, float), optional
        Wavelength band for ``"bandpass"``, m.

    Returns
    -------
    (N - 1,) or (N,) ndarray
    """
    dx = _regular(profile, f"profile {profile.name or track!r}")
    z = profile.track(track)
    if np.isnan(z).any():
        raise InputError(f"track {track!r} of {profile.name or 'the profile'} has missing (NaN) elevations; "
                         "cut or fill the gap before comparing.")
    key = str(filter).lower()
    if key == "iri":
        k = max(1, int(np.floor(base_length / dx + 0.5)))
        if k >= 2:
            z = np.lib.stride_tricks.sliding_window_view(z, k).mean(axis=-1)
        n_lead = max(1, int(np.floor(lead_in / dx + 0.5)))
        if z.size <= n_lead + 1:
            raise InputError(f"the profile is shorter than the lead-in ({lead_in:g} m).")
        st, pr = golden_car_matrices(dx)
        s0 = (z[n_lead] - z[0]) / (n_lead * dx)
        res = linear_recursion(st, pr[:, None], np.diff(z) / dx, np.array([s0, 0.0, s0, 0.0]),
                               output_matrix=_C_RATE)
        return res.outputs[:, 0]
    if key == "bandpass":
        if band is None or len(band) != 2:
            raise InputError("filter='bandpass' needs band=(shortest, longest) wavelengths in m.")
        short, long_ = sorted(require_positive("band wavelength (m)", b) for b in band)
        nyquist_wl = 2 * dx
        if short <= nyquist_wl:
            raise InputError(f"the shortest wavelength {short:g} m must exceed twice the step ({nyquist_wl:g} m).")
        sos = filter_design("butter", 2, [1.0 / long_, 1.0 / short], btype="bandpass", fs=1.0 / dx, output="sos")
        return sos_filtfilt(sos, z - z.mean())  # z is one track (1-D): scipy's sosfiltfilt, bit for bit
    if key == "none":
        return z - z.mean()
    raise InputError(f"unknown filter {filter!r}; use 'iri', 'bandpass' or 'none'.")


def _full_correlation(q: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``scipy.signal.correlate(q, p, mode="full")`` of two real 1-D arrays by FFT (scipy.fft).

    The same product of real FFTs scipy.signal's "fft" method computes; calling scipy.fft directly spares a
    command the ~0.4 s import of scipy.signal (issue 12, start-up), tested against scipy.signal.correlate."""
    from scipy import fft

    size = q.size + p.size - 1
    n = fft.next_fast_len(size, real=True)
    return fft.irfft(fft.rfft(q, n) * fft.rfft(p[::-1], n), n)[:size]


def _xcorr(p: np.ndarray, q: np.ndarray, lag_lo: int, lag_hi: int, min_overlap: int):
    """Normalised correlation of p[i] with q[i + l] for l in lag_lo..lag_hi over their overlap."""
    lags = np.arange(lag_lo, lag_hi + 1)
    full = _full_correlation(q, p)  # full[l + len(p) - 1] = sum_i p[i] q[i + l]
    idx = lags + p.size - 1
    ok = (idx >= 0) & (idx < full.size)
    num = np.zeros(lags.size)
    num[ok] = full[idx[ok]]
    cp = np.concatenate([[0.0], np.cumsum(p * p)])
    cq = np.concatenate([[0.0], np.cumsum(q * q)])
    i0 = np.maximum(0, -lags)
    i1 = np.minimum(p.size, q.size - lags)
    n = i1 - i0
    valid = n >= min_overlap
    i0c, i1c = np.where(valid, i0, 0), np.where(valid, i1, 0)
    ep = cp[i1c] - cp[i0c]
    eq = cq[i1c + lags * valid] - cq[i0c + lags * valid]
    den = np.sqrt(ep * eq)
    rho = np.full(lags.size, np.nan)
    good = valid & (den > 0)
    rho[good] = num[good] / den[good]
    ratio = np.full(lags.size, np.nan)
    ratio[good] = np.sqrt(eq[good] / ep[good])
    return lags, rho, ratio, n


def compare_profiles(reference: Profile, run: Profile, *, track: str | None = None, filter: str = "iri",
                     band: tuple[float, float] | None = None, max_offset: float = DEFAULT_MAX_OFFSET,
                     spacing: float | None = None, min_overlap: float = 0.5) -> ProfileComparison:
    """Cross-correlation of a run with a reference profile after a filter, maximised over a distance offset.

    Parameters
    ----------
    reference, run : Profile
        The same track of the same road, stations in m. Both must have the same constant step unless
        ``spacing`` is given (then both are resampled onto that step by linear interpolation, explicitly).
    track : str, optional
        Track to compare (default: the reference's first track; it must exist in the run).
    filter, band
        See :func:`filter_for_comparison` (default the IRI filter).
    max_offset : float
        Largest |offset| searched, m (0: no search).
    spacing : float, optional
        Common step to resample both profiles to, m.
    min_overlap : float
        Smallest overlap accepted, as a fraction of the shorter filtered profile.

    Returns
    -------
    ProfileComparison

    Raises
    ------
    InputError
        Different steps without ``spacing``; irregular stations; no overlap; NaN elevations.

    Notes
    -----
    Karamihas' rating (Karamihas & Gillespie, UMTRI 2002, "Development of cross correlation for objective
    comparison of profiles"; Karamihas, "Critical profiler accuracy requirements", UMTRI 2005; AASHTO R 56
    Appendix X1): both profiles pass through the filter of the index of interest and the agreement is the
    normalised cross-correlation ``rho = sum p_i q_i / sqrt(sum p_i^2 sum q_i^2)`` over the overlapping
    samples. Karamihas' rating also penalises a difference in amplitude: ``rating = rho * min(a, 1 / a)``, ``a``
    the RMS ratio of the filtered profiles (ASSUMPTION on the exact form, docs/road-acceptance.md; until session 36
    longprofile rated on ``rho`` alone, and a run at half or a thousandth of the reference's amplitude passed). The
    best offset is the one that maximises the rating.
    """
    if spacing is not None:
        reference, run = resample_profile(reference, spacing), resample_profile(run, spacing)
    dr = _regular(reference, f"reference {reference.name!r}")
    dq = _regular(run, f"run {run.name!r}")
    if not np.isclose(dr, dq, rtol=1e-6, atol=0):
        ref_name, run_name = reference.name or "the reference", run.name or "the run"
        raise InputError(f"the profiles have different sample intervals ({dr:.6g} m for {ref_name}, {dq:.6g} m for "
                         f"{run_name}); pass spacing=... (CLI: --spacing) to resample both explicitly.")
    track = reference.tracks[0] if track is None else track
    max_offset = require_positive("max_offset (m)", max_offset, strict=False)
    p = filter_for_comparison(reference, track, filter=filter, band=band)
    q = filter_for_comparison(run, track, filter=filter, band=band)
    # pairing p[i] with q[i + l]: reference station xr0 + i dx, run station xq0 + (i + l) dx; the offset
    # (reference minus run station of the paired samples) is (xr0 - xq0) - l dx.
    nominal = (reference.distance[0] - run.distance[0]) / dr
    l0 = int(np.round(nominal))
    half = int(np.floor(max_offset / dr + 1e-9))
    min_n = max(2, int(np.ceil(min_overlap * min(p.size, q.size))))
    _refuse_flat(p, reference, track, filter)
    _refuse_flat(q, run, track, filter)
    # beyond the search, for a better alignment to name: OUTSIDE_SEARCH times it, and at least the default search
    # (--max-offset 0 on runs 1.3 m apart rated -0.155 and failed without a hint)
    wide = OUTSIDE_SEARCH * max(half, int(np.floor(DEFAULT_MAX_OFFSET / dr + 1e-9)))
    lags, rho, ratio, n = _xcorr(p, q, l0 - wide, l0 + wide, min_n)
    rating = rho * np.minimum(ratio, 1.0 / ratio)
    inside = np.abs(lags - l0) <= half
    outside = _better_outside(rating, inside, (nominal - lags) * dr)
    lags, rho, ratio, n, rating = lags[inside], rho[inside], ratio[inside], n[inside], rating[inside]
    if not np.isfinite(rho).any():
        raise InputError(f"the profiles do not overlap by {min_overlap:.0%} of the shorter one within "
                         f"+-{max_offset:g} m of their station alignment (reference {reference.distance[0]:g} .. "
                         f"{reference.distance[-1]:g} m, run {run.distance[0]:g} .. {run.distance[-1]:g} m).")
    best = int(np.nanargmax(rating))
    offsets = (nominal - lags) * dr
    zero = int(np.argmin(np.abs(lags - l0)))
    return ProfileComparison(correlation=float(rho[best]), offset=float(offsets[best]),
                             correlation_at_zero=float(rho[zero]), amplitude_ratio=float(ratio[best]),
                             overlap=float(n[best] * dr), lags=offsets, curve=rho, track=track, filter=str(filter),
                             rating=float(rating[best]), rating_curve=rating, outside=outside)


def _better_outside(rating: np.ndarray, inside: np.ndarray, offsets: np.ndarray) -> tuple | None:
    """``(offset, rating)`` of the best alignment outside the search when it rates better than the best inside by
    more than 0.05; else None."""
    if inside.all() or not np.isfinite(rating[~inside]).any():
        return None
    best_in = np.nanmax(rating[inside]) if np.isfinite(rating[inside]).any() else -np.inf
    k = int(np.nanargmax(np.where(inside, np.nan, rating)))
    return (float(offsets[k]), float(rating[k])) if rating[k] > best_in + 0.05 else None


def _refuse_flat(filtered: np.ndarray, profile: Profile, track: str, filter: str) -> None:
    """Refuse a profile whose filtered track is zero throughout (a flat or dead-sensor profile: nothing to
    correlate; it was reported as "do not overlap")."""
    if not np.any(filtered):
        name = profile.name or "a profile"
        raise InputError(f"{name}: track {track!r} is flat after the {filter} filter (every filtered value 0: a "
                         "constant or dead-sensor profile?); nothing to compare.")


def _section_iri(profile: Profile, track: str) -> float:
    """IRI of one track over the whole profile, m/km (ASTM E1926 via :func:`iri`)."""
    length = max(1.0, float(np.ptp(profile.distance)))
    return float(iri(profile, tracks=track, segment_length=length).section_iri[0])


def certify_profiler(reference: Profile, runs, *, tracks=None, filter: str = "iri",
                     band: tuple[float, float] | None = None, max_offset: float = DEFAULT_MAX_OFFSET,
                     spacing: float | None = None, thresholds: dict | None = None,
                     names=None) -> CertificationResult:
    """Repeatability (all pairs of runs) and accuracy (each run against the reference), AASHTO R 56 practice.

    Parameters
    ----------
    reference : Profile
        Reference profile (e.g. from a reference device).
    runs : sequence of Profile
        Repeated runs of the profiler under test (R 56 asks for ten; one is compared with the reference, but only two or
        more can pass, repeatability being judged on them).
    tracks : str or sequence of str, optional
        Tracks to judge (default: the reference's tracks present in every run).
    filter, band, max_offset, spacing
        See :func:`compare_profiles`.
    thresholds : dict, optional
        ``{"repeatability": ..., "accuracy": ...}``; default :data:`R56_THRESHOLDS`. Unknown keys are refused.
    names : sequence of str, optional
        Run labels (default the profiles' names, else ``run1``, ...).

    Returns
    -------
    CertificationResult
    """
    runs = list(runs)
    if not runs:
        raise InputError("certify_profiler needs at least one run.")
    th = dict(R56_THRESHOLDS)
    if thresholds is not None:
        unknown = sorted(set(thresholds) - set(R56_THRESHOLDS))
        if unknown:
            raise InputError(f"unknown threshold key {unknown[0]!r}; use {sorted(R56_THRESHOLDS)}.")
        th.update({k: float(v) for k, v in thresholds.items()})
        bad = [k for k, v in th.items() if not 0 < v <= 1]
        if bad:
            raise InputError(f"the {bad[0]} threshold must be a correlation in (0, 1]; got {th[bad[0]]:g} "
                             "(a percentage? 90 % is 0.90).")
    labels = list(names) if names is not None else [r.name or f"run{i + 1}" for i, r in enumerate(runs)]
    if len(labels) != len(runs):
        raise InputError(f"names gives {len(labels)} label(s) for {len(runs)} run(s).")
    _refuse_copies(runs, labels)
    if spacing is not None:
        reference = resample_profile(reference, spacing)
        runs = [resample_profile(r, spacing) for r in runs]
    runs = [_reference_track_names(reference, r) for r in runs]
    notes = []
    if tracks is None:
        tracks = [t for t in reference.tracks if all(t in r.tracks for r in runs)]
        notes += [f"the reference's track {t!r} is not in every run ({', '.join(lab for lab, r in zip(labels, runs) if t not in r.tracks)}): "
                  "not judged" for t in reference.tracks if t not in tracks and tracks]
        if not tracks:
            lab, run = next((lab, r) for lab, r in zip(labels, runs) if not set(reference.tracks) & set(r.tracks))
            raise InputError(f"no track of the reference {list(reference.tracks)} is in every run: {lab} has "
                             f"{list(run.tracks)}; tracks are matched by name: rename the run's track with --rename "
                             f"{run.tracks[0]}={reference.tracks[0]} (road compare, or road convert to keep the "
                             f"file; in Python, profile.renamed({{{run.tracks[0]!r}: {reference.tracks[0]!r}}})).")
    else:
        tracks = [tracks] if isinstance(tracks, str) else list(tracks)
    kw = {"filter": filter, "band": band, "max_offset": max_offset}
    ref_length = float(reference.distance[-1] - reference.distance[0])
    run_rows, pair_rows, rep, acc, ref_iri, comps = [], [], {}, {}, {}, {}
    for t in tracks:
        ref_iri[t] = _section_iri(reference, t)
        cs = []
        for lab, r in zip(labels, runs):
            c = compare_profiles(reference, r, track=t, **kw)
            comps[(lab, t)] = c
            cs.append(c.rating)
            notes += _edge_note(c, lab, "the reference", max_offset)
            run_rows.append({"run": lab, "track": t, "offset_m": c.offset, "accuracy_correlation": c.rating,
                             "shape_correlation": c.correlation, "correlation_at_zero": c.correlation_at_zero,
                             "amplitude_ratio": c.amplitude_ratio, "iri_m_per_km": _section_iri(r, t),
                             "coverage": c.overlap / ref_length})
        acc[t] = float(np.mean(cs))
        ps = []
        for (la, a), (lb, b) in combinations(zip(labels, runs), 2):
            c = compare_profiles(a, b, track=t, **kw)
            ps.append(c.rating)
            notes += _edge_note(c, lb, la, max_offset)
            pair_rows.append({"run_a": la, "run_b": lb, "track": t, "offset_m": c.offset, "correlation": c.rating,
                              "shape_correlation": c.correlation})
        rep[t] = float(np.mean(ps)) if ps else float("nan")
    covered = all(row["coverage"] >= MIN_REFERENCE_COVERAGE for row in run_rows)
    if len(runs) < 2:
        notes.append("one run: repeatability is not judged, so the profiler is not certified (AASHTO R 56 asks for "
                     "repeated runs)")
    passed = covered and len(runs) >= 2 and all(acc[t] >= th["accuracy"] and rep[t] >= th["repeatability"]
                                                for t in tracks)
    meta = {"method": "Karamihas cross-correlation (UMTRI 2002/2005), AASHTO R 56 practice", "filter": str(filter),
            "band_m": None if band is None else [float(b) for b in band], "max_offset_m": float(max_offset),
            "spacing_m": None if spacing is None else float(spacing), "n_runs": len(runs),
            "thresholds_source": "AASHTO R 56-14 as recalled (ASSUMPTION, see docs/road-acceptance.md)",
            "rating": "shape correlation x smaller / larger RMS of the filtered profiles (ASSUMPTION on the form)"}
    return CertificationResult(runs=pd.DataFrame(run_rows), pairs=pd.DataFrame(pair_rows, columns=[
        "run_a", "run_b", "track", "offset_m", "correlation", "shape_correlation"]), repeatability=rep, accuracy=acc,
        reference_iri=ref_iri, thresholds=th, passed=bool(passed), metadata=meta, comparisons=comps,
        warnings=tuple(notes))


def _edge_note(c: ProfileComparison, run: str, against: str, max_offset: float) -> list[str]:
    """A note when a comparison aligns better beyond the searched offsets (:attr:`ProfileComparison.outside`)."""
    if c.outside is None:
        return []
    return [f"{run} against {against}, track {c.track!r}: rated {c.rating:.3f} at {c.offset:+.2f} m but "
            f"{c.outside[1]:.3f} at {c.outside[0]:+.2f} m, outside the +-{max_offset:g} m search: the stations "
            "differ by more than the search allows; widen max_offset (CLI: --max-offset)"]


def _reference_track_names(reference: Profile, run: Profile) -> Profile:
    """``run`` with a track named as the reference's where the names differ only in case (a CSV's ``left``, a ProVAL
    ERD's ``Left`` or ``LEFT``: the user had to edit the ERD's header)."""
    by_lower = {t.lower(): t for t in reference.tracks}
    names = tuple(t if t in reference.tracks else by_lower.get(t.lower(), t) for t in run.tracks)
    return run if names == tuple(run.tracks) or len(set(names)) < len(names) else replace(run, tracks=names)


def _refuse_copies(runs, labels) -> None:
    """Refuse two runs with identical stations and elevations (the same file given twice counts as a perfect
    repeat)."""
    seen = {}
    for lab, r in zip(labels, runs):
        key = (tuple(r.tracks), r.distance.tobytes(), np.asarray(r.elevation).tobytes())
        if key in seen:
            raise InputError(f"runs {seen[key]} and {lab} are identical (the same file twice?): repeatability needs "
                             "separate runs.")
        seen[key] = lab
