"""Diamond-grinding simulation: the least grinding that brings localized roughness below a threshold."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from ...core import Profile
from ...errors import InputError
from ..indices._iri import _is_regular, _resume, _run_arrays, _shared_start
from ._acceptance import (
    AcceptanceSpec,
    _cumulative,
    _localized_centres,
    _localized_values,
    default_spec,
    localized_index,
    resolve_index,
    validate_spec,
)

__all__ = ["GrindingResult", "simulate_grinding"]

#: The grind aims 0.1 % below the threshold, so that windows placed on another grid (e.g. every sample of
#: :func:`longprofile.road.iri_report`) also stay below it.
_MARGIN = 1e-3
#: Grinder settings tried at once per refinement round (one golden-car run over all of them).
_GRID = 8


@dataclass(frozen=True, eq=False)
class GrindingResult:
    """Must-grind areas, the grind chosen for each, and the profile after grinding.

    Attributes
    ----------
    grinds : pandas.DataFrame
        One row per area and track: ``area, track, start, end, length, max_depth, mean_depth, achieved,
        peak_before, peak_after, limit`` (lengths in the spec's length unit, depths in mm (SI) or in (US), localized
        index in its IRI unit; ``mean_depth`` over the ground length, ``start``/``end`` the ground length;
        ``limit`` what stops an area not achieved: ``depression``, ``depth`` or ``frame``, see
        :func:`_binding_limit`; also ``metadata["limits"]``).
    profile : Profile
        The profile after grinding (SI).
    threshold : float
        Localized roughness target, IRI unit.
    achieved : bool
        Every area reached the threshold within the depth limit and with the grinder frame.
    station, index_before, index_after : (M,) ndarray
        Localized index (IRI unit) at the window centres (length unit) before and after grinding: the index of
        :func:`~longprofile.road.smoothness_acceptance` (MRI of two tracks unless the spec says ``index = "iri"``:
        the worst track), after grinding from one golden-car run of the whole ground profile.
    metadata : dict
    """

    grinds: pd.DataFrame
    profile: Profile
    threshold: float
    achieved: bool
    station: np.ndarray = None
    index_before: np.ndarray = None
    index_after: np.ndarray = None
    metadata: dict = field(default_factory=dict)

    def summary(self) -> str:
        """One line: how many must-grind areas the grinding brings below the threshold, and of those it cannot,
        what stops it (:func:`_binding_limit`: a depression, the depth limit or the grinder frame)."""
        n = int(self.metadata.get("areas", self.grinds["area"].nunique()))
        unit = self.metadata.get("iri_unit", "")
        target = f"{self.threshold:g} {unit}".strip()
        if n == 0:
            return f"no must-grind area (localized index <= {target})"
        failed = int(self.grinds.loc[~self.grinds["achieved"].astype(bool), "area"].nunique())
        if failed == 0:
            return f"grinding brings all {n} must-grind area(s) to <= {target}"
        return (f"grinding brings {n - failed} of {n} must-grind area(s) to <= {target}; {failed} CANNOT be brought "
                f"below it: {self._limits_text()}")

    def _limits_text(self) -> str:
        """What stops the areas the grinding cannot fix, grouped by limit (from ``metadata["limits"]``)."""
        m = self.metadata
        du, lu = m.get("depth_unit", ""), m.get("length_unit", "")
        limits = m.get("limits", [])
        parts = []
        dips = [r for r in limits if r["limit"] == "depression"]
        if dips:
            parts.append(f"{len(dips)} depression(s) ({_stations(dips, lu)}, up to {max(r['value'] for r in dips):.3g} "
                         f"{du} below the surroundings), which grinding cannot fill: it only removes what stands above "
                         "the grinder's chord (patch, or mill and inlay)")
        deep = [r for r in limits if r["limit"] == "depth"]
        if deep:
            parts.append(f"{len(deep)} limited by the depth limit ({m.get('max_depth', float('nan')):g} {du}, reached; "
                         f"{_stations(deep, lu)}; grinding.max_depth)")
        frame = [r for r in limits if r["limit"] == "frame"]
        if frame:
            parts.append(f"{len(frame)} limited by the grinder frame ({m.get('grinder_length', float('nan')):g} {lu}; "
                         f"{_stations(frame, lu)}): grinding all that stands above its chord, at most "
                         f"{max(r['value'] for r in frame):.3g} {du} deep (within the {m.get('max_depth'):g} {du} "
                         "depth limit), is not enough; a longer frame may be (grinding.grinder_length)")
        return "; ".join(parts) or "limit not recorded"


def _stations(limits, lu) -> str:
    """``a-b lu`` of the first area of ``limits`` (and how many more)."""
    r = limits[0]
    more = f" and {len(limits) - 1} more" if len(limits) > 1 else ""
    return f"{r['start']:.6g}-{r['end']:.6g} {lu}{more}"


def _binding_limit(xs, zs, cut, a, b, w, max_depth) -> tuple[str, float]:
    """Why the grind of an area ``[a, b]`` (m) that stays above the threshold cannot do better: ``("depression",
    depth)`` when the area lies deeper below its surroundings than anything in it stands above them (grinding
    removes only what is above the chord: it cannot fill a dip), else ``("depth", max_depth)`` when the deepest
    grind tried reaches the depth limit, else ``("frame", deepest cut)``: all that stands above the frame's chord is
    ground and it is not enough. Depths in m.

    The surroundings: a quadratic (grade and vertical curve) fitted per track to the profile within one
    localized window ``w`` before and after the area (ASSUMPTION, longprofile's reading of "a depression")."""
    around = ((xs >= a - w) & (xs < a)) | ((xs > b) & (xs <= b + w))
    inside = (xs >= a) & (xs <= b)
    if around.sum() > 3 and inside.any():
        dip = bump = 0.0
        for j in range(zs.shape[1]):
            r = zs[inside, j] - np.polyval(np.polyfit(xs[around] - a, zs[around, j], 2), xs[inside] - a)
            dip, bump = max(dip, float(-r.min())), max(bump, float(r.max()))
        if dip > bump:
            return "depression", dip
    deepest = float(cut.max()) if cut.size else 0.0
    return ("depth", max_depth) if deepest >= max_depth * (1.0 - 1e-9) else ("frame", deepest)


def _chord_deviation(x, z, half):
    """z(x) - mean of z at x -+ half (supports clipped to the record)."""
    lo, hi = np.clip(x - half, x[0], x[-1]), np.clip(x + half, x[0], x[-1])
    return z - 0.5 * (np.interp(lo, x, z) + np.interp(hi, x, z))


def _row_max(a: np.ndarray) -> np.ndarray:
    """``a.max(axis=-1)`` (NaN propagated, the same values) as a loop of ``np.maximum`` over the few tracks: numpy
    reduces a short last axis row by row, tens of times slower."""
    out = a[..., 0].copy()
    for j in range(1, a.shape[-1]):
        np.maximum(out, a[..., j], out=out)
    return out


def _cumulative_resumed(shared, cum0, rest):
    """``(stations, cumulative)`` of :func:`_cumulative` for the candidates whose rectified slope is
    ``shared.rectified`` (tiled) then ``rest``: the shared rows tiled, the rest summed on from the last shared one
    (a cumulative sum is sequential, so the numbers are those of one cumulative sum over the whole)."""
    n_cand = rest.shape[1] // cum0.shape[1]
    s = shared.steps
    cum = np.empty((shared.station.size, rest.shape[1]), order="F")  # contiguous columns for np.interp
    cum[:s + 1] = np.tile(cum0, (1, n_cand))
    tail = shared.step[s:, None] * rest
    tail[0] += cum[s]
    np.cumsum(tail, axis=0, out=cum[s + 1:])
    return shared.station, cum


def _must_grind_areas(centres, above, scale, w) -> list[list[float]]:
    """The must-grind areas, m: unions of the localized windows (centres in the spec unit, width w in m) above
    the threshold, overlapping windows merged."""
    areas = []
    if above.any():
        d = np.diff(np.concatenate([[0], above.astype(np.int8), [0]]))
        for i, k in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1):
            a, b = centres[i] * scale - w / 2, centres[k] * scale + w / 2
            if areas and a <= areas[-1][1]:
                areas[-1][1] = b
            else:
                areas.append([a, b])
    return areas


