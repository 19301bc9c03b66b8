"""ISO 8608: synthesis has the class PSD exactly (scipy periodogram), Welch + fit recovers the class."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import periodogram, welch

from longprofile.errors import InputError
from longprofile.road import (
    ISO8608_CLASSES,
    Profile,
    fit_iso8608,
    iso8608_class,
    iso8608_gd,
    iso8608_profile,
    profile_psd,
)


def test_class_table_is_iso8608_table1():
    # ISO 8608 table 1, Gd(n0) in 1e-6 m^3: geometric means 16, 64, ..., 262144; each class a factor 4 wide
    means = [ISO8608_CLASSES[c][1] * 1e6 for c in "ABCDEFGH"]
    np.testing.assert_allclose(means, 16 * 4.0 ** np.arange(8))
    for c in "BCDEFG":
        lo, mid, hi = ISO8608_CLASSES[c]
        np.testing.assert_allclose([lo * 2, hi / 2], [mid, mid])
    assert [iso8608_class(16e-6 * 4.0 ** k) for k in range(8)] == list("ABCDEFGH")
    assert iso8608_class(32e-6) == "B" and iso8608_class(31.9e-6) == "A" and iso8608_class(1.0) == "H"


@pytest.mark.parametrize("road_class", ["A", "D", "H"])
def test_synthesis_has_the_exact_psd_at_its_harmonics(road_class):
    dx, length = 0.1, 999.9
    p = iso8608_profile(length, dx, road_class, rng=4)
    n = p.n_samples
    f, pxx = periodogram(p.elevation[:, 0], fs=1 / dx, window="boxcar", detrend=False, scaling="density")
    band = (f >= 0.011) & (f <= 2.83) & (f > 0) & (f < 0.5 / dx)
    np.testing.assert_allclose(pxx[band], iso8608_gd(f[band], road_class), rtol=1e-9)
    assert np.all(pxx[~band] < 1e-20 * pxx[band].max())
    np.testing.assert_allclose(p.elevation.var(), np.sum(iso8608_gd(f[band], road_class)) / (n * dx), rtol=1e-9)


@settings(max_examples=8, deadline=None)
@given(road_class=st.sampled_from(list("ABCDEFGH")), seed=st.integers(0, 2**31))
def test_welch_fit_recovers_class_and_waviness(road_class, seed):
    p = iso8608_profile(2000.0, 0.1, road_class, rng=seed)
    psd = profile_psd(p)
    fit = fit_iso8608(psd.wavenumber, psd.psd[:, 0])
    assert fit.road_class == road_class and fit.road_class_free == road_class
    np.testing.assert_allclose(fit.gd_n0, ISO8608_CLASSES[road_class][1], rtol=0.25)
    assert abs(fit.waviness - 2.0) < 0.15


@settings(max_examples=40, deadline=None)
@given(n=st.integers(16, 3000), frac=st.floats(0.01, 1.0), detrend=st.sampled_from(["linear", "constant"]),
       window=st.sampled_from(["hann", "hamming"]), tracks=st.integers(1, 3), seed=st.integers(0, 2**31))
def test_welch_equals_scipy_signal_welch(n, frac, detrend, window, tracks, seed):
    # the external oracle: scipy.signal.welch with the same segments, window, detrending and density scaling
    dx = 0.05
    rng = np.random.default_rng(seed)
    z = np.cumsum(rng.normal(size=(n, tracks)), axis=0) * 1e-3 + rng.normal(size=tracks) * 0.1
    p = Profile(distance=np.arange(n) * dx, elevation=z, tracks=tuple(f"t{k}" for k in range(tracks)))
    nper = max(8, int(frac * n))
    psd = profile_psd(p, segment_length=nper * dx, detrend=detrend, window=window)
    f, pxx = welch(z, fs=1 / dx, window=window, nperseg=nper, noverlap=nper // 2, detrend=detrend,
                   scaling="density", axis=0)
    np.testing.assert_allclose(psd.wavenumber, f, rtol=1e-12)
    np.testing.assert_allclose(psd.psd, pxx, rtol=1e-9, atol=1e-12 * pxx.max())
    assert psd.psd.shape == (f.size, tracks)


def test_welch_refuses_an_unknown_detrending():
    p = iso8608_profile(200.0, 0.1, "C", rng=0)
    with pytest.raises(InputError, match="detrend must be"):
        profile_psd(p, detrend="quadratic")


def test_fit_recovers_other_waviness():
    p = iso8608_profile(4000.0, 0.1, 3e-4, waviness=2.5, rng=1)
    psd = profile_psd(p)
    fit = fit_iso8608(psd.wavenumber, psd.psd[:, 0])
    assert abs(fit.waviness - 2.5) < 0.15
    np.testing.assert_allclose(fit.gd_n0_free, 3e-4, rtol=0.25)


def test_psd_integrates_to_variance():
    p = iso8608_profile(1000.0, 0.05, "C", rng=2, band=(0.05, 2.83))
    psd = profile_psd(p, detrend="constant")
    df = psd.wavenumber[1] - psd.wavenumber[0]
    np.testing.assert_allclose(psd.psd[:, 0].sum() * df, p.elevation.var(), rtol=0.1)


def test_seed_reproducible_and_tracks_independent():
    a = iso8608_profile(100.0, 0.25, "C", rng=11, tracks=("left", "right"))
    b = iso8608_profile(100.0, 0.25, "C", rng=11, tracks=("left", "right"))
    np.testing.assert_array_equal(a.elevation, b.elevation)
    assert a.tracks == ("left", "right") and a.n_samples == 401
    assert abs(np.corrcoef(a.elevation.T)[0, 1]) < 0.9


def test_errors():
    with pytest.raises(InputError, match="road_class must be one of"):
        iso8608_profile(100.0, 0.1, "Z")
    with pytest.raises(InputError, match="no spatial frequency"):
        iso8608_profile(10.0, 0.1, "A", band=(0.001, 0.05))
    x = np.sort(np.random.default_rng(0).uniform(0, 100, 500))
    with pytest.raises(InputError, match="constant station spacing"):
        profile_psd(Profile(distance=x, elevation=np.zeros_like(x)))
    with pytest.raises(InputError, match="at least 3 positive PSD ordinates"):
        fit_iso8608([0.0, 5.0, 6.0], [1.0, 1.0, 1.0])
