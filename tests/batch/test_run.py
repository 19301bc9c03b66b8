"""run_batch: identical results on every executor, resume after a crash, corrupt files, refused folders."""

import shutil

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from longprofile.batch import (
    IRITask,
    ReconstructTask,
    expand_paths,
    open_executor,
    read_manifest,
    read_results,
    run_batch,
)
from longprofile.batch._run import partition_file
from longprofile.errors import InputError, OutputError

from ._helpers import FailOnFlag, comparable, expected_allocator_status, make_network


@pytest.fixture(scope="module")
def network(tmp_path_factory):
    root = tmp_path_factory.mktemp("surveys")
    return root, make_network(root, 5)


@pytest.fixture(scope="module")
def serial_run(network, tmp_path_factory):
    _, files = network
    out = tmp_path_factory.mktemp("serial") / "results"
    summary = run_batch(IRITask(), files, out)
    return summary, read_results(out)


def _same_results(a, b):
    pd.testing.assert_frame_equal(a.segments, b.segments, check_exact=True)
    pd.testing.assert_frame_equal(comparable(a.manifest), comparable(b.manifest), check_exact=True)


def test_serial_results_are_the_single_file_library_calls(serial_run, network):
    from longprofile.io import read_profile
    from longprofile.road import iri_report

    summary, res = serial_run
    assert (summary.n_ok, summary.n_error, summary.n_skipped) == (5, 2, 0)
    done = res.manifest[res.manifest.status == "ok"]
    for path, route in zip(done.path, done.route):
        want = iri_report(read_profile(path)).to_frame()
        got = res.segments[res.segments.route == route].drop(columns=["route", "file"]).reset_index(drop=True)
        pd.testing.assert_frame_equal(got, want, check_exact=True)  # bit for bit
        assert (res.segments[res.segments.route == route].file == path).all()
    assert set(res.manifest.route) == {"R1/lane0", "R1/lane2", "R1/lane4", "R2/lane1", "R2/lane3", "R1/truncated",
                                       "R2/garbage"}


def test_corrupt_files_are_manifest_rows_with_their_error_and_the_others_finish(serial_run):
    summary, res = serial_run
    m = res.manifest.set_index("route")
    assert m.loc["R1/truncated", "status"] == "error" and "truncated.erd" in m.loc["R1/truncated", "error"]
    assert m.loc["R2/garbage", "status"] == "error" and m.loc["R2/garbage", "error"]
    assert (m.loc[m.status == "ok", "error"] == "").all() and (m.loc[m.status == "ok", "rows"] > 0).all()
    assert not partition_file(res.folder, "R1/truncated").exists()
    assert len(m.loc["R2/garbage", "sha256"]) == 64  # a failed file's content hash is recorded too
    assert {p for p, _ in summary.failed} == set(m.loc[m.status == "error", "path"])
    assert "2 failed" in summary.line() and "\n" not in summary.line()


def test_dataset_is_a_standard_hive_partitioned_parquet_dataset(serial_run):
    _, res = serial_run
    direct = pd.read_parquet(res.folder / "segments")  # any Parquet reader, no longprofile needed
    assert set(direct.route.astype(str)) == set(res.segments.route)
    assert len(direct) == len(res.segments)
    _, info = read_manifest(res.folder)
    assert info["task"] == "iri" and info["options"]["interval"] == 100.0
    meta = pq.read_schema(partition_file(res.folder, "R1/lane0")).metadata
    assert b"longprofile" in meta  # the IRI report metadata travel with each partition


@pytest.mark.parametrize("scheduler", ["threads", "processes"])
def test_threads_and_processes_equal_serial_bit_for_bit(scheduler, network, serial_run, tmp_path):
    _, files = network
    run_batch(IRITask(), files, tmp_path / "r", executor=scheduler, workers=2)
    _same_results(read_results(tmp_path / "r"), serial_run[1])


@pytest.mark.parametrize("processes", [True, False])
def test_dask_local_cluster_equals_serial_bit_for_bit(processes, network, serial_run, tmp_path):
    distributed = pytest.importorskip("distributed", reason="dask[distributed] not installed "
                                                            "(pip install longprofile[dask])")
    _, files = network
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=processes, dashboard_address=":0") \
            as cluster, distributed.Client(cluster) as client:
        run_batch(IRITask(), files, tmp_path / "r", executor=client)
        if processes:  # each worker process tuned its allocator against the nanny's MALLOC_TRIM_THRESHOLD_
            from longprofile._memory import memory_status

            assert set(client.run(memory_status).values()) == {expected_allocator_status()}
    _same_results(read_results(tmp_path / "r"), serial_run[1])


