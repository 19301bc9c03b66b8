"""Profiles with gaps: the IRI over the measured parts, the quarter car restarted after each gap.

A profile may miss elevations: a sensor dropout, a bridge joint lost, data removed by the operator (written as NaN;
rows removed leave a station step longer than :data:`~longprofile.road.indices._iri.MAX_IRI_STEP_M`). By default
the IRI refuses such a profile (``gaps="refuse"``). With ``gaps="restart"`` (CLI ``--gaps restart``) it is
computed as ProVAL and ASTM E1926 practice do, with these ASSUMPTIONS (docs/road-indices.md, "Profiles with gaps"):

* the profile is split at every gap into runs of measured samples (:func:`valid_runs`, the run finder of
  ``road acceptance`` too), each track at its own gaps;
* each run is processed exactly as if it were its own file (:func:`run_slopes`): the elevations re-zeroed at its
  first sample, its own moving-average decision, the quarter car initialised by the standard 11 m lead-in slope;
  so a run's rectified slope -- and the IRI of any interval inside it -- is that of the run written as its own file;
* a run too short to initialise (shorter than the lead-in, or than it once smoothed) is dropped and named;
* a track left without any run long enough (every elevation missing: a dead sensor) is a *dead track*: its
  intervals get no IRI, nor the MRI and HRI, which need both tracks; the other tracks are computed exactly as if
  analysed alone, and the profile is refused only when no track has a run long enough;
* an interval's IRI is the rectified slope integrated over its measured parts divided by their length; an interval
  measured over less than ``min_valid`` of its length (default :data:`MIN_VALID_FRACTION`) gets NaN, with the
  reason in its ``note``;
* nothing is ever interpolated across a gap.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._validation import true_runs
from ...errors import InputError

__all__ = ["GAP_MODES", "MIN_VALID_FRACTION", "GapSummary", "gaps_mode", "min_valid_fraction", "valid_runs",
           "run_slopes"]

#: ``gaps`` of the IRI functions: "refuse" (default) a profile with missing elevations, or "restart" the quarter car
#: after each gap.
GAP_MODES = ("refuse", "restart")
#: Default smallest measured share of an interval for its IRI to be reported (ASSUMPTION, docs/road-indices.md §1c:
#: on the measured Sroubek-Sorel profile with one gap placed at random, the IRI of a 100 m segment measured over
#: 80-90 % is within 3.6 % of the whole segment's (median; p95 10 %), over 70-80 % within 6.8 % (p95 12.5 %)).
MIN_VALID_FRACTION = 0.8


def gaps_mode(value) -> str:
    """``gaps`` normalised ("refuse" or "restart") and checked."""
    key = value.strip().lower() if isinstance(value, str) else value
    if key not in GAP_MODES:
        raise InputError(f"gaps must be 'refuse' (a profile with missing elevations is refused) or 'restart' (the IRI "
                         f"over the measured parts, the quarter car restarted after each gap); got {value!r}.")
    return key


def min_valid_fraction(value) -> float:
    """``min_valid`` checked: a fraction in (0, 1]."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"min_valid must be a number in (0, 1]; got {value!r}.") from None
    if not 0.0 < v <= 1.0:
        hint = f" (a percentage? {v:g} % is {v / 100:g})" if 1.0 < v <= 100.0 else ""
        raise InputError(f"min_valid must be the smallest measured fraction of an interval, in (0, 1]; got "
                         f"{value!r}{hint}.")
    return v


def valid_runs(x, missing, *, max_step: float | None = None) -> list[tuple[int, int]]:
    """``(first, last)`` sample index of each run of measured samples: the runs of False in ``missing``, also split
    at every station step longer than ``max_step`` (rows removed from the file) when it is given."""
    runs = true_runs(~np.asarray(missing, dtype=bool))
    x = np.asarray(x, dtype=float)
    if max_step is None or x.size < 2:
        return runs
    breaks = np.flatnonzero(np.diff(x) > max_step)  # the step from sample b to b + 1 is a gap
    if breaks.size == 0:
        return runs
    out = []
    for i, k in runs:
        first = i
        for b in breaks[np.searchsorted(breaks, i):np.searchsorted(breaks, k)].tolist():
            out.append((first, b))
            first = b + 1
        out.append((first, k))
    return out


