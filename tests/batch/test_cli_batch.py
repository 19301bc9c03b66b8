"""``longprofile batch iri|reconstruct|report``: exit codes 0 / 3 / 2, one-line errors, the network page."""

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from longprofile.batch import EXIT_SOME_FAILED, read_results
from longprofile.cli.app import main

from ._helpers import make_network


@pytest.fixture(scope="module")
def surveys(tmp_path_factory):
    root = tmp_path_factory.mktemp("cli")
    make_network(root / "surveys", 3)
    return root


def _cli(*args, cwd):
    """Run the installed command in a subprocess: (exit code, stderr lines)."""
    exe = Path(sys.executable).with_name("longprofile")  # the console script of this environment
    proc = subprocess.run([str(exe), *args], capture_output=True, text=True, cwd=cwd,
                          env={**os.environ, "OPENBLAS_NUM_THREADS": "1", "COLUMNS": "200"})
    assert "Traceback" not in proc.stderr, proc.stderr
    return proc.returncode, [ln for ln in proc.stderr.splitlines() if ln.strip()]


def test_all_ok_is_exit_0_and_a_one_line_summary(surveys, tmp_path, capsys):
    out = tmp_path / "ok"
    code = main(["batch", "iri", str(surveys / "surveys" / "**" / "lane*"), "-o", str(out), "--scheduler", "serial"])
    assert code == 0
    err = capsys.readouterr().err
    assert "batch iri: 3 ok, 0 failed, 0 skipped of 3 file(s)" in err
    assert len(read_results(out).segments) > 0


def test_failed_files_give_exit_3_and_one_summary_line_then_resume_and_report(surveys):
    code, lines = _cli("batch", "iri", "surveys/**/*", "-o", "results", "--workers", "2", cwd=surveys)
    assert code == EXIT_SOME_FAILED == 3
    assert lines[-1].startswith("some files failed: batch iri: 3 ok, 2 failed") and "manifest.parquet" in lines[-1]
    code, lines = _cli("batch", "iri", "surveys/**/*", "-o", "results", cwd=surveys)
    assert code == 2 and len(lines) == 1 and "--resume" in lines[0] and lines[0].startswith("error:")
    code, lines = _cli("batch", "iri", "surveys/**/*", "-o", "results", "--resume", "--scheduler", "threads",
                       cwd=surveys)
    assert code == 3 and "0 ok, 2 failed, 3 skipped" in lines[-1]
    code, lines = _cli("batch", "report", "results", "-o", "network", cwd=surveys)
    assert code == 0 and lines[-1].startswith("network report: network/index.html")
    page = (surveys / "network" / "index.html").read_text()
    assert "Files that failed (2)" in page
    for name in ("truncated.erd", "garbage.csv"):
        assert name in page
    assert "Worst segments" in page and "Distribution of the segment IRI" in page
    assert (surveys / "network" / "iri_histogram.png").read_bytes()[:4] == b"\x89PNG"
    failed = pd.read_csv(surveys / "network" / "failed.csv")
    assert len(failed) == 2 and failed.error.str.len().min() > 0


@pytest.mark.parametrize("args, message", [
    (["--resume", "--overwrite"], "exclude each other"),
    (["--units", "mm"], "units must be 'si'"),
    (["--scheduler", "gpu"], "unknown scheduler"),
    (["--mode", "sideways"], "unknown mode"),
])
def test_bad_options_are_one_red_line_exit_2_and_nothing_written(surveys, tmp_path, args, message):
    code, lines = _cli("batch", "iri", "surveys/**/lane*", "-o", str(tmp_path / "r"), *args, cwd=surveys)
    assert code == 2 and len(lines) == 1 and message in lines[0], lines
    assert not (tmp_path / "r").exists()


def test_pattern_matching_nothing_and_report_of_a_non_results_folder(surveys, tmp_path):
    code, lines = _cli("batch", "iri", "surveys/**/*.xyz", "-o", str(tmp_path / "r"), cwd=surveys)
    assert code == 2 and len(lines) == 1 and "matches no file" in lines[0]
    code, lines = _cli("batch", "report", str(surveys / "surveys"), "-o", str(tmp_path / "rep"), cwd=surveys)
    assert code == 2 and len(lines) == 1 and "not a longprofile batch results folder" in lines[0]


