"""APL reconstruction of records of any length (issue 11): the long-record path gives the short path's profile."""

import numpy as np
import pytest

from longprofile.cli.app import main
from longprofile.road.apl import simulate_apl_recording
from longprofile.road.apl._deconvolution import (
    LONG_RECORD_SAMPLES,
    apl_deconvolution_model,
    detrend_profile,
    fit_noise_variances,
    increment_deconvolution_model,
    reconstruct_profile,
)
from longprofile.road.apl._model import apl_model, paper_identified_model
from longprofile.statespace import kalman_filter, rts_smoother

DX = 0.05


@pytest.fixture(scope="module")
def long_record():
    """10.5 km of class C road at 20 m/s, 5 cm: above LONG_RECORD_SAMPLES and past the exact start (~164k)."""
    rec = simulate_apl_recording("iso8608", apl_model(20.0, DX), length=10_500.0, road_class="C",
                                 noise_fraction=0.02, rng=5)
    assert rec.signal.size > LONG_RECORD_SAMPLES
    return rec


def _band_rms_error(a, b, truth):
    return np.sqrt(np.mean((a - b) ** 2)) / np.std(truth)


def test_increment_model_is_the_wiener_model():
    """Same likelihood of y; the running sum of smoothed increments is the Wiener model's smoothed elevation."""
    m = apl_model(20.0, DX)
    rec = simulate_apl_recording("iso8608", m, length=400.0, road_class="B", noise_fraction=0.02, rng=1)
    q, r = 1e-6, 2e-8
    wiener, inc = apl_deconvolution_model(m, q, r), increment_deconvolution_model(m, q, r)
    fw, fi = kalman_filter(wiener, rec.signal), kalman_filter(inc, rec.signal)
    assert fi.log_likelihood == pytest.approx(fw.log_likelihood, rel=1e-10)
    uw = rts_smoother(wiener, fw).mean[:, -1]
    ui = np.concatenate([[0.0], np.cumsum(rts_smoother(inc, fi).mean[1:, -1])])
    dw, di = detrend_profile(uw, DX), detrend_profile(ui, DX)
    assert _band_rms_error(di, dw, dw) < 1e-6
    # an instrument without a zero at 1 does not need (and refuses) the rewriting
    with pytest.raises(Exception, match="static gain"):
        increment_deconvolution_model(paper_identified_model("4.3-roots"), 10.0, 1.0, dx=0.15)


def test_long_path_gives_the_short_path_profile(long_record):
    """Issue 11: within 1e-6 of the band RMS, on a record where both paths run (fixed q, r and fitted ones)."""
    m = apl_model(20.0, DX)
    y = long_record.signal
    kw = dict(q=2.4e-6, r=7.8e-8)
    long_ = reconstruct_profile(y, m, **kw)  # default: > LONG_RECORD_SAMPLES -> long-record path
    short = reconstruct_profile(y, m, stationary=False, **kw)
    assert long_.raw_std is None and short.raw_std is not None
    e_l, e_s = long_.profile.elevation[:, 0], short.profile.elevation[:, 0]
    assert _band_rms_error(e_l, e_s, e_s) < 1e-6
    np.testing.assert_array_equal(long_.profile.std, short.profile.std)


def test_ml_fit_is_path_independent(long_record):
    m = apl_model(20.0, DX)
    y = long_record.signal[:LONG_RECORD_SAMPLES + 20_000]
    a = fit_noise_variances(y, m, stationary=True)
    b = fit_noise_variances(y, m, stationary=False)
    assert a.log_likelihood == pytest.approx(b.log_likelihood, rel=1e-10)
    assert a.q == pytest.approx(b.q, rel=1e-5) and a.r == pytest.approx(b.r, rel=1e-5)


