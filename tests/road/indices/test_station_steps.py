"""Station steps the IRI accepts (issue 13, a user's files): gaps and coarse stations are refused, a median step
above 0.3 m is noted, and an IRI outside any road's range is named (docs/road-indices.md, "Station steps")."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.core import Profile
from longprofile.errors import InputError
from longprofile.road import iri, iri_plausibility, iri_report, iso8608_profile, sampling_note


@pytest.fixture(scope="module")
def road():
    return iso8608_profile(600.0, 0.05, "C", rng=3)


@settings(max_examples=25, deadline=None)
@given(start=st.floats(20.0, 550.0), length=st.floats(0.2, 40.0))
def test_a_gap_longer_than_a_metre_is_refused_and_a_shorter_one_is_not(road, start, length):
    x, z = road.distance, road.elevation[:, 0]
    keep = (x <= start) | (x >= start + length)
    cut = Profile(x[keep], z[keep])
    longest = float(np.diff(cut.distance).max())
    if longest > 1.0:
        with pytest.raises(InputError, match=r"1 gap\(s\) longer than 1 m .* from station"):
            iri(cut)
    else:
        assert np.isfinite(iri(cut).section_iri).all()


@pytest.mark.parametrize("step", [2, 5.0, 50.0])
def test_coarse_stations_are_refused_with_the_unit_hint(road, step):
    k = int(round(step / 0.05))
    coarse = Profile(road.distance[::k], road.elevation[::k, 0])
    with pytest.raises(InputError, match=f"sampled every {step:g} m.*distance_mm"):
        iri_report(coarse)


def test_a_median_step_above_0_3_m_is_noted_and_the_iri_is_lower(road):
    z = road.elevation[:, 0]
    fine, half = Profile(road.distance, z), Profile(road.distance[::10], z[::10])
    assert sampling_note(fine) is None
    assert "sampled every 0.5 m" in sampling_note(half)
    assert iri(half).section_iri[0] < iri(fine).section_iri[0]  # the bias the note names


def test_the_plausible_iri_range():
    assert iri_plausibility([1.0, 12.0]) == ""
    assert "beyond any road" in iri_plausibility([3.0, 80.0])
    assert "below any paved road" in iri_plausibility([0.01, 3.0])
    assert "segment IRI 0.05" in iri_plausibility([[0.05, np.nan]], what="segment IRI")
    assert iri_plausibility([np.nan]) == ""


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "longprofile", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=120)


def test_the_cli_refuses_a_gap_in_one_line_and_warns_on_metres_under_a_mm_label(road, tmp_path):
    import pandas as pd

    x, z = road.distance, road.elevation[:, 0]
    keep = (x < 200) | (x >= 260)
    pd.DataFrame({"distance_m": x[keep], "left_mm": 1e3 * z[keep]}).to_csv(tmp_path / "gap.csv", index=False)
    r = _cli("road", "iri", "gap.csv", "-o", "iri.csv", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("error:") == 1 and len(r.stderr.splitlines()) == 1
    assert "gap(s) longer than 1 m" in r.stderr and not (tmp_path / "iri.csv").exists()
    pd.DataFrame({"distance_m": x, "left_mm": z}).to_csv(tmp_path / "m.csv", index=False)  # metres, mm label
    r = _cli("road", "iri", "m.csv", "-o", "iri.csv", cwd=tmp_path)
    assert r.returncode == 0 and "below any paved road" in " ".join((r.stdout + r.stderr).split())


def test_road_report_refuses_a_plot_onto_one_of_its_own_files(road, tmp_path):
    import pandas as pd

    pd.DataFrame({"distance_m": road.distance, "left_mm": 1e3 * road.elevation[:, 0]}).to_csv(tmp_path / "p.csv",
                                                                                             index=False)
    r = _cli("road", "report", "p.csv", "-o", "R", "--plot", "R/iri.png", cwd=tmp_path)
    assert r.returncode == 2 and "is inside the output folder R" in r.stderr and not (tmp_path / "R").exists()
