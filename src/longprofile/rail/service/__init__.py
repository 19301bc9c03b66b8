"""Rail settlement monitoring service (issue 15): ingestion API, database, recompute, alarms, dashboard.

Needs the ``serve`` extra (``pip install 'longprofile[serve]'``); start it with ``longprofile rail serve``.
Importing this package imports nothing of the extra; the modules do:

_db         -- SQLAlchemy 2 models, ``Database(url)`` (SQLite WAL or PostgreSQL, Alembic migrations at start-up).
_core       -- sites, sensors, survey, thresholds, loggers, channels, users (audited) and ``ingest``.
_recompute  -- ``recompute(db, site)``: stored readings -> ``estimate_settlement`` -> versioned run and results.
_alarms     -- alarm levels (``settlement_alarms``), lifecycle, "no data", notification outbox and delivery.
_auth       -- password hashes, signed login cookies, CSRF tokens, roles.
_web        -- ``create_app(db)``: the FastAPI application (API and server-rendered pages).
_serve      -- ``serve`` (uvicorn), ``ServerThread``, the replay demo (``run_demo``).

See docs/rail-service.md.
"""
