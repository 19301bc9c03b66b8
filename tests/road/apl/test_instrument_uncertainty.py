"""The declared instrument uncertainty in the printed std of the APL reconstruction (issue 13, paper 000)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from longprofile.cli.app import app, main
from longprofile.errors import InputError
from longprofile.road import iso8608_profile
from longprofile.road.apl import (
    TABLE1_CONFIGURATIONS,
    APLModel,
    InstrumentUncertainty,
    TrailerPoles,
    apl_deconvolution_model,
    apl_model,
    apl_response,
    detrend_profile,
    instrument_parameters,
    perturbed_instrument,
    reconstruct_profile,
    smoother_error_std,
)
from longprofile.statespace import kalman_filter, rts_smoother

DX, SPEED = 0.05, 20.0
Q, R = 2e-6, 1e-9
NOMINAL = apl_model(SPEED, DX)
POLES = TABLE1_CONFIGURATIONS[(SPEED, DX)]
SLOW = settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@pytest.fixture(scope="module")
def record():
    """A 300 m class C road recorded by a trailer 10 % off in its pendulum frequency, 2 % noise."""
    rng = np.random.default_rng(5)
    truth = iso8608_profile(300.0, DX, "C", rng=rng).elevation[:, 0]
    other = apl_model(SPEED, DX, poles=TrailerPoles(POLES.pendulum_modulus, 1.1 * POLES.pendulum_frequency,
                                                    POLES.damper_modulus, POLES.damper_frequency))
    y0 = apl_response(truth, other)
    return y0 + rng.normal(0.0, 0.02 * y0.std(), y0.size)


def _scaled_eq1(parameter: int, s: float) -> APLModel:
    """Oracle of a perturbed eq. (1) model: apl_model itself with one Table 1 value scaled (or the gain)."""
    f1, f2 = POLES.pendulum_frequency, POLES.damper_frequency
    if parameter == 2:
        return APLModel(NOMINAL.zeros, NOMINAL.poles, NOMINAL.gain * (1 + s), 0, NOMINAL.dt, SPEED, DX)
    f1, f2 = (f1 * (1 + s), f2) if parameter == 0 else (f1, f2 * (1 + s))
    return apl_model(SPEED, DX, poles=TrailerPoles(POLES.pendulum_modulus, f1, POLES.damper_modulus, f2))


def test_the_default_is_the_posterior_std_and_estimate_composed_from_the_public_pieces(record):
    """Bit-identical to the pipeline before the term: RTS smoother mean, detrended; std = smoother_error_std."""
    rec = reconstruct_profile(record, NOMINAL, q=Q, r=R)
    model = apl_deconvolution_model(NOMINAL, Q, R)
    mean = rts_smoother(model, kalman_filter(model, record)).mean[:, -1]
    assert np.array_equal(rec.profile.elevation[:, 0], detrend_profile(mean, DX))
    assert np.array_equal(rec.profile.std[:, 0], np.full(record.size, smoother_error_std(NOMINAL, Q, R, dx=DX, highpass_wavelength=100.0)))
    assert rec.instrument_uncertainty is None and rec.instrument_std is None


@pytest.mark.parametrize("method", ["smoother", "fixed-lag"])
def test_zero_uncertainty_prints_the_default_std(record, method):
    ref = reconstruct_profile(record, NOMINAL, q=Q, r=R, method=method)
    rec = reconstruct_profile(record, NOMINAL, q=Q, r=R, method=method,
                              instrument_uncertainty=InstrumentUncertainty(frequency=0.0, gain=0.0))
    assert np.array_equal(rec.profile.std, ref.profile.std)
    assert np.array_equal(rec.profile.elevation, ref.profile.elevation)
    assert rec.instrument_std is None


@SLOW
@given(parameter=st.integers(0, 2), s=st.floats(-0.3, 0.3).filter(lambda v: abs(v) > 1e-3))
def test_perturbed_instrument_is_apl_model_with_the_scaled_table_1_value(parameter, s):
    f = np.geomspace(1e-3, 0.49 / NOMINAL.dt, 400)
    got = perturbed_instrument(NOMINAL, parameter, s).response_at(f)
    np.testing.assert_allclose(got, _scaled_eq1(parameter, s).response_at(f), rtol=1e-9, atol=1e-12)
    assert len(instrument_parameters(NOMINAL)) == 3


@SLOW
@given(freq=st.floats(0.01, 0.25), gain=st.floats(0.0, 0.1))
def test_the_instrument_std_is_the_finite_difference_of_the_public_function(record, freq, gain):
    """Oracle: with no averaging window, instrument_std^2 = sum over (f1, f2, k) of the change of
    reconstruct_profile(y, apl_model with that value scaled by 1 + sigma, same q, r)."""
    unc = InstrumentUncertainty(frequency=freq, gain=gain, window_m=0.0)
    rec = reconstruct_profile(record, NOMINAL, q=Q, r=R, instrument_uncertainty=unc)
    var = np.zeros(record.size)
    for parameter, s in ((0, freq), (1, freq), (2, gain)):
        if s > 0:
            other = reconstruct_profile(record, _scaled_eq1(parameter, s), q=Q, r=R)
            var += (other.profile.elevation[:, 0] - rec.profile.elevation[:, 0]) ** 2
    # the two models' poles differ by round-off (1e-15 in |H|), which the smoother amplifies to ~1e-5 of delta
    delta = np.sqrt(var)
    np.testing.assert_allclose(rec.instrument_std, delta, rtol=1e-4, atol=1e-4 * delta.max())
    post = smoother_error_std(NOMINAL, Q, R, dx=DX, highpass_wavelength=100.0)
    np.testing.assert_allclose(rec.profile.std[:, 0], np.sqrt(post ** 2 + var), rtol=1e-5)


def test_the_fixed_lag_instrument_std_is_the_finite_difference_of_the_public_function(record):
    unc = InstrumentUncertainty(frequency=0.1, window_m=0.0)
    rec = reconstruct_profile(record, NOMINAL, q=Q, r=R, method="fixed-lag", lag_m=20.0, instrument_uncertainty=unc)
    var = sum((reconstruct_profile(record, _scaled_eq1(p, 0.1), q=Q, r=R, method="fixed-lag",
                                   lag_m=20.0).profile.elevation[:, 0] - rec.profile.elevation[:, 0]) ** 2
              for p in (0, 1))
    np.testing.assert_allclose(rec.instrument_std, np.sqrt(var), rtol=1e-4, atol=1e-4 * np.sqrt(var.max()))


def test_the_window_averages_the_squared_sensitivity(record):
    kw = dict(q=Q, r=R)
    bare = reconstruct_profile(record, NOMINAL, instrument_uncertainty=InstrumentUncertainty(0.1, 0.02, 0.0), **kw)
    avg = reconstruct_profile(record, NOMINAL, instrument_uncertainty=InstrumentUncertainty(0.1, 0.02, 1.0), **kw)
    v = bare.instrument_std ** 2
    k = 400  # interior sample: the centred 20-sample mean
    assert avg.instrument_std[k] ** 2 == pytest.approx(v[k - 10:k + 10].mean(), rel=1e-9)
    assert avg.instrument_std.mean() == pytest.approx(np.sqrt(v).mean(), rel=0.2)


@SLOW
@given(lo=st.floats(0.005, 0.15), factor=st.floats(1.2, 2.0), which=st.sampled_from(["frequency", "gain"]))
def test_the_std_grows_monotonically_with_the_declared_uncertainty(record, lo, factor, which):
    """Everywhere above the posterior std, and its record RMS grows with sigma. (Sample by sample the one-sided
    difference is not monotone beyond the linear range: a sign change of delta moves with sigma.)"""
    hi = lo * factor
    std = [reconstruct_profile(record, NOMINAL, q=Q, r=R,
                               instrument_uncertainty=InstrumentUncertainty(**{which: s})).profile.std[:, 0]
           for s in (0.0, lo, hi)]
    assert np.all(std[1] >= std[0]) and np.all(std[2] >= std[0])
    rms = [np.sqrt(np.mean(v ** 2)) for v in std]
    assert rms[0] < rms[1] < rms[2]


@pytest.mark.parametrize("bad", [dict(frequency=-0.1), dict(gain=1.0), dict(frequency=float("nan")),
                                 dict(gain=float("inf")), dict(window_m=-1.0), dict(frequency="abc")])
def test_bad_values_are_refused(bad):
    with pytest.raises(InputError, match="instrument uncertainty"):
        InstrumentUncertainty(**bad)


@pytest.mark.parametrize("text", ["freq=0.1,gain", "f=0.1", "freq=0.1,freq=0.2", "freq=x", "freq=1.5", ""])
def test_bad_strings_are_refused(record, text):
    with pytest.raises(InputError, match="instrument uncertainty"):
        reconstruct_profile(record, NOMINAL, q=Q, r=R, instrument_uncertainty=text)


def test_parse_and_methods_without_a_printed_std(record):
    assert InstrumentUncertainty.parse(" freq = 0.1 , gain=0.03,window=5") == InstrumentUncertainty(0.1, 0.03, 5.0)
    for kw in (dict(method="filter"), dict(method="double"), dict(highpass_wavelength=None)):
        with pytest.raises(InputError, match="printed std"):
            reconstruct_profile(record, NOMINAL, instrument_uncertainty="freq=0.1", **({"q": Q, "r": R} | kw))
    with pytest.raises(InputError, match="InstrumentUncertainty or a string"):
        reconstruct_profile(record, NOMINAL, q=Q, r=R, instrument_uncertainty={"frequency": 0.1})


def test_cli_instrument_uncertainty(tmp_path, capsys):
    rec = tmp_path / "rec.csv"
    runner = CliRunner()
    assert runner.invoke(app, ["road", "simulate", "-o", str(rec), "--length", "200", "--seed", "3"]).exit_code == 0
    base, wide = tmp_path / "a.csv", tmp_path / "b.csv"
    common = ["road", "reconstruct", str(rec), "--q", "2e-6", "--r", "1e-9"]
    assert runner.invoke(app, common + ["-o", str(base)]).exit_code == 0
    r = runner.invoke(app, common + ["-o", str(wide), "--instrument-uncertainty", "freq=0.115,gain=0.029"])
    assert r.exit_code == 0, r.output
    a, b = pd.read_csv(base, comment="#"), pd.read_csv(wide, comment="#")
    assert list(b.columns) == list(a.columns)
    assert np.array_equal(a["elevation_m"], b["elevation_m"]) and (b["std_m"] >= a["std_m"]).all()
    assert b["std_m"].mean() > 1.2 * a["std_m"].mean()
    for bad in ("freq=1.2", "gain=-0.1", "freq", "freq=0.1,speed=2"):
        capsys.readouterr()
        code = main(common + ["-o", str(tmp_path / "c.csv"), "--instrument-uncertainty", bad])
        err = capsys.readouterr()
        lines = [ln for ln in (err.out + err.err).splitlines() if ln.strip()]
        assert code == 2 and len(lines) == 1 and "instrument uncertainty" in lines[0], lines
    assert not (tmp_path / "c.csv").exists()
