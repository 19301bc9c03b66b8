"""The innovation diagnostic of a trailer model against a record (``_model_check.innovation_check``, issue 13).

docs/road-apl.md, "An undeclared trailer mismatch: what the innovations can tell": the shape of the filter's
normalised-innovation spectrum across the resolved wavenumbers rejects a trailer whose damper and pendulum
frequencies differ from the model's and accepts the model's own trailer on an ISO road; it is a diagnostic (it also
rejects a road that is not n^-2), not used by the printed std.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from longprofile.road import iso8608_profile
from longprofile.road.apl import TABLE1_CONFIGURATIONS, TrailerPoles, apl_model, apl_response, fit_noise_variances
from longprofile.road.apl._deconvolution import apl_deconvolution_model
from longprofile.road.apl._model_check import MODEL_CHECK_ALPHA, innovation_check
from longprofile.statespace import kalman_filter

DX, SPEED, LENGTH = 0.05, 20.0, 2000.0
MODEL = apl_model(SPEED, DX)


def _wiener(q):
    return lambda w: q / np.abs(1.0 - np.exp(-1j * w)) ** 2


def _check(instrument, seed):
    """A 2 km class C record made by ``instrument`` with 2 % noise, checked against the nominal model (ML q, r)."""
    rng = np.random.default_rng(seed)
    n = int(round(LENGTH / DX))
    u = iso8608_profile(n * DX - DX / 2, DX, "C", rng=rng).elevation.reshape(-1)[:n]
    y0 = apl_response(u, instrument)
    y = y0 + rng.normal(0.0, 0.02 * np.sqrt(np.mean(y0 ** 2)), n)
    fit = fit_noise_variances(y, MODEL, dx=DX)
    f = kalman_filter(apl_deconvolution_model(MODEL, fit.q, fit.r, dx=DX), y)
    return innovation_check(f.innovation, f.innovation_cov, MODEL, fit.r, _wiener(fit.q), DX)


@pytest.mark.parametrize("seed", [11, 12])
def test_own_model_not_rejected(seed):
    c = _check(MODEL, seed)
    assert not c.rejected and c.p_value > 0.05 and c.dof >= 5
    assert abs(c.overall_nis - 1.0) < 0.02  # ML q and r: the overall NIS is 1 by construction
    assert np.all(np.abs(np.log(c.band_nis)) < 0.2)


@pytest.mark.parametrize("seed", [11, 12])
def test_mismatched_trailer_rejected(seed):
    p = TABLE1_CONFIGURATIONS[(SPEED, DX)]
    true = apl_model(SPEED, DX, poles=TrailerPoles(p.pendulum_modulus, 1.2 * p.pendulum_frequency,
                                                   p.damper_modulus, 0.8 * p.damper_frequency))
    c = _check(true, seed)
    assert c.rejected and c.p_value < MODEL_CHECK_ALPHA
    assert abs(c.overall_nis - 1.0) < 0.02  # ... which is why the overall NIS cannot see it


def test_white_innovations_are_rarely_rejected():
    """Unit white Gaussian innovations, 1 000 records: rejected on at most 1 % at alpha = 1e-3.

    Measured 2026-12-06: 7 of these 1 000 (seeds 0-999) and 5 of 1 500 others (seeds 10 000 000-10 001 499) rejected,
    about 0.5 %, and p < 0.05 on 11 % of the latter: the chi^2 null of the band log-NIS is anti-conservative about 5x
    at this level (the bands' equivalent degrees of freedom are an approximation), not "conservative" as first
    written; a random-seed property with 15 draws then failed on about one run in fifteen (seed 166067: p = 3e-6).
    The diagnostic is not used by the estimator (module docstring)."""
    rejected = 0
    for seed in range(1000):
        rng = np.random.default_rng(seed)
        e = rng.normal(0.0, 2e-3, 40_000)
        c = innovation_check(e, np.full(e.size, 4e-6), MODEL, 1e-8, _wiener(2.5e-6), DX)
        assert c.dof >= 5
        rejected += c.rejected
    assert rejected <= 10, rejected


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2 ** 31 - 1))
@example(seed=64920)  # p = 6.4e-5: rejected at the default alpha = 1e-3 (found by a stress run)
def test_white_innovations_not_rejected(seed):
    """Unit white Gaussian innovations: no rejection, judged against the statistic's measured spread under white
    innovations (not the nominal alpha: the chi^2 approximation is not conservative for exactly white ones).

    Measured (2026-12-06) over seeds 200000-219999: rejected at the default alpha = 1e-3 on 0.55 % of draws (5.5x the
    nominal rate: mean X 12.6 for dof 11, variance 30 for 22), p < 1e-4 on 0.085 %, p < 1e-5 on 0.005 %, none below
    1e-6 (min 3.8e-6); so ``not c.rejected`` failed ~8 % of 15-example runs (seed 64920: p = 6.4e-5). The bound 1e-7
    keeps a margin of ~40x below that minimum. The band NIS are checked too: std of ln n_b measured 0.03-0.12 per band
    (mean -0.006 to -0.001), so |ln n_b| < 0.6 is >= 5 sigma for every band, and still fails a factor-2 normalisation
    error; the overall NIS of ~38 000 unit normals has std 0.007.
    """
    rng = np.random.default_rng(seed)
    e = rng.normal(0.0, 2e-3, 40_000)
    c = innovation_check(e, np.full(e.size, 4e-6), MODEL, 1e-8, _wiener(2.5e-6), DX)
    assert c.dof >= 5 and c.p_value > 1e-7, (c.statistic, c.dof, c.p_value)
    assert np.all(np.abs(np.log(c.band_nis)) < 0.6) and abs(c.overall_nis - 1.0) < 0.05, (c.band_nis, c.overall_nis)


def test_too_short_gives_no_verdict():
    c = innovation_check(np.ones(3000), np.ones(3000), MODEL, 1e-8, _wiener(2.5e-6), DX)
    assert not c.rejected and c.p_value == 1.0 and c.dof == 0
