"""Figures drawn in a helper process (report/_render.py): the same bytes as in the calling process, errors raised
where the caller waits, a dead helper replaced by drawing in the caller, inline where a helper cannot run."""

import multiprocessing
import os

import numpy as np
import pytest

from longprofile.report._render import BackgroundRenderer, InlineRenderer, figure_renderer


def _pid(_=None):
    return os.getpid()


def _fail(message):
    raise ValueError(message)


def _die_in_helper(parent_pid, value):
    if os.getpid() != parent_pid:
        os._exit(3)  # the helper dies mid-job
    return value


def _acceptance_inputs():
    from longprofile.road import Profile
    from longprofile.road.smoothness._acceptance import smoothness_acceptance, spec_from_dict
    from longprofile.road.smoothness._grinding import simulate_grinding

    x = np.arange(0, 800, 0.025)
    bumps = sum(5e-3 * np.exp(-((x - s) / 0.4) ** 2) for s in (200.0, 520.0))
    z = np.column_stack([4e-3 * np.sin(2 * np.pi * x / 37) + bumps, 3e-3 * np.sin(2 * np.pi * x / 23) + bumps])
    prof = Profile(distance=x, elevation=z, tracks=("left", "right"))
    spec = spec_from_dict({"lot": {"length": 200.0}, "localized": {"threshold": 2.0},
                           "exclusions": {"zones": [[600.0, 610.0]]},
                           "pay": {"schedule": [[1.0, 1.05], [2.0, 1.0], [9.0, 0.9]]}})
    res = smoothness_acceptance(prof, spec, check_units=False)  # a sine, smoother than any pavement (0.16 m/km)
    return res, simulate_grinding(prof, spec, acceptance=res)


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs the fork start method")
def test_background_report_is_byte_identical_to_the_inline_report(tmp_path, monkeypatch):
    from longprofile.report import write_acceptance_report

    monkeypatch.setenv("LONGPROFILE_FIGURES", "helper")  # whatever the machine's load
    res, g = _acceptance_inputs()
    inline = write_acceptance_report(res, tmp_path / "inline", grinding=g, ground_profile=True)
    with figure_renderer() as renderer:
        assert renderer.background
        assert renderer.submit(_pid).result() != os.getpid()  # really drawn in another process
        calls = []
        back = write_acceptance_report(res, tmp_path / "back", grinding=lambda: calls.append(1) or g,
                                       renderer=renderer, ground_profile=True)
    assert calls == [1]
    assert [p.name for p in inline] == [p.name for p in back]
    assert "profile_ground.csv" in [p.name for p in back] and len(g.grinds)
    for a, b in zip(inline, back):
        assert a.read_bytes() == b.read_bytes(), a.name


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs the fork start method")
def test_errors_reach_the_caller_and_a_dead_helper_is_replaced_by_the_caller():
    renderer = BackgroundRenderer()
    try:
        with pytest.raises(ValueError, match="no such figure"):
            renderer.submit(_fail, "no such figure").result()
        assert renderer.submit(_die_in_helper, os.getpid(), 7).result() == 7  # drawn here after the helper died
        assert renderer.submit(_pid).result() == os.getpid()  # and every later figure too
    finally:
        renderer.close()
    with pytest.raises(ValueError, match="inline"):
        InlineRenderer().submit(_fail, "inline").result()


