"""The CLI root: version, citation, and the error contract (one line, exit code 2, no traceback)."""

import subprocess
import sys
from pathlib import Path

import pytest

from longprofile import __version__
from longprofile.cli.app import main


def test_version(capsys):
    assert main(["--version"]) == 0
    assert __version__ in capsys.readouterr().out


def test_cite_names_the_papers(capsys):
    assert main(["--cite"]) == 0
    out = capsys.readouterr().out
    for key in ("[000]", "[001]", "[002]", "[003]", "[004]"):
        assert key in out


def test_library_error_is_one_line_exit_2():
    # a missing input file is a library InputError: one red line on stderr, exit code 2, no traceback
    code = ("import sys; from longprofile.cli.app import app, main\n"
            "from longprofile.io import read_table\n"
            "@app.command('boom')\n"
            "def boom():\n    read_table('/nonexistent/file.csv')\n"
            "sys.exit(main(['boom']))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "no such file" in lines[0]


def test_usage_error_exit_2(capsys):
    assert main(["no-such-command"]) == 2


@pytest.mark.parametrize("argv, says", [
    (["road", "iri", "--segmnt", "100", "p.csv"], ["--segmnt", "--segment", "'longprofile road iri --help'"]),
    (["road", "irri", "p.csv"], ["'irri'", "'iri'", "'longprofile road --help'"]),
    (["rail", "settle", "--sensors", "s.csv"], ["'--readings'", "'longprofile rail settle --help'"]),
    (["road", "iri", "p.csv", "--segment", "abc"], ["'--segment'", "'abc'"]),
])
def test_a_command_line_click_refuses_is_one_line_naming_the_help(argv, says):
    # a typo got click's usage block (usage, "Try ...", a blank line, "Error: ..."): now one line, exit 2
    proc = subprocess.run([str(Path(sys.executable).parent / "longprofile"), *argv], capture_output=True, text=True)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert all(s in lines[0] for s in says), lines[0]


def test_a_group_without_its_command_still_shows_its_help():
    proc = subprocess.run([str(Path(sys.executable).parent / "longprofile"), "road"], capture_output=True, text=True)
    assert "Usage: longprofile road" in proc.stdout and "Commands" in proc.stdout


def test_error_text_is_printed_as_written_not_as_markup():
    # a message naming a TOML table ("[lot]") or a unit ("[m]") must not be eaten by rich's markup parser
    code = ("import sys; from longprofile.cli.app import app, main\n"
            "from longprofile.errors import InputError\n"
            "@app.command('boom')\n"
            "def boom():\n    raise InputError('set index in the spec ([lot] index), stations [m]')\n"
            "sys.exit(main(['boom']))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "([lot] index), stations [m]" in " ".join(proc.stderr.split())


def test_python_dash_m_runs_the_same_cli_with_its_exit_codes(tmp_path):
    ok = subprocess.run([sys.executable, "-m", "longprofile", "--version"], capture_output=True, text=True)
    assert ok.returncode == 0 and __version__ in ok.stdout
    bad = subprocess.run([sys.executable, "-m", "longprofile", "road", "iri", str(tmp_path / "missing.csv")],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr + bad.stdout


def test_fast_exit_keeps_output_exit_code_and_exit_handlers(tmp_path):
    """The console script ends with os._exit after main (no interpreter teardown): the printed lines, the files
    written, the exit codes and the atexit handlers must be those of the normal exit (LONGPROFILE_FAST_EXIT=0)."""
    import os

    import numpy as np

    x = np.arange(0.0, 200.0, 0.25)
    (tmp_path / "p.csv").write_text("distance_m,elevation_m\n" + "\n".join(
        f"{d:.6f},{1e-3 * np.sin(d / 3.0):.9f}" for d in x) + "\n")
    hook = tmp_path / "hook"
    hook.mkdir()  # an exit handler registered by a module the command imports (as multiprocessing's, coverage's)
    (hook / "sitecustomize.py").write_text(
        "import atexit, os\natexit.register(lambda: open(os.environ['HOOK_FILE'], 'w').write('ran'))\n")
    runs = {}
    for fast in ("1", "0"):
        env = dict(os.environ, LONGPROFILE_FAST_EXIT=fast, PYTHONPATH=str(hook), HOOK_FILE=str(tmp_path / f"h{fast}"))
        ok = subprocess.run([sys.executable, "-m", "longprofile", "road", "iri", str(tmp_path / "p.csv"), "-o",
                             str(tmp_path / f"iri{fast}.csv")], capture_output=True, text=True, env=env)
        bad = subprocess.run([sys.executable, "-m", "longprofile", "road", "iri", str(tmp_path / "missing.csv")],
                             capture_output=True, text=True, env=env)
        runs[fast] = (ok.returncode, ok.stdout.replace(fast + ".csv", ""), bad.returncode, bad.stdout,
                      (tmp_path / f"iri{fast}.csv").read_bytes(), (tmp_path / f"h{fast}").read_text())
    assert runs["1"] == runs["0"]
    assert runs["1"][0] == 0 and runs["1"][2] == 2 and runs["1"][-1] == "ran" and runs["1"][4].count(b"\n") > 3
