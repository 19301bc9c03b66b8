"""ISO 8608 road roughness: class table, random road synthesis, PSD in wavenumber and class fit.

Definitions (ISO 8608:2016, *Mechanical vibration -- Road surface profiles -- Reporting of
measured data*, section 5 and table 1; the same table is in the 1995 edition):

* displacement PSD Gd(n) in m^3 (= m^2 per cycle/m) against the spatial frequency n in cycles/m;
* the idealised spectrum ``Gd(n) = Gd(n0) * (n / n0) ** (-w)`` with n0 = 0.1 cycle/m and the
  waviness w = 2 for the classification;
* classes A..H by the value of Gd(n0), each class one factor 4 wide (table ``ISO8608_CLASSES``);
* the spatial frequency range of the classification 0.011 <= n <= 2.83 cycles/m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._validation import as_float_array, require_positive
from ...core import Profile
from ...errors import InputError, ShapeError
from ._gaps import gaps_mode, valid_runs

__all__ = [
    "ISO8608_CLASSES",
    "ISO8608_BAND",
    "iso8608_gd",
    "iso8608_class",
    "iso8608_profile",
    "ProfilePSD",
    "profile_psd",
    "ISO8608Fit",
    "fit_iso8608",
]

#: ISO 8608 table 1: class -> (lower limit, geometric mean, upper limit) of Gd(n0), m^3, n0 = 0.1 cycle/m.
#: Class A has no lower limit (0 here) and class H no upper limit (inf here).
ISO8608_CLASSES: dict[str, tuple[float, float, float]] = {
    "A": (0.0, 16e-6, 32e-6),
    "B": (32e-6, 64e-6, 128e-6),
    "C": (128e-6, 256e-6, 512e-6),
    "D": (512e-6, 1024e-6, 2048e-6),
    "E": (2048e-6, 4096e-6, 8192e-6),
    "F": (8192e-6, 16384e-6, 32768e-6),
    "G": (32768e-6, 65536e-6, 131072e-6),
    "H": (131072e-6, 262144e-6, np.inf),
}

#: Spatial frequency range (cycles/m) over which ISO 8608 classifies a road.
ISO8608_BAND: tuple[float, float] = (0.011, 2.83)


def iso8608_gd(wavenumber, road_class: str | float, *, waviness: float = 2.0, n0: float = 0.1) -> np.ndarray:
    """Idealised ISO 8608 displacement PSD ``Gd(n) = Gd(n0) (n/n0)^-w``, m^3.

    Parameters
    ----------
    wavenumber : array_like
        Spatial frequencies n, cycles/m (> 0).
    road_class : str or float
        A class letter ``"A"``..``"H"`` (uses the geometric mean of the class, ISO 8608 table 1)
        or the value Gd(n0) itself in m^3.
    waviness : float
        Exponent w (ISO 8608: 2).
    n0 : float
        Reference spatial frequency, cycles/m (ISO 8608: 0.1).

    Returns
    -------
    ndarray
        Gd(n), m^3, same shape as ``wavenumber``.
    """
    n = as_float_array("wavenumber", wavenumber, allow_nan=False)
    if np.any(n <= 0):
        raise InputError("wavenumber must be > 0 cycles/m; got a value <= 0.")
    gd0 = _gd_n0_of(road_class)
    n0 = require_positive("n0", n0)
    return gd0 * (n / n0) ** (-float(waviness))


def _gd_n0_of(road_class) -> float:
    if isinstance(road_class, str):
        key = road_class.strip().upper()
        if key not in ISO8608_CLASSES:
            raise InputError(f"road_class must be one of {list(ISO8608_CLASSES)} or a value Gd(n0) in m^3; "
                             f"got {road_class!r}.")
        return ISO8608_CLASSES[key][1]
    return require_positive("road_class (Gd(n0) in m^3)", road_class)


def iso8608_class(gd_n0: float) -> str:
    """ISO 8608 class letter (A..H) of a displacement PSD value Gd(n0) in m^3 (table 1 limits).

    A value exactly on a limit belongs to the rougher class (limits are lower-inclusive).
    """
    g = require_positive("gd_n0", gd_n0)
    for letter, (lo, _, hi) in ISO8608_CLASSES.items():
        if lo <= g < hi:
            return letter
    return "H"  # pragma: no cover  (hi of H is inf)


def iso8608_profile(length: float, dx: float, road_class: str | float, *, rng=None, waviness: float = 2.0,
                    n0: float = 0.1, band: tuple[float, float] | None = None,
                    tracks: tuple[str, ...] = ("left",), name: str = "") -> Profile:
    """A random road profile with the ISO 8608 displacement PSD of a class.

    Parameters
    ----------
    length : float
        Length of the profile, m. The stations are ``0, dx, 2 dx, ...`` up to ``length``
        (``N = floor(length / dx) + 1`` samples).
    dx : float
        Sample spacing, m.
    road_class : str or float
        Class ``"A"``..``"H"`` (geometric mean Gd(n0) of the class, ISO 8608 table 1) or Gd(n0) in m^3.
    rng : int, numpy.random.Generator or None
        Seed or generator for the random phases (same seed -> same profile).
    waviness : float
        Exponent w of ``Gd(n) = Gd(n0) (n/n0)^-w`` (default 2, the ISO 8608 value).
    n0 : float
        Reference spatial frequency, cycles/m (default 0.1).
    band : (float, float) or None
        Spatial frequency band (cycles/m) that receives power. Default: the ISO 8608 range
        ``(0.011, 2.83)``. Only frequencies that a record of this length and spacing can carry
        are synthesised (see Notes); a band entirely outside them raises :class:`InputError`.
    tracks : tuple of str
        Track names; each track is an independent realisation (no left/right coherence).
    name : str
        Label stored in the profile.

    Returns
    -------
    Profile
        ``distance`` (N,) m from 0, ``elevation`` (N, len(tracks)) m with zero mean.

    Notes
    -----
    Synthesis by harmonic superposition (sum of cosines with deterministic amplitudes and
    independent uniform random phases, the method of Shinozuka & Jan 1972)::

        z(x) = sum_k sqrt(2 Gd(n_k) dn) cos(2 pi n_k x + phi_k),   n_k = k dn,   dn = 1 / (N dx)

    evaluated exactly with one inverse real FFT of length N. The harmonics are those of the
    FFT grid strictly inside ``(0, 1/(2 dx))`` whose frequency lies in ``band``: frequencies
    below ``1/(N dx)`` cannot exist in a record of length ``N dx`` and frequencies above the
    Nyquist frequency ``1/(2 dx)`` cannot be sampled, so the realised band is
    ``[max(band[0], 1/(N dx)), min(band[1], 1/(2 dx))``. The one-sided periodogram of the
    (periodic) record equals Gd(n_k) exactly at every synthesised harmonic; the variance is
    ``sum_k Gd(n_k) dn``. The elevation is Gaussian only asymptotically (central limit theorem).

    References
    ----------
    ISO 8608:2016, Mechanical vibration -- Road surface profiles -- Reporting of measured data.
    M. Shinozuka, C.-M. Jan, "Digital simulation of random processes and its applications",
    J. Sound Vib. 25(1), 1972.

    Examples
    --------
    >>> p = iso8608_profile(200.0, 0.05, "C", rng=0)
    >>> p.elevation.shape
    (4001, 1)
    """
    length = require_positive("length", length)
    dx = require_positive("dx", dx)
    n0 = require_positive("n0", n0)
    waviness = float(waviness)
    if not np.isfinite(waviness):
        raise InputError(f"waviness must be finite; got {waviness!r}.")
    gd0 = _gd_n0_of(road_class)
    lo, hi = ISO8608_BAND if band is None else band
    lo = require_positive("band[0]", lo, strict=False)
    hi = require_positive("band[1]", hi)
    if hi <= lo:
        raise InputError(f"band must be (low, high) cycles/m with low < high; got {band!r}.")
    tracks = tuple(tracks)
    if not tracks:
        raise InputError("tracks must name at least one track.")
    n_samples = int(np.floor(length / dx + 1e-9)) + 1
    if n_samples < 4:
        raise InputError(f"length / dx gives only {n_samples} samples; need at least 4 (length {length} m, dx {dx} m).")
    dn = 1.0 / (n_samples * dx)
    k = np.arange(n_samples // 2 + 1)
    n = k * dn
    keep = (k > 0) & (2 * k < n_samples) & (n >= lo) & (n <= hi)
    if not keep.any():
        raise InputError(f"no spatial frequency of a {n_samples * dx:g} m record sampled every {dx:g} m lies in "
                         f"band {lo:g}..{hi:g} cycles/m (resolvable: {dn:g}..{0.5 / dx:g}); lengthen the profile, "
                         "refine dx or widen the band.")
    amplitude = np.zeros(n.shape)
    amplitude[keep] = np.sqrt(2.0 * gd0 * (n[keep] / n0) ** (-waviness) * dn)
    gen = np.random.default_rng(rng)
    z = np.empty((n_samples, len(tracks)))
    for j in range(len(tracks)):
        phase = gen.uniform(0.0, 2.0 * np.pi, size=n.shape)
        spectrum = 0.5 * n_samples * amplitude * np.exp(1j * phase)
        z[:, j] = np.fft.irfft(spectrum, n=n_samples)
    distance = np.arange(n_samples) * dx
    return Profile(distance=distance, elevation=z, tracks=tracks, name=name or f"ISO 8608 class {road_class}")


@dataclass(frozen=True)
class ProfilePSD:
    """One-sided displacement PSD of a profile in wavenumber.

    Attributes
    ----------
    wavenumber : (F,) ndarray
        Spatial frequency n, cycles/m (starts at 0).
    psd : (F, K) ndarray
        Gd(n), m^3 (m^2 per cycle/m), one column per track.
    tracks : tuple of str
        Track names of the columns.
    segment_length : float
        Length of the Welch segments, m (frequency resolution = 1 / segment_length).
    n_segments : int
        Number of (50 % overlapping) segments averaged.
    """

    wavenumber: np.ndarray
    psd: np.ndarray
    tracks: tuple[str, ...]
    segment_length: float
    n_segments: int


def _window(name: str, n: int) -> np.ndarray:
    """The periodic (DFT-even) window of ``scipy.signal.get_window(name, n)``; Hann without importing scipy.signal."""
    if name in ("hann", "hanning"):
        return np.hanning(n + 1)[:-1]
    from scipy.signal import get_window

    return get_window(name, n)


def profile_psd(profile: Profile, *, segment_length: float | None = None, detrend: str = "linear",
                window: str = "hann", gaps: str = "refuse") -> ProfilePSD:
    """Welch estimate of the one-sided displacement PSD of each track, in cycles/m.

    Parameters
    ----------
    profile : Profile
        Regularly spaced profile (elevations in m). Missing samples (NaN) are not allowed.
    segment_length : float, optional
        Welch segment length, m (default: ``min(profile length, 2**ceil(log2(100 m / dx)) * dx)``,
        i.e. >= 100 m so the lowest resolved wavenumber is <= 0.01 cycle/m when the profile allows).
    detrend : {"linear", "constant"}
        Per-segment detrending (default linear: removes grade).
    window : str
        Window name of :func:`scipy.signal.get_window` (default Hann, periodic), 50 % overlap.
    gaps : {"refuse", "restart"}
        Missing (NaN) elevations: refused (default), or ``"restart"``: Welch's average over the segments lying in
        the runs of measured samples only (each run as its own record; ``mlab.psd`` per run, the runs' averages
        weighted by their numbers of segments; a run shorter than one segment is not used). The default segment
        is then at most the shortest track's longest run.

    Returns
    -------
    ProfilePSD

    Raises
    ------
    InputError
        Irregular station spacing (Welch needs a constant step: interpolate explicitly, e.g. with
        ``numpy.interp`` onto a regular grid, and say so in your report), NaN elevations, or a segment
        longer than the profile.

    Notes
    -----
    The estimate of ``scipy.signal.welch(z, fs=1/dx, window, nperseg, noverlap=nperseg // 2, detrend,
    scaling="density", axis=0)`` with ``fs`` in samples/m, so the PSD is in m^2/(cycle/m) = m^3 and integrates (over
    n) to the variance of the detrended profile, as ISO 8608 section 5 defines Gd(n). It is computed by
    :func:`matplotlib.mlab.psd` (the same Welch average; equal to scipy's within 2e-15 relative, tested against
    it): importing scipy.signal costs ``road report`` 0.35 s of its start-up, matplotlib.mlab 0.08 s (issue 12).
    """
    from matplotlib import mlab

    if detrend not in ("linear", "constant"):
        raise InputError(f"profile_psd: detrend must be 'linear' or 'constant', not {detrend!r}.")
    gaps_mode(gaps)
    dx = profile.spacing
    if dx is None:
        raise InputError("profile_psd needs a constant station spacing; this profile is irregular. Interpolate it "
                         "onto a regular grid first (e.g. numpy.interp) and state it in your report.")
    n = profile.n_samples
    z = profile.elevation.reshape(n, -1)
    runs = None
    if np.isnan(z).any():
        if gaps_mode(gaps) != "restart":
            raise InputError("profile_psd: the elevation has NaN (missing) samples; fill or cut them out first, or "
                             "pass gaps='restart' (--gaps restart) to average the Welch segments of the measured runs.")
        runs = [valid_runs(profile.distance, np.isnan(z[:, j])) for j in range(z.shape[1])]
        n = min((max((k - i + 1 for i, k in r), default=0) for r in runs), default=0)
    if segment_length is None:
        nper = min(n, int(2 ** np.ceil(np.log2(max(100.0 / dx, 8)))))
    else:
        seg = require_positive("segment_length", segment_length)
        nper = int(round(seg / dx))
        if nper > n:
            what = "the profile" if runs is None else "the longest measured run between the gaps"
            raise InputError(f"segment_length {seg:g} m is longer than {what} ({n * dx:g} m); shorten it.")
        if nper < 8:
            raise InputError(f"segment_length {seg:g} m covers only {nper} samples of {dx:g} m; need at least 8.")
    if runs is not None and nper < 8:
        raise InputError(f"the longest run of measured elevations between the gaps has {n} samples; the PSD needs at "
                         "least 8.")
    taps = _window(window, nper)

    def welch(col):
        return mlab.psd(col, NFFT=nper, Fs=1.0 / dx, detrend="mean" if detrend == "constant" else "linear",
                        window=taps, noverlap=nper // 2, sides="onesided", scale_by_freq=True)

    if runs is None:
        columns = [welch(col) for col in z.T]
        n_segments = 1 + (n - nper) // (nper - nper // 2)
    else:
        columns, counts = [], []
        for j, track_runs in enumerate(runs):
            parts = [(1 + (k - i + 1 - nper) // (nper - nper // 2), welch(z[i:k + 1, j])) for i, k in track_runs
                     if k - i + 1 >= nper]
            count = sum(c for c, _ in parts)
            columns.append((sum(c * p for c, (p, _) in parts) / count, parts[0][1][1]))
            counts.append(count)
        n_segments = min(counts)
    pxx, f = np.stack([c[0] for c in columns], axis=1), columns[0][1]
    return ProfilePSD(wavenumber=f, psd=pxx, tracks=profile.tracks, segment_length=nper * dx, n_segments=n_segments)


@dataclass(frozen=True)
class ISO8608Fit:
    """ISO 8608 fit of a displacement PSD.

    Attributes
    ----------
    n0 : float
        Reference spatial frequency, cycles/m.
    gd_n0 : float
        Gd(n0), m^3, fitted with the waviness fixed at 2 (the ISO 8608 classification value).
    road_class : str
        ISO 8608 class (A..H) of ``gd_n0``.
    gd_n0_free : float
        Gd(n0), m^3, fitted jointly with the waviness.
    waviness : float
        Fitted waviness w.
    road_class_free : str
        ISO 8608 class of ``gd_n0_free``.
    band : (float, float)
        Spatial frequency band used, cycles/m.
    n_points : int
        Number of PSD ordinates used.
    """

    n0: float
    gd_n0: float
    road_class: str
    gd_n0_free: float
    waviness: float
    road_class_free: str
    band: tuple[float, float]
    n_points: int


def fit_iso8608(wavenumber, psd, *, n0: float = 0.1, band: tuple[float, float] | None = None) -> ISO8608Fit:
    """Fit ``Gd(n) = Gd(n0) (n/n0)^-w`` to a PSD (w = 2 and free w) and classify it (ISO 8608).

    Parameters
    ----------
    wavenumber : (F,) array_like
        Spatial frequencies, cycles/m (``ProfilePSD.wavenumber``).
    psd : (F,) array_like
        Displacement PSD, m^3 (one track: ``ProfilePSD.psd[:, k]``).
    n0 : float
        Reference spatial frequency, cycles/m (default 0.1).
    band : (float, float), optional
        Fit range, cycles/m (default: ISO 8608's 0.011..2.83 intersected with the positive ordinates given).

    Returns
    -------
    ISO8608Fit

    Notes
    -----
    Least squares on ``log Gd`` against ``log(n/n0)`` with weights ``1/n`` so that every part of the
    log-frequency axis counts equally (Welch ordinates are evenly spaced in n; unweighted, the short
    wavelengths would dominate). With w fixed at 2 this gives ``log Gd(n0)`` as the weighted mean of
    ``log G(n) + 2 log(n/n0)``. Assumption: the small bias of the log of a Welch estimate (a few per cent
    for the tens of averaged segments of a typical profile) is neglected.
    """
    n = as_float_array("wavenumber", wavenumber, ndim=1, allow_nan=False)
    g = as_float_array("psd", psd, ndim=1, allow_nan=False)
    if g.shape != n.shape:
        raise ShapeError(f"psd must have one value per wavenumber ({n.shape[0]}); got shape {g.shape}.")
    n0 = require_positive("n0", n0)
    lo, hi = ISO8608_BAND if band is None else band
    use = (n >= lo) & (n <= hi) & (n > 0) & (g > 0)
    if use.sum() < 3:
        raise InputError(f"fit_iso8608 needs at least 3 positive PSD ordinates in {lo:g}..{hi:g} cycles/m; got "
                         f"{int(use.sum())}. Use a longer profile or longer Welch segments.")
    x = np.log(n[use] / n0)
    y = np.log(g[use])
    w = 1.0 / n[use]
    w = w / w.sum()
    log_gd_fixed = float(np.sum(w * (y + 2.0 * x)))
    xm, ym = float(np.sum(w * x)), float(np.sum(w * y))
    slope = float(np.sum(w * (x - xm) * (y - ym)) / np.sum(w * (x - xm) ** 2))
    log_gd_free = ym - slope * xm
    gd_fixed, gd_free = float(np.exp(log_gd_fixed)), float(np.exp(log_gd_free))
    return ISO8608Fit(n0=n0, gd_n0=gd_fixed, road_class=iso8608_class(gd_fixed), gd_n0_free=gd_free,
                      waviness=-slope, road_class_free=iso8608_class(gd_free), band=(float(lo), float(hi)),
                      n_points=int(use.sum()))
