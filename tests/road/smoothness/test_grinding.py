"""Grinding simulation. Oracle: the continuous IRI of the ground profile computed independently by
longprofile.road.iri_report (every-sample windows) must be below the threshold; a Gaussian bump on a smooth
profile is removed with depth <= its height and nothing outside the must-grind area changes."""

import numpy as np
import pytest

from longprofile.errors import InputError
from longprofile.road import Profile, iri_report
from longprofile.road.smoothness._acceptance import spec_from_dict
from longprofile.road.smoothness._grinding import simulate_grinding


def _road(bump=6e-3):
    x = np.arange(0, 600, 0.025)
    z = 5e-3 * np.sin(2 * np.pi * x / 37) + 1e-3 * np.sin(2 * np.pi * x / 5.3)
    return Profile(distance=x, elevation=z + bump * np.exp(-((x - 300) / 0.4) ** 2))


def test_bump_is_ground_below_threshold():
    prof = _road()
    before = iri_report(prof, mode="continuous").iri.max()
    spec = spec_from_dict({"index": "iri", "localized": {"threshold": 2.0}})
    assert before > 2.5
    g = simulate_grinding(prof, spec)
    assert g.achieved and len(g.grinds) == 1
    after = iri_report(g.profile, mode="continuous").iri.max()
    assert after <= 2.0
    # the patched localized index after grinding equals a full re-run of the acceptance on the ground profile
    from longprofile.road.smoothness._acceptance import localized_index

    c_full, _, idx_full, _ = localized_index(g.profile, spec)
    assert np.allclose(g.station, c_full) and np.nanmax(np.abs(g.index_after - idx_full)) < 1e-3 * 2.0
    dz = prof.elevation[:, 0] - g.profile.elevation[:, 0]
    assert dz.min() >= 0.0  # grinding only removes material
    assert dz.max() <= 6e-3
    row = g.grinds.iloc[0]
    assert row.max_depth == pytest.approx(dz.max() * 1000)
    assert np.all(dz[(prof.distance < row.start - 1e-9) | (prof.distance > row.end + 1e-9)] == 0.0)


def test_depth_limit_flags_not_achieved_and_no_defect_no_grind():
    prof = _road(bump=30e-3)
    spec = spec_from_dict({"index": "iri", "localized": {"threshold": 2.0}, "grinding": {"max_depth": 2.0}})
    g = simulate_grinding(prof, spec)
    assert not g.achieved and g.grinds.max_depth.max() <= 2.0 + 1e-9
    smooth = simulate_grinding(_road(bump=0.0), spec)
    assert smooth.grinds.empty and np.array_equal(smooth.profile.elevation, _road(bump=0.0).elevation)


def test_needs_threshold():
    with pytest.raises(InputError, match="threshold"):
        simulate_grinding(_road(), spec_from_dict({"index": "iri"}))


def _two_tracks():
    x = np.arange(0, 800, 0.025)
    bumps = sum(5e-3 * np.exp(-((x - s) / 0.4) ** 2) for s in (200.0, 520.0))
    left = 4e-3 * np.sin(2 * np.pi * x / 37) + bumps + 7e-3 * np.exp(-((x - 350) / 0.3) ** 2)  # left only
    z = np.column_stack([left, 3e-3 * np.sin(2 * np.pi * x / 23) + bumps])
    return Profile(distance=x, elevation=z, tracks=("left", "right"))


def test_grinding_fixes_the_defects_of_the_acceptance_by_its_index():
    """Spec index "auto" on two tracks: the acceptance's localized index (and defects) are the MRI; the grinding
    must use the same index (before: the worst track, so the grind list and the before/after map did not describe
    the report's defects)."""
    from longprofile.road.smoothness._acceptance import smoothness_acceptance

    prof = _two_tracks()
    spec = spec_from_dict({"lot": {"length": 200.0}, "localized": {"threshold": 2.0}})
    acc = smoothness_acceptance(prof, spec, check_units=False)  # a synthetic sine, smoother than a pavement
    assert acc.spec.index == "mri" and len(acc.defects) >= 2
    for g in (simulate_grinding(prof, spec, acceptance=acc), simulate_grinding(prof, spec)):
        np.testing.assert_array_equal(g.index_before, acc.localized["index"].to_numpy())
        assert g.metadata["areas"] == len(acc.defects)  # these defects are far apart: one area each
        # where nothing was ground, the index after equals the index before (same index, same car run)
        assert np.nanmax(g.index_after[acc.localized["station"].to_numpy() < 150.0]
                         - g.index_before[acc.localized["station"].to_numpy() < 150.0]) == 0.0
        assert np.nanmax(g.index_after) <= 2.0
        # the worst track of the left-only bump (MRI below the threshold) is not ground
        assert not ((g.grinds.start <= 351.0) & (g.grinds.end >= 349.0)).any()
    worst = simulate_grinding(prof, spec_from_dict({"index": "iri", "localized": {"threshold": 2.0}}))
    assert ((worst.grinds.start <= 351.0) & (worst.grinds.end >= 349.0)).any()


def test_summary_counts_the_areas_that_cannot_be_reached():
    prof = _road(bump=30e-3)
    spec = spec_from_dict({"index": "iri", "localized": {"threshold": 2.0}, "grinding": {"max_depth": 2.0}})
    assert simulate_grinding(prof, spec).summary() == ("grinding brings 0 of 1 must-grind area(s) to <= 2 m/km; 1 "
                                                       "CANNOT be brought below it: 1 limited by the depth limit (2 mm, "
                                                       "reached; 292.34-310.01 m; grinding.max_depth)")
    ok = simulate_grinding(_road(), spec_from_dict({"index": "iri", "localized": {"threshold": 2.0}}))
    assert ok.summary() == "grinding brings all 1 must-grind area(s) to <= 2 m/km"
    none = simulate_grinding(_road(bump=0.0), spec)
    assert none.summary() == "no must-grind area (localized index <= 2 m/km)"
