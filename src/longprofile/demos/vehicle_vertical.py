"""Demo step: vertical vehicle states on an ISO 8608 class C road (thesis 003).

Writes under ``outdir/vehicle/``:

* ``vertical_log_config3.csv``    -- simulated sensor log (configuration 3) with the true states;
* ``vertical_states_config3.csv`` -- the per-corner EKF estimates;
* ``vertical_states_config3.png`` -- estimates vs truth, front-left corner;
* ``vertical_scores.csv``         -- epsilon (%) of each variable for configurations 1-3, next to the thesis's
  Table 4.4 values;
* ``vertical_observability.csv``  -- singular values and weakest direction of the corner models (thesis §3.5).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["run_demo"]


def run_demo(outdir) -> list[Path]:
    """Run the vertical-states demo and return the files written."""
    from ..io import write_table
    from ..report import plot_vertical_estimate
    from ..vehicle import (
        THESIS_BENCH_TABLE,
        corner_observability,
        estimate_to_frame,
        estimate_vertical_states,
        measure_vertical,
        score_vertical_estimate,
        sensors_to_frame,
        vertical_test_run,
    )

    out = Path(outdir) / "vehicle"
    out.mkdir(parents=True, exist_ok=True)
    written = []
    sim, sens3 = vertical_test_run(3, test="road", road_class="C", speed=20.0, duration=8.0, seed=0)
    log = sensors_to_frame(sens3, sim)
    written.append(write_table(log, out / "vertical_log_config3.csv"))
    rows = []
    for config in (1, 2, 3):
        sens = sens3 if config == 3 else measure_vertical(sim, config, rng=1)
        est = estimate_vertical_states(sens)
        scores = score_vertical_estimate(sim, est)
        for var, val in scores.items():
            rows.append({"config": config, "variable": var, "epsilon_FL": round(float(val[0]), 2),
                         "epsilon_mean_4_corners": round(float(np.mean(val)), 2),
                         "thesis_table_4_4": THESIS_BENCH_TABLE[config][var]})
        if config == 3:
            written.append(write_table(estimate_to_frame(est), out / "vertical_states_config3.csv"))
            fig = plot_vertical_estimate(est, log)
            png = out / "vertical_states_config3.png"
            fig.savefig(png, dpi=100)
            written.append(png)
    written.append(write_table(pd.DataFrame(rows), out / "vertical_scores.csv"))
    obs = []
    for model in ("absolute", "relative"):
        for config in (1, 2, 3):
            r = corner_observability(config, model=model)
            obs.append({"model": model, "config": config, "rank": r.rank,
                        "singular_values": " ".join(f"{v:.3g}" for v in r.singular_values),
                        "weakest_direction": " ".join(f"{n}={v:+.2f}" for n, v in zip(r.state_names,
                                                                                      r.weakest_direction))})
    written.append(write_table(pd.DataFrame(obs), out / "vertical_observability.csv"))
    return written
