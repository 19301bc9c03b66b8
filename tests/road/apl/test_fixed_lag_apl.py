"""Real-time APL reconstruction by the fixed-lag smoother (``reconstruct_profile(method="fixed-lag")``)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import signal
from typer.testing import CliRunner

from longprofile.cli.app import app, main
from longprofile.errors import InputError
from longprofile.road import iso8608_profile
from longprofile.road.apl import apl_model, apl_response, default_fixed_lag, reconstruct_profile

DX, SPEED = 0.05, 20.0


def _band_error_pct(estimate, truth, dx=DX, band=(1.0, 50.0), edge=50.0):
    """Error RMS in a sharp 1-50 m waveband, % of the true band RMS (quadratic removed, ends excluded)."""
    def band_pass(x):
        s = np.linspace(-1, 1, x.size)
        V = np.vander(s, 3)
        x = (x - V @ np.linalg.lstsq(V, x, rcond=None)[0]) * signal.windows.tukey(x.size, 2 * edge / (x.size * dx))
        X = np.fft.rfft(x)
        f = np.fft.rfftfreq(x.size, dx)
        X[(f < 1 / band[1]) | (f > 1 / band[0])] = 0
        return np.fft.irfft(X, x.size)[int(edge / dx):-int(edge / dx)]
    return 100 * np.sqrt(np.mean(band_pass(estimate - truth) ** 2) / np.mean(band_pass(truth) ** 2))


@pytest.fixture(scope="module")
def class_b_road():
    rng = np.random.default_rng(11)
    truth = iso8608_profile(400.0, DX, "B", rng=rng).elevation[:, 0]
    truth = truth - truth[0]
    instrument = apl_model(SPEED, DX)
    y0 = apl_response(truth, instrument)
    return truth, y0 + rng.normal(0, 0.02 * y0.std(), y0.size), instrument


def test_default_lag_is_four_pendulum_time_constants_of_table_1():
    # Table 1 (paper 000), 20 m/s, 5 cm: |p1| = 0.9976 -> tau = -dt / ln|p1| with dt = 0.05 / 20
    tau = -(DX / SPEED) / np.log(0.9976)
    assert default_fixed_lag(apl_model(SPEED, DX)) == pytest.approx(4 * tau * SPEED, rel=1e-9)
    # 6 m/s, 5 cm: |p1| = 0.9918, dt = 0.05 / 6
    tau6 = -(DX / 6.0) / np.log(0.9918)
    assert default_fixed_lag(apl_model(6.0, DX)) == pytest.approx(4 * tau6 * 6.0, rel=1e-9)


def test_band_error_far_below_the_causal_filter(class_b_road):
    truth, y, instrument = class_b_road
    fixed = reconstruct_profile(y, instrument, method="fixed-lag", highpass_wavelength=None)
    causal = reconstruct_profile(y, instrument, method="filter", highpass_wavelength=None)
    err_fixed = _band_error_pct(fixed.raw_elevation, truth)
    err_causal = _band_error_pct(causal.raw_elevation, truth)
    assert err_causal > 50.0  # the paper's filter with the Wiener model (docs/road-apl.md: ~124 %)
    assert err_fixed < 8.0
    assert err_fixed < err_causal / 10
    assert fixed.method == "fixed-lag" and fixed.input_model == "ar1" and fixed.correlation_length == 2.0
    assert fixed.lag_m == pytest.approx(round(default_fixed_lag(instrument) / DX) * DX)
    assert fixed.raw_std.shape == y.shape and np.all(fixed.raw_std[1:] > 0)
    assert fixed.profile.std is None  # highpass_wavelength=None: no detrending, no std of a detrended profile
    # a shorter lag is worse, a longer one better (error-vs-lag curve of docs/road-apl.md)
    short = reconstruct_profile(y, instrument, method="fixed-lag", lag_m=5.0, q=fixed.q, r=fixed.r,
                                highpass_wavelength=None)
    assert _band_error_pct(short.raw_elevation, truth) > err_fixed


@pytest.mark.parametrize("stationary", [False, True], ids=["exact", "steady-state"])
def test_latency_respected(class_b_road, stationary):
    _truth, y, instrument = class_b_road
    kw = dict(method="fixed-lag", lag_m=10.0, q=6e-7, r=2e-8, stationary=stationary, highpass_wavelength=None)
    a = reconstruct_profile(y, instrument, **kw)
    t = 3000
    lag = int(round(10.0 / DX))
    changed = y.copy()
    changed[t + lag + 1:] += 0.01 * np.sin(np.arange(changed.size - t - lag - 1))
    b = reconstruct_profile(changed, instrument, **kw)
    np.testing.assert_allclose(a.raw_elevation[:t + 1], b.raw_elevation[:t + 1], rtol=0, atol=1e-12)
    assert np.abs(a.raw_elevation[t + 1:] - b.raw_elevation[t + 1:]).max() > 1e-5
    assert a.lag_m == pytest.approx(10.0)


def test_errors(class_b_road):
    _truth, y, instrument = class_b_road
    with pytest.raises(InputError, match="lag_m applies to method='fixed-lag' only"):
        reconstruct_profile(y, instrument, method="smoother", lag_m=20.0)
    with pytest.raises(InputError, match="lag_m must be"):
        reconstruct_profile(y, instrument, method="fixed-lag", lag_m=-1.0, q=1e-6, r=1e-8)


def test_cli_fixed_lag(tmp_path, capsys):
    rec = tmp_path / "rec.csv"
    runner = CliRunner()
    r = runner.invoke(app, ["road", "simulate", "-o", str(rec), "--length", "200", "--seed", "2"])
    assert r.exit_code == 0, r.output
    out = tmp_path / "p.csv"
    r = runner.invoke(app, ["road", "reconstruct", str(rec), "--method", "fixed-lag", "--lag", "20", "-o", str(out),
                            "--q", "2e-6", "--r", "1e-8", "--plot", str(tmp_path / "p.png")])
    assert r.exit_code == 0, r.output
    assert "latency 20 m = 1.00 s" in " ".join(r.output.split())
    prof = pd.read_csv(out, comment="#")
    assert list(prof.columns) == ["distance_m", "elevation_m", "std_m", "raw_m", "raw_std_m"]
    assert np.isfinite(prof["raw_m"]).all() and (tmp_path / "p.png").stat().st_size > 1000
    assert main(["road", "reconstruct", str(rec), "--method", "smoother", "--lag", "20", "-o", str(out),
                 "--overwrite"]) == 2
    assert "lag_m applies" in capsys.readouterr().err.replace("\n", " ")


def test_the_detrended_fixed_lag_std_matches_its_error_on_the_models_own_road():
    """Oracle: a road drawn from the model itself (AR(1), white noise, known q and r): the empirical std of the
    detrended error against the printed std. The smoother's closed form matches to 1 %; the fixed-lag one, from the
    impulse response of its steady-state filter, is ~4 % conservative (docs/road-apl.md)."""
    from longprofile.road.apl import detrend_profile

    instrument = apl_model(20.0, DX)
    rng = np.random.default_rng(11)
    q, r, n = 2e-6, 5e-8, 60_000
    phi = np.exp(-DX / 2.0)
    u = signal.lfilter([1.0], [1.0, -phi], rng.normal(0.0, np.sqrt(q), n))  # u_k = phi u_{k-1} + e_k, u_-1 = 0
    y = apl_response(u, instrument) + rng.normal(0.0, np.sqrt(r), n)
    truth = detrend_profile(u, DX)
    keep = slice(4000, n - 4000)
    for method, kw, band in (("fixed-lag", {}, (0.90, 1.0)),
                             ("smoother", {"input_model": "ar1", "correlation_length": 2.0}, (0.97, 1.03))):
        rec = reconstruct_profile(y, instrument, method=method, q=q, r=r, **kw)
        std = np.asarray(rec.profile.std).reshape(-1)
        assert np.all(std == std[0]) and std[0] > 0
        ratio = float(np.std((rec.profile.elevation.reshape(-1) - truth)[keep]) / std[0])
        assert band[0] <= ratio <= band[1], (method, ratio)


def test_the_fixed_lag_warns_where_its_std_was_measured_too_narrow():
    # docs/road-apl.md "The fixed-lag at 6 m/s": coverage 34 % at 6 m/s with the default lag (no warning would be a
    # silent wrong band), 97 % at 20 m/s with the default, 64-71 % at 20 m/s with a 10-24 m lag
    from longprofile.road.apl import apl_model, default_fixed_lag
    from longprofile.road.apl._deconvolution import fixed_lag_calibration_warning

    slow, fast = apl_model(6.0, 0.05), apl_model(20.0, 0.05)
    assert "13 % of its peak gain" in fixed_lag_calibration_warning(slow, default_fixed_lag(slow), 100.0)
    assert fixed_lag_calibration_warning(slow, 120.0, 100.0) is None
    assert fixed_lag_calibration_warning(fast, default_fixed_lag(fast), 100.0) is None
    assert "under 50 m" in fixed_lag_calibration_warning(fast, 24.0, 100.0)
    assert fixed_lag_calibration_warning(fast, 24.0, None) is None
    rng = np.random.default_rng(0)
    y = apl_response(np.cumsum(rng.normal(0, 1e-3, 6000)), slow) + rng.normal(0, 1e-5, 6000)
    short = reconstruct_profile(y, slow, method="fixed-lag", q=1e-6, r=1e-9, lag_m=default_fixed_lag(slow))
    assert len(short.warnings) == 1 and "6 m/s" in short.warnings[0]
    # the default lag is the calibrated one there: 120 m at 6 m/s (4 time constants are 24 m), no warning
    default = reconstruct_profile(y, slow, method="fixed-lag", q=1e-6, r=1e-9)
    assert default.lag_m == pytest.approx(120.0) and default.warnings == ()
    fast_default = reconstruct_profile(apl_response(np.cumsum(rng.normal(0, 1e-3, 6000)), fast), fast,
                                       method="fixed-lag", q=1e-6, r=1e-9)
    assert fast_default.lag_m == pytest.approx(round(default_fixed_lag(fast) / 0.05) * 0.05)  # unchanged at 20 m/s
    assert reconstruct_profile(y, slow, method="smoother", q=1e-6, r=1e-9).warnings == ()
