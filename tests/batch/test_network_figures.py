"""The network report's figures at network scale (session 38): drawn at the figure's resolution, tables unchanged.

A network of 1.3 million overlapping windows took 45 s in ``batch report``, most of it drawing one rectangle (and one
stair step) per window. The figures are now reduced to a few elements per pixel; these tests count what is drawn,
check the reduction against brute-force oracles, and pin the report's tables to the bytes the report wrote before.
"""

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.batch import BatchResults, summarize_network
from longprofile.report import write_network_report
from longprofile.report._network import condition_spans, plot_network_routes, plot_worst_routes, step_envelope

_TIES = (2, 1, 0, 3, 4)  # poor, fair, good, none, then "no segment": the order a tie is given in a bin


def _windows(route, n, *, step=0.05, window=7.62, centre=1.5, seed=0, two_tracks=True):
    """``n`` overlapping windows of one route, IRI scattered around ``centre`` m/km (conditions alternating)."""
    rng = np.random.default_rng(seed)
    s = np.arange(n) * step
    v = centre + 0.05 * rng.standard_normal(n) + 1.3 * (np.sin(s / 40.0) > 0.8)
    row = {"route": route, "file": f"/data/{route}.erd", "start_m": s, "end_m": s + window, "iri_left_m_per_km": 0.9 * v}
    if two_tracks:
        row.update({"iri_right_m_per_km": 1.1 * v, "mri_m_per_km": v, "hri_m_per_km": 0.7 * v})
    return pd.DataFrame(row)


def _network(frames):
    manifest = pd.DataFrame([{"path": f"/data/{f['route'].iloc[0]}.erd", "route": f["route"].iloc[0], "status": "ok",
                              "error": "", "warning": "", "longprofile_version": "0"} for f in frames])
    return BatchResults(folder=Path("/data/results"), task="iri", options={}, manifest=manifest,
                        segments=pd.concat(frames, ignore_index=True))


def _shown(start, end):
    """Brute force: the stretch each segment shows (to the next segment's start, or its own end if sooner)."""
    return [(s, min(e, start[i + 1]) if i + 1 < len(start) else e) for i, (s, e) in enumerate(zip(start, end))]


segments = st.lists(st.tuples(st.floats(0.0, 30.0), st.floats(0.5, 40.0), st.integers(0, 3)), min_size=1,
                    max_size=60)


def _segment_arrays(items):
    gaps, lengths, codes = (np.array(x) for x in zip(*items))
    start = np.cumsum(gaps * 0.3)  # windows every 0..9 m, some longer than the spacing (overlap), some shorter (gap)
    return start, start + lengths, codes.astype(int)


@settings(max_examples=150)
@given(segments)
def test_strip_rectangles_cover_each_condition_over_the_length_it_shows(items):
    start, end, code = _segment_arrays(items)
    x0, w, c = condition_spans(start, end, code, start[0], end.max(), bins=len(items))  # enough bins: exact
    shown = _shown(start, end)
    for k in range(4):
        want = sum(b - a for (a, b), ck in zip(shown, code) if ck == k and b > a)
        assert np.isclose(w[c == k].sum(), want, rtol=1e-9, atol=1e-9)
    assert np.all(w > 0) and np.all(x0[1:] >= x0[:-1] + w[:-1] - 1e-9)  # ordered, not overlapping
    assert len(x0) <= len(items)


@settings(max_examples=150)
@given(st.lists(st.tuples(st.floats(0.1, 30.0), st.floats(0.5, 40.0), st.integers(1, 3)), min_size=2, max_size=60),
       st.integers(1, 12))
def test_a_strip_with_more_changes_than_bins_gives_each_bin_its_majority_condition(items, bins):
    start, end, steps = _segment_arrays(items)
    code = np.cumsum(steps) % 4  # each segment's condition differs from the one before: as many runs as segments
    lo, hi = start[0], end.max()
    x0, w, c = condition_spans(start, end, code, lo, hi, bins)
    assert len(x0) <= max(bins, len(items))
    if len(items) <= bins:
        return
    assert len(x0) <= bins
    edges = np.linspace(lo, hi, bins + 1)
    for b in range(bins):
        a, z = edges[b], edges[b + 1]
        share = np.zeros(5)
        for (s, e), ck in zip(_shown(start, end), code):
            share[ck] += max(0.0, min(e, z) - max(s, a))
        share[4] = (z - a) - share[:4].sum()
        top = sorted(share, reverse=True)
        if top[0] - top[1] < 1e-7 * (hi - lo):
            continue  # a near tie
        want = _TIES[int(np.argmax(share[list(_TIES)]))]
        mid = 0.5 * (a + z)
        inside = np.flatnonzero((x0 <= mid) & (mid < x0 + w))
        assert (int(c[inside[0]]) if inside.size else 4) == want


