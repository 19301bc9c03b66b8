"""Issue 13, "never lose what the user had": an existing output is refused without --overwrite (exit 2, one line,
the file left byte-identical), replaced with it, and a failure while replacing leaves the old file intact."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import signal as sps

from longprofile.cli.app import main


def _snapshot(path: Path) -> dict:
    """Bytes of a file, or of every file under a folder (relative name -> bytes)."""
    if path.is_dir():
        return {str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}
    return {path.name: path.read_bytes()}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("inputs")
    rng = np.random.default_rng(0)
    x = np.arange(0, 300.0, 0.25)
    z = np.cumsum(rng.normal(0, 0.4, (x.size, 2)), axis=0)  # mm
    pd.DataFrame({"distance_m": x, "left_mm": z[:, 0], "right_mm": z[:, 1]}).to_csv(d / "prof.csv", index=False)
    z2 = z + rng.normal(0, 0.05, z.shape)
    pd.DataFrame({"distance_m": x, "left_mm": z2[:, 0], "right_mm": z2[:, 1]}).to_csv(d / "prof2.csv", index=False)
    t = np.arange(400) * 1e-3
    pd.DataFrame({"t": t, "x": np.sin(2 * np.pi * 2 * t)}).to_csv(d / "sig.csv", index=False)
    from longprofile.road.apl import apl_model

    m = apl_model(20.0, 0.05)
    k = np.arange(3000)
    u = np.where(((k + 250) // 500) % 2 == 1, 0.01, 0.0)
    y = sps.lfilter(m.numerator, m.denominator, u) + rng.normal(0, 2e-5, k.size)
    pd.DataFrame({"u": u}).to_csv(d / "u.csv", index=False)
    pd.DataFrame({"y": y}).to_csv(d / "y.csv", index=False)
    assert main(["road", "simulate", "-o", str(d / "rec.csv"), "--length", "300"]) == 0
    assert main(["rail", "simulate", "-o", str(d / "site"), "--days", "5", "--sampling-minutes", "120"]) == 0
    assert main(["vehicle", "simulate", "-o", str(d / "drive.csv"), "--duration", "2"]) == 0
    assert main(["vehicle", "vertical", "simulate", "-o", str(d / "vlog.csv"), "--duration", "2"]) == 0
    (d / "surveys").mkdir()
    for name in ("a.csv", "b.csv"):
        (d / "surveys" / name).write_bytes((d / "prof.csv").read_bytes())
    assert main(["batch", "iri", str(d / "surveys" / "*.csv"), "-o", str(d / "results"), "--scheduler", "serial"]) == 0
    return d


# name: (arguments with {i} = inputs folder and {o} = output folder, the output that must survive)
COMMANDS = {
    "road simulate": (["road", "simulate", "--length", "300", "-o", "{o}/rec.csv"], "rec.csv"),
    "road simulate --plot": (["road", "simulate", "--length", "300", "-o", "{o}/r-{n}.csv", "--plot", "{o}/r.png"],
                             "r.png"),
    "road reconstruct": (["road", "reconstruct", "{i}/rec.csv", "--q", "2e-6", "--r", "1e-8", "-o", "{o}/p.csv"],
                         "p.csv"),
    "road identify": (["road", "identify", "--input", "{i}/u.csv", "--output", "{i}/y.csv", "--orders", "5", "6", "0",
                       "-o", "{o}/model.json"], "model.json"),
    "road iri": (["road", "iri", "{i}/prof.csv", "-o", "{o}/iri.csv"], "iri.csv"),
    "road iri --plot": (["road", "iri", "{i}/prof.csv", "-o", "{o}/iri-{n}.csv", "--plot", "{o}/iri.png"], "iri.png"),
    "road report": (["road", "report", "{i}/prof.csv", "-o", "{o}/report"], "report"),
    "road convert": (["road", "convert", "{i}/prof.csv", "{o}/prof.erd"], "prof.erd"),
    "road compare": (["road", "compare", "{i}/prof.csv", "{i}/prof2.csv", "-o", "{o}/compare"], "compare"),
    "road acceptance": (["road", "acceptance", "{i}/prof.csv", "-o", "{o}/acceptance"], "acceptance"),
    "rail simulate": (["rail", "simulate", "--days", "5", "--sampling-minutes", "120", "-o", "{o}/site"], "site"),
    "rail settle": (["rail", "settle", "--sensors", "{i}/site/sensors.csv", "--readings", "{i}/site/readings.csv",
                     "--survey", "{i}/site/survey.csv", "--monte-carlo", "20", "-o", "{o}/settle.csv"], "settle.csv"),
    "rail settle --report": (["rail", "settle", "--sensors", "{i}/site/sensors.csv", "--readings",
                              "{i}/site/readings.csv", "--survey", "{i}/site/survey.csv", "--monte-carlo", "20",
                              "-o", "{o}/s-{n}.csv", "--report", "{o}/rail_report"], "rail_report"),
    "vehicle simulate": (["vehicle", "simulate", "--duration", "2", "-o", "{o}/drive.csv"], "drive.csv"),
    "vehicle slope": (["vehicle", "slope", "{i}/drive.csv", "-o", "{o}/states.csv"], "states.csv"),
    "vehicle vertical simulate": (["vehicle", "vertical", "simulate", "--duration", "2", "-o", "{o}/v.csv"], "v.csv"),
    "vehicle vertical estimate": (["vehicle", "vertical", "estimate", "{i}/vlog.csv", "-o", "{o}/est.csv"], "est.csv"),
    "vehicle vertical estimate --profile": (["vehicle", "vertical", "estimate", "{i}/vlog.csv", "-o", "{o}/e-{n}.csv",
                                             "--profile", "{o}/wheels.csv", "--speed", "20"], "wheels.csv"),
    "vehicle vertical tables": (["vehicle", "vertical", "tables", "--duration", "2", "-o", "{o}/tables.csv"],
                                "tables.csv"),
    "differentiate": (["differentiate", "{i}/sig.csv", "-c", "x", "--dt", "1e-3", "-w", "10", "-o", "{o}/d.csv"],
                      "d.csv"),
    "batch report": (["batch", "report", "{i}/results", "-o", "{o}/network"], "network"),
}


def _args(template, inputs, out, n):
    return [a.format(i=inputs, o=out, n=n) for a in template]


@pytest.mark.parametrize("name", list(COMMANDS))
def test_second_run_is_refused_without_overwrite(name, inputs, tmp_path, capsys):
    template, target = COMMANDS[name]
    path = tmp_path / target
    assert main(_args(template, inputs, tmp_path, 1)) == 0
    before = _snapshot(path)
    assert before and all(before.values())
    capsys.readouterr()
    # {n} gives the other outputs of the command a new name: the refusal is about `target`
    assert main(_args(template, inputs, tmp_path, 2)) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err  # one line, printed before any work (no progress bar)
    assert err.startswith("error:") and str(path) in err and "--overwrite" in err
    assert _snapshot(path) == before
    assert not list(tmp_path.glob("*-2.csv"))  # nothing else written either
    # sentinel bytes in every file of the output: a run that exits 0 and writes nothing cannot pass
    sentinel = b"sentinel: must be replaced by --overwrite\n"
    for rel in before:
        (path / rel if path.is_dir() else path).write_bytes(sentinel)
    assert main(_args(template, inputs, tmp_path, 3) + ["--overwrite"]) == 0
    after = _snapshot(path)
    assert set(after) == set(before)  # the same files...
    stale = [rel for rel, data in after.items() if data == sentinel]
    assert not stale, f"--overwrite left these files unwritten: {stale}"  # ...replaced
    assert not list(path.parent.glob(".*.tmp*"))  # no temporary file left behind


# an input inside the output folder, under a name the command writes there: refused even with --overwrite
INPUT_IN_OUTPUT = {
    "road compare": (["road", "compare", "{o}/runs.csv", "{i}/prof2.csv", "-o", "{o}"], "runs.csv"),
    "road compare (run)": (["road", "compare", "{i}/prof.csv", "{o}/pairs.csv", "-o", "{o}"], "pairs.csv"),
    "road acceptance": (["road", "acceptance", "{o}/profile_ground.csv", "-o", "{o}"], "profile_ground.csv"),
    "road acceptance (lots)": (["road", "acceptance", "{o}/lots.csv", "-o", "{o}"], "lots.csv"),
    "road report": (["road", "report", "{o}/iri_segments.csv", "-o", "{o}"], "iri_segments.csv"),
    "rail settle --report": (["rail", "settle", "--sensors", "{o}/sensors.csv", "--readings", "{i}/site/readings.csv",
                              "--survey", "{i}/site/survey.csv", "--monte-carlo", "20", "-o", "{i}/../s-{n}.csv",
                              "--report", "{o}"], "sensors.csv"),
}


@pytest.mark.parametrize("name", list(INPUT_IN_OUTPUT))
def test_overwrite_never_replaces_an_input_inside_the_output_folder(name, inputs, tmp_path, capsys, monkeypatch):
    template, target = INPUT_IN_OUTPUT[name]
    source = inputs / ("site/sensors.csv" if target == "sensors.csv" else "prof.csv")
    (tmp_path / target).write_bytes(source.read_bytes())
    before = _snapshot(tmp_path)
    import longprofile.io as lio

    def no_work(*args, **kwargs):
        raise AssertionError("an input was read before the output folder was checked")

    monkeypatch.setattr(lio, "read_profile", no_work)
    monkeypatch.setattr(lio, "read_rail_site", no_work)
    capsys.readouterr()
    assert main(_args(template, inputs, tmp_path, 1) + ["--overwrite"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "would overwrite its input" in err and target in err, err
    assert _snapshot(tmp_path) == before  # the input's bytes unchanged, nothing written


def test_overwrite_never_allows_writing_over_an_input(inputs, tmp_path, capsys):
    prof = tmp_path / "prof.csv"
    prof.write_bytes((inputs / "prof.csv").read_bytes())
    assert main(["road", "convert", str(prof), str(prof), "--overwrite"]) == 2
    assert "is also an input" in capsys.readouterr().err
    assert prof.read_bytes() == (inputs / "prof.csv").read_bytes()


def test_overwrite_keeps_other_files_of_an_output_folder(inputs, tmp_path):
    out = tmp_path / "report"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert main(["road", "report", str(inputs / "prof.csv"), "-o", str(out)]) == 2
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    assert main(["road", "report", str(inputs / "prof.csv"), "-o", str(out), "--overwrite"]) == 0
    assert (out / "notes.txt").read_text() == "mine" and (out / "index.html").exists()


def test_failure_while_overwriting_leaves_the_old_file(inputs, tmp_path, monkeypatch):
    out = tmp_path / "iri.csv"
    assert main(["road", "iri", str(inputs / "prof.csv"), "-o", str(out)]) == 0
    before = out.read_bytes()
    import longprofile.io._report_tables as report_tables

    real = pd.DataFrame.to_csv

    def broken(self, fh=None, *args, **kwargs):
        if hasattr(fh, "write"):
            fh.write("distance_m,partial\n0,")  # started writing, then the disk is full
            raise OSError(28, "No space left on device")
        return real(self, fh, *args, **kwargs)

    monkeypatch.setattr(report_tables.pd.DataFrame, "to_csv", broken)
    # one line, exit 2 (the OSError is an OutputError saying what failed and what to do)
    assert main(["road", "iri", str(inputs / "prof.csv"), "-o", str(out), "--overwrite"]) == 2
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["iri.csv"]  # the temporary file was removed


@pytest.mark.parametrize("writer", ["table", "erd"])
def test_io_writers_replace_atomically(tmp_path, monkeypatch, writer):
    from longprofile.core import Profile
    from longprofile.io import write_erd, write_table

    x = np.arange(10) * 0.25
    prof = Profile(distance=x, elevation=np.zeros((10, 1)), tracks=("left",))
    path = tmp_path / ("t.csv" if writer == "table" else "p.erd")
    write = (lambda: write_table(pd.DataFrame({"a": x}), path)) if writer == "table" else (lambda: write_erd(prof, path))
    write()
    before = path.read_bytes()
    import pyarrow.csv as pacsv

    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(pacsv, "write_csv", broken)
    monkeypatch.setattr(pd.DataFrame, "to_csv", broken)
    with pytest.raises(OSError):
        write()
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


def test_vehicle_plots_are_announced_by_the_one_cli_figure_helper(inputs, tmp_path, capsys):
    import longprofile.cli._vehicle_planar as planar
    import longprofile.cli._vehicle_vertical as vertical

    assert not hasattr(planar, "_save_figure") and not hasattr(vertical, "_save_figure")  # one helper: _common's
    png = tmp_path / "drive.png"
    assert main(["vehicle", "simulate", "--duration", "2", "-o", str(tmp_path / "d.csv"), "--plot", str(png)]) == 0
    assert f"wrote {png}" in capsys.readouterr().err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("inside", [["-o", "{o}/rep/sensors.csv"], ["-o", "{o}/rep/mine.csv"],
                                    ["-o", "{o}/s.csv", "--plot", "{o}/rep/settlement.png"]])
def test_an_output_inside_the_report_folder_is_refused_before_any_work(inputs, tmp_path, capsys, inside):
    """Found by a user's probe (session 35): ``-o rep/sensors.csv --report rep --overwrite`` had the report's sensor
    table replace the settlement table; ``-o rep2/x.csv --report rep2`` computed, wrote -o, then refused the folder."""
    (tmp_path / "rep").mkdir()
    (tmp_path / "rep" / "sensors.csv").write_text("a user's earlier output\n")
    argv = ["rail", "settle", "--sensors", "{i}/site/sensors.csv", "--readings", "{i}/site/readings.csv", "--survey",
            "{i}/site/survey.csv", *inside, "--report", "{o}/rep", "--overwrite"]
    before = _snapshot(tmp_path)
    assert main([a.format(i=inputs, o=tmp_path) for a in argv]) == 2
    assert "is inside the --report folder" in capsys.readouterr().err.replace("\n", " ")
    assert _snapshot(tmp_path) == before