def test_resume_after_a_crash_mid_batch_finishes_the_rest(network, serial_run, tmp_path):
    _, files = network
    flag = tmp_path / "crash"
    flag.touch()
    task = FailOnFlag(flag=str(flag), victim="lane3.erd")  # the same task (and options) in every run
    out = tmp_path / "r"
    seen = []

    def interrupt_after_three(row):
        seen.append(row["path"])
        if len(seen) == 3:
            raise KeyboardInterrupt  # the user (or the machine) stops the run

    with pytest.raises(KeyboardInterrupt):
        run_batch(task, files, out, on_result=interrupt_after_three)
    m, _ = read_manifest(out)  # the manifest of an interrupted run is readable and holds what finished
    assert len(m) == 3
    with pytest.raises(OutputError, match="--resume"):
        run_batch(task, files, out)  # refused without --resume / --overwrite
    assert set(m.status) == {"ok"}  # serial, sorted: R1/lane0, R1/lane2, R1/lane4
    s1 = run_batch(task, files, out, resume=True)
    assert (s1.n_skipped, s1.n_ok, s1.n_error) == (3, 1, 3)  # lane3 crashes again, the 2 corrupt files fail
    flag.unlink()
    s2 = run_batch(task, files, out, resume=True)
    assert (s2.n_skipped, s2.n_ok, s2.n_error) == (4, 1, 2)  # lane3 done now; the corrupt files still fail
    res = read_results(out)
    pd.testing.assert_frame_equal(res.segments, serial_run[1].segments, check_exact=True)
    status = res.manifest.set_index("route").status
    assert status["R2/lane3"] == "ok" and (status.drop(["R2/lane3", "R1/truncated", "R2/garbage"]) == "skipped").all()


def test_resume_recomputes_missing_rows_changed_files_and_ignores_orphan_partitions(tmp_path):
    root = tmp_path / "in"
    files = make_network(root, 3, corrupt=False)
    out = tmp_path / "r"
    run_batch(IRITask(), files, out)
    clean = read_results(out)
    # a crash between a partition's rename and its manifest row: the partition is there, the row is not
    m, info = read_manifest(out)
    from longprofile.batch._run import _Manifest

    dropped = m.route.iloc[0]
    _Manifest(out, info, {r["path"]: r for r in m.to_dict("records") if r["route"] != dropped}).flush(force=True)
    assert dropped not in set(read_results(out).segments.route)  # only rows marked done are read
    # and a file edited since its run
    from longprofile.io import read_profile, write_profile

    edited = files[1]
    p = read_profile(edited)
    write_profile(type(p)(p.distance, p.elevation * 2.0, tracks=p.tracks), edited, units="mm")
    s = run_batch(IRITask(), files, out, resume=True)
    assert (s.n_ok, s.n_skipped) == (2, 1)
    res = read_results(out)
    assert len(res.segments) == len(clean.segments)  # no duplicate of the recomputed route
    route = res.manifest.set_index("path").loc[str(edited.resolve()), "route"]
    new = res.segments[res.segments.route == route].iri_left_m_per_km.to_numpy()
    old = clean.segments[clean.segments.route == route].iri_left_m_per_km.to_numpy()
    np.testing.assert_allclose(new, 2.0 * old, rtol=1e-9)  # IRI is linear in the elevation


def test_a_file_that_became_corrupt_loses_its_old_results(tmp_path):
    files = make_network(tmp_path / "in", 2, corrupt=False)
    out = tmp_path / "r"
    run_batch(IRITask(), files, out)
    files[0].write_text("ERDFILEV2.00\nnot an erd\n")
    s = run_batch(IRITask(), files, out, resume=True)
    assert (s.n_error, s.n_skipped) == (1, 1)
    res = read_results(out)
    assert str(files[0].resolve()) not in set(res.segments.file)
    assert not partition_file(out, res.manifest.route[res.manifest.status == "error"].iloc[0]).exists()


def test_existing_folders_are_refused_before_any_work(network, tmp_path):
    _, files = network
    user = tmp_path / "mine"
    user.mkdir()
    (user / "notes.txt").write_text("keep me")
    for kw in ({}, {"resume": True}, {"overwrite": True}):
        with pytest.raises(OutputError, match="not a longprofile batch results folder"):
            run_batch(IRITask(), files, user, **kw)
    assert [p.name for p in user.iterdir()] == ["notes.txt"]
    with pytest.raises(InputError, match="exclude each other"):
        run_batch(IRITask(), files, tmp_path / "new", resume=True, overwrite=True)
    with pytest.raises(OutputError, match="inside the output folder"):
        run_batch(IRITask(), files, files[0].parent.parent)
    (tmp_path / "afile").write_text("x")
    with pytest.raises(OutputError, match="is a file"):
        run_batch(IRITask(), files, tmp_path / "afile")
    assert not (tmp_path / "new").exists()


