"""The serving process's copy of the day cache (``Database.memo``): what a run stored is reused by the next run of
the same process instead of reading ``day_stats`` back, only while the table is still what that run committed, and
it is the same arrays the table gives, bit for bit (so every result is the same as with the table read)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from sqlalchemy import delete, select

from longprofile.rail.service import _core, _recompute
from longprofile.rail.service._db import Database, DayStat, ResultRow
from longprofile.rail.service._recompute import (
    _active_sensors,
    _day_cache_rows,
    _load_day_cache,
    _store_day_cache,
    recompute,
)

from .conftest import synthetic

NOW = 2_000_000_000


def _ingest(db, rows):
    for i in range(0, len(rows), 2000):
        _core.ingest(db, "mitt", rows.iloc[i:i + 2000].to_dict("records"), now=NOW)


def _setup(db):
    syn, r = synthetic()
    _core.create_site(db, "tester", "mitt", clock="data")
    _core.put_sensors(db, "tester", "mitt", syn.sensors.to_dict("records"))
    _core.put_survey(db, "tester", "mitt", syn.survey.to_dict("records"))
    return r


def _table_rows(db):
    with db.read() as s:
        st = s.scalar(select(_core.Site).where(_core.Site.name == "mitt"))
        return _day_cache_rows(s, st, None)


def _sorted(arr, lines):
    order = np.lexsort((arr[:, 1], arr[:, 0]))
    return arr[order], lines[order]


def _assert_memo_is_the_table(db):
    (_key, arr, lines), (t_arr, t_lines) = db.memo[("day_cache", _site_id(db))], _table_rows(db)
    (arr, lines), (t_arr, t_lines) = _sorted(arr, lines), _sorted(t_arr, t_lines)
    assert arr.shape == t_arr.shape and lines.shape == t_lines.shape
    for a, b in ((arr, t_arr), (lines, t_lines)):
        assert np.array_equal(a, b, equal_nan=True)
        assert np.array_equal(np.signbit(a), np.signbit(b))  # -0.0 as the database gives it back


def _site_id(db):
    with db.read() as s:
        return s.scalar(select(_core.Site.id).where(_core.Site.name == "mitt"))


def _with_negative_zeros(r):
    """One sensor reads exactly -0.0 deg and -0.0 degC on day 4 (its statistics hold -0.0, which SQLite gives back
    as 0.0)."""
    r = r.copy()
    on = (r["sensor_id"] == r["sensor_id"].iloc[0]) & (r["timestamp"].str[:10] == sorted(
        r["timestamp"].str[:10].unique())[4])
    r.loc[on, ["angle_deg", "temperature_c"]] = -0.0
    return r


def _steps(r):
    """Ingestion steps: the first 3 days, then one day at a time (5 steps), the second with a revision of day 3
    and a late reading of day 2."""
    days = sorted(r["timestamp"].str[:10].unique())
    assert len(days) == 8
    steps = [r[r["timestamp"].str[:10] < days[3]]]
    for k, d in enumerate(days[3:]):
        day = r[r["timestamp"].str[:10] == d]
        if k == 1:
            rev = r[r["timestamp"].str[:10] == days[2]].iloc[[100]].copy()
            rev["angle_deg"] = rev["angle_deg"] + 0.5
            late = day.iloc[:1].copy()
            late["timestamp"] = f"{days[1]}T12:34:56Z"
            day = pd.concat([day.iloc[1:], rev, late])
        steps.append(day)
    return steps


def _results(db, run_id):
    with db.read() as s:
        rows = s.execute(select(ResultRow.day, ResultRow.sensor_id, ResultRow.dz_m, ResultRow.dz_std_m,
                                ResultRow.smoothed_dz_m, ResultRow.smoothed_std_m, ResultRow.rate_m_per_day,
                                ResultRow.rate_std_m_per_day).where(ResultRow.run_id == run_id)).all()
    return pd.DataFrame(rows).sort_values(["day", "sensor_id"]).reset_index(drop=True)


class _TableReads:
    """Counts the day-cache table reads (``_float_columns`` with the median-line blob) of recompute."""

    def __init__(self, monkeypatch):
        self.n, real = 0, _recompute._float_columns

        def counted(*a, **k):
            self.n += bool(k.get("blob"))
            return real(*a, **k)

        monkeypatch.setattr(_recompute, "_float_columns", counted)


def test_the_memo_is_the_table_bit_for_bit_and_is_used(site, monkeypatch):
    db, _, r = site
    _core.update_site(db, "t", "mitt", baseline_start="2019-11-18", baseline_end="2019-11-21")
    reads = _TableReads(monkeypatch)
    for k, rows in enumerate(_steps(_with_negative_zeros(r))):
        _ingest(db, rows)
        before = reads.n
        out = recompute(db, "mitt")
        assert out["status"] == "ok", out["message"]
        assert reads.n == before  # first run: a full build; then the memo: never the table
        _assert_memo_is_the_table(db)


def test_results_equal_a_process_without_the_memo_and_other_writers_are_seen(tmp_path, monkeypatch):
    a, b = Database(f"sqlite:///{tmp_path}/a.db"), Database(f"sqlite:///{tmp_path}/b.db")
    r = _setup(a)
    _setup(b)
    reads = _TableReads(monkeypatch)
    steps = _steps(r)
    for k, rows in enumerate(steps[:3]):
        _ingest(a, rows), _ingest(b, rows)
        b.memo.clear()  # b: every run reads the table back, as a freshly started process does
        ra, rb = recompute(a, "mitt"), recompute(b, "mitt")
        assert ra["status"] == rb["status"] == "ok"
        pd.testing.assert_frame_equal(_results(a, ra["run_id"]), _results(b, rb["run_id"]), check_exact=True)
    # another process (a second Database on a's file) revises a reading and recomputes: the table has as many rows
    # as a's memo but other values, and a new data version; a's memo no longer matches
    other = Database(f"sqlite:///{tmp_path}/a.db")
    rev = r[r["timestamp"].str[:10] == sorted(r["timestamp"].str[:10].unique())[2]].iloc[[7]].copy()
    rev["angle_deg"] = rev["angle_deg"] - 0.3
    _ingest(other, rev), _ingest(b, rev)
    n_rows = len(_table_rows(a)[0])
    assert recompute(other, "mitt")["status"] == "ok"
    other.dispose()
    assert len(_table_rows(a)[0]) == n_rows
    _ingest(a, steps[3]), _ingest(b, steps[3])
    n = reads.n
    b.memo.clear()
    ra, rb = recompute(a, "mitt"), recompute(b, "mitt")
    assert reads.n == n + 2  # a read the table (the other writer's rows), as b did
    pd.testing.assert_frame_equal(_results(a, ra["run_id"]), _results(b, rb["run_id"]), check_exact=True)
    _assert_memo_is_the_table(a)
    # one (sensor, day) row removed behind a's back (same data version): the row count no longer matches, the
    # table is read
    with a.write() as s:
        pk, day = s.execute(select(DayStat.sensor_pk, DayStat.day).order_by(DayStat.day.desc()).limit(1)).one()
        s.execute(delete(DayStat).where(DayStat.sensor_pk == pk, DayStat.day == day))
    n = reads.n
    recompute(a, "mitt", force=True)
    assert reads.n == n + 1
    _assert_memo_is_the_table(a)
    a.dispose(), b.dispose()


def test_a_failed_store_leaves_the_memo_describing_the_table(tmp_path, monkeypatch):
    a, b = Database(f"sqlite:///{tmp_path}/a.db"), Database(f"sqlite:///{tmp_path}/b.db")
    r = _setup(a)
    _setup(b)
    steps = _steps(r)
    for db in (a, b):
        _ingest(db, steps[0])
        recompute(db, "mitt")
        _ingest(db, steps[1])
    real = _recompute.evaluate_result

    def fail(*args, **kw):
        raise RuntimeError("crash inside the store transaction")

    monkeypatch.setattr(_recompute, "evaluate_result", fail)
    with pytest.raises(RuntimeError):
        recompute(a, "mitt")  # rolled back: the day cache rows of this run were never committed
    monkeypatch.setattr(_recompute, "evaluate_result", real)
    _assert_memo_is_the_table(a)
    ra = recompute(a, "mitt")
    b.memo.clear()
    rb = recompute(b, "mitt")
    assert ra["status"] == rb["status"] == "ok"
    pd.testing.assert_frame_equal(_results(a, ra["run_id"]), _results(b, rb["run_id"]), check_exact=True)
    a.dispose(), b.dispose()


def test_a_stored_negative_zero_is_remembered_as_the_database_gives_it_back(site):
    """SQLite stores a REAL without fraction as an integer (-0.0 reads back as 0.0); PostgreSQL keeps -0.0. The
    memo of a store must be what the table then gives, on both."""
    db, _, r = site
    _ingest(db, r[r["timestamp"].str[:10] < "2019-11-22"])
    assert recompute(db, "mitt")["status"] == "ok"
    with db.write() as s:
        st = s.scalar(select(_core.Site).where(_core.Site.name == "mitt"))
        sens = _active_sensors(s, st)
        stats = _load_day_cache(s, st, sens, "linear")
        med = stats.raw_median_deg.copy()
        med[1, 2] = -0.0
        lines = stats.median_lines.copy()
        lines[1, 2, 0] = -0.0
        stats = replace(stats, raw_median_deg=med, median_lines=lines)
        key, arr, lines = _store_day_cache(s, st, sens, stats, None, list(range(len(sens))), "linear",
                                           st.data_version)
    t_arr, t_lines = _table_rows(db)
    (arr, lines), (t_arr, t_lines) = _sorted(arr, lines), _sorted(t_arr, t_lines)
    for a, b in ((arr, t_arr), (lines, t_lines)):
        assert np.array_equal(a, b, equal_nan=True)
        assert np.array_equal(np.signbit(a), np.signbit(b))
    assert np.signbit(t_lines).any()  # the median-line blob is bytes: -0.0 kept on every database


def test_a_writer_committing_between_a_runs_read_and_its_store_is_not_remembered_over(tmp_path, monkeypatch):
    """Another process's run commits while this run estimates (between its read of the cache and its store): this
    run must not remember rows it did not see; its next run equals a process without the memo."""
    a, b = Database(f"sqlite:///{tmp_path}/a.db"), Database(f"sqlite:///{tmp_path}/b.db")
    r = _setup(a)
    _setup(b)
    steps = _steps(r)
    days = sorted(r["timestamp"].str[:10].unique())
    for db in (a, b):
        _ingest(db, steps[0])
        recompute(db, "mitt")
        _ingest(db, steps[1])
    late = r[r["timestamp"].str[:10] == days[1]].iloc[[5]].copy()  # a revision of day 1: an earlier change
    late["angle_deg"] = late["angle_deg"] + 0.2
    real, busy = _recompute.estimate_settlement_from_daily, []

    def with_other_writer(*args, **kw):
        if not busy:
            busy.append(1)
            other = Database(f"sqlite:///{tmp_path}/a.db")
            _ingest(other, late)
            assert recompute(other, "mitt")["status"] == "ok"
            other.dispose()
        return real(*args, **kw)

    monkeypatch.setattr(_recompute, "estimate_settlement_from_daily", with_other_writer)
    assert recompute(a, "mitt")["status"] == "ok"
    assert busy
    monkeypatch.setattr(_recompute, "estimate_settlement_from_daily", real)
    entry = a.memo.get(("day_cache", _site_id(a)))
    assert entry is None or np.array_equal(_sorted(*entry[1:])[0], _sorted(*_table_rows(a))[0], equal_nan=True)
    # b: the same readings in the order they were committed, every run reading the table
    recompute(b, "mitt")
    _ingest(b, late)
    for db, rows in ((a, steps[2]), (b, steps[2])):
        _ingest(db, rows)
    ra = recompute(a, "mitt")
    b.memo.clear()
    rb = recompute(b, "mitt")
    assert ra["status"] == rb["status"] == "ok"
    _assert_memo_is_the_table(a)
    pd.testing.assert_frame_equal(_results(a, ra["run_id"]), _results(b, rb["run_id"]), check_exact=True)
    a.dispose(), b.dispose()