def _touching_runs(cut: np.ndarray, i0: int, i1: int) -> np.ndarray:
    """``cut`` (k, C) with only the runs of cutting (consecutive rows > 0 per column) that touch the rows
    ``i0 .. i1`` (the area, contiguous) kept: a row before the area is kept when every row from it to ``i0``
    cuts, a row after it when every row from ``i1`` to it cuts (whole runs only: no step at the ends)."""
    pos = cut > 0
    keep = pos.copy()
    keep[:i0 + 1] = np.logical_and.accumulate(pos[i0::-1], axis=0)[::-1]
    keep[i1:] = np.logical_and.accumulate(pos[i1:], axis=0)
    return np.where(keep, cut, 0.0)


def _grind_setting(xs, zs, in_area, nb, a, b, half, max_depth, names, loc_spec, spec, scale, w, target, tolerance):
    """The shallowest grind of one area ``[a, b]`` (m) on its sub-profile ``xs, zs``: ``(ground elevations, cut,
    achieved, peak before, peak after)`` (model: :func:`simulate_grinding`, Notes)."""
    dev = np.column_stack([_chord_deviation(xs, zs[:, j], half) for j in range(zs.shape[1])])
    rows_in = np.flatnonzero(in_area)  # contiguous (xs sorted); all before nb
    if np.isnan(zs[:nb].sum()):
        raise InputError("the grinding simulation needs elevations without NaN around each must-grind area "
                         f"({a:.3f} .. {b:.3f} m).")
    dx_nb = _is_regular(xs[:nb])  # as rectified_slope finds it on the search sub-profile

    def ground_many(cvals, k, start=0):
        """Ground elevations (k - start, len(cvals) * K) and cuts for several settings on the samples start .. k-1
        (``start`` > 0 only before the first sample any setting cuts: the runs are then those of the whole)."""
        cv = np.asarray(cvals, dtype=float)
        cut = np.clip(dev[start:k, None, :] - cv[None, :, None], 0.0, max_depth).reshape(k - start, -1)
        cut = (_touching_runs(cut, max(rows_in[0] - start, 0), rows_in[-1] - start) if rows_in.size
               else np.zeros_like(cut))
        return np.tile(zs[start:k], (1, cv.size)) - cut, cut

    def ground(c):
        zg, cut = ground_many([c], zs.shape[0])
        return zg, cut

    def peaks(cvals):
        """Largest localized index inside the area for each grinder setting (one car run for all): the numbers
        of :func:`localized_index` on the ground sub-profile (golden car with the defaults of rectified_slope),
        at the window centres inside the area only, without re-validating the arrays; the car is run only
        from the first sample any setting cuts (the states before it are shared, the same numbers)."""
        k = len(names)
        if shared is not None:
            st, cum = _cumulative_resumed(shared, cum0, _resume(shared, ground_many(cvals, nb, shared.steps)[0]))
        else:
            st, cum = _cumulative(_run_arrays(xs[:nb], ground_many(cvals, nb)[0], (), 11.0, None, 0.25, None, dx_nb)[0])
        centres = _localized_centres(xs[:nb], st, loc_spec)
        cs = centres / scale
        m = (cs * scale >= a + w / 2 - 1e-9) & (cs * scale <= b - w / 2 + 1e-9)
        if not m.any():
            return np.full(len(cvals), -np.inf)
        vals = _localized_values(st, cum, centres[m], loc_spec)
        v = vals.reshape(int(m.sum()), len(cvals), k)
        idx = v.mean(axis=2) if (spec.index == "mri" and k == 2) else _row_max(v)
        return np.fmax.reduce(idx, axis=0)  # ignores blank (excluded) windows, no All-NaN warning

    deepest = np.flatnonzero(_row_max(ground_many([0.0], nb)[1]) > 0)  # every setting cuts within this
    shared = _shared_start(xs[:nb], zs[:nb], dx_nb, int(deepest[0]) if deepest.size else None)
    if shared is not None:  # cumulative of the shared steps (as _cumulative: the same sums, in the same order)
        cum0 = np.cumsum(np.vstack([np.zeros((1, len(names))), shared.step[:shared.steps, None] * shared.rectified]),
                         axis=0)
    c_hi = max(0.0, float(dev[in_area].max())) if in_area.any() else 0.0  # no grinding
    c_lo = 0.0  # everything above the chord ground away (to the depth limit): the most a grinder can do
    aim = target * (1.0 - _MARGIN)

    def refine(lo, hi):
        """The settings of the next round of grid refinement (none once the setting is known to ``tolerance``)."""
        return np.linspace(lo, hi, _GRID + 2)[1:-1] if hi - lo > tolerance else np.empty(0)

    # the first refinement round rides along with the two end settings (one car run; the columns are independent,
    # so each setting's peak is the number a run of its own gives)
    grid = refine(c_lo, c_hi)
    pk = peaks(np.concatenate([[c_hi, c_lo], grid]))
    before, at_most, pk = pk[0], pk[1], pk[2:]
    after = at_most
    ok = at_most <= aim
    while ok and grid.size:  # grid refinement: the index grows with the setting c (less grinding, rougher)
        good = np.flatnonzero(pk <= aim)
        j = good[-1] if good.size else -1
        if j >= 0:
            c_lo, after = float(grid[j]), float(pk[j])
        if j + 1 < grid.size:
            c_hi = float(grid[j + 1])
        grid = refine(c_lo, c_hi)
        if grid.size:
            pk = peaks(grid)
    c = c_lo
    zg, cut = ground(c)
    return zg, cut, ok, before, after


