"""Kalman deconvolution of the APL signal (paper 000, §5) and the smoother beyond the paper."""

import numpy as np
import pytest
from scipy import signal

from longprofile.errors import InputError, NotDetectableError
from longprofile.road import iso8608_profile
from longprofile.road.apl._deconvolution import (
    apl_deconvolution_model,
    detrend_profile,
    fit_noise_variances,
    increment_deconvolution_model,
    instrument_state_space,
    is_detectable,
    reconstruct_profile,
    smoother_error_std,
)
from longprofile.road.apl._model import apl_filter, apl_model, apl_response, paper_identified_model
from longprofile.statespace import steady_state_gain

DX = 0.05


def _band(x, lo=1.0, hi=50.0, dx=DX):
    """Sharp FFT band 1/hi..1/lo cycles/m after removing a quadratic (what the APL cannot see)."""
    s = np.linspace(-1, 1, x.size)
    V = np.vander(s, 3)
    x = x - V @ np.linalg.lstsq(V, x, rcond=None)[0]
    X = np.fft.rfft(x)
    n = np.fft.rfftfreq(x.size, dx)
    X[(n < 1 / hi) | (n > 1 / lo)] = 0
    return np.fft.irfft(X, x.size)


@pytest.fixture(scope="module")
def road():
    m = apl_model(20.0, DX)
    p = iso8608_profile(300.0, DX, "C", rng=11)
    u = p.elevation[:, 0]
    y0 = apl_response(u, m)
    sigma = 0.02 * y0.std()
    y = y0 + np.random.default_rng(5).normal(0, sigma, y0.size)
    q = 256e-6 * 2 * np.pi ** 2 * 0.1 ** 2 * DX  # ISO 8608 n^-2 spectrum == Wiener increments of this variance
    return m, u - u[0], y, q, sigma ** 2


@pytest.mark.parametrize("make", [lambda: apl_model(20, 0.05), lambda: apl_model(6, 0.05),
                                  lambda: paper_identified_model("4.3-roots"),
                                  lambda: paper_identified_model("4.2.3-white-noise")])
def test_realisation_is_minimal_and_matches_scipy_dlsim(make):
    m = make()
    A, B, C, D = instrument_state_space(m)
    assert A.shape == (m.order + m.delay, m.order + m.delay)
    x = np.random.default_rng(0).normal(size=300)
    _, y, _ = signal.dlsim((A, B, C, D, m.dt), x)
    assert np.allclose(y[:, 0], apl_filter(m, x, initial="rest"), atol=1e-10)
    assert np.allclose(np.sort_complex(np.linalg.eigvals(A)[np.abs(np.linalg.eigvals(A)) > 0]),
                       np.sort_complex(m.poles), atol=1e-7)


def test_detectability_section_5_2():
    m = apl_model()
    assert not is_detectable(apl_deconvolution_model(m, 1e-6, 1e-8))  # Wiener integrator cancels a zero at 1
    assert is_detectable(apl_deconvolution_model(m, 1e-6, 1e-8, input_model="ar1", correlation_length=500.0))
    # option 2: identified zeros slightly off 1
    assert is_detectable(apl_deconvolution_model(paper_identified_model("4.3-roots"), 10.0, 1.0, dx=0.15))
    # no stationary filter for the Wiener model as it is, but its detectable rewriting has one (long records)
    with pytest.raises(NotDetectableError):
        steady_state_gain(apl_deconvolution_model(m, 1e-6, 1e-8))
    assert is_detectable(increment_deconvolution_model(m, 1e-6, 1e-8))
    steady_state_gain(increment_deconvolution_model(m, 1e-6, 1e-8))


def test_model_structure_eqs_9_12():
    m = apl_model()
    ss = apl_deconvolution_model(m, 2e-6, 1e-8)
    n = m.order
    F, Q = ss.transition, ss.process_cov
    assert F[n, n] == 1.0 and np.all(F[n, :n] == 0)  # Wiener: u[k+1] = u[k] + v
    assert Q[n, n] == 2e-6 and np.count_nonzero(Q) == 1
    assert ss.obs_cov[0, 0] == 1e-8
    assert ss.initial_cov[n, n] == 0.0  # elevations relative to the first station


def test_smoother_recovers_the_roughness_band(road):
    m, u, y, q, r = road
    rec = reconstruct_profile(y, m, q=q, r=r, method="smoother", stationary=False)
    tb = _band(u)
    inner = slice(1000, -1000)
    err = _band(rec.raw_elevation) - tb
    rel = np.std(err[inner]) / np.std(tb[inner])
    raw_rel = np.std((_band(y) - tb)[inner]) / np.std(tb[inner])
    assert rel < 0.03
    assert raw_rel > 0.4  # phase distortion of the raw signal
    predicted = smoother_error_std(m, q, r, band=(1.0, 50.0))
    assert 0.5 < np.std(err[inner]) / predicted < 2.0
    assert rec.profile.std is not None and rec.raw_std.shape == y.shape
    dbl = reconstruct_profile(y, m, method="double")
    assert dbl.profile.std is None and dbl.q is None


