"""``make demo`` step: Kalman filtering and RTS smoothing of a noisy track with a data gap."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io import write_table
from ..report import plot_kalman_smoothing
from ..statespace import StateSpaceModel, kalman_filter, rts_smoother, simulate

__all__ = ["run_demo", "constant_acceleration_model"]

GAP_S = (8.0, 11.0)  # the 3 s without observations


def constant_acceleration_model(dt: float, jerk_psd: float, position_std: float):
    """Constant-acceleration model (position, velocity, acceleration) driven by white jerk.

    ``dt`` in s, ``jerk_psd`` in m^2/s^5, ``position_std`` in m; the position is observed.
    Q is the exact discretisation of continuous white jerk (Bar-Shalom, Li & Kirubarajan 2001, §6.2.3).
    """
    F = np.array([[1.0, dt, dt**2 / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    Q = jerk_psd * np.array([[dt**5 / 20, dt**4 / 8, dt**3 / 6],
                             [dt**4 / 8, dt**3 / 3, dt**2 / 2],
                             [dt**3 / 6, dt**2 / 2, dt]])
    return StateSpaceModel(F, [[1.0, 0.0, 0.0]], Q, [[position_std**2]], [0.0, 5.0, 0.0],
                           np.diag([1.0, 1.0, 0.5]))


def run_demo(outdir: Path) -> list[Path]:
    """Simulate a track, lose 3 s of data, filter and smooth it; write a plot and a table.

    Writes ``outdir/statespace/kalman_smoothing.png`` and ``.csv`` and returns their paths.
    """
    import pandas as pd

    dt, T = 0.05, 400
    model = constant_acceleration_model(dt, jerk_psd=0.5, position_std=0.5)
    x, y = simulate(model, T, rng=0)
    t = np.arange(T) * dt
    gap = (t >= GAP_S[0]) & (t < GAP_S[1])
    y_obs = y[:, 0].copy()
    y_obs[gap] = np.nan
    filtered = kalman_filter(model, y_obs)
    smoothed = rts_smoother(model, filtered)
    f_std = np.sqrt(filtered.cov[:, [0, 1], [0, 1]])
    s_std = np.sqrt(smoothed.cov[:, [0, 1], [0, 1]])

    folder = Path(outdir) / "statespace"
    folder.mkdir(parents=True, exist_ok=True)
    table = pd.DataFrame({
        "t_s": t,
        "true_position_m": x[:, 0], "observed_position_m": y_obs,
        "filtered_position_m": filtered.mean[:, 0], "filtered_position_std_m": f_std[:, 0],
        "smoothed_position_m": smoothed.mean[:, 0], "smoothed_position_std_m": s_std[:, 0],
        "true_velocity_m_s": x[:, 1],
        "filtered_velocity_m_s": filtered.mean[:, 1], "smoothed_velocity_m_s": smoothed.mean[:, 1],
        "smoothed_velocity_std_m_s": s_std[:, 1],
    })
    csv = write_table(table, folder / "kalman_smoothing.csv")
    fig = plot_kalman_smoothing(t, x, y_obs, filtered, smoothed, gap=GAP_S)
    png = folder / "kalman_smoothing.png"
    fig.savefig(png, dpi=120)
    return [png, csv]
