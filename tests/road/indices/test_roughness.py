"""Localised roughness (continuous IRI) and waveband energies."""

import numpy as np
import pytest

from longprofile.errors import InputError
from longprofile.road import APL_BANDS, Profile, iri, iso8608_profile, localized_roughness, waveband_energy


@pytest.fixture(scope="module")
def bumpy():
    p = iso8608_profile(300.0, 0.1, "A", rng=5)
    x = p.distance
    z = p.elevation[:, 0] + 0.02 * np.exp(-0.5 * ((x - 180.0) / 0.8) ** 2)  # a 20 mm bump at 180 m
    return Profile(distance=x, elevation=z)


def test_continuous_iri_equals_iri_of_the_window(bumpy):
    loc = localized_roughness(bumpy, window=25.0, threshold=np.inf)  # the curve alone (100 m/km: in/mi? refused)
    for centre in (40.0, 180.0, 250.3):
        k = int(np.argmin(np.abs(loc.station - centre)))
        c = loc.station[k]
        seg = iri(bumpy, segment_length=25.0, start=c - 12.5)
        np.testing.assert_allclose(loc.continuous_iri[k, 0], seg.iri[0, 0], rtol=1e-9)
    assert loc.defects == ()


def test_defect_found_at_the_bump(bumpy):
    loc = localized_roughness(bumpy, window=25.0, threshold=3.0)
    assert len(loc.defects) == 1
    d = loc.defects[0]
    assert d.track == "left" and d.start < 180.0 < d.end and d.end - d.start < 30.0
    assert d.peak_iri > 3.0 and abs(d.peak_station - 180.0) < 12.5
    df = loc.to_frame()
    assert list(df.columns) == ["track", "start_m", "end_m", "length_m", "peak_station_m", "peak_iri_m_per_km"]
    assert np.all(loc.continuous_iri[(loc.station < 150) | (loc.station > 210), 0] < 3.0)


def test_two_tracks_add_mri_column():
    p = iso8608_profile(120.0, 0.1, "B", rng=1, tracks=("left", "right"))
    loc = localized_roughness(p, window=25.0)
    assert loc.tracks == ("left", "right", "MRI")
    np.testing.assert_allclose(loc.continuous_iri[:, 2], loc.continuous_iri[:, :2].mean(axis=1), rtol=1e-12)


@pytest.mark.parametrize("wavelength,band_index", [(1.4, 0), (5.0, 1), (20.0, 2)])
def test_waveband_energy_of_a_sinusoid(wavelength, band_index):
    dx, amp = 0.05, 3e-3
    x = np.arange(0.0, 800.0, dx)  # a whole number of every wavelength
    p = Profile(distance=x, elevation=amp * np.sin(2 * np.pi * x / wavelength))
    res = waveband_energy(p, segment_length=200.0)
    assert res.energy.shape == (3, 1, 3) and list(res.bands) == list(APL_BANDS)
    want = np.zeros(3)
    want[band_index] = 0.5 * (amp * 1000) ** 2  # mean square of a sine, mm^2
    np.testing.assert_allclose(res.energy[:, 0, :], np.tile(want, (3, 1)), atol=2e-3 * want.max())
    assert "left medium 2.8-11.3 m [mm2]" in res.to_frame().columns


def test_waveband_errors():
    p = iso8608_profile(100.0, 0.5, "A", rng=0)
    with pytest.raises(InputError, match="shorter than twice the spacing"):
        waveband_energy(p)
    with pytest.raises(InputError, match="shortest < longest"):
        waveband_energy(p, bands={"bad": (10.0, 5.0)})
    with pytest.raises(InputError, match="shorter than the window"):
        localized_roughness(iso8608_profile(20.0, 0.1, "A", rng=0), window=25.0, lead_in=5.0)


def test_analysis_and_report_on_irregular_stations(tmp_path):
    from longprofile.report import write_road_report
    from longprofile.road import analyse_roughness

    p = iso8608_profile(150.0, 0.1, "B", rng=3)
    keep = np.sort(np.random.default_rng(1).choice(p.n_samples, size=1200, replace=False))
    irregular = Profile(distance=p.distance[keep], elevation=p.elevation[keep], name="irregular")
    a = analyse_roughness(irregular, segment_length=50.0)
    assert a.psd is None and a.iso8608 is None and a.waveband is None
    assert a.iri.method == "per-step" and "irregular" in a.notes[0]
    files = write_road_report(a, tmp_path / "rep")
    page = files[0].read_text()
    assert "Stations are irregular" in page and "psd.png" not in [f.name for f in files]


@pytest.mark.parametrize("threshold", [60.0, 160.0, 170.0])
def test_a_threshold_in_inches_per_mile_is_named(threshold):
    """160 in/mi given as m/km flagged nothing, silently (session 36, a pavement engineer's probe)."""
    from longprofile.errors import UnitsError
    from longprofile.road import iso8608_profile, localized_roughness

    p = iso8608_profile(300.0, 0.05, "C", rng=1)
    with pytest.raises(UnitsError, match=rf"threshold {threshold:g} m/km is above any road's IRI.*"
                                         rf"{threshold / 63.36:.3g} m/km"):
        localized_roughness(p, threshold=threshold)
    assert localized_roughness(p, threshold=threshold / 63.36).threshold == pytest.approx(threshold / 63.36)
