"""What the network report counts (session 37, a network-survey engineer's trial): the surveyed length with
overlapping windows counted once and each defect once, the measured length beside the gaps, files left out of the
totals (implausible IRI, duplicate content, inputs gone after --resume), and unit-named CSV columns. Results folders
built with ``batch iri`` on small simulated profiles."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.batch import BatchResults, IRITask, read_results, run_batch, summarize_network
from longprofile.report import write_network_report

DX = 0.1


def _profile(path: Path, length: float, *, seed: int, scale_mm: float = 1.0, bump_at=None, gap=None,
             gd: float = 6e-6) -> Path:
    """A two-track ISO 8608 class-B-like profile as CSV (distance_m, left_mm, right_mm): elevations x ``scale_mm``
    (1e-3: metres under the mm label), a 30 mm bump over 2 m at ``bump_at``, NaN over ``gap`` = (from, to) m."""
    from longprofile.road import iso8608_profile

    p = iso8608_profile(length, DX, gd, rng=seed, tracks=("left", "right"))
    x = np.asarray(p.distance, float)
    z = np.asarray(p.elevation, float) * 1000.0  # mm
    if bump_at is not None:
        z[(x >= bump_at) & (x < bump_at + 2.0)] += 30.0
    if gap is not None:
        z[(x >= gap[0]) & (x < gap[1])] = np.nan
    path.parent.mkdir(parents=True, exist_ok=True)
    pd.DataFrame({"distance_m": x, "left_mm": z[:, 0] * scale_mm, "right_mm": z[:, -1] * scale_mm}).to_csv(
        path, index=False)
    return path


def _report(results, out):
    summary = summarize_network(read_results(results))
    write_network_report(summary, out, inputs=(results,))
    return summary, (out / "index.html").read_text()


def test_continuous_mode_counts_the_surveyed_length_once_and_each_defect_once(tmp_path):
    files = [_profile(tmp_path / "s" / "a.csv", 300.0, seed=1, bump_at=150.0),
             _profile(tmp_path / "s" / "b.csv", 200.0, seed=2)]
    run_batch(IRITask(mode="continuous", window=10.0, step=0.5), files, tmp_path / "r", executor="serial")
    s, page = _report(tmp_path / "r", tmp_path / "rep")
    # each window is 10 m long, one every 0.5 m: the windows sum to ~20 times the road; the length covered is the road
    assert (s.segments.end - s.segments.start).sum() > 10 * 500.0
    assert s.length == pytest.approx(500.0, abs=2 * 10.0)
    assert s.routes.set_index("route").length.to_dict() == pytest.approx({"a": 300.0, "b": 200.0}, abs=10.0)
    assert sum(s.share.values()) == pytest.approx(1.0) and s.overlapping
    # worst areas: distinct (none overlaps another of its route), the bump reported once, its peak inside its extent
    for _, g in s.worst.groupby("route"):
        iv = sorted(zip(g.start, g.end))
        assert all(e0 <= s1 for (_, e0), (s1, _) in zip(iv, iv[1:]))
    top = s.worst.iloc[0]
    assert top.route == "a" and top.start <= 150.0 + 2.0 and top.end >= 150.0
    assert top.start <= top.peak_start and top.peak_end <= top.end and top.windows > 1
    assert ((s.worst.route == "a") & (s.worst.start < 152.0) & (s.worst.end > 150.0)).sum() == 1
    assert "0.5 km" in page and "overlapping windows counted once" in page


def test_gaps_give_the_measured_length_and_a_labelled_no_iri_share(tmp_path):
    files = [_profile(tmp_path / "s" / "a.csv", 500.0, seed=3, gap=(150.0, 350.0)),
             _profile(tmp_path / "s" / "b.csv", 500.0, seed=4)]
    run_batch(IRITask(gaps="restart"), files, tmp_path / "r", executor="serial")
    s, page = _report(tmp_path / "r", tmp_path / "rep")
    assert s.length == pytest.approx(1000.0, abs=1.0)
    assert "0.8 km" in page and "0.2 km unmeasured" in page
    assert s.measured == pytest.approx(800.0, abs=1.0)
    assert sum(s.share.values()) == pytest.approx(1.0) and s.share["none"] >= 0.1
    assert "0.8 km" in page and "0.2 km unmeasured" in page and "no IRI" in page


def test_a_dead_track_file_is_ok_and_its_length_unmeasured_not_rated_by_one_track(tmp_path):
    """Session 38: a file whose right laser is dead (every elevation empty) is computed (the left track's IRI kept in
    its rows, a warning in the manifest) and its length is unmeasured in the totals, in "no IRI" -- as is a segment
    of a two-track file whose right track is measured under --min-valid: the left IRI alone is not its MRI."""
    dead = _profile(tmp_path / "s" / "dead.csv", 500.0, seed=12)
    d = pd.read_csv(dead)
    d["right_mm"] = np.nan
    d.to_csv(dead, index=False)
    part = _profile(tmp_path / "s" / "part.csv", 500.0, seed=13)
    d = pd.read_csv(part)
    d.loc[(d.distance_m > 220.0) & (d.distance_m < 260.0), "right_mm"] = np.nan  # 200-300: right 60 % measured
    d.to_csv(part, index=False)
    files = [dead, part, _profile(tmp_path / "s" / "good.csv", 500.0, seed=14)]
    run_batch(IRITask(gaps="restart"), files, tmp_path / "r", executor="serial")
    res = read_results(tmp_path / "r")
    m = res.manifest.set_index("route")
    assert (m.status == "ok").all() and m.warning["dead"].startswith("track(s) 'right' have no measured run")
    rows = res.segments.set_index(["route", "start_m"])
    assert rows.loc["dead", "iri_left_m_per_km"].notna().all() and rows.loc["part", "iri_left_m_per_km"].notna().all()
    s, page = _report(tmp_path / "r", tmp_path / "rep")
    routes = s.routes.set_index("route")
    assert routes.none["dead"] == 1.0 and np.isnan(routes.mean_iri["dead"])
    assert routes.none["part"] == pytest.approx(0.2) and routes.none["good"] == 0.0
    assert s.length == pytest.approx(1500.0, abs=1.0) and s.share["none"] == pytest.approx(600.0 / 1500.0, abs=1e-3)
    # the unmeasured length is the dead file's 500 m and the part's 40 m of the right track (valid_fraction 0.6)
    assert s.measured == pytest.approx(1500.0 - 500.0 - 40.0, abs=1.0)
    assert "0.5 km unmeasured" in page and "Results to check (2)" in page  # the dead file and the gap


def test_a_flagged_implausible_file_is_left_out_of_the_totals(tmp_path):
    files = [_profile(tmp_path / "s" / "metres.csv", 400.0, seed=5, scale_mm=1e-3),
             _profile(tmp_path / "s" / "ok.csv", 400.0, seed=6, gd=20e-6)]
    run_batch(IRITask(), files, tmp_path / "r", executor="serial")
    res = read_results(tmp_path / "r")
    assert "below any paved road" in res.manifest.set_index("route").warning["metres"]
    s, page = _report(tmp_path / "r", tmp_path / "rep")
    ok = s.routes.set_index("route").loc["ok"]
    assert s.length == pytest.approx(400.0) and ok.good < 0.5  # the metres file alone would be 100 % good
    assert [s.share[c] for c in ("good", "fair", "poor")] == pytest.approx([ok.good, ok.fair, ok.poor])
    assert list(s.excluded.route) == ["metres"] and s.excluded.length.iloc[0] == pytest.approx(400.0)
    assert set(s.worst.route) == {"ok"} and set(s.routes.route) == {"metres", "ok"}
    assert "Left out of the totals" in page and "implausible IRI" in page
    routes = pd.read_csv(tmp_path / "rep" / "routes.csv").set_index("route")
    assert routes.counted["ok"] == "yes" and routes.counted["metres"].startswith("implausible IRI")


def test_the_same_content_under_two_names_is_counted_once_and_listed_twice(tmp_path):
    a = _profile(tmp_path / "s" / "a.csv", 400.0, seed=7)
    b = tmp_path / "s" / "copy_of_a.csv"
    b.write_bytes(a.read_bytes())
    run_batch(IRITask(), [a, b], tmp_path / "r", executor="serial")
    s, page = _report(tmp_path / "r", tmp_path / "rep")
    assert s.length == pytest.approx(400.0)
    assert set(s.routes.route) == {"a", "copy_of_a"} and list(s.excluded.route) == ["copy_of_a"]
    assert "counted once" in s.excluded.reason.iloc[0]
    assert s.worst.route.nunique() == 1


def test_inputs_deleted_or_renamed_after_resume_are_marked_and_left_out(tmp_path):
    a = _profile(tmp_path / "s" / "a.csv", 400.0, seed=8)
    b = _profile(tmp_path / "s" / "b.csv", 300.0, seed=9)
    c = _profile(tmp_path / "s" / "c.csv", 200.0, seed=10)
    run_batch(IRITask(), [a, b, c], tmp_path / "r", executor="serial")
    b.unlink()
    c.rename(tmp_path / "s" / "c2.csv")
    run_batch(IRITask(), [a, tmp_path / "s" / "c2.csv"], tmp_path / "r", executor="serial", resume=True)
    s, page = _report(tmp_path / "r", tmp_path / "rep")
    assert s.length == pytest.approx(600.0)  # a + c2, not b nor c
    assert sorted(s.excluded.route) == ["b", "c"]
    assert all(r.startswith("file no longer exists") for r in s.excluded.reason)
    assert "file no longer exists" in page and "0.5 km" in page


def test_us_units_name_the_units_in_the_csv_columns_and_the_page(tmp_path):
    files = [_profile(tmp_path / "s" / "a.csv", 400.0, seed=11)]
    run_batch(IRITask(units="us"), files, tmp_path / "r", executor="serial")
    s, page = _report(tmp_path / "r", tmp_path / "rep")
    routes = pd.read_csv(tmp_path / "rep" / "routes.csv")
    worst = pd.read_csv(tmp_path / "rep" / "worst_segments.csv")
    for col in ("start_ft", "end_ft", "length_ft", "mean_iri_in_per_mi", "max_iri_in_per_mi"):
        assert col in routes.columns and f"<th>{col}</th>" in page
    assert {"start_ft", "end_ft", "segment_iri_in_per_mi"} <= set(worst.columns)
    assert not {"start", "end", "length", "mean_iri", "start_m", "segment_iri"} & (set(routes.columns) | set(worst.columns))
    assert "start_m" not in page and "mean_iri_m_per_km" not in page
    assert routes.mean_iri_in_per_mi.iloc[0] == pytest.approx(s.routes.mean_iri.iloc[0])


def _union(intervals) -> float:
    """Length of a union of intervals (a sweep over them sorted: the oracle)."""
    total, hi = 0.0, -np.inf
    for a, b in sorted(intervals):
        if b > hi:
            total += b - max(a, hi)
            hi = b
    return total


@settings(max_examples=60, deadline=None)
@given(st.dictionaries(st.sampled_from(["a", "b", "c"]), st.tuples(
    st.sampled_from([5.0, 7.62, 100.0]),
    st.lists(st.floats(0.05, 150.0), min_size=1, max_size=25),
    st.lists(st.floats(0.6, 12.0), min_size=25, max_size=25)), min_size=1))
def test_windows_of_any_spacing_count_the_union_of_the_road_and_distinct_worst_areas(routes):
    """The length of a network of equal-length windows at any spacing (overlapping or with gaps) is the length of
    the union of its windows per route, and no two worst areas of a route overlap."""
    rows, manifest = [], []
    for name, (window, steps, values) in routes.items():
        starts = np.cumsum([0.0] + steps[:-1])
        rows += [{"route": name, "file": f"/d/{name}", "start_m": x, "end_m": x + window, "iri_left_m_per_km": v}
                 for x, v in zip(starts, values)]
        manifest.append({"path": f"/d/{name}", "route": name, "status": "ok", "error": "", "warning": "",
                         "longprofile_version": "0"})
    res = BatchResults(folder=Path("/d/r"), task="iri", options={}, manifest=pd.DataFrame(manifest),
                       segments=pd.DataFrame(rows))
    s = summarize_network(res, n_worst=1000)
    want = sum(_union([(x, x + w) for x in np.cumsum([0.0] + st_[:-1])]) for w, st_, _ in routes.values())
    assert s.length == pytest.approx(want)
    assert sum(s.share.values()) == pytest.approx(1.0)
    for _, g in s.worst.groupby("route"):
        iv = sorted(zip(g.start, g.end))
        assert all(e0 <= s1 + 1e-9 for (_, e0), (s1, _) in zip(iv, iv[1:]))
    assert s.worst.segment_iri.iloc[0] == pytest.approx(max(max(v[:len(st_)]) for _, st_, v in routes.values()))
