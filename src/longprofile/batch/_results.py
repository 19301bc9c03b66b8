"""Reading a results folder back, and the network summary the network report renders."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputFormatError
from ._run import PROFILES, SEGMENTS, partition_file, read_manifest

__all__ = ["BatchResults", "read_results", "NetworkSummary", "summarize_network", "IRI_UNITS"]

#: Unit suffix of an IRI column -> unit label, and the factor from m/km.
IRI_UNITS = {"m_per_km": ("m/km", 1.0), "mm_per_m": ("mm/m", 1.0), "in_per_mi": ("in/mi", 63.36)}
_VALUE = re.compile(r"^(?P<kind>iri|mri|hri)(?:_(?P<track>.+?))?_(?P<unit>m_per_km|mm_per_m|in_per_mi)$")
_START = re.compile(r"^(?:segment_)?start(?:_(?P<unit>[a-z]+))?$")
_END = re.compile(r"^(?:segment_)?end(?:_(?P<unit>[a-z]+))?$")


@dataclass(frozen=True, eq=False)
class BatchResults:
    """A results folder read back.

    Attributes
    ----------
    folder : Path
    task : str
        ``"iri"`` or ``"reconstruct"``.
    options : dict
        The task options of the run.
    manifest : pandas.DataFrame
        One row per input (columns: :data:`longprofile.batch.MANIFEST_COLUMNS`), sorted by route.
    segments : pandas.DataFrame
        The segment tables of the inputs with status ok or skipped, in manifest order: ``route, file`` then the
        IRI report columns. Partitions without an ok manifest row (left by an interrupted run) are not read.
    n_inputs : int or None
        How many inputs the last run was given (None for folders written before session 35).
    complete : bool or None
        Whether the last run went through all of them (False: interrupted; ``--resume`` finishes it).
    missing_inputs : tuple of str
        Manifest paths with results whose file no longer exists when the folder is read (deleted or renamed since:
        ``--resume`` keeps their rows).
    last_run : int or None
        Number of the last run (manifest column ``run``); None for folders written before session 38, whose rows are
        all taken as seen by the last run (ASSUMPTION, docs/batch.md).
    not_in_last_run : tuple of str
        Manifest paths with results of existing files that the last run was not given (rows kept by ``--resume``
        from an earlier run).
    """

    folder: Path
    task: str
    options: dict
    manifest: object
    segments: object
    n_inputs: int | None = None
    complete: bool | None = None
    missing_inputs: tuple = ()
    last_run: int | None = None
    not_in_last_run: tuple = ()

    def profile(self, route: str):
        """The per-sample table of one route (``reconstruct``: the reconstructed profile), as a DataFrame."""
        import pandas as pd

        path = partition_file(self.folder, route, PROFILES)
        if not path.is_file():
            raise InputFormatError(f"{self.folder} has no profile for route {route!r} (only `batch reconstruct` "
                                   "writes profiles, and only for files that succeeded).")
        return pd.read_parquet(path)


def read_results(folder) -> BatchResults:
    """Read the manifest and the segment dataset of a ``longprofile batch`` results folder.

    Raises
    ------
    InputError
        Not a results folder.
    InputFormatError
        A damaged folder (a partition listed as done is missing or unreadable).
    """
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    folder = Path(folder)
    manifest, info = read_manifest(folder)
    done = manifest[manifest["status"].isin(["ok", "skipped"])]
    tables = []
    for route in done["route"]:
        path = partition_file(folder, route, SEGMENTS)
        try:
            t = pq.read_table(path)
        except Exception as exc:
            raise InputFormatError(f"{path} (route {route!r}) is listed as done but cannot be read ({exc}); rerun the "
                                   "batch with --resume (it recomputes missing results) or --overwrite.") from None
        tables.append(t.add_column(0, "route", pa.array([route] * t.num_rows, pa.string())))
    if tables:
        segments = pa.concat_tables(tables, promote_options="default").to_pandas()
    else:
        segments = pd.DataFrame({"route": pd.Series(dtype=str), "file": pd.Series(dtype=str)})
    missing = tuple(str(p) for p in done["path"] if not Path(str(p)).exists())
    last = info.get("run")  # None: a folder written before session 38, every row taken as seen by the last run
    earlier = done["path"][done["run"] != last] if last is not None else done["path"][:0]
    unseen = tuple(str(p) for p in earlier if str(p) not in missing)
    return BatchResults(folder=folder, task=info.get("task", ""), options=info.get("options", {}),
                        manifest=manifest, segments=segments, n_inputs=info.get("n_inputs"),
                        complete=info.get("complete"), missing_inputs=missing,
                        last_run=None if last is None else int(last), not_in_last_run=unseen)


@dataclass(frozen=True, eq=False)
class NetworkSummary:
    """Network-level tables of a batch (what :func:`longprofile.report.write_network_report` draws).

    Attributes
    ----------
    results : BatchResults
    segments : pandas.DataFrame
        ``route, file, start, end`` (station unit), the IRI columns, ``segment_iri``, ``condition``
        (good / fair / poor / none) and ``counted`` (False for the rows of a route left out of the totals).
    routes : pandas.DataFrame
        Per route, worst mean first: ``route, file, start, end, length`` (length covered: overlapping windows
        counted once), ``segments, mean_iri`` (length-weighted), ``max_iri, good, fair, poor, none`` (share of the
        length, 0..1; none = no IRI, e.g. unmeasured), ``counted`` ("yes", or why the route is left out of the
        totals).
    worst : pandas.DataFrame
        The ``n_worst`` distinct worst areas of the counted routes, highest segment IRI first. Overlapping windows
        (continuous / overlapping modes) of one condition are merged: ``start, end`` is the extent of the area, the
        IRI columns those of its peak window (``peak_start, peak_end``), ``windows`` how many windows it spans.
    failed, warnings : pandas.DataFrame
        ``path, route, error`` of the files that failed in the last run; ``path, route, warning`` of flagged results.
    excluded : pandas.DataFrame
        ``path, route, reason, length`` of the routes with results left out of the totals.
    value_columns : tuple of str
        IRI columns of the report table (per track, then MRI/HRI).
    segment_iri : str
        How ``segment_iri`` is defined (which column, or the mean of the tracks).
    segment_iri_column : str or None
        The column ``segment_iri`` copies (MRI, or the only track), None when it is the mean of the tracks.
    iri_unit, station_unit : str
        ``"m/km"`` or ``"in/mi"``; ``"m"``, ``"ft"``...
    limits : (float, float)
        Good/poor condition limits in ``iri_unit``.
    length, mean_iri : float
        Length covered by the counted routes (station unit; overlapping windows counted once) and its
        length-weighted mean segment IRI (NaN without segments).
    share : dict
        Share of the length per condition (good, fair, poor, none = no IRI); they add up to 1.
    measured : float
        Measured part of ``length`` (without the gaps of ``--gaps restart``: segment length x ``valid_fraction``).
    overlapping : bool
        Whether segments overlap (windows of the continuous / overlapping modes).
    """

    results: BatchResults
    segments: object
    routes: object
    worst: object
    failed: object
    warnings: object
    value_columns: tuple[str, ...]
    segment_iri: str
    segment_iri_column: str | None
    iri_unit: str
    station_unit: str
    limits: tuple[float, float]
    length: float
    mean_iri: float
    share: dict
    measured: float = float("nan")
    excluded: object = None
    overlapping: bool = False

    @property
    def counts(self) -> dict:
        """Files of the last run by manifest status (ok, skipped, error); every row for a folder written before
        session 38 (no ``run`` column)."""
        m, last = self.results.manifest, self.results.last_run
        s = (m["status"] if last is None else m.loc[m["run"] == last, "status"]).value_counts()
        return {k: int(s.get(k, 0)) for k in ("ok", "skipped", "error")}


def _find(columns, pattern, what):
    for c in columns:
        m = pattern.match(str(c))
        if m:
            return c, (m.group("unit") or "")
    raise InputFormatError(f"the segment table has no {what} column (columns: {list(columns)}).")


def _left_out(results: BatchResults, seg, tracks, factor) -> dict:
    """Route -> why its results are left out of the network totals: its file no longer exists, the last run was not
    given it (a row kept by ``--resume`` from an earlier run), its IRI is implausible
    (:func:`longprofile.road.iri_plausibility`, the check behind the manifest's warning), or its content (sha256) is
    that of an earlier counted input (counted once)."""
    from ..road import iri_plausibility

    manifest = results.manifest
    done = manifest[manifest["status"].isin(["ok", "skipped"])].sort_values("path")
    missing, unseen = set(results.missing_inputs), set(results.not_in_last_run)
    reasons, first = {}, {}
    by_route = {r: g for r, g in seg.groupby("route", sort=False)} if len(seg) and tracks else {}
    for row in done.itertuples():
        route = str(row.route)
        if str(row.path) in missing:
            reasons[route] = "file no longer exists (results kept by --resume)"
            continue
        if str(row.path) in unseen:
            reasons[route] = f"not in the last run (run {int(row.run)} of {results.last_run}; results kept by --resume)"
            continue
        g = by_route.get(route)
        note = iri_plausibility(g[tracks].to_numpy(dtype=float) / factor, what="segment IRI") if g is not None else ""
        if note:
            reasons[route] = f"implausible IRI: {note}"
            continue
        digest = str(getattr(row, "sha256", "") or "")
        if digest:
            other = first.setdefault(digest, str(row.path))
            if other != str(row.path):
                reasons[route] = f"same content as {other}: counted once"
    return reasons


def _covered(out):
    """Length each segment stands for: to the next segment's start when they overlap (windows), else its own; the
    lengths of a route add up to the length its segments cover (ASSUMPTION, docs/batch.md: a window stands for the
    stretch up to the next window)."""
    import numpy as np
    import pandas as pd

    route = pd.factorize(out["route"])[0]  # grouping only: integer codes sort 10x faster than the strings
    start, end = out["start"].to_numpy(dtype=float), out["end"].to_numpy(dtype=float)
    pos = np.lexsort((end, start, route))
    s, e, r = start[pos], end[pos], route[pos]
    nxt = np.append(s[1:], np.nan)
    nxt[np.append(r[1:] != r[:-1], True)] = np.nan  # the last segment of each route
    covered = np.empty_like(start)
    covered[pos] = np.where(np.isfinite(nxt), np.clip(np.minimum(e, nxt) - s, 0.0, None), e - s)
    overlap = bool(np.any(np.isfinite(nxt) & (nxt < e - 1e-9 * np.maximum(1.0, np.abs(e)))))
    return covered, overlap


def _worst_areas(out, n_worst: int, overlapping: bool):
    """The ``n_worst`` distinct worst areas: without overlap, the worst segments; with overlapping windows, each
    chain of overlapping windows of one condition is one area (extent, peak window, window count), and an area
    overlapping one already listed is not listed again."""
    import numpy as np

    ok = out[np.isfinite(out["segment_iri"].to_numpy(dtype=float)) & out["counted"]]
    if not overlapping:
        return (ok.sort_values(["segment_iri", "route", "start"], ascending=[False, True, True])
                .head(int(n_worst)).drop(columns=["counted"]).reset_index(drop=True))
    ok = ok.sort_values(["route", "start", "end"], kind="stable").reset_index(drop=True)
    same = ((ok["route"] == ok["route"].shift()) & (ok["condition"] == ok["condition"].shift())
            & (ok["start"] < ok["end"].shift()))
    ok["_run"] = (~same).cumsum()
    g = ok.groupby("_run", sort=False)
    peaks = ok.loc[g["segment_iri"].idxmax()].copy()
    peaks["peak_start"], peaks["peak_end"] = peaks["start"], peaks["end"]
    peaks["start"], peaks["end"] = g["start"].min().to_numpy(), g["end"].max().to_numpy()
    peaks["windows"] = g.size().to_numpy()
    peaks = peaks.sort_values(["segment_iri", "route", "start"], ascending=[False, True, True])
    keep, taken = [], {}
    for idx, r in zip(peaks.index, peaks.itertuples()):
        if len(keep) >= int(n_worst):
            break
        if any(a < r.end and r.start < b for a, b in taken.get(r.route, ())):
            continue
        keep.append(idx)
        taken.setdefault(r.route, []).append((r.start, r.end))
    return peaks.loc[keep].drop(columns=["counted", "_run"]).reset_index(drop=True)


def summarize_network(results: BatchResults, *, limits_m_per_km=None, n_worst: int = 20) -> NetworkSummary:
    """Per-route and network tables of a batch: condition shares, length-weighted means, worst areas.

    Parameters
    ----------
    results : BatchResults
        From :func:`read_results`.
    limits_m_per_km : (float, float), optional
        Good/poor IRI limits in m/km (default :data:`longprofile.report.IRI_CONDITION_LIMITS`, FHWA 1.50 / 2.68),
        converted to the table's unit.
    n_worst : int
        Rows of the worst-segments table.

    Notes
    -----
    The *segment IRI* ranked and counted here is, segment by segment, the MRI where its file has two tracks (none
    where the segment has no MRI: a track under ``--min-valid`` or dead), else the mean of the IRIs of the tracks its
    file has (a network mixes one- and two-track files). A segment is good below the first limit, poor above the
    second, fair in between (the rule of the single-file report).

    Lengths are lengths covered: overlapping windows (continuous / overlapping modes) count once, each window for
    the stretch up to the next window's start. The totals (length, shares, mean, worst areas) leave out the routes of
    :func:`_left_out` (file gone, not given to the last run, implausible IRI, duplicate content); they stay listed
    in ``routes``.
    """
    import numpy as np
    import pandas as pd

    if limits_m_per_km is None:
        from ..report import IRI_CONDITION_LIMITS as limits_m_per_km
    seg = results.segments  # read only (a copy of a million rows cost 0.2 s)
    manifest = results.manifest
    last = manifest["run"] == results.last_run if results.last_run is not None else True  # failures of the last run
    failed = manifest.loc[(manifest["status"] == "error") & last, ["path", "route", "error"]].reset_index(drop=True)
    flagged = manifest.loc[(manifest["warning"].fillna("") != ""), ["path", "route", "warning"]].reset_index(drop=True)
    values = [c for c in seg.columns if _VALUE.match(str(c))]
    tracks = [c for c in values if _VALUE.match(str(c)).group("kind") == "iri"]
    unit_key = _VALUE.match(str(values[0])).group("unit") if values else "m_per_km"
    iri_unit, factor = IRI_UNITS[unit_key]
    limits = (float(limits_m_per_km[0]) * factor, float(limits_m_per_km[1]) * factor)
    if len(seg) and not values:
        raise InputFormatError(f"the segment table of {results.folder} has no IRI column (columns: {list(seg.columns)}).")
    if values:
        start, station_unit = _find(seg.columns, _START, "segment start")
        end, _ = _find(seg.columns, _END, "segment end")
    else:
        start, end, station_unit = "start", "end", "m"
        seg = seg.assign(start=pd.Series(dtype=float), end=pd.Series(dtype=float))
    mri = [c for c in values if _VALUE.match(str(c)).group("kind") == "mri"]
    # per file: a network mixes files of one and two tracks (each file's own columns, NaN in the others'): the MRI
    # where its file has two tracks, else the mean of the tracks it has (session 35: with one two-track file among 33,
    # the MRI column was taken for every row and 30 routes had no IRI). A row of a two-track file whose MRI is empty
    # (a track under --min-valid or dead, --gaps restart) has none, as its note says (session 38: the other track's
    # IRI alone rated it, the page calling it the MRI)
    by_row = seg[tracks].astype(float).mean(axis=1) if tracks else pd.Series(np.nan, index=seg.index)
    seg_iri = by_row
    if mri:
        two = seg[mri[0]].notna()  # rows of two-track files: an MRI, or (--gaps restart) the half car's valid length
        for c in seg.columns:
            if str(c).startswith("valid_length_hri_"):
                two |= seg[c].notna()
        seg_iri = seg[mri[0]].astype(float).where(two, by_row)
    single = mri[0] if mri else (tracks[0] if len(tracks) == 1 else None)
    source = single if single is not None and seg_iri.equals(seg[single].astype(float)) else None
    if source is not None:
        how = f"{source} (MRI: mean of the two tracks)" if mri else source
    elif mri:
        how = f"{mri[0]} (MRI) where a file has two tracks, else the mean of its tracks' IRIs"
    else:
        how = f"mean of {', '.join(tracks)}" if len(tracks) > 1 else "the track's IRI"
    good, poor = limits
    v = seg_iri.to_numpy(dtype=float)
    condition = np.where(~np.isfinite(v), "none", np.where(v < good, "good", np.where(v > poor, "poor", "fair")))
    out = pd.DataFrame({"route": seg["route"].astype(str), "file": seg["file"].astype(str),
                        "start": seg[start].astype(float), "end": seg[end].astype(float)})
    for c in values:
        out[c] = seg[c].astype(float)
    out["segment_iri"] = v
    out["condition"] = condition
    reasons = _left_out(results, out, tracks, factor)
    out["counted"] = ~out["route"].isin(list(reasons))
    length, overlapping = _covered(out)
    valid = seg["valid_fraction"].astype(float).fillna(0.0).to_numpy() if "valid_fraction" in seg else 1.0
    routes = _route_table(out, length, v, condition, reasons)
    w = out["counted"].to_numpy(dtype=bool)
    total = float(length[w].sum())
    rated = w & np.isfinite(v)
    share = {c: (float(length[w & (condition == c)].sum()) / total if total > 0 else float("nan"))
             for c in ("good", "fair", "poor", "none")}
    done = manifest[manifest["route"].astype(str).isin(list(reasons))]
    by_route = pd.Series(length).groupby(out["route"].astype(str).to_numpy()).sum()  # one pass, not one per route
    excluded = pd.DataFrame({"path": done["path"].astype(str).to_numpy(), "route": done["route"].astype(str).to_numpy(),
                             "reason": [reasons[str(r)] for r in done["route"]],
                             "length": [float(by_route.get(str(r), 0.0)) for r in done["route"]]})
    return NetworkSummary(results=results, segments=out, routes=routes,
                          worst=_worst_areas(out, n_worst, overlapping), failed=failed, warnings=flagged,
                          value_columns=tuple(values), segment_iri=how,
                          segment_iri_column=source, iri_unit=iri_unit, station_unit=station_unit,
                          limits=limits, length=total,
                          mean_iri=float(np.sum(v[rated] * length[rated]) / length[rated].sum()) if length[rated].sum() > 0
                          else float("nan"),
                          share=share, measured=float(np.sum((length * valid)[w])), excluded=excluded,
                          overlapping=overlapping)


def _route_table(out, length, v, condition, reasons):
    """Per route, worst mean first (see :class:`NetworkSummary`)."""
    import numpy as np
    import pandas as pd

    t = out[["route", "file", "start", "end", "segment_iri"]].assign(_len=length)
    t["_w"] = np.where(np.isfinite(v), v * length, 0.0)
    t["_wl"] = np.where(np.isfinite(v), length, 0.0)
    for c in ("good", "fair", "poor", "none"):
        t[f"_{c}"] = np.where(condition == c, length, 0.0)
    g = t.groupby("route", sort=False)
    lengths = g["_len"].sum()
    routes = pd.DataFrame({
        "route": list(g.groups),
        "file": g["file"].first().to_numpy(),
        "start": g["start"].min().to_numpy(), "end": g["end"].max().to_numpy(),
        "length": lengths.to_numpy(), "segments": g.size().to_numpy(),
        "mean_iri": (g["_w"].sum() / g["_wl"].sum().where(g["_wl"].sum() > 0)).to_numpy(),
        "max_iri": g["segment_iri"].max().to_numpy(),
        **{c: (g[f"_{c}"].sum() / lengths.where(lengths > 0)).to_numpy() for c in ("good", "fair", "poor", "none")},
    })
    routes["counted"] = [reasons.get(r, "yes") for r in routes["route"]]
    return routes.sort_values(["mean_iri", "route"], ascending=[False, True], na_position="last").reset_index(drop=True)