def test_stationary_smoother_agrees_with_time_varying(road):
    m, u, y, q, r = road
    kw = dict(q=q, r=r, input_model="ar1", correlation_length=500.0)
    a = reconstruct_profile(y, m, stationary=True, **kw).raw_elevation
    b = reconstruct_profile(y, m, stationary=False, **kw).raw_elevation
    inner = slice(1000, -1000)
    assert np.std((_band(a) - _band(b))[inner]) < 0.01 * np.std(_band(u)[inner])


def test_ml_recovers_q_and_r_on_a_wiener_road():
    m = apl_model()
    rng = np.random.default_rng(3)
    q, r = 1e-6, 4e-8
    u = np.cumsum(rng.normal(0, np.sqrt(q), 6000))
    y = apl_response(u, m) + rng.normal(0, np.sqrt(r), u.size)
    fit = fit_noise_variances(y, m)
    assert fit.converged
    assert abs(np.log10(fit.q / fit.r) - np.log10(q / r)) < 4 * fit.ratio_std_log10 + 0.02
    assert fit.r == pytest.approx(r, rel=0.1)


def test_gaps_are_bridged_with_larger_uncertainty(road):
    m, u, y, q, r = road
    yg = y.copy()
    yg[3000:3040] = np.nan
    rec = reconstruct_profile(yg, m, q=q, r=r, stationary=False)
    assert np.all(np.isfinite(rec.raw_elevation))
    assert rec.raw_std[3020] > rec.raw_std[2900]
    with pytest.raises(InputError, match="missing"):
        reconstruct_profile(yg, m, method="double")
    # the long-record path bridges them too (finding 5, session 39: it refused them), with the exact path's profile
    kw = dict(q=q, r=r, input_model="ar1", correlation_length=500.0)
    lr = reconstruct_profile(yg, m, stationary=True, **kw).profile.elevation
    ex = reconstruct_profile(yg, m, stationary=False, **kw).profile.elevation
    assert np.abs(lr - ex).max() < 1e-6 * np.std(ex)
    with pytest.raises(InputError, match="use the smoother"):  # the fixed-lag's long-record path does not
        reconstruct_profile(yg, m, method="fixed-lag", q=q, r=r, stationary=True)


def test_input_errors(road):
    m, u, y, q, r = road
    with pytest.raises(InputError, match="method"):
        reconstruct_profile(y, m, method="magic")
    with pytest.raises(InputError, match="both q and r"):
        reconstruct_profile(y, m, q=q)
    with pytest.raises(InputError, match="need at least"):
        reconstruct_profile(y[:100], m, q=q, r=r)
    with pytest.raises(InputError, match="correlation_length"):
        apl_deconvolution_model(m, q, r, input_model="ar1")
    # optimum outside the search interval: flagged, never returned as converged
    assert not fit_noise_variances(y, m, bounds_log10_ratio=(-8.0, -7.0)).converged


def test_detrend_removes_quadratics_exactly():
    s = np.arange(4000) * DX
    z = 0.3 + 0.01 * s - 1e-4 * s ** 2
    assert np.max(np.abs(detrend_profile(z, DX, highpass_wavelength=None))) < 1e-10
    w = 0.01 * np.sin(2 * np.pi * s / 10.0)
    out = detrend_profile(z + w, DX)
    assert np.max(np.abs(out - w)[800:-800]) < 1e-3 * 0.01 * 10


@pytest.mark.parametrize("n_differentiators,min_corr", [(1, 0.99), (2, 0.5)])
def test_causal_filter_tracks_when_the_instrument_has_few_differentiators(n_differentiators, min_corr):
    # the "filter" path is correct: with one zero at 1 (cancelled by the Wiener integrator) the causal
    # estimate tracks crenels; the triple zero of the APL is what breaks causal deconvolution (docs/road-apl.md)
    from longprofile.road.apl import APLModel

    n = 4000
    k = np.arange(n)
    u = np.where(((k + 250) // 500) % 2 == 1, 1.0, 0.0)
    m = APLModel(zeros=np.ones(n_differentiators), poles=np.full(n_differentiators, 0.99), gain=1.0, delay=0,
                 dt=0.0025, dx=DX)
    y = apl_filter(m, u, initial="rest") + np.random.default_rng(0).normal(0, 1e-3, n)
    rec = reconstruct_profile(y, m, method="filter", q=1e-3, r=1e-6, highpass_wavelength=None, stationary=False)
    s = np.linspace(-1, 1, n)
    V = np.vander(s, 3)
    det = lambda x: x - V @ np.linalg.lstsq(V, x, rcond=None)[0]  # noqa: E731
    assert np.corrcoef(det(rec.raw_elevation), det(u))[0, 1] > min_corr
