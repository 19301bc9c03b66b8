"""Smoothness acceptance. Oracles: lot IRI against longprofile.road.iri_report (mode="fixed", a separate code path
with exact inserted boundaries) and the continuous IRI against iri_report(mode="continuous"); pay factors,
exclusions and histogram against hand calculation on a profile of two halves with known, different roughness."""

import numpy as np
import pytest

from longprofile.errors import InputError, UnitsError
from longprofile.road import Profile, iri_report, iso8608_profile
from longprofile.road.smoothness._acceptance import (
    default_spec,
    pay_factor,
    read_spec,
    smoothness_acceptance,
    spec_from_dict,
)


@pytest.fixture(scope="module")
def two_track():
    a, b = iso8608_profile(1300.0, 0.05, "A", rng=3), iso8608_profile(1300.0, 0.05, "A", rng=4)
    return Profile(distance=a.distance, elevation=np.column_stack([a.elevation[:, 0], b.elevation[:, 0]]),
                   tracks=("left", "right"))


@pytest.mark.parametrize("units,lot", [("si", 100.0), ("us", 528.0)])
def test_lots_match_iri_report(two_track, units, lot):
    spec = spec_from_dict({"units": units, "lot": {"length": lot}})
    res = smoothness_acceptance(two_track, spec)
    rep = iri_report(two_track, mode="fixed", interval=lot, units=units)
    assert len(res.lots) == rep.iri.shape[0]
    # iri_report leaves out an incomplete last segment; the acceptance merges a remainder shorter than half a lot into
    # the last lot (US: the 41 ft after 8 lots of 528 ft), which then differs: the whole lots agree
    k = int(np.isclose(res.lots.end - res.lots.start, lot).sum())
    assert k >= len(res.lots) - 1
    # limits interpolated within a step here, inserted as stations there: agree to ~dx / lot length
    assert np.allclose(res.lots[["iri_left", "iri_right"]].to_numpy()[:k], rep.iri[:k], rtol=5e-4)
    assert np.allclose(res.lots["mri"][:k], rep.mri[:k], rtol=5e-4)


def test_localized_matches_continuous_iri_report(two_track):
    spec = default_spec("us")
    res = smoothness_acceptance(two_track, spec)
    rep = iri_report(two_track, mode="continuous", units="us")
    centre = 0.5 * (rep.interval_start + rep.interval_end)
    ref = np.interp(res.localized.station, centre, rep.iri[:, 0])
    assert np.allclose(res.localized.iri_left, ref, rtol=2e-3)


def test_pay_exclusions_histogram_by_hand():
    # left half smooth, right half rough: a sine of known IRI response; the lots' pay follows the schedule.
    x = np.arange(0, 400.0 + 0.025, 0.05)
    z = np.where(x < 200, 0.5e-3, 3e-3) * np.sin(2 * np.pi * x / 10.0)
    prof = Profile(distance=x, elevation=z)
    spec = spec_from_dict({"index": "iri", "lot": {"length": 100}, "localized": {"threshold": 5.0},
                           "exclusions": {"zones": [[250.0, 300.0]]},
                           "pay": {"schedule": [[1.0, 1.05], [3.0, 1.0], [6.0, 0.9]], "histogram_bin": 1.0}})
    res = smoothness_acceptance(prof, spec)
    lots = res.lots
    assert lots.included_length.tolist() == pytest.approx([100.0, 100.0, 50.0, 100.0], abs=0.2)
    # by hand: pay = first row whose limit >= lot IRI
    assert lots.pay_factor.tolist() == [pay_factor(v, spec.pay_schedule) for v in lots["index"]]
    assert lots["index"][0] < lots["index"][2]
    # the excluded zone's windows are blank
    st = res.localized.station
    assert res.localized["index"][(st > 250 - 3.81) & (st < 300 + 3.81)].isna().all()
    assert res.histogram.lots.sum() == 4
    assert res.histogram.length.sum() == pytest.approx(lots.included_length.sum())
    assert res.pay_summary["excluded_length"] == pytest.approx(50.0)
    assert pay_factor(7.0, spec.pay_schedule) != pay_factor(7.0, spec.pay_schedule)  # NaN above the schedule


def test_spec_errors(tmp_path):
    with pytest.raises(InputError, match="unknown key 'lots'"):
        spec_from_dict({"lots": {"length": 1}})
    with pytest.raises(InputError, match=r"unknown key lot.'lenght'"):
        spec_from_dict({"lot": {"lenght": 1}})
    with pytest.raises(InputError, match="increase"):
        spec_from_dict({"pay": {"schedule": [[2, 1.0], [1, 0.9]]}})
    f = tmp_path / "spec.toml"
    f.write_text('units = "us"\n[lot]\nlength = 528\n[localized]\nthreshold = 160\ncolour = "red"\n')
    with pytest.raises(InputError, match="colour"):
        read_spec(f)
    ev = tmp_path / "events.csv"
    ev.write_text("start_m,end_m\n10,20\n")
    f.write_text('[exclusions]\nevents = "events.csv"\n')
    assert read_spec(f).exclusions == ((10.0, 20.0),)