@settings(max_examples=150)
@given(st.lists(st.floats(0.0, 10.0) | st.just(float("nan")), min_size=1, max_size=300), st.integers(1, 20))
def test_the_step_line_keeps_each_bins_first_last_lowest_and_highest_value(values, bins):
    y = np.array(values)
    start = np.arange(y.size) * 0.25
    keep = step_envelope(start, y, bins)
    assert np.all(np.diff(keep) > 0)
    if y.size <= 4 * bins:
        np.testing.assert_array_equal(keep, np.arange(y.size))
        return
    assert keep.size <= 6 * bins
    span = start[-1] - start[0]
    binof = np.minimum((start / span * bins).astype(int), bins - 1)
    for b in np.unique(binof):
        idx = np.flatnonzero(binof == b)
        kept = np.intersect1d(keep, idx)
        assert kept[0] == idx[0] and kept[-1] == idx[-1]
        if np.isfinite(y[idx]).any():
            assert np.nanmin(y[kept]) == np.nanmin(y[idx]) and np.nanmax(y[kept]) == np.nanmax(y[idx])


def test_figures_of_a_route_of_60000_windows_are_drawn_from_a_few_elements_per_pixel():
    summary = summarize_network(_network([_windows("A", 60_000, seed=1), _windows("B", 40_000, seed=2)]))
    fig = plot_network_routes(summary, ["A", "B"])
    ax = fig.axes[0]
    pixels = ax.get_window_extent().width
    rectangles = sum(len(coll.get_paths()) for coll in ax.collections)
    assert 0 < rectangles <= 2 * np.ceil(2 * pixels)  # two routes, at most 2 per pixel each (drew 100 000)
    drawn = {tuple(np.round(col, 6)) for col in ax.collections[0].get_facecolors()}
    assert len(drawn) >= 2  # both conditions of the alternating routes are shown
    fig = plot_worst_routes(summary, ["A", "B"])
    for ax, route in zip(fig.axes, ["A", "B"]):
        (line,) = [p for p in ax.patches if type(p).__name__ == "StepPatch"]
        values = line.get_data().values
        assert values.size <= 6 * np.ceil(2 * ax.get_window_extent().width)  # drew one step per window
        peak = summary.routes.set_index("route").loc[route, "max_iri"]
        assert np.nanmax(values) == peak  # the envelope keeps the route's highest segment IRI
        assert np.nanmin(values) == summary.segments.query("route == @route").segment_iri.min()


# routes.csv and worst_segments.csv of this network, written by the report before the figures were reduced
# (session 38, recorded with the previous src/longprofile/report/_network.py and batch/_results.py)
_TABLE_DIGESTS = {
    "routes.csv": "1dfb9cf88bac925471854b2fad672553d741a8b6bb9b642f4bdf15e8702f51d0",
    "worst_segments.csv": "ab6399b7d6cea39025a854831a0270ea8f2cdf76181fd31f7f4120fdfe614265",
}


def test_the_report_tables_are_those_written_before_the_figures_were_reduced(tmp_path):
    frames = [_windows("R2/lane-1", 800, step=2.0, window=10.0, centre=1.2, seed=5, two_tracks=False),
              _windows("R1/lane-2", 2500, step=0.25, centre=2.4, seed=4), _windows("R1/lane-1", 3000, seed=3)]
    write_network_report(summarize_network(_network(frames), n_worst=15), tmp_path / "net")
    for name, digest in _TABLE_DIGESTS.items():
        assert hashlib.sha256((tmp_path / "net" / name).read_bytes()).hexdigest() == digest, name


def test_route_names_and_panel_titles_are_not_cut_or_overlapped():
    """Route names of 34 characters fit left of the strips (they were cut at the figure's edge), and each worst-route
    panel's title clears the tick labels of the panel above (they overlapped its "0")."""
    names = [f"surveys/district-{k:02d}/route-A{k}/lane-1"[-34:] for k in range(3)]
    summary = summarize_network(_network([_windows(r, 400, seed=k) for k, r in enumerate(names)]))
    fig = plot_network_routes(summary, names)
    renderer = fig.canvas.get_renderer()
    labels = [t for t in fig.axes[0].get_yticklabels() if t.get_text()]
    assert len(labels) == 3 and min(t.get_window_extent(renderer).x0 for t in labels) >= 0.0
    fig = plot_worst_routes(summary, names)
    renderer = fig.canvas.get_renderer()
    for above, below in zip(fig.axes[:-1], fig.axes[1:]):
        ticks = [t.get_window_extent(renderer) for t in above.get_xticklabels() if t.get_text()]
        title = next(t for t in below.get_children() if getattr(t, "get_text", lambda: "")() in names)
        assert ticks and title.get_window_extent(renderer).y1 < min(b.y0 for b in ticks)  # display y points up
