"""A localized roughness defect that reaches a stretch no window assesses (session 41, issue 13 §2): the profile's
ends (half a window and the moving average's half base) and windows blanked by an exclusion. Session 40's probe: a
bump at 1997 m of a 2000 m section was reported 2.15 m long with its peak at the last window centre, nothing said."""

import numpy as np
import pandas as pd
import pytest

from longprofile.cli.app import main
from longprofile.road import smoothness_acceptance
from longprofile.road.smoothness._acceptance import spec_from_dict
from tests.road.smoothness.test_acceptance_checks import _csv, _road


def _bump(at, height=0.02):
    return lambda x: height * np.exp(-0.5 * ((x - at) / 0.3) ** 2)


@pytest.mark.parametrize("at,open_end", [(298.0, True), (2.0, True), (150.0, False)])
def test_a_defect_reaching_an_unassessed_end_is_flagged_and_warned(at, open_end):
    res = smoothness_acceptance(_road(300.0, add=_bump(at)), spec_from_dict({"localized": {"threshold": 2.5}}))
    d = res.defects
    assert len(d) == 1 and bool(d["open_end"].iloc[0]) == open_end
    lines = [w for w in res.warnings if "runs up to the unassessed end" in w]
    assert len(lines) == int(open_end)
    if open_end:
        (a0, b0), (a1, b1) = res.pay_summary["localized_unassessed"]
        end = f"{a1:.6g}-{b1:.6g} m" if at > 150 else f"{a0:.6g}-{b0:.6g} m"
        assert end in lines[0] and f"({d['length'].iloc[0]:.3g} m)" in lines[0]
        # the truth: the whole bump's windows would be longer than the assessed part reported
        full = smoothness_acceptance(_road(300.0, add=_bump(150.0)), spec_from_dict({"localized": {"threshold": 2.5}}))
        assert full.defects["length"].iloc[0] > 2 * d["length"].iloc[0]


def test_a_defect_against_an_exclusion_is_flagged():
    spec = spec_from_dict({"localized": {"threshold": 2.5}, "exclusions": {"zones": [[151.0, 170.0]]}})
    res = smoothness_acceptance(_road(300.0, add=_bump(149.5)), spec)
    assert res.defects["open_end"].tolist() == [True]
    assert any("touch an exclusion zone" in w for w in res.warnings)


def test_the_cli_warns_and_defects_csv_has_the_flag(tmp_path, capsys):
    f = _csv(_road(300.0, add=_bump(298.0)), tmp_path / "p.csv")
    (tmp_path / "spec.toml").write_text("[localized]\nthreshold = 2.5\n")
    code = main(["road", "acceptance", f, "--spec", str(tmp_path / "spec.toml"), "-o", str(tmp_path / "r"),
                 "--no-grind"])
    err = " ".join(capsys.readouterr().err.split())
    assert code == 0 and "warning: localized roughness area" in err and "runs up to the unassessed end" in err
    assert pd.read_csv(tmp_path / "r" / "defects.csv")["open_end"].tolist() == [True]