def run_slopes(x, z, names, runs, *, lead_in: float, moving_average, base_length: float, extra_stations=None):
    """The golden car over each run of measured samples, each as its own profile (ASTM E1926 initialisation).

    Parameters
    ----------
    x : (N,) ndarray
        Stations, m.
    z : (N, K) ndarray
        Elevations, m (NaN outside the runs).
    names : tuple of str
        Track names of the columns.
    runs : list of (int, int)
        ``(first, last)`` sample index of each run (:func:`valid_runs`).
    lead_in, moving_average, base_length, extra_stations
        As :func:`longprofile.road.rectified_slope`; ``extra_stations`` (m) outside a run are ignored.

    Returns
    -------
    kept : list of (int, int, RectifiedSlope, ndarray or None, float)
        ``(first, last, rectified slope, mask of the inserted stations, station tolerance)`` of each run computed
        exactly as :func:`~longprofile.road.rectified_slope` computes the run written as its own file.
    dropped : list of (int, int)
        The runs too short to initialise (shorter than ``lead_in``, or than it once smoothed).
    """
    from ._iri import _is_regular, _run_arrays

    kept, dropped = [], []
    for i, k in runs:
        if x[k] - x[i] < lead_in:
            dropped.append((i, k))
            continue
        xr = x[i:k + 1]
        dx = _is_regular(xr)
        try:
            # a C-ordered copy, as a file's tracks are (the same kernels and the same numbers as the run's own file)
            zr = np.array(z[i:k + 1], dtype=float, order="C")
            rs, mask = _run_arrays(xr, zr, tuple(names), lead_in, moving_average, base_length, extra_stations, dx)
        except InputError:  # only "shorter than the lead-in (or the moving-average base)" once smoothed
            dropped.append((i, k))
            continue
        kept.append((i, k, rs, mask, 1e-6 * (dx if dx is not None else float(np.min(np.diff(xr))))))
    return kept, dropped


def _spans(x, runs) -> list[tuple[float, float]]:
    """Unmeasured spans of the profile around ``runs``: between two runs (last sample of one to the first of the
    next), before the first and after the last."""
    out = []
    prev = None
    for i, k in runs:
        if prev is None and i > 0:
            out.append((float(x[0]), float(x[i])))
        elif prev is not None:
            out.append((float(x[prev]), float(x[i])))
        prev = k
    if prev is None:
        out.append((float(x[0]), float(x[-1])))
    elif prev < x.size - 1:
        out.append((float(x[prev]), float(x[-1])))
    return out


def _merge_spans(spans) -> list[tuple[str, float, float]]:
    """``(tracks, start, end)`` spans of several tracks merged where they overlap (tracks joined by '+')."""
    out: list[list] = []
    for track, a, b in sorted(spans, key=lambda s: (s[1], s[2])):
        if out and a <= out[-1][2]:
            out[-1][2] = max(out[-1][2], b)
            if track not in out[-1][0]:
                out[-1][0].append(track)
        else:
            out.append([[track], a, b])
    return [("+".join(t), a, b) for t, a, b in out]


