"""Every command and snippet of the user guides (``docs/guide/*.md``) runs as written, in a fresh folder.

As the README (:mod:`tests.test_readme`): each guide's ```sh blocks run line by line with bash, in order, from one
temporary folder per guide with the project's ``.venv/bin`` first on PATH, then its ```python blocks as scripts in
the same folder. A block fenced as ```text or ```console is shown, not run (e.g. a command's printed output).
"""

import subprocess
import sys

import pytest

from tests.test_readme import ROOT, _env, markdown_blocks, shell_commands

GUIDES = sorted((ROOT / "docs" / "guide").glob("*.md"))


def test_there_are_guides_and_the_readme_links_them():
    assert GUIDES, "docs/guide/ has no guide"
    readme = (ROOT / "README.md").read_text()
    for guide in GUIDES:
        assert f"docs/guide/{guide.name}" in readme, f"the README does not link {guide.name}"


@pytest.mark.parametrize("guide", GUIDES, ids=[g.stem for g in GUIDES])
def test_guide_commands_and_snippets_run_as_written(guide, tmp_path):
    text = guide.read_text()
    for cmd in shell_commands(text):
        proc = subprocess.run(["bash", "-c", cmd], cwd=tmp_path, env=_env(), capture_output=True, text=True,
                              timeout=600)
        assert proc.returncode == 0, f"{guide.name}: command failed (exit {proc.returncode}): {cmd}\n" \
                                     f"{proc.stderr[-2000:]}"
    for i, code in enumerate(markdown_blocks(text, "python")):
        script = tmp_path / f"snippet_{i}.py"
        script.write_text(code)
        proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=_env(), capture_output=True,
                              text=True, timeout=600)
        assert proc.returncode == 0, f"{guide.name}: Python snippet {i} failed:\n{code}\n{proc.stderr[-2000:]}"
