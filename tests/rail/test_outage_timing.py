"""The timing of the change across a logger outage (docs/rail.md, "Logger outages: the timing of the change"): the
all-days model spreads a sensor's change across its unread days as a ramp; the band also holds the nearest read
sensors' timing."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import longprofile.rail._settle as settle
from longprofile.rail import estimate_settlement, validate_site
from longprofile.rail._settle import _outage_timing_shift, _with_timing_shift
from longprofile.rail._synthetic import simulate_site

Z90 = 1.6448536269514722


def test_the_alternative_mean_is_the_neighbours_step_path():
    """Oracle by hand: sensor 2 unread on days 3-5 (read on 2 and 6), its model mean a ramp from -1 to -5 mm; both
    neighbours step on day 5. The shift takes the ramp to the step path z_a + Delta 1[t >= 5], elsewhere 0; with the
    neighbours' bands wider than half their change (TIMING_MIN_CHANGE = 2 stds), their timing is no evidence: 0."""
    D, N = 8, 5
    x = np.arange(N, dtype=float)
    z = np.zeros((D, N))
    z[5:, [1, 3]] = [-2e-3, -3e-3]
    z[:, 2] = 1e-3 * np.array([0, -0.5, -1, -2, -3, -4, -5, -5])
    obs = np.ones((D, N))
    obs[3:6, 2] = np.nan
    obs[:, 4] = np.nan  # an excluded sensor is no neighbour
    filled = obs.copy()
    filled[3:6, 2] = 0.0
    shift, group = _outage_timing_shift(x, z, np.full((D, N), 0.5e-3), obs, filled)
    expected = np.zeros((D, N))
    expected[3:6, 2] = 1e-3 * (np.array([-1, -1, -5]) - np.array([-2, -3, -4]))
    np.testing.assert_allclose(shift, expected, atol=1e-15)
    on = np.zeros((D, N), bool)
    on[3:6, 2] = True
    assert (group[on] == 0).all() and (group[~on] == -1).all()
    wide, group = _outage_timing_shift(x, z, np.full((D, N), 1.1e-3), obs, filled)  # |Delta_k| < 2 hypot(std)
    assert (wide == 0).all() and (group == -1).all()


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_the_shift_stays_on_the_missing_days_and_between_the_runs_ends(seed):
    """Property: delta is 0 off the missing sensor-days, on runs that start on day 0 or reach the last day; where it
    is given (a neighbour read on every day of the run and either side), the alternative mean z + delta lies between
    the sensor's means on the read days either side of the run."""
    rng = np.random.default_rng(seed)
    D, N = int(rng.integers(4, 12)), int(rng.integers(3, 9))
    x = np.sort(rng.uniform(0, 50, N))
    z = np.vstack([np.zeros(N), np.cumsum(rng.normal(0, 1e-3, (D - 1, N)), axis=0)])
    obs = np.where(rng.random((D, N)) < 0.3, np.nan, 1.0)
    filled = np.where(np.isnan(obs), 0.0, obs)
    filled[:, rng.random(N) < 0.2] = np.nan
    shift, group = _outage_timing_shift(x, z, np.zeros((D, N)), obs, filled)
    miss = np.isnan(obs) & np.isfinite(filled)
    assert (shift[~miss] == 0).all() and (group[~miss] == -1).all()
    alt = z + shift
    for j in range(N):
        for first, last in settle._missing_runs(miss[:, j]):
            a, b = first - 1, last + 1
            if a < 0 or b >= D:
                assert (shift[first:last + 1, j] == 0).all()
                continue
            lo, hi = sorted((z[a, j], z[b, j]))
            if (group[first:b, j] < 0).all():  # no neighbour read over a..b (or none changed): no shift
                assert (shift[first:b, j] == 0).all()
                continue
            assert ((alt[first:b, j] >= lo - 1e-15) & (alt[first:b, j] <= hi + 1e-15)).all()


