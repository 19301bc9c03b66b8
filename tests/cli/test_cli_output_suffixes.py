"""Every command writing a table or a profile with -o refuses an unknown suffix at once: exit 2, one line, nothing
written, and the work never started (each case passes an input or option that the work would have failed on
first: a missing file, an unknown scenario -- the suffix error comes instead)."""

import pytest

from longprofile.cli.app import main

CASES = {
    "road simulate": (["road", "simulate", "-o", "{out}", "--profile", "no-such-road"], ".csv"),
    "road reconstruct": (["road", "reconstruct", "{missing}", "-o", "{out}"], ".csv"),
    "road identify": (["road", "identify", "--input", "{missing}", "--output", "{missing}", "-o", "{out}"], ".json"),
    "road convert": (["road", "convert", "{missing}", "{out}"], ".csv"),
    "differentiate": (["differentiate", "{missing}", "-c", "x", "--dt", "1", "-m", "backward", "-o", "{out}"], ".csv"),
    "rail settle": (["rail", "settle", "--sensors", "{missing}", "--readings", "{missing}", "-o", "{out}"], ".csv"),
    "vehicle simulate": (["vehicle", "simulate", "-o", "{out}", "--scenario", "no-such-drive",
                          "--vehicle", "{missing}"], ".csv"),
    "vehicle slope": (["vehicle", "slope", "{missing}", "-o", "{out}"], ".csv"),
    "vehicle vertical simulate": (["vehicle", "vertical", "simulate", "-o", "{out}", "--test", "no-such-test"], ".csv"),
    "vehicle vertical estimate": (["vehicle", "vertical", "estimate", "{missing}", "-o", "{out}"], ".csv"),
    "vehicle vertical tables": (["vehicle", "vertical", "tables", "-o", "{out}", "--reference", "no-such",
                                 "--car", "no-such"], ".csv"),
}
#: Profile writers accept .erd; the others refuse it like any unknown suffix.
PROFILE_COMMANDS = {"road reconstruct", "road convert"}


def _run(capsys, tmp_path, command, name):
    args, _ = CASES[command]
    out = tmp_path / "new" / name
    argv = [a.format(out=out, missing=tmp_path / "missing.csv") for a in args]
    code = main(argv)
    err = capsys.readouterr().err
    return code, err, out


@pytest.mark.parametrize("command", sorted(CASES))
@pytest.mark.parametrize("name", ["result.txt", "result.xlsx", "result"])
def test_unknown_output_suffix_is_refused_before_any_work(capsys, tmp_path, command, name):
    code, err, out = _run(capsys, tmp_path, command, name)
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    suffix = out.suffix
    assert f"unknown format {suffix!r}" in lines[0] and "use one of" in lines[0], lines[0]
    assert CASES[command][1] in lines[0]  # says which suffix to use
    assert not out.parent.exists()  # nothing written, not even the folder


@pytest.mark.parametrize("command", sorted(set(CASES) - PROFILE_COMMANDS - {"road identify"}))
def test_erd_is_refused_by_table_writers(capsys, tmp_path, command):
    code, err, out = _run(capsys, tmp_path, command, "result.erd")
    assert code == 2 and "unknown format '.erd'; use one of .csv, .parquet" in err
    assert not out.parent.exists()


@pytest.mark.parametrize("command", sorted(PROFILE_COMMANDS))
def test_erd_is_accepted_by_profile_writers(capsys, tmp_path, command):
    code, err, out = _run(capsys, tmp_path, command, "result.erd")
    assert code == 2 and "missing.csv: no such file" in err  # got past the output check to the input
