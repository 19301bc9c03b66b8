"""The ``longprofile demo`` signal step (paper 002): plot and error table."""

import pandas as pd


def test_demo_step_writes_plot_and_error_table(tmp_path):
    from longprofile.demos.signal import run_demo

    files = run_demo(tmp_path)
    assert {f.name for f in files} == {"derivatives.png", "derivative_errors.csv"}
    table = pd.read_csv(tmp_path / "signal" / "derivative_errors.csv")
    err = dict(zip(table["estimator"], table["rms_error"]))
    # the paper's point (§4, fig. 1): separating the model order from the window beats the backward difference
    assert err["ML d=2"] < err["backward n=2"] / 10
    assert err["Kalman smoother"] < err["Kalman filter"]
