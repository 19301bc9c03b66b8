"""summarize_network (properties on random networks) and write_network_report (the page a person reads)."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.batch import BatchResults, summarize_network
from longprofile.errors import InputFormatError, OutputError
from longprofile.report import IRI_CONDITION_LIMITS, write_network_report


def _results(routes, *, units="si", failed=(), two_tracks=True):
    """A BatchResults built in memory: routes = {name: (start, segment length, [IRI per segment])}."""
    lu, iu = ("m", "m_per_km") if units == "si" else ("ft", "in_per_mi")
    rows, manifest = [], []
    for name, (x0, seg, values) in routes.items():
        for k, v in enumerate(values):
            v = v * (1.0 if units == "si" else 63.36)  # values given in m/km
            row = {"route": name, "file": f"/data/{name}.erd", f"start_{lu}": x0 + k * seg,
                   f"end_{lu}": x0 + (k + 1) * seg, f"iri_left_{iu}": v * 0.9}
            if two_tracks:
                row.update({f"iri_right_{iu}": v * 1.1, f"mri_{iu}": v, f"hri_{iu}": v * 0.7})
            rows.append(row)
        manifest.append({"path": f"/data/{name}.erd", "route": name, "status": "ok", "error": "", "warning": "",
                         "longprofile_version": "0"})
    for name, err in failed:
        manifest.append({"path": f"/data/{name}", "route": name, "status": "error", "error": err, "warning": "",
                         "longprofile_version": "0"})
    seg = pd.DataFrame(rows) if rows else pd.DataFrame({"route": pd.Series(dtype=str), "file": pd.Series(dtype=str)})
    return BatchResults(folder=Path("/data/results"), task="iri", options={}, manifest=pd.DataFrame(manifest),
                        segments=seg)


iri_values = st.lists(st.floats(0.6, 12.0) | st.just(float("nan")), min_size=1, max_size=15)
networks = st.dictionaries(st.text("ABCR0123/", min_size=1, max_size=6), st.tuples(
    st.sampled_from([0.0, 250.0]), st.sampled_from([20.0, 100.0]), iri_values), min_size=1, max_size=6)


@settings(max_examples=60)
@given(networks, st.sampled_from(["si", "us"]), st.booleans())
def test_summary_shares_means_and_ranking(routes, units, two_tracks):
    s = summarize_network(_results(routes, units=units, two_tracks=two_tracks), n_worst=5)
    factor = 1.0 if units == "si" else 63.36
    assert s.limits == pytest.approx((IRI_CONDITION_LIMITS[0] * factor, IRI_CONDITION_LIMITS[1] * factor))
    assert s.iri_unit == ("m/km" if units == "si" else "in/mi") and s.station_unit == ("m" if units == "si" else "ft")
    assert sum(s.share.values()) == pytest.approx(1.0)
    length = (s.segments.end - s.segments.start).to_numpy()
    v = s.segments.segment_iri.to_numpy()
    ok = np.isfinite(v)
    assert s.length == pytest.approx(length.sum())
    if ok.any():
        assert s.mean_iri == pytest.approx(np.sum(v[ok] * length[ok]) / np.sum(length[ok]))
    # segment IRI: the MRI with two tracks, the track's IRI with one
    want = s.segments[s.value_columns[2]] if two_tracks else s.segments[s.value_columns[0]]
    np.testing.assert_array_equal(v, want.to_numpy())
    good, poor = s.limits
    cond = np.where(~ok, "none", np.where(v < good, "good", np.where(v > poor, "poor", "fair")))
    np.testing.assert_array_equal(s.segments.condition.to_numpy(), cond)
    # worst segments: the n largest finite, in order
    assert list(s.worst.segment_iri) == sorted(v[ok], reverse=True)[:5]
    # routes, worst mean first; per-route shares add up to 1
    m = s.routes.mean_iri.to_numpy()
    finite = m[np.isfinite(m)]
    assert np.all(np.diff(finite) <= 0) and np.all(np.isnan(m[finite.size:]))
    assert set(s.routes.route) == set(routes)
    shares = (s.routes[["good", "fair", "poor"]].sum(axis=1) + s.segments.assign(l=length).query(
        "condition == 'none'").groupby("route").l.sum().reindex(s.routes.route).fillna(0).to_numpy()
        / s.routes.length.to_numpy())
    np.testing.assert_allclose(shares, 1.0)


def test_a_table_without_iri_columns_is_refused():
    res = _results({"a": (0.0, 100.0, [1.0])})
    bad = BatchResults(res.folder, res.task, res.options, res.manifest,
                       res.segments.drop(columns=[c for c in res.segments.columns if "per_km" in c]))
    with pytest.raises(InputFormatError, match="no IRI column"):
        summarize_network(bad)


def test_page_lists_failed_files_escaped_and_every_section(tmp_path):
    routes = {f"R{i}/lane1": (0.0, 100.0, list(np.linspace(0.8, 4.0, 12) * (0.5 + 0.3 * i))) for i in range(5)}
    failed = [("R9/<evil>.erd", "R9/<evil>.erd: no END line closing the header"), ("R8/x.csv", "KeyError: 'x'")]
    summary = summarize_network(_results(routes, failed=failed))
    files = write_network_report(summary, tmp_path / "net")
    page = (tmp_path / "net" / "index.html").read_text()
    assert files[0].name == "index.html" and all(f.exists() for f in files)
    assert "Files that failed (2)" in page and "&lt;evil&gt;.erd" in page and "<evil>" not in page
    assert "KeyError: &#x27;x&#x27;" in page
    for section in ("Condition along each route", "IRI along the worst routes", "Distribution of the segment IRI",
                    "Worst segments", "Routes, worst mean IRI first"):
        assert section in page
    assert page.count("data:image/png;base64,") == 3
    assert pd.read_csv(tmp_path / "net" / "routes.csv").route.tolist() == summary.routes.route.tolist()


def test_many_routes_are_split_over_figures_and_a_smaller_rerun_removes_stale_ones(tmp_path):
    routes = {f"r{i:03d}": (0.0, 100.0, [1.0 + i / 50, 2.0, 3.0]) for i in range(90)}
    write_network_report(summarize_network(_results(routes)), tmp_path / "net")
    assert sorted(p.name for p in (tmp_path / "net").glob("routes-*.png")) == [
        "routes-01.png", "routes-02.png", "routes-03.png"]
    write_network_report(summarize_network(_results(dict(list(routes.items())[:10]))), tmp_path / "net")
    assert [p.name for p in (tmp_path / "net").glob("routes-*.png")] == ["routes-01.png"]


def test_nothing_succeeded_still_gives_a_page_of_failures(tmp_path):
    summary = summarize_network(_results({}, failed=[("a.erd", "broken")]))
    write_network_report(summary, tmp_path / "net")
    page = (tmp_path / "net" / "index.html").read_text()
    assert "Files that failed (1)" in page and "broken" in page and "No route has results" in page
    assert "nan" not in page.lower()


def test_report_folder_must_not_be_the_results_folder_or_a_file(tmp_path):
    summary = summarize_network(_results({"a": (0.0, 100.0, [1.0, 2.0])}))
    with pytest.raises(OutputError, match="is an input"):
        write_network_report(summary, tmp_path, inputs=(tmp_path,))
    (tmp_path / "f").write_text("")
    with pytest.raises(OutputError, match="is a file"):
        write_network_report(summary, tmp_path / "f")


def test_a_network_of_one_and_two_track_files_ranks_every_segment():
    """33 files of which 3 had two tracks: the MRI column was taken for every row, and 30 routes had no IRI in the
    report (session 35, a probe). Per segment: the MRI where its file has one, else its track's IRI."""
    two = _results({"A": (0.0, 100.0, [2.0, 3.0])}, two_tracks=True)
    one = _results({"B": (0.0, 100.0, [1.0, 4.0]), "C": (0.0, 100.0, [5.0])}, two_tracks=False)
    seg = pd.concat([two.segments, one.segments], ignore_index=True)
    mixed = BatchResults(folder=two.folder, task="iri", options={},
                         manifest=pd.concat([two.manifest, one.manifest], ignore_index=True), segments=seg)
    s = summarize_network(mixed)
    by = s.segments.set_index(["route", "start"])["segment_iri"]
    assert by[("A", 0.0)] == 2.0 and by[("A", 100.0)] == 3.0  # the MRI
    assert by[("B", 0.0)] == pytest.approx(0.9) and by[("C", 0.0)] == pytest.approx(4.5)  # the one track's IRI
    assert s.routes["mean_iri"].notna().all() and s.share["none"] == 0.0
    assert "where a file has two tracks" in s.segment_iri
