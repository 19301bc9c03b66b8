"""Database layer of the rail monitoring service: SQLAlchemy 2 models, engine (SQLite WAL or PostgreSQL), migrations.

Times are stored as integer seconds since 1970-01-01 UTC (``*_ts`` columns): exact equality for the
idempotency key (sensor, timestamp), the same on SQLite and PostgreSQL, and fast range queries.
"""

from __future__ import annotations

import json
import threading
import time
from contextlib import contextmanager
from pathlib import Path

from sqlalchemy import (
    BigInteger,
    Boolean,
    Float,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    String,
    Text,
    UniqueConstraint,
    create_engine,
    event,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, sessionmaker

from ...errors import InputError
from .. import THRESHOLD_LEVELS, THRESHOLD_QUANTITIES

__all__ = ["Base", "Database", "now_ts", "LEVELS", "QUANTITIES", "ROLES"]

#: Alarm levels, lowest first (index + 1 = severity).
LEVELS = THRESHOLD_LEVELS  # the library's (rail/_thresholds.py): rail settle --thresholds takes the same
#: Quantities that carry three thresholds per site (m, m/day, m).
QUANTITIES = THRESHOLD_QUANTITIES
ROLES = ("viewer", "engineer", "admin")


def now_ts() -> int:
    return int(time.time())


class Base(DeclarativeBase):
    pass


class Site(Base):
    __tablename__ = "sites"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(64), unique=True)
    title: Mapped[str] = mapped_column(String(200), default="")
    baseline_start_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    baseline_end_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    no_data_hours: Mapped[float] = mapped_column(Float, default=6.0)
    # "wall": staleness against the clock; "data": against the newest reading of the site (replays)
    clock: Mapped[str] = mapped_column(String(8), default="wall")
    # IANA zone of the loggers' clocks: a time without a UTC offset is read in it (docs/rail-service.md)
    timezone: Mapped[str] = mapped_column(String(64), default="UTC", server_default="UTC")
    settings_json: Mapped[str] = mapped_column(Text, default="{}")
    dirty_from_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    data_version: Mapped[int] = mapped_column(BigInteger, default=0)
    created_ts: Mapped[int] = mapped_column(BigInteger, default=now_ts)

    @property
    def settings(self) -> dict:
        return json.loads(self.settings_json or "{}")