def _sub_profile(x, missing, a, b, lead, margin) -> tuple[int, int]:
    """Rows ``i0 .. i1 - 1`` of the stations ``x`` from ``lead`` before the area ``[a, b]`` (m) to ``margin`` after
    it, between the missing rows (sorted) around it: the sub-profile re-simulated for one area (a gap lies in an
    exclusion zone, outside the area)."""
    i0 = int(np.searchsorted(x, max(x[0], a - lead)))
    i1 = int(np.searchsorted(x, min(x[-1], b + margin), side="right"))
    if missing.size:
        mid = int(np.searchsorted(x, 0.5 * (a + b)))
        k = int(np.searchsorted(missing, mid))
        i0 = max(i0, int(missing[k - 1]) + 1) if k > 0 else i0
        i1 = min(i1, int(missing[k])) if k < missing.size else i1
    return i0, i1


def _grind_rows(n, names, cut, xs, scale, spec, ok, before, after, limit=None) -> list[dict]:
    """The grind-list rows of area ``n``: one per track with a cut (start, end, length, depths, what limits an
    area the grinding cannot fix)."""
    rows = []
    for j, t in enumerate(names):
        cj = cut[:, j]
        g = cj > 0
        if not g.any():
            continue
        ga, gb = xs[g][0], xs[g][-1]
        rows.append({"area": n, "track": t, "start": ga / scale, "end": gb / scale, "length": (gb - ga) / scale,
                     "max_depth": float(cj.max()) / spec.depth_factor,
                     "mean_depth": float(cj[(xs >= ga) & (xs <= gb)].mean()) / spec.depth_factor,
                     "achieved": bool(ok), "peak_before": before, "peak_after": after,
                     "limit": "" if limit is None else limit[0]})
    return rows