def test_overwrite_replaces_only_what_the_batch_wrote_and_resume_needs_the_same_options(network, tmp_path):
    _, files = network
    out = tmp_path / "r"
    run_batch(IRITask(), files[:2], out)
    (out / "README.txt").write_text("my notes")
    with pytest.raises(InputError, match="same task and options"):
        run_batch(IRITask(interval=50.0), files, out, resume=True)
    s = run_batch(IRITask(interval=50.0), files[2:4], out, overwrite=True)
    assert s.n_ok + s.n_error == 2
    res = read_results(out)
    assert len(res.manifest) == 2 and (out / "README.txt").read_text() == "my notes"
    assert res.options["interval"] == 50.0


def test_bad_options_and_no_input_fail_before_the_folder_is_made(network, tmp_path):
    _, files = network
    with pytest.raises(InputError, match="unknown mode"):
        run_batch(IRITask(mode="sideways"), files, tmp_path / "r")
    with pytest.raises(InputError, match="no input file"):
        run_batch(IRITask(), [], tmp_path / "r")
    with pytest.raises(InputError, match="unknown scheduler"):
        run_batch(IRITask(), files, tmp_path / "r", executor="gpu")
    assert not (tmp_path / "r").exists()


def test_expand_paths_recursive_sorted_and_clear_errors(network):
    root, files = network
    got = expand_paths([str(root / "**" / "*.erd"), str(root / "R2" / "*")])
    assert got[:3] == sorted(p for p in files if p.suffix == ".erd")
    want = {p for p in files if p.suffix == ".erd" or p.parent.name == "R2"}
    assert len(got) == len(set(got)) == len(want) and set(got) == want  # R2/lane3.erd matched twice, listed once
    with pytest.raises(InputError, match="matches no file"):
        expand_paths([str(root / "**" / "*.xyz")])
    with pytest.raises(InputError, match="is a folder"):
        expand_paths([str(root)])
    with pytest.raises(InputError, match="no such file"):
        expand_paths([str(root / "nope.erd")])


def test_reconstruct_task_is_road_reconstruct_then_the_iri_report(tmp_path):
    from longprofile.road import Profile, iri_report
    from longprofile.road.apl import apl_model, reconstruct_profile, simulate_apl_recording

    folder = tmp_path / "apl"
    folder.mkdir()
    recs = []
    for i in range(2):
        rec = simulate_apl_recording("iso8608", apl_model(20.0, 0.05), length=600.0, road_class="B", rng=i)
        pd.DataFrame({"distance_m": rec.distance, "apl_m": rec.signal}).to_parquet(folder / f"run{i}.parquet")
        recs.append(rec)
    (folder / "run9.parquet").write_bytes(b"PAR1 truncated")
    out = tmp_path / "r"
    with open_executor("threads", 2) as ex:
        s = run_batch(ReconstructTask(), sorted(folder.glob("*.parquet")), out, executor=ex)
    assert (s.n_ok, s.n_error) == (2, 1)
    res = read_results(out)
    for i, rec in enumerate(recs):
        direct = reconstruct_profile(Profile(rec.distance, rec.signal), apl_model(20.0, 0.05))
        prof = res.profile(f"run{i}")
        assert list(prof.columns) == ["distance_m", "elevation_m", "std_m", "raw_m", "raw_std_m"]
        np.testing.assert_array_equal(prof.elevation_m.to_numpy(), direct.profile.elevation[:, 0])
        want = iri_report(Profile(direct.profile.distance, direct.profile.elevation, tracks=("elevation",))).to_frame()
        got = res.segments[res.segments.route == f"run{i}"].drop(columns=["route", "file"]).reset_index(drop=True)
        pd.testing.assert_frame_equal(got, want, check_exact=True)
    shutil.rmtree(out)


def test_a_second_run_on_the_same_output_folder_is_refused_while_the_first_runs(network, tmp_path):
    """Two `--resume` runs at once on one folder lost 159 of 211 files from the manifest (session 35, a probe): the
    second run is now refused before any work, and the folder is free again once the first ends."""
    _, files = network
    out = tmp_path / "r"
    seen = []

    def second(_row):  # called as the first run's files finish: a concurrent run at that moment
        if not seen:
            with pytest.raises(OutputError, match="another `longprofile batch` run is writing to"):
                run_batch(IRITask(), files, out, resume=True)
            seen.append(True)

    first = run_batch(IRITask(), files, out, on_result=second)
    assert seen and first.n_ok + first.n_error == len(files)
    again = run_batch(IRITask(), files, out, resume=True)
    assert again.n_skipped == first.n_ok and not list(tmp_path.glob(".*lock"))


