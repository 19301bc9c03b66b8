"""Profilograph simulation (California type, 25 ft) and the Profile Index with a blanking band (CT 526 practice).

The trace is a linear, non-recursive combination of the profile at the wheel positions (no recursion loop).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..._validation import require_positive
from ...core import Profile
from ...errors import InputError

__all__ = ["CALIFORNIA_WHEELS_FT", "ProfileIndexResult", "ProfilographTrace", "profilograph_index",
           "profilograph_trace"]

_FT = 0.3048
#: Support-wheel offsets of the simulated California profilograph from its recording wheel, ft: 12 wheels, six
#: at each end of the 25 ft frame, 6 in apart, the outermost at the frame ends. ASSUMPTION: CT 526 and ASTM
#: E2955 describe a 25 ft, 12-wheel frame with staggered support wheels; their exact positions could not be
#: confirmed here. Pass ``wheels=`` (m) for another layout.
CALIFORNIA_WHEELS_FT = tuple(s * (12.5 - 0.5 * i) for s in (-1.0, 1.0) for i in range(6))
#: Blanking band width: 0.2 in (5.08 mm), CT 526 (the historical California band; agencies now often use 0.0).
BLANKING_BAND_M = 0.2 * 0.0254
#: Smallest scallop counted: 0.03 in high (0.762 mm) and 2 ft long (CT 526 practice as recalled; ASSUMPTION).
MIN_SCALLOP = (0.03 * 0.0254, 2 * _FT)
#: Bump template: 0.3 in (7.62 mm) over 25 ft (7.62 m) (CT 526 practice as recalled; ASSUMPTION).
BUMP_TEMPLATE = (0.3 * 0.0254, 25 * _FT)


@dataclass(frozen=True, eq=False)
class ProfilographTrace:
    """Simulated profilograph trace: recording-wheel elevation minus the mean of the support wheels.

    Attributes
    ----------
    station : (M,) ndarray
        Recording-wheel stations whose frame lies on the profile, m.
    trace : (M, K) ndarray
        m; columns ``tracks``.
    tracks : tuple of str
    wheels : (W,) ndarray
        Support-wheel offsets from the recording wheel, m.
    """

    station: np.ndarray
    trace: np.ndarray
    tracks: tuple[str, ...]
    wheels: np.ndarray


@dataclass(frozen=True, eq=False)
class ProfileIndexResult:
    """Profile Index of profilograph traces per segment, and the bumps above the template.

    Attributes
    ----------
    segment_start, segment_end : (S,) ndarray
        m.
    profile_index : (S, K) ndarray
        Sum of scallop heights outside the blanking band per length, m/km (x 63.36 for in/mi).
    bumps : pandas.DataFrame
        ``track, start_m, end_m, height_m``: rises-and-falls of the trace higher than the template within its
        length.
    tracks : tuple of str
    metadata : dict
    """

    segment_start: np.ndarray
    segment_end: np.ndarray
    profile_index: np.ndarray
    bumps: pd.DataFrame
    tracks: tuple[str, ...]
    metadata: dict = field(default_factory=dict)


def profilograph_trace(profile: Profile, *, wheels=None, tracks=None) -> ProfilographTrace:
    """Simulate a profilograph: ``trace(x) = z(x) - mean_i z(x + d_i)``.

    Parameters
    ----------
    profile : Profile
        Stations (may be irregular) and elevations, m; no NaN.
    wheels : (W,) array_like, optional
        Support-wheel offsets from the recording wheel, m (default :data:`CALIFORNIA_WHEELS_FT` in m).
    tracks : str or sequence of str, optional

    Returns
    -------
    ProfilographTrace

    Notes
    -----
    The kinematic profilograph of ASTM E2955 (first practice): a rigid frame resting on its support wheels
    carries the recording wheel; with the frame height taken as the mean of the support-wheel elevations
    (equal load on every wheel, point contact; longprofile assumptions) the trace is the recording wheel
    relative to the frame. On a sine of wavenumber k the gain is ``|1 - mean_i exp(j k d_i)|`` (tested).
    """
    d = np.asarray([w * _FT for w in CALIFORNIA_WHEELS_FT] if wheels is None else wheels, dtype=float)
    if d.ndim != 1 or d.size == 0 or not np.all(np.isfinite(d)):
        raise InputError("wheels must be a non-empty 1-D array of finite offsets, m.")
    names = profile.tracks if tracks is None else ((tracks,) if isinstance(tracks, str) else tuple(tracks))
    z = np.column_stack([profile.track(t) for t in names])
    if np.isnan(z).any():
        raise InputError("the profilograph simulation needs a continuous profile (NaN elevations found).")
    x = profile.distance
    keep = (x + d.min() >= x[0] - 1e-9) & (x + d.max() <= x[-1] + 1e-9)
    if not keep.any():
        raise InputError(f"the profile ({x[-1] - x[0]:.3f} m) is shorter than the profilograph frame "
                         f"({d.max() - d.min():.3f} m).")
    c = x[keep]
    pos = np.clip(c[:, None] + d[None, :], x[0], x[-1]).ravel()
    tr = np.column_stack([z[keep, j] - np.interp(pos, x, z[:, j]).reshape(c.size, d.size).mean(axis=1)
                          for j in range(z.shape[1])])
    return ProfilographTrace(station=c, trace=tr, tracks=tuple(names), wheels=d)


def _scallops(s: np.ndarray, y: np.ndarray, half_band: float, min_height: float, min_length: float) -> float:
    """Sum of the heights of the excursions of y beyond +-half_band (each counted once at its peak)."""
    total = 0.0
    for sign in (1.0, -1.0):
        out = sign * y > half_band
        if not out.any():
            continue
        edge = np.diff(np.concatenate([[0], out.astype(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(edge == 1), np.flatnonzero(edge == -1) - 1):
            height = float(np.max(sign * y[a:b + 1]) - half_band)
            if height >= min_height and s[b] - s[a] >= min_length:
                total += height
    return total


def profilograph_index(trace: ProfilographTrace, *, segment_length: float = 0.1 * 1609.344,
                  blanking_band: float = BLANKING_BAND_M, min_scallop=MIN_SCALLOP,
                  bump_template=BUMP_TEMPLATE, lowpass: float | None = 2 * _FT) -> ProfileIndexResult:
    """Profile Index (CT 526 practice): scallops outside a blanking band per length, and template bumps.

    Parameters
    ----------
    trace : ProfilographTrace
        Regularly sampled trace (from a regularly sampled profile).
    segment_length : float
        m (default 0.1 mi = 160.9344 m).
    blanking_band : float
        Full band width, m (default 0.2 in; 0 for the "zero blanking band" PI).
    min_scallop : (float, float)
        Smallest counted scallop (height, length), m.
    bump_template : (float, float)
        (height, length), m: a bump is a rise and fall of the trace each larger than the height within the length.
    lowpass : float or None
        Cut-off wavelength of a 3rd-order zero-phase Butterworth low-pass applied to the trace first, m
        (default 2 ft, the filter ProVAL applies to simulated traces as recalled -- ASSUMPTION); None: no filter.

    Returns
    -------
    ProfileIndexResult

    Notes
    -----
    The band is centred on the least-squares line of the trace over each segment (ASSUMPTION: CT 526 places
    it by eye through the trace). Each excursion beyond the band counts once with its peak height above (or
    below) the band; PI = sum of heights / segment length, reported in m/km (1 m/km = 63.36 in/mi). On a sine
    trace of amplitude a and wavelength lambda the PI is ``2 (a - b/2) / lambda`` per length (tested).
    """
    seg = require_positive("segment_length (m)", segment_length)
    band = require_positive("blanking_band (m)", blanking_band, strict=False)
    s, y = trace.station, trace.trace.copy()
    if s.size < 2:
        raise InputError("the trace is too short.")
    dx = float(np.mean(np.diff(s)))
    if not np.allclose(np.diff(s), dx, rtol=1e-6, atol=0):
        raise InputError("profilograph_index needs a regularly sampled trace; resample the profile first.")
    if lowpass is not None:
        from ...statespace import filter_design, sos_filtfilt

        cut = require_positive("lowpass (m)", lowpass)
        if cut > 2 * dx:
            sos = filter_design("butter", 3, 1.0 / cut, btype="lowpass", fs=1.0 / dx, output="sos")
            y = sos_filtfilt(sos, y)
    n = int(np.floor((s[-1] - s[0]) / seg + 1e-9))
    if n < 1:
        raise InputError(f"the trace ({s[-1] - s[0]:.2f} m) is shorter than one segment ({seg:g} m).")
    starts = s[0] + seg * np.arange(n)
    pi = np.zeros((n, y.shape[1]))
    for i, a in enumerate(starts):
        m = (s >= a) & (s < a + seg)
        for j in range(y.shape[1]):
            coef = np.polyfit(s[m] - a, y[m, j], 1)
            r = y[m, j] - np.polyval(coef, s[m] - a)
            pi[i, j] = _scallops(s[m], r, 0.5 * band, min_scallop[0], min_scallop[1]) / seg * 1000.0
    rows = []
    h, length = bump_template
    w = max(2, 2 * int(round(length / dx / 2)))  # even: the windows below are exactly [i - w, i] and [i, i + w]
    for j, t in enumerate(trace.tracks):
        yj = y[:, j]
        if yj.size <= w:
            continue
        # rise from the lowest point within the template length before, and fall to the lowest after
        from scipy.ndimage import minimum_filter1d

        before = minimum_filter1d(yj, size=w + 1, origin=w // 2, mode="nearest")
        after = minimum_filter1d(yj, size=w + 1, origin=-(w // 2), mode="nearest")
        bump = np.minimum(yj - before, yj - after) > h
        edge = np.diff(np.concatenate([[0], bump.astype(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(edge == 1), np.flatnonzero(edge == -1) - 1):
            k = a + int(np.argmax(yj[a:b + 1]))
            rows.append({"track": t, "start_m": float(s[a]), "end_m": float(s[b]), "peak_m": float(s[k]),
                         "height_m": float(min(yj[k] - before[k], yj[k] - after[k]))})
    meta = {"practice": "California Test 526 / ASTM E2955 kinematic profilograph (constants: see docs)",
            "blanking_band_m": band, "min_scallop_m": list(map(float, min_scallop)),
            "bump_template_m": list(map(float, bump_template)), "lowpass_m": lowpass,
            "wheels_m": trace.wheels.tolist(), "segment_length_m": seg}
    return ProfileIndexResult(segment_start=starts, segment_end=starts + seg, profile_index=pi,
                              bumps=pd.DataFrame(rows, columns=["track", "start_m", "end_m", "peak_m", "height_m"]),
                              tracks=trace.tracks, metadata=meta)
