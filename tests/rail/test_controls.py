"""Control surveys against the estimate (``rail/_controls.py``): the table, the chi-squared check, the warning."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.rail import CONTROL_CHECK_P, check_controls, compare_controls, estimate_settlement, validate_site
from longprofile.rail._scenarios import SCENARIO_FAMILIES, SHAPE_FAMILIES, simulate_scenario

DAYS = pd.date_range("2024-03-01", periods=3, freq="D").to_numpy()
X = np.array([0.0, 5.0, 10.0, 15.0, 20.0])


def _table(ctrl_mm, *, sigma_a=2e-3, std=5e-4, est=None):
    """compare_controls on a flat initial survey: a control survey on day 2 at 0, 2.5, ..., 20 m."""
    cx = np.arange(0.0, 20.01, 2.5)
    dz = np.zeros((3, X.size)) if est is None else est
    controls = pd.DataFrame({"date": "2024-03-03", "x_m": cx, "z_m": 100.0 + 1e-3 * np.asarray(ctrl_mm, float)})
    return compare_controls(controls, DAYS, X, dz, np.full((3, X.size), std), np.array([0.0, 20.0]),
                            np.array([100.0, 100.0]), sigma_a=sigma_a)


def test_the_table_standardises_by_the_band_and_both_surveys_noise():
    est = np.zeros((3, X.size))
    est[2] = -1e-3 * X / 20.0  # 0 to -1 mm, linear: interpolation between sensors is exact
    t = _table(np.full(9, -3.0), est=est)
    cx = np.arange(0.0, 20.01, 2.5)
    assert list(t.columns) == ["date", "x_m", "dz_control_m", "dz_estimate_m", "std_m", "z", "inside_90"]
    np.testing.assert_allclose(t.dz_estimate_m, -1e-3 * cx / 20.0, atol=1e-12)
    np.testing.assert_allclose(t.z, (-3e-3 + 1e-3 * cx / 20.0) / np.hypot(5e-4, np.sqrt(2) * 2e-3))
    assert (t.inside_90 == (np.abs(t.z) <= 1.6448536269514722)).all()
    assert (t.date == "2024-03-03").all()


def test_the_users_survey_noise_is_the_one_used():
    loose, tight = _table(np.full(9, 3.0), sigma_a=2e-3), _table(np.full(9, 3.0), sigma_a=0.5e-3)
    assert loose.inside_90.all() and not tight.inside_90.any()  # 3 mm: inside 2 mm levelling, outside 0.5 mm
    with pytest.raises(InputError, match="sigma_a"):
        _table(np.zeros(9), sigma_a=0.0)


def test_points_outside_the_spans_or_on_other_days_are_left_out():
    controls = pd.DataFrame({"date": ["2024-03-03", "2024-03-03", "2024-04-01"], "x_m": [-5.0, 10.0, 10.0],
                             "z_m": [100.0, 100.0, 100.0]})
    t = compare_controls(controls, DAYS, X, np.zeros((3, 5)), np.full((3, 5), 1e-3), np.array([0.0, 20.0]),
                         np.array([100.0, 100.0]))
    assert t.x_m.tolist() == [10.0]
    assert compare_controls(None, DAYS, X, np.zeros((3, 5)), np.ones((3, 5)), X, X) is None
    assert check_controls(None) is None


def test_the_check_is_the_chi_squared_test_and_names_the_worst_point():
    mm = np.zeros(9)
    mm[4] = -20.0
    t = _table(mm)
    c = check_controls(t)
    from scipy.stats import chi2

    assert c.chi2 == pytest.approx(float((t.z**2).sum()))
    assert c.p_value == pytest.approx(chi2.sf(c.chi2, 9))
    assert c.disagree and c.n_points == 9 and c.n_outside == 1
    assert c.worst[:2] == ("2024-03-03", 10.0) and c.worst[2] == pytest.approx(-20e-3)
    assert "-20.0 mm at x = 10 m on 2024-03-03" in c.message()
    assert not check_controls(_table(np.zeros(9))).disagree and check_controls(_table(np.zeros(9))).message() == ""
    with pytest.raises(InputError, match="p must be"):
        check_controls(t, p=0.0)


@settings(max_examples=30, deadline=None)
@given(offset_mm=st.floats(15.0, 500.0), sign=st.sampled_from([-1.0, 1.0]), seed=st.integers(0, 2**31 - 1))
def test_controls_on_another_datum_are_named_as_an_offset_before_the_other_causes(offset_mm, sign, seed):
    """Every point off by the same amount (controls on another benchmark; a user's probe, session 39: +0.3 m was
    reported as "a span end that moved"): the warning names the offset first and how to remove it."""
    noise = np.random.default_rng(seed).normal(0.0, 2.0, 9)  # the levelling's own noise, mm
    c = check_controls(_table(sign * offset_mm + noise))
    assert c.disagree and len(c.offsets) == 1
    date, off, spread = c.offsets[0]
    assert date == "2024-03-03" and off == pytest.approx(1e-3 * (sign * offset_mm + noise.mean()), abs=1e-9)
    msg = c.message()
    assert "Same offset at every point" in msg and "another datum or benchmark" in msg
    assert msg.index("another datum") < msg.index("a span end that moved")


def test_a_moved_end_or_a_step_is_not_called_an_offset():
    cx = np.arange(0.0, 20.01, 2.5)
    step = np.where(cx > 10.0, -20.0, 0.0)  # a step at a joint: half the span lowered
    tilt = -20.0 * cx / 20.0  # the far end moved
    single = np.zeros(9)
    single[4] = -20.0
    for mm in (step, tilt, single):
        c = check_controls(_table(mm))
        assert c.disagree and c.offsets == () and "Same offset" not in c.message()


@settings(max_examples=20, deadline=None)
@given(n=st.integers(3, 60), seed=st.integers(0, 2**31 - 1))
def test_false_alarm_rate_of_agreeing_controls_is_the_level(n, seed):
    """Controls that agree (z iid N(0, 1)): the check fires at the rate CONTROL_CHECK_P, within binomial bounds."""
    rng = np.random.default_rng(seed)
    trials = 4000
    z = rng.standard_normal((trials, n))
    from scipy.stats import binom, chi2

    stat = (z**2).sum(axis=1)
    fired = int((chi2.sf(stat, n) < CONTROL_CHECK_P).sum())
    lo, hi = binom.ppf([1e-4, 1 - 1e-4], trials, CONTROL_CHECK_P)
    assert lo <= fired <= hi
    # and through check_controls itself on a few of them
    for row in z[:3]:
        t = pd.DataFrame({"date": "2024-03-03", "x_m": np.arange(n, dtype=float), "dz_control_m": row * 1e-3,
                          "dz_estimate_m": 0.0, "std_m": 1e-3, "z": row, "inside_90": np.abs(row) <= 1.645})
        assert check_controls(t).disagree == (chi2.sf((row**2).sum(), n) < CONTROL_CHECK_P)


def _site(family, seed, **overrides):
    fam = replace({**SCENARIO_FAMILIES, **SHAPE_FAMILIES}[family], control_surveys=2, **overrides)
    sc = simulate_scenario(fam, seed)
    return sc, validate_site(sc.sensors, sc.readings, sc.survey, sc.controls)


def test_scenario_controls_level_the_survey_points_without_changing_the_site():
    sc, _ = _site("drift", 301)
    plain = simulate_scenario("drift", 301)
    pd.testing.assert_frame_equal(sc.readings, plain.readings)
    pd.testing.assert_frame_equal(sc.survey, plain.survey)
    assert plain.controls is None
    assert sc.controls.date.nunique() == 2 and set(sc.controls.x_m) == set(sc.survey.x_m)
    # a tilt (the far end lowered by the whole depth): where a survey point is a sensor (both ends at least), the
    # control minus the initial altitude is the true change exactly
    exact = simulate_scenario(replace(SHAPE_FAMILIES["tilt-healthy"], control_surveys=2, noise_free=True), 301)
    days = pd.DatetimeIndex(exact.truth.days).strftime("%Y-%m-%d").tolist()
    for date, g in exact.controls.groupby("date"):
        d = days.index(date)
        at = np.isin(g.x_m.to_numpy(), exact.truth.x)
        assert at.sum() >= 2 and exact.truth.settlement[d, -1] < -1e-3
        z0 = np.interp(g.x_m.to_numpy()[at], exact.truth.x, exact.truth.initial_z)
        truth = exact.truth.settlement[d, np.isin(exact.truth.x, g.x_m.to_numpy())]
        np.testing.assert_allclose(g.z_m.to_numpy()[at] - z0, truth, atol=1e-9)


def test_a_step_the_sensors_miss_is_named_and_a_bowl_is_not():
    """A transition (one side of the span lowered, the step's witnesses excluded as faults): the controls show it and
    the estimate warns; a bowl between stable ends with the same surveys: no warning (calibration seeds)."""
    _, site = _site("transition", 303)
    res = estimate_settlement(site, n_monte_carlo=0)
    assert res.control_check.disagree
    assert any(w.startswith("the control surveys disagree with the estimate") for w in res.warnings)
    _, site = _site("drift", 303)
    res = estimate_settlement(site, n_monte_carlo=0)
    assert res.control_check is not None and not res.control_check.disagree
    assert not any("control surveys" in w for w in res.warnings)


def test_control_points_left_out_are_named():
    from longprofile.rail._controls import unmatched_controls

    controls = pd.DataFrame({"date": ["2024-03-03", "2024-03-03", "2025-01-01", "2025-01-02"],
                             "x_m": [10.0, 99.0, 10.0, 10.0], "z_m": [100.0] * 4})
    t = compare_controls(controls, DAYS, X, np.zeros((3, 5)), np.full((3, 5), 1e-3), np.array([0.0, 20.0]),
                         np.array([100.0, 100.0]))
    msg = unmatched_controls(controls, t, DAYS)
    assert msg.startswith("3 of 4 control point(s) not compared with the estimate: 2 on day(s) without readings "
                          "(2025-01-01, 2025-01-02; the readings cover 2024-03-01 to 2024-03-03); 1 outside the span")
    assert unmatched_controls(controls.iloc[:1], t, DAYS) == "" and unmatched_controls(None, None, DAYS) == ""
    assert unmatched_controls(controls.iloc[2:], None, DAYS).startswith("2 of 2 control point(s)")