def test_inline_where_a_helper_cannot_run(monkeypatch):
    monkeypatch.setenv("LONGPROFILE_FIGURES", "inline")
    with figure_renderer() as renderer:
        assert not renderer.background
        assert renderer.submit(_pid).result() == os.getpid()
    monkeypatch.delenv("LONGPROFILE_FIGURES")
    with figure_renderer(background=False) as renderer:
        assert not renderer.background
    import longprofile.report._render as render

    monkeypatch.setattr(render.os, "getloadavg", lambda: (float(render._cores()), 0.0, 0.0))  # oversubscribed
    with figure_renderer() as renderer:
        assert not renderer.background
    monkeypatch.setattr(render.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert render._spare_core()
    monkeypatch.setenv("LONGPROFILE_FIGURES", "helper")
    with figure_renderer() as renderer:
        assert renderer.background == ("fork" in multiprocessing.get_all_start_methods())


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs the fork start method")
def test_a_command_with_plot_draws_in_its_helper_and_never_imports_matplotlib(tmp_path):
    import subprocess
    import sys

    code = ("import sys; from longprofile.cli.app import main; "
            "code = main(['road', 'simulate', '--profile', 'crenels', '--length', '300', '-o', 'rec.csv', "
            "'--plot', 'rec.png']); print(code, 'matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path,
                         env={**os.environ, "COLUMNS": "200", "LONGPROFILE_FIGURES": "helper"}).stdout
    assert out.strip().splitlines()[-1] == "0 False"
    assert (tmp_path / "rec.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_which_command_lines_get_a_figure_helper():
    from longprofile.cli.app import _draws_figures

    assert _draws_figures(["road", "iri", "p.csv", "--plot", "i.png"])
    assert _draws_figures(["rail", "settle", "--report=r/"])
    assert _draws_figures(["road", "acceptance", "p.erd", "-o", "acc/"])
    assert _draws_figures(["road", "report", "p.csv", "-o", "r/"])
    assert not _draws_figures(["road", "iri", "p.csv", "-o", "iri.csv"])
    assert not _draws_figures(["road", "convert", "report.csv", "x.erd"])


def test_the_helper_runs_by_default_only_where_it_was_measured_to_help(monkeypatch):
    from longprofile.cli.app import _figure_helper

    monkeypatch.delenv("LONGPROFILE_FIGURES", raising=False)
    assert _figure_helper(["road", "acceptance", "p.erd", "-o", "acc/"]) == (True, ())
    assert _figure_helper(["road", "convert", "p.erd", "p.parquet", "--plot", "p.png"]) == (True, ())
    on, preload = _figure_helper(["vehicle", "vertical", "estimate", "v.csv", "-o", "s.csv", "--plot", "s.png"])
    assert on and any(p.startswith("longprofile.vehicle.vertical") for p in preload)
    on, preload = _figure_helper(["vehicle", "slope", "log.csv", "-o", "s.csv", "--plot", "s.png"])
    assert on and "longprofile.vehicle:SlopeEstimate" in preload
    assert _figure_helper(["vehicle", "drive", "log.csv", "--plot", "s.png"]) == (False, ())
    assert _figure_helper(["road", "convert", "p.erd", "p.parquet"]) == (False, ())  # draws nothing
    monkeypatch.setenv("LONGPROFILE_FIGURES", "helper")
    assert _figure_helper(["vehicle", "drive", "log.csv", "--plot", "s.png"]) == (True, ())


def test_only_the_multi_figure_reports_get_a_second_helper():
    from longprofile.cli.app import _second_helper

    assert _second_helper(["road", "report", "p.csv", "-o", "r/"])
    assert _second_helper(["rail", "settle", "--sensors", "s.csv", "--report", "r/"])
    assert not _second_helper(["road", "reconstruct", "rec.csv", "-o", "p.csv", "--plot", "p.png"])
    assert not _second_helper(["vehicle", "slope", "log.csv", "-o", "s.csv", "--plot", "s.png"])


def test_every_preload_of_the_helper_resolves():
    """A misspelt module or name in the table would make the helper fail at start (and every figure be drawn
    inline): each entry is imported and its names fetched, as the helper does."""
    from longprofile.cli.app import _HELPER_COMMANDS
    from longprofile.report._render import _warm

    entries = sorted({e for preload in _HELPER_COMMANDS.values() for e in preload})
    assert entries
    _warm(tuple(entries))
    with pytest.raises(AttributeError):
        _warm(("longprofile.rail:NoSuchResult",))


def test_a_preload_entry_ending_in_parentheses_is_called(monkeypatch):
    """``"module:function()"``: the helper calls the command's own warm-up figure (``road reconstruct``:
    ``warm_reconstructions``); a plain name is only fetched."""
    import longprofile.report._apl as apl
    from longprofile.report._render import _warm

    calls = []
    monkeypatch.setattr(apl, "warm_reconstructions", lambda: calls.append(1))
    monkeypatch.delattr("longprofile.report.warm_reconstructions", raising=False)  # the lazy namespace re-reads it
    _warm(("longprofile.report:warm_reconstructions",))
    assert calls == []
    _warm(("longprofile.report:warm_reconstructions()",))
    assert calls == [1]


def test_the_reconstruction_figure_from_arrays_is_the_figure_from_the_reconstruction():
    """``road reconstruct --plot`` sends arrays (elevation, std) and the truth detrended in the command, so that the
    helper needs neither the road package nor scipy: the same PNG bytes as from the Reconstruction and the raw truth."""
    from longprofile.report._apl import plot_reconstructions, warm_reconstructions
    from longprofile.report._html import png_bytes
    from longprofile.road.apl import apl_model, detrend_profile, reconstruct_profile, simulate_apl_recording

    model = apl_model(20.0, 0.05)
    rec_in = simulate_apl_recording("iso8608", model, length=300.0, road_class="C", rng=3)
    rec = reconstruct_profile(rec_in.signal, model, method="smoother")
    truth = rec_in.true_elevation
    old = plot_reconstructions(rec_in.distance, rec_in.signal, {"smoother": rec}, truth=truth,
                               highpass_wavelength=100.0, dx=0.05, title="t")
    new = plot_reconstructions(rec_in.distance, rec_in.signal,
                               {"smoother": (rec.profile.elevation[:, 0], rec.profile.std[:, 0])},
                               truth=detrend_profile(truth - truth[0], 0.05, highpass_wavelength=100.0),
                               truth_detrended=True, title="t")
    assert png_bytes(old, dpi=120) == png_bytes(new, dpi=120)
    warm_reconstructions()  # draws to nothing, without error


def _imported(name):
    import sys

    return name in sys.modules


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="no fork start method")
def test_the_helper_imports_its_preload_before_the_first_figure():
    import sys

    assert "mailbox" not in sys.modules or pytest.skip("mailbox already imported in this process")
    renderer = BackgroundRenderer(preload=("mailbox",))
    try:
        assert renderer.submit(_imported, "mailbox").result() is True
    finally:
        renderer.close()
    assert "mailbox" not in sys.modules  # imported in the helper only


def _name_pid(name, suffix):
    import time

    time.sleep(0.2)  # long enough for the second helper to take its share, even on a loaded machine
    if name == "boom":
        raise ValueError("boom")
    return name + suffix, os.getpid()


def _spread_names(names, suffix):
    from longprofile.report._render import spread

    return spread(_name_pid, names, suffix)


def _kill_second():
    from longprofile.report import _render

    for pid in [p.pid for p in _render._SECOND._processes.values()]:
        os.kill(pid, 9)
    return True


def test_spread_in_the_calling_process_keeps_the_order():
    from longprofile.report._render import spread

    out = spread(_name_pid, ["c", "a", "b"], "!")
    assert list(out) == ["c", "a", "b"] and [v[0] for v in out.values()] == ["c!", "a!", "b!"]
    assert {v[1] for v in out.values()} == {os.getpid()}


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs the fork start method")
def test_two_helpers_share_a_job_keep_its_order_and_stop_with_the_renderer():
    import time

    names = ["a", "b", "c", "d", "e", "f"]
    renderer = BackgroundRenderer(second=True)
    try:
        out = renderer.submit(_spread_names, names, "?").result()
        assert list(out) == names and [v[0] for v in out.values()] == [n + "?" for n in names]
        pids = {v[1] for v in out.values()}
        assert len(pids) == 2 and os.getpid() not in pids  # drawn by the helper and by its second helper
        for failing in (["x", "boom"], ["boom", "x"]):  # raised in the second helper, then in the first
            with pytest.raises(ValueError, match="boom"):
                renderer.submit(_spread_names, failing, "").result()
    finally:
        t0 = time.perf_counter()
        renderer.close()  # the helper stops its second helper on exit (no hang)
        assert time.perf_counter() - t0 < 10


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs the fork start method")
def test_a_dead_second_helper_leaves_its_share_to_the_first():
    renderer = BackgroundRenderer(second=True)
    try:
        assert renderer.submit(_kill_second).result()
        out = renderer.submit(_spread_names, ["a", "b", "c"], "").result()
        assert [v[0] for v in out.values()] == ["a", "b", "c"]
        assert len({v[1] for v in out.values()}) == 1
    finally:
        renderer.close()


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs the fork start method")
def test_a_report_drawn_by_two_helpers_is_byte_identical_to_the_inline_report(tmp_path):
    from longprofile.report import write_road_report
    from longprofile.road import Profile, analyse_roughness

    x = np.arange(0, 600, 0.05)
    z = 3e-3 * np.sin(2 * np.pi * x / 31) + 1e-3 * np.sin(2 * np.pi * x / 3.7)
    analysis = analyse_roughness(Profile(distance=x, elevation=z[:, None], tracks=("left",)), segment_length=100.0)
    inline = write_road_report(analysis, tmp_path / "inline")
    from longprofile.report import use_renderer

    renderer = BackgroundRenderer(second=True)
    try:
        with use_renderer(renderer):
            back = write_road_report(analysis, tmp_path / "back")
    finally:
        renderer.close()
    assert [p.name for p in inline] == [p.name for p in back]
    for a, b in zip(inline, back):
        assert a.read_bytes() == b.read_bytes(), a.name


def _imported(name):
    import sys

    return name in sys.modules


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs the fork start method")
@pytest.mark.parametrize("inherit", [False, True])
def test_an_inherited_preload_is_imported_once_before_the_fork(tmp_path, monkeypatch, inherit):
    """``inherit=True`` (``rail settle``: pandas, which the command imports first anyway): the preload is imported
    in the calling process before the helper is forked, and the helper has it without importing its own copy; an
    entry ending in ``()`` is still called in the helper only."""
    import sys

    (tmp_path / "lp_preload_probe.py").write_text("import os\nPID = os.getpid()\ndef warm():\n"
                                                  "    open(os.path.join(os.path.dirname(__file__), f'warm-{os.getpid()}'),"
                                                  " 'w').close()\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("LONGPROFILE_FIGURES", "helper")
    monkeypatch.delitem(sys.modules, "lp_preload_probe", raising=False)
    with figure_renderer(preload=("lp_preload_probe:warm()",), inherit=inherit) as renderer:
        assert renderer.background
        assert _imported("lp_preload_probe") is inherit
        helper = renderer.submit(_pid).result()
        imported_at = renderer.submit(_probe_pid).result()
    assert helper != os.getpid()
    assert imported_at == (os.getpid() if inherit else helper)  # the module object the helper holds was made here
    assert [p.name for p in tmp_path.glob("warm-*")] == [f"warm-{helper}"]  # called in the helper only
    sys.modules.pop("lp_preload_probe", None)


def _probe_pid(_=None):
    import lp_preload_probe

    return lp_preload_probe.PID


def test_rail_settle_inherits_its_preload():
    from longprofile.cli.app import _INHERIT_PRELOAD_COMMANDS, _command_in

    assert _command_in(["rail", "settle", "--sensors", "s.csv", "--report", "r/"], _INHERIT_PRELOAD_COMMANDS)
    assert not _command_in(["road", "report", "p.csv", "-o", "r/"], _INHERIT_PRELOAD_COMMANDS)
