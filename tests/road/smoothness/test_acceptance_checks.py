"""Smoothness acceptance on a pavement engineer's files (session 36, /tmp/probe_pave/findings.md): implausible input
refused or flagged before any pay, the last partial lot evaluated, dropouts written as values refused, gaps inside
exclusion zones accepted, lots needing corrective work and an unassessed localized roughness named, the earlier run's
report files removed by --overwrite, and the grinding naming what limits it."""

from __future__ import annotations

import functools
import json

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.cli.app import main
from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.io import read_profile, write_profile
from longprofile.road import Profile, iso8608_profile, simulate_grinding, smoothness_acceptance
from longprofile.road.smoothness._acceptance import spec_from_dict
from tests._reference_data import reference_file

PAY = {"schedule": [[0.95, 1.05], [1.2, 1.0], [1.9, 0.9]]}


@functools.lru_cache(maxsize=4)
def _tracks(length: float, dx: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Two correlated tracks of a smooth new pavement (0.45 x ISO 8608 class A: lot MRI about 1 m/km)."""
    a, b = iso8608_profile(length, dx, "A", rng=seed), iso8608_profile(length, dx, "A", rng=seed + 100)
    left = 0.45 * a.elevation[:, 0]
    return a.distance, np.column_stack([left, 0.6 * left + 0.36 * b.elevation[:, 0]])


def _road(length=600.0, dx=0.05, seed=1, start=0.0, add=None) -> Profile:
    x, z = _tracks(length, dx, seed)
    z = z.copy() if add is None else z + np.asarray(add(x))[:, None]
    return Profile(distance=x + start, elevation=z, tracks=("left", "right"))


def _csv(profile: Profile, path, factor=1e3) -> str:
    """The profile as a CSV in mm (``factor`` = file units per metre)."""
    pd.DataFrame({"distance_m": profile.distance, "left_mm": profile.elevation[:, 0] * factor,
                  "right_mm": profile.elevation[:, 1] * factor}).to_csv(path, index=False)
    return str(path)


def _spec(tmp_path, text: str) -> str:
    path = tmp_path / "spec.toml"
    path.write_text('units = "si"\n[lot]\nlength = 100\n[pay]\nschedule = [[0.95, 1.05], [1.2, 1.0], [1.9, 0.9]]\n'
                    + text)
    return str(path)


# -- 1: a garbage profile gets no bonus without a loud signal ------------------------------------------------------


def test_metres_under_a_mm_label_are_refused_and_flagged_when_forced():
    road = _road(500.0)
    metres_as_mm = Profile(road.distance, road.elevation / 1000.0, tracks=road.tracks)
    spec = spec_from_dict({"pay": PAY})
    with pytest.raises(UnitsError, match=r"section IRI 0\.00\d+ m/km is below any paved road.*Lot\(s\) 1-5 of 5 "
                                         r"\(0-500 m\).*--no-check-units"):
        smoothness_acceptance(metres_as_mm, spec)
    res = smoothness_acceptance(metres_as_mm, spec, check_units=False)
    assert res.pay_summary["implausible_lots"] == [1, 2, 3, 4, 5]
    assert len(res.warnings) == 1 and "do not pay on it" in res.warnings[0]
    assert smoothness_acceptance(road, spec).warnings == ()  # the same road in its unit: nothing to say


def test_a_lot_outside_the_range_is_named_while_the_section_is_paid():
    # the roughness of lot 3 (200-300 m) faded to 1 % with 20 m cosine tapers: that lot reads 0.02 m/km
    def fade(x):
        w = np.clip(np.minimum(x - 180.0, 320.0 - x) / 20.0, 0.0, 1.0)
        return 0.99 * (0.5 - 0.5 * np.cos(np.pi * w))
    x, z = _tracks(500.0, 0.05, 1)
    road = Profile(x, z * (1.0 - fade(x))[:, None], tracks=("left", "right"))
    res = smoothness_acceptance(road, spec_from_dict({"pay": PAY}))
    assert res.pay_summary["implausible_lots"] == [3]
    assert res.warnings and res.warnings[0].startswith("lot(s) 3 of 5 (200-300 m) have an IRI outside 0.2-50 m/km")


def test_cli_refuses_metres_as_mm_in_one_line_and_flags_everywhere_when_forced(tmp_path, capsys):
    road = _road(500.0)
    f = _csv(road, tmp_path / "m_as_mm.csv", factor=1.0)  # metres under a mm label
    spec = _spec(tmp_path, "")
    assert main(["road", "acceptance", f, "--spec", spec, "-o", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 1 and "below any paved road" in err and "--no-check-units" in err
    assert main(["road", "acceptance", f, "--spec", spec, "-o", str(tmp_path / "b"), "--no-check-units"]) == 0
    err = " ".join(capsys.readouterr().err.split())
    assert "warning: section IRI" in err and "CHECK THE WARNING(S) ABOVE BEFORE PAYING" in err
    summary = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert summary["warnings"] and summary["pay"]["implausible_lots"] == [1, 2, 3, 4, 5]
    page = (tmp_path / "b" / "index.html").read_text()
    assert "<h2>Warnings</h2>" in page and "below any paved road" in page


# -- 2: the last partial lot ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("span,lot,frac,n,rule,last", [
    (1550.0, 100.0, 0.5, 16, "own", (1500.0, 1550.0)),          # the probe's SI section: its last 50 m
    (5085.3, 528.0, 0.5, 10, "own", (4752.0, 5085.3)),          # the US section: its last 333 ft
    (1530.0, 100.0, 0.5, 15, "merged", (1400.0, 1530.0)),       # 30 m: merged into the previous lot
    (1530.0, 100.0, 0.2, 16, "own", (1500.0, 1530.0)),          # min_fraction 0.2 makes 30 m a lot
    (1500.0, 100.0, 0.5, 15, "none", (1400.0, 1500.0)),
    (60.0, 100.0, 0.5, 1, "own", (0.0, 60.0)),                  # a 60 m section is one (short) lot
])
def test_lot_bounds_give_the_remainder_its_own_lot_or_merge_it(span, lot, frac, n, rule, last):
    from longprofile.road.smoothness._acceptance import lot_bounds

    spec = spec_from_dict({"lot": {"length": lot, "min_fraction": frac}})
    bounds, info = lot_bounds(0.0, span, spec)
    assert len(bounds) - 1 == n and info["rule"] == rule
    assert (bounds[-2], bounds[-1]) == pytest.approx(last)
    with pytest.raises(InputError, match=r"shorter than the shortest lot the spec makes \(0\.5 of a 100 m lot"):
        lot_bounds(0.0, 40.0, spec_from_dict({"lot": {"length": 100.0}}))


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(length=st.floats(20.0, 640.0), lot=st.sampled_from([10.0, 25.0, 100.0, 160.934]),
       frac=st.sampled_from([0.0, 0.25, 0.5, 1.0]), zone=st.one_of(st.none(), st.tuples(st.floats(0.0, 1.0),
                                                                                          st.floats(0.5, 30.0))))
def test_the_lots_cover_the_section_minus_the_exclusions(length, lot, frac, zone):
    x, z = _tracks(650.0, 0.1, 7)
    keep = x <= length
    prof = Profile(x[keep] + 2000.0, z[keep], tracks=("left", "right"))
    x0, x1 = prof.distance[0], prof.distance[-1]
    width = None if zone is None else min(zone[1], 0.5 * (x1 - x0))
    zones = [] if zone is None else [[x0 + zone[0] * (x1 - x0 - width), x0 + zone[0] * (x1 - x0 - width) + width]]
    spec = spec_from_dict({"lot": {"length": lot, "min_fraction": frac}, "exclusions": {"zones": zones}})
    if x1 - x0 < frac * lot - 1e-6 * lot:
        with pytest.raises(InputError, match="shorter than the shortest lot"):
            smoothness_acceptance(prof, spec, check_units=False)
        return
    res = smoothness_acceptance(prof, spec, check_units=False)
    lots, ps = res.lots, res.pay_summary
    assert lots.start.iloc[0] == x0 and lots.end.iloc[-1] == x1
    np.testing.assert_allclose(lots.start.to_numpy()[1:], lots.end.to_numpy()[:-1], rtol=0, atol=1e-9)
    excluded = sum(b - a for a, b in zones)
    assert lots.included_length.sum() == pytest.approx(x1 - x0 - excluded, abs=1e-6)
    assert ps["evaluated_length"] + ps["excluded_length"] == pytest.approx(ps["section"]["length"], abs=1e-6)
    widths = (lots.end - lots.start).to_numpy()
    np.testing.assert_allclose(widths[:-1], lot, rtol=1e-9)
    last = {"none": (lot, lot), "own": (frac * lot, lot), "merged": (lot, (1 + frac) * lot)}[ps["last_lot"]["rule"]]
    assert last[0] - 1e-6 * lot <= widths[-1] <= last[1] + 1e-6 * lot


def test_cli_states_the_last_lot_on_the_console_in_the_report_and_in_summary_json(tmp_path, capsys):
    f = _csv(_road(1550.0, dx=0.05, start=2000.0), tmp_path / "acc_si.csv")
    assert main(["road", "acceptance", f, "--spec", _spec(tmp_path, ""), "-o", str(tmp_path / "r")]) == 0
    err = " ".join(capsys.readouterr().err.split())
    assert "16 lot(s) over 2000-3550 m (the last, 3500-3550 m, is the 50 m remainder as a lot of its own)" in err
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["pay"]["last_lot"] == {"rule": "own", "remainder": pytest.approx(50.0), "start": 3500.0,
                                          "end": pytest.approx(3550.0)}
    assert summary["pay"]["evaluated_length"] == pytest.approx(1550.0)
    assert "is the 50 m remainder as a lot of its own" in (tmp_path / "r" / "index.html").read_text()
    assert len(pd.read_csv(tmp_path / "r" / "lots.csv")) == 16


# -- 3: dropouts written as values ----------------------------------------------------------------------------------


def test_a_missing_value_code_is_refused_when_the_file_is_read(tmp_path):
    road = _road(300.0)
    z = road.elevation.copy()
    z[4000:4101, 0] = -9.999  # -9999 mm over 5 m
    f = _csv(Profile(road.distance, z, tracks=road.tracks), tmp_path / "x_9999.csv")
    with pytest.raises(InputFormatError, match=r"track 'left' holds -9999 mm at station 200\.000 m to 205\.000 m "
                                               r"\(101 samples\): a logger's code for a missing value\? Write the "
                                               r"missing samples as NaN"):
        read_profile(f)
    erd = write_profile(Profile(road.distance, z, tracks=road.tracks), tmp_path / "x.erd", units="mm")
    with pytest.raises(InputFormatError, match="holds -9999 mm at station 200.000 m"):
        read_profile(erd)
    # a road about 10 m above the datum, in mm, passing through 9999.000 mm, is a road
    level = road.elevation + 9.999 - road.elevation[2000, 0]
    back = read_profile(_csv(Profile(road.distance, level, tracks=road.tracks), tmp_path / "ten_m.csv"))
    assert back.elevation[2000, 0] == pytest.approx(9.999, abs=1e-12)


def test_a_run_of_one_elevation_is_refused_by_acceptance_and_flagged_by_road_iri(tmp_path, capsys):
    from longprofile.road import dropout_runs

    road = _road(600.0)
    z = road.elevation.copy()
    z[(road.distance >= 400.0) & (road.distance < 405.0), 0] = 0.0  # the probe's zero dropout
    zeroed = Profile(road.distance, z, tracks=road.tracks)
    assert dropout_runs(zeroed) == [("left", 400.0, pytest.approx(404.95), 0.0)]
    assert dropout_runs(road) == []
    with pytest.raises(InputError, match=r"track 'left' holds one exact elevation \(0 mm\) from station 400\.000 to "
                                         r"404\.950 m .*Write the missing samples as NaN.*exclusion zone"):
        smoothness_acceptance(zeroed, spec_from_dict({"pay": PAY}))
    # excluded (the hint), it is not evaluated: accepted
    res = smoothness_acceptance(zeroed, spec_from_dict({"pay": PAY, "exclusions": {"zones": [[398.0, 407.0]]}}))
    assert res.warnings == ()
    f = _csv(zeroed, tmp_path / "zero.csv")
    assert main(["road", "iri", f, "-o", str(tmp_path / "iri.csv")]) == 0
    assert "warning: track 'left' holds one exact elevation (0 mm) from station 400.000" in " ".join(
        capsys.readouterr().err.split())


def test_the_measured_road_profile_has_no_run_of_one_elevation_near_the_dropout_length():
    """The assumption behind MIN_DROPOUT_RUN_M (2 m): the Sroubek-Sorel measured profile repeats one elevation over
    0.5 m at most (0.25 m step, 0.1 mm resolution)."""
    from longprofile._validation import constant_runs
    from longprofile.road import dropout_runs

    data = np.loadtxt(reference_file("sorel-iri-profile", "profile_1.txt"))
    prof = Profile(data[:, 0], data[:, 1])
    assert dropout_runs(prof) == []
    assert constant_runs(data[:, 0], data[:, 1], 0.5) and not constant_runs(data[:, 0], data[:, 1], 0.75)


# -- 4: a gap inside an exclusion zone ------------------------------------------------------------------------------


def test_a_gap_inside_an_exclusion_zone_is_accepted_and_one_outside_is_refused():
    bump = lambda x: 0.012 * (np.abs(x - 460.0) < 1.0) * np.cos(np.pi * (x - 460.0) / 2) ** 2  # noqa: E731
    road = _road(600.0, add=bump)
    z = road.elevation.copy()
    z[(road.distance >= 300.0) & (road.distance < 305.0), 0] = np.nan
    gap = Profile(road.distance, z, tracks=road.tracks)
    spec = {"pay": PAY, "localized": {"threshold": 2.5}, "grinding": {"grinder_length": 4.0}}
    with pytest.raises(InputError, match=r"missing \(NaN\) elevations from station 300\.000 to 304\.950 m \(100 "
                                         r"sample\(s\)\) outside the exclusion zones.*zones = \[\[299, 305\]\]"):
        smoothness_acceptance(gap, spec_from_dict(spec))
    spec = spec_from_dict({**spec, "exclusions": {"zones": [[295.0, 310.0]]}})
    res, whole = smoothness_acceptance(gap, spec), smoothness_acceptance(road, spec)
    assert res.lots.included_length.tolist()[2:4] == pytest.approx([95.0, 90.0])
    # before the gap the car runs over the same samples; after it, restarted, it agrees once its start has decayed
    np.testing.assert_allclose(res.lots.mri[:3], whole.lots.mri[:3], rtol=1e-12)
    np.testing.assert_allclose(res.lots.mri[4:], whole.lots.mri[4:], rtol=1e-3)
    assert len(res.defects) == 1
    g = simulate_grinding(gap, spec, acceptance=res)
    assert g.achieved and np.nanmax(g.index_after) <= 2.5


# -- 5, 6: what the console says ------------------------------------------------------------------------------------


def test_the_pay_line_names_the_lots_needing_corrective_work(tmp_path, capsys):
    road = _road(600.0)
    limit = float(np.median(smoothness_acceptance(road).lots["mri"]))
    schedule = [[limit, 1.0]]
    res = smoothness_acceptance(road, spec_from_dict({"pay": {"schedule": schedule}}))
    k = int((res.lots["index"] > limit).sum())
    assert k == 3 and res.pay_summary["lots_corrective_work"] == k
    assert f"{k} lot(s) NEED CORRECTIVE WORK (MRI above the last pay limit {limit:g} m/km): no pay" in res.pay_text()
    spec = tmp_path / "s.toml"
    spec.write_text(f"[pay]\nschedule = [[{limit!r}, 1.0]]\n")
    assert main(["road", "acceptance", _csv(road, tmp_path / "p.csv"), "--spec", str(spec), "-o",
                 str(tmp_path / "r")]) == 0
    assert "pay: mean pay factor 1.0000 over 3 paid lot(s); 3 lot(s) NEED CORRECTIVE WORK" in " ".join(
        capsys.readouterr().err.split())


def test_without_a_threshold_the_localized_roughness_is_not_assessed(tmp_path, capsys):
    assert main(["road", "acceptance", _csv(_road(300.0), tmp_path / "p.csv"), "-o", str(tmp_path / "r")]) == 0
    err = " ".join(capsys.readouterr().err.split())
    assert "localized roughness not assessed (no threshold in the spec" in err and "0 localized" not in err
    assert json.loads((tmp_path / "r" / "summary.json").read_text())["pay"]["localized_defects"] is None
    page = (tmp_path / "r" / "index.html").read_text()
    assert "Localized roughness not assessed" in page and "above the threshold" not in page


# -- 7: --overwrite leaves no file of the earlier run --------------------------------------------------------------


def test_overwrite_removes_the_earlier_runs_outputs_and_nothing_else(tmp_path):
    bump = lambda x: 0.012 * (np.abs(x - 150.0) < 1.0) * np.cos(np.pi * (x - 150.0) / 2) ** 2  # noqa: E731
    f = _csv(_road(300.0, add=bump), tmp_path / "p.csv")
    spec = _spec(tmp_path, "[localized]\nthreshold = 2.5\n[grinding]\ngrinder_length = 4.0\n")
    out = tmp_path / "r"
    assert main(["road", "acceptance", f, "--spec", spec, "-o", str(out)]) == 0
    assert (out / "grinds.csv").exists() and (out / "profile_ground.csv").exists()
    (out / "notes.txt").write_text("mine")
    assert main(["road", "acceptance", f, "--spec", spec, "-o", str(out), "--no-grind", "--overwrite"]) == 0
    assert not (out / "grinds.csv").exists() and not (out / "profile_ground.csv").exists()
    assert (out / "notes.txt").read_text() == "mine" and (out / "lots.csv").exists()


def test_a_compare_report_without_a_plot_removes_an_earlier_correlation_png(tmp_path):
    from longprofile.report import write_compare_report
    from longprofile.road import certify_profiler

    road = _road(300.0)
    res = certify_profiler(road, [road], names=["run.csv"])
    out = tmp_path / "cmp"
    out.mkdir()
    (out / "correlation.png").write_bytes(b"an earlier run's figure")
    (out / "mine.png").write_bytes(b"keep")
    write_compare_report(res, out, reference="ref.csv", runs=["run.csv"], overwrite=True)
    assert sorted(p.name for p in out.iterdir()) == ["mine.png", "pairs.csv", "runs.csv", "summary.json"]


# -- 8: what limits the grinding ------------------------------------------------------------------------------------


def test_the_grinding_names_a_depression_and_the_grinder_frame():
    bump = lambda x: 0.012 * (np.abs(x - 300.0) < 1.0) * np.cos(np.pi * (x - 300.0) / 2) ** 2  # noqa: E731
    dip = lambda x: -0.010 * ((x > 297.0) & (x < 300.0)) * np.sin(np.pi * (x - 297.0) / 3.0)  # noqa: E731
    spec = spec_from_dict({"localized": {"threshold": 2.5}, "grinding": {"grinder_length": 1.2, "max_depth": 50}})
    g = simulate_grinding(_road(600.0, dx=0.025, add=bump), spec)
    assert not g.achieved and g.grinds["limit"].unique().tolist() == ["frame"]
    assert g.grinds["max_depth"].max() < 10.0  # far from the 50 mm limit: the frame, not the depth, binds
    assert "1 limited by the grinder frame (1.2 m;" in g.summary() and "within the 50 mm depth limit" in g.summary()
    assert "depth limit (50 mm)" not in g.summary()
    longer = spec_from_dict({"localized": {"threshold": 2.5}, "grinding": {"grinder_length": 4.0, "max_depth": 50}})
    assert simulate_grinding(_road(600.0, dx=0.025, add=bump), longer).achieved
    g = simulate_grinding(_road(600.0, dx=0.025, add=dip), longer)
    assert not g.achieved and g.metadata["limits"][0]["limit"] == "depression"
    assert "1 depression(s) (" in g.summary() and "which grinding cannot fill" in g.summary()


@given(st.one_of(st.integers(-10**14, 10**14).map(float), st.floats(allow_nan=True, allow_infinity=True),
                 st.integers(3, 14).map(lambda k: float(10**k - 1)), st.integers(3, 14).map(lambda k: -float(10**k - 1))))
def test_the_shared_missing_value_code_is_the_rail_rule(v):
    """The rule moved from rail/_data.py to _validation (one rule for rail tables and road files): a whole number of
    9s, at least 999 in size."""
    import math

    from longprofile._validation import missing_value_code, missing_value_codes
    from longprofile.rail import missing_value_code as rail_rule

    old = math.isfinite(v) and abs(v) >= 999 and v == round(v) and set(f"{abs(v):.0f}") == {"9"}
    assert missing_value_code(v) == old == bool(missing_value_codes(np.array([v]))[0])
    assert rail_rule is missing_value_code