@pytest.mark.parametrize(("units", "section", "value", "hint"), [
    ("si", {"localized": {"threshold": 160.0}}, 160.0, 'units = "us"'),  # a US spec without units = "us"
    ("si", {"pay": {"schedule": [[45.0, 1.05], [60.0, 1.0]]}}, 45.0, 'units = "us"'),
    ("us", {"grinding": {"threshold": 2.5}}, 2.5, 'units = "si"'),  # m/km typed into a US spec
])
def test_iri_limits_in_the_other_unit_system_are_refused(units, section, value, hint):
    # before 2026-12-06 the US limits read as m/km paid every lot the top factor, silently
    with pytest.raises(UnitsError, match=rf"{value:g} .* outside any paved road's range .*{hint}"):
        spec_from_dict({"units": units, **section})
    us = {"localized": {"threshold": 160.0}, "pay": {"schedule": [[45.0, 1.05], [60.0, 1.0]]}}
    assert spec_from_dict({"units": "us", **us}).localized_threshold == 160.0  # the same values, declared


def test_a_pay_factor_given_as_a_percentage_is_refused():
    with pytest.raises(InputError, match="pay factor 105 .* percentage"):
        spec_from_dict({"pay": {"schedule": [[1.0, 105.0], [2.0, 100.0]]}})


def test_zone_outside_profile_and_mri_needs_two_tracks():
    x = np.arange(0, 300.0, 0.05)
    prof = Profile(distance=x, elevation=1e-3 * np.sin(x))
    with pytest.raises(InputError, match="outside the profile"):
        smoothness_acceptance(prof, spec_from_dict({"index": "iri", "exclusions": {"zones": [[350, 400]]}}))
    with pytest.raises(InputError, match="MRI needs exactly two tracks"):
        smoothness_acceptance(prof, spec_from_dict({"index": "mri"}))
    # the default index is "auto": the IRI for one track (MRI for two), resolved in the result
    assert smoothness_acceptance(prof, default_spec()).spec.index == "iri"
    # a lot or window out of any plausible range is a unit mistake (1e-9 ft asked for a 7 TiB array of lots)
    for spec in ({"index": "iri", "lot": {"length": 1e-9}}, {"index": "iri", "localized": {"window": 0.1}}):
        with pytest.raises(UnitsError, match="outside the plausible"):
            spec_from_dict(spec)
    # a window shorter than 10 samples of a coarse profile (1 m): not a statement
    coarse = Profile(distance=np.arange(0, 300.0, 1.0), elevation=1e-3 * np.sin(np.arange(0, 300.0, 1.0)))
    with pytest.raises(InputError, match="shorter than 10 samples"):
        smoothness_acceptance(coarse, spec_from_dict({"index": "iri"}))


def _cli():
    import typer

    from longprofile.cli._road_acceptance import register

    app = typer.Typer()
    register(app)

    @app.command("noop")
    def _noop():
        pass

    return app


def test_cli_acceptance_report(tmp_path):
    from typer.testing import CliRunner

    from longprofile.io import write_profile

    x = np.arange(0, 1000.0, 0.025)
    rng = np.random.default_rng(0)
    z = 5e-3 * np.sin(2 * np.pi * x / 37.0) + 6e-3 * np.exp(-((x - 400.0) / 0.4) ** 2)
    prof = Profile(distance=x, elevation=np.column_stack([z, z + rng.normal(0, 2e-5, x.size)]),
                   tracks=("left", "right"))
    f = write_profile(prof, tmp_path / "profile.erd")
    spec = tmp_path / "spec.toml"
    spec.write_text('units = "us"\n[lot]\nlength = 528\n[localized]\nthreshold = 120\n'
                    '[exclusions]\nzones = [[2000, 2100]]\n[pay]\nschedule = [[60, 1.05], [90, 1.0], [200, 0.9]]\n')
    out = tmp_path / "report"
    # a synthetic sine, smoother than any pavement (section IRI 0.17 m/km): refused unless --no-check-units
    res = CliRunner().invoke(_cli(), ["acceptance", str(f), "--spec", str(spec), "-o", str(out)])
    assert isinstance(res.exception, UnitsError) and "--no-check-units" in str(res.exception)
    res = CliRunner().invoke(_cli(), ["acceptance", str(f), "--spec", str(spec), "-o", str(out), "--no-check-units"])
    assert res.exit_code == 0, res.output
    page = (out / "index.html").read_text()
    assert "Lots" in page and "Grinding simulation" in page and "data:image/png;base64" in page
    import pandas as pd

    grinds = pd.read_csv(out / "grinds.csv")
    assert len(grinds) >= 1 and grinds.achieved.all()
    assert abs(grinds.start_ft.min() * 0.3048 - 400.0) < 3.0  # columns named with the spec's units (US: ft)
    assert (out / "profile_ground.csv").exists()
    spec.write_text('units = "us"\n[lot]\nlength = 528\nsize = 3\n')
    bad = CliRunner().invoke(_cli(), ["acceptance", str(f), "--spec", str(spec), "-o", str(out), "--overwrite"])
    assert isinstance(bad.exception, InputError) and "size" in str(bad.exception)
