"""The public surface: every exported name exists, is documented, and the engine's namespace is pinned."""

import importlib
import inspect

import pytest

SUBPACKAGES = ["statespace", "signal", "identify", "road", "rail", "vehicle", "io", "report", "batch", "errors", "core",
               "road.apl", "road.indices", "road.smoothness"]


@pytest.mark.parametrize("name", SUBPACKAGES)
def test_exports_exist_and_are_documented(name):
    mod = importlib.import_module(f"longprofile.{name}")
    assert mod.__doc__ and mod.__doc__.strip(), f"longprofile.{name} has no index docstring"
    exported = getattr(mod, "__all__", None)
    assert exported, f"longprofile.{name} declares no __all__"
    assert len(set(exported)) == len(exported), f"duplicate names in longprofile.{name}.__all__"
    undocumented = []
    for attr in exported:
        obj = getattr(mod, attr)  # AttributeError here means __all__ names something missing
        if (inspect.isfunction(obj) or inspect.isclass(obj)) and not (obj.__doc__ or "").strip():
            undocumented.append(attr)
    assert not undocumented, f"longprofile.{name}: no docstring on {undocumented}"


def test_import_has_no_side_effects_on_warnings_or_logging():
    # in a fresh interpreter, so that no other test has imported anything yet
    import subprocess
    import sys

    code = (
        "import logging, warnings, importlib\n"
        # third-party imports install their own filters (numpy, scipy.special): baseline after them
        "import numpy, scipy.linalg, scipy.signal, scipy.optimize, scipy.special, scipy.stats, scipy.sparse\n"
        "import pandas, numba, matplotlib, typer, rich, pyarrow\n"
        "f, h = list(warnings.filters), list(logging.getLogger().handlers)\n"
        f"for n in {SUBPACKAGES!r}: importlib.import_module('longprofile.' + n)\n"
        "import longprofile.cli.app\n"
        "assert list(warnings.filters) == f, 'warnings filters changed by import'\n"
        "assert list(logging.getLogger().handlers) == h, 'logging handlers changed by import'\n"
        "import matplotlib\n"
        "print('ok')\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr


def test_lazy_vehicle_namespace_lists_exactly_its_exports_and_stays_light():
    import subprocess
    import sys

    import longprofile.vehicle as vehicle

    assert {n for names in vehicle._EXPORTS.values() for n in names} == set(vehicle.__all__)
    assert set(vehicle.__all__) <= set(dir(vehicle))
    with pytest.raises(AttributeError, match="no attribute 'estimate_slopes'"):
        vehicle.estimate_slopes  # noqa: B018
    # the planar estimator does not drag in the vertical estimators (and scipy.signal)
    code = ("import sys\nfrom longprofile.vehicle import estimate_slope\n"
            "print('longprofile.vehicle.vertical' in sys.modules, 'scipy.signal' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.stdout.split() == ["False", "False"], proc.stdout + proc.stderr


def test_lazy_report_namespace_lists_exactly_its_exports_and_loads_only_what_is_used():
    import subprocess
    import sys

    import longprofile.report as report

    assert {n for names in report._EXPORTS.values() for n in names} == set(report.__all__)
    assert set(report.__all__) <= set(dir(report))
    # the acceptance page does not drag in the derivative kernels or the vehicle figures; importing the package
    # alone loads no matplotlib
    code = ("import sys\nimport longprofile.report\nbare = 'matplotlib' in sys.modules\n"
            "from longprofile.report import write_acceptance_report\n"
            "print(bare, 'longprofile.signal._kernels' in sys.modules, 'longprofile.report._vehicle_vertical' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.stdout.split() == ["False", "False", "False"], proc.stdout + proc.stderr
