"""Bad input the way users get it wrong: one clear line, exit code 2, inputs never overwritten (user QA)."""

import numpy as np
import pandas as pd
import pytest

from longprofile.cli.app import main
from longprofile.io import read_table


def _err(capsys):
    return " ".join(capsys.readouterr().err.split())


@pytest.fixture()
def signal_csv(tmp_path):
    t = np.arange(400) * 1e-3
    path = tmp_path / "sig.csv"
    pd.DataFrame(dict(t=t, x=np.sin(2 * np.pi * 2 * t))).to_csv(path, index=False)
    return path


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "rec.csv"
    assert main(["road", "simulate", "-o", str(path), "--length", "100", "--seed", "3"]) == 0
    return path


# --- output paths ---------------------------------------------------------------------------------------------

def test_output_under_a_file_is_one_line_error(signal_csv, capsys):
    assert main(["differentiate", str(signal_csv), "-c", "x", "--dt", "1e-3", "-w", "10",
                 "-o", str(signal_csv / "d.csv")]) == 2
    assert "cannot create the folder" in _err(capsys)


def test_output_that_is_a_folder_is_refused(signal_csv, capsys):
    assert main(["differentiate", str(signal_csv), "-c", "x", "--dt", "1e-3", "-w", "10",
                 "-o", str(signal_csv.parent)]) == 2
    assert "is an existing folder" in _err(capsys)


def test_unknown_plot_format_is_refused_before_any_work(signal_csv, tmp_path, capsys):
    out = tmp_path / "d.csv"
    assert main(["differentiate", str(signal_csv), "-c", "x", "--dt", "1e-3", "-w", "10", "-o", str(out),
                 "--plot", str(tmp_path / "d.txt")]) == 2
    assert "unknown figure format '.txt'" in _err(capsys)
    assert not out.exists()


def test_simulate_refuses_a_plot_named_like_a_table(tmp_path, capsys):
    out = tmp_path / "rec.csv"
    assert main(["road", "simulate", "-o", str(out), "--length", "50", "--plot", str(tmp_path / "rec2.csv")]) == 2
    assert "unknown figure format" in _err(capsys)
    assert not out.exists()


# --- reading tables -------------------------------------------------------------------------------------------

def test_blank_lines_of_a_one_column_csv_are_missing_samples_not_dropped(tmp_path, capsys):
    x = np.arange(60.0)
    x[20:25] = np.nan
    path = tmp_path / "x.csv"
    # a logger or a spreadsheet exports an empty cell of a one-column table as an empty line
    path.write_text("x\n" + "".join("\n" if np.isnan(v) else f"{v}\n" for v in x))
    df = read_table(path, numeric=["x"])
    assert len(df) == 60 and np.isnan(df["x"][20:25]).all() and df["x"][25] == 25.0
    out = tmp_path / "d.csv"
    assert main(["differentiate", str(path), "-c", "x", "--dt", "1", "-m", "backward", "-o", str(out)]) == 0
    d = pd.read_csv(out)
    assert len(d) == 60 and d["derivative"][40] == pytest.approx(1.0)


def test_empty_file_says_so(tmp_path, capsys):
    path = tmp_path / "empty.csv"
    path.write_text("")
    assert main(["differentiate", str(path), "-c", "x", "--dt", "1e-3", "-w", "10", "-o", str(tmp_path / "d.csv")]) == 2
    assert "the file is empty" in _err(capsys)


# --- differentiate ----------------------------------------------------------------------------------------------

def test_differentiate_names_the_missing_cli_option(signal_csv, tmp_path, capsys):
    out = str(tmp_path / "d.csv")
    assert main(["differentiate", str(signal_csv), "-c", "x", "--dt", "1e-3", "-o", out]) == 2
    assert "--window" in _err(capsys)
    assert main(["differentiate", str(signal_csv), "-c", "x", "--dt", "1e-3", "-m", "kalman", "-o", out]) == 2
    assert "--q-over-r" in _err(capsys)


