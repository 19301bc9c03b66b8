"""``longprofile differentiate`` in process and its error contract (the demo step: tests/demos/test_signal.py)."""

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from longprofile.cli.app import app, main
from longprofile.signal import derivative

runner = CliRunner()


def _write_signal(path, n=600, dt=0.001):
    t = np.arange(n) * dt
    x = np.sin(2 * np.pi * 3 * t) + 0.001 * np.random.default_rng(0).standard_normal(n)
    pd.DataFrame({"t": t, "x": x}).to_csv(path, index=False)
    return x


def test_differentiate_writes_the_library_result(tmp_path):
    src = tmp_path / "signal.csv"
    x = _write_signal(src)
    out = tmp_path / "out.csv"
    png = tmp_path / "out.png"
    result = runner.invoke(app, ["differentiate", str(src), "--column", "x", "--dt", "0.001", "--method", "ml",
                                 "--degree", "2", "--window", "45", "-o", str(out), "--plot", str(png)])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out)
    assert list(table.columns) == ["time_s", "value", "derivative", "derivative_std", "settled"]
    np.testing.assert_array_equal(table["time_s"], np.arange(x.size) * 0.001)  # the file's time column, beside each row
    lib = derivative(x, 0.001, method="ml", window=45, degree=2)
    np.testing.assert_allclose(table["derivative"], lib.derivative, rtol=1e-12, equal_nan=True)
    np.testing.assert_allclose(table["derivative_std"], lib.derivative_std, rtol=1e-12, equal_nan=True)
    assert table["derivative"].isna().sum() == 45
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"


def test_differentiate_kalman_smoother_parquet(tmp_path):
    src = tmp_path / "signal.csv"
    x = _write_signal(src)
    out = tmp_path / "out.parquet"
    result = runner.invoke(app, ["differentiate", str(src), "-c", "x", "--dt", "0.001", "--method", "kalman",
                                 "--q-over-r", "1e10", "--smooth", "--steady-state", "--noise-std", "0.001",
                                 "-o", str(out)])
    assert result.exit_code == 0, result.output
    table = pd.read_parquet(out)
    truth = 2 * np.pi * 3 * np.cos(2 * np.pi * 3 * np.arange(x.size) * 0.001)
    assert np.sqrt(np.mean((table["derivative"].to_numpy() - truth)[50:-50] ** 2)) < 0.5


def test_missing_column_is_one_line_exit_2(tmp_path, capsys):
    src = tmp_path / "signal.csv"
    _write_signal(src)
    code = main(["differentiate", str(src), "--column", "nope", "--dt", "0.001", "--window", "10",
                 "-o", str(tmp_path / "o.csv")])
    assert code == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "missing column(s) ['nope']" in lines[0]


def test_bad_options_are_library_errors_exit_2(tmp_path, capsys):
    src = tmp_path / "signal.csv"
    _write_signal(src)
    out = str(tmp_path / "o.csv")
    assert main(["differentiate", str(src), "-c", "x", "--dt", "0.001", "--window", "1", "--degree", "3",
                 "-o", out]) == 2
    assert "window (N, the number of past samples) must be >= degree" in capsys.readouterr().err
    assert main(["differentiate", str(src), "-c", "x", "--dt", "0.001", "--window", "10", "--smooth",
                 "-o", out]) == 2
    assert "does not take smooth" in capsys.readouterr().err
    assert main(["differentiate", str(src), "-c", "x", "--dt", "0.001", "-o", out]) == 2
    assert "requires window" in capsys.readouterr().err


def test_differentiate_std_option_selects_what_derivative_std_covers(tmp_path, capsys):
    src = tmp_path / "signal.csv"
    x = _write_signal(src)
    tables = {}
    for std in ("total", "noise"):
        out = tmp_path / f"{std}.csv"
        assert main(["differentiate", str(src), "-c", "x", "--dt", "0.001", "-w", "120", "--std", std,
                     "-o", str(out)]) == 0
        assert f"derivative_std: {std}" in " ".join(capsys.readouterr().err.split())
        tables[std] = pd.read_csv(out)
        lib = derivative(x, 0.001, method="ml", window=120, std=std)
        np.testing.assert_allclose(tables[std]["derivative_std"], lib.derivative_std, rtol=1e-12, equal_nan=True)
    np.testing.assert_array_equal(tables["total"]["derivative"], tables["noise"]["derivative"])
    # a 120-sample window on a 3 Hz sine: the bias dominates, the total std is far above the noise-only one
    assert (tables["total"]["derivative_std"] > 3 * tables["noise"]["derivative_std"]).mean() > 0.5
    assert main(["differentiate", str(src), "-c", "x", "--dt", "0.001", "-w", "10", "--std", "bias",
                 "-o", str(tmp_path / "bad.csv")]) == 2
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "std must be one of ('total', 'noise')" in lines[0]