@dataclass(frozen=True)
class GapSummary:
    """What the gaps of a profile did to an IRI computed with ``gaps="restart"`` (lengths in m).

    Attributes
    ----------
    gaps : tuple of (str, float, float)
        Unmeasured spans ``(tracks, start, end)``, those of several tracks merged where they overlap.
    dropped : tuple of (str, float, float)
        Runs of measured samples too short to initialise the quarter car ``(track, first, last station)``.
    intervals, affected, without_iri : int
        Reported intervals, those overlapping a gap or a dropped run, those with a NaN IRI (or HRI) -- of the tracks
        that have a run long enough (the dead tracks' intervals all have none).
    min_valid : float
        Smallest measured fraction of an interval for its IRI to be reported.
    lead_in : float
        Initialisation length, m.
    dead : tuple of str
        Tracks without any measured run of at least the lead-in (no IRI at all; their gaps and runs are not in
        ``gaps`` and ``dropped``).
    live : tuple of str
        The other tracks (those with an IRI), named in the message's hint when some are dead.
    """

    gaps: tuple[tuple[str, float, float], ...]
    dropped: tuple[tuple[str, float, float], ...]
    intervals: int
    affected: int
    without_iri: int
    min_valid: float
    lead_in: float
    dead: tuple[str, ...] = ()
    live: tuple[str, ...] = ()

    @property
    def any(self) -> bool:
        """Whether the profile had a gap (or a run left out, or a dead track)."""
        return bool(self.gaps or self.dropped or self.dead)

    @property
    def gap_length(self) -> float:
        """Total unmeasured length, m."""
        return float(sum(b - a for _, a, b in self.gaps))

    def metadata(self, metres_per_unit: float = 1.0) -> dict:
        """The summary as JSON scalars for a report's metadata (lengths in the report unit)."""
        return {"gaps": "restart", "min_valid": self.min_valid, "gap_count": len(self.gaps),
                "gap_length": self.gap_length / metres_per_unit, "gap_intervals_affected": self.affected,
                "gap_intervals_without_iri": self.without_iri, "gap_runs_dropped": len(self.dropped),
                "gap_dead_tracks": ",".join(self.dead)}

    def message(self, *, length_unit: str = "m", metres_per_unit: float = 1.0, what: str = "segment") -> str:
        """One sentence for the console and the report ("" without gaps)."""
        if not self.any:
            return ""
        f, lu = metres_per_unit, length_unit
        text = self._dead_text()
        if not (self.gaps or self.dropped):
            return text + "."
        text += "; " if text else ""
        if self.gaps:
            tracks = sorted({t for g in self.gaps for t in g[0].split("+")})
            a, b = self.gaps[0][1:]
            text += (f"{len(self.gaps)} gap(s) of missing elevations (track {', '.join(tracks)}), "
                    f"{self.gap_length / f:.6g} {lu} in all, the first {a / f:.3f}-{b / f:.3f} {lu}: ")
        text += (f"IRI over the measured parts, the quarter car restarted after each gap (--gaps restart); "
                 f"{self.affected} of {self.intervals} {what}(s) affected, {self.without_iri} without IRI (measured "
                 f"over less than {self.min_valid * 100:g}%, --min-valid)")
        if self.dropped:
            tr, a, b = self.dropped[0]
            more = f" and {len(self.dropped) - 1} more" if len(self.dropped) > 1 else ""
            text += (f"; {len(self.dropped)} run(s) shorter than the {self.lead_in:g} m lead-in left out ({tr} "
                     f"{a / f:.3f}-{b / f:.3f} {lu}{more})")
        return text + "."

    def _dead_text(self) -> str:
        """The clause naming the dead tracks ("" without)."""
        if not self.dead:
            return ""
        names = ", ".join(repr(t) for t in self.dead)
        other = f" (--track {','.join(self.live)})" if self.live else " (--track)"
        return (f"track(s) {names} have no measured run of at least the {self.lead_in:g} m lead-in (every elevation "
                f"missing: a dead sensor?): no IRI for them, nor MRI or HRI, which need both tracks; check the "
                f"sensor, or analyse the other track(s) alone{other}")


@dataclass(frozen=True, eq=False)
class GappedSums:
    """Per-interval integrals of the rectified slope of every track over its measured runs (:func:`gapped_sums`).

    ``total`` (S, K) in m/km x m and ``length`` (S, K) in m per interval; ``section_total``, ``section_length`` (K,)
    over the whole profile; ``start``, ``end`` the first and last simulated station (m); ``spans`` and ``dropped``
    ``(track, start, end)`` in m; ``dead`` the tracks without any run long enough (all zero); the moving-average
    decision and the method of the runs."""

    total: np.ndarray
    length: np.ndarray
    section_total: np.ndarray
    section_length: np.ndarray
    start: float
    end: float
    spans: tuple
    dropped: tuple
    moving_average: bool
    moving_average_reason: str
    method: str
    dead: tuple = ()