def test_derivative_plot_says_what_was_computed():
    from longprofile.report import plot_derivative
    from longprofile.signal import derivative

    x = np.sin(np.arange(300) * 0.01)
    fig = plot_derivative(x, 1e-3, derivative(x, 1e-3, method="ml", window=20, degree=2), label="x")
    title = fig._suptitle.get_text()
    assert "ml" in title and "window 20" in title and "dt = 0.001 s" in title
    assert "/ s" in fig.axes[1].get_ylabel()


# --- road reconstruct -----------------------------------------------------------------------------------------

def test_reconstruct_converts_a_column_named_in_mm(recording, tmp_path):
    df = pd.read_csv(recording)
    mm = tmp_path / "rec_mm.csv"
    df.assign(apl_mm=df["apl_m"] * 1e3).drop(columns="apl_m").to_csv(mm, index=False)
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["road", "reconstruct", str(recording), "--method", "double", "-o", str(a)]) == 0
    assert main(["road", "reconstruct", str(mm), "--column", "apl_mm", "--method", "double", "-o", str(b)]) == 0
    np.testing.assert_allclose(pd.read_csv(b, comment="#")["elevation_m"], pd.read_csv(a, comment="#")["elevation_m"], rtol=1e-9, atol=1e-12)


def test_reconstruct_refuses_millimetres_in_a_metre_column(recording, tmp_path, capsys):
    df = pd.read_csv(recording)
    bad = tmp_path / "rec_bad.csv"
    df.assign(apl_m=df["apl_m"] * 1e3).to_csv(bad, index=False)
    assert main(["road", "reconstruct", str(bad), "--method", "double", "-o", str(tmp_path / "p.csv")]) == 2
    assert "impossible for an APL signal" in _err(capsys)


def test_reconstruct_says_when_it_bridged_missing_samples(recording, tmp_path, capsys):
    df = pd.read_csv(recording)
    df.loc[300:319, "apl_m"] = np.nan
    gap = tmp_path / "gap.csv"
    df.to_csv(gap, index=False)
    assert main(["road", "reconstruct", str(gap), "--q", "2e-6", "--r", "1e-8", "-o", str(tmp_path / "p.csv")]) == 0
    assert "20 missing (NaN) sample(s)" in _err(capsys)


def test_reconstruct_bad_plot_path_fails_before_writing(recording, tmp_path, capsys):
    out = tmp_path / "p.csv"
    assert main(["road", "reconstruct", str(recording), "--method", "double", "-o", str(out),
                 "--plot", str(out)]) == 2
    assert "unknown figure format '.csv'" in _err(capsys)
    assert not out.exists()


# --- road iri / report ----------------------------------------------------------------------------------------

def test_iri_of_a_reconstruct_output_is_the_iri_of_its_profile(recording, tmp_path, capsys):
    prof = tmp_path / "p.csv"
    assert main(["road", "reconstruct", str(recording), "--method", "double", "-o", str(prof)]) == 0
    iri = tmp_path / "iri.csv"
    assert main(["road", "iri", str(prof), "--segment", "20", "-o", str(iri)]) == 0
    assert list(pd.read_csv(iri, comment="#").columns) == ["start_m", "end_m", "iri_elevation_m_per_km"]
    assert "analysing its profile track 'elevation'" in _err(capsys)


def test_iri_refuses_elevations_in_mm_labelled_m(tmp_path, capsys):
    x = np.arange(0, 200, 0.25)
    z = 2e-3 * np.sin(2 * np.pi * x / 5.0)  # a rough but real road, in m
    path = tmp_path / "p.csv"
    pd.DataFrame(dict(distance_m=x, left_m=z * 1e3)).to_csv(path, index=False)  # mm values, header says m
    assert main(["road", "iri", str(path), "-o", str(tmp_path / "i.csv")]) == 2  # refused, not a warning
    err = _err(capsys)
    assert "look like millimetres under a metre label" in err and "left_mm" in err
    assert not (tmp_path / "i.csv").exists()
    pd.DataFrame(dict(distance_m=x, left_mm=z * 1e3)).to_csv(path, index=False)  # the unit named: accepted
    assert main(["road", "iri", str(path), "-o", str(tmp_path / "i.csv")]) == 0
    assert "beyond any road" not in _err(capsys)


