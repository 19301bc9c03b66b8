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
from ..._validation import true_runs as _runs
from ...core import Profile
from ...errors import InputError, InputFormatError, UnitsError
from ..indices._dropouts import dropout_message, dropout_runs
from ..indices._gaps import run_slopes, valid_runs
from ..indices._iri import (
    PLAUSIBLE_IRI_M_PER_KM,
    REPORT_UNITS,
    ReportUnits,
    _check_steps,
    iri_plausibility,
    rectified_slope,
)

__all__ = ["AcceptanceResult", "AcceptanceSpec", "acceptance_slope", "default_spec", "lot_bounds", "read_spec",
           "smoothness_acceptance", "spec_from_dict"]

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
        A lot with less than this share of its length outside the exclusions gets no pay factor (default 0.5); the
        section's remainder after the whole lots is a lot of its own when at least this share of a lot, else it is
        merged into the previous lot (:func:`lot_bounds`).
    lot_start : float or None
        A station the lot limits are aligned to (``[lot] start``; default: the first station of the profile): the
        limits are ``lot_start + k * lot_length``; the stretch before the first limit inside the profile is a lot of
        its own or merged into the next, by the rule of the last remainder (:func:`lot_bounds`).
    events : str or None
        The exclusion events file the zones were read from (``[exclusions] events``, resolved): an input of the
        acceptance, never overwritten by a report.
    notes : tuple of str
        What reading the spec noticed (an events file without a row): added to the acceptance's warnings.
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
    lot_start: float | None = None
    events: str | None = None
    notes: tuple = ()

    @property
    def depth_factor(self) -> float:
        """Metres per spec depth unit (mm in SI, in in US)."""
        return 1e-3 if self.units == "si" else 0.0254

    def with_unit_names(self, table: pd.DataFrame) -> pd.DataFrame:
        """``table`` (``lots``, ``localized``, ``defects``, ``histogram`` of an :class:`AcceptanceResult` or a
        grind list) with each column's unit in its name, as ``road acceptance`` writes them and as ``road iri``
        names its own: lengths ``_m`` / ``_ft``, IRI ``_m_per_km`` / ``_in_per_mi``, depths ``_mm`` / ``_in``
        (``start_m``, ``iri_left_m_per_km``, ``max_depth_mm``). Counts, pay factors, names and flags keep theirs."""
        iri = REPORT_UNITS[self.units]["iri_column"]
        suffix = {**dict.fromkeys(_LENGTH_COLUMNS, self.length_unit), **dict.fromkeys(_IRI_COLUMNS, iri),
                  **dict.fromkeys(_DEPTH_COLUMNS, "mm" if self.units == "si" else "in")}
        names = {c: f"{c}_{suffix.get(c, iri)}" for c in table.columns
                 if c in suffix or str(c).startswith("iri_")}
        return table.rename(columns=names)


#: Columns of the acceptance tables in the spec's length unit, its IRI unit and its depth unit
#: (:meth:`AcceptanceSpec.with_unit_names`; ``iri_<track>`` columns are IRI too).
_LENGTH_COLUMNS = ("start", "end", "length", "included_length", "peak_station", "station")
_IRI_COLUMNS = ("mri", "index", "peak", "peak_before", "peak_after", "low", "high")
_DEPTH_COLUMNS = ("max_depth", "mean_depth")


#: TOML layout of a spec file: section -> key -> AcceptanceSpec field (top-level keys under ""; the top-level
#: ``index`` is the same setting as ``[lot] index``, kept for the specs written before it moved to [lot]).
_SPEC_KEYS = {
    "": {"units": "units", "index": "index"},
    "lot": {"length": "lot_length", "index": "index", "min_fraction": "min_lot_fraction", "start": "lot_start"},
    "localized": {"window": "localized_window", "threshold": "localized_threshold", "step": "localized_step"},
    "exclusions": {"zones": "exclusions", "events": "events"},
    "pay": {"schedule": "pay_schedule", "histogram_bin": "histogram_bin"},
    "grinding": {"threshold": "grind_threshold", "grinder_length": "grinder_length", "max_depth": "grind_max_depth"},
}

#: The TOML type each spec key takes, with an example of the expected form (a typed spec: a value of another type
#: is refused in one line naming the key, what was given and this form).
_SPEC_TYPES = {
    ("", "units"): ("text", '"si"'), ("", "index"): ("text", '"mri"'),
    ("lot", "length"): ("number", "100"), ("lot", "index"): ("text", '"mri"'),
    ("lot", "min_fraction"): ("number", "0.5"), ("lot", "start"): ("number", "1200"),
    ("localized", "window"): ("number", "7.62"), ("localized", "threshold"): ("number", "2.5"),
    ("localized", "step"): ("number", "0.25"),
    ("exclusions", "zones"): ("pairs", "[[1000, 1150]]"), ("exclusions", "events"): ("path", '"events.csv"'),
    ("pay", "schedule"): ("pairs", "[[0.95, 1.05], [1.2, 1.0], [1.9, 0.9]]"), ("pay", "histogram_bin"): ("number", "0.2"),
    ("grinding", "threshold"): ("number", "2.5"), ("grinding", "grinder_length"): ("number", "1.22"),
    ("grinding", "max_depth"): ("number", "10"),
}
#: The spec key of each AcceptanceSpec field, as a message names it (``[lot] length``).
_FIELD_KEYS = {f: (k if sec == "" else f"[{sec}] {k}") for sec, keys in reversed(list(_SPEC_KEYS.items()))
               for k, f in keys.items() if f is not None}
_TYPE_FORMS = {"number": "a number", "text": "a quoted text", "path": "a quoted file name",
               "pairs": "a list of [a, b] pairs of numbers"}


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and bool(np.isfinite(float(value)))


def _is_pairs(value) -> bool:
    return isinstance(value, list) and all(isinstance(r, list) and len(r) == 2 and all(map(_is_number, r))
                                           for r in value)