class Sensor(Base):
    __tablename__ = "sensors"
    __table_args__ = (UniqueConstraint("site_id", "sensor_id", name="uq_sensor_site_sid"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"), index=True)
    sensor_id: Mapped[str] = mapped_column(String(64))
    x_m: Mapped[float] = mapped_column(Float)
    z_m: Mapped[float | None] = mapped_column(Float, nullable=True)
    active: Mapped[bool] = mapped_column(Boolean, default=True)
    #: when the sensor was registered (NULL for sensors registered before 2026-12-07): the no-data grace period
    created_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    #: when it was last made inactive (NULL while active, or inactive before 2026-12-07)
    deactivated_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)


class SurveyPoint(Base):
    __tablename__ = "survey_points"
    __table_args__ = (UniqueConstraint("site_id", "x_m", name="uq_survey_site_x"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"), index=True)
    x_m: Mapped[float] = mapped_column(Float)
    z_m: Mapped[float] = mapped_column(Float)


class ControlPoint(Base):
    """A point of a control (levelling) survey of the track: altitude ``z_m`` at ``x_m`` on ``date``
    (``YYYY-MM-DD``, UTC), the ``controls`` table of ``rail settle``."""
    __tablename__ = "control_points"
    __table_args__ = (UniqueConstraint("site_id", "date", "x_m", name="uq_control_site_date_x"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"), index=True)
    date: Mapped[str] = mapped_column(String(10))
    x_m: Mapped[float] = mapped_column(Float)
    z_m: Mapped[float] = mapped_column(Float)


class SensorEvent(Base):
    """A declared re-installation (``event`` "reinstalled") or replacement ("replaced_by" ``new_id``) of a sensor on
    ``date`` (``YYYY-MM-DD``, UTC): a row of the events table of ``rail settle --events``."""
    __tablename__ = "sensor_events"
    __table_args__ = (UniqueConstraint("site_id", "sensor_id", "date", name="uq_event_site_sensor_date"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"), index=True)
    sensor_id: Mapped[str] = mapped_column(String(64))
    date: Mapped[str] = mapped_column(String(10))
    event: Mapped[str] = mapped_column(String(16))
    new_id: Mapped[str] = mapped_column(String(64), default="")


class Threshold(Base):
    __tablename__ = "thresholds"
    __table_args__ = (UniqueConstraint("site_id", "quantity", "level", name="uq_threshold"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"), index=True)
    quantity: Mapped[str] = mapped_column(String(16))
    level: Mapped[str] = mapped_column(String(16))
    value: Mapped[float] = mapped_column(Float)  # m (settlement, twist) or m/day (rate), on |value|


class Logger(Base):
    __tablename__ = "loggers"
    __table_args__ = (UniqueConstraint("site_id", "name", name="uq_logger_site_name"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"), index=True)
    name: Mapped[str] = mapped_column(String(64))
    key_id: Mapped[str] = mapped_column(String(32), unique=True)
    key_hash: Mapped[str] = mapped_column(String(128))
    active: Mapped[bool] = mapped_column(Boolean, default=True)


class Reading(Base):
    __tablename__ = "readings"
    __table_args__ = (UniqueConstraint("sensor_pk", "ts", name="uq_reading_key"),
                      Index("ix_readings_site_ts", "site_id", "ts"))
    id: Mapped[int] = mapped_column(BigInteger().with_variant(Integer, "sqlite"), primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"))
    sensor_pk: Mapped[int] = mapped_column(ForeignKey("sensors.id"))
    ts: Mapped[int] = mapped_column(BigInteger)
    angle_deg: Mapped[float | None] = mapped_column(Float, nullable=True)
    temperature_c: Mapped[float | None] = mapped_column(Float, nullable=True)
    revision: Mapped[int] = mapped_column(Integer, default=0)
    batch_id: Mapped[int] = mapped_column(ForeignKey("batches.id"))


class ReadingRevision(Base):
    """Every superseded value of a reading (never a silent overwrite)."""
    __tablename__ = "reading_revisions"
    id: Mapped[int] = mapped_column(BigInteger().with_variant(Integer, "sqlite"), primary_key=True)
    reading_id: Mapped[int] = mapped_column(ForeignKey("readings.id"), index=True)
    revision: Mapped[int] = mapped_column(Integer)
    angle_deg: Mapped[float | None] = mapped_column(Float, nullable=True)
    temperature_c: Mapped[float | None] = mapped_column(Float, nullable=True)
    batch_id: Mapped[int] = mapped_column(ForeignKey("batches.id"))
    superseded_by_batch_id: Mapped[int] = mapped_column(ForeignKey("batches.id"))


class Batch(Base):
    __tablename__ = "batches"
    # a logger's newest batch by arrival and by reading, one index seek per logger (the logger no-data alarm)
    __table_args__ = (Index("ix_batches_logger_received", "logger_id", "received_ts"),
                      Index("ix_batches_logger_last_reading", "logger_id", "last_reading_ts"))
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"), index=True)
    logger_id: Mapped[int | None] = mapped_column(ForeignKey("loggers.id"), nullable=True)
    received_ts: Mapped[int] = mapped_column(BigInteger, default=now_ts)
    n_accepted: Mapped[int] = mapped_column(Integer, default=0)
    n_duplicate: Mapped[int] = mapped_column(Integer, default=0)
    n_revised: Mapped[int] = mapped_column(Integer, default=0)
    n_rejected: Mapped[int] = mapped_column(Integer, default=0)
    #: the newest reading time of the batch's rows for known, active sensors (accepted, duplicate or revised): the
    #: logger's newest reading on a clock="data" site (logger no-data alarm); None when every row was rejected
    last_reading_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)


class Audit(Base):
    __tablename__ = "audit"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    ts: Mapped[int] = mapped_column(BigInteger, default=now_ts)
    actor: Mapped[str] = mapped_column(String(64))
    site_id: Mapped[int | None] = mapped_column(Integer, nullable=True, index=True)
    entity: Mapped[str] = mapped_column(String(32))
    key: Mapped[str] = mapped_column(String(200))
    action: Mapped[str] = mapped_column(String(16))
    old_json: Mapped[str | None] = mapped_column(Text, nullable=True)
    new_json: Mapped[str | None] = mapped_column(Text, nullable=True)


class User(Base):
    __tablename__ = "users"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    username: Mapped[str] = mapped_column(String(64), unique=True)
    password_hash: Mapped[str] = mapped_column(String(256))
    role: Mapped[str] = mapped_column(String(16))
    active: Mapped[bool] = mapped_column(Boolean, default=True)


class Secret(Base):
    __tablename__ = "secrets"
    name: Mapped[str] = mapped_column(String(32), primary_key=True)
    value: Mapped[str] = mapped_column(String(256))


class Run(Base):
    __tablename__ = "runs"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"), index=True)
    started_ts: Mapped[int] = mapped_column(BigInteger, default=now_ts)
    finished_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    code_version: Mapped[str] = mapped_column(String(64))
    settings_hash: Mapped[str] = mapped_column(String(64))
    data_version: Mapped[int] = mapped_column(BigInteger)  # watermark: the site's data version read
    data_complete_to_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    changed_from_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    n_readings: Mapped[int] = mapped_column(Integer, default=0)
    n_days: Mapped[int] = mapped_column(Integer, default=0)
    status: Mapped[str] = mapped_column(String(16), default="running")
    message: Mapped[str] = mapped_column(Text, default="")
    warnings_json: Mapped[str] = mapped_column(Text, default="[]")
    #: "all-days" or "per-day" (docs/rail-service.md, "Which settlement model"); NULL for runs before 2026-12-06
    model: Mapped[str | None] = mapped_column(String(16), nullable=True)


class ResultRow(Base):
    __tablename__ = "results"
    __table_args__ = (Index("ix_results_run_day", "run_id", "day"), Index("ix_results_run_sensor", "run_id", "sensor_id"))
    id: Mapped[int] = mapped_column(BigInteger().with_variant(Integer, "sqlite"), primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"))
    day: Mapped[str] = mapped_column(String(10))
    sensor_id: Mapped[str] = mapped_column(String(64))
    x_m: Mapped[float] = mapped_column(Float)
    status: Mapped[str] = mapped_column(String(16))
    dz_m: Mapped[float] = mapped_column(Float)
    dz_std_m: Mapped[float] = mapped_column(Float)
    smoothed_dz_m: Mapped[float | None] = mapped_column(Float, nullable=True)
    smoothed_std_m: Mapped[float | None] = mapped_column(Float, nullable=True)
    rate_m_per_day: Mapped[float | None] = mapped_column(Float, nullable=True)
    rate_std_m_per_day: Mapped[float | None] = mapped_column(Float, nullable=True)


class ControlComparison(Base):
    """A run's comparison of its settlement with the control surveys (``SettlementResult.controls``)."""
    __tablename__ = "control_comparisons"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), index=True)
    date: Mapped[str] = mapped_column(String(10))
    x_m: Mapped[float] = mapped_column(Float)
    dz_control_m: Mapped[float] = mapped_column(Float)
    dz_estimate_m: Mapped[float] = mapped_column(Float)
    std_m: Mapped[float] = mapped_column(Float)
    inside_90: Mapped[bool] = mapped_column(Boolean)


class DayCache(Base):
    """State of a site's per-day statistics cache (``day_stats``): the key of what shaped it (thermal model,
    reference temperature, baseline start), and the data version it was last updated from."""
    __tablename__ = "day_cache"
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"), primary_key=True)
    key: Mapped[str] = mapped_column(String(64))
    data_version: Mapped[int] = mapped_column(BigInteger)
    updated_ts: Mapped[int] = mapped_column(BigInteger, default=now_ts)


class DayStat(Base):
    """Per (sensor, day) statistics of ``longprofile.rail.day_statistics`` (fields of ``DayStatistics``)."""
    __tablename__ = "day_stats"
    __table_args__ = (Index("ix_day_stats_site_day", "site_id", "day"),)
    sensor_pk: Mapped[int] = mapped_column(ForeignKey("sensors.id"), primary_key=True)
    day: Mapped[int] = mapped_column(Integer, primary_key=True)  # days since 1970-01-01 UTC
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"))
    n_raw: Mapped[int] = mapped_column(Integer)
    raw_median_deg: Mapped[float | None] = mapped_column(Float, nullable=True)
    raw_spread_deg: Mapped[float | None] = mapped_column(Float, nullable=True)
    noise_used_deg: Mapped[float | None] = mapped_column(Float, nullable=True)
    n_dev_below: Mapped[int] = mapped_column(Integer)
    n_dev_at_most: Mapped[int] = mapped_column(Integer)
    n_dev_nonzero: Mapped[int] = mapped_column(Integer, default=0)
    n_outliers: Mapped[int] = mapped_column(Integer)
    n_kept: Mapped[int] = mapped_column(Integer)
    thermal_slope: Mapped[float | None] = mapped_column(Float, nullable=True)
    coef_deg_per_c: Mapped[float | None] = mapped_column(Float, nullable=True)
    median_deg: Mapped[float | None] = mapped_column(Float, nullable=True)
    median_temp_c: Mapped[float | None] = mapped_column(Float, nullable=True)
    temp_range_c: Mapped[float | None] = mapped_column(Float, nullable=True)
    temperature_sum_c: Mapped[float | None] = mapped_column(Float, nullable=True)
    n_temperature: Mapped[int] = mapped_column(Integer)
    last_ts: Mapped[int] = mapped_column(BigInteger)
    n_below_lines: Mapped[int] = mapped_column(Integer, default=0)
    median_window_deg_per_c: Mapped[float | None] = mapped_column(Float, nullable=True)
    # DayStatistics.median_lines of the day: 2 MEDIAN_LINES little-endian float64 (angles, then temperatures)
    median_lines: Mapped[bytes | None] = mapped_column(LargeBinary, nullable=True)


class HealthRow(Base):
    __tablename__ = "health"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id"), index=True)
    sensor_id: Mapped[str] = mapped_column(String(64))
    status: Mapped[str] = mapped_column(String(16))
    reason: Mapped[str] = mapped_column(Text, default="")
    last_reading_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)


class Alarm(Base):
    __tablename__ = "alarms"
    __table_args__ = (Index("ix_alarms_site_state", "site_id", "state"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"))
    quantity: Mapped[str] = mapped_column(String(16))  # settlement, rate, twist, no_data, health
    subject: Mapped[str] = mapped_column(String(140))  # "site" or a sensor id
    level: Mapped[str] = mapped_column(String(16))
    state: Mapped[str] = mapped_column(String(16), default="raised")  # raised, acknowledged, cleared
    # one open alarm per (site, quantity, subject): open_key is set while open, NULL once cleared
    open_key: Mapped[str | None] = mapped_column(String(200), unique=True, nullable=True)
    value: Mapped[float | None] = mapped_column(Float, nullable=True)
    threshold: Mapped[float | None] = mapped_column(Float, nullable=True)
    day: Mapped[str | None] = mapped_column(String(10), nullable=True)
    message: Mapped[str] = mapped_column(Text, default="")
    raised_ts: Mapped[int] = mapped_column(BigInteger, default=now_ts)
    raised_run_id: Mapped[int | None] = mapped_column(Integer, nullable=True)
    ack_by: Mapped[str | None] = mapped_column(String(64), nullable=True)
    ack_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    ack_comment: Mapped[str | None] = mapped_column(Text, nullable=True)
    cleared_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    cleared_reason: Mapped[str | None] = mapped_column(Text, nullable=True)


class Channel(Base):
    """Where a site's notifications go: kind "webhook" (URL) or "smtp" (address; server in settings)."""
    __tablename__ = "channels"
    __table_args__ = (UniqueConstraint("site_id", "kind", "target", name="uq_channel"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("sites.id"), index=True)
    kind: Mapped[str] = mapped_column(String(16))
    target: Mapped[str] = mapped_column(String(300))


class Outbox(Base):
    __tablename__ = "outbox"
    __table_args__ = (Index("ix_outbox_pending", "sent_ts"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    key: Mapped[str] = mapped_column(String(64), unique=True)  # idempotency key sent with the notification
    alarm_id: Mapped[int] = mapped_column(ForeignKey("alarms.id"))
    event: Mapped[str] = mapped_column(String(16))  # raised, cleared
    kind: Mapped[str] = mapped_column(String(16))
    target: Mapped[str] = mapped_column(String(300))
    payload_json: Mapped[str] = mapped_column(Text)
    created_ts: Mapped[int] = mapped_column(BigInteger, default=now_ts)
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    next_try_ts: Mapped[int] = mapped_column(BigInteger, default=0)
    sent_ts: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    last_error: Mapped[str | None] = mapped_column(Text, nullable=True)


MIGRATIONS = Path(__file__).with_name("migrations")


class Database:
    """An engine, a session factory and the write lock; ``Database(url)`` migrates the schema to the head."""

    def __init__(self, url: str, *, migrate: bool = True):
        if not isinstance(url, str) or "://" not in url:
            raise InputError(f"database URL {url!r}: expected e.g. sqlite:///site.db or "
                             "postgresql+psycopg://user@127.0.0.1:5432/db.")
        if url.startswith("postgresql://"):
            url = "postgresql+psycopg://" + url[len("postgresql://"):]
        self.url = url
        self.is_sqlite = url.startswith("sqlite")
        if self.is_sqlite:
            self.engine = create_engine(url, connect_args={"check_same_thread": False, "timeout": 60})

            @event.listens_for(self.engine, "connect")
            def _pragmas(dbapi_conn, _record):
                dbapi_conn.isolation_level = None  # SQLAlchemy emits BEGIN itself (below)
                cur = dbapi_conn.cursor()
                cur.execute("PRAGMA journal_mode=WAL")
                cur.execute("PRAGMA synchronous=FULL")  # a commit survives a power cut, not just kill -9
                cur.execute("PRAGMA foreign_keys=ON")
                cur.execute("PRAGMA busy_timeout=60000")
                cur.close()

            @event.listens_for(self.engine, "begin")
            def _begin(conn):
                conn.exec_driver_sql("BEGIN")
        else:
            self.engine = create_engine(url, pool_size=10, max_overflow=20, pool_pre_ping=True)
        self.Session = sessionmaker(self.engine, expire_on_commit=False)
        # SQLite has one writer: serialise this process's write transactions (no SQLITE_BUSY upgrades)
        self._write_lock = threading.RLock() if self.is_sqlite else None
        #: this process's copies of committed tables it wrote, each checked against the database before use
        #: (the recompute's day cache: ``_recompute._day_cache_rows``)
        self.memo: dict = {}
        if migrate:
            self.migrate()

    def migrate(self):
        """Upgrade the schema to the newest migration (Alembic, run programmatically)."""
        from alembic import command
        from alembic.config import Config

        cfg = Config()
        cfg.set_main_option("script_location", str(MIGRATIONS))
        with self.engine.begin() as conn:
            cfg.attributes["connection"] = conn
            command.upgrade(cfg, "head")

    @contextmanager
    def write(self):
        """A session for a write transaction; commits on exit (the caller acknowledges only after this)."""
        lock = self._write_lock
        if lock is not None:
            lock.acquire()
        try:
            with self.Session() as s, s.begin():
                yield s
        finally:
            if lock is not None:
                lock.release()

    @contextmanager
    def read(self):
        with self.Session() as s:
            yield s

    def dispose(self):
        self.engine.dispose()