def simulate_grinding(profile: Profile, spec: AcceptanceSpec | None = None, *, threshold: float | None = None,
                      tracks=None, lead: float = 40.0, margin: float = 60.0, tolerance: float = 2e-5,
                      acceptance=None) -> GrindingResult:
    """Find must-grind areas and the shallowest grind of each that brings localized roughness below a threshold.

    Parameters
    ----------
    profile : Profile
        SI profile.
    spec : AcceptanceSpec, optional
        Units, localized window, exclusions, grinder length and depth limit (default :func:`default_spec`).
    threshold : float, optional
        Localized roughness target, IRI unit of the spec (default ``spec.grind_threshold`` or
        ``spec.localized_threshold``).
    tracks : str or sequence of str, optional
    lead : float
        Profile kept before an area when re-simulating it, m (default 40 m: the lead-in plus the decay of the
        initial transient of the golden car, whose sprung mode decays as exp(-c t / 2) = exp(-3 t)).
    margin : float
        Profile after an area in which a run of cutting that touches it may continue, m (default 60 m).
    tolerance : float
        Bisection stops when the grinder setting is known to this, m (default 0.02 mm).
    acceptance : AcceptanceResult, optional
        The :func:`~longprofile.road.smoothness_acceptance` result of the same profile and spec: its localized
        index is reused (saves one golden-car run).

    Returns
    -------
    GrindingResult

    Notes
    -----
    Model (a longprofile ASSUMPTION, after ProVAL's grinding simulation): a must-grind area is the union of
    the localized-roughness windows above the threshold. A grinder whose frame of length ``grinder_length``
    rides on the profile cuts what lies higher than the frame chord by more than a clearance ``c >= 0``:
    ``z' = z - clip(d - c, 0, max_depth)`` with ``d = z - (z(x - L/2) + z(x + L/2)) / 2`` (the rolling
    straightedge deviation, one pass; whole runs of cutting that touch the area are kept, so no step is cut
    at its ends; grinding cannot fill dips). The same ``c`` is used for every track of an area (one machine
    setting); it is found by grid refinement (8 settings per car run) as the largest (shallowest grind) that
    brings every window of the area to the threshold (aiming 0.1 % below it), the area re-simulated with
    ``lead`` m of profile before it. Grinding only removes material, only in runs of cutting that touch the
    area. An area that the grinder cannot fix is ground as deep as it can (everything above the chord, to the depth
    limit) and flagged ``achieved = False`` with what limits it (:func:`_binding_limit`: a depression, the depth
    limit or the frame length). Missing (NaN) elevations are accepted inside the exclusion zones (as
    :func:`~longprofile.road.smoothness_acceptance`): an area's sub-profile stops at the gaps around it.
    """
    spec = validate_spec(spec or default_spec())
    target = threshold if threshold is not None else (spec.grind_threshold or spec.localized_threshold)
    if target is None:
        raise InputError("the grinding simulation needs a threshold (grinding.threshold or localized.threshold "
                         "in the spec, or threshold=...).")
    target = float(target)
    scale = spec.metres_per_unit
    loc_spec = replace(spec, localized_threshold=target)
    same = acceptance is not None and all(getattr(acceptance.spec, f) == getattr(spec, f) for f in (
        "localized_window", "localized_step", "units", "exclusions"))
    if same and f"iri_{acceptance.tracks[0]}" in acceptance.localized:
        # the per-track values are those localized_index gives (same run, windows and exclusions); the index
        # is formed below by this spec's rule
        centres = acceptance.localized["station"].to_numpy()
        names = acceptance.tracks
        vals = np.column_stack([acceptance.localized[f"iri_{t}"].to_numpy(dtype=float) for t in names])
    else:
        centres, vals, _, names = localized_index(profile, loc_spec, tracks=tracks)
    spec = resolve_index(spec, names)  # "auto": the index of the acceptance (MRI of two tracks), its defects
    loc_spec = replace(spec, localized_threshold=target)
    index = vals.mean(axis=1) if spec.index == "mri" else vals.max(axis=1)
    x = profile.distance
    z_all = np.column_stack([profile.track(t) for t in names])
    z_new = z_all.copy()
    above = np.nan_to_num(index, nan=-np.inf) > target
    w = spec.localized_window * scale
    areas = _must_grind_areas(centres, above, scale, w)
    half = 0.5 * spec.grinder_length * scale
    max_depth = spec.grind_max_depth * spec.depth_factor
    rows, limits = [], []
    all_ok = True
    missing = np.flatnonzero(np.isnan(z_all).any(axis=1))  # gaps, inside exclusion zones (acceptance_slope)
    for n, (a, b) in enumerate(areas, start=1):
        i0, i1 = _sub_profile(x, missing, a, b, lead, margin)
        xs = x[i0:i1]
        zs = z_new[i0:i1].copy()  # not a view: z_new is updated below
        in_area = (xs >= a) & (xs <= b)
        nb = int(np.searchsorted(xs, b + 1.0, side="right"))  # search: windows inside the area only (causal car)
        zg, cut, ok, before, after = _grind_setting(xs, zs, in_area, nb, a, b, half, max_depth, names, loc_spec,
                                                    spec, scale, w, target, tolerance)
        all_ok &= ok
        z_new[i0:i1] = zg
        limit = None if ok else _binding_limit(xs, zs, cut, a, b, w, max_depth)
        if limit is not None:
            limits.append({"area": n, "start": a / scale, "end": b / scale, "limit": limit[0],
                           "value": limit[1] / spec.depth_factor})
        rows.extend(_grind_rows(n, names, cut, xs, scale, spec, ok, before, after, limit))
    ground_profile = Profile(distance=x, elevation=z_new, tracks=names, name=(profile.name + " ground").strip())
    # the localized index after grinding: one run of the whole ground profile (as smoothness_acceptance on it)
    index_after = localized_index(ground_profile, loc_spec)[2] if rows else np.array(index, dtype=float, copy=True)
    meta = {"model": "one-pass grinder: cut = clip(d - c, 0, max_depth), d = deviation from a chord of "
                     "grinder_length; c by grid refinement per area (longprofile assumption)",
            "grinder_length": spec.grinder_length, "max_depth": spec.grind_max_depth,
            "depth_unit": "mm" if spec.units == "si" else "in", "areas": len(areas), "iri_unit": spec.iri_unit,
            "length_unit": spec.length_unit, "limits": limits}
    grinds = pd.DataFrame(rows, columns=["area", "track", "start", "end", "length", "max_depth", "mean_depth",
                                         "achieved", "peak_before", "peak_after", "limit"])
    return GrindingResult(grinds=grinds, profile=ground_profile, threshold=target, achieved=bool(all_ok),
                          station=np.asarray(centres, dtype=float), index_before=np.asarray(index, dtype=float),
                          index_after=index_after, metadata=meta)
