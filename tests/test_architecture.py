"""The architecture contract (docs/architecture.md, issue 12): no upward import, no private cross-package import.

Every ``import`` statement in ``src/longprofile`` (module level *and* inside functions: a lazy import is still a
dependency) is resolved to the longprofile module it names and checked against the layers:

    shared   errors, _validation, _jit, _lazy, _atomic, _memory, core
    engine   statespace
    domains  signal, identify, road, rail, vehicle          (rail.service is an edge)
    edges    io, report, demos, batch, rail.service, cli, __main__

A module may import its own layer or below, never above. Among the edges, ``cli`` is imported only by
``__main__`` and ``demos`` only by ``cli``. Across units (a unit is a top-level subpackage; ``rail.service`` is
its own unit), only public names are imported: no ``longprofile.road._iri`` from ``vehicle``, no
``from ..report._road import`` in ``batch``.

The checker is tested on synthetic sources too, so a broken rule cannot pass silently.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "longprofile"

LAYERS = {
    "errors": 0, "_validation": 0, "_jit": 0, "_lazy": 0, "_atomic": 0, "_memory": 0, "core": 0, "__init__": 0,
    "statespace": 1,
    "signal": 2, "identify": 2, "road": 2, "rail": 2, "vehicle": 2,
    "io": 3, "report": 3, "demos": 3, "batch": 3, "rail.service": 3, "cli": 3, "__main__": 3,
}


def unit_of(module: str) -> str:
    """The unit of a dotted module name inside longprofile: 'road', 'rail.service', 'errors', ..."""
    parts = module.split(".")[1:]  # drop 'longprofile'
    if not parts:
        return "__init__"
    if parts[0] == "rail" and len(parts) > 1 and parts[1] == "service":
        return "rail.service"
    return parts[0]


def module_name(path: Path, root: Path = SRC) -> str:
    rel = path.relative_to(root.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imported_modules(source: str, module: str, is_package: bool) -> list[tuple[int, str]]:
    """(line, absolute module) for every longprofile import in ``source`` (``from X import name`` yields X.name, so
    importing a private module by name is seen)."""
    tree = ast.parse(source)
    package = module if is_package else module.rsplit(".", 1)[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == "longprofile"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "longprofile":
                continue
            out.append((node.lineno, target))
            out += [(node.lineno, f"{target}.{a.name}") for a in node.names if a.name.startswith("_")
                    and not a.name.startswith("__")]
    return out


def _private_part(target: str, unit: str) -> bool:
    """Does ``target`` reach below the public surface of ``unit`` (a ``_name`` after the unit's own prefix)?"""
    rest = target.split(".")[1 + len(unit.split(".")):] if unit != "__init__" else target.split(".")[1:]
    return any(p.startswith("_") and not p.startswith("__") for p in rest)


def violations(module: str, source: str, is_package: bool = False) -> list[str]:
    """Rule violations of one module (empty when it keeps the contract)."""
    me = unit_of(module)
    found = []
    for line, target in imported_modules(source, module, is_package):
        other = unit_of(target)
        if other == me or other == "__init__":
            continue
        where = f"{module}:{line} imports {target}"
        if LAYERS.get(other, 3) > LAYERS.get(me, 3):
            found.append(f"{where}: upward import ({me} is below {other})")
        elif other == "cli" and me != "__main__":
            found.append(f"{where}: only __main__ imports the CLI")
        elif other == "demos" and me != "cli":
            found.append(f"{where}: only the CLI imports demos")
        elif _private_part(target, other):
            found.append(f"{where}: private name of another package (import its public API)")
    return found


def _all_modules():
    for path in sorted(SRC.rglob("*.py")):
        yield path, module_name(path), path.name == "__init__.py"


def test_the_source_tree_keeps_the_architecture_contract():
    problems = []
    for path, module, is_pkg in _all_modules():
        problems += violations(module, path.read_text(), is_pkg)
    assert not problems, "architecture contract broken (docs/architecture.md):\n" + "\n".join(problems)


@pytest.mark.parametrize("module, source, expected", [
    ("longprofile.statespace._kalman", "from ..road import Profile\n", "upward import"),
    ("longprofile.road._x", "def f():\n    from ..io import read_profile\n", "upward import"),  # lazy: still upward
    ("longprofile.rail._x", "import longprofile.report\n", "upward import"),
    ("longprofile.vehicle._x", "from ..road._iri import iri\n", "private name"),
    ("longprofile.batch._x", "from ..report._road import LIMITS\n", "private name"),
    ("longprofile.batch._x", "from ..report import _road\n", "private name"),
    ("longprofile.report._x", "from ..cli import app\n", "only __main__"),
    ("longprofile.report._x", "from ..demos import road_apl\n", "only the CLI imports demos"),
    ("longprofile.io._x", "from ..core import Profile\nfrom ..errors import InputError\n", None),
    ("longprofile.road.apl._x", "from .._y import z\nfrom ...statespace import kalman_filter\n", None),
    ("longprofile.rail.service._web", "from ...rail import estimate_settlement\n", None),
    ("longprofile.cli.road", "from ..demos import road_apl\nfrom ..road import iri\n", None),
])
def test_the_checker_flags_each_kind_of_breach(module, source, expected):
    found = violations(module, source)
    if expected is None:
        assert found == []
    else:
        assert found and all(expected in f for f in found), found


# ---- function size (issue 12: no function over 120 lines outside unrolled kernels) ----------------------------

MAX_FUNCTION_LINES = 120
#: The functions allowed to be longer, each named: (file under src/longprofile, qualified name). The unrolled
#: Kalman filter kernel (its factory and the kernel it compiles: one loop, split it and numba loses the unrolling)
#: and the generated schema migration (Alembic output, a list of tables, frozen history).
SIZE_EXEMPT = {
    ("statespace/_kernels.py", "_make_filter_kernel"),
    ("statespace/_kernels.py", "_make_filter_kernel.kernel"),
    ("rail/service/migrations/versions/0001_initial_schema.py", "upgrade"),
}


def function_lengths(source: str) -> dict[str, int]:
    """Lines of every function and method (``def`` line to last line, docstring included), by qualified name."""
    out = {}

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = prefix + child.name
                if not isinstance(child, ast.ClassDef):
                    out[name] = child.end_lineno - child.lineno + 1
                visit(child, name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(source), "")
    return out


def long_functions(root: Path = SRC, limit: int = MAX_FUNCTION_LINES, exempt=SIZE_EXEMPT) -> list[str]:
    """Functions of the package under ``root`` longer than ``limit`` lines and not exempt: "file: name has N lines"."""
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        found += [f"{rel}: {name} has {n} lines" for name, n in function_lengths(path.read_text()).items()
                  if n > limit and (rel, name) not in exempt]
    return found


def test_no_function_over_120_lines():
    found = long_functions()
    assert not found, "split these into named stages (small private helpers):\n" + "\n".join(found)
    for rel, name in SIZE_EXEMPT:  # an exemption names a function that exists (no stale entry after a rename)
        assert name in function_lengths((SRC / rel).read_text()), (rel, name)


def test_the_size_check_counts_every_line_and_only_named_exemptions(tmp_path):
    body = "\n".join(f"    x{i} = {i}" for i in range(119))
    doc = '    """' + "\n".join(["doc"] * 5) + '"""\n'
    method = "\n".join("    " + line for line in (doc + body).splitlines())
    (tmp_path / "m.py").write_text(f"def fits():\n{body}\n\n\ndef over():\n{doc}{body}\n\n\n"
                                   f"class C:\n    @njit\n    def k(self):\n{method}\n")
    assert function_lengths((tmp_path / "m.py").read_text()) == {"fits": 120, "over": 125, "C.k": 125}
    assert long_functions(tmp_path) == ["m.py: over has 125 lines", "m.py: C.k has 125 lines"]
    assert long_functions(tmp_path, exempt={("m.py", "C.k")}) == ["m.py: over has 125 lines"]
    assert long_functions(tmp_path, limit=125) == []
