"""Every command and snippet of the README runs as written, in a fresh folder (issue 13, a newcomer's first hour).

The ```sh blocks are run line by line with bash (backslash continuations joined, comments kept: bash ignores
them) from one temporary folder, in README order, with the project's ``.venv/bin`` first on PATH — what
``source .venv/bin/activate`` (the README's instruction after ``make demo``) does. The ```python blocks run as
scripts in the same folder. A failing command fails the test with its output.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


def markdown_blocks(text: str, lang: str) -> list[str]:
    """The bodies of the ```lang fenced blocks of a Markdown text, in order."""
    return re.findall(rf"^```{lang}\n(.*?)^```", text, flags=re.S | re.M)


def _blocks(lang: str) -> list[str]:
    return markdown_blocks(README.read_text(), lang)


def shell_commands(text: str) -> list[str]:
    """The command lines of a Markdown text's ```sh blocks (backslash continuations joined, comment lines dropped;
    ``source .venv/bin/activate`` is what :func:`_env` does: the venv's bin first on PATH)."""
    cmds = []
    for block in markdown_blocks(text, "sh"):
        block = re.sub(r"\\\n\s*", " ", block)
        cmds += [line.strip() for line in block.splitlines() if line.strip() and not line.strip().startswith("#")]
    return [c for c in cmds if c != "source .venv/bin/activate"]


def _commands() -> list[str]:
    return shell_commands(README.read_text())


def test_readme_opens_with_exactly_the_two_set_up_commands():
    head = README.read_text().split("\n## ", 1)[0]
    setup = [line.split("#")[0].strip() for line in head.splitlines() if line.startswith("    make ")]
    assert setup == ["make demo", "make test"]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("readme")


def _env():
    bindir = Path(sys.executable).parent  # the venv's bin: longprofile and python live there
    return dict(os.environ, PATH=f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}", OPENBLAS_NUM_THREADS="1")


def test_readme_shell_commands_run_as_written(workdir):
    commands = _commands()
    assert len(commands) >= 10, "the README lost its command examples"
    for cmd in commands:
        proc = subprocess.run(["bash", "-c", cmd], cwd=workdir, env=_env(), capture_output=True, text=True,
                              timeout=600)
        assert proc.returncode == 0, f"README command failed (exit {proc.returncode}): {cmd}\n{proc.stderr[-2000:]}"


def test_readme_python_snippets_run_as_written(workdir):
    snippets = _blocks("python")
    assert snippets, "the README lost its Python example"
    for i, code in enumerate(snippets):
        script = workdir / f"readme_snippet_{i}.py"
        script.write_text(code)
        proc = subprocess.run([sys.executable, str(script)], cwd=workdir, env=_env(), capture_output=True,
                              text=True, timeout=600)
        assert proc.returncode == 0, f"README Python snippet {i} failed:\n{code}\n{proc.stderr[-2000:]}"