def test_iri_segment_longer_than_the_profile_is_explained(tmp_path, capsys):
    x = np.arange(0, 60, 0.25)
    path = tmp_path / "p.csv"
    pd.DataFrame(dict(distance_m=x, left_m=1e-3 * np.sin(x))).to_csv(path, index=False)
    assert main(["road", "iri", str(path), "--segment", "100", "-o", str(tmp_path / "i.csv")]) == 0
    assert "shorter than one 100 m segment" in _err(capsys)


def test_report_into_a_file_or_over_its_input_is_refused(tmp_path, capsys):
    x = np.arange(0, 60, 0.25)
    folder = tmp_path / "rep"
    folder.mkdir()
    src = folder / "psd.csv"  # a name the report writes
    pd.DataFrame(dict(distance_m=x, left_m=1e-3 * np.sin(x))).to_csv(src, index=False)
    before = src.read_bytes()
    assert main(["road", "report", str(src), "--segment", "20", "-o", str(folder)]) == 2
    assert "exists and is not empty" in _err(capsys)
    # the input is protected even with --overwrite
    assert main(["road", "report", str(src), "--segment", "20", "-o", str(folder), "--overwrite"]) == 2
    assert "would overwrite its input" in _err(capsys)
    assert main(["road", "report", str(src), "--segment", "20", "-o", str(src)]) == 2
    (tmp_path / "afile").write_text("x")
    assert main(["road", "report", str(src), "--segment", "20", "-o", str(tmp_path / "afile")]) == 2
    assert "is a file" in _err(capsys)
    assert src.read_bytes() == before


def test_differentiate_refuses_a_dt_contradicting_the_time_column(signal_csv, tmp_path, capsys):
    out = str(tmp_path / "d.csv")
    assert main(["differentiate", str(signal_csv), "-c", "x", "--dt", "0.01", "-w", "10", "-o", out]) == 2
    assert "column 't' steps by 0.001 s but --dt is 0.01 s" in _err(capsys)
    assert main(["differentiate", str(signal_csv), "-c", "x", "--dt", "0.001", "-w", "10", "-o", out]) == 0


def test_differentiate_takes_dt_from_a_uniform_time_column(signal_csv, tmp_path, capsys):
    import pandas as pd

    given, inferred = tmp_path / "given.csv", tmp_path / "inferred.csv"
    assert main(["differentiate", str(signal_csv), "-c", "x", "--dt", "0.001", "-w", "10", "-o", str(given)]) == 0
    assert main(["differentiate", str(signal_csv), "-c", "x", "-w", "10", "-o", str(inferred)]) == 0
    assert inferred.read_bytes() == given.read_bytes()  # the decimal step 0.001, not its float median
    frame = pd.read_csv(signal_csv)
    jit = tmp_path / "jit.csv"
    frame.assign(t=frame["t"] + np.random.default_rng(0).uniform(-5e-5, 5e-5, len(frame))).to_csv(jit, index=False)
    assert main(["differentiate", str(jit), "-c", "x", "-w", "10", "-o", str(tmp_path / "j.csv")]) == 2
    assert "is not uniformly sampled" in _err(capsys) and not (tmp_path / "j.csv").exists()
    frame.drop(columns="t").to_csv(tmp_path / "no_t.csv", index=False)
    assert main(["differentiate", str(tmp_path / "no_t.csv"), "-c", "x", "-w", "10", "-o", str(tmp_path / "n.csv")]) == 2
    assert "no time column" in _err(capsys)


def test_apl_figures_say_what_they_show():
    from longprofile.identify import fit_output_error
    from longprofile.report import plot_identification, plot_reconstructions, plot_recording

    x = np.arange(0, 100, 0.05)
    fig = plot_recording(x, np.sin(x), 0.5 * np.sin(x), title="simulated APL recording: bump")
    assert fig.axes[0].get_title() == "simulated APL recording: bump"
    fig = plot_reconstructions(x, np.sin(x), {"double": np.sin(x)}, title="t")
    assert fig.axes[1].get_title().startswith("zoom on")
    rng = np.random.default_rng(0)
    u = rng.normal(size=400)
    y = np.convolve(u, [0.5, 0.3], mode="full")[:400] + 0.01 * rng.normal(size=400)
    est = fit_output_error(u, y, na=1, nb=2, nk=0)
    title = plot_identification(u, y, est, dt=0.01).axes[0].get_title()
    assert title.startswith("OE identification") and "stable" in title


