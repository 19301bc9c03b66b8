"""Which run last saw each input (session 38): the manifest's ``run`` column, and a network report that counts only
the last run's inputs, listing the rows kept by ``--resume`` from earlier runs as "not in the last run". Folders
written before the column existed are read as before (ASSUMPTION: every row seen by the last run) and can be
resumed."""

import json
import tempfile
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.batch import IRITask, read_manifest, read_results, run_batch, summarize_network
from longprofile.cli.app import main

from .test_network_totals import _profile, _report

LENGTHS = {"a": 400.0, "b": 300.0, "c": 200.0}


def _files(folder: Path) -> dict:
    return {k: _profile(folder / "s" / f"{k}.csv", n, seed=i + 20) for i, (k, n) in enumerate(LENGTHS.items())}


def _make_old(folder: Path) -> None:
    """Rewrite a results folder's manifest as written before session 38: no ``run`` column, no ``run`` metadata."""
    path = folder / "manifest.parquet"
    table = pq.read_table(path)
    meta = dict(table.schema.metadata)
    info = json.loads(meta[b"longprofile.batch"])
    info.pop("run", None)
    meta[b"longprofile.batch"] = json.dumps(info, sort_keys=True).encode()
    table = table.drop_columns([c for c in ("run",) if c in table.column_names])
    pq.write_table(table.replace_schema_metadata(meta), path)


def test_two_runs_over_different_files_count_only_the_second_runs_files(tmp_path):
    f = _files(tmp_path)
    bad = tmp_path / "s" / "bad.csv"
    bad.write_text("not,a\nprofile,\n")
    run_batch(IRITask(), [f["a"], f["b"], bad], tmp_path / "r", executor="serial")
    run_batch(IRITask(), [f["b"], f["c"]], tmp_path / "r", executor="serial", resume=True)
    manifest, info = read_manifest(tmp_path / "r")
    assert info["run"] == 2
    assert dict(zip(manifest.route, manifest.run)) == {"a": 1, "b": 2, "c": 2, "bad": 1}
    assert dict(zip(manifest.route, manifest.status))["b"] == "skipped"  # skipped rows are stamped too
    s, page = _report(tmp_path / "r", tmp_path / "rep")
    assert s.length == pytest.approx(LENGTHS["b"] + LENGTHS["c"])  # not a, which still exists
    assert list(s.excluded.route) == ["a"] and s.excluded.length.tolist() == pytest.approx([LENGTHS["a"]])
    assert s.excluded.reason.iloc[0].startswith("not in the last run")
    assert s.routes.set_index("route").counted["a"].startswith("not in the last run")
    assert s.counts == {"ok": 1, "skipped": 1, "error": 0} and len(s.failed) == 0  # bad.csv failed in run 1 only
    assert "not in the last run" in page and "0.4 km" in page and "2 / 2 done" in page
    assert "more existing file(s)" not in page


@settings(max_examples=6, deadline=None)
@given(st.lists(st.sets(st.sampled_from(sorted(LENGTHS)), min_size=1), min_size=1, max_size=3))
def test_the_report_counts_exactly_the_last_runs_inputs(runs):
    with tempfile.TemporaryDirectory() as tmp:
        f = _files(Path(tmp))
        for i, names in enumerate(runs):
            run_batch(IRITask(), [f[k] for k in sorted(names)], Path(tmp) / "r", executor="serial", resume=i > 0)
        s = summarize_network(read_results(Path(tmp) / "r"))
        seen = set().union(*runs)
        assert s.length == pytest.approx(sum(LENGTHS[k] for k in runs[-1]))
        assert set(s.excluded.route) == seen - runs[-1]
        assert all(r.startswith("not in the last run") for r in s.excluded.reason)


def test_an_old_manifest_without_the_run_column_is_read_as_before_and_resumed(tmp_path):
    f = _files(tmp_path)
    out = tmp_path / "r"
    run_batch(IRITask(), [f["a"], f["b"]], out, executor="serial")
    run_batch(IRITask(), [f["b"]], out, executor="serial", resume=True)
    _make_old(out)
    # ASSUMPTION: every row seen by the last run: a (not given to the last run) is counted, as before session 38
    res = read_results(out)
    assert res.last_run is None and res.not_in_last_run == () and set(res.manifest.run) == {0}
    s, page = _report(out, tmp_path / "rep")
    assert s.length == pytest.approx(LENGTHS["a"] + LENGTHS["b"]) and len(s.excluded) == 0
    assert "1 more existing file(s)" in page
    # --resume on the old folder: same options hash (not refused), unchanged files skipped, runs recorded from now on
    assert main(["batch", "iri", str(f["b"]), str(f["c"]), "-o", str(out), "--scheduler", "serial", "--resume"]) == 0
    manifest, info = read_manifest(out)
    assert info["run"] == 1 and dict(zip(manifest.route, manifest.run)) == {"a": 0, "b": 1, "c": 1}
    assert dict(zip(manifest.route, manifest.status)) == {"a": "ok", "b": "skipped", "c": "ok"}
    s, page = _report(out, tmp_path / "rep2")
    assert s.length == pytest.approx(LENGTHS["b"] + LENGTHS["c"]) and list(s.excluded.route) == ["a"]
    assert "not in the last run" in page
