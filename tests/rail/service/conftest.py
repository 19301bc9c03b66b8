"""Fixtures of the rail monitoring service tests: SQLite always, PostgreSQL when LONGPROFILE_TEST_PG_URL is set.

Locally a missing PostgreSQL server or Chromium skips those tests with the reason printed; with
LONGPROFILE_REQUIRE_SERVICES=1 (set by .ci/run) it fails them instead.
"""

from __future__ import annotations

import os

import pytest

pytest.importorskip("fastapi", reason="the service tests need the serve extra (pip install -e '.[test]')")
pytest.importorskip("sqlalchemy")

import pandas as pd  # noqa: E402

REQUIRE = os.environ.get("LONGPROFILE_REQUIRE_SERVICES") == "1"
PG_URL = os.environ.get("LONGPROFILE_TEST_PG_URL")


def missing_service(reason: str):
    if REQUIRE:
        pytest.fail(f"{reason} (LONGPROFILE_REQUIRE_SERVICES=1: the service must be there)")
    print(f"SKIP: {reason}")
    pytest.skip(reason)


_WORKER_PG_URLS: dict = {}


def _worker_pg_url(url):
    """The test database of this pytest-xdist worker: ``<name>_<worker>`` on the same server, created on first use
    (the workers' tests drop and recreate the schema, so they must not share a database); ``url`` itself when
    the suite runs in one process."""
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    if not worker:
        return url
    if url not in _WORKER_PG_URLS:
        from sqlalchemy import create_engine, text
        from sqlalchemy.engine import make_url

        base = make_url(url)
        name = f"{base.database}_{worker}"
        eng = create_engine(base, isolation_level="AUTOCOMMIT")
        with eng.connect() as c:
            if not c.execute(text("SELECT 1 FROM pg_database WHERE datname = :n"), {"n": name}).scalar():
                c.execute(text(f'CREATE DATABASE "{name}"'))
        eng.dispose()
        _WORKER_PG_URLS[url] = base.set(database=name).render_as_string(hide_password=False)
    return _WORKER_PG_URLS[url]


def _clean_pg(url):
    from sqlalchemy import create_engine, text

    eng = create_engine(url.replace("postgresql://", "postgresql+psycopg://", 1) if url.startswith("postgresql://")
                        else url)
    with eng.begin() as c:
        c.execute(text("DROP SCHEMA public CASCADE"))
        c.execute(text("CREATE SCHEMA public"))
    eng.dispose()


@pytest.fixture(params=["sqlite", "postgresql"])
def db_url(request, tmp_path):
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path}/site.db"
    if not PG_URL:
        missing_service("PostgreSQL: LONGPROFILE_TEST_PG_URL is not set (.ci/run starts a throwaway cluster)")
    try:
        url = _worker_pg_url(PG_URL)
        _clean_pg(url)
    except Exception as exc:  # noqa: BLE001
        missing_service(f"PostgreSQL at LONGPROFILE_TEST_PG_URL is not reachable: {type(exc).__name__}: {exc}")
    return url


@pytest.fixture
def db(db_url):
    from longprofile.rail.service._db import Database

    d = Database(db_url)
    yield d
    d.dispose()


_SYN = {}


def synthetic(n_days=8, sampling_minutes=60.0):
    key = (n_days, sampling_minutes)
    if key not in _SYN:
        from longprofile.rail import simulate_site

        syn = simulate_site("mittersheim-like", seed=0, sampling_minutes=sampling_minutes, n_days=n_days)
        r = syn.readings.copy()
        r["timestamp"] = pd.to_datetime(r["timestamp"]).dt.strftime("%Y-%m-%dT%H:%M:%SZ")
        _SYN[key] = (syn, r)
    return _SYN[key]


@pytest.fixture
def site(db):
    """A site "mitt" with 58 sensors, a survey, a logger key; returns (db, key, readings as ISO rows)."""
    from longprofile.rail.service import _core

    syn, r = synthetic()
    _core.create_site(db, "tester", "mitt", clock="data")
    _core.put_sensors(db, "tester", "mitt", syn.sensors.to_dict("records"))
    _core.put_survey(db, "tester", "mitt", syn.survey.to_dict("records"))
    key = _core.add_logger(db, "tester", "mitt", "logger-1")
    return db, key, r


def count_readings(db, site="mitt"):
    from longprofile.rail.service._core import reading_count

    return reading_count(db, site)
