"""The ``make demo`` Kalman smoothing step writes its plot and a table whose numbers are consistent."""

import numpy as np

from longprofile.demos.statespace import run_demo
from longprofile.io import read_table


def test_kalman_demo_writes_png_and_csv(tmp_path):
    files = run_demo(tmp_path)
    png, csv = tmp_path / "statespace" / "kalman_smoothing.png", tmp_path / "statespace" / "kalman_smoothing.csv"
    assert set(files) == {png, csv}
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    t = read_table(csv)
    gap = (t["t_s"] >= 8.0) & (t["t_s"] < 11.0)
    assert t.loc[gap, "observed_position_m"].isna().all() and t.loc[~gap, "observed_position_m"].notna().all()
    # the smoother is never less certain than the filter, and is far more certain inside the gap
    assert np.all(t["smoothed_position_std_m"] <= t["filtered_position_std_m"] + 1e-12)
    assert (t.loc[gap, "smoothed_position_std_m"].max() < 0.2 * t.loc[gap, "filtered_position_std_m"].max())
    err_s = np.sqrt(np.mean((t["smoothed_position_m"] - t["true_position_m"]) ** 2))
    err_f = np.sqrt(np.mean((t["filtered_position_m"] - t["true_position_m"]) ** 2))
    assert err_s < err_f
