"""The APL instrument model (paper 000, eq. 1, Table 1, §4.2-4.3)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from longprofile.errors import InputError, ModelError, UnitsError
from longprofile.road import Profile
from longprofile.road.apl._model import (
    TABLE1_CONFIGURATIONS,
    TrailerPoles,
    apl_filter,
    apl_model,
    apl_model_from_polynomials,
    apl_response,
    frequency_response,
    paper_identified_model,
    passband,
)


@pytest.mark.parametrize("speed,dx", sorted(TABLE1_CONFIGURATIONS))
def test_table1_configurations_have_unit_gain_band(speed, dx):
    m = apl_model(speed, dx)
    assert m.dt == pytest.approx(dx / speed)
    assert m.is_stable and m.order == 5
    lo, hi = passband(m, tolerance=0.1)
    # paper: "unitaire de 0.2 Hz a presque 30 Hz"; the issue: ~0.4 to ~20 Hz at 20 m/s, 5 cm
    assert 0.2 < lo < 0.45
    assert 18.0 < hi < 30.0
    # -3 dB band matches the paper's 0.2 .. ~30 Hz claim
    f = np.logspace(-1.5, np.log10(min(30.0, 0.5 / m.dt)), 400)
    mag = frequency_response(m, f).magnitude
    band3 = f[mag >= 1 / np.sqrt(2)]
    assert 0.2 < band3.min() < 0.3 and band3.max() > 25.0


def test_printed_gain_is_a_misprint_and_bilinear_gain_is_its_correction():
    printed = apl_model(gain_normalisation="as-printed")
    fixed = apl_model()
    p1 = fixed.poles[1]
    # the printed k is off by |1 - p1|^2 / |1 + p1|^2, giving k ~ 1e-7 and |H| ~ 4e-6 in the band
    ratio = abs(1 - p1) ** 2 / abs(1 + p1) ** 2
    assert printed.gain / fixed.gain == pytest.approx(ratio, rel=1e-12)
    assert printed.gain < 1e-6 and np.abs(printed.response_at(2.0)) < 1e-5
    # bilinear normalisation: each section has unit gain at its own asymptote
    assert abs(fixed.response_at(2.0)) == pytest.approx(1.0, abs=0.05)


def test_eq1_structure_and_pole_placement():
    m = apl_model(20.0, 0.05)
    assert np.allclose(np.sort(m.zeros.real), [-1, -1, 1, 1, 1])
    dt = 0.05 / 20.0
    p1 = 0.9976 * np.exp(2j * np.pi * 0.2185 * dt)
    assert np.any(np.isclose(m.poles, p1))
    assert np.any(np.isclose(m.poles, np.conj(p1)))
    tau = 0.4 * np.pi
    assert np.any(np.isclose(m.poles, (1 - dt / (2 * tau)) / (1 + dt / (2 * tau))))
    assert m.dc_gain == pytest.approx(0.0, abs=1e-12)


def test_overridable_trailer_and_unknown_configuration():
    with pytest.raises(InputError, match="no Table 1 calibration"):
        apl_model(15.0, 0.05)
    m = apl_model(15.0, 0.05, poles=TrailerPoles(0.997, 0.22, 0.6, 20.0))
    assert m.speed == 15.0 and m.dt == pytest.approx(0.05 / 15)
    with pytest.raises(InputError, match="modulus"):
        apl_model(15.0, 0.05, poles=TrailerPoles(1.2, 0.22, 0.6, 20.0))
    with pytest.raises(InputError, match="Nyquist"):
        apl_model(20.0, 0.05, poles=TrailerPoles(0.99, 0.22, 0.6, 500.0))


def test_frequency_response_against_scipy():
    m = apl_model(20.0, 0.15)
    f = np.logspace(0, np.log10(0.45 / m.dt), 50)
    fr = frequency_response(m, f)
    _, h = signal.freqz_zpk(m.zeros, m.poles, m.gain, worN=f, fs=1 / m.dt)
    assert np.allclose(fr.magnitude, np.abs(h), rtol=1e-9)
    # scipy's polynomial group delay is accurate away from the near-unit poles
    _, gd = signal.group_delay((m.numerator, m.denominator), w=f, fs=1 / m.dt)
    assert np.allclose(fr.group_delay, gd * m.dt, rtol=1e-5, atol=1e-9)
    # and ours equals -dphase/domega everywhere (central differences, incl. low frequency)
    f2 = np.array([0.1, 0.5, 3.0])
    eps = 1e-6
    ph = lambda ff: frequency_response(m, ff).phase  # noqa: E731
    num = -(ph(f2 + eps) - ph(f2 - eps)) / (2 * np.pi * 2 * eps)
    assert np.allclose(frequency_response(m, f2).group_delay, num, rtol=1e-5)
    assert np.allclose(fr.wavelength, 20.0 / f)


def test_sos_filter_matches_lfilter_and_delay():
    m = paper_identified_model("4.3-roots")
    x = np.random.default_rng(0).normal(size=400)
    y = apl_filter(m, x, initial="rest")
    assert y[0] == 0.0  # nk = 1: pure delay
    assert np.allclose(y, signal.lfilter(m.numerator, m.denominator, x), atol=1e-9)
    e = apl_model()
    assert np.allclose(apl_filter(e, x, initial="rest"), signal.lfilter(e.numerator, e.denominator, x), atol=1e-9)


def test_steady_start_ignores_the_absolute_level():
    m = apl_model()
    x = np.random.default_rng(1).normal(size=300)
    assert np.allclose(apl_filter(m, x + 5.0), apl_filter(m, x), atol=1e-12)


def test_section_43_roots_match_printed_421_coefficients():
    printed = paper_identified_model("4.2.1-crenels")
    roots = paper_identified_model("4.3-roots")
    # expanded §4.3 roots reproduce the printed B and A within the printing precision of the roots
    assert np.allclose(roots.numerator, printed.numerator, atol=2e-3)
    assert np.allclose(roots.denominator, printed.denominator, atol=2e-3)
    # well separated roots agree directly
    assert np.min(np.abs(printed.zeros - 0.2039)) < 5e-4
    for p in (0.4047 + 0.3978j, 0.4047 - 0.3978j):
        assert np.min(np.abs(printed.poles - p)) < 5e-4
    # three zeros near 1 (the triple differentiator) and a cluster of three poles near 1
    near = lambda r: r[np.abs(r - 1) < 0.05]  # noqa: E731
    assert near(printed.zeros).size == 3 and near(printed.poles).size == 3
    assert np.sum(near(printed.zeros)).real == pytest.approx(1.0012 + 2 * 0.9992, abs=1e-3)
    assert np.sum(near(printed.poles)).real == pytest.approx(0.9915 + 2 * 0.9921, abs=1e-3)


def test_identified_models_by_name_and_stability_flags():
    m = paper_identified_model("4.2.1-crenels")
    assert m.delay == 1 and m.dt == 7.5e-3
    step = apl_filter(m, np.ones(200), initial="rest")
    assert step.min() == pytest.approx(-0.5, abs=0.02)  # §4.2.2: "minimum a -0.5 environ"
    assert not paper_identified_model("4.2.2-sine-arcs").is_stable
    assert not paper_identified_model("4.2.4-test-track").is_stable
    assert paper_identified_model("4.2.3-white-noise").is_stable
    assert paper_identified_model("4.3-roots").is_stable
    with pytest.raises(ModelError, match="unstable"):
        apl_response(np.zeros(10), paper_identified_model("4.2.4-test-track"))
    with pytest.raises(InputError, match="unknown identified model"):
        paper_identified_model("nope")


def test_apl_response_profile_checks_spacing_and_nan():
    m = apl_model()
    p = Profile(np.arange(100) * 0.05, np.zeros(100))
    out = apl_response(p, m)
    assert isinstance(out, Profile) and out.elevation.shape == (100, 1)
    with pytest.raises(UnitsError, match="spacing"):
        apl_response(Profile(np.arange(100) * 0.1, np.zeros(100)), m)
    z = np.zeros(100)
    z[5] = np.nan
    with pytest.raises(InputError, match="missing"):
        apl_response(Profile(np.arange(100) * 0.05, z), m)


def test_model_from_polynomials_checks_units():
    with pytest.raises(UnitsError):
        apl_model_from_polynomials([0, 1.0], [1, -0.5], dt=0.01, speed=20.0, dx=0.05)
    # more zeros than poles is causal in z^-1 (refused as "not proper" until session 36): the response is B/A
    m = apl_model_from_polynomials([1.0, 1.0, 1.0], [1, -0.5], dt=0.01)
    zi = np.exp(-2j * np.pi * np.array([0.0, 7.0, 31.0]) * 0.01)
    np.testing.assert_allclose(m.response_at([0.0, 7.0, 31.0]), (1 + zi + zi ** 2) / (1 - 0.5 * zi), rtol=1e-9)


@settings(max_examples=20, deadline=None)
@given(st.floats(5.0, 40.0), st.floats(0.02, 0.25), st.floats(0.95, 0.999), st.floats(0.5, 0.9))
def test_any_speed_and_spacing_give_the_bilinear_section_gains(speed, dx, m1, m2):
    dt = dx / speed
    f2 = min(20.0, 0.3 / dt)
    m = apl_model(speed, dx, poles=TrailerPoles(m1, 0.22, m2, f2))
    assert m.is_stable and m.dt == pytest.approx(dt)
    assert frequency_response(m, [0.0]).magnitude[0] < 1e-12  # triple differentiator: blind to a level
    # k is the product of the three section normalisations: RC and pendulum at z = -1, damper at z = 1
    p1, p2 = m.poles[1], m.poles[3]
    rc = 1.0 / (1 + dt / (2 * 0.4 * np.pi))
    pend = abs(1 + p1) ** 2 / 4.0
    damp = abs(1 - p2) ** 2 / 4.0
    assert m.gain == pytest.approx(rc * pend * damp, rel=1e-12)
    # and each normalised section has unit gain at its own asymptote, so the product does too
    assert abs(m.response_at(0.5 / dt)) == pytest.approx(0.0, abs=1e-12)  # (1 + z^-1)^2: zero at Nyquist


def test_plot_frequency_response_returns_figure(tmp_path):
    from longprofile.report import plot_frequency_response

    fig = plot_frequency_response([apl_model(20, 0.05), apl_model(6, 0.05)])
    out = tmp_path / "fr.png"
    fig.savefig(out, dpi=50)
    assert out.stat().st_size > 1000


def test_public_namespace_resolves():
    import longprofile.road as road
    import longprofile.road.apl as apl

    for name in apl.__all__:
        assert getattr(apl, name) is not None
    for name in ("apl", "apl_model", "apl_response", "double_filter", "reconstruct_profile", "Reconstruction"):
        assert name in road.__all__


@settings(max_examples=20, deadline=None)
@given(taps=st.lists(st.floats(-2.0, 2.0).filter(lambda v: abs(v) > 1e-3), min_size=2, max_size=6),
       delay=st.integers(0, 2))
def test_an_fir_bench_model_is_accepted_and_responds_as_its_taps(taps, delay):
    """Orders ``0 nb nk`` (no poles: an FIR bench model) were refused as "not proper" (session 36, a probe); causal in
    z^-1, its response must be the taps' direct sum sum_k b_k e^{-j w (k + delay)} (the oracle)."""
    from longprofile.road.apl import apl_model_from_polynomials

    m = apl_model_from_polynomials([0.0] * delay + list(taps), [1.0], dt=0.01)
    f = np.linspace(0.0, 49.0, 37)
    w = 2 * np.pi * f * 0.01
    direct = sum(b * np.exp(-1j * w * (k + delay)) for k, b in enumerate(taps))
    np.testing.assert_allclose(m.response_at(f), direct, rtol=1e-7, atol=1e-9 * max(map(abs, taps)))


def test_identify_names_a_bad_speed_not_dt():
    from longprofile.road.apl import identify_trailer

    u = np.random.default_rng(0).standard_normal(400)
    with pytest.raises(InputError, match=r"speed \(m/s\) must be finite and > 0; got -20"):
        identify_trailer(u, u, speed=-20.0, dx=0.05)