def gapped_sums(x, z, names, *, lead_in, moving_average, base_length, extra_stations, per_interval,
                n_intervals: int, required: bool = True) -> GappedSums:
    """Run the golden car over each run of measured samples of each track (tracks with the same gaps together) and
    integrate its rectified slope per interval.

    ``per_interval(rectified_slope, inserted, tol) -> (total (S, k), length (S,))`` integrates one run (the
    ``_segment_sums`` or ``_window_sums`` of :mod:`._iri`). A track without any run long enough (a *dead* track) is
    left at zero length (its IRI NaN everywhere) and named in ``dead``; when no track has one the profile is refused
    (``required``).
    """
    from ._iri import MAX_IRI_STEP_M

    missing = np.isnan(z)
    groups: dict[bytes, list[int]] = {}
    for j in range(z.shape[1]):
        groups.setdefault(np.packbits(missing[:, j]).tobytes(), []).append(j)
    k_all = z.shape[1]
    total, length = np.zeros((n_intervals, k_all)), np.zeros((n_intervals, k_all))
    sec_total, sec_length = np.zeros(k_all), np.zeros(k_all)
    spans, dropped, dead, decisions, first, last = [], [], [], [], np.inf, -np.inf
    for cols in groups.values():
        runs = valid_runs(x, missing[:, cols[0]], max_step=MAX_IRI_STEP_M)
        kept, short = run_slopes(x, z[:, cols], [names[c] for c in cols], runs, lead_in=lead_in,
                                 moving_average=moving_average, base_length=base_length,
                                 extra_stations=extra_stations)
        group_spans = _spans(x, runs)
        spans += [(names[c], a, b) for c in cols for a, b in group_spans]
        dropped += [(names[c], float(x[i]), float(x[k])) for c in cols for i, k in short]
        if not kept:
            dead += [names[c] for c in cols]
        for _i, _k, rs, mask, tol in kept:
            t, covered = per_interval(rs, mask, tol)
            total[:, cols] += t
            length[:, cols] += covered[:, None]
            sec_total[cols] += rs.step @ rs.rectified
            sec_length[cols] += rs.step.sum()
            decisions.append((rs.moving_average, rs.moving_average_reason, rs.method))
            first, last = min(first, float(rs.station[0])), max(last, float(rs.station[-1]))
    if required and len(dead) == k_all:
        which = f"track {names[0]!r} has no" if k_all == 1 else f"none of the tracks {', '.join(map(repr, names))} has a"
        raise InputError(f"{which} measured run of at least the {lead_in:g} m lead-in between the gaps (every elevation "
                         "missing: a dead sensor?): no IRI can be computed; check the file, or choose other tracks "
                         "(--track).")
    dead = [n for n in names if n in dead]  # in the tracks' order
    applied = [d[0] for d in decisions]
    reason = decisions[0][1] if decisions else "no run long enough to compute"
    if len(set(applied)) > 1:
        reason = (f"decided per run, each as its own file: applied in {sum(applied)} of {len(applied)} runs; first "
                  f"run: {reason}")
    method = "constant-step" if all(d[2] == "constant-step" for d in decisions) else "per-step"
    return GappedSums(total=total, length=length, section_total=sec_total, section_length=sec_length, start=first,
                      end=last, spans=tuple(spans), dropped=tuple(dropped), moving_average=any(applied),
                      moving_average_reason=reason, method=method, dead=tuple(dead))


def valid_means(total, length, interval_length, min_valid: float) -> np.ndarray:
    """``total / length`` per interval and column where the measured share ``length / interval_length`` is at least
    ``min_valid``, NaN elsewhere."""
    total, length = np.asarray(total, float), np.asarray(length, float)
    keep = (length > 0) & (length >= (min_valid - 1e-12) * np.asarray(interval_length, float)[:, None])
    out = np.full(total.shape, np.nan)
    out[keep] = total[keep] / length[keep]
    return out


def summarise(sums: GappedSums, starts_m, ends_m, values, min_valid: float, lead_in: float,
              extra_dropped=(), tracks=()) -> GapSummary:
    """The :class:`GapSummary` of a gapped computation: the tracks' spans merged, intervals overlapping a span or a
    dropped run (``extra_dropped``: the half-car's), intervals with a NaN in ``values`` (S, C) -- all of the tracks
    with a run long enough (a dead track is named in ``dead``, its spans and its columns left out: ``values`` holds
    the live tracks' columns only); ``tracks`` all the tracks' names."""
    dead = set(sums.dead)
    gaps = tuple(_merge_spans([s for s in sums.spans if s[0] not in dead]))
    dropped = tuple(d for d in sums.dropped if d[0] not in dead) + tuple(extra_dropped)
    starts_m, ends_m = np.asarray(starts_m, float), np.asarray(ends_m, float)
    blank = [(a, b) for _, a, b in _merge_spans([(t, a, b) for t, a, b in gaps + dropped])]
    affected = np.zeros(starts_m.size, dtype=bool)
    if blank:
        g0, g1 = np.array([a for a, _ in blank]), np.array([b for _, b in blank])
        idx = np.searchsorted(g1, starts_m, side="right")  # the first span ending after the interval's start
        inside = idx < g0.size
        affected[inside] = g0[idx[inside]] < ends_m[inside]
    without = int(np.count_nonzero(np.isnan(values).any(axis=1))) if values.size else 0
    return GapSummary(gaps=gaps, dropped=dropped, intervals=int(starts_m.size), affected=int(affected.sum()),
                      without_iri=without, min_valid=float(min_valid), lead_in=float(lead_in), dead=tuple(sums.dead),
                      live=tuple(t for t in tracks if t not in dead))


