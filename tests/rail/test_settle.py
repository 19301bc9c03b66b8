"""The whole job on synthetic truth: accuracy, band coverage, sensor health, controls, options."""

import dataclasses

import numpy as np
import pytest

from longprofile.errors import InputError
from longprofile.rail import estimate_settlement, simulate_site, validate_site


@pytest.fixture(scope="module")
def mitt():
    syn = simulate_site("mittersheim-like", seed=0, sampling_minutes=20)
    site = validate_site(syn.sensors, syn.readings, syn.survey)
    res = estimate_settlement(site, settlement_threshold_m=0.01, rate_threshold_m_per_day=0.003, n_monte_carlo=300)
    return syn, site, res


def test_mittersheim_accuracy_and_band_coverage(mitt):
    # the per-day posteriors (joint_days=False, step 9); the default all-days model: the next test
    syn, site, _ = mitt
    res = estimate_settlement(site, n_monte_carlo=0, joint_days=False)
    err = res.dz - syn.truth.settlement
    assert np.sqrt(np.mean(err**2)) <= 2e-3
    # the change prior fitted by maximum likelihood (sigma fixed): the data prefer the smooth ||f'''||^2 prior
    assert res.change_prior is not None and res.penalty_order == 3
    assert res.change_prior.log_likelihood[3] > res.change_prior.log_likelihood[2]
    # its full posterior 90 % bands cover 85-95 % of the true values (days after the reference day, interior
    # stations; seed 0 — docs/rail.md gives seeds 0-4)
    inside = (np.abs(err) <= 1.6448536 * res.dz_std)[1:, 1:-1]
    assert 0.85 <= inside.mean() <= 0.95
    table = res.to_table()
    assert np.allclose(table["dz_upper90_m"] - table["dz_lower90_m"], 2 * 1.6448536269514722 * res.dz_std.ravel())
    sm = res.smoothed
    assert np.sqrt(np.mean((sm.mean - syn.truth.settlement) ** 2)) <= 2e-3
    # the posterior variance contains the noise-only part (plus the prior's share): never below it
    assert np.all(res.dz_std >= res.dz_noise_std * (1 - 1e-9))


def test_mittersheim_all_days_model_accuracy_and_band_coverage(mitt):
    """The default (all days at once, issue 13 step 10) on the paper's own simulator, whose errors are white: as
    accurate as the per-day posteriors (seed 0: 0.170 against 0.169 mm), bands that contain the noise-only part, and
    the 90 % bands' coverage over seeds 0-4 within 85-95 % (measured 92.4 %; per seed 82.3-99.2 %, the per-day
    model's 76.8-94.6 %, mean 88.2 %)."""
    syn, _, res = mitt
    assert res.settings["joint_days"]
    err = res.dz - syn.truth.settlement
    assert np.sqrt(np.mean(err**2)) <= 2e-3
    assert np.sqrt(np.mean((res.smoothed.mean - syn.truth.settlement) ** 2)) <= 2e-3
    assert np.all(res.dz_std >= res.dz_noise_std * (1 - 1e-9))
    inside = [(np.abs(err) <= 1.6448536 * res.dz_std)[1:, 1:-1]]
    for seed in (1, 2, 3, 4):
        s = simulate_site("mittersheim-like", seed=seed, sampling_minutes=20)
        r = estimate_settlement(validate_site(s.sensors, s.readings, s.survey), n_monte_carlo=0)
        inside.append((np.abs(r.dz - s.truth.settlement) <= 1.6448536 * r.dz_std)[1:, 1:-1])
    assert 0.85 <= np.mean(np.concatenate([i.ravel() for i in inside])) <= 0.95


def test_the_papers_fixed_rigidity_gives_over_wide_bands(mitt):
    # r = 1e-8 (paper §4.1) with the paper's cubic prior: the posterior std (~5 mm) is ~30x the actual error,
    # its 90 % band covers essentially every true value — why the default fits the change prior instead
    syn, site, fitted = mitt
    res = estimate_settlement(site, rigidity=1e-8, n_monte_carlo=0, through_time=False)
    assert res.penalty_order == 2 and res.change_prior is None
    err = res.dz - syn.truth.settlement
    assert (np.abs(err) <= 1.6448536 * res.dz_std)[1:, 1:-1].mean() > 0.99
    assert np.median(res.dz_std[1:, 1:-1]) > 10 * np.median(fitted.dz_std[1:, 1:-1])


def test_dead_and_reversed_sensors_are_flagged_and_reported(mitt):
    syn, _, res = mitt
    flagged = {sid: st for sid, st, _ in res.health.flagged()}
    assert flagged == syn.truth.bad_sensors
    for sid in flagged:
        assert any(f"sensor {sid} excluded" in w for w in res.warnings)
    table = res.to_table()
    assert set(table.loc[table.sensor_id.isin(list(flagged)), "status"]) == set(flagged.values())
    assert len(table) == res.dz.size


