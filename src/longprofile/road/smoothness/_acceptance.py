"""Smoothness acceptance of a new pavement: lot IRI/MRI, localized roughness, exclusions, pay factors.

The golden car runs once per track (:func:`longprofile.road.rectified_slope`, ASTM E1926); every reported
value -- lot IRI, continuous short-interval IRI -- is an average of its rectified slope over an interval.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from ..._validation import require_positive
from ...core import Profile
from ...errors import InputError, InputFormatError, UnitsError
from ..indices._iri import REPORT_UNITS, ReportUnits, rectified_slope

__all__ = ["AcceptanceResult", "AcceptanceSpec", "default_spec", "read_spec", "smoothness_acceptance",
           "spec_from_dict"]

_FT = 0.3048


@dataclass(frozen=True)
class AcceptanceSpec(ReportUnits):
    """A smoothness specification (all lengths in the spec's length unit, IRI in its IRI unit).

    Attributes
    ----------
    units : {"si", "us"}
        ``"si"``: m and m/km; ``"us"``: ft and in/mi.
    index : {"auto", "mri", "iri"}
        Lot index: MRI (mean of the two tracks' IRI; needs two tracks) or the IRI of each track (the worst
        track decides the pay); ``"auto"`` (default): MRI for two tracks, IRI otherwise (resolved in the
        result's spec).
    lot_length : float
        Fixed lot (sublot) length (default 0.1 mi = 528 ft, or 100 m in SI -- common agency choices).
    localized_window, localized_threshold : float
        Continuous short-interval IRI window (default 25 ft = 7.62 m, ProVAL's short continuous base length)
        and its threshold (default none: no localized roughness defects).
    localized_step : float or None
        Distance between reported continuous windows (default: every sample).
    exclusions : tuple of (float, float)
        Station ranges left out of the lots and of the localized roughness (bridges, joints, ...).
    pay_schedule : tuple of (float, float)
        ``(upper IRI limit, pay factor)`` rows in increasing limit; a lot pays the factor of the first row whose
        limit is >= its index; above the last limit the lot has no pay factor (corrective work).
    histogram_bin : float or None
        Bin width of the lot-index histogram (default: 10 in/mi or 0.2 m/km).
    grind_threshold : float or None
        Localized roughness the grinding simulation must reach (default: ``localized_threshold``).
    grinder_length : float
        Grinder frame length for the grinding simulation (default 4 ft = 1.219 m; ASSUMPTION).
    grind_max_depth : float
        Largest grind depth allowed, in the elevation unit of the spec (mm in SI, in in US; default 10 mm).
    min_lot_fraction : float
        A lot with less than this share of its length outside the exclusions gets no pay factor (default 0.5).
    """

    units: str = "si"
    index: str = "auto"
    lot_length: float = 100.0
    localized_window: float = 7.62
    localized_threshold: float | None = None
    localized_step: float | None = None
    exclusions: tuple = ()
    pay_schedule: tuple = ()
    histogram_bin: float | None = None
    grind_threshold: float | None = None
    grinder_length: float = 4 * _FT
    grind_max_depth: float = 10.0
    min_lot_fraction: float = 0.5

    @property
    def depth_factor(self) -> float:
        """Metres per spec depth unit (mm in SI, in in US)."""
        return 1e-3 if self.units == "si" else 0.0254


#: TOML layout of a spec file: section -> key -> AcceptanceSpec field (top-level keys under "").
_SPEC_KEYS = {
    "": {"units": "units", "index": "index"},
    "lot": {"length": "lot_length", "index": "index", "min_fraction": "min_lot_fraction"},
    "localized": {"window": "localized_window", "threshold": "localized_threshold", "step": "localized_step"},
    "exclusions": {"zones": "exclusions", "events": None},
    "pay": {"schedule": "pay_schedule", "histogram_bin": "histogram_bin"},
    "grinding": {"threshold": "grind_threshold", "grinder_length": "grinder_length", "max_depth": "grind_max_depth"},
}


def default_spec(units: str = "si") -> AcceptanceSpec:
    """Defaults in the given units: lots of 100 m (SI) or 528 ft = 0.1 mi (US), window 25 ft."""
    units = _units(units)
    if units == "us":
        return AcceptanceSpec(units="us", lot_length=528.0, localized_window=25.0, grinder_length=4.0,
                              grind_max_depth=0.4)
    return AcceptanceSpec()


def _units(units) -> str:
    key = str(units).strip().lower()
    if key not in REPORT_UNITS:
        raise UnitsError(f"units must be 'si' (m, m/km) or 'us' (ft, in/mi); got {units!r}.")
    return key


def spec_from_dict(data: dict, *, base_dir: Path | None = None, source: str = "spec") -> AcceptanceSpec:
    """Build a spec from a TOML-like dict; every unknown key is an error naming it.

    Layout::

        units = "us"                      # si | us
        [lot]       length = 528, index = "mri", min_fraction = 0.5
        [localized] window = 25, threshold = 160, step = 1
        [exclusions] zones = [[1000, 1150]], events = "events.csv"   # CSV columns start, end
        [pay]       schedule = [[45, 1.05], [60, 1.0], [75, 0.95], [90, 0.9]], histogram_bin = 10
        [grinding]  threshold = 160, grinder_length = 4, max_depth = 0.4
    """
    if not isinstance(data, dict):
        raise InputError(f"{source}: expected a table of settings.")
    for key, value in data.items():
        if key not in _SPEC_KEYS[""] and key not in _SPEC_KEYS:
            known = sorted(set(_SPEC_KEYS[""]) | (set(_SPEC_KEYS) - {""}))
            raise InputError(f"{source}: unknown key {key!r}; known: {known}.")
        if key in _SPEC_KEYS and key != "" and not isinstance(value, dict):
            raise InputError(f"{source}: {key!r} must be a table ([{key}]).")
    units = _units(data.get("units", "si"))
    spec = default_spec(units)
    values: dict = {}
    for section, keys in _SPEC_KEYS.items():
        if section == "":
            continue
        for key, value in data.get(section, {}).items():
            if key not in keys:
                raise InputError(f"{source}: unknown key {section}.{key!r}; known in [{section}]: {sorted(keys)}.")
            if keys[key] is not None:
                values[keys[key]] = value
    if "index" in data:
        values.setdefault("index", data["index"])
    zones = [tuple(map(float, z)) for z in values.pop("exclusions", [])]
    events = data.get("exclusions", {}).get("events")
    if events is not None:
        path = Path(events)
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        zones += read_exclusion_events(path, units=units)
    values["exclusions"] = tuple(zones)
    if "pay_schedule" in values:
        values["pay_schedule"] = tuple(tuple(map(float, r)) for r in values["pay_schedule"])
    spec = replace(spec, **values)
    return validate_spec(spec)


def read_exclusion_events(path, *, units: str = "si") -> list[tuple[float, float]]:
    """Exclusion zones from a CSV event file with columns ``start`` and ``end`` (the spec's length unit), or
    ``start_m, end_m`` / ``start_ft, end_ft`` (converted)."""
    path = Path(path)
    try:
        frame = pd.read_csv(path, comment="#")
    except (OSError, pd.errors.ParserError) as exc:
        raise InputFormatError(f"exclusion events {path}: cannot read ({exc}).") from None
    cols = {c.strip().lower(): c for c in frame.columns}
    factor = 1.0
    scale = REPORT_UNITS[units]["metres_per_unit"]
    for s, e, f in (("start", "end", 1.0), ("start_m", "end_m", 1.0 / scale), ("start_ft", "end_ft", _FT / scale)):
        if s in cols and e in cols:
            factor = f
            break
    else:
        raise InputFormatError(f"exclusion events {path}: need columns start,end (or start_m,end_m / "
                               f"start_ft,end_ft); got {list(frame.columns)}.")
    a = pd.to_numeric(frame[cols[s]], errors="coerce").to_numpy() * factor
    b = pd.to_numeric(frame[cols[e]], errors="coerce").to_numpy() * factor
    if np.isnan(a).any() or np.isnan(b).any():
        raise InputFormatError(f"exclusion events {path}: non-numeric start/end on row "
                               f"{int(np.flatnonzero(np.isnan(a) | np.isnan(b))[0]) + 2}.")
    return list(zip(a.tolist(), b.tolist()))


def validate_spec(spec: AcceptanceSpec) -> AcceptanceSpec:
    """Check values (positive lengths, ordered schedule, ordered zones); return the spec."""
    if spec.index not in ("auto", "mri", "iri"):
        raise InputError(f"lot index must be 'auto', 'mri' or 'iri'; got {spec.index!r}.")
    for name in ("lot_length", "localized_window", "grinder_length", "grind_max_depth"):
        require_positive(f"{name} ({spec.length_unit})", getattr(spec, name))
    for name in ("localized_threshold", "localized_step", "histogram_bin", "grind_threshold"):
        if getattr(spec, name) is not None:
            require_positive(name, getattr(spec, name))
    if not 0.0 <= spec.min_lot_fraction <= 1.0:
        raise InputError(f"lot min_fraction must be within 0..1; got {spec.min_lot_fraction}.")
    for a, b in spec.exclusions:
        if not (np.isfinite(a) and np.isfinite(b) and b > a):
            raise InputError(f"exclusion zone [{a}, {b}] must have end > start.")
    limits = [r[0] for r in spec.pay_schedule]
    if any(len(r) != 2 for r in spec.pay_schedule):
        raise InputError("pay schedule rows must be [upper IRI limit, pay factor].")
    if limits != sorted(limits) or len(set(limits)) != len(limits):
        raise InputError(f"pay schedule limits must increase strictly; got {limits}.")
    _check_iri_values(spec)
    for limit, factor in spec.pay_schedule:
        if not 0.0 <= factor <= PAY_FACTOR_MAX:
            raise InputError(f"pay factor {factor:g} (limit {limit:g}) is outside 0-{PAY_FACTOR_MAX:g}: a factor "
                             "multiplies the lot's price (1.05 for a 5 % bonus); is it a percentage?")
    return spec


#: Plausible range of an IRI/MRI threshold or pay limit, m/km: from below the smoothest new pavement (~0.5 m/km)
#: to twice a rough unpaved road (~20 m/km). Outside it the value is in the other unit system (160 in/mi typed in
#: an SI spec is 160 m/km) or a typo; ASSUMPTION: no specification sets a limit outside it.
IRI_LIMIT_RANGE = (0.2, 40.0)
#: Largest pay factor accepted (a bonus of 100 %); 105 (a percentage) is refused.
PAY_FACTOR_MAX = 2.0


def _check_iri_values(spec: AcceptanceSpec) -> None:
    """Refuse IRI thresholds and pay limits outside :data:`IRI_LIMIT_RANGE` once converted to m/km."""
    per = REPORT_UNITS[spec.units]["iri_per_m_per_km"]
    values = [("localized threshold", spec.localized_threshold), ("grinding threshold", spec.grind_threshold)]
    values += [("pay schedule limit", limit) for limit, _ in spec.pay_schedule]
    lo, hi = IRI_LIMIT_RANGE
    for what, value in values:
        if value is not None and not lo <= value / per <= hi:
            other = "us" if spec.units == "si" else "si"
            shown = f"{value:g} {spec.iri_unit}" + ("" if per == 1.0 else f" = {value / per:.4g} m/km")
            raise UnitsError(f"{what} {shown} is outside any paved "
                             f"road's range ({lo:g}-{hi:g} m/km); is it in {REPORT_UNITS[other]['iri_unit']}? "
                             f"set units = \"{other}\" in the spec, or fix the value.")


def read_spec(path) -> AcceptanceSpec:
    """Read a TOML spec file (see :func:`spec_from_dict` for its layout)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"spec {path}: cannot read ({exc.strerror or exc}).") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputFormatError(f"spec {path}: not valid TOML ({exc}).") from None
    return spec_from_dict(data, base_dir=path.parent, source=f"spec {path}")


@dataclass(frozen=True, eq=False)
class AcceptanceResult:
    """Smoothness acceptance of a profile against a spec (all in the spec's units).

    Attributes
    ----------
    lots : pandas.DataFrame
        ``start, end, included_length, iri_<track>..., mri, index, pay_factor`` per lot.
    localized : pandas.DataFrame
        ``station, iri_<track>..., mri`` continuous short-interval IRI at window centres (NaN where the window
        touches an exclusion).
    defects : pandas.DataFrame
        ``start, end, length, peak_station, peak`` runs of the localized index above the threshold.
    histogram : pandas.DataFrame
        ``low, high, lots, length`` of the lot index.
    pay_summary : dict
        Length-weighted mean pay factor, lots without pay, totals.
    spec : AcceptanceSpec
    tracks : tuple of str
    metadata : dict
    """

    lots: pd.DataFrame
    localized: pd.DataFrame
    defects: pd.DataFrame
    histogram: pd.DataFrame
    pay_summary: dict
    spec: AcceptanceSpec
    tracks: tuple[str, ...]
    metadata: dict = field(default_factory=dict)


def _cumulative(rs):
    """Stations and cumulative length-weighted rectified slope (rectified slope is in m/km) per track."""
    c = np.concatenate([np.zeros((1, rs.rectified.shape[1])), np.cumsum(rs.step[:, None] * rs.rectified, axis=0)])
    return rs.station, c


def _interval_sum(st, cum, a, b):
    """Integral of the rectified slope over [a, b] (arrays), by linear interpolation of the cumulative."""
    return np.column_stack([np.interp(b, st, cum[:, j]) - np.interp(a, st, cum[:, j]) for j in range(cum.shape[1])])


def _merge(zones):
    zones = sorted(zones)
    out = []
    for a, b in zones:
        if out and a <= out[-1][1]:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [(a, b) for a, b in out]


def _runs(mask):
    if not mask.any():
        return []
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1))


def resolve_index(spec: AcceptanceSpec, tracks) -> AcceptanceSpec:
    """``spec`` with ``index = "auto"`` resolved for the profile's ``tracks``: MRI for two tracks, IRI otherwise (the
    rule of the lots, the localized index and the grinding alike); an MRI asked of other than two tracks is an
    error."""
    if spec.index == "auto":
        spec = replace(spec, index="mri" if len(tracks) == 2 else "iri")
    if spec.index == "mri" and len(tracks) != 2:
        raise InputError(f"the MRI needs exactly two tracks; the profile has {list(tracks)}: set index = "
                         "\"iri\" in the spec ([lot] index) or choose two tracks.")
    return spec


def localized_index(profile: Profile, spec: AcceptanceSpec, *, tracks=None, rs=None):
    """Continuous short-interval IRI (spec units) at window centres; NaN where a window touches an exclusion.

    Returns (centres in the length unit, values (M, K) per track, index (M,) MRI or worst track, tracks).
    """
    rs = rectified_slope(profile, tracks=tracks) if rs is None else rs
    st, cum = _cumulative(rs)
    centres = _localized_centres(profile.distance, st, spec)
    vals = _localized_values(st, cum, centres, spec)
    index = vals.mean(axis=1) if (spec.index == "mri" and vals.shape[1] == 2) else vals.max(axis=1)
    return centres / spec.metres_per_unit, vals, index, rs.tracks


def _localized_centres(distance: np.ndarray, st: np.ndarray, spec: AcceptanceSpec) -> np.ndarray:
    """Window centres of the localized index, m: the stations (or the spec's step grid) whose window of
    ``localized_window`` lies within the simulated stations ``st``."""
    scale = spec.metres_per_unit
    w = spec.localized_window * scale
    lo, hi = st[0] + w / 2, st[-1] - w / 2
    if hi < lo:
        raise InputError(f"the profile ({(st[-1] - st[0]) / scale:.2f} {spec.length_unit}) is shorter than the "
                         f"localized window ({spec.localized_window:g} {spec.length_unit}).")
    if spec.localized_step is None:
        return distance[(distance >= lo) & (distance <= hi)]
    return np.arange(lo, hi + 1e-9, spec.localized_step * scale)


def _localized_values(st: np.ndarray, cum: np.ndarray, centres: np.ndarray, spec: AcceptanceSpec) -> np.ndarray:
    """(M, K) continuous IRI (spec's IRI unit) of the windows centred on ``centres`` (m), from the cumulative
    rectified slope ``cum`` at the stations ``st`` (:func:`_cumulative`); NaN where a window touches an exclusion."""
    scale = spec.metres_per_unit
    w = spec.localized_window * scale
    vals = _interval_sum(st, cum, centres - w / 2, centres + w / 2) / w * spec.iri_factor
    for a, b in spec.exclusions:
        touch = (centres + w / 2 > a * scale) & (centres - w / 2 < b * scale)
        vals[touch] = np.nan
    return vals


def _check_zones(spec: AcceptanceSpec, x0: float, x1: float):
    tol = 1e-6 * max(1.0, abs(x1))
    for a, b in spec.exclusions:
        if a < x0 - tol or b > x1 + tol:
            raise InputError(f"exclusion zone [{a:g}, {b:g}] {spec.length_unit} lies outside the profile "
                             f"({x0:g} .. {x1:g} {spec.length_unit}).")


def pay_factor(value: float, schedule) -> float:
    """Pay factor of a lot index from ``(limit, factor)`` rows (NaN above the last limit or for NaN)."""
    if not np.isfinite(value):
        return float("nan")
    for limit, factor in schedule:
        if value <= limit:
            return float(factor)
    return float("nan")


def smoothness_acceptance(profile: Profile, spec: AcceptanceSpec | None = None, *, tracks=None) -> AcceptanceResult:
    """Lot IRI/MRI, localized roughness, exclusions, histogram and pay factors of a profile against a spec.

    Parameters
    ----------
    profile : Profile
        SI profile (stations, elevations in m); one track (index IRI) or two (MRI).
    spec : AcceptanceSpec, optional
        Default :func:`default_spec` ("si").
    tracks : str or sequence of str, optional

    Returns
    -------
    AcceptanceResult

    Raises
    ------
    InputError
        Exclusion zones outside the profile; MRI asked of a profile without two tracks; a profile shorter
        than one lot or than the localized window.

    Notes
    -----
    One golden-car run per track over the whole profile (ASTM E1926, 11 m lead-in, 250 mm moving average by
    its rule); an interval's IRI is the integral of the rectified slope over it divided by its length, the
    integral interpolated linearly within the steps cut by the interval limits (not inserted as stations, to
    keep the constant-step run: lot values equal :func:`longprofile.road.iri_report` ``mode="fixed"``, which
    inserts them, to within about dx / lot length, 2e-4 for 25 mm and 0.1 mi; tested to 5e-4). A lot's IRI is the mean
    rectified slope over its length outside the exclusions (longprofile's reading of "excluded from the
    lot"); the localized roughness is the continuous IRI over ``localized_window`` centred on each
    station, as ProVAL's Smoothness Assurance continuous analysis (FHWA), blanked where the window touches an
    exclusion. Lots start at the first station and only complete lots are reported.
    """
    spec = validate_spec(spec or default_spec())
    scale, lu = spec.metres_per_unit, spec.length_unit
    x = profile.distance
    x0u, x1u = x[0] / scale, x[-1] / scale
    _check_zones(spec, x0u, x1u)
    step = float(np.median(np.diff(x))) if x.size > 1 else 0.0
    for what, value in (("lot length", spec.lot_length), ("localized window", spec.localized_window)):
        if value * scale < 10.0 * step:  # e.g. 1e-9 ft: a trillion lots (a 7 TiB array), not a statement
            raise InputError(f"the {what} {value:g} {lu} is shorter than 10 samples of the profile ({step / scale:.3g} "
                             f"{lu} apart): a unit mistake in the spec?")
    n_lots = int(np.floor((x1u - x0u) / spec.lot_length + 1e-9))
    if n_lots < 1:
        raise InputError(f"the profile ({x1u - x0u:.2f} {lu}) is shorter than one lot ({spec.lot_length:g} {lu}).")
    bounds_u = x0u + spec.lot_length * np.arange(n_lots + 1)
    zones = _merge(spec.exclusions)
    rs = rectified_slope(profile, tracks=tracks)  # no inserted limits: keeps the fast constant-step run
    spec = resolve_index(spec, rs.tracks)
    st, cum = _cumulative(rs)
    a, b = bounds_u[:-1] * scale, bounds_u[1:] * scale
    a, b = np.maximum(a, st[0]), np.minimum(b, st[-1])
    total = _interval_sum(st, cum, a, b)
    length = b - a
    for za, zb in zones:
        ca, cb = np.clip(za * scale, a, b), np.clip(zb * scale, a, b)
        total = total - _interval_sum(st, cum, ca, cb)
        length = length - (cb - ca)
    with np.errstate(invalid="ignore", divide="ignore"):
        lot_iri = np.where(length[:, None] > 1e-9, total / length[:, None], np.nan) * spec.iri_factor
    fraction = length / (b - a)
    cols = {"start": bounds_u[:-1], "end": bounds_u[1:], "included_length": length / scale}
    for j, t in enumerate(rs.tracks):
        cols[f"iri_{t}"] = lot_iri[:, j]
    if len(rs.tracks) == 2:
        cols["mri"] = lot_iri.mean(axis=1)
    index = cols["mri"] if spec.index == "mri" else lot_iri.max(axis=1)
    index = np.where(fraction >= spec.min_lot_fraction, index, np.nan)
    cols["index"] = index
    cols["pay_factor"] = np.array([pay_factor(v, spec.pay_schedule) for v in index]) if spec.pay_schedule else np.nan
    lots = pd.DataFrame(cols)
    centres, vals, loc_index, _ = localized_index(profile, spec, rs=rs)
    loc = {"station": centres}
    for j, t in enumerate(rs.tracks):
        loc[f"iri_{t}"] = vals[:, j]
    if len(rs.tracks) == 2:
        loc["mri"] = vals.mean(axis=1)
    loc["index"] = loc_index
    localized = pd.DataFrame(loc)
    defect_rows = []
    if spec.localized_threshold is not None:
        above = np.nan_to_num(loc_index, nan=-np.inf) > spec.localized_threshold
        for i, k in _runs(above):
            p = i + int(np.argmax(loc_index[i:k + 1]))
            defect_rows.append({"start": centres[i], "end": centres[k], "length": centres[k] - centres[i],
                                "peak_station": centres[p], "peak": loc_index[p]})
    defects = pd.DataFrame(defect_rows, columns=["start", "end", "length", "peak_station", "peak"])
    width = spec.histogram_bin or (10.0 if spec.units == "us" else 0.2)
    finite = index[np.isfinite(index)]
    top = max(width, float(np.ceil((finite.max() if finite.size else width) / width + 1e-9) * width))
    edges = np.arange(0.0, top + width / 2, width)
    counts, _ = np.histogram(finite, bins=edges)
    lens, _ = np.histogram(finite, bins=edges, weights=(length / scale)[np.isfinite(index)])
    histogram = pd.DataFrame({"low": edges[:-1], "high": edges[1:], "lots": counts, "length": lens})
    pf = lots["pay_factor"].to_numpy(dtype=float)
    paid = np.isfinite(pf)
    weights = length / scale
    mean_pf = float(np.sum(pf[paid] * weights[paid]) / np.sum(weights[paid])) if paid.any() else None
    summary = {"lots": int(n_lots), "lots_with_pay": int(paid.sum()),
               "lots_without_pay": int((~paid).sum()) if spec.pay_schedule else None,
               "mean_pay_factor": mean_pf,
               "excluded_length": float(sum(zb - za for za, zb in zones)),
               "localized_defects": len(defects), "localized_defect_length": float(defects["length"].sum())}
    meta = {"standard": "ASTM E1926 IRI (golden car, 80 km/h); MRI mean of two tracks; continuous IRI as ProVAL SAM",
            "units": spec.units, "length_unit": lu, "iri_unit": spec.iri_unit,
            "moving_average": bool(rs.moving_average), "moving_average_reason": rs.moving_average_reason,
            "first_station": float(x0u), "last_station": float(x1u)}
    return AcceptanceResult(lots=lots, localized=localized, defects=defects, histogram=histogram,
                            pay_summary=summary, spec=spec, tracks=rs.tracks, metadata=meta)