@settings(max_examples=25, deadline=None)
@given(ratio=st.floats(0.0, 20.0), sd=st.floats(1e-5, 1e-2))
def test_the_band_holds_the_neighbours_timing_monte_carlo(ratio, sd):
    """Oracle: a Monte Carlo of the stated hypothesis. If the track followed the neighbours' timing (truth = mean +
    delta, plus the Gaussian posterior's own error of std sd), the band mean +/- 1.645 sqrt(sd^2 + delta^2) covers at
    least 90 % of the draws (less MC error) for any delta; the mixture "mean +/- delta" has that variance. The same for
    the daily rate with the day differences of delta."""
    rng = np.random.default_rng(0)
    n = 20000
    delta = ratio * sd
    shift = np.array([[0.0], [delta], [0.0]])
    z_std, rate_std = _with_timing_shift(np.full((3, 1), sd), np.array([[np.nan], [sd], [sd]]), shift)
    truth = delta + sd * rng.standard_normal(n)
    assert np.mean(np.abs(truth) <= Z90 * z_std[1, 0]) >= 0.89
    mix = rng.choice([-1.0, 1.0], n) * delta + sd * rng.standard_normal(n)
    assert abs(np.std(mix) / z_std[1, 0] - 1) < 0.03
    assert np.isnan(rate_std[0, 0])
    rate_truth = -delta + sd * rng.standard_normal(n)  # the day after: the neighbours' timing catches up
    assert np.mean(np.abs(rate_truth) <= Z90 * rate_std[2, 0]) >= 0.89


def _probe(monkeypatch=None):
    """mittersheim-like seed 0 with S30-S45 unread on 2019-12-05..09 (the bowl's step on 12-09): the estimate and
    the truth."""
    site = simulate_site("mittersheim-like", seed=0)
    r = site.readings
    day = pd.to_datetime(r["timestamp"]).dt.normalize()
    drop = r["sensor_id"].isin([f"S{k}" for k in range(30, 46)]) & day.between("2019-12-05", "2019-12-09")
    res = estimate_settlement(validate_site(site.sensors, r[~drop], site.survey), n_monte_carlo=200, rng=0)
    return res, site.truth.settlement


def test_an_outage_over_a_work_days_step_gets_an_honest_band(monkeypatch):
    """The probe's case (docs/rail.md): the band covered 66.7 % of the 75 outage sensor-days (RMS z 1.50) and the
    daily rate 73.3 % of the 90 rate cells of the outage; now 93.3 % (0.92) and 87.8 % (measured). The printed mean
    is unchanged, no band narrower, and the measured sensor-days untouched. The maximum settlement's draws carry the
    two timings too: its interval (200 draws) on the outage days 1.5-2.5 mm wide without them, 2.4-4.9 mm with them
    (measured), elsewhere as wide."""
    res, truth = _probe()
    calls = []
    real = settle._outage_timing_shift

    def zero(*args):
        shift, group = real(*args)
        calls.append(1)
        return np.zeros_like(shift), group

    monkeypatch.setattr(settle, "_outage_timing_shift", zero)
    ramp, _ = _probe()
    assert calls
    meas = res.measured()
    out = ~meas & meas.any(axis=0)[None, :]
    assert out.sum() == 75
    z = (res.dz - truth)[out] / res.dz_std[out]
    assert np.mean(np.abs(z) <= Z90) >= 0.85
    rate_cells = (out[1:] | out[:-1])
    rz = (res.smoothed.rate[1:] - np.diff(truth, axis=0))[rate_cells] / res.smoothed.rate_std[1:][rate_cells]
    assert rate_cells.sum() == 90 and np.mean(np.abs(rz) <= Z90) >= 0.80
    np.testing.assert_array_equal(res.dz, ramp.dz)
    assert (res.dz_std >= ramp.dz_std).all()
    np.testing.assert_array_equal(res.dz_std[~out], ramp.dz_std[~out])
    days = out.any(axis=1)
    width = res.max_settlement_upper - res.max_settlement_lower
    ramp_width = ramp.max_settlement_upper - ramp.max_settlement_lower
    assert np.mean(width[days]) >= 1.3 * np.mean(ramp_width[days])
    np.testing.assert_allclose(width[~days], ramp_width[~days], rtol=0.3)


@pytest.mark.parametrize("n_draws", [0, 40])
def test_a_site_without_missing_days_is_bit_identical(monkeypatch, n_draws):
    """Without a missing sensor-day the timing shift is never computed (it would raise here) and nothing changes:
    bands and the maximum settlement's draws are those of the all-days posterior as before."""
    site = simulate_site("mittersheim-like", seed=1)
    data = validate_site(site.sensors, site.readings, site.survey)
    before = estimate_settlement(data, n_monte_carlo=n_draws, rng=3)

    def boom(*args):
        raise AssertionError("the timing shift was computed on a site without missing days")

    monkeypatch.setattr(settle, "_outage_timing_shift", boom)
    after = estimate_settlement(data, n_monte_carlo=n_draws, rng=3)
    assert before.measured()[:, np.isin(np.asarray(before.health.status), ["ok"])].all()
    pd.testing.assert_frame_equal(before.to_table(), after.to_table())
    np.testing.assert_array_equal(before.max_settlement_mean, after.max_settlement_mean)
    np.testing.assert_array_equal(before.max_settlement_upper, after.max_settlement_upper)