def test_semicolon_csv_from_a_european_spreadsheet_reads_as_written(tmp_path, capsys):
    # session 40: ';' with decimal commas and no point anywhere has one reading (before: refused)
    path = tmp_path / "p.csv"
    path.write_text("distance_m;left_mm\n0,00;1,5\n0,25;1,7\n")
    assert main(["road", "convert", str(path), str(tmp_path / "out.csv")]) == 0
    assert (tmp_path / "out.csv").read_text().splitlines()[1:] == ["0,0.0015", "0.25,0.0017"]


@pytest.mark.parametrize("sep", [";", "\t"])
def test_a_semicolon_or_tab_file_with_both_decimal_marks_gets_the_hint(tmp_path, capsys, sep):
    # "0.05;-0,38;0,43": the decimal mark cannot be told (before session 40 every ';' file was refused; before
    # that, a pandas tokenizer error)
    path = tmp_path / "p.csv"
    path.write_text("# exported\n" + sep.join(["distance_m", "elevation_m", "std_m"]) + "\n"
                    + "".join(sep.join([f"{0.05 * i:g}", "-0,38", "0,43"]) + "\n" for i in range(1, 20)))
    assert main(["road", "iri", str(path)]) == 2
    err = _err(capsys)
    assert "decimal mark cannot be told" in err and "tokeniz" not in err and len(err.strip().splitlines()) == 1


def test_an_upper_case_reconstruct_output_reads_as_its_lower_case_original(tmp_path, capsys):
    # a spreadsheet that upper-cases the header: STD_M still belongs to ELEVATION_M, RAW_M is still no track
    x = np.arange(4000) * 0.05
    z = 1e-3 * np.sin(2 * np.pi * x / 7.0)
    frame = pd.DataFrame({"distance_m": x, "elevation_m": z, "std_m": 1e-4, "raw_m": z, "raw_std_m": 2e-4})
    frame.to_csv(tmp_path / "low.csv", index=False)
    frame.rename(columns=str.upper).to_csv(tmp_path / "up.csv", index=False)
    for name in ("low", "up"):
        assert main(["road", "iri", str(tmp_path / f"{name}.csv"), "--segment", "100",
                     "-o", str(tmp_path / f"iri_{name}.csv")]) == 0
    low, up = (pd.read_csv(tmp_path / f"iri_{n}.csv", comment="#") for n in ("low", "up"))
    assert low.shape == up.shape and low.shape[1] == 3  # one track, not two
    np.testing.assert_array_equal(low.to_numpy(), up.to_numpy())


def test_demo_into_a_file_is_one_line_error(tmp_path, capsys):
    (tmp_path / "out").write_text("not a folder")
    assert main(["demo", "-o", str(tmp_path / "out")]) == 2
    assert "is a file" in _err(capsys)


def test_report_says_how_much_of_the_road_is_above_the_roughness_threshold(tmp_path):
    x = np.arange(0, 200, 0.25)
    path = tmp_path / "p.csv"
    z = np.where((x > 80) & (x < 120), 4e-3 * np.sin(2 * np.pi * x / 3.0), 0.0)  # one rough 40 m patch
    pd.DataFrame(dict(distance_m=x, left_m=z)).to_csv(path, index=False)
    assert main(["road", "report", str(path), "--segment", "50", "-o", str(tmp_path / "rep")]) == 0
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "1 location" in page and "% of the length" in page


def test_report_of_a_profile_shorter_than_one_waveband_segment(tmp_path):
    x = np.arange(0, 150, 0.25)  # 150 m < the 200 m waveband segment
    path = tmp_path / "p.csv"
    pd.DataFrame(dict(distance_m=x, left_mm=2.0 * np.sin(2 * np.pi * x / 7.0))).to_csv(path, index=False)
    assert main(["road", "report", str(path), "--segment", "50", "-o", str(tmp_path / "rep")]) == 0
    assert "Waveband energies" in (tmp_path / "rep" / "index.html").read_text()


