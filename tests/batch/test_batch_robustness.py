"""Session 37 probe: the batch says what `road iri` says, a full or read-only disk is one line, one lock per folder
whatever the path to it, and --resume recomputes a damaged partition."""

import errno
import os
import re
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from longprofile.batch import IRITask, read_manifest, read_results, run_batch
from longprofile.batch._run import _output_lock, partition_file
from longprofile.cli.app import main
from longprofile.errors import InputFormatError, OutputError

from ._helpers import make_network


def _warnings_of_road_iri(path, capsys, *extra):
    """The `warning:` lines `longprofile road iri` prints for a file (the oracle the manifest is held to)."""
    capsys.readouterr()
    assert main(["road", "iri", str(path), "-o", str(path.with_suffix(".iri.csv")), "--overwrite", *extra]) == 0
    text = " ".join(capsys.readouterr().err.split())  # rich wraps long lines
    parts = re.split(r"(?=warning: |section IRI \(|moving average: |note: )", text)
    return [w.removeprefix("warning: ").strip() for w in parts if w.startswith("warning: ")]


def _held_and_coarse(folder: Path) -> list[Path]:
    """A profile whose left track holds one value over 3.9 m (a dropout written as a value) and one sampled every
    0.328 m (1.08 ft): the two warnings of the probe."""
    from longprofile.io import write_profile
    from longprofile.road import Profile, iso8608_profile

    folder.mkdir(parents=True, exist_ok=True)
    p = iso8608_profile(1200.0, 0.1, "B", rng=3, tracks=("left", "right"))
    z = p.elevation.copy()
    held = (p.distance >= 400.0) & (p.distance <= 403.9)
    z[held, 0] = z[np.argmax(held), 0]
    coarse = iso8608_profile(1200.0, 0.328084, "B", rng=4, tracks=("left", "right"))
    return [write_profile(Profile(p.distance, z, tracks=p.tracks), folder / "held.csv", units="mm"),
            write_profile(coarse, folder / "coarse.csv", units="mm")]


@pytest.mark.parametrize("gaps", ["refuse", "restart"])
def test_the_manifest_warning_holds_every_warning_road_iri_prints(gaps, tmp_path, capsys):
    files = _held_and_coarse(tmp_path / "in")
    run_batch(IRITask(gaps=gaps), files, tmp_path / "r")
    manifest, _ = read_manifest(tmp_path / "r")
    for f in files:
        printed = _warnings_of_road_iri(f, capsys, "--gaps", gaps)
        assert printed  # the probe's files do warn
        warning = manifest.set_index("path").loc[str(f.resolve()), "warning"]
        for w in printed:
            assert w in warning
    # and `batch report` lists them among the results to check
    assert main(["batch", "report", str(tmp_path / "r"), "-o", str(tmp_path / "rep")]) == 0
    html = (tmp_path / "rep" / "index.html").read_text()
    assert "held one exact elevation" not in html and "holds one exact elevation" in html
    assert "sampled every 0.328 m" in html


def _failing_writer(monkeypatch, err: int, where: str, after: int = 0):
    """pyarrow.parquet.write_table raising OSError(err) for files whose name contains ``where`` (after ``after``
    successful writes there), once it has written a few bytes (a disk that fills up mid-file)."""
    real = pq.write_table
    count = {"n": 0}

    def write_table(table, where_to, *args, **kwargs):
        name = getattr(where_to, "name", str(where_to))
        if where in str(name):
            count["n"] += 1
            if count["n"] > after:
                where_to.write(b"PAR1")
                raise OSError(err, os.strerror(err), name)
        return real(table, where_to, *args, **kwargs)

    monkeypatch.setattr(pq, "write_table", write_table)


def test_a_disk_full_while_writing_a_partition_is_one_line_and_leaves_a_consistent_folder(tmp_path, capsys,
                                                                                          monkeypatch):
    make_network(tmp_path / "in", 5, corrupt=False)
    out = tmp_path / "r"
    _failing_writer(monkeypatch, errno.ENOSPC, "part-0.parquet", after=2)
    code = main(["batch", "iri", str(tmp_path / "in" / "**" / "*.*"), "-o", str(out), "--scheduler", "serial"])
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("error:")]
    assert code == 2 and len(err) == 1 and "No space left on device" in err[0] and "--resume" in err[0]
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]  # no (zero-byte) temporary file left
    manifest, _ = read_manifest(out)
    done = set(manifest.route[manifest.status == "ok"])
    on_disk = {p.parent.name.removeprefix("route=") for p in (out / "segments").rglob("part-0.parquet")}
    assert len(done) == 2 and {r.replace("/", "%2F") for r in done} == on_disk
    read_results(out)  # every row marked done can be read
    monkeypatch.undo()
    s = run_batch(IRITask(), sorted((tmp_path / "in").rglob("*.*")), out, resume=True)
    assert (s.n_ok, s.n_skipped, s.n_error) == (3, 2, 0)


def test_a_read_only_output_is_one_line_exit_2(tmp_path, capsys, monkeypatch):
    make_network(tmp_path / "in", 2, corrupt=False)
    pattern = str(tmp_path / "in" / "**" / "*.*")
    _failing_writer(monkeypatch, errno.EROFS, "manifest.parquet")  # the first write of a run
    assert main(["batch", "iri", pattern, "-o", str(tmp_path / "r"), "--scheduler", "serial"]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and err[0].startswith("error: cannot write") and "Read-only file system" in err[0]
    assert not [p for p in (tmp_path / "r").rglob("*") if p.name.endswith(".tmp")]
    monkeypatch.undo()
    real_open = os.open

    def no_lock(path, *args, **kwargs):
        if str(path).endswith(".longprofile-lock"):
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(path))
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr(os, "open", no_lock)
    assert main(["batch", "iri", pattern, "-o", str(tmp_path / "r2"), "--scheduler", "serial"]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and err[0].startswith("error: cannot create the lock file")


def test_a_link_to_the_output_folder_takes_the_same_lock(tmp_path):
    files = make_network(tmp_path / "in", 2, corrupt=False)
    out = tmp_path / "lockt"
    out.mkdir()
    link = tmp_path / "lockt_link"
    link.symlink_to(out)
    with _output_lock(out):  # a run on lockt is going on
        with pytest.raises(OutputError, match="another `longprofile batch` run is writing to"):
            run_batch(IRITask(), files, link, resume=True)
    assert run_batch(IRITask(), files, link).n_ok == 2  # free again afterwards


def test_resume_recomputes_a_partition_that_cannot_be_read(tmp_path):
    files = make_network(tmp_path / "in", 3, corrupt=False)
    out = tmp_path / "r"
    run_batch(IRITask(), files, out)
    clean = read_results(out)
    route = clean.manifest.route.iloc[1]
    part = partition_file(out, route)
    part.write_bytes(part.read_bytes()[:200])  # truncated (a disk error, a copy cut short)
    with pytest.raises(InputFormatError, match="rerun the batch with --resume"):
        read_results(out)
    s = run_batch(IRITask(), files, out, resume=True)
    assert (s.n_ok, s.n_skipped) == (1, 2)
    again = read_results(out)
    assert again.segments.sort_values(["route", "start_m"]).reset_index(drop=True).equals(
        clean.segments.sort_values(["route", "start_m"]).reset_index(drop=True))
