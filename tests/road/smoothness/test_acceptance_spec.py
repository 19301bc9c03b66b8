"""Acceptance specs and reports after a pavement engineer's probe (session 40, /tmp/s40/probe-accept): the events
table is an input the report never overwrites, a typed spec (one line for a value of the wrong type), plausible
lengths and depths per unit system, schedules that cannot be right, zones past the profile's end, lots on the
project's stationing, the unassessed ends of the localized roughness, three-track profiles and the cosmetics."""

from __future__ import annotations

import datetime
import json

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.cli.app import main
from longprofile.errors import InputError, InputFormatError, UnitsError
from longprofile.road import Profile, compare_profiles, smoothness_acceptance
from longprofile.road.smoothness._acceptance import _SPEC_TYPES, lot_bounds, spec_from_dict
from tests.road.smoothness.test_acceptance_checks import _csv, _road


def _run(capsys, *args) -> tuple[int, str]:
    code = main(["road", "acceptance", *map(str, args)])
    return code, capsys.readouterr().err


def _one_line_error(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    return lines[0]


# -- 1: the events table (any file the spec names) is an input -----------------------------------------------------


@pytest.mark.parametrize("events,grind", [("defects.csv", True), ("grinds.csv", False), ("histogram.csv", True)])
def test_an_events_file_in_the_report_folder_is_never_overwritten(tmp_path, capsys, events, grind):
    f = _csv(_road(300.0), tmp_path / "p.csv")
    out = tmp_path / "rep"
    out.mkdir()
    table = "start_m,end_m\n100,120\n"
    (out / events).write_text(table)
    (out / "spec.toml").write_text(f'[localized]\nthreshold = 2.5\n[exclusions]\nevents = "{events}"\n')
    args = [f, "--spec", out / "spec.toml", "-o", out, "--overwrite"] + ([] if grind else ["--no-grind"])
    code, err = _run(capsys, *args)
    assert code == 2 and "overwrite its input" in _one_line_error(err) and events in err
    assert (out / events).read_text() == table


# -- 2, 3: a typed spec with plausible values -------------------------------------------------------------------------


@pytest.mark.parametrize("units,section,key,value,meant", [
    ("si", "localized", "window", 25, "if you meant 25 ft, write 7.62"),
    ("us", "grinding", "max_depth", 5, "if you meant 5 mm, write 0.1969"),
    ("si", "grinding", "max_depth", 0.2, "if you meant 0.2 in, write 5.08"),
    ("us", "grinding", "grinder_length", 1.22, "if you meant 1.22 m, write 4.003"),
    ("si", "pay", "histogram_bin", 10, "if you meant 10 in/mi, write 0.1578"),
    ("us", "lot", "length", 20, "if you meant 20 m, write 65.62"),
    ("si", "lot", "length", 0.1, "0.1 m is outside the plausible 10-10000 m of a lot length; the spec is in SI units (m): fix the value."),
])
def test_lengths_and_depths_of_the_other_unit_system_are_refused(units, section, key, value, meant):
    with pytest.raises(UnitsError) as exc:
        spec_from_dict({"units": units, section: {key: value}})
    text = str(exc.value)
    assert f"[{section}] {key} = {value:g}" in text and f"the spec is in {units.upper()} units" in text
    assert meant in text and "\n" not in text
    # the value of its own unit system passes
    good = {"window": 7.62, "max_depth": 0.2 if units == "us" else 5.0, "grinder_length": 4.0,
            "histogram_bin": 10.0 if units == "us" else 0.2, "length": 528.0}[key]
    spec_from_dict({"units": units, section: {key: good}})


@pytest.mark.parametrize("text,key", [
    ('[localized]\nthreshold = "2.5"', "[localized] threshold"),
    ("[pay]\nschedule = [1.0, 1.05]", "[pay] schedule"),
    ('[pay]\nschedule = "x"', "[pay] schedule"),
    ('[lot]\nlength = "100"', "[lot] length"),
    ('[lot]\nmin_fraction = "half"', "[lot] min_fraction"),
    ("[exclusions]\nzones = [1000, 1150]", "[exclusions] zones"),
    ('[exclusions]\nzones = "1000-1150"', "[exclusions] zones"),
    ("[exclusions]\nzones = [[1000, 1150, 3]]", "[exclusions] zones"),
    ('[exclusions]\nzones = [["a", "b"]]', "[exclusions] zones"),
    ("[exclusions]\nevents = 5", "[exclusions] events"),
    ("[localized]\nwindow = true", "[localized] window"),
])
def test_a_value_of_the_wrong_type_is_one_line_naming_the_key(tmp_path, capsys, text, key):
    (tmp_path / "spec.toml").write_text(text + "\n")
    code, err = _run(capsys, tmp_path / "none.csv", "--spec", tmp_path / "spec.toml", "-o", tmp_path / "out")
    line = _one_line_error(err)
    assert code == 2 and key in line and "expected e.g." in line


def _toml(value) -> str:
    """A TOML value (the test's own writer)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, float):
        return "nan" if value != value else ("inf" if value == np.inf else ("-inf" if value == -np.inf else
                                                                             repr(value)))
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}"
    return str(value)  # int, date, time


_SCALARS = st.one_of(st.booleans(), st.integers(-10**6, 10**6), st.floats(allow_nan=True, allow_infinity=True),
                     st.text("ab1.-_ ", max_size=6), st.dates(min_value=datetime.date(1900, 1, 1)))
_VALUES = st.recursive(_SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                         st.dictionaries(st.sampled_from("xyz"), inner, max_size=2)),
                       max_leaves=6)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                 HealthCheck.too_slow])
@given(key=st.sampled_from(sorted(_SPEC_TYPES)), value=_VALUES)
def test_any_toml_value_of_any_key_is_accepted_or_one_line(tmp_path, capsys, key, value):
    section, name = key
    line = f"{name} = {_toml(value)}\n"
    (tmp_path / "spec.toml").write_text(line if section == "" else f"[{section}]\n{line}")
    code, err = _run(capsys, tmp_path / "none.csv", "--spec", tmp_path / "spec.toml", "-o", tmp_path / "out")
    text = _one_line_error(err)  # a wrong value, or (a right one) the missing profile: never a traceback
    assert code == 2
    assert name in text or "none.csv" in text or "exclusion events" in text or "units" in text, text


# -- 4, 5: tracks -----------------------------------------------------------------------------------------------


def test_an_empty_track_names_track_first_and_a_zone_over_everything_is_one_line(tmp_path, capsys):
    road = _road(300.0)
    z = road.elevation.copy()
    z[:, 1] = np.nan
    f = _csv(Profile(road.distance, z, tracks=road.tracks), tmp_path / "p.csv")
    code, err = _run(capsys, f, "-o", tmp_path / "a")
    assert code == 2 and "--track left" in _one_line_error(err) and "zones" not in err
    (tmp_path / "spec.toml").write_text("[exclusions]\nzones = [[0, 300]]\n")
    code, err = _run(capsys, f, "--spec", tmp_path / "spec.toml", "-o", tmp_path / "b")
    assert code == 2 and "cover the whole profile" in _one_line_error(err)
    with pytest.raises(InputError, match="nothing is left to assess"):
        smoothness_acceptance(_road(300.0), spec_from_dict({"exclusions": {"zones": [[-10, 100], [100, 400]]}}))


def test_three_tracks_are_refused_unless_chosen_and_the_index_tracks_are_named(tmp_path):
    road = _road(300.0)
    three = Profile(road.distance, np.column_stack([road.elevation, road.elevation.mean(axis=1)]),
                    tracks=("left", "right", "centre"))
    with pytest.raises(InputError, match=r"3 tracks .*--track left,right for the MRI"):
        smoothness_acceptance(three)
    res = smoothness_acceptance(three, tracks=["left", "right"])
    assert "lot index: MRI of left and right" in res.lots_text()
    worst = smoothness_acceptance(three, spec_from_dict({"lot": {"index": "iri"}}))
    assert worst.lots_text().endswith("lot index: worst IRI of left, right, centre")
    single = smoothness_acceptance(three, tracks=["centre"])
    assert single.lots_text().endswith("lot index: IRI of centre")


# -- 6, 7: schedules and zones ------------------------------------------------------------------------------------


def test_a_schedule_paying_more_for_rougher_lots_is_refused_and_none_is_not_assessed(tmp_path, capsys):
    with pytest.raises(InputError, match="pays more for a rougher lot"):
        spec_from_dict({"pay": {"schedule": [[0.8, 0.9], [1.0, 1.0], [1.5, 1.05]]}})
    f = _csv(_road(300.0), tmp_path / "p.csv")
    (tmp_path / "spec.toml").write_text("[pay]\nschedule = []\n")
    code, err = _run(capsys, f, "--spec", tmp_path / "spec.toml", "-o", tmp_path / "r")
    assert code == 0 and "pay: not assessed (no [pay] schedule in the spec)\n" in err
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["text"]["pay"] == "not assessed (no [pay] schedule in the spec)"
    assert "Pay: not assessed" in (tmp_path / "r" / "index.html").read_text()


def test_a_zone_past_the_end_is_clipped_with_a_warning_and_one_wholly_outside_refused():
    road = _road(300.0)
    x1 = road.distance[-1]
    res = smoothness_acceptance(road, spec_from_dict({"exclusions": {"zones": [[250, 400]]}}))
    assert res.spec.exclusions == ((250.0, x1),)
    assert any(f"clipped to [250, {x1:g}]" in w and f"the part {x1:g}-400 m" in w for w in res.warnings)
    assert res.pay_summary["excluded_length"] == pytest.approx(x1 - 250.0)
    with pytest.raises(InputError, match="lies outside the profile"):
        smoothness_acceptance(road, spec_from_dict({"exclusions": {"zones": [[350, 400]]}}))


# -- 8: lots on the project's stationing --------------------------------------------------------------------------


def test_lots_aligned_to_a_start_station():
    spec = spec_from_dict({"lot": {"length": 100, "start": 1200}})
    bounds, info = lot_bounds(1234.5, 2000.0, spec)
    assert bounds.tolist() == [1234.5] + [1300.0 + 100 * k for k in range(8)]
    assert info["first_rule"] == "own" and info["first_part"] == pytest.approx(65.5)
    bounds, info = lot_bounds(1280.0, 2000.0, spec)  # 20 m before 1300: merged into the next lot
    assert bounds[:2].tolist() == [1280.0, 1400.0] and info["first_rule"] == "merged"
    # a jittered first station does not shift the lots off the stationing
    bounds, _ = lot_bounds(0.000118, 2000.0, spec_from_dict({"lot": {"length": 100, "start": 0}}))
    assert bounds[1:].tolist() == [100.0 * k for k in range(1, 21)]


@settings(max_examples=40, deadline=None)
@given(x0=st.floats(-500, 500), span=st.floats(100, 900), start=st.floats(-3000, 3000),
       frac=st.sampled_from([0.0, 0.3, 0.5, 1.0]))
def test_aligned_lots_cover_the_section_on_the_grid(x0, span, start, frac):
    spec = spec_from_dict({"lot": {"length": 100, "start": start, "min_fraction": frac}})
    bounds, _ = lot_bounds(x0, x0 + span, spec)
    assert bounds[0] == x0 and bounds[-1] == x0 + span and np.all(np.diff(bounds) > 0)
    inner = (bounds[1:-1] - start) / 100.0
    np.testing.assert_allclose(inner, np.round(inner), atol=1e-6)
    assert np.all(np.diff(bounds) <= 100.0 * (1 + 2 * frac) + 1e-6)  # a short part at each end merged


def test_cli_lots_from_a_start_station(tmp_path, capsys):
    f = _csv(_road(300.0, start=1234.5), tmp_path / "p.csv")
    (tmp_path / "spec.toml").write_text("[lot]\nlength = 100\nstart = 1200\n")
    assert _run(capsys, f, "--spec", tmp_path / "spec.toml", "-o", tmp_path / "r")[0] == 0
    lots = pd.read_csv(tmp_path / "r" / "lots.csv")
    assert lots["start_m"].tolist()[:3] == [1234.5, 1300.0, 1400.0]


# -- 9: the ends of the localized roughness ------------------------------------------------------------------------


def test_the_unassessed_ends_of_the_localized_roughness_are_stated(tmp_path, capsys):
    f = _csv(_road(300.0), tmp_path / "p.csv")
    (tmp_path / "spec.toml").write_text("[localized]\nthreshold = 2.5\n")
    code, err = _run(capsys, f, "--spec", tmp_path / "spec.toml", "-o", tmp_path / "r", "--no-grind")
    assert code == 0
    err = " ".join(err.split())
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    (a0, b0), (a1, b1) = summary["pay"]["localized_unassessed"]
    assert a0 == 0.0 and b0 == pytest.approx(3.81 + 0.125, abs=0.03) and b1 == pytest.approx(300.0, abs=0.06)
    assert 300.0 - a1 == pytest.approx(3.81 + 0.125, abs=0.08)
    assert "not assessed at the profile's ends" in err and f"0-{b0:.6g} and {a1:.6g}-{b1:.6g} m" in err
    assert "not assessed at the profile" in summary["text"]["localized"]


# -- 10: cosmetics and the events file ---------------------------------------------------------------------------


def test_histogram_edges_are_rounded_and_min_fraction_zero_reads_wholly_excluded():
    road = _road(600.0)
    res = smoothness_acceptance(road, spec_from_dict({"lot": {"min_fraction": 0.0}, "exclusions": {"zones": [
        [100, 200]]}, "pay": {"schedule": [[1.5, 1.0], [3.0, 0.9]], "histogram_bin": 0.2}}))
    edges = res.histogram["low"].tolist() + res.histogram["high"].tolist()
    assert all(e == round(e, 1) and len(repr(e)) <= 5 for e in edges), edges
    assert "1 lot(s) not rated (wholly excluded): no pay" in res.pay_text()


def test_a_file_name_as_the_report_folder_is_refused(tmp_path, capsys):
    f = _csv(_road(300.0), tmp_path / "p.csv")
    code, err = _run(capsys, f, "-o", tmp_path / "report.html")
    assert code == 2 and "is a folder" in _one_line_error(err) and not (tmp_path / "report.html").exists()


def test_html_tables_name_their_units(tmp_path, capsys):
    f = _csv(_road(300.0), tmp_path / "p.csv")
    assert _run(capsys, f, "-o", tmp_path / "r")[0] == 0
    page = (tmp_path / "r" / "index.html").read_text()
    assert "<th>start_m</th>" in page and "<th>mri_m_per_km</th>" in page and "<th>low_m_per_km</th>" in page


@pytest.mark.parametrize("text,match", [
    ("start_m,end_m\n100,120\n150,x\n", r"ev\.csv, row 3: start_m, end_m = .*not both numbers"),
    ("start_m,end_m\n100,120\n150,140\n", r"ev\.csv, row 3: end_m 140 is not after start_m 150"),
    ("start_m,end_m,start_ft,end_ft\n100,120,328,394\n", r"ev\.csv: columns start_m,end_m, start_ft,end_ft are ambig"),
])
def test_events_file_refusals_name_the_file_and_row(tmp_path, text, match):
    (tmp_path / "ev.csv").write_text(text)
    with pytest.raises(InputFormatError, match=match):
        spec_from_dict({"exclusions": {"events": "ev.csv"}}, base_dir=tmp_path)


@pytest.mark.parametrize("text", ["", "start_m,end_m\n"])
def test_an_empty_events_file_is_a_warning(tmp_path, text):
    (tmp_path / "ev.csv").write_text(text)
    spec = spec_from_dict({"exclusions": {"events": "ev.csv"}}, base_dir=tmp_path)
    res = smoothness_acceptance(_road(300.0), spec)
    assert any("ev.csv" in w and "no zone is excluded" in w for w in res.warnings)


def test_compare_with_no_offset_search_names_the_alignment_beyond_it():
    road = _road(400.0)
    shift = 1.3
    run = Profile(road.distance + shift, road.elevation, tracks=road.tracks)  # the run's stations 1.3 m off
    c = compare_profiles(road, run, max_offset=0.0)
    assert c.rating < 0.5 and c.outside is not None and c.outside[0] == pytest.approx(-shift, abs=0.06)
