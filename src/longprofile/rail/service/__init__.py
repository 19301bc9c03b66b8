"""Rail settlement monitoring service (issue 15): ingestion API, database, recompute, alarms, dashboard.

Needs the ``serve`` extra (``pip install 'longprofile[serve]'``); start it with ``longprofile rail serve``.
Importing this package imports nothing of the extra; the modules do:

_db         -- SQLAlchemy 2 models, ``Database(url)`` (SQLite WAL or PostgreSQL, Alembic migrations at start-up).
_core       -- sites, sensors, survey, control surveys, thresholds, loggers (keys revoked, rotated), channels, users
               (audited) and ``ingest``.
_events     -- declared re-installations and replacements of sensors (the events table of rail settle --events).
_recompute  -- ``recompute(db, site)``: stored readings -> ``estimate_settlement`` -> versioned run and results.
_alarms     -- alarm levels (``threshold_alarms``), lifecycle, "no data", notification outbox and delivery.
_auth       -- password hashes, signed login cookies, CSRF tokens, roles.
_web        -- ``create_app(db)``: the FastAPI application (API and server-rendered pages).
_serve      -- ``serve`` (uvicorn), ``ServerThread``, the replay demo (``run_demo``).

See docs/rail-service.md.
"""

from ..._lazy import lazy_namespace

#: Lazy public namespace (PEP 562): the CLI imports these names; nothing of the ``serve`` extra is imported until
#: one is used.
_EXPORTS = {
    "._db": ("Database",),
    "._core": ("add_channel", "remove_channel", "channel_status", "add_logger", "add_user", "user_exists", "audit_trail", "create_site", "delete_controls", "get_controls",
               "get_site", "ingest", "list_sites", "put_controls", "put_sensors", "put_survey", "revoke_logger",
               "rotate_logger", "set_threshold", "replace_thresholds", "threshold_rows", "update_site"),
    "._events": ("put_events", "delete_event", "get_events"),
    "._recompute": ("recompute",),
    "._alarms": ("Notifier", "list_alarms"),
    "._web": ("create_app",),
    "._serve": ("serve", "ServerThread", "HttpSession", "replay_demo", "seed_demo_site", "run_demo", "DEMO_USER",
                "DEMO_PASSWORD"),
}
__all__ = sorted(name for names in _EXPORTS.values() for name in names)
__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, __all__)
