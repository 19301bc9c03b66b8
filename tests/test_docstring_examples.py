"""The Examples in the library's docstrings run and print what they show (doctest), module by module.

Every module under ``src/longprofile`` whose docstrings hold a ``>>>`` example is imported and its examples are
run with :mod:`doctest` (``NORMALIZE_WHITESPACE | ELLIPSIS``; NumPy printing in its legacy-free default). An
example that cannot run in a test (it needs a user's file) says so with ``# doctest: +SKIP``.
"""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PKG = SRC / "longprofile"


def _modules_with_examples() -> list[str]:
    names = []
    for path in sorted(PKG.rglob("*.py")):
        if ">>> " not in path.read_text():
            continue
        rel = path.relative_to(SRC).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names.append(".".join(parts))
    return names


MODULES = _modules_with_examples()


def test_the_library_has_runnable_examples():
    assert len(MODULES) >= 8, MODULES


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS)
    tests = [t for t in finder.find(module, name) if t.examples]
    assert tests, f"{name} has '>>> ' text but no collectable example"
    for t in tests:
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} failing docstring example(s) in {name} (run: python -m doctest -v)"