@pytest.mark.parametrize(("name", "scale"), [("t", 1.0), ("Time [ms]", 1e3), ("time (us)", 1e6), ("T_MS", 1e3),
                                             ("time_s", 1.0), ("TIME", 1.0)])
def test_the_sample_interval_comes_from_a_time_column_named_with_its_unit(tmp_path, name, scale):
    # the derivative depends on dt: every spelling of the same time column gives the library's result at 1 ms
    src = tmp_path / "signal.csv"
    x = _write_signal(src)
    frame = pd.read_csv(src)
    frame.assign(t=frame["t"] * scale).rename(columns={"t": name}).to_csv(src, index=False)
    out = tmp_path / "out.csv"
    result = runner.invoke(app, ["differentiate", str(src), "--column", "x", "--method", "ml", "--degree", "2",
                                 "--window", "45", "-o", str(out)])
    assert result.exit_code == 0, result.output
    lib = derivative(x, 0.001, method="ml", window=45, degree=2)
    table = pd.read_csv(out)
    np.testing.assert_allclose(table["derivative"], lib.derivative, rtol=1e-9, equal_nan=True)
    np.testing.assert_allclose(table["time_s"], np.arange(x.size) * 0.001, rtol=1e-12, atol=1e-12)  # in seconds


def test_without_a_time_column_there_is_no_time_in_the_output(tmp_path):
    src = tmp_path / "signal.csv"
    x = _write_signal(src)
    pd.read_csv(src).drop(columns="t").to_csv(src, index=False)
    out = tmp_path / "out.csv"
    result = runner.invoke(app, ["differentiate", str(src), "--column", "x", "--dt", "0.001", "--method", "ml",
                                 "--degree", "2", "--window", "45", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert list(pd.read_csv(out).columns) == ["value", "derivative", "derivative_std", "settled"]
    assert len(pd.read_csv(out)) == x.size


def test_unix_time_stamps_at_10_khz_are_a_uniform_interval(tmp_path):
    """Unix time stamps (1.7e9 s) at 10 kHz: float64 rounding moves each step by up to +-2.4e-7 s, more than the
    0.1 % tolerance of a 0.1 ms step, and was refused as non-uniform; the derivative is now the library's at the
    median step (within its rounding)."""
    src = tmp_path / "signal.csv"
    t = 1.7e9 + np.arange(4000) * 1e-4
    x = np.sin(2 * np.pi * 5 * (t - t[0]))
    assert np.ptp(np.diff(t)) > 1e-3 * 1e-4
    pd.DataFrame({"t": t, "x": x}).to_csv(src, index=False, float_format="%.17g")
    out = tmp_path / "out.csv"
    result = runner.invoke(app, ["differentiate", str(src), "--column", "x", "--method", "ml", "--degree", "2",
                                 "--window", "45", "-o", str(out)])
    assert result.exit_code == 0, result.output
    lib = derivative(x, 1e-4, method="ml", window=45, degree=2)
    np.testing.assert_allclose(pd.read_csv(out)["derivative"], lib.derivative, rtol=1e-3, equal_nan=True)


def test_a_time_column_with_one_finite_time_is_one_line(tmp_path, capsys):
    """It ended in a traceback (a maximum over no steps)."""
    src = tmp_path / "signal.csv"
    src.write_text("t,x\n0,1\n,2\n,3\n")
    assert main(["differentiate", str(src), "-c", "x", "--method", "ml", "--degree", "2", "-w", "3",
                 "-o", str(tmp_path / "out.csv")]) == 2
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "fewer than two finite times" in lines[0]