@pytest.mark.parametrize("method", ["filter", "fixed-lag"])
def test_every_method_runs_on_a_long_record(long_record, method):
    m = apl_model(20.0, DX)
    rec = reconstruct_profile(long_record.signal, m, method=method, q=2.4e-6, r=7.8e-8)
    assert np.all(np.isfinite(rec.profile.elevation))
    if method == "filter":  # the exact causal filter in chunks, with its growing per-sample std
        assert rec.raw_std is not None and rec.raw_std[-1] > rec.raw_std[1000]


def test_readme_main_path_on_a_10_km_record(tmp_path, capsys):
    """`road simulate --length 10000` then the README's `road reconstruct` with its defaults: exit 0."""
    rec, prof = tmp_path / "rec.csv", tmp_path / "profile.csv"
    assert main(["road", "simulate", "--road-class", "C", "--length", "10000", "-o", str(rec)]) == 0
    assert main(["road", "reconstruct", str(rec), "--speed", "20", "--dx", "0.05", "--method", "smoother",
                 "-o", str(prof)]) == 0
    import pandas as pd

    out = pd.read_csv(prof, comment="#")
    assert len(out) == 200_001 and np.isfinite(out["elevation_m"]).all()


def test_gaps_in_a_long_record_are_bridged_as_by_the_exact_smoother(long_record):
    """Finding 5: a record of more than LONG_RECORD_SAMPLES with dropouts (in the exact start, after the switch to
    the constant gain, a 20 m one) reconstructs by default on the long-record path and gives the exact smoother's
    profile (measured: max |difference| <= 6.4e-9 m, 4.7e-7 of the RMS, docs/road-apl.md) and the same std."""
    m = apl_model(20.0, DX)
    y = long_record.signal.copy()
    for a, length in [(30_000, 20), (180_000, 40), (200_000, 400)]:
        y[a:a + length] = np.nan
    kw = dict(q=2.4e-6, r=7.8e-8)
    long_ = reconstruct_profile(y, m, **kw)  # default: > LONG_RECORD_SAMPLES -> long-record path
    exact = reconstruct_profile(y, m, stationary=False, **kw)
    assert long_.raw_std is None and exact.raw_std is not None
    e_l, e_s = long_.profile.elevation[:, 0], exact.profile.elevation[:, 0]
    assert np.abs(e_l - e_s).max() < 1e-6 * np.std(e_s)
    np.testing.assert_array_equal(long_.profile.std, exact.profile.std)
    std = long_.profile.std[:, 0]
    assert std[200_200] > 3 * std[100_000]  # the std grows inside the 20 m gap


def test_cli_reconstructs_a_long_record_with_a_gap(tmp_path, monkeypatch, capsys):
    """`road reconstruct` on a record above the long-record threshold (lowered here to keep the test short) with a
    dropout: exit 0 (was 'error: ... needs it complete'), std_m finite and larger in the gap."""
    import pandas as pd

    from longprofile.road.apl import _deconvolution

    monkeypatch.setattr(_deconvolution, "LONG_RECORD_SAMPLES", 20_000)
    rec, prof = tmp_path / "rec.parquet", tmp_path / "profile.parquet"
    assert main(["road", "simulate", "--road-class", "C", "--length", "1500", "-o", str(rec)]) == 0
    table = pd.read_parquet(rec)
    table.loc[15_000:15_039, "apl_m"] = np.nan
    table.to_parquet(rec)
    capsys.readouterr()
    assert main(["road", "reconstruct", str(rec), "-o", str(prof)]) == 0
    note = " ".join(capsys.readouterr().err.split())
    assert "40 missing (NaN) sample(s)" in note and "std_m includes the larger uncertainty" in note  # no raw_std_m
    out = pd.read_parquet(prof)
    assert np.isfinite(out["elevation_m"]).all() and np.isfinite(out["std_m"]).all()
    assert out["std_m"][15_020] > 2 * out["std_m"][5_000]
    # the fixed-lag's long-record path still needs a complete record: one line that says what to do
    assert main(["road", "reconstruct", str(rec), "--method", "fixed-lag", "-o", str(tmp_path / "fl.parquet")]) == 2
    assert "use the smoother" in " ".join(capsys.readouterr().err.split())