def test_a_report_on_an_interrupted_run_says_so(network, tmp_path):
    """An interrupted run's report said "195 / 195 done" of 211 inputs (session 35, a probe)."""
    from longprofile.batch import read_results, summarize_network
    from longprofile.report import write_network_report

    _, files = network
    out = tmp_path / "r"
    done = []

    def stop(_row):
        done.append(1)
        if len(done) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_batch(IRITask(), files, out, on_result=stop)
    res = read_results(out)
    assert res.complete is False and res.n_inputs == len(files) and len(res.manifest) < len(files)
    write_network_report(summarize_network(res), tmp_path / "rep")
    page = (tmp_path / "rep" / "index.html").read_text()
    assert f"/ {len(files)} done" in page and "--resume finishes it" in page
    run_batch(IRITask(), files, out, resume=True)
    assert read_results(out).complete is True


def test_an_earlier_output_in_the_tree_and_a_copy_of_a_survey_are_not_taken_as_new_surveys(network, tmp_path):
    """A pattern over a survey tree holding an earlier run's output took its partitions as surveys; a survey copied
    under another name was counted twice without a word; a killed run's temporary file stayed (session 35)."""
    from pathlib import Path

    folder, _ = network
    tree = tmp_path / "tree"
    shutil.copytree(folder, tree)
    good = sorted(p for p in tree.rglob("*.erd") if "truncated" not in p.name)[:2]
    shutil.copy(good[0], tree / "copy-of-first.erd")
    run_batch(IRITask(), good, tree / "old-results")
    inputs = expand_paths([str(tree / "**" / "*.erd"), str(tree / "**" / "*.parquet")])
    assert not any("old-results" in str(p) for p in inputs)
    out = tmp_path / "r"
    out.mkdir()
    summary = run_batch(IRITask(), [p for p in inputs if p.suffix == ".erd"], out)
    (out / "segments" / ".part-0.parquet.999.tmp").write_bytes(b"junk")
    dup = [(Path(p).name, w) for p, w in summary.warnings if "same content as" in w]
    assert len(dup) == 1 and good[0].name in dup[0][1]
    run_batch(IRITask(), [p for p in inputs if p.suffix == ".erd"], out, resume=True)
    assert not list(out.rglob(".*.tmp"))


def test_dangling_links_and_link_loops_matched_by_a_glob_are_failed_rows_saying_why(tmp_path):
    """A glob matching a dangling symbolic link or a loop (a -> b -> a) left them out of the run without a manifest
    row (session 35, a probe); given directly, a loop stopped run_batch with a RuntimeError."""
    files = make_network(tmp_path / "in", 2, corrupt=False)
    folder = files[0].parent
    (folder / "gone.erd").symlink_to(folder / "deleted.erd")
    (folder / "loop-a.erd").symlink_to("loop-b.erd")
    (folder / "loop-b.erd").symlink_to("loop-a.erd")
    (folder / "z-alias.erd").symlink_to(files[0])  # a working link: the file it names, taken once
    inputs = expand_paths([str(tmp_path / "in" / "**" / "*")])
    assert sorted(p.name for p in inputs) == sorted(["gone.erd", "loop-a.erd", "loop-b.erd", *(f.name for f in files)])
    summary = run_batch(IRITask(), inputs, tmp_path / "r", executor="threads", workers=2)
    assert (summary.n_ok, summary.n_error) == (2, 3)
    m = read_manifest(tmp_path / "r")[0].set_index("route")
    assert m.loc["R1/gone", "status"] == "error" and m.loc["R1/gone", "path"] == str(folder.resolve() / "gone.erd")
    assert m.loc["R1/gone", "error"] == (f"{folder.resolve() / 'gone.erd'}: dangling symbolic link: "
                                         f"{folder.resolve() / 'deleted.erd'} does not exist; restore the target or "
                                         "remove the link.")
    for name in ("loop-a", "loop-b"):
        assert m.loc[f"R1/{name}", "status"] == "error"
        assert m.loc[f"R1/{name}", "error"].startswith(f"{folder.resolve() / name}.erd: symbolic link loop (it points to ")
    with pytest.raises(InputError, match="no such file"):
        expand_paths([str(folder / "deleted.erd")])