def test_monte_carlo_max_settlement_and_alarms(mitt):
    syn, _, res = mitt
    true_max = -syn.truth.settlement[-1].min()
    assert abs(res.max_settlement_mean[-1] - true_max) < 3 * res.max_settlement_std[-1]
    assert res.max_settlement_std[-1] > 0
    al = res.alarms
    assert len(al) > 0 and set(al["kind"]) == {"settlement", "rate"}
    assert al["probability"].between(0.5, 1.0).all()
    # no settlement alarm before the works (week 1)
    first_work = str(np.datetime_as_string(syn.truth.days[np.argmax(syn.truth.work_days)], unit="D"))
    assert (al["date"] >= first_work).all()


def test_paper_chain_integrations_are_less_accurate_than_the_posterior(mitt):
    syn, _, res = mitt
    rms = {k: np.sqrt(np.mean((v - syn.truth.settlement) ** 2)) for k, v in res.integrated.items()}
    post = np.sqrt(np.mean((res.dz - syn.truth.settlement) ** 2))
    assert set(rms) == {"forward", "backward", "average", "convex"}
    assert post < min(rms.values())


def test_settings_object_gives_the_same_result_as_keywords(mitt):
    from longprofile.rail import SettlementSettings

    syn, site, res = mitt
    opt = SettlementSettings(settlement_threshold_m=0.01, rate_threshold_m_per_day=0.003, n_monte_carlo=300)
    again = estimate_settlement(site, settings=opt)
    for name in ("dz", "dz_std", "dz_noise_std", "slope_change", "max_settlement_mean", "max_settlement_std",
                 "sigma_by_day"):
        assert np.array_equal(getattr(again, name), getattr(res, name)), name
    assert again.settings == res.settings and again.warnings == res.warnings
    assert again.alarms.equals(res.alarms)
    with pytest.raises(InputError, match="error_model"):
        SettlementSettings(error_model="pink")
    with pytest.raises(InputError, match="sigma_z"):
        SettlementSettings(sigma_z=0.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        opt.sigma = 1.0


def test_options_exclusion_affine_and_errors(mitt):
    syn, site, _ = mitt
    res = estimate_settlement(site, exclude_sensors=["S01"], use_affine_correction=True, through_time=False,
                              n_monte_carlo=0, sigma=2e-5)
    assert res.smoothed is None and np.isnan(res.max_settlement_mean).all()
    assert any("affine correction" in w for w in res.warnings)
    assert dict((s, st) for s, st, _ in res.health.flagged())["S01"] == "excluded"  # was "improbable"
    assert res.sigma == 2e-5
    with pytest.raises(InputError, match="unknown sensor id"):
        estimate_settlement(site, exclude_sensors=["nope"])


def test_farebersviller_lagged_thermal_model_is_closer_to_controls():
    syn = simulate_site("farebersviller-like", seed=0, sampling_minutes=60, n_days=40)
    site = validate_site(syn.sensors, syn.readings, syn.survey, syn.controls)
    rms = {}
    for thermal in ("linear", "lagged"):
        res = estimate_settlement(site, thermal=thermal, n_monte_carlo=0)
        c = res.controls
        assert c is not None and set(c["date"]) == {"2021-04-06"}
        rms[thermal] = np.sqrt(np.mean((c["dz_control_m"] - c["dz_estimate_m"]) ** 2))
        rms[thermal + "_truth"] = np.sqrt(np.mean((res.dz - syn.truth.settlement) ** 2))
    assert rms["lagged_truth"] < rms["linear_truth"]
    assert rms["lagged"] < rms["linear"]
    assert rms["lagged"] < 4e-3  # the control surveys themselves have 2 mm noise


def test_drifting_and_detached_sensors_are_classified():
    import pandas as pd

    syn = simulate_site("mittersheim-like", seed=0, sampling_minutes=30)
    r = syn.readings.copy()
    t = (pd.to_datetime(r.timestamp) - pd.Timestamp("2019-11-18")).dt.total_seconds() / 86400
    m = r.sensor_id == "S05"
    r.loc[m, "angle_deg"] += 0.01 * t[m]  # drifts 0.01 deg/day
    m = r.sensor_id == "S50"
    r.loc[m & (t > 15), "angle_deg"] += 0.3  # comes loose on day 15
    res = estimate_settlement(validate_site(syn.sensors, r, syn.survey), n_monte_carlo=0)
    flagged = {s: st for s, st, _ in res.health.flagged()}
    assert flagged == {**syn.truth.bad_sensors, "S05": "drifting", "S50": "detached"}
