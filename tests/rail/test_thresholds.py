"""Graded alarm thresholds (settlement, rate, twist x alert, action, alarm): rail.threshold_alarms, the thresholds
table of ``rail settle --thresholds``, and the report's statement when no threshold was set (issue 13)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, InputFormatError
from longprofile.io import read_rail_thresholds
from longprofile.rail import (
    THRESHOLD_RANGE_M,
    check_threshold,
    check_thresholds,
    settlement_alarms,
    threshold_alarms,
)

DAYS = pd.date_range("2020-01-01", periods=4).to_numpy()
IDS = ["A", "B", "C", "D", "E"]
X = np.array([0.0, 3.0, 6.0, 9.0, 12.0])


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), t=st.lists(st.floats(1e-3, 2e-2), min_size=3, max_size=3),
       p=st.floats(0.05, 0.95))
@example(seed=1256, t=[0.015625] * 3, p=0.5)  # no twist alarm: the empty reference had object columns (allclose raised)
def test_levels_are_nested_and_each_level_is_settlement_alarms(seed, t, p):
    rng = np.random.default_rng(seed)
    mean = rng.normal(0.0, 0.01, (4, 5))
    std = rng.uniform(5e-4, 4e-3, (4, 5))
    rate, rate_std = rng.normal(0.0, 2e-3, (4, 5)), rng.uniform(2e-4, 1e-3, (4, 5))
    lo, mid, hi = sorted(t)
    thr = {"settlement": {"alert": lo, "action": mid, "alarm": hi}, "rate": {"alert": lo / 4}, "twist": {"alarm": mid}}
    a = threshold_alarms(DAYS, IDS, X, mean, std, thr, rate=rate, rate_std=rate_std, min_probability=p)
    key = ["date", "sensor_id"]
    sets = {lv: set(map(tuple, a[(a.kind == "settlement") & (a.level == lv)][key].to_numpy())) for lv in thr["settlement"]}
    assert sets["alarm"] <= sets["action"] <= sets["alert"]  # a higher threshold is exceeded less often
    for lv, v in thr["settlement"].items():  # each level is settlement_alarms at its threshold (the same rows)
        ref = settlement_alarms(DAYS, IDS, X, mean, std, threshold_m=v, min_probability=p)
        got = a[(a.kind == "settlement") & (a.level == lv)].drop(columns="level").reset_index(drop=True)
        pd.testing.assert_frame_equal(got, ref.reset_index(drop=True), check_dtype=False)
    ref = settlement_alarms(DAYS, IDS, X, mean, std, rate=rate, rate_std=rate_std, rate_threshold_m_per_day=lo / 4,
                            min_probability=p)
    assert len(a[a.kind == "rate"]) == len(ref)
    # twist: the difference of neighbours' changes with the std of independent errors, between the pair
    tw = a[a.kind == "twist"]
    d = np.diff(mean, axis=1)
    s = np.hypot(std[:, 1:], std[:, :-1])
    ref = settlement_alarms(DAYS, [f"{u}|{v}" for u, v in zip(IDS[:-1], IDS[1:])], 0.5 * (X[1:] + X[:-1]), d, s,
                            threshold_m=mid, min_probability=p)
    assert list(tw["sensor_id"]) == list(ref["sensor_id"]) and np.allclose(tw["value"], ref["value"])
    assert set(a["level"]) <= {"alert", "action", "alarm"}


def test_check_thresholds_refuses_what_a_user_gets_wrong():
    assert check_thresholds({"settlement": {"alert": 0.01, "alarm": 0.02}}) == {"settlement": {"alert": 0.01, "alarm": 0.02}}
    for bad, msg in [({"heave": {"alert": 0.01}}, "unknown threshold quantity"),
                     ({"settlement": {"panic": 0.01}}, "unknown threshold level"),
                     ({"settlement": {"alert": 0.02, "alarm": 0.01}}, "must grow"),
                     ({"settlement": {"alert": 10.0}}, "not plausible"),  # mm given as m
                     ({"rate": {"alert": 2e-6}}, "not plausible"),  # m/day given as km/day, or mm as m twice
                     ({"twist": {"alert": float("nan")}}, "> 0"),
                     ([("settlement", 0.01)], "mapping")]:
        with pytest.raises(InputError, match=msg):
            check_thresholds(bad)
    assert check_threshold(THRESHOLD_RANGE_M[1]) == 1.0


def test_thresholds_table_is_read_in_mm_and_checked(tmp_path):
    f = tmp_path / "thr.csv"
    f.write_text("quantity,level,value_mm\nsettlement,alert,10\nsettlement,alarm,20\nrate,alert,2\ntwist,action,4\n")
    assert read_rail_thresholds(f) == {"settlement": {"alert": 0.01, "alarm": 0.02}, "rate": {"alert": 0.002},
                                       "twist": {"action": 0.004}}
    for text, msg in [("quantity,level,value_mm\nsettlement,alert,10\nsettlement,alert,12\n", "given twice"),
                      ("quantity,level,value_mm\nsettlement,alert,0.001\n", "metres under value_mm"),
                      ("quantity,level,value\nsettlement,alert,10\n", "value_mm"),
                      ("quantity,level,value_mm,note\nsettlement,alert,10,x\n", "unknown column"),
                      ("quantity,level,value_mm\nsettlement,alert,abc\n", "value_mm"),
                      ("quantity,level,value_mm\nsettlement,orange,10\n", "level 'orange'")]:
        f.write_text(text)
        with pytest.raises(InputFormatError, match=msg):
            read_rail_thresholds(f)


def test_settle_with_a_thresholds_file_and_without_any(tmp_path, capsys):
    from longprofile.cli.app import main

    site = tmp_path / "site"
    assert main(["rail", "simulate", "--preset", "mittersheim-like", "--days", "8", "-o", str(site)]) == 0
    base = ["rail", "settle", "--sensors", str(site / "sensors.csv"), "--readings", str(site / "readings.csv"),
            "--survey", str(site / "survey.csv"), "--monte-carlo", "0"]
    capsys.readouterr()
    assert main(base + ["-o", str(tmp_path / "a.csv"), "--report", str(tmp_path / "ra")]) == 0
    assert "no alarm thresholds set" in capsys.readouterr().err  # the console line (stderr)
    page = (tmp_path / "ra" / "index.html").read_text()
    assert "No alarm thresholds were set" in page
    thr = tmp_path / "thr.csv"
    thr.write_text("quantity,level,value_mm\nsettlement,alert,2\nsettlement,alarm,6\n")
    assert main(base + ["-o", str(tmp_path / "b.csv"), "--report", str(tmp_path / "rb"), "--thresholds", str(thr)]) == 0
    out = capsys.readouterr().err
    alarms = pd.read_csv(tmp_path / "rb" / "alarms.csv")
    assert f"{len(alarms)} alarm(s)" in " ".join(out.split()) and len(alarms) > 0
    assert set(alarms["level"]) <= {"alert", "alarm"} and set(alarms["kind"]) == {"settlement"}
    page = (tmp_path / "rb" / "index.html").read_text()
    assert "No alarm thresholds were set" not in page and "settlement alarm 6 mm" in page
    # the alert rows are those of the single threshold of the same value
    assert main(base + ["-o", str(tmp_path / "c.csv"), "--report", str(tmp_path / "rc"),
                        "--settlement-threshold-mm", "2"]) == 0
    single = pd.read_csv(tmp_path / "rc" / "alarms.csv")
    alert = alarms[alarms.level == "alert"].drop(columns="level").reset_index(drop=True)
    pd.testing.assert_frame_equal(alert, single.reset_index(drop=True))
    assert main(base + ["-o", str(tmp_path / "d.csv"), "--thresholds", str(thr), "--settlement-threshold-mm", "2"]) == 2
    assert "not both" in capsys.readouterr().err and not (tmp_path / "d.csv").exists()