# --- rail and vehicle commands: output and plot paths are checked before any work -----------------

def test_rail_simulate_into_an_existing_file_is_one_line_error(tmp_path, capsys):
    from longprofile.cli.app import main

    f = tmp_path / "site.csv"
    f.write_text("keep me\n")
    assert main(["rail", "simulate", "-o", str(f)]) == 2
    assert "existing file" in capsys.readouterr().err
    assert f.read_text() == "keep me\n"


def test_rail_simulate_bad_plot_suffix_fails_before_writing(tmp_path):
    from longprofile.cli.app import main

    out = tmp_path / "site"
    assert main(["rail", "simulate", "-o", str(out), "--plot", str(tmp_path / "x.txt")]) == 2
    assert not out.exists()


def test_vehicle_slope_positive_poles_name_the_cli_option(tmp_path, capsys):
    from longprofile.cli.app import main

    log = tmp_path / "log.csv"
    assert main(["vehicle", "simulate", "--scenario", "hill", "--duration", "2", "-o", str(log)]) == 0
    capsys.readouterr()
    assert main(["vehicle", "slope", str(log), "-o", str(tmp_path / "s.csv"), "--poles", "5,7"]) == 2
    err = capsys.readouterr().err
    assert "--poles" in err and "negative" in err


def test_vehicle_vertical_bad_plot_suffix_fails_before_writing(tmp_path):
    from longprofile.cli.app import main

    out = tmp_path / "vlog.csv"
    assert main(["vehicle", "vertical", "simulate", "--duration", "1", "-o", str(out),
                 "--plot", str(tmp_path / "p.csv")]) == 2
    assert not out.exists()


@pytest.mark.parametrize("args", [["vehicle", "simulate", "--duration", "1e13"],  # 71 PiB: beyond any address space
                                  ["vehicle", "simulate", "--duration", "1e16"],  # numpy: "Maximum allowed size"
                                  ["road", "simulate", "--length", "1e14"]])
def test_a_size_no_machine_holds_is_one_line_not_a_traceback(args, tmp_path, capsys):
    out = tmp_path / "x.csv"
    assert main(args + ["-o", str(out)]) == 2
    err = _err(capsys)
    assert "not enough memory for this request" in err and "Traceback" not in err and not out.exists()


def test_vertical_simulation_refuses_an_implausible_speed(tmp_path, capsys):
    out = tmp_path / "v.csv"
    assert main(["vehicle", "vertical", "simulate", "--config", "3", "--speed", "120", "-o", str(out)]) == 2
    assert "not a plausible road-vehicle speed" in _err(capsys) and not out.exists()


@pytest.mark.parametrize(("stamp", "hint"), [("18/11/2019 00:00", "day/month"), ("1574035200", "seconds since 1970")])
def test_rail_dates_that_are_not_iso_are_one_line_naming_the_row_and_value(tmp_path, capsys, stamp, hint):
    # before 2026-12-06: pandas' four-line "You might want to try: ..." advice about its own arguments
    pd.DataFrame({"sensor_id": ["S1", "S2", "S3"], "x_m": [0.0, 3.0, 6.0]}).to_csv(tmp_path / "s.csv", index=False)
    pd.DataFrame({"x_m": [0.0, 3.0, 6.0], "z_m": [210.0, 210.01, 210.02]}).to_csv(tmp_path / "v.csv", index=False)
    rows = [("2019-11-17 00:00", s, 0.01, 5.0) for s in ("S1", "S2", "S3")] + [(stamp, "S1", 0.01, 5.0)]
    pd.DataFrame(rows, columns=["timestamp", "sensor_id", "angle_deg", "temperature_c"]).to_csv(
        tmp_path / "r.csv", index=False)
    code = main(["rail", "settle", "--sensors", str(tmp_path / "s.csv"), "--readings", str(tmp_path / "r.csv"),
                 "--survey", str(tmp_path / "v.csv"), "-o", str(tmp_path / "out.csv")])
    err = _err(capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "row 3" in err and stamp in err and hint in err and "You might" not in err
    assert not (tmp_path / "out.csv").exists()
