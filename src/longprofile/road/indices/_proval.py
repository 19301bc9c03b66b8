"""ProVAL's other analyses as an agency reports them, in SI or US units: the Ride Number per segment (ASTM E1489),
rolling straightedge defects, the California Profile Index per segment (CT 526) and joint faulting (AASHTO R 36
practice) -- one call each, what ``longprofile road ride-number``, ``road straightedge``, ``road profile-index``
and ``road faulting`` write (docs/road-indices.md, "Other ProVAL analyses").

Every default is a named constant below; the assumptions are listed in the docs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ...core import Profile
from ...errors import InputError, UnitsError

__all__ = ["INDEX_DEFAULTS", "INDEX_VALUE_RANGES", "IndexReport", "faulting_report", "profile_index_report",
           "ride_number_report", "straightedge_report"]

#: The unit systems: length unit and m per unit, small-length unit and mm per unit, a slope index (m/km; in/mi).
_UNITS = {
    "si": {"length": "m", "m": 1.0, "small": "mm", "mm": 1.0, "slope": "m/km", "slope_col": "m_per_km",
           "per_m_per_km": 1.0, "pi": "mm/km", "pi_col": "mm_per_km", "per_mm_per_km": 1.0},
    "us": {"length": "ft", "m": 0.3048, "small": "in", "mm": 25.4, "slope": "in/mi", "slope_col": "in_per_mi",
           "per_m_per_km": 63.36, "pi": "in/mi", "pi_col": "in_per_mi", "per_mm_per_km": 0.06336},
}

#: Defaults per unit system, in that system's units (ASSUMPTIONS, docs/road-indices.md "Other ProVAL analyses"):
#: 100 m / 528 ft (0.1 mi) segments (the Ride Number as `road iri`; the Profile Index: CT 526 reports per 0.1 mi,
#: 0.1 km in SI); a 3 m (EN 13036-7) / 10 ft straightedge with a 3 mm / 1/8 in deviation threshold; CT 526's
#: 0.2 in blanking band, 5 mm in SI (Caltrans' metric value, not 5.08 mm); joints found with a fault of 1 mm /
#: 0.04 in or more, at least 3 m / 10 ft apart (shorter than any slab).
INDEX_DEFAULTS = {
    "si": {"segment": 100.0, "straightedge_length": 3.0, "threshold": 3.0, "blanking_band": 5.0, "min_fault": 1.0,
           "min_joint_spacing": 3.0},
    "us": {"segment": 528.0, "straightedge_length": 10.0, "threshold": 0.125, "blanking_band": 0.2,
           "min_fault": 0.04, "min_joint_spacing": 10.0},
}

#: Plausible range of each option once converted (lengths in m, small lengths in mm), with the option and what it
#: is: outside it the value is in the other unit system (``--length 10`` in an SI run meant 10 ft) or a typo.
#: ASSUMPTION (longprofile's choices, as SPEC_VALUE_RANGES of `road acceptance`): segments of 10 m-10 km,
#: straightedges of 1-6 m (3 m, 10 ft, 16 ft in use), a deviation threshold of 0.5-25 mm, a blanking band of 0
#: or 1-12.7 mm (0.5 in), a smallest fault of 0.2-25 mm, joints 1-30 m apart.
INDEX_VALUE_RANGES = {
    "segment": ("--segment", "segment", (10.0, 10000.0), "length"),
    "straightedge_length": ("--length", "straightedge", (1.0, 6.0), "length"),
    "threshold": ("--threshold", "straightedge deviation threshold", (0.5, 25.0), "small"),
    "blanking_band": ("--blanking-band", "blanking band (or 0)", (1.0, 12.7), "small"),
    "min_fault": ("--min-fault", "smallest fault found", (0.2, 25.0), "small"),
    "min_joint_spacing": ("--min-joint-spacing", "smallest joint spacing", (1.0, 30.0), "length"),
}

#: (factor, share): a warning when more than ``share`` of the joint spacings found are under ``factor`` x the smallest
#: spacing allowed -- joints detected as densely as allowed, which steps on an unjointed (asphalt) pavement are
#: (ASSUMPTION: measured on a simulated ISO 8608 class C asphalt profile, 1 km, 0.05 m: 251 "joints", 46 % of the
#: spacings under 1.2 x 3 m; jointed slabs are 4-6 m long).
CLOSE_JOINTS = (1.2, 0.25)

#: Smallest plausible section Profile Index of the Ride Number, m/m (0.1 m/km: RN 4.92). ASSUMPTION: the smoothest
#: new pavements have an IRI of about 0.5 m/km (PLAUSIBLE_IRI_M_PER_KM starts at 0.2) and the RN's PI exceeds the
#: IRI on the profiles measured here (PI 12.9, IRI 8.8 m/km on a simulated class C road).
MIN_PLAUSIBLE_PI = 1e-4

#: Longest station step these analyses accept, m (a step over it is a gap: rows removed from the file).
MAX_STEP_M = 1.0


@dataclass(frozen=True, eq=False)
class IndexReport:
    """One ProVAL analysis as a table in the report units.

    Attributes
    ----------
    kind : str
        "ride-number", "straightedge", "profile-index" or "faulting".
    table : pandas.DataFrame
        The main table (``-o``): segments (Ride Number, Profile Index), defects (straightedge) or joints
        (faulting); each column names its unit (``_m``/``_ft``, ``_mm``/``_in``, ``_m_per_km``/``_in_per_mi``).
    detail : pandas.DataFrame or None
        The second table: the deviation at every station (straightedge) or the bumps (Profile Index).
    summary : tuple of str
        The lines the command prints.
    notes : tuple of str
        Warnings (a value no road gives, no joint found, a profile shorter than one segment).
    units : str
        "si" or "us".
    metadata : dict
        JSON scalars: standard, units, options in the report units, section values.
    """

    kind: str
    table: pd.DataFrame
    detail: pd.DataFrame | None
    summary: tuple[str, ...]
    notes: tuple[str, ...]
    units: str
    metadata: dict = field(default_factory=dict)

    @property
    def length_unit(self) -> str:
        return _UNITS[self.units]["length"]

    @property
    def small_unit(self) -> str:
        return _UNITS[self.units]["small"]

    def to_frame(self) -> pd.DataFrame:
        """The main table with the metadata in ``frame.attrs["longprofile"]`` (what ``-o`` writes)."""
        frame = self.table.copy()
        frame.attrs["longprofile"] = dict(self.metadata)
        return frame

    def detail_frame(self) -> pd.DataFrame | None:
        """The second table with the metadata, or None."""
        if self.detail is None:
            return None
        frame = self.detail.copy()
        frame.attrs["longprofile"] = dict(self.metadata)
        return frame


def _unit_system(units) -> dict:
    key = units.strip().lower() if isinstance(units, str) else units
    if key not in _UNITS:
        raise UnitsError(f"units must be 'si' (m, mm) or 'us' (ft, in); got {units!r}.")
    return dict(_UNITS[key], key=key)


def _option(name: str, value, u: dict, *, zero: bool = False) -> float:
    """``value`` of the option ``name`` (None: the default) in the report units, checked against
    :data:`INDEX_VALUE_RANGES`; returns it in SI (m for lengths, mm for small lengths)."""
    if value is None:
        value = INDEX_DEFAULTS[u["key"]][name]
    option, what, (lo, hi), kind = INDEX_VALUE_RANGES[name]
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{option} must be a number; got {value!r}.") from None
    if zero and v == 0.0:
        return 0.0
    unit, factor = (u["length"], u["m"]) if kind == "length" else (u["small"], u["mm"])
    base = "m" if kind == "length" else "mm"
    if np.isfinite(v) and lo <= v * factor <= hi:
        return v * factor
    other = _UNITS["us" if u["key"] == "si" else "si"]
    o_unit, o_factor = (other["length"], other["m"]) if kind == "length" else (other["small"], other["mm"])
    shown = f"{v:g} {unit}" + ("" if factor == 1.0 else f" = {v * factor:.4g} {base}")
    meant = (f"if you meant {v:g} {o_unit}, write {v * o_factor / factor:.4g} (or run with --units "
             f"{'us' if u['key'] == 'si' else 'si'}, which changes every option's unit); else fix the value"
             if np.isfinite(v) and lo <= v * o_factor <= hi else "fix the value")
    raise UnitsError(f"{option} {value}: {shown} is outside the plausible {lo:g}-{hi:g} {base} of a {what}; the run "
                     f"is in {u['key'].upper()} units ({unit}): {meant}.")


def _tracks(profile: Profile, tracks) -> tuple[str, ...]:
    names = profile.tracks if tracks is None else ((tracks,) if isinstance(tracks, str) else tuple(tracks))
    if not names:
        raise InputError("tracks must name at least one track.")
    for t in names:
        profile.track(t)  # an unknown track: the Profile's own error
    return names


def _continuous(profile: Profile, names, what: str) -> None:
    """Refuse a missing elevation (NaN) or a station step over :data:`MAX_STEP_M` (a gap: rows removed), naming
    the first and what to do: these analyses run over a continuous profile only."""
    x = profile.distance
    cut = ("cut the profile at the gap(s) and analyse each part (only `road iri` and `road report` compute over "
           "gaps, with --gaps restart)")
    for t in names:
        z = profile.track(t)
        if np.isnan(z).any():
            i = int(np.flatnonzero(np.isnan(z))[0])
            raise InputError(f"track {t!r} has a missing (NaN) elevation at station {x[i]:.3f} m: the {what} needs a "
                             f"continuous profile; {cut}.")
    if x.size < 2:
        raise InputError(f"the profile has {x.size} station(s): the {what} needs a profile.")
    h = np.diff(x)
    k = int(np.argmax(h))
    if h[k] > MAX_STEP_M:
        med = float(np.median(h))
        if med > MAX_STEP_M:
            raise InputError(f"the profile is sampled every {med:.4g} m: the {what} needs stations at most "
                             f"{MAX_STEP_M:g} m apart. Stations in mm or ft under a metre label? Name the column "
                             "with its unit (distance_mm, distance_ft).")
        n = int(np.count_nonzero(h > MAX_STEP_M))
        raise InputError(f"the profile has {n} gap(s) longer than {MAX_STEP_M:g} m between stations (the longest "
                         f"{h[k]:.4g} m from station {x[k]:.3f} m; the median step is {med:.4g} m): rows removed "
                         f"from the file? The {what} needs a continuous profile; {cut}.")


def _meta(kind: str, standard: str, u: dict, names, **values) -> dict:
    from ... import __version__

    return {"software": f"longprofile {__version__}", "analysis": kind, "standard": standard, "units": u["key"],
            "length_unit": u["length"], "small_unit": u["small"], "tracks": ",".join(names), **values}


def _segments(x0: float, x1: float, seg: float) -> np.ndarray:
    """Starts of the complete segments of length ``seg`` from ``x0`` within ``x1`` (m)."""
    n = int(np.floor((x1 - x0) / seg + 1e-9))
    return x0 + seg * np.arange(max(n, 0))


def _fmt(v: float, prec: int = 2) -> str:
    return f"{v:.{prec}f}" if np.isfinite(v) else "none"


def ride_number_report(profile: Profile, *, segment: float | None = None, units: str = "si", tracks=None,
                       lead_in: float = 11.0, moving_average: str = "auto") -> IndexReport:
    """Ride Number (ASTM E1489) of the section and of each fixed segment, SI or US units.

    Parameters
    ----------
    profile : Profile
        Constant step, m; no NaN, no station step over 1 m.
    segment : float, optional
        Segment length in the report's length unit (default 100 m; 528 ft = 0.1 mi in US units).
    units : {"si", "us"}
    tracks : str or sequence of str, optional
    lead_in : float
        m in both unit systems (as ``road iri``'s).
    moving_average : {"auto", "on", "off"}
        The 250 mm moving average (auto: the IRI's rule, :func:`~longprofile.road.indices.ride_number_filter`).

    Returns
    -------
    IndexReport
        ``table``: ``start, end, pi_<track>`` (m/km or in/mi: the PI slope x 1000), ``rn_<track>``, ``rn``
        (from the tracks' combined PI).

    Notes
    -----
    One run of :func:`~longprofile.road.indices.ride_number_filter` over the whole profile (the quarter car is not
    restarted at segment limits, as the IRI's golden car); a segment's PI is the RMS of the filter output over the
    steps whose middle lies in it, its RN ``5 exp(-160 PI)`` (ASTM E1489 as recalled; constants: docs). The
    section values are those of :func:`~longprofile.road.indices.ride_number` (tested: equal).
    """
    from ._ride_number import ride_number_filter, rn_from_pi

    u = _unit_system(units)
    names = _tracks(profile, tracks)
    _continuous(profile, names, "Ride Number")
    seg = _option("segment", segment, u)
    modes = {"auto": None, "on": True, "off": False}
    key = moving_average.strip().lower() if isinstance(moving_average, str) else moving_average
    if key not in modes:
        raise InputError(f"moving_average must be auto, on or off; got {moving_average!r}.")
    station, out, names, applied = ride_number_filter(profile, tracks=names, lead_in=lead_in,
                                                      moving_average=modes[key])
    dx = float(profile.spacing)
    x = profile.distance
    starts = _segments(float(x[0]), float(x[-1]), seg)
    idx = np.floor((station - 0.5 * dx - x[0]) / seg).astype(np.int64)
    inside = (idx >= 0) & (idx < starts.size)
    count = np.bincount(idx[inside], minlength=starts.size).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        pi = np.column_stack([np.sqrt(np.bincount(idx[inside], weights=out[inside, j] ** 2, minlength=starts.size)
                                      / count) for j in range(out.shape[1])]) if starts.size else np.empty((0, 0))
    section_pi = np.sqrt(np.mean(out * out, axis=0))
    section_all = float(np.sqrt(np.mean(section_pi * section_pi)))
    lu, f = u["length"], u["per_m_per_km"] * 1000.0
    cols = {f"start_{lu}": starts / u["m"], f"end_{lu}": (starts + seg) / u["m"]}
    for j, t in enumerate(names):
        cols[f"pi_{t}_{u['slope_col']}"] = pi[:, j] * f if starts.size else np.empty(0)
    for j, t in enumerate(names):
        cols[f"rn_{t}"] = rn_from_pi(pi[:, j]) if starts.size else np.empty(0)
    cols["rn"] = rn_from_pi(np.sqrt(np.mean(pi * pi, axis=1))) if starts.size else np.empty(0)
    rn, track_rn = float(rn_from_pi(section_all)), rn_from_pi(section_pi)
    meta = _meta("ride-number", "ASTM E1489-08 Ride Number (constants recalled: docs/road-acceptance.md)", u, names,
                 segment=seg / u["m"], lead_in_m=float(lead_in), moving_average=key,
                 moving_average_applied=bool(applied), section_rn=rn, n_segments=int(starts.size),
                 **{f"section_rn_{t}": float(v) for t, v in zip(names, track_rn)},
                 first_station=float(x[0] / u["m"]), last_station=float(x[-1] / u["m"]))
    per_track = ", ".join(f"{t} {v:.2f}" for t, v in zip(names, track_rn))
    summary = [f"Ride Number (ASTM E1489): section {rn:.2f}" + (f" ({per_track})" if len(names) > 1 else "")
               + f"; {starts.size} segment(s) of {seg / u['m']:g} {lu} from {x[0] / u['m']:g} {lu}",
               f"moving average: {'applied' if applied else 'not applied'} (250 mm, the IRI's rule unless --moving-"
               "average on|off)"]
    notes = []
    if starts.size == 0:
        notes.append(f"the profile ({(x[-1] - x[0]) / u['m']:g} {lu}) is shorter than one {seg / u['m']:g} {lu} "
                     "segment: only the section Ride Number is given; use a shorter --segment.")
    if section_all < MIN_PLAUSIBLE_PI:
        notes.append(f"section Ride Number {rn:.3f} (PI {section_all * 1000:.3g} m/km) is that of a profile smoother "
                     f"than any road (PI under {MIN_PLAUSIBLE_PI * 1000:g} m/km; RN 5 = perfectly smooth): elevations "
                     "in metres under a mm label (e.g. left_mm holding metres), or a smoothed series rather than a "
                     "measured profile?")
    return IndexReport("ride-number", pd.DataFrame(cols), None, tuple(summary), tuple(notes), u["key"], meta)


def straightedge_report(profile: Profile, *, length: float | None = None, threshold: float | None = None,
                        units: str = "si", tracks=None) -> IndexReport:
    """Rolling straightedge (ProVAL practice): the defects over a deviation threshold, and the deviation at every
    station, SI or US units.

    Parameters
    ----------
    profile : Profile
        m; no NaN, no station step over 1 m (stations may be irregular).
    length : float, optional
        Straightedge length in the report's length unit (default 3 m; 10 ft in US units).
    threshold : float, optional
        |deviation| limit in mm or in (default 3 mm; 1/8 in in US units).
    units : {"si", "us"}
    tracks : str or sequence of str, optional

    Returns
    -------
    IndexReport
        ``table``: one row per defect, ``track, start, end, length, peak, deviation`` (start and end are centre
        stations: the straightedge reaches L/2 further each way; deviation signed, positive = bump);
        ``detail``: ``station, deviation_<track>`` at every centre station.

    Notes
    -----
    :func:`~longprofile.road.indices.rolling_straightedge`: ``d(x) = z(x) - (z(x - L/2) + z(x + L/2)) / 2``, point
    supports. On a sine ``A sin(2 pi x / lambda)`` the largest |d| is ``A (1 - cos(pi L / lambda))`` (tested).
    """
    from ._straightedge import rolling_straightedge

    u = _unit_system(units)
    names = _tracks(profile, tracks)
    _continuous(profile, names, "rolling straightedge")
    length_m = _option("straightedge_length", length, u)
    thr_mm = _option("threshold", threshold, u)
    x = profile.distance
    if x[-1] - x[0] < length_m:
        raise InputError(f"the profile ({(x[-1] - x[0]) / u['m']:g} {u['length']}) is shorter than the "
                         f"{length_m / u['m']:g} {u['length']} straightedge; use a longer profile or --length.")
    res = rolling_straightedge(profile, length=length_m, threshold=thr_mm / 1000.0, tracks=names)
    lu, su, m, mm = u["length"], u["small"], u["m"], u["mm"] / 1000.0
    rows = [{"track": d.track, f"start_{lu}": d.start / m, f"end_{lu}": d.end / m, f"length_{lu}": (d.end - d.start) / m,
             f"peak_{lu}": d.peak_station / m, f"deviation_{su}": d.peak_deviation / mm} for d in res.defects]
    table = pd.DataFrame(rows, columns=["track", f"start_{lu}", f"end_{lu}", f"length_{lu}", f"peak_{lu}",
                                        f"deviation_{su}"])
    detail = pd.DataFrame({f"station_{lu}": res.station / m,
                           **{f"deviation_{t}_{su}": res.deviation[:, j] / mm for j, t in enumerate(names)}})
    worst = res.max_abs_deviation / mm
    meta = _meta("straightedge", "rolling straightedge, mid-length wheel, point supports (FHWA ProVAL practice)", u,
                 names, length=length_m / m, threshold=thr_mm * 1e-3 / mm, n_defects=len(rows),
                 **{f"max_abs_deviation_{t}": float(v) for t, v in zip(names, worst)})
    per = ", ".join(f"{t} {sum(d.track == t for d in res.defects)}" for t in names)
    over = float(table[f"length_{lu}"].sum()) if rows else 0.0
    summary = [f"rolling straightedge {length_m / m:g} {lu}, threshold {thr_mm * 1e-3 / mm:g} {su}: {len(rows)} "
               f"defect(s)" + (f" ({per})" if len(names) > 1 else "") + f" over {over:.4g} {lu} of centre stations",
               "largest |deviation|: " + ", ".join(f"{t} {v:.3g} {su}" for t, v in zip(names, worst))]
    return IndexReport("straightedge", table, detail, tuple(summary), (), u["key"], meta)


def profile_index_report(profile: Profile, *, segment: float | None = None, blanking_band: float | None = None,
                         units: str = "si", tracks=None) -> IndexReport:
    """California profilograph Profile Index (CT 526 practice) per fixed segment, and the bumps, SI or US units.

    Parameters
    ----------
    profile : Profile
        Constant step, m; no NaN, no station step over 1 m.
    segment : float, optional
        Segment length in the report's length unit (default 100 m = 0.1 km; 528 ft = 0.1 mi in US units).
    blanking_band : float, optional
        Full band width in mm or in (default 5 mm; 0.2 in in US units); 0 for the zero-blanking-band PI.
    units : {"si", "us"}
    tracks : str or sequence of str, optional

    Returns
    -------
    IndexReport
        ``table``: ``start, end, pi_<track>`` (mm/km or in/mi), ``bumps_<track>`` (bumps whose peak lies in the
        segment); ``detail``: the bumps, ``track, start, end, peak, height``.

    Notes
    -----
    :func:`~longprofile.road.indices.profilograph_trace` (25 ft frame) then
    :func:`~longprofile.road.indices.profilograph_index`; the segments start at the first recording-wheel station
    (12.5 ft after the first profile station). 1 mm/km = 0.06336 in/mi.
    """
    from ._profilograph import BUMP_TEMPLATE, profilograph_index, profilograph_trace

    u = _unit_system(units)
    names = _tracks(profile, tracks)
    _continuous(profile, names, "Profile Index")
    seg = _option("segment", segment, u)
    band_mm = _option("blanking_band", blanking_band, u, zero=True)
    x = profile.distance
    trace = profilograph_trace(profile, tracks=names)
    lu, su, m, mm = u["length"], u["small"], u["m"], u["mm"] / 1000.0
    span = trace.station[-1] - trace.station[0]
    if span < seg - 1e-9:
        raise InputError(f"the profile ({(x[-1] - x[0]) / m:g} {lu}, {span / m:.4g} {lu} once the 25 ft profilograph "
                         f"frame is on it) is shorter than one {seg / m:g} {lu} segment; use a shorter --segment.")
    res = profilograph_index(trace, segment_length=seg, blanking_band=band_mm / 1000.0)
    f = u["per_mm_per_km"] * 1000.0
    cols = {f"start_{lu}": res.segment_start / m, f"end_{lu}": res.segment_end / m}
    bumps = res.bumps
    for j, t in enumerate(names):
        cols[f"pi_{t}_{u['pi_col']}"] = res.profile_index[:, j] * f
    for t in names:
        peaks = bumps.peak_m[bumps.track == t].to_numpy()
        k = np.floor((peaks - res.segment_start[0]) / seg).astype(np.int64)
        k = k[(k >= 0) & (k < res.segment_start.size)]
        cols[f"bumps_{t}"] = np.bincount(k, minlength=res.segment_start.size)
    detail = pd.DataFrame({"track": bumps.track, f"start_{lu}": bumps.start_m / m, f"end_{lu}": bumps.end_m / m,
                           f"peak_{lu}": bumps.peak_m / m, f"height_{su}": bumps.height_m / mm})
    mean = res.profile_index.mean(axis=0) * f
    h, length = BUMP_TEMPLATE
    meta = _meta("profile-index", "California Test 526 / ASTM E2955 profilograph (constants: docs/road-acceptance.md)",
                 u, names, segment=seg / m, blanking_band=band_mm * 1e-3 / mm, pi_unit=u["pi"],
                 n_segments=int(res.segment_start.size), n_bumps=int(len(bumps)),
                 **{f"mean_pi_{t}": float(v) for t, v in zip(names, mean)})
    per = ", ".join(f"{t} {int((bumps.track == t).sum())}" for t in names)
    summary = [f"Profile Index (CT 526, {band_mm * 1e-3 / mm:g} {su} blanking band): mean of {res.segment_start.size} "
               f"segment(s) of {seg / m:g} {lu}: " + ", ".join(f"{t} {v:.4g} {u['pi']}" for t, v in zip(names, mean)),
               f"bumps over the {h / mm:.3g} {su} in {length / m:.3g} {lu} template: {len(bumps)}"
               + (f" ({per})" if len(names) > 1 else "")]
    return IndexReport("profile-index", pd.DataFrame(cols), detail, tuple(summary), (), u["key"], meta)


def faulting_report(profile: Profile, *, min_fault: float | None = None, min_joint_spacing: float | None = None,
                    window: float = 0.3, gap: float = 0.05, units: str = "si", tracks=None) -> IndexReport:
    """Joint faulting (AASHTO R 36 practice) at joints found in the profile, SI or US units.

    Parameters
    ----------
    profile : Profile
        Constant step, m, stations increasing in the direction of traffic; no NaN, no station step over 1 m.
    min_fault : float, optional
        Smallest |fault| of a joint found, mm or in (default 1 mm; 0.04 in in US units).
    min_joint_spacing : float, optional
        Smallest distance between two joints, report length unit (default 3 m; 10 ft in US units).
    window, gap : float
        m in both unit systems, as :func:`~longprofile.road.indices.joint_faulting` (0.3 m, 0.05 m).
    units : {"si", "us"}
    tracks : str or sequence of str, optional

    Returns
    -------
    IndexReport
        ``table``: one row per joint and track, ``joint, track, fault`` (approach minus leave: positive when the
        slab after the joint is lower), ``residual_rms``, ``n_samples``, ``spacing`` (from the track's previous
        joint).

    Notes
    -----
    Each track's joints are found by :func:`~longprofile.road.indices.find_joints` (the joint spacing is not
    given: it comes out of the joints found, its median printed) and measured by
    :func:`~longprofile.road.indices.joint_faulting`. A step of h gives a fault of h (tested).
    """
    from ._faulting import find_joints, joint_faulting

    u = _unit_system(units)
    names = _tracks(profile, tracks)
    _continuous(profile, names, "faulting")
    fault_mm = _option("min_fault", min_fault, u)
    spacing_m = _option("min_joint_spacing", min_joint_spacing, u)
    lu, su, m, mm = u["length"], u["small"], u["m"], u["mm"] / 1000.0
    frames, lines = [], []
    for t in names:
        joints = find_joints(profile, t, min_fault=fault_mm / 1000.0, min_spacing=spacing_m, window=window, gap=gap)
        if joints.size:
            fr = joint_faulting(profile, joints, window=window, gap=gap, tracks=t).joints
            fr = fr.assign(spacing=np.r_[np.nan, np.diff(fr.joint_m.to_numpy())])
            frames.append(fr)
            lines.append(f"{t} {joints.size} joint(s), median spacing {np.median(np.diff(joints)) / m:.4g} {lu}"
                         if joints.size > 1 else f"{t} 1 joint")
            f_ = fr.fault_m.to_numpy() / mm
            k = int(np.argmax(np.abs(f_)))
            d = 2 if su == "mm" else 3  # 0.01 mm, 0.001 in
            lines[-1] += (f", mean fault {round(f_.mean(), d) + 0.0:.{d}f} {su}, mean |fault| {np.abs(f_).mean():.{d}f} {su}, "
                          f"largest {f_[k]:.{d}f} {su} at {fr.joint_m.iloc[k] / m:.6g} {lu}")
        else:
            lines.append(f"{t} no joint")
    names_u = [f"joint_{lu}", "track", f"fault_{su}", f"residual_rms_{su}", "n_samples", f"spacing_{lu}"]
    if frames:
        fr = pd.concat(frames, ignore_index=True)
        table = pd.DataFrame({names_u[0]: fr.joint_m / m, "track": fr.track, names_u[2]: fr.fault_m / mm,
                              names_u[3]: fr.residual_rms_m / mm, "n_samples": fr.n_samples,
                              names_u[5]: fr.spacing / m})
    else:
        table = pd.DataFrame({c: pd.Series(dtype=object if c == "track" else float) for c in names_u})
    notes = [] if frames else [f"no joint with a fault of {fault_mm * 1e-3 / mm:g} {su} or more: an unjointed "
                               "pavement, or faults under --min-fault (only faulted joints are found)."]
    gaps = np.concatenate([np.diff(f.joint_m.to_numpy()) for f in frames]) if frames else np.empty(0)
    close = int(np.count_nonzero(gaps < CLOSE_JOINTS[0] * spacing_m))
    if gaps.size >= 4 and close > CLOSE_JOINTS[1] * gaps.size:
        notes.append(f"{close} of the {gaps.size} joint spacings found are under {CLOSE_JOINTS[0]:g} x "
                     f"--min-joint-spacing ({CLOSE_JOINTS[0] * spacing_m / m:.3g} {lu}): steps are found about as "
                     "close as allowed, as on a pavement without joints (asphalt: the steps are roughness, not "
                     "faults); check the pavement type, or set --min-joint-spacing just under the slab length.")
    meta = _meta("faulting", "AASHTO R 36 practice (faulting = approach minus leave elevation at the joint); "
                 "step-line fit, joints found by the step statistic", u, names, min_fault=fault_mm * 1e-3 / mm,
                 min_joint_spacing=spacing_m / m, window_m=float(window), gap_m=float(gap), n_joints=int(len(table)))
    summary = [f"faulting (AASHTO R 36 practice), joints with |fault| >= {fault_mm * 1e-3 / mm:g} {su} at least "
               f"{spacing_m / m:g} {lu} apart: " + "; ".join(lines)]
    return IndexReport("faulting", table, None, tuple(summary), tuple(notes), u["key"], meta)