def _toml_text(value, limit: int = 60) -> str:
    """``value`` as it reads in a TOML file (``true``, ``"2.5"``, ``[1.0, 1.05]``), cut to ``limit`` characters."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, str):
        text = '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    elif isinstance(value, list):
        text = "[" + ", ".join(_toml_text(v, limit) for v in value) + "]"
    elif isinstance(value, dict):
        text = "{" + ", ".join(f"{k} = {_toml_text(v, limit)}" for k, v in value.items()) + "}"
    else:
        text = str(value)
    text = " ".join(text.split())  # one line whatever the value holds
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _typed(section: str, key: str, value, source: str):
    """``value`` of a spec key checked against :data:`_SPEC_TYPES` (numbers as float, pairs as tuples of floats)."""
    kind, example = _SPEC_TYPES[(section, key)]
    ok = {"number": _is_number, "text": lambda v: isinstance(v, str),
          "path": lambda v: isinstance(v, str) and bool(v.strip()), "pairs": _is_pairs}[kind](value)
    if not ok:
        where = key if section == "" else f"[{section}] {key}"
        raise InputError(f"{source}: {where} = {_toml_text(value)} is not {_TYPE_FORMS[kind]}; expected e.g. "
                         f"{key} = {example}.")
    if kind == "number":
        return float(value)
    if kind == "pairs":
        return tuple((float(a), float(b)) for a, b in value)
    return value


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


def _spec_values(data: dict, source: str) -> dict:
    """The spec's settings by AcceptanceSpec field, each of its type (:data:`_SPEC_TYPES`); an unknown key, a
    section that is not a table or a value of another type is refused in one line naming it."""
    for key, value in data.items():
        if key not in _SPEC_KEYS[""] and key not in _SPEC_KEYS:
            known = sorted(set(_SPEC_KEYS[""]) | (set(_SPEC_KEYS) - {""}))
            raise InputError(f"{source}: unknown key {key!r}; known: {known}.")
        if key in _SPEC_KEYS and key != "" and not isinstance(value, dict):
            raise InputError(f"{source}: {key!r} must be a table ([{key}]); got {key} = {_toml_text(value)}.")
    values: dict = {}
    for section, keys in _SPEC_KEYS.items():
        table = {k: v for k, v in data.items() if k in keys} if section == "" else data.get(section, {})
        for key, value in table.items():
            if key not in keys:
                raise InputError(f"{source}: unknown key {section}.{key!r}; known in [{section}]: {sorted(keys)}.")
            field_name, typed = keys[key], _typed(section, key, value, source)
            if field_name in values and values[field_name] != typed:  # index = at the top and in [lot]
                raise InputError(f"{source}: index given twice ({values[field_name]!r} at the top, {typed!r} in "
                                 "[lot]); keep [lot] index only.")
            values[field_name] = typed
    return values


def spec_from_dict(data: dict, *, base_dir: Path | None = None, source: str = "spec") -> AcceptanceSpec:
    """Build a spec from a TOML-like dict; every unknown key, and every value of the wrong type, is an error naming
    it (:data:`_SPEC_TYPES`).

    Layout::

        units = "us"                      # si | us
        [lot]       length = 528, index = "mri", min_fraction = 0.5, start = 1200
        [localized] window = 25, threshold = 160, step = 1
        [exclusions] zones = [[1000, 1150]], events = "events.csv"   # CSV columns start, end
        [pay]       schedule = [[45, 1.05], [60, 1.0], [75, 0.95], [90, 0.9]], histogram_bin = 10
        [grinding]  threshold = 160, grinder_length = 4, max_depth = 0.4
    """
    if not isinstance(data, dict):
        raise InputError(f"{source}: expected a table of settings.")
    values = _spec_values(data, source)
    try:
        units = _units(values.pop("units", "si"))
    except UnitsError as exc:
        raise UnitsError(f"{source}: {exc}") from None
    zones = list(values.pop("exclusions", ()))
    notes = []
    if "events" in values:
        path = Path(values["events"])
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        events, note = _exclusion_events(path, units=units)
        zones += events
        notes += [note] if note else []
        values["events"] = str(path)
    values["exclusions"] = tuple(zones)
    spec = replace(default_spec(units), **values, notes=tuple(notes))
    return validate_spec(spec, source=source)


def read_exclusion_events(path, *, units: str = "si") -> list[tuple[float, float]]:
    """Exclusion zones from a CSV event file with columns ``start`` and ``end`` (the spec's length unit), or
    ``start_m, end_m`` / ``start_ft, end_ft`` (converted); one pair of columns only (two are ambiguous)."""
    return _exclusion_events(path, units=units)[0]


def _exclusion_events(path, *, units: str) -> tuple[list[tuple[float, float]], str | None]:
    """:func:`read_exclusion_events` and a warning for an events file without a row (None otherwise); every refusal
    names the file (and the row: 1 is the header line)."""
    path = Path(path)
    try:
        frame = pd.read_csv(path, comment="#", skip_blank_lines=True)
    except pd.errors.EmptyDataError:
        return [], f"exclusion events {path}: the file is empty: no zone is excluded from it"
    except (OSError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise InputFormatError(f"exclusion events {path}: cannot read ({' '.join(str(exc).split())}).") from None
    cols = {str(c).strip().lower(): c for c in frame.columns}
    scale = REPORT_UNITS[units]["metres_per_unit"]
    pairs = [(s, e, f) for s, e, f in (("start", "end", 1.0), ("start_m", "end_m", 1.0 / scale),
                                       ("start_ft", "end_ft", _FT / scale)) if s in cols and e in cols]
    if not pairs:
        semi = " (a ';'-separated file? write it with commas)" if any(";" in str(c) for c in frame.columns) else ""
        raise InputFormatError(f"exclusion events {path}: need columns start,end (or start_m,end_m / "
                               f"start_ft,end_ft); got {list(frame.columns)}{semi}.")
    if len(pairs) > 1:
        raise InputFormatError(f"exclusion events {path}: columns {', '.join(f'{s},{e}' for s, e, _ in pairs)} "
                               "are ambiguous: keep one pair (the unit in the names: start_m,end_m or "
                               "start_ft,end_ft).")
    s, e, factor = pairs[0]
    if frame.empty:
        return [], f"exclusion events {path}: no row under the header: no zone is excluded from it"
    a = pd.to_numeric(frame[cols[s]], errors="coerce").to_numpy(dtype=float) * factor
    b = pd.to_numeric(frame[cols[e]], errors="coerce").to_numpy(dtype=float) * factor
    bad = ~(np.isfinite(a) & np.isfinite(b))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputFormatError(f"exclusion events {path}, row {i + 2}: {s}, {e} = {frame[cols[s]].iloc[i]!r}, "
                               f"{frame[cols[e]].iloc[i]!r} are not both numbers.")
    back = np.flatnonzero(b <= a)
    if back.size:
        i = int(back[0])
        raise InputFormatError(f"exclusion events {path}, row {i + 2}: {e} {frame[cols[e]].iloc[i]} is not after "
                               f"{s} {frame[cols[s]].iloc[i]}: an excluded stretch needs end > start.")
    return list(zip(a.tolist(), b.tolist())), None


#: Plausible range of the spec's lengths, depths and bins once converted (m; depths in mm; IRI bins in m/km), with
#: what each is. Outside it the value is in the other unit system (``window = 25`` in an SI spec meant 25 ft,
#: ``max_depth = 5`` in a US spec is 127 mm) or a typo. ASSUMPTION (longprofile's choices, no standard gives them):
#: a localized window of 2-20 m (25 ft = 7.62 m, ProVAL's default; 0.01 mi = 16.1 m), lots of 10 m-10 km, a
#: grinder frame of 0.5-10 m, a grind depth limit of 1-50 mm, a histogram bin of 0.01-5 m/km.
SPEC_VALUE_RANGES = {
    "lot_length": ("[lot] length", "lot length", (10.0, 10000.0), "length"),
    "localized_window": ("[localized] window", "localized roughness window", (2.0, 20.0), "length"),
    "grinder_length": ("[grinding] grinder_length", "grinder frame", (0.5, 10.0), "length"),
    "grind_max_depth": ("[grinding] max_depth", "grind depth limit", (1.0, 50.0), "depth"),
    "histogram_bin": ("[pay] histogram_bin", "histogram bin", (0.01, 5.0), "iri"),
}


#: Largest station magnitude ``[lot] start`` takes, spec unit (10 000 km in metres): beyond it a value is no station.
MAX_STATION = 1e7


def _unit_facts(kind: str, units: str) -> tuple[str, float]:
    """(unit name, base units per spec unit) of a length (m), depth (mm) or IRI (m/km) in ``units``."""
    if kind == "length":
        return REPORT_UNITS[units]["length_unit"], REPORT_UNITS[units]["metres_per_unit"]
    if kind == "depth":
        return ("mm", 1.0) if units == "si" else ("in", 25.4)
    return REPORT_UNITS[units]["iri_unit"], 1.0 / REPORT_UNITS[units]["iri_per_m_per_km"]


def _check_ranges(spec: AcceptanceSpec, source: str) -> None:
    """Refuse a length, depth or bin outside :data:`SPEC_VALUE_RANGES`, saying the spec's unit and what the value
    would be in the other unit system."""
    other = "us" if spec.units == "si" else "si"
    for name, (where, what, (lo, hi), kind) in SPEC_VALUE_RANGES.items():
        value = getattr(spec, name)
        if value is None:
            continue
        unit, factor = _unit_facts(kind, spec.units)
        base = {"length": "m", "depth": "mm", "iri": "m/km"}[kind]
        if lo <= value * factor <= hi:
            continue
        other_unit, other_factor = _unit_facts(kind, other)
        shown = f"{value:g} {unit}" + ("" if factor == 1.0 else f" = {value * factor:.4g} {base}")
        meant = (f"if you meant {value:g} {other_unit}, write {value * other_factor / factor:.4g}; else fix the value"
                 if lo <= value * other_factor <= hi else "fix the value")
        raise UnitsError(f"{source}: {where} = {value:g}: {shown} is outside the plausible {lo:g}-{hi:g} {base} of a "
                         f"{what}; the spec is in {spec.units.upper()} units ({unit}): {meant}.")


def _numeric_fields(spec: AcceptanceSpec, source: str) -> None:
    """Refuse a bool, a text or another non-number where a spec field needs a number (a spec built in Python)."""
    for name in ("lot_length", "localized_window", "grinder_length", "grind_max_depth", "min_lot_fraction",
                 "localized_threshold", "localized_step", "histogram_bin", "grind_threshold", "lot_start"):
        value = getattr(spec, name)
        if value is not None and not _is_number(value):
            raise InputError(f"{source}: {_FIELD_KEYS[name]} = {_toml_text(value)} is not a number.")
    for name in ("exclusions", "pay_schedule"):
        rows = [list(r) if isinstance(r, (tuple, list)) else r for r in getattr(spec, name)]
        if not _is_pairs(rows):
            raise InputError(f"{source}: {_FIELD_KEYS[name]} = {_toml_text(rows)} is not {_TYPE_FORMS['pairs']}.")


def validate_spec(spec: AcceptanceSpec, source: str = "spec") -> AcceptanceSpec:
    """Check values (numbers where numbers are needed, positive and plausible lengths, ordered schedule whose factor
    does not grow with roughness, ordered zones); return the spec."""
    if spec.index not in ("auto", "mri", "iri"):
        raise InputError(f"{source}: [lot] index must be 'auto', 'mri' or 'iri'; got {spec.index!r}.")
    _numeric_fields(spec, source)
    for name in ("lot_length", "localized_window", "grinder_length", "grind_max_depth", "localized_threshold",
                 "localized_step", "histogram_bin", "grind_threshold"):
        if getattr(spec, name) is not None:
            require_positive(f"{source}: {_FIELD_KEYS[name]}", getattr(spec, name))
    if not 0.0 <= spec.min_lot_fraction <= 1.0:
        raise InputError(f"{source}: [lot] min_fraction must be within 0..1; got {spec.min_lot_fraction}.")
    _check_ranges(spec, source)
    if spec.lot_start is not None and abs(spec.lot_start) > MAX_STATION:
        raise InputError(f"{source}: [lot] start = {spec.lot_start:g} {spec.length_unit} is not a station (beyond "
                         f"+-{MAX_STATION:g} {spec.length_unit}); give the station the lots are aligned to, e.g. 0.")
    if spec.localized_step is not None and spec.localized_step > spec.localized_window:
        raise InputError(f"{source}: [localized] step = {spec.localized_step:g} {spec.length_unit} is longer than "
                         f"the window ({spec.localized_window:g} {spec.length_unit}): the windows would leave "
                         "stretches unassessed; use step <= window.")
    for a, b in spec.exclusions:
        if not b > a:
            raise InputError(f"{source}: [exclusions] zones: zone [{a:g}, {b:g}] must have end > start.")
    _check_schedule(spec, source)
    _check_iri_values(spec)
    return spec


def _check_schedule(spec: AcceptanceSpec, source: str) -> None:
    """Rows ``[limit, factor]`` with strictly increasing limits, factors within 0-:data:`PAY_FACTOR_MAX` that do not
    grow with the limit (a rougher lot is never paid more)."""
    limits = [r[0] for r in spec.pay_schedule]
    if limits != sorted(limits) or len(set(limits)) != len(limits):
        raise InputError(f"{source}: [pay] schedule limits must increase strictly; got {limits}.")
    for limit, factor in spec.pay_schedule:
        if not 0.0 <= factor <= PAY_FACTOR_MAX:
            raise InputError(f"{source}: [pay] schedule: pay factor {factor:g} (limit {limit:g}) is outside "
                             f"0-{PAY_FACTOR_MAX:g}: a factor "
                             "multiplies the lot's price (1.05 for a 5 % bonus); is it a percentage?")
    rows = spec.pay_schedule
    for (l0, f0), (l1, f1) in zip(rows, rows[1:]):
        if f1 > f0:
            raise InputError(f"{source}: [pay] schedule pays more for a rougher lot ({f0:g} up to {l0:g}, {f1:g} up "
                             f"to {l1:g} {spec.iri_unit}): the factors must not increase with the limit; are the "
                             "columns swapped ([limit, factor]) or the rows out of order?")


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
        ``start, end, length, peak_station, peak, open_end`` runs of the localized index above the threshold;
        ``open_end`` True for a run that reaches an unassessed stretch (the profile's ends, where no whole window is
        centred, or a window blanked by an exclusion): its length and peak are those of its assessed part, and
        ``warnings`` says so (session 41).
    histogram : pandas.DataFrame
        ``low, high, lots, length`` of the lot index.
    pay_summary : dict
        Length-weighted mean pay factor, lots with and without pay (corrective work, not rated), the section, the
        last lot's rule, the excluded length, the localized roughness areas (None: not assessed).
    spec : AcceptanceSpec
    tracks : tuple of str
    metadata : dict
    warnings : tuple of str
        What the acceptance was computed despite (``check_units=False``) or flags (lots outside any paved road's
        IRI range): shown by the command, the report and summary.json.
    """

    lots: pd.DataFrame
    localized: pd.DataFrame
    defects: pd.DataFrame
    histogram: pd.DataFrame
    pay_summary: dict
    spec: AcceptanceSpec
    tracks: tuple[str, ...]
    metadata: dict = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    def lots_text(self) -> str:
        """How the lots cover the section: their number and stations, the last lot's rule, the excluded length."""
        ps, lu = self.pay_summary, self.spec.length_unit
        sec, last = ps["section"], ps["last_lot"]
        text = f"{ps['lots']} lot(s) over {sec['start']:.6g}-{sec['end']:.6g} {lu}"
        span = f"the last, {last['start']:.6g}-{last['end']:.6g} {lu}"
        if last["rule"] == "own":
            text += f" ({span}, is the {last['remainder']:.6g} {lu} remainder as a lot of its own)"
        elif last["rule"] == "merged":
            text += (f" ({span}, takes the {last['remainder']:.6g} {lu} remainder, shorter than "
                     f"{self.spec.min_lot_fraction:g} lot: {last['end'] - last['start']:.6g} {lu})")
        first = ps.get("first_lot", {"rule": "none"})
        if first["rule"] != "none":
            how = "a lot of its own" if first["rule"] == "own" else "merged into the next lot"
            text += (f"; lots aligned to station {self.spec.lot_start:g} {lu} ([lot] start): the "
                     f"{first['part']:.6g} {lu} before the first limit is {how}")
        elif self.spec.lot_start is not None:
            text += f"; lots aligned to station {self.spec.lot_start:g} {lu} ([lot] start)"
        if ps["excluded_length"] > 0:
            text += (f"; {ps['excluded_length']:.6g} {lu} in {len(_merge(self.spec.exclusions))} exclusion zone(s) "
                     "not evaluated")
        return text + f"; lot index: {self.index_text()}"

    def index_text(self) -> str:
        """Which tracks make the lot index: ``MRI of left and right``, ``IRI of left``, ``worst IRI of left, right,
        centre``."""
        tracks = list(self.metadata.get("index_tracks", self.tracks))
        if self.spec.index == "mri":
            return f"MRI of {tracks[0]} and {tracks[1]}"
        if len(tracks) == 1:
            return f"IRI of {tracks[0]}"
        return f"worst IRI of {', '.join(tracks)}"

    def pay_text(self) -> str | None:
        """The pay in one sentence: mean factor of the paid lots, lots needing corrective work, lots not rated
        ("not assessed ..." without a pay schedule, or with an empty one)."""
        ps, spec = self.pay_summary, self.spec
        if not spec.pay_schedule:
            return "not assessed (no [pay] schedule in the spec)"
        parts = ["no lot earns a pay factor" if ps["mean_pay_factor"] is None else
                 f"mean pay factor {ps['mean_pay_factor']:.4f} over {ps['lots_with_pay']} paid lot(s)"]
        if ps["lots_corrective_work"]:
            parts.append(f"{ps['lots_corrective_work']} lot(s) NEED CORRECTIVE WORK ({spec.index.upper()} above the "
                         f"last pay limit {spec.pay_schedule[-1][0]:g} {spec.iri_unit}): no pay")
        if ps["lots_not_rated"]:
            why = ("wholly excluded" if spec.min_lot_fraction == 0 else
                   f"less than {spec.min_lot_fraction:g} of their length outside the exclusions")
            parts.append(f"{ps['lots_not_rated']} lot(s) not rated ({why}): no pay")
        return "; ".join(parts)

    def localized_text(self) -> str:
        """The localized roughness in one sentence (with the stretches at the ends no window covers), or that it was
        not assessed (no threshold)."""
        ps, spec = self.pay_summary, self.spec
        if ps["localized_defects"] is None:
            return "localized roughness not assessed (no threshold in the spec: [localized] threshold)"
        ends = " and ".join(f"{a:.6g}-{b:.6g}" for a, b in ps.get("localized_unassessed", []))
        ends = (f"; not assessed at the profile's ends (no whole window centred there: half a window and the "
                f"moving average's half base): {ends} {spec.length_unit}" if ends else "")
        return (f"{ps['localized_defects']} localized roughness area(s) above {spec.localized_threshold:g} "
                f"{spec.iri_unit} ({ps['localized_defect_length']:.6g} {spec.length_unit}){ends}")


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


def resolve_index(spec: AcceptanceSpec, tracks) -> AcceptanceSpec:
    """``spec`` with ``index = "auto"`` resolved for the profile's ``tracks``: MRI for two tracks, the IRI of one
    track (the rule of the lots, the localized index and the grinding alike); an MRI asked of other than two tracks,
    and ``"auto"`` on more than two tracks (which two make the MRI?), are errors. ``index = "iri"`` on several
    tracks rates on the worst of them."""
    tracks = tuple(tracks)
    if spec.index == "auto" and len(tracks) > 2:
        raise InputError(f"the profile has {len(tracks)} tracks {list(tracks)}: the lot index is the MRI of two "
                         f"tracks or the IRI of one; choose them (road acceptance --track {tracks[0]},{tracks[1]} for "
                         f"the MRI, --track {tracks[-1]} for one track's IRI), or set [lot] index = \"iri\" to rate "
                         "each lot on its worst track.")
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
    rs = acceptance_slope(profile, spec, tracks=tracks) if rs is None else rs
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


def _clip_zones(spec: AcceptanceSpec, x0: float, x1: float) -> tuple[AcceptanceSpec, list[str]]:
    """The spec with its exclusion zones clipped to the profile ``x0 .. x1`` (spec unit), and a warning per zone
    clipped naming the part left out (a bridge at the project's end often runs past it); a zone wholly outside the
    profile, or zones covering all of it, are refused."""
    tol = 1e-6 * max(1.0, abs(x1))
    lu, zones, notes = spec.length_unit, [], []
    for a, b in spec.exclusions:
        if b <= x0 + tol or a >= x1 - tol:
            raise InputError(f"exclusion zone [{a:g}, {b:g}] {lu} lies outside the profile ({x0:g} .. {x1:g} {lu}): "
                             "a station typed wrong, or a zone of another profile?")
        ca, cb = max(a, x0), min(b, x1)
        cut = [f"{p:g}-{q:g}" for p, q in ((a, ca), (cb, b)) if q - p > tol]
        if cut:
            notes.append(f"exclusion zone [{a:g}, {b:g}] {lu} runs past the profile ({x0:g} .. {x1:g} {lu}): clipped "
                         f"to [{ca:g}, {cb:g}] (the part {' and '.join(cut)} {lu} is not in the profile)")
        zones.append((ca, cb))
    merged = _merge(zones)
    if merged and merged[0][0] <= x0 + tol and merged[0][1] >= x1 - tol:
        raise InputError(f"the exclusion zone(s) cover the whole profile ({x0:g} .. {x1:g} {lu}): nothing is left to "
                         "assess; exclude only the stretches that are not to be paid.")
    return replace(spec, exclusions=tuple(zones)), notes


def pay_factor(value: float, schedule) -> float:
    """Pay factor of a lot index from ``(limit, factor)`` rows (NaN above the last limit or for NaN)."""
    if not np.isfinite(value):
        return float("nan")
    for limit, factor in schedule:
        if value <= limit:
            return float(factor)
    return float("nan")


def lot_bounds(x0: float, x1: float, spec: AcceptanceSpec) -> tuple[np.ndarray, dict]:
    """Lot limits from the first station ``x0`` to the last ``x1`` (spec unit) and the rule of the end lots.

    Whole lots of ``lot_length`` from ``x0``, or on the grid ``lot_start + k * lot_length`` when the spec gives
    ``[lot] start`` (lots on the project's stationing: a profile from 1234.5 m with start 1200 has the limits 1300,
    1400, ...); a part shorter than a lot at an end (the remainder after the last limit, the stretch before the first
    one) is a (shorter) lot of its own when it is at least ``min_lot_fraction`` of a lot, else it is merged into its
    neighbour (ASSUMPTION, the common agency rule; 0.5 by default: a remainder of at least half a lot is its own
    lot). So the lots cover the whole section. Returns ``(bounds, {"rule": "none" | "own" | "merged", "remainder":
    length, "first_rule": ..., "first_part": length})`` (``first_rule`` "none" without a part before the first
    limit); a section shorter than ``min_lot_fraction`` of a lot is refused (:class:`InputError`).
    """
    lot, lu = spec.lot_length, spec.length_unit
    tiny = 1e-6 * lot  # float noise of the stations, not a remainder
    origin = x0 if spec.lot_start is None else float(spec.lot_start)
    k0 = np.ceil((x0 + tiny - origin) / lot)
    n = int(np.floor((x1 - tiny - origin) / lot) - k0) + 1
    if n > 10 * (x1 - x0) / lot + 1e6:  # a spec not validated (lots are 10 m or more: SPEC_VALUE_RANGES)
        raise InputError(f"[lot] length {lot:g} {lu} makes over a million lots: a unit mistake?")
    grid = origin + lot * (k0 + np.arange(max(n, 0)))
    bounds = np.concatenate([[x0], grid[(grid > x0 + tiny) & (grid < x1 - tiny)], [x1]])
    short = spec.min_lot_fraction * lot - tiny
    rest = bounds[-1] - bounds[-2]
    if len(bounds) == 2 and rest < short:
        raise InputError(f"the profile ({x1 - x0:.2f} {lu}) is shorter than the shortest lot the spec makes "
                         f"({spec.min_lot_fraction:g} of a {lot:g} {lu} lot, [lot] min_fraction): set a shorter "
                         "[lot] length or a smaller min_fraction.")
    info = {"rule": "none" if rest >= lot - 2 * tiny else ("own" if rest >= short else "merged"),
            "remainder": 0.0 if rest >= lot - 2 * tiny else float(rest)}
    if info["rule"] == "merged":
        bounds = np.delete(bounds, -2)
    head = bounds[1] - bounds[0]
    info["first_rule"], info["first_part"] = "none", 0.0
    if spec.lot_start is not None and head < lot - 2 * tiny:
        info["first_part"] = float(head)
        info["first_rule"] = "own" if head >= short or len(bounds) == 2 else "merged"
        if info["first_rule"] == "merged":
            bounds = np.delete(bounds, 1)
    return bounds, info


def acceptance_slope(profile: Profile, spec: AcceptanceSpec, *, tracks=None):
    """:func:`~longprofile.road.rectified_slope` of the profile for the acceptance; missing (NaN) elevations are
    accepted inside the spec's exclusion zones only.

    With such gaps the golden car runs once per part between them (``valid_runs`` and ``run_slopes`` of
    :mod:`longprofile.road.indices._gaps`, as ``road iri --gaps restart``: each part restarted with the standard
    11 m initialisation, ASTM E1926) and the parts are joined with a zero rectified slope across each gap: the gap
    lies in an excluded zone, whose integral the lots subtract and whose windows are blank. A part wholly inside a
    zone is skipped. A gap outside the zones is refused (:class:`InputError`), naming it and the zone that would
    cover it.
    """
    names = profile.tracks if tracks is None else ((tracks,) if isinstance(tracks, str) else tuple(tracks))
    z = np.column_stack([profile.track(t) for t in names])
    missing = np.isnan(z).any(axis=1)
    if not missing.any():
        return rectified_slope(profile, tracks=names)
    scale, x = spec.metres_per_unit, profile.distance
    zones = [(a * scale, b * scale) for a, b in _merge(spec.exclusions)]
    for i, k in _runs(missing):
        if not any(a <= x[i] and x[k] <= b for a, b in zones):
            _refuse_gap(x, z, names, i, k, spec)
    parts = [(i, k) for i, k in valid_runs(x, missing) if not any(a <= x[i] and x[k] <= b for a, b in zones)]
    for i, k in parts:
        _check_steps(x[i:k + 1])  # a station step over 1 m inside a part is refused, as without gaps
    if not parts:  # every measured stretch lies in a zone (the zones cover all but missing samples)
        raise InputError(f"no measured stretch of the profile lies outside the exclusion zones "
                         f"({x[0] / scale:g} .. {x[-1] / scale:g} {spec.length_unit}): nothing is left to assess.")
    runs, short = run_slopes(x, z, names, parts, lead_in=11.0, moving_average=None, base_length=0.25)
    if short:  # the golden car's lead-in: a shorter part cannot be initialised
        i, k = short[0]
        raise InputError(f"the profile between the missing elevations, {x[i] / scale:.3f} to {x[k] / scale:.3f} "
                         f"{spec.length_unit}, is shorter than the IRI's 11 m lead-in: extend the exclusion zone "
                         "over it.")
    return _join_runs([rs for _i, _k, rs, _mask, _tol in runs])


def _refuse_gap(x, z, names, i, k, spec) -> None:
    """Refuse the missing samples ``i .. k`` outside the exclusion zones: the gap, and the zone that covers it."""
    scale, lu = spec.metres_per_unit, spec.length_unit
    track = names[int(np.flatnonzero(np.isnan(z[i]))[0])]
    empty = [t for j, t in enumerate(names) if np.isnan(z[:, j]).all()]
    if empty:
        rest = [t for t in names if t not in empty]
        use = (f"leave it out: road acceptance --track {','.join(rest)} (tracks={rest!r} in Python; the lot index is "
               f"then {'the IRI of ' + rest[0] if len(rest) == 1 else 'of ' + ', '.join(rest)})" if rest else
               "the file has no elevation: check the columns and the file")
        raise InputError(f"track(s) {empty} have no elevation at all (every sample missing, NaN): {use}.")
    lo, hi = x[max(i - 1, 0)] / scale, x[min(k + 1, x.size - 1)] / scale
    raise InputError(f"track {track!r} has missing (NaN) elevations from station {x[i] / scale:.3f} to "
                     f"{x[k] / scale:.3f} {lu} ({k - i + 1} sample(s)) outside the exclusion zones; the IRI needs a "
                     f"continuous profile: add an exclusion zone covering the gap to the spec (e.g. [exclusions] "
                     f"zones = [[{np.floor(lo):g}, {np.ceil(hi):g}]]), or fill it explicitly.")


def _join_runs(runs):
    """One RectifiedSlope of the golden-car runs of consecutive profile parts, a zero rectified slope across the
    step between two parts."""
    first = runs[0]
    station = np.concatenate([r.station for r in runs])
    zero = np.zeros((1, first.rectified.shape[1]))
    rectified = np.concatenate([a for r in runs for a in (zero, r.rectified)][1:])
    return replace(first, station=station, step=np.diff(station), rectified=rectified,
                   moving_average=any(r.moving_average for r in runs))


def _selected_profile(profile: Profile, tracks) -> Profile:
    """The profile with the acceptance's tracks only (as read: NaN kept)."""
    if tuple(tracks) == tuple(profile.tracks):
        return profile
    z = np.column_stack([profile.track(t) for t in tracks])
    return Profile(distance=profile.distance, elevation=z, tracks=tuple(tracks), name=profile.name)


def _check_dropouts(profile: Profile, spec: AcceptanceSpec, tracks, check_units: bool) -> list[str]:
    """Refuse (``check_units``) or return as a warning the runs of one exact elevation over
    :data:`~longprofile.road.MIN_DROPOUT_RUN_M` outside the exclusion zones (a dropout written as a value)."""
    scale = spec.metres_per_unit
    runs = dropout_runs(_selected_profile(profile, tracks), exclusions=[(a * scale, b * scale) for a, b in
                                                                          _merge(spec.exclusions)])
    text = dropout_message(runs, length_unit=spec.length_unit, metres_per_unit=scale)
    if not text:
        return []
    if check_units:
        raise InputError(f"{text} (If the profile is right, e.g. a synthetic one, --no-check-units / "
                         "check_units=False computes the acceptance with this warning.)")
    return [f"{text} (computed anyway: check_units off)"]


def _lot_ranges(numbers) -> str:
    """Lot numbers (1-based, sorted) as ``1-3, 7``."""
    out, numbers = [], list(numbers)
    i = 0
    while i < len(numbers):
        j = i
        while j + 1 < len(numbers) and numbers[j + 1] == numbers[j] + 1:
            j += 1
        out.append(f"{numbers[i]}" if i == j else f"{numbers[i]}-{numbers[j]}")
        i = j + 1
    return ", ".join(out)


def _check_plausible(lots, lot_iri_m, section_m, spec, check_units: bool) -> tuple[list[str], list[int]]:
    """The plausibility rule of ``road iri`` (:func:`~longprofile.road.iri_plausibility`, 0.2-50 m/km) on the
    section IRI of each track and on each lot: a section outside it is refused with ``check_units`` (a dead sensor,
    metres under a mm label), else a warning; lots outside it are warned of. Returns (warnings, lot numbers)."""
    lo, hi = PLAUSIBLE_IRI_M_PER_KM
    bad = np.flatnonzero(np.any(np.isfinite(lot_iri_m) & ((lot_iri_m < lo) | (lot_iri_m > hi)), axis=1)) + 1
    where = ""
    if bad.size:
        lu = spec.length_unit
        where = (f"lot(s) {_lot_ranges(bad.tolist())} of {len(lots)} ({lots['start'].iloc[bad[0] - 1]:.6g}-"
                 f"{lots['end'].iloc[bad[-1] - 1]:.6g} {lu}) have an IRI outside {lo:g}-{hi:g} m/km")
    note = iri_plausibility(section_m, what="section IRI")
    lots_note = f" {where[:1].upper()}{where[1:]}." if where else ""
    if note and check_units:
        raise UnitsError(f"{note}{lots_note} No pay is computed on such a profile: check the sensor and the elevation "
                         "unit; if the profile is right, --no-check-units (check_units=False) computes the acceptance "
                         "with this warning.")
    if note:
        return [f"{note}{lots_note} Computed anyway (check_units off): do not pay on it before checking the "
                "profile."], bad.tolist()
    if where:
        return [f"{where}: {iri_plausibility(lot_iri_m, what='lot IRI')} Check the profile there before paying on "
                "these lots."], bad.tolist()
    return [], []


def _lot_table(st, cum, bounds_u, zones, spec, tracks):
    """The lots (``start, end, included_length, iri_<track>, [mri], index, pay_factor``) and their IRI per track in
    m/km (NaN where nothing is evaluated), and the section IRI per track in m/km (outside the zones)."""
    scale = spec.metres_per_unit
    a, b = bounds_u[:-1] * scale, bounds_u[1:] * scale
    ac, bc = np.maximum(a, st[0]), np.minimum(b, st[-1])  # the moving average leaves half its base at each end
    total, length, included = _interval_sum(st, cum, ac, bc), bc - ac, b - a
    for za, zb in zones:
        ca, cb = np.clip(za * scale, ac, bc), np.clip(zb * scale, ac, bc)
        total = total - _interval_sum(st, cum, ca, cb)
        length = length - (cb - ca)
        included = included - (np.clip(zb * scale, a, b) - np.clip(za * scale, a, b))
    with np.errstate(invalid="ignore", divide="ignore"):
        lot_iri_m = np.where(length[:, None] > 1e-9, total / length[:, None], np.nan)
        section_m = total.sum(axis=0) / length.sum()
    lot_iri = lot_iri_m * spec.iri_factor
    cols = {"start": bounds_u[:-1], "end": bounds_u[1:], "included_length": included / scale}
    for j, t in enumerate(tracks):
        cols[f"iri_{t}"] = lot_iri[:, j]
    if len(tracks) == 2:
        cols["mri"] = lot_iri.mean(axis=1)
    index = cols["mri"] if spec.index == "mri" else lot_iri.max(axis=1)
    cols["index"] = np.where(included / (b - a) >= spec.min_lot_fraction, index, np.nan)
    cols["pay_factor"] = (np.array([pay_factor(v, spec.pay_schedule) for v in cols["index"]]) if spec.pay_schedule
                          else np.nan)
    return pd.DataFrame(cols), lot_iri_m, section_m


def _localized_table(profile, spec, rs):
    """The localized index table (``station, iri_<track>, [mri], index``) and its defects above the threshold (none
    without a threshold)."""
    centres, vals, loc_index, _ = localized_index(profile, spec, rs=rs)
    loc = {"station": centres}
    for j, t in enumerate(rs.tracks):
        loc[f"iri_{t}"] = vals[:, j]
    if len(rs.tracks) == 2:
        loc["mri"] = vals.mean(axis=1)
    loc["index"] = loc_index
    rows = []
    if spec.localized_threshold is not None:
        above = np.nan_to_num(loc_index, nan=-np.inf) > spec.localized_threshold
        blank = ~np.isfinite(loc_index)
        for i, k in _runs(above):
            p = i + int(np.argmax(loc_index[i:k + 1]))
            # a run reaching the first or last window, or a blank window (an exclusion), may go on where no window
            # is assessed: its length and peak are those of its assessed part
            open_end = i == 0 or k == loc_index.size - 1 or bool(blank[i - 1]) or bool(blank[k + 1])
            rows.append({"start": centres[i], "end": centres[k], "length": centres[k] - centres[i],
                         "peak_station": centres[p], "peak": loc_index[p], "open_end": open_end})
    return pd.DataFrame(loc), pd.DataFrame(rows, columns=["start", "end", "length", "peak_station", "peak",
                                                          "open_end"])


def _open_end_warnings(defects, unassessed, spec) -> list[str]:
    """One line per localized roughness area that runs up to an unassessed stretch (``open_end``: the profile's ends,
    an exclusion): it may go on, and peak higher, where no window is assessed (session 41)."""
    lu, out = spec.length_unit, []
    for d in defects[defects["open_end"].astype(bool)].itertuples():
        near = [f"{a:.6g}-{b:.6g} {lu}" for a, b in unassessed if min(abs(d.start - b), abs(d.end - a)) < 1e-6]
        where = (f"the unassessed end {near[0]} (no whole window centred there)" if near else
                 "a stretch whose windows touch an exclusion zone (blank)")
        out.append(f"localized roughness area {d.start:.6g}-{d.end:.6g} {lu} (peak {d.peak:.4g} {spec.iri_unit}) "
                   f"runs up to {where}: its length ({d.length:.3g} {lu}) and peak are those of its assessed part only; the "
                   "defect may go on, and peak higher, beyond it: measure a few metres past the section's ends (or "
                   "check it on site)")
    return out


def _histogram(lots, spec) -> pd.DataFrame:
    """``low, high, lots, length`` of the rated lots' index (bin ``histogram_bin``)."""
    index = lots["index"].to_numpy(dtype=float)
    width = spec.histogram_bin or (10.0 if spec.units == "us" else 0.2)
    finite = index[np.isfinite(index)]
    top = max(width, float(np.ceil((finite.max() if finite.size else width) / width + 1e-9) * width))
    decimals = len(f"{width:.10f}".rstrip("0").split(".")[1])  # the bin's decimals: 0.6, not 0.6000000000000001
    edges = np.round(np.arange(0.0, top + width / 2, width), decimals)
    counts, _ = np.histogram(finite, bins=edges)
    lens, _ = np.histogram(finite, bins=edges, weights=lots["included_length"].to_numpy()[np.isfinite(index)])
    return pd.DataFrame({"low": edges[:-1], "high": edges[1:], "lots": counts, "length": lens})


def _unassessed_ends(localized, x0u, x1u) -> list[list[float]]:
    """The stretches at the profile's ends with no localized window centred on them (half a window, and the
    moving average's half base), spec unit."""
    centres = localized["station"].to_numpy(dtype=float)
    if not centres.size:
        return [[float(x0u), float(x1u)]]
    return [[float(a), float(b)] for a, b in ((x0u, centres[0]), (centres[-1], x1u)) if b - a > 1e-9]


def _pay_summary(lots, defects, spec, zones, last, x0u, x1u, implausible, unassessed) -> dict:
    """The pay summary: lots with pay, needing corrective work (index above the schedule), not rated (too much
    excluded); length-weighted mean pay factor; the section, its last lot and excluded length; the defects."""
    pf, index = lots["pay_factor"].to_numpy(dtype=float), lots["index"].to_numpy(dtype=float)
    paid = np.isfinite(pf)
    weights = lots["included_length"].to_numpy()
    mean_pf = float(np.sum(pf[paid] * weights[paid]) / np.sum(weights[paid])) if paid.any() else None
    scheduled = bool(spec.pay_schedule)
    assessed = spec.localized_threshold is not None
    end = lots.iloc[-1]
    return {"lots": len(lots), "lots_with_pay": int(paid.sum()),
            "lots_without_pay": int((~paid).sum()) if scheduled else None,
            "lots_corrective_work": int((~paid & np.isfinite(index)).sum()) if scheduled else None,
            "lots_not_rated": int((~np.isfinite(index)).sum()) if scheduled else None,
            "mean_pay_factor": mean_pf,
            "section": {"start": float(x0u), "end": float(x1u), "length": float(x1u - x0u)},
            "first_lot": {"rule": last.pop("first_rule"), "part": last.pop("first_part"),
                          "start": float(lots["start"].iloc[0]), "end": float(lots["end"].iloc[0])},
            "last_lot": {**last, "start": float(end["start"]), "end": float(end["end"])},
            "evaluated_length": float(weights.sum()),
            "excluded_length": float(sum(zb - za for za, zb in zones)),
            "implausible_lots": implausible,
            "localized_defects": len(defects) if assessed else None,
            "localized_unassessed": unassessed,
            "localized_defect_length": float(defects["length"].sum()) if assessed else None}


def smoothness_acceptance(profile: Profile, spec: AcceptanceSpec | None = None, *, tracks=None,
                          check_units: bool = True) -> AcceptanceResult:
    """Lot IRI/MRI, localized roughness, exclusions, histogram and pay factors of a profile against a spec.

    Parameters
    ----------
    profile : Profile
        SI profile (stations, elevations in m); one track (index IRI) or two (MRI). Missing (NaN) elevations are
        accepted inside exclusion zones only (:func:`acceptance_slope`).
    spec : AcceptanceSpec, optional
        Default :func:`default_spec` ("si").
    tracks : str or sequence of str, optional
    check_units : bool, default True
        Refuse a section whose IRI is outside any paved road's range (0.2-50 m/km,
        :func:`~longprofile.road.iri_plausibility`: a dead sensor, metres under a mm label) and a track holding
        one exact elevation over 2 m outside the exclusions (:func:`~longprofile.road.dropout_runs`: a dropout
        written as a value). False computes the acceptance anyway, with these in ``warnings``.

    Returns
    -------
    AcceptanceResult

    Raises
    ------
    InputError
        Exclusion zones outside the profile; MRI asked of a profile without two tracks; a profile shorter
        than ``min_lot_fraction`` of a lot or than the localized window; a gap (NaN) outside the exclusion zones;
        a dropout (``check_units``).
    UnitsError
        A section IRI outside 0.2-50 m/km (``check_units``).

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
    exclusion. Lots start at the first station and cover the section to the last (:func:`lot_bounds`: the
    remainder is a lot of its own or merged into the previous one).
    """
    spec = validate_spec(spec or default_spec())
    scale, lu = spec.metres_per_unit, spec.length_unit
    x = profile.distance
    x0u, x1u = x[0] / scale, x[-1] / scale
    spec, zone_notes = _clip_zones(spec, x0u, x1u)
    step = float(np.median(np.diff(x))) if x.size > 1 else 0.0
    for what, value in (("lot length", spec.lot_length), ("localized window", spec.localized_window)):
        if value * scale < 10.0 * step:  # e.g. 1e-9 ft: a trillion lots (a 7 TiB array), not a statement
            raise InputError(f"the {what} {value:g} {lu} is shorter than 10 samples of the profile ({step / scale:.3g} "
                             f"{lu} apart): a unit mistake in the spec?")
    bounds_u, last = lot_bounds(x0u, x1u, spec)
    zones = _merge(spec.exclusions)
    rs = acceptance_slope(profile, spec, tracks=tracks)  # no inserted limits: keeps the fast constant-step run
    spec = resolve_index(spec, rs.tracks)
    warnings = list(spec.notes) + zone_notes + _check_dropouts(profile, spec, rs.tracks, check_units)
    st, cum = _cumulative(rs)
    lots, lot_iri_m, section_m = _lot_table(st, cum, bounds_u, zones, spec, rs.tracks)
    plausible_warnings, implausible = _check_plausible(lots, lot_iri_m, section_m, spec, check_units)
    localized, defects = _localized_table(profile, spec, rs)
    unassessed = _unassessed_ends(localized, x0u, x1u)
    summary = _pay_summary(lots, defects, spec, zones, last, x0u, x1u, implausible, unassessed)
    plausible_warnings += _open_end_warnings(defects, unassessed, spec)
    meta = {"standard": "ASTM E1926 IRI (golden car, 80 km/h); MRI mean of two tracks; continuous IRI as ProVAL SAM",
            "units": spec.units, "length_unit": lu, "iri_unit": spec.iri_unit,
            "moving_average": bool(rs.moving_average), "moving_average_reason": rs.moving_average_reason,
            "first_station": float(x0u), "last_station": float(x1u), "index_tracks": list(rs.tracks),
            "section_iri_m_per_km": {t: (float(v) if np.isfinite(v) else None) for t, v in zip(rs.tracks, section_m)}}
    return AcceptanceResult(lots=lots, localized=localized, defects=defects, histogram=_histogram(lots, spec),
                            pay_summary=summary, spec=spec, tracks=rs.tracks, metadata=meta,
                            warnings=tuple(warnings + plausible_warnings))
