"""One folder check for every report (before any work), and every report file written atomically."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from longprofile.errors import OutputError


def test_report_folder_as_a_precheck_creates_nothing_and_protects_inputs(tmp_path):
    from longprofile.report import report_folder

    out = tmp_path / "out"
    assert report_folder(out, (), writes=("runs.csv",), overwrite=False, create=False) == out
    assert not out.exists()
    out.mkdir()
    ref = out / "runs.csv"
    ref.write_text("keep")
    with pytest.raises(OutputError, match="would overwrite its input"):
        report_folder(out, (ref,), writes=("runs.csv",), overwrite=True, create=False)
    with pytest.raises(OutputError, match="is an input"):
        report_folder(out, (out,), overwrite=True)
    with pytest.raises(OutputError, match="is a file; give a folder, e.g. x_compare/"):
        report_folder(ref, (), hint="give a folder, e.g. x_compare/")
    assert ref.read_text() == "keep"


def test_write_rail_report_uses_the_folder_check_before_any_work(tmp_path):
    from longprofile.report import write_rail_report

    site = tmp_path / "site"
    site.mkdir()
    (site / "sensors.csv").write_text("keep")
    with pytest.raises(OutputError, match="would overwrite its input"):
        write_rail_report(None, site, inputs=(site / "sensors.csv",))
    (tmp_path / "afile").write_text("x")
    with pytest.raises(OutputError, match="is a file"):
        write_rail_report(None, tmp_path / "afile")
    assert (site / "sensors.csv").read_text() == "keep"


@pytest.fixture
def replaced(monkeypatch):
    """Paths os.replace'd into place (atomic writes), recorded."""
    seen = []
    real = os.replace

    def record(src, dst):
        seen.append(Path(dst).resolve())
        return real(src, dst)

    monkeypatch.setattr(os, "replace", record)
    return seen


def _profile(n=2400, seed=0):
    from longprofile.core import Profile

    rng = np.random.default_rng(seed)
    x = np.arange(n) * 0.25
    z = 1e-3 * np.cumsum(rng.normal(0, 0.3, (n, 1)), axis=0)
    return Profile(distance=x, elevation=z, tracks=("left",), name="p")


def test_road_report_files_are_all_written_atomically(tmp_path, replaced):
    from longprofile.report import write_road_report
    from longprofile.road import analyse_roughness

    files = write_road_report(analyse_roughness(_profile(), segment_length=100.0), tmp_path / "rep")
    assert files and {p.resolve() for p in files} <= set(replaced)


def test_acceptance_report_files_are_all_written_atomically(tmp_path, replaced):
    from longprofile.report import write_acceptance_report
    from longprofile.road import default_spec, smoothness_acceptance

    prof = _profile()
    files = write_acceptance_report(smoothness_acceptance(prof, default_spec()), tmp_path / "acc")
    assert files and {p.resolve() for p in files} <= set(replaced)


def test_compare_report_writes_its_tables_atomically_and_protects_inputs(tmp_path, replaced):
    import json

    from longprofile.report import write_compare_report
    from longprofile.road import certify_profiler

    ref, run = _profile(seed=0), _profile(seed=0)
    res = certify_profiler(ref, [run], names=["run.csv"])
    out = tmp_path / "cmp"
    files = write_compare_report(res, out, reference="ref.csv", runs=["run.csv"])
    assert sorted(p.name for p in files) == ["pairs.csv", "runs.csv", "summary.json"]
    assert {p.resolve() for p in files} <= set(replaced)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reference"] == "ref.csv" and summary["runs"] == ["run.csv"]
    (out / "runs.csv").write_text("keep")
    with pytest.raises(OutputError, match="would overwrite its input"):
        write_compare_report(res, out, reference=out / "runs.csv", runs=["run.csv"])
    assert (out / "runs.csv").read_text() == "keep"


def test_network_report_files_are_all_written_atomically(tmp_path, replaced):
    from longprofile.batch import summarize_network
    from longprofile.report import write_network_report
    from tests.batch.test_network_report import _results

    summary = summarize_network(_results({"a": (0.0, 100.0, [1.0, 2.0]), "b": (0.0, 100.0, [3.0])}))
    files = write_network_report(summary, tmp_path / "net")
    assert files and {p.resolve() for p in files} <= set(replaced)
