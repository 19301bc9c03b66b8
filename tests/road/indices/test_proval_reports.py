"""ProVAL's other analyses as reports (road ride-number, straightedge, profile-index, faulting): oracles from
geometry (a sine under a straightedge and under the profilograph's wheels, steps at joints), identities of the Ride
Number (a flat road is 5, PI linear in the roughness, segments tiling the section), the two unit systems describing
one road, and the one-line refusals (gaps, short profiles, values in the other unit system)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, UnitsError
from longprofile.road import (
    Profile,
    faulting_report,
    iso8608_profile,
    profile_index_report,
    ride_number,
    ride_number_report,
    straightedge_report,
)
from longprofile.road.indices._profilograph import CALIFORNIA_WHEELS_FT

# ---- straightedge: a sine of amplitude A and wavelength lambda under a chord of length L ------------------------


@settings(max_examples=15, deadline=None)
@given(wavelength=st.floats(2.0, 20.0), amp_mm=st.floats(2.0, 20.0))
def test_straightedge_on_a_sine_gives_the_chord_geometry(wavelength, amp_mm):
    # the mid-chord deviation of A sin(kx) is A (1 - cos(k L / 2)) sin(kx): its peak is A (1 - cos(pi L / lambda))
    x = np.arange(0.0, 12 * wavelength, 0.005)
    prof = Profile(distance=x, elevation=amp_mm * 1e-3 * np.sin(2 * np.pi * x / wavelength))
    peak = amp_mm * (1 - np.cos(np.pi * 3.0 / wavelength))
    rep = straightedge_report(prof, length=3.0, threshold=max(0.6, 0.5 * peak))
    dev = rep.detail["deviation_left_mm"].to_numpy()
    assert np.max(np.abs(dev)) == pytest.approx(peak, rel=2e-3)
    # two defects (a bump and a dip) per wavelength along the centre stations
    n_wl = (x[-1] - x[0] - 3.0) / wavelength
    if 0.5 * peak >= 0.6:
        assert abs(len(rep.table) - 2 * n_wl) <= 2
        assert set(np.sign(rep.table.deviation_mm)) == {-1.0, 1.0}


def test_straightedge_in_us_units_is_the_same_road():
    prof = iso8608_profile(120.0, 0.05, "C", rng=np.random.default_rng(3), tracks=("left", "right"))
    si = straightedge_report(prof, length=3.048, threshold=3.175)
    us = straightedge_report(prof, units="us")  # 10 ft, 1/8 in
    assert np.allclose(us.detail["station_ft"] * 0.3048, si.detail["station_m"], rtol=1e-12)
    assert np.allclose(us.detail["deviation_right_in"] * 25.4, si.detail["deviation_right_mm"], rtol=1e-12)
    assert len(us.table) == len(si.table) > 0


# ---- Profile Index: a sine under the profilograph --------------------------------------------------------------


def _pi_sine(wavelength=5.0, amp=0.01, periods=40, dx=0.01):
    d = np.array(CALIFORNIA_WHEELS_FT) * 0.3048
    k = 2 * np.pi / wavelength
    gain = abs(1 - np.mean(np.exp(1j * k * d)))  # the frame's response to a sine (rigid frame, mean of the wheels)
    x = np.arange(0.0, 3.81 + 3.81 + periods * wavelength + 1e-9, dx)
    # the trace starts at the first recording-wheel station (12.5 ft = 3.81 m): start the sine there at 0
    return Profile(distance=x, elevation=amp * np.sin(k * (x - 3.81))), amp * gain


@pytest.mark.parametrize("band_mm", [0.0, 5.0])
def test_profile_index_of_a_sine_is_its_scallops(band_mm):
    # each wavelength of a trace of amplitude a has one scallop above and one below the band, each a - b/2 high:
    # PI = 2 (a - b/2) / lambda per length (CT 526's definition: sum of the scallop heights per length)
    prof, a = _pi_sine()
    rep = profile_index_report(prof, segment=100.0, blanking_band=band_mm)
    expected = 2 * (a - band_mm * 1e-3 / 2) / 5.0 * 1e6  # mm/km
    assert rep.table["pi_left_mm_per_km"].to_numpy() == pytest.approx([expected, expected], rel=0.02)
    # a band wider than the trace: nothing outside it
    small, a = _pi_sine(amp=0.002)
    wide = profile_index_report(small, segment=100.0, blanking_band=2.2 * a * 1e3)
    assert np.all(wide.table["pi_left_mm_per_km"] == 0)


def test_profile_index_in_us_units_is_the_same_road():
    prof = iso8608_profile(400.0, 0.05, "B", rng=np.random.default_rng(5))
    si = profile_index_report(prof, segment=160.9344, blanking_band=5.08)
    us = profile_index_report(prof, units="us")  # 0.1 mi, 0.2 in
    assert np.allclose(us.table["pi_left_in_per_mi"], si.table["pi_left_mm_per_km"] * 0.06336, rtol=1e-9)
    assert np.allclose(us.table["start_ft"] * 0.3048, si.table["start_m"], rtol=1e-12)
    # the bumps whose peak lies in a (complete) segment are counted in it
    inside = (si.detail["peak_m"] >= si.table["start_m"].iloc[0]) & (si.detail["peak_m"] < si.table["end_m"].iloc[-1])
    assert us.table["bumps_left"].sum() == si.table["bumps_left"].sum() == inside.sum() > 0


# ---- faulting: a step of h at each joint --------------------------------------------------------------------------


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), grade=st.floats(-0.05, 0.05))
def test_a_step_of_h_is_a_fault_of_h(seed, grade):
    rng = np.random.default_rng(seed)
    dx = 0.025
    joints = np.cumsum(rng.uniform(4.0, 6.0, 12)) + 1.0
    h = rng.uniform(1.5, 15.0, joints.size) * rng.choice([-1.0, 1.0], joints.size)  # mm, either sign
    x = np.arange(0.0, joints[-1] + 3.0, dx)
    # the slab after a joint lower by h: z drops by h there (approach minus leave = +h)
    z = grade * x - 1e-3 * (h[None, :] * (x[:, None] > joints[None, :])).sum(axis=1)
    for units, scale in (("si", 1.0), ("us", 25.4)):
        rep = faulting_report(Profile(distance=x, elevation=z), units=units)
        fault = rep.table["fault_mm" if units == "si" else "fault_in"].to_numpy() * scale
        assert fault == pytest.approx(h, abs=1e-9)
        found = rep.table["joint_m" if units == "si" else "joint_ft"].to_numpy() * (1.0 if units == "si" else 0.3048)
        assert np.all(np.abs(found - joints) <= dx)
        assert rep.notes == ()


def test_faulting_on_an_unjointed_road_warns():
    flat = Profile(distance=np.arange(0.0, 60.0, 0.05), elevation=0.01 * np.arange(1200) * 0.05)
    rep = faulting_report(flat)
    assert len(rep.table) == 0 and "no joint" in rep.notes[0]
    rough = iso8608_profile(300.0, 0.05, "C", rng=np.random.default_rng(1))
    assert any("without joints" in n for n in faulting_report(rough).notes)


# ---- Ride Number ------------------------------------------------------------------------------------------------


def test_ride_number_of_a_smooth_road_is_5_and_falls_with_roughness():
    x = np.arange(0.0, 300.0, 0.05)
    for z in (np.zeros_like(x), 0.02 * x + 1.0):  # flat, and a constant grade
        rep = ride_number_report(Profile(distance=x, elevation=z))
        assert rep.metadata["section_rn"] == pytest.approx(5.0, abs=1e-9)
        assert np.allclose(rep.table["rn"], 5.0, atol=1e-9)
    base = iso8608_profile(300.0, 0.05, "B", rng=np.random.default_rng(2))
    reps = [ride_number_report(Profile(distance=base.distance, elevation=s * base.elevation)) for s in (1, 2, 4)]
    pi = [r.table["pi_left_m_per_km"].to_numpy() for r in reps]
    assert np.allclose(pi[1], 2 * pi[0], rtol=1e-9) and np.allclose(pi[2], 4 * pi[0], rtol=1e-9)  # linear filter
    rn = [r.metadata["section_rn"] for r in reps]
    assert 5.0 > rn[0] > rn[1] > rn[2] > 0.0
    assert np.all(np.diff(np.column_stack([r.table["rn"] for r in reps]), axis=1) < 0)


def test_ride_number_segments_tile_the_section():
    prof = iso8608_profile(400.0, 0.05, "C", rng=np.random.default_rng(4), tracks=("left", "right"))
    length = prof.distance[-1] - prof.distance[0]
    rep = ride_number_report(prof, segment=length / 4, moving_average="off")
    lib = ride_number(prof, moving_average=False)
    assert rep.metadata["section_rn"] == lib.ride_number
    # equal segments tiling every filter step: the section PI^2 is the mean of the segments' PI^2
    for j, t in enumerate(("left", "right")):
        seg = rep.table[f"pi_{t}_m_per_km"].to_numpy() / 1000
        assert np.sqrt(np.mean(seg ** 2)) == pytest.approx(lib.profile_index[j], rel=1e-9)
    # the combined RN of a segment comes from the RMS of its tracks' PI (ASTM E1489)
    pi = rep.table[["pi_left_m_per_km", "pi_right_m_per_km"]].to_numpy() / 1000
    assert np.allclose(rep.table["rn"], 5 * np.exp(-160 * np.sqrt(np.mean(pi ** 2, axis=1))), rtol=1e-12)
    one = ride_number_report(prof, segment=length, moving_average="off")
    assert one.table["rn"].iloc[0] == pytest.approx(lib.ride_number, rel=1e-12)


def test_a_metre_profile_under_a_mm_label_is_warned():
    base = iso8608_profile(200.0, 0.05, "C", rng=np.random.default_rng(2))
    rep = ride_number_report(Profile(distance=base.distance, elevation=base.elevation / 1000))
    assert any("smoother than any road" in n for n in rep.notes)


# ---- refusals: one line each -------------------------------------------------------------------------------------

_FUNCS = (ride_number_report, straightedge_report, profile_index_report, faulting_report)


@pytest.mark.parametrize("fn", _FUNCS, ids=lambda f: f.__name__)
def test_gaps_are_refused_with_the_station(fn):
    x = np.arange(0.0, 400.0, 0.05)
    z = 1e-3 * np.sin(x)
    z[3000] = np.nan
    with pytest.raises(InputError, match=r"missing \(NaN\) elevation at station 150\.000 m.*cut the profile"):
        fn(Profile(distance=x, elevation=z))
    keep = (x < 150) | (x > 170)  # rows removed: a 20 m step
    with pytest.raises(InputError, match=r"1 gap\(s\) longer than 1 m.*from station 149\.950 m"):
        fn(Profile(distance=x[keep], elevation=np.sin(x[keep]) * 1e-3))


@pytest.mark.parametrize(("fn", "length", "match"), [
    (ride_number_report, 8.0, "shorter than the lead-in"),
    (straightedge_report, 2.5, "shorter than the 3 m straightedge"),
    (profile_index_report, 60.0, "shorter than one 100 m segment"),
    (faulting_report, 0.6, "shorter than two windows"),
], ids=lambda v: getattr(v, "__name__", None))
def test_a_profile_too_short_is_refused(fn, length, match):
    x = np.arange(0.0, length, 0.05)
    with pytest.raises(InputError, match=match):
        fn(Profile(distance=x, elevation=1e-3 * np.sin(x)))


@pytest.mark.parametrize(("fn", "kwargs", "match"), [
    (straightedge_report, dict(length=10.0), r"10 m is outside .* straightedge.*if you meant 10 ft, write 3\.048"),
    (straightedge_report, dict(threshold=0.125), r"0\.125 mm .*if you meant 0\.125 in, write 3\.175"),
    (straightedge_report, dict(units="us", length=3.0), r"3 ft = 0\.9144 m .*if you meant 3 m, write 9\.843"),
    (straightedge_report, dict(units="us", threshold=3.0), r"if you meant 3 mm, write 0\.1181"),
    (profile_index_report, dict(blanking_band=0.2), r"if you meant 0\.2 in, write 5\.08"),
    (profile_index_report, dict(segment=5.0), r"5 m is outside the plausible 10-10000 m of a segment"),
    (faulting_report, dict(units="us", min_fault=1.0), r"if you meant 1 mm, write 0\.03937"),
    (ride_number_report, dict(units="us", segment=2.0), r"segment"),
], ids=lambda v: getattr(v, "__name__", None) or str(v))
def test_a_value_in_the_other_unit_system_is_refused(fn, kwargs, match):
    prof = iso8608_profile(300.0, 0.05, "B", rng=np.random.default_rng(0))
    with pytest.raises(UnitsError, match=match):
        fn(prof, **kwargs)


def test_zero_blanking_band_is_accepted():
    prof, _ = _pi_sine(periods=22)
    assert profile_index_report(prof, blanking_band=0).metadata["blanking_band"] == 0.0
