"""The demo step reads the APL demo's reconstructed profile and writes the report (contract test)."""

import numpy as np
import pandas as pd
import pytest

from longprofile.demos.road_report import run_demo
from longprofile.errors import InputError
from longprofile.road import iso8608_profile


def test_demo_report_from_apl_contract(tmp_path):
    p = iso8608_profile(400.0, 0.1, "B", rng=2)
    z = p.elevation[:, 0]
    noise = np.random.default_rng(0).normal(scale=2e-4, size=z.size)
    (tmp_path / "road").mkdir()
    pd.DataFrame({"distance_m": p.distance, "true_m": z, "smoother_m": z + noise,
                  "smoother_std_m": np.full(z.size, 2e-4), "filter_m": z + 2 * noise,
                  "double_m": 0.9 * z}).to_csv(tmp_path / "road" / "reconstructed_profile.csv", index=False)
    files = run_demo(tmp_path)
    assert files[0] == tmp_path / "road" / "report" / "index.html"
    page = files[0].read_text()
    assert "true profile" in page and "smoother" in page
    comp = pd.read_csv(tmp_path / "road" / "report" / "iri_by_reconstruction.csv")
    assert list(comp["profile"]) == ["true", "smoother", "filter", "double"]
    np.testing.assert_allclose(comp.loc[comp.profile == "double", "error_vs_true_percent"], -10.0, rtol=1e-6)


def test_demo_report_needs_the_apl_step(tmp_path):
    with pytest.raises(InputError, match="Run the APL demo step first"):
        run_demo(tmp_path)
