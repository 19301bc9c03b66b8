"""The CLI root: version, citation, and the error contract (one line, exit code 2, no traceback)."""

import subprocess
import sys

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
