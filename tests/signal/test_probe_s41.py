"""differentiate after session 40's user probes (session 41, issue 13 §2 "never a silent wrong number"): the model
check missed ``ml`` N = 1000 d = 2 on a 2 Hz sine (coverage 14 %, 8 % for the second derivative), and the output
file did not say the unit of a column named with one ('position (mm)')."""

import numpy as np
import pandas as pd
import pytest

from longprofile.cli.app import main
from longprofile.signal import derivative, model_check

DT = 1e-3


def _sine(n=5000, noise=1e-3, seed=0):
    t = np.arange(n) * DT
    return t, np.sin(2 * np.pi * 2 * t) + noise * np.random.default_rng(seed).standard_normal(n)


def _coverage(res, t, order, skip):
    w = 2 * np.pi * 2
    truth = w * np.cos(w * t) if order == 1 else -w * w * np.sin(w * t)
    return float(np.mean(np.abs(res.derivative - truth)[skip:] <= 1.645 * res.derivative_std[skip:]))


@pytest.mark.parametrize("method,window,degree,order,flagged", [
    ("ml", 1000, 2, 1, True), ("ml", 1000, 2, 2, True),  # the probe's misses
    ("ml", 1000, 1, 1, True),  # flagged before too (the residual test)
    ("ml", 45, 2, 1, False), ("ml", 400, 2, 1, False), ("ml", 200, 2, 2, False), ("ml", 1000, 3, 2, False),
    ("polyfit", 400, 2, 1, False), ("polyfit", 300, 3, 2, False),
])
def test_the_model_check_flags_exactly_the_windows_whose_band_fails(method, window, degree, order, flagged):
    t, x = _sine()
    res = derivative(x, DT, method=method, window=window, degree=degree, order=order)
    check = model_check(x, DT, method=method, window=window, degree=degree, noise_std=res.params["noise_std"],
                        skip=window + 1, estimate=res)
    coverage = _coverage(res, t, order, window + 1)
    assert (not check.adequate) == flagged, (check, coverage)
    assert (coverage < 0.5) == flagged  # the external oracle: the truth against the printed band


def test_white_noise_is_never_inconsistent():
    """The derivative-domain test subtracts the inconsistency's exact white-noise power (from the FIR taps)."""
    x = np.random.default_rng(5).standard_normal(5000)
    for window, degree, order in [(45, 2, 1), (10, 2, 2), (200, 3, 2), (1000, 2, 1)]:
        res = derivative(x, DT, method="ml", window=window, degree=degree, order=order)
        check = model_check(x, DT, method="ml", window=window, degree=degree, noise_std=res.params["noise_std"],
                            skip=window + 1, estimate=res)
        assert check.adequate and check.inconsistency < 0.5, (window, degree, order, check)


@pytest.mark.parametrize("extra", [[], ["--order", "2"]])
def test_differentiate_warns_for_ml_1000_degree_2(tmp_path, capsys, extra):
    t, x = _sine()
    pd.DataFrame({"time": t, "x": x}).to_csv(tmp_path / "s.csv", index=False)
    code = main(["differentiate", str(tmp_path / "s.csv"), "-c", "x", "-m", "ml", "-w", "1000", "-d", "2", *extra,
                 "-o", str(tmp_path / "d.csv")])
    err = " ".join(capsys.readouterr().err.split())
    assert code == 0 and "warning: window too long for this signal" in err and "shorten --window" in err
    assert "times derivative_std" in err


@pytest.mark.parametrize("name,args,value,rate", [
    ("position (mm)", [], "value [mm]", "derivative [mm/s]"),
    ("speed [km/h]", ["--order", "2", "-d", "3"], "value [km/h]", "derivative [(km/h)/s^2]"),
    ("position (mm)", ["--dt", "0.001", "--no-time"], "value [mm]", "derivative [mm per --dt unit]"),
    ("x", [], "value", "derivative"),
])
def test_the_output_columns_carry_the_signal_unit(tmp_path, capsys, name, args, value, rate):
    t, x = _sine(600)
    frame = pd.DataFrame({"time [ms]": t * 1e3, name: 1e3 * x})
    if "--no-time" in args:
        frame, args = frame.drop(columns=["time [ms]"]), [a for a in args if a != "--no-time"]
    frame.to_csv(tmp_path / "s.csv", index=False)
    code = main(["differentiate", str(tmp_path / "s.csv"), "-c", name, "-w", "45", *args, "-o",
                 str(tmp_path / "d.csv")])
    out = pd.read_csv(tmp_path / "d.csv")
    assert code == 0 and value in out.columns and rate in out.columns
    assert rate.replace("derivative", "derivative_std") in out.columns
    np.testing.assert_array_equal(out[value].to_numpy()[-10:], frame[name].to_numpy()[-10:])  # not converted
    if value != "value":
        assert f"columns '{value}', '{rate}'" in " ".join(capsys.readouterr().err.split())


def test_the_help_says_the_unit_is_carried():
    from typer.testing import CliRunner

    from longprofile.cli.app import app

    text = " ".join(CliRunner().invoke(app, ["differentiate", "--help"]).output.replace("│", " ").split())
    assert "'x (mm)' gives 'value [mm]', 'derivative [mm/s]'" in text  # the brackets not eaten as markup
