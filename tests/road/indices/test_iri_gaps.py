"""IRI of a profile with gaps (``gaps="restart"``): each run of measured samples is its own file.

External oracle throughout: the existing no-gap path (``iri``, ``iri_report``, ``localized_roughness``,
``profile_psd``) run on the runs written as their own profiles; the real Sroubek-Sorel profile with gaps cut in.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.road import (
    Profile,
    analyse_roughness,
    iri,
    iri_report,
    iso8608_profile,
    localized_roughness,
    profile_psd,
)
from tests._reference_data import reference_file


def _runs(z):
    """(first, last) index of each run of finite values (the test's own splitter, not the library's)."""
    ok = np.isfinite(z)
    edges = np.diff(np.concatenate([[0], ok.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1))


def _gapped(length, dx, seed, gaps, tracks=("left",)):
    """An ISO 8608 class C profile with the stations of each ``(start, length)`` gap set to NaN (all tracks)."""
    p = iso8608_profile(length, dx, "C", rng=seed, tracks=tracks)
    z = p.elevation.reshape(p.distance.size, -1).copy()
    for a, g in gaps:
        z[(p.distance >= a) & (p.distance <= a + g)] = np.nan
    return p, Profile(distance=p.distance, elevation=z, tracks=tracks)


GAPS = st.lists(st.tuples(st.floats(0.0, 1.0), st.floats(0.1, 15.0)), min_size=1, max_size=3)


@settings(max_examples=25, deadline=None)
@given(dx=st.sampled_from([0.025, 0.05, 0.1, 0.25]), seed=st.integers(0, 10_000), gaps=GAPS,
       interval=st.integers(5, 60), mode=st.sampled_from(["fixed", "overlapping"]))
def test_each_run_is_computed_exactly_as_its_own_file(dx, seed, gaps, interval, mode):
    length = 240.0
    _, pg = _gapped(length, dx, seed, [(a * length, g) for a, g in gaps])
    rep = iri_report(pg, mode=mode, interval=float(interval), gaps="restart", min_valid=0.01)
    frame = rep.to_frame().set_index("start_m")
    x, z = pg.distance, pg.elevation[:, 0]
    checked = 0
    for i, k in _runs(z):
        if x[k] - x[i] < 12.0:
            continue
        run = Profile(distance=x[i:k + 1], elevation=z[i:k + 1], tracks=("left",))  # the run as its own file
        first = float(np.ceil((x[i] - 1e-9) / interval * (2 if mode == "overlapping" else 1))
                      * interval / (2 if mode == "overlapping" else 1))
        if first + interval > x[k]:
            continue
        own = iri_report(run, mode=mode, interval=float(interval), start=first)
        mine = frame.loc[own.interval_start]
        np.testing.assert_array_equal(mine["iri_left_m_per_km"].to_numpy(), own.iri[:, 0])
        checked += own.iri.shape[0]
    longest = max((x[k] - x[i] for i, k in _runs(z)), default=0.0)
    assert checked > 0 or longest < 12.0 + 2 * interval  # a long enough run was compared


@settings(max_examples=25, deadline=None)
@given(dx=st.sampled_from([0.05, 0.1, 0.25]), seed=st.integers(0, 10_000), gaps=GAPS, interval=st.integers(10, 80))
def test_segment_iri_is_the_valid_length_weighted_mean_of_the_runs(dx, seed, gaps, interval):
    length = 300.0
    _, pg = _gapped(length, dx, seed, [(a * length, g) for a, g in gaps])
    res = iri(pg, segment_length=float(interval), gaps="restart", min_valid=1e-9, moving_average=False)
    x, z = pg.distance, pg.elevation[:, 0]
    runs = [(i, k) for i, k in _runs(z) if x[k] - x[i] >= 11.0]
    for s, (a, b) in enumerate(zip(res.segment_start, res.segment_end)):
        total = covered = 0.0
        for i, k in runs:
            lo, hi = max(a, x[i]), min(b, x[k])
            if hi - lo <= 1e-9:
                continue
            run = Profile(distance=x[i:k + 1], elevation=z[i:k + 1], tracks=("left",))
            part = iri(run, segment_length=hi - lo, start=lo, moving_average=False)  # the no-gap path on the run
            total += part.iri[0, 0] * (hi - lo)
            covered += hi - lo
        np.testing.assert_allclose(res.valid_length[s, 0], covered, rtol=1e-9, atol=1e-9)
        if covered > 0:
            np.testing.assert_allclose(res.iri[s, 0], total / covered, rtol=1e-9)
        else:
            assert np.isnan(res.iri[s, 0])


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), gaps=GAPS, min_valid=st.floats(0.05, 1.0))
def test_a_segment_below_the_minimum_fraction_is_nan_with_its_reason(seed, gaps, min_valid):
    _, pg = _gapped(400.0, 0.1, seed, [(a * 400.0, g) for a, g in gaps])
    rep = iri_report(pg, interval=25.0, gaps="restart", min_valid=min_valid)
    frame = rep.to_frame()
    frac = rep.valid_length[:, 0] / 25.0
    short = frac < min_valid - 1e-12
    np.testing.assert_array_equal(np.isnan(rep.iri[:, 0]), short)
    np.testing.assert_allclose(frame["valid_fraction"], frac)
    assert all(("no IRI" in n) == bool(s) for n, s in zip(frame["note"], short))
    assert rep.gaps.without_iri == int(short.sum())


def test_the_default_refuses_naming_the_option():
    _, pg = _gapped(200.0, 0.05, 1, [(100.05, 4.9)])
    for call in (lambda: iri(pg), lambda: iri_report(pg), lambda: localized_roughness(pg),
                 lambda: analyse_roughness(pg)):
        with pytest.raises(InputError, match=r"missing \(NaN\) elevation at station 100\.050 m.*--gaps restart"):
            call()
    with pytest.raises(InputError, match="gaps='restart'"):
        profile_psd(pg)
    with pytest.raises(InputError, match="gaps must be 'refuse'"):
        iri(pg, gaps="interpolate")
    with pytest.raises(InputError, match=r"min_valid .* \(0, 1\].*0\.8"):
        iri(pg, gaps="restart", min_valid=80)


@pytest.mark.parametrize("mode", ["fixed", "continuous"])
def test_restart_on_a_profile_without_gaps_changes_nothing(mode):
    p = iso8608_profile(300.0, 0.05, "B", rng=5, tracks=("left", "right"))
    a = iri_report(p, mode=mode, window=None if mode == "fixed" else 7.62)
    b = iri_report(p, mode=mode, window=None if mode == "fixed" else 7.62, gaps="restart")
    for f in ("iri", "mri", "hri", "section_iri"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    assert not b.gaps.any and "gap_note" in b.metadata and b.metadata["gap_note"] == ""
    assert {"valid_length_left_m", "valid_length_right_m", "valid_length_hri_m", "valid_fraction", "note"} <= set(
        b.to_frame().columns) and "note" not in a.to_frame().columns


def test_tracks_with_gaps_at_different_places():
    p = iso8608_profile(500.0, 0.05, "C", rng=8, tracks=("left", "right"))
    z = p.elevation.copy()
    z[(p.distance > 120) & (p.distance < 126)] = np.nan * z[0]
    z[(p.distance > 120) & (p.distance < 126), 1] = p.elevation[(p.distance > 120) & (p.distance < 126), 1]
    z[(p.distance > 310) & (p.distance < 340), 1] = np.nan
    two = Profile(distance=p.distance, elevation=z, tracks=p.tracks)
    rep = iri_report(two, interval=50.0, gaps="restart")
    for j, t in enumerate(p.tracks):  # each track as if analysed alone (its own gaps only)
        alone = iri_report(Profile(distance=p.distance, elevation=z[:, j], tracks=(t,)), interval=50.0,
                           gaps="restart")
        np.testing.assert_allclose(rep.iri[:, j], alone.iri[:, 0], rtol=1e-13)
        np.testing.assert_allclose(rep.valid_length[:, j], alone.valid_length[:, 0])
    np.testing.assert_array_equal(np.isnan(rep.mri), np.isnan(rep.iri).any(axis=1))
    half = iri_report(Profile(distance=p.distance, elevation=z.mean(axis=1), tracks=("h",)), interval=50.0,
                      gaps="restart")
    np.testing.assert_allclose(rep.hri, half.iri[:, 0], rtol=1e-13)
    assert np.isnan(rep.iri[6, 1]) and np.isfinite(rep.iri[6, 0])  # 300-350: right measured over 40 %
    assert rep.gaps.gaps[0][0] == "left" and rep.gaps.gaps[1][0] == "right"


def test_a_run_too_short_to_initialise_is_dropped_and_named():
    _, pg = _gapped(300.0, 0.05, 3, [(100.0, 5.0), (113.0, 4.0)])  # 105-113: 8 m of data, under the 11 m lead-in
    rep = iri_report(pg, interval=50.0, gaps="restart")
    assert len(rep.gaps.dropped) == 1 and rep.gaps.dropped[0][0] == "left"
    assert rep.gaps.dropped[0][1] == pytest.approx(105.05) and rep.gaps.dropped[0][2] == pytest.approx(112.95)
    assert "1 run(s) shorter than the 11 m lead-in left out (left 105.050-112.950 m)" in rep.metadata["gap_note"]
    # 100-150: measured from 117.05 (after the second gap) + the 0.1 m the moving average trims at a run's start
    np.testing.assert_allclose(rep.valid_length[2, 0], 150.0 - 117.15, atol=1e-9)


def test_rows_removed_are_gaps_as_nan_rows_are():
    p, pg = _gapped(300.0, 0.05, 4, [(150.0, 6.0)])
    keep = np.isfinite(pg.elevation[:, 0])
    cut = Profile(distance=p.distance[keep], elevation=p.elevation[keep], tracks=p.tracks)
    with pytest.raises(InputError, match="gap.*longer than 1 m.*--gaps restart"):
        iri(cut)
    a, b = iri(pg, segment_length=20.0, gaps="restart"), iri(cut, segment_length=20.0, gaps="restart")
    np.testing.assert_array_equal(a.iri, b.iri)
    np.testing.assert_array_equal(a.valid_length, b.valid_length)
    assert a.gaps.gaps == b.gaps.gaps


def test_localized_roughness_and_psd_per_run():
    _, pg = _gapped(600.0, 0.1, 6, [(250.0, 10.0)])
    x, z = pg.distance, pg.elevation
    loc = localized_roughness(pg, window=25.0, threshold=np.inf, gaps="restart")
    for i, k in _runs(z[:, 0]):
        own = localized_roughness(Profile(distance=x[i:k + 1], elevation=z[i:k + 1], tracks=("left",)),
                                  window=25.0, threshold=np.inf)
        at = np.searchsorted(loc.station, own.station)
        np.testing.assert_array_equal(loc.station[at], own.station)
        np.testing.assert_array_equal(loc.continuous_iri[at, 0], own.continuous_iri[:, 0])
    assert loc.station.size == sum(
        localized_roughness(Profile(distance=x[i:k + 1], elevation=z[i:k + 1], tracks=("left",)), window=25.0,
                            threshold=np.inf).station.size for i, k in _runs(z[:, 0]))
    psd = profile_psd(pg, segment_length=51.2, gaps="restart")
    parts = [profile_psd(Profile(distance=x[i:k + 1], elevation=z[i:k + 1], tracks=("left",)), segment_length=51.2)
             for i, k in _runs(z[:, 0])]
    want = sum(q.psd * q.n_segments for q in parts) / sum(q.n_segments for q in parts)
    np.testing.assert_allclose(psd.psd, want, rtol=1e-12)
    assert psd.n_segments == sum(q.n_segments for q in parts)


def test_report_analysis_states_the_gaps():
    _, pg = _gapped(500.0, 0.1, 9, [(140.0, 8.0)])
    an = analyse_roughness(pg, gaps="restart")
    assert an.iri.gaps.any and any(n.startswith("Gaps: 1 gap(s)") for n in an.notes)
    assert an.psd is not None and an.waveband is None
    assert any("Waveband energies not computed" in n and "whole record" in n for n in an.notes)


# ---- the real Sroubek-Sorel profile (0.25 m, 544 m) with gaps cut in --------------------------------------------

@pytest.fixture(scope="module")
def sorel():
    d = np.loadtxt(reference_file("sorel-iri-profile", "profile_1.txt"))
    x, z = d[:, 0], d[:, 1]
    return x, z, iri(Profile(distance=x, elevation=z, tracks=("e",)), segment_length=20.0).iri[:, 0]


def test_sorel_with_gaps_fully_measured_segments(sorel):
    x, z, ref = sorel
    zz = z.copy()
    zz[(x > 640.3) & (x < 644.1)] = np.nan  # one gap of 3.5 m in the segment 638-658
    res = iri(Profile(distance=x, elevation=zz, tracks=("e",)), segment_length=20.0, gaps="restart")
    before = res.segment_end <= 638.0
    np.testing.assert_array_equal(res.iri[before, 0], ref[before])  # the car is causal: bit for bit
    # after the gap: exactly the segments of the run written as its own file (the restart's initialisation) ...
    i = int(np.flatnonzero(np.isnan(zz))[-1]) + 1
    own = iri(Profile(distance=x[i:], elevation=z[i:], tracks=("e",)), segment_length=20.0, start=658.0)
    after = res.segment_start >= 658.0
    np.testing.assert_array_equal(res.iri[after, 0], own.iri[:, 0])
    # ... which differ from the no-gap values by the restart transient only where it has not died out
    rel = np.abs(res.iri[after, 0] / ref[after] - 1)
    assert rel[0] > 1e-4 and rel[3:].max() < 1e-3


def test_sorel_partial_segments_against_the_no_gap_value(sorel):
    x, z, ref = sorel
    rng = np.random.default_rng(0)
    errors = []
    for _ in range(150):
        zz = z.copy()
        a, g = rng.uniform(x[0] + 12, x[-1] - 24), rng.uniform(0.5, 10.0)
        zz[(x >= a) & (x <= a + g)] = np.nan
        res = iri(Profile(distance=x, elevation=zz, tracks=("e",)), segment_length=20.0, gaps="restart")
        frac = res.valid_length[:, 0] / 20.0
        part = (frac < 0.999) & np.isfinite(res.iri[:, 0])
        assert (frac[part] >= 0.8).all()
        errors += list(res.iri[part, 0] / ref[part] - 1)
    errors = np.abs(errors)
    # the figures of docs/road-indices.md ("Profiles with gaps"): median a few %, a third at most
    assert 0.01 < np.median(errors) < 0.1 and np.percentile(errors, 95) < 0.4


# ---- a dead track (every elevation missing, or only runs shorter than the lead-in): reported, not fatal -----------

def _dead(p, dead, blips):
    """``p`` (two tracks) with track ``dead`` missing except ``blips`` ``(start, length)`` shorter than the lead-in."""
    z = p.elevation.copy()
    keep = np.zeros(p.distance.size, dtype=bool)
    for a, g in blips:
        keep |= (p.distance >= a) & (p.distance <= a + g)
    z[~keep, dead] = np.nan
    return Profile(distance=p.distance, elevation=z, tracks=p.tracks)


@settings(max_examples=20, deadline=None)
@given(dx=st.sampled_from([0.05, 0.1, 0.25]), seed=st.integers(0, 10_000), gaps=st.lists(
           st.tuples(st.floats(0.0, 1.0), st.floats(0.1, 15.0)), max_size=2), dead=st.sampled_from([0, 1]),
       blips=st.lists(st.tuples(st.floats(0.0, 230.0), st.floats(0.0, 9.0)), max_size=3),
       mode=st.sampled_from(["fixed", "continuous", "overlapping"]), units=st.sampled_from(["si", "us"]))
def test_the_live_track_of_a_profile_with_a_dead_track_is_that_track_alone(dx, seed, gaps, dead, blips, mode, units):
    length = 240.0
    p, pg = _gapped(length, dx, seed, [(a * length, g) for a, g in gaps], tracks=("left", "right"))
    pg = _dead(pg, dead, blips)
    live, name = 1 - dead, pg.tracks[1 - dead]
    kw = dict(mode=mode, units=units, gaps="restart", interval=30.0 if units == "si" else 100.0)
    if any(pg.distance[k] - pg.distance[i] >= 12.0 for i, k in _runs(pg.elevation[:, live])):
        rep = iri_report(pg, **kw)
    else:  # the live track has no run long enough either: refused in one line
        with pytest.raises(InputError, match="none of the tracks 'left', 'right' has a measured run of at least"):
            iri_report(pg, **kw)
        return
    alone = iri_report(pg, tracks=name, **kw)
    np.testing.assert_array_equal(rep.iri[:, live], alone.iri[:, 0])  # bit for bit
    np.testing.assert_array_equal(rep.valid_length[:, live], alone.valid_length[:, 0])
    assert rep.section_iri[live] == alone.section_iri[0]
    assert (rep.section_start, rep.section_end) == (alone.section_start, alone.section_end)
    for key in ("moving_average_applied", "moving_average_reason", "method", f"section_iri_{name}"):
        assert rep.metadata[key] == alone.metadata[key]
    assert (rep.valid_length[:, dead] == 0).all() and (rep.hri_valid_length == 0).all()
    assert np.isnan(rep.iri[:, dead]).all() and np.isnan(rep.mri).all() and np.isnan(rep.hri).all()
    assert np.isnan(rep.section_iri[dead]) and np.isnan(rep.section_mri) and np.isnan(rep.section_hri)
    frame = rep.to_frame()
    assert (frame["valid_fraction"] == 0).all()
    note = frame["note"].str
    assert (note.startswith("no IRI: measured ") & note.contains(f"{pg.tracks[dead]} 0.0%,", regex=False)
            & note.endswith("hri 0.0% (< 80%)")).all()
    assert rep.gaps.dead == (pg.tracks[dead],) and rep.metadata["gap_dead_tracks"] == pg.tracks[dead]
    note = rep.metadata["gap_note"]
    assert note.startswith(f"track(s) '{pg.tracks[dead]}' have no measured run of at least the 11 m lead-in")
    assert f"check the sensor, or analyse the other track(s) alone (--track {name})" in note
    # the dead track's gaps and short runs are not counted as the live track's
    assert rep.gaps.gaps == alone.gaps.gaps and rep.gaps.dropped == alone.gaps.dropped


def test_a_dead_track_in_iri_localized_roughness_and_the_report_analysis():
    p = iso8608_profile(400.0, 0.1, "C", rng=11, tracks=("left", "right"))
    pg = _dead(p, 0, [])
    res, alone = iri(pg, segment_length=50.0, gaps="restart"), iri(pg, segment_length=50.0, gaps="restart",
                                                                   tracks="right")
    np.testing.assert_array_equal(res.iri[:, 1], alone.iri[:, 0])
    assert np.isnan(res.iri[:, 0]).all() and np.isnan(res.mri).all() and np.isnan(res.hri).all()
    assert res.gaps.dead == ("left",) and res.gaps.without_iri == 0 and not res.gaps.gaps
    loc = localized_roughness(pg, window=25.0, threshold=2.0, gaps="restart")
    own = localized_roughness(pg, window=25.0, threshold=2.0, gaps="restart", tracks="right")
    np.testing.assert_array_equal(loc.station, own.station)
    np.testing.assert_array_equal(loc.continuous_iri[:, 1], own.continuous_iri[:, 0])
    assert loc.tracks == ("left", "right", "MRI") and np.isnan(loc.continuous_iri[:, [0, 2]]).all()
    assert {d.track for d in loc.defects} <= {"right"}
    an = analyse_roughness(pg, segment_length=50.0, gaps="restart")
    assert an.psd.tracks == ("right",) and len(an.iso8608) == 1
    np.testing.assert_array_equal(an.psd.psd[:, 0], profile_psd(own_profile := Profile(
        distance=p.distance, elevation=p.elevation[:, 1], tracks=("right",))).psd[:, 0])
    assert own_profile.tracks == ("right",)
    assert any(n.startswith("Gaps: track(s) 'left' have no measured run") for n in an.notes)
    assert any("PSD and ISO 8608 class: track(s) left have no measured run" in n for n in an.notes)


def test_no_track_with_a_run_long_enough_is_refused_in_one_line():
    p = iso8608_profile(300.0, 0.1, "C", rng=12, tracks=("left", "right"))
    both = _dead(_dead(p, 0, [(50.0, 8.0)]), 1, [])
    with pytest.raises(InputError) as err:
        iri_report(both, gaps="restart")
    assert "none of the tracks 'left', 'right' has a measured run of at least the 11 m lead-in" in str(err.value)
    assert "\n" not in str(err.value)
    with pytest.raises(InputError, match=r"^track 'right' has no measured run of at least the 11 m lead-in"):
        iri(_dead(p, 1, []), gaps="restart", tracks="right")
    with pytest.raises(InputError, match="track 'right' has a missing \\(NaN\\) elevation.*--gaps restart"):
        iri(_dead(p, 1, []))  # the default still refuses any missing elevation