def gap_columns(valid, names, interval_length, min_valid: float, length_unit: str) -> dict:
    """The columns a table gains with ``gaps="restart"``: ``valid_length_<name>_<unit>`` per column of ``valid``
    (S, C; in ``length_unit``), ``valid_fraction`` (the smallest of them over the interval length) and ``note``
    (why an IRI is NaN: the columns measured over less than ``min_valid``)."""
    valid = np.asarray(valid, float).reshape(len(interval_length), -1)
    cols = {f"valid_length_{n}_{length_unit}": valid[:, j] for j, n in enumerate(names)}
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = valid / np.asarray(interval_length, float)[:, None]
    cols["valid_fraction"] = frac.min(axis=1) if frac.shape[1] else np.zeros(0)
    short = frac < min_valid - 1e-12
    notes = np.full(frac.shape[0], "", dtype=object)
    for r in np.flatnonzero(short.any(axis=1)):
        parts = ", ".join(f"{n} {frac[r, j]:.1%}" for j, n in enumerate(names) if short[r, j])
        notes[r] = f"no IRI: measured {parts} (< {min_valid * 100:g}%)"
    cols["note"] = notes
    return cols


@dataclass(frozen=True, eq=False)
class GappedIRI:
    """The IRI of a profile with gaps per interval (:func:`gapped_iri`), in the unit ``factor`` gives.

    ``tracks`` (K names); ``values`` (S, K) and ``valid`` (S, K, m) per track; ``mri``, ``hri``, ``hri_valid``
    (S,) with two tracks (else None); ``section`` (K,), ``section_mri``, ``section_hri``; ``start``, ``end`` (m) of
    the simulated stations; the moving-average decision, the method and the :class:`GapSummary` (``valid``,
    ``hri_valid`` and ``summary`` are None for a profile computed without ``gaps="restart"``)."""

    tracks: tuple[str, ...]
    values: np.ndarray
    valid: np.ndarray | None
    mri: np.ndarray | None
    hri: np.ndarray | None
    hri_valid: np.ndarray | None
    section: np.ndarray
    section_mri: float | None
    section_hri: float | None
    start: float
    end: float
    moving_average: bool
    moving_average_reason: str
    method: str
    summary: GapSummary | None


def gapped_iri(x, z, names, *, lead_in, moving_average, base_length, extra_stations, per_interval, starts_m, ends_m,
               min_valid: float, factor: float = 1.0) -> GappedIRI:
    """IRI per interval ``[starts_m, ends_m]`` (m) of the tracks ``z`` (N, K; NaN in the gaps) over their measured
    runs (:func:`gapped_sums`), NaN where less than ``min_valid`` is measured; with two tracks the MRI (mean of the
    two IRI, NaN if either is) and the HRI (the half-car profile, missing where either track is, run the same way).
    ``factor`` converts m/km to the report's IRI unit. A dead track (no run long enough) has NaN everywhere, and so
    have the MRI and HRI; the other tracks' values are those of the tracks analysed alone."""
    starts_m, ends_m = np.asarray(starts_m, float), np.asarray(ends_m, float)
    span = ends_m - starts_m
    run = dict(lead_in=lead_in, moving_average=moving_average, base_length=base_length,
               extra_stations=extra_stations, per_interval=per_interval, n_intervals=starts_m.size)
    sums = gapped_sums(x, z, names, **run)
    values = valid_means(sums.total, sums.length, span, min_valid) * factor
    with np.errstate(invalid="ignore", divide="ignore"):
        section = sums.section_total / sums.section_length * factor
    mri = hri = hri_valid = section_mri = section_hri = None
    extra_dropped: tuple = ()
    live = [j for j, n in enumerate(names) if n not in sums.dead]
    every = values[:, live]
    if z.shape[1] == 2:
        mri = values.mean(axis=1)
        section_mri = float(section.mean())
        half = gapped_sums(x, z.mean(axis=1)[:, None], ("half-car",), required=False, **run)
        hri = valid_means(half.total, half.length, span, min_valid)[:, 0] * factor
        hri_valid = half.length[:, 0]
        section_hri = (float(half.section_total[0] / half.section_length[0] * factor) if half.section_length[0] > 0
                       else float("nan"))
        extra_dropped = tuple(d for d in half.dropped if not any(d[1] <= b and d[2] >= a for _, a, b in sums.dropped))
        if not sums.dead:
            every = np.column_stack([values, hri])
    summary = summarise(sums, starts_m, ends_m, every, min_valid, lead_in, extra_dropped, tuple(names))
    return GappedIRI(tracks=tuple(names), values=values, valid=sums.length, mri=mri, hri=hri, hri_valid=hri_valid,
                     section=section, section_mri=section_mri, section_hri=section_hri, start=sums.start, end=sums.end,
                     moving_average=sums.moving_average, moving_average_reason=sums.moving_average_reason,
                     method=sums.method, summary=summary)