def test_us_units_flow_through_to_the_dataset_and_the_report(surveys, tmp_path):
    out = tmp_path / "us"
    # the failed files give the documented exit code 3, returned by main() in process
    assert main(["batch", "iri", str(surveys / "surveys" / "**" / "*"), "-o", str(out), "--units", "us",
                 "--scheduler", "serial"]) == 3
    seg = read_results(out).segments
    assert {"start_ft", "end_ft", "iri_left_in_per_mi", "mri_in_per_mi"} <= set(seg.columns)
    assert (seg.end_ft - seg.start_ft).round(6).eq(528.0).all()
    assert main(["batch", "report", str(out), "-o", str(tmp_path / "rep")]) == 0
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "in/mi" in page and "station [ft]" not in page  # the unit is in the figure, the page names in/mi


def test_dask_scheduler_address(surveys, tmp_path, capsys):
    distributed = pytest.importorskip("distributed", reason="dask[distributed] not installed "
                                                            "(pip install longprofile[dask])")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0",
                                  protocol="tcp", host="127.0.0.1") as cluster:  # a tcp:// address on loopback
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        code = main(["batch", "iri", str(surveys / "surveys" / "**" / "lane*"), "-o", str(tmp_path / "d"),
                     "--scheduler", cluster.scheduler_address])
    assert code == 0
    assert "3 ok" in capsys.readouterr().err
    ref = tmp_path / "s"
    assert main(["batch", "iri", str(surveys / "surveys" / "**" / "lane*"), "-o", str(ref), "--scheduler",
                 "serial"]) == 0
    pd.testing.assert_frame_equal(read_results(tmp_path / "d").segments, read_results(ref).segments,
                                  check_exact=True)


def test_batch_reconstruct_command(tmp_path, capsys):
    from longprofile.road.apl import apl_model, simulate_apl_recording

    rec = simulate_apl_recording("iso8608", apl_model(20.0, 0.05), length=500.0, road_class="B", rng=3)
    (tmp_path / "runs").mkdir()
    pd.DataFrame({"distance_m": rec.distance, "apl_mm": rec.signal * 1e3}).to_csv(tmp_path / "runs" / "a.csv",
                                                                                  index=False)
    code = main(["batch", "reconstruct", str(tmp_path / "runs" / "*.csv"), "-o", str(tmp_path / "r"), "--column",
                 "apl_mm", "--scheduler", "serial", "--segment", "50"])
    assert code == 0, capsys.readouterr().err
    res = read_results(tmp_path / "r")
    span = rec.distance[-1] - rec.distance[0]
    assert res.task == "reconstruct" and len(res.segments) == int(span // 50.0)  # complete 50 m segments
    assert "iri_elevation_m_per_km" in res.segments.columns
    assert len(res.profile("a")) == rec.distance.size


def test_ctrl_c_is_one_line_exit_130_and_resume_finishes(surveys, tmp_path, capsys, monkeypatch):
    """Ctrl-C during the batch (KeyboardInterrupt in the command): one line naming how far it got and --resume, exit
    130; the same command with --resume then completes the network."""
    import longprofile.batch as batch

    real = batch.run_batch

    def interrupted(task, paths, output, **kw):
        def on_result(row):
            kw["on_result"](row)
            raise KeyboardInterrupt  # after the first file

        return real(task, paths[:2], output, **{**kw, "on_result": on_result})

    monkeypatch.setattr(batch, "run_batch", interrupted)
    out = tmp_path / "res"
    args = ["batch", "iri", str(surveys / "surveys" / "**" / "lane*"), "-o", str(out), "--scheduler", "serial"]
    assert main(args) == 130
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip() and "batch iri" not in ln]
    assert err == [f"interrupted after 1 of 2 files: the results so far are in {out}; the same command with --resume "
                   "continues."]
    monkeypatch.setattr(batch, "run_batch", real)
    assert main(args + ["--resume"]) == 0
    assert "2 ok, 0 failed, 1 skipped of 3 file(s)" in capsys.readouterr().err


def test_a_dangling_link_in_the_pattern_is_a_failed_file_exit_3(surveys, tmp_path, capsys):
    """It was left out silently (session 35): now the run goes on, and the link is a failed row saying why."""
    folder = tmp_path / "in"
    folder.mkdir()
    for f in (surveys / "surveys").rglob("lane*"):
        (folder / f.name).symlink_to(f)
    (folder / "moved.erd").symlink_to(tmp_path / "elsewhere.erd")
    code = main(["batch", "iri", str(folder / "*"), "-o", str(tmp_path / "r"), "--scheduler", "serial"])
    assert code == EXIT_SOME_FAILED
    assert "some files failed: batch iri: 3 ok, 1 failed" in capsys.readouterr().err
    m = read_results(tmp_path / "r").manifest.set_index("path")
    assert "dangling symbolic link" in m.loc[str(folder / "moved.erd"), "error"]
