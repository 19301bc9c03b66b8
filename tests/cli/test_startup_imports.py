"""Start-up guard (issue 12): a command imports only the heavy libraries it uses.

Each command runs in a fresh interpreter (``cli.app.main``), which then lists the heavy top-level modules found in
``sys.modules``. A module-level import of matplotlib, scipy.signal, pandas or the service stack added to a module on
a light command's path makes the matching case fail (checked 2026-12-03 by re-adding ``import matplotlib`` to
``cli/_common.py`` and ``from scipy import signal`` to ``road/indices/_iri.py``).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

HEAVY = ("matplotlib", "scipy.signal", "scipy.stats", "scipy.optimize", "pandas", "pyarrow", "numba",
         "sqlalchemy", "fastapi", "jinja2", "alembic")

_DRIVER = (
    "import json, sys\n"
    "from longprofile.cli.app import main\n"
    "args = json.loads(sys.argv[1])\n"
    "code = main(args) if args is not None else 0\n"
    "heavy = json.loads(sys.argv[3])\n"
    "open(sys.argv[2], 'w').write(json.dumps([code, [m for m in heavy if m in sys.modules]]))\n"
)


def _heavy_imports(args, tmp_path) -> set[str]:
    out = tmp_path / "modules.json"
    proc = subprocess.run([sys.executable, "-c", _DRIVER, json.dumps(args), str(out), json.dumps(HEAVY)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    code, found = json.loads(out.read_text())
    assert code == 0, proc.stdout + proc.stderr
    return set(found)


@pytest.fixture
def profile_csv(tmp_path):
    x = np.arange(0.0, 300.0, 0.25)
    path = tmp_path / "p.csv"
    path.write_text("distance_m,elevation_m\n" + "\n".join(f"{d:.6f},{1e-3 * np.sin(d / 3.0):.9f}" for d in x) + "\n")
    return path


@pytest.mark.parametrize("args", [None, ["--help"], ["road", "--help"], ["rail", "site", "--help"],
                                  ["vehicle", "vertical", "--help"]], ids=["import", "help", "road-help",
                                                                           "rail-site-help", "vertical-help"])
def test_app_and_help_import_no_heavy_library(args, tmp_path):
    assert _heavy_imports(args, tmp_path) == set()


def test_road_convert_to_erd_loads_no_numba_scipy_or_matplotlib(profile_csv, tmp_path):
    found = _heavy_imports(["road", "convert", str(profile_csv), str(tmp_path / "p.erd")], tmp_path)
    assert found <= {"pandas", "pyarrow"}, found  # the CSV reader


def test_road_iri_loads_no_scipy_signal_matplotlib_or_service(profile_csv, tmp_path):
    found = _heavy_imports(["road", "iri", str(profile_csv), "--units", "us", "-o", str(tmp_path / "iri.csv")],
                           tmp_path)
    assert found <= {"pandas", "pyarrow", "numba"}, found


def test_vehicle_simulate_loads_no_scipy_signal_matplotlib_or_service(tmp_path):
    found = _heavy_imports(["vehicle", "simulate", "--scenario", "hill", "--duration", "1", "-o",
                            str(tmp_path / "log.csv")], tmp_path)
    assert found <= {"pandas", "pyarrow", "numba"}, found


def test_road_simulate_loads_no_scipy_signal_matplotlib_or_service(tmp_path, monkeypatch):
    # the APL response is the engine's SOS filter (numba) on the instrument's sections from the design cache: with
    # the cache warm, no scipy.signal (2026-12-06: 0.82-0.89 s against 1.06-1.19 s with scipy.signal.sosfilt)
    monkeypatch.setenv("LONGPROFILE_CACHE_DIR", str(tmp_path / "design-cache"))
    for n in (1, 2):
        found = _heavy_imports(["road", "simulate", "--road-class", "C", "--length", "200", "-o",
                                str(tmp_path / f"r{n}.csv")], tmp_path)
    assert found <= {"pandas", "pyarrow", "numba"}, found


def test_road_compare_loads_no_scipy_signal_or_service(profile_csv, tmp_path):
    run = tmp_path / "run.csv"  # another run of the same road (a copy of the reference is refused: issue 13)
    x = np.arange(0.0, 300.0, 0.25)
    run.write_text("distance_m,elevation_m\n" + "\n".join(f"{d:.6f},{1e-3 * np.sin(d / 3.0) + 1e-5 * np.cos(d):.9f}"
                                                           for d in x) + "\n")
    found = _heavy_imports(["road", "compare", str(profile_csv), str(run), "-o", str(tmp_path / "cmp")], tmp_path)
    # the cross-correlation is scipy.fft's (scipy.signal's import is ~0.4 s, issue 12)
    assert found <= {"pandas", "pyarrow", "numba"}, found


def test_road_report_loads_no_scipy_signal_or_service(profile_csv, tmp_path):
    found = _heavy_imports(["road", "report", str(profile_csv), "-o", str(tmp_path / "report")], tmp_path)
    # the Welch PSD is matplotlib.mlab's (scipy.signal's import is ~0.35 s of the command, issue 12); matplotlib
    # draws the figures (here, or in the figure helper process when a core is free)
    assert found <= {"pandas", "pyarrow", "numba", "matplotlib", "jinja2"}, found  # jinja2: the page template


# ---------------------------------------------------------------- filters without scipy.signal (issue 12)
# The APL reconstruction and the vertical-vehicle estimator filter with the engine's second-order sections
# (statespace.sos_filter / sos_filtfilt) on designs read from the design cache: once a command has run, the next
# run of it loads no scipy.signal (scipy.signal's import was 0.45-0.7 s of these commands). Checked on sys.modules
# at the end of the second run, in a cache folder of the test's own.


@pytest.fixture
def design_cache(tmp_path, monkeypatch):
    folder = tmp_path / "design-cache"
    monkeypatch.setenv("LONGPROFILE_CACHE_DIR", str(folder))
    return folder


@pytest.fixture
def apl_recording(tmp_path, design_cache):
    assert _heavy_imports(["road", "simulate", "--road-class", "C", "--length", "150", "-o",
                           str(tmp_path / "rec.csv")], tmp_path) is not None
    return tmp_path / "rec.csv"


def _warm_then_modules(args, tmp_path):
    """Run ``args`` twice (``{n}`` in an argument is the run number); the heavy modules of the second run."""
    _heavy_imports([a.format(n=1) for a in args], tmp_path)
    return _heavy_imports([a.format(n=2) for a in args], tmp_path)


@pytest.mark.parametrize("method", ["smoother", "filter", "double", "fixed-lag"])
def test_road_reconstruct_with_a_warm_design_cache_loads_no_scipy_signal(apl_recording, tmp_path, method):
    found = _warm_then_modules(["road", "reconstruct", str(apl_recording), "--method", method, "-o",
                                str(tmp_path / "p{n}.erd")], tmp_path)
    assert "scipy.signal" not in found and "scipy.stats" not in found, found


@pytest.mark.parametrize("method", ["smoother", "filter", "fixed-lag"])
def test_road_reconstruct_fitting_q_and_r_loads_no_scipy_optimize(apl_recording, tmp_path, method):
    # the q/r likelihood search is the package's own Brent minimiser (road/apl/_minimize.py): scipy.optimize's
    # import was 0.18-0.28 s CPU of every method (2026-12-07). With a warm design cache (scipy.signal, which a cold
    # one needs for the filter designs, imports scipy.optimize itself); --plot draws with matplotlib alone
    found = _warm_then_modules(["road", "reconstruct", str(apl_recording), "--method", method, "-o",
                                str(tmp_path / "p{n}.csv"), "--plot", str(tmp_path / "p{n}.png")], tmp_path)
    assert "scipy.optimize" not in found, found


def test_vehicle_vertical_commands_with_a_warm_design_cache_load_no_scipy_signal(tmp_path, design_cache):
    log = tmp_path / "vlog.csv"
    found = _warm_then_modules(["vehicle", "vertical", "simulate", "--config", "3", "--road-class", "C", "--speed",
                                "20", "--duration", "1", "-o", str(tmp_path / "vlog{n}.csv")], tmp_path)
    assert "scipy.signal" not in found, found
    (tmp_path / "vlog2.csv").rename(log)
    found = _warm_then_modules(["vehicle", "vertical", "estimate", str(log), "--config", "3", "-o",
                                str(tmp_path / "vstates{n}.csv"), "--profile", str(tmp_path / "wheels{n}.csv"),
                                "--speed", "20"], tmp_path)
    assert "scipy.signal" not in found and "scipy.stats" not in found, found
    found = _warm_then_modules(["vehicle", "vertical", "tables", "--car", "magneride", "--reference", "thesis",
                                "--duration", "1.2", "-o", str(tmp_path / "vtables{n}.csv")], tmp_path)
    assert "scipy.signal" not in found and "scipy.stats" not in found, found
