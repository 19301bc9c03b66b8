"""``longprofile batch iri`` inputs and options (probe 37): files named with glob characters, tracks in any letter
case, the ``--resume`` refusal saying what changed, ``--workers`` where it has no effect."""

from pathlib import Path

import pytest

from longprofile.batch import expand_paths, read_results
from longprofile.cli.app import main
from longprofile.errors import InputError
from longprofile.io import write_erd, write_profile
from longprofile.road import iso8608_profile


def _profile(tracks, seed=0, length=250.0):
    return iso8608_profile(length, 0.25, "C", rng=seed, tracks=tracks)


def _err(capsys):
    return " ".join(capsys.readouterr().err.split())


def test_a_file_named_with_glob_characters_is_that_file(tmp_path):
    """``Route [7]/lane*1.csv`` names a file: it was read as a pattern and matched nothing ("matches no file")."""
    folder = tmp_path / "g1" / "Route [7]"
    folder.mkdir(parents=True)
    star, other, question = (write_profile(_profile(("left",)), folder / n, units="mm")
                             for n in ("lane*1.csv", "laneX1.csv", "lane?2.csv"))
    assert expand_paths([str(star)]) == [star]  # the file itself, not the pattern (which would match laneX1 too)
    assert expand_paths([str(question), str(star)]) == [question, star]
    rel = Path("g1") / "Route [7]" / "lane*1.csv"
    assert expand_paths([str(tmp_path / rel)]) == [star]
    assert expand_paths([str(tmp_path / "g1" / "*" / "lane*1.csv")]) == [star, other]  # a pattern is still one
    with pytest.raises(InputError, match="matches no file"):
        expand_paths([str(folder / "lane*9.csv")])


def test_a_file_named_with_glob_characters_runs_from_the_command_line(tmp_path, capsys, monkeypatch):
    folder = tmp_path / "g1" / "Route [7]"
    folder.mkdir(parents=True)
    write_profile(_profile(("left", "right")), folder / "lane*1.csv", units="mm")
    write_profile(_profile(("left", "right"), 1), folder / "lane?2.csv", units="mm")
    monkeypatch.chdir(tmp_path)
    code = main(["batch", "iri", "g1/Route [7]/lane*1.csv", str(folder / "lane?2.csv"), "-o", "x",
                 "--scheduler", "serial"])
    assert code == 0, _err(capsys)
    assert "2 ok, 0 failed" in _err(capsys)


def test_tracks_are_found_in_any_letter_case_and_named_as_asked(tmp_path, capsys):
    """``--track left,right`` on files whose tracks are Left/Right (CSV) and LEFT/RIGHT (ERD): every file is analysed
    (it failed: "no track 'left'") and the dataset has one column per asked track."""
    write_profile(_profile(("Left", "Right")), tmp_path / "in" / "a.csv", units="mm")
    write_erd(_profile(("LEFT", "RIGHT"), 1), tmp_path / "in" / "b.erd")
    code = main(["batch", "iri", str(tmp_path / "in" / "*"), "--track", "left,right", "-o", str(tmp_path / "out"),
                 "--scheduler", "serial"])
    assert code == 0, _err(capsys)
    segments = read_results(tmp_path / "out").segments
    iri = sorted(c for c in segments.columns if c.startswith("iri_"))
    assert iri == ["iri_left_m_per_km", "iri_right_m_per_km"]
    assert segments[iri].notna().all().all() and segments["file"].nunique() == 2


def test_resume_with_other_options_says_only_what_changed(tmp_path, capsys):
    write_profile(_profile(("left", "right")), tmp_path / "in" / "a.csv", units="mm")
    args = ["batch", "iri", str(tmp_path / "in" / "a.csv"), "-o", str(tmp_path / "out"), "--scheduler", "serial"]
    assert main(args) == 0
    capsys.readouterr()
    assert main([*args, "--resume", "--gaps", "restart", "--segment", "50"]) == 2
    err = _err(capsys)
    assert "other options (gaps: refuse -> restart, interval: 100.0 -> 50.0); --resume needs the same" in err
    assert "{" not in err  # the two option dicts are no longer printed
    assert main([*args, "--resume", "--track", "left"]) == 2
    assert "(tracks: None -> ['left'])" in _err(capsys)


@pytest.mark.parametrize("scheduler,why", [("serial", "--scheduler serial runs one file at a time"),
                                           ("tcp://127.0.0.1:8786", "the Dask scheduler tcp://127.0.0.1:8786 runs "
                                                                    "the files on the workers started on its cluster")])
def test_workers_with_a_scheduler_that_ignores_it_is_one_warning_line(tmp_path, capsys, monkeypatch, scheduler, why):
    import longprofile.batch as batch

    def stop(*args, **kwargs):
        raise InputError("stopped by the test")

    monkeypatch.setattr(batch, "run_batch", stop)
    write_profile(_profile(("left",)), tmp_path / "a.csv", units="mm")
    assert main(["batch", "iri", str(tmp_path / "a.csv"), "-o", str(tmp_path / "o"), "--scheduler", scheduler,
                 "--workers", "4"]) == 2
    err = capsys.readouterr().err
    assert f"warning: --workers 4 is ignored: {why}" in " ".join(err.split())
    assert main(["batch", "iri", str(tmp_path / "a.csv"), "-o", str(tmp_path / "o"), "--scheduler", "threads",
                 "--workers", "4"]) == 2
    assert "warning" not in capsys.readouterr().err
