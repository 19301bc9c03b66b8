"""``longprofile rail serve`` and ``longprofile rail site ...``: the settlement monitoring service (issue 15).

Thin commands: each reads its options, makes one call to ``longprofile.rail.service`` and prints the outcome.
"""

from __future__ import annotations

import getpass
import json
import os
from contextlib import contextmanager
from pathlib import Path

import typer

from ._common import console

__all__ = ["register", "site_app"]

site_app = typer.Typer(help="Manage monitored sites: sensors, survey, control surveys, sensor events, thresholds, "
                            "loggers, channels, users, audit.",
                       no_args_is_help=True)

DB_OPT = typer.Option(..., "--db", help="Database URL: sqlite:///site.db or postgresql://user@host:port/db.")
ACTOR_OPT = typer.Option(None, "--actor", help="Name recorded in the audit trail (default: cli:<login>).")


def _db(url, *, existing: bool = False):
    """The service database; ``existing``: a SQLite file must already exist (a read or a change of what a site
    has: a mistyped path would create an empty database and show no sites)."""
    from ..errors import DependencyError, InputError

    try:
        from ..rail.service import Database
    except ImportError as exc:
        raise DependencyError(f"the service needs the serve extra: pip install 'longprofile[serve]' ({exc}).") from None
    path = _sqlite_path(url)
    if existing and path is not None and not Path(path).exists():
        raise InputError(f"no such database: {path} does not exist (create a site first with rail site create).")
    return Database(url)


def _sqlite_path(url) -> str | None:
    """The file of a ``sqlite:///...`` URL (None for another database or an in-memory one)."""
    if not isinstance(url, str) or not url.startswith("sqlite:///"):
        return None
    path = url[len("sqlite:///"):].split("?", 1)[0]
    return None if path in ("", ":memory:") else path


def _actor(actor):
    if actor:
        return actor
    try:
        return f"cli:{getpass.getuser()}"
    except Exception:  # noqa: BLE001
        return "cli"


def _rows(path: Path, kind: str, text=()):
    from ..io import read_rail_table

    t = read_rail_table(path, kind)  # as rail settle reads it: any letter case, declared units converted
    for c in text:  # e.g. dates as written (a Parquet date column is a timestamp)
        if c in t.columns:
            t[c] = [v if v is None or isinstance(v, str) else str(v) for v in t[c]]
    return t.to_dict("records")


def _print(obj):
    typer.echo(json.dumps(obj, indent=2, default=str))


def serve_command(
    db: str = typer.Option(None, "--db", help="Database URL: sqlite:///site.db (default for --demo: a temporary "
                                              "file) or postgresql://user@host:port/db."),
    host: str = typer.Option("127.0.0.1", "--host", help="Interface to listen on."),
    port: int = typer.Option(8000, "--port", help="TCP port."),
    demo: bool = typer.Option(False, "--demo", help="Seed a synthetic site, replay its readings day by day through "
                                                    "the API and keep serving (log in as demo / demo-password)."),
    smtp_host: str = typer.Option("127.0.0.1", "--smtp-host", help="SMTP server for e-mail channels."),
    smtp_port: int = typer.Option(25, "--smtp-port", help="SMTP port."),
    smtp_from: str = typer.Option("longprofile@localhost", "--smtp-from", help="Sender of notification e-mails."),
    tick: float = typer.Option(2.0, "--tick", help="Seconds between recompute / no-data / outbox passes."),
):
    """Serve the monitoring service: ingestion API, dashboard, recompute worker and notification outbox."""
    from ..errors import InputError
    from ..rail.service import Notifier

    notifier = Notifier(smtp_host=smtp_host, smtp_port=smtp_port, smtp_from=smtp_from)
    if not demo:
        if db is None:
            raise InputError("--db is required (e.g. --db sqlite:///site.db), unless --demo.")
        from ..rail.service import serve

        console.print(f"serving {db} on http://{host}:{port}/ (Ctrl-C stops)")
        serve(db, host=host, port=port, notifier=notifier, tick_s=tick)
        return
    with _demo_database(db) as db:
        _serve_demo(db, port, tick, notifier)


def _serve_demo(db: str, port: int, tick: float, notifier) -> None:
    """Seed the demo site in ``db``, replay its readings through the API, keep serving until Ctrl-C."""
    import time

    from ..rail.service import DEMO_PASSWORD, DEMO_USER, ServerThread, replay_demo, seed_demo_site

    database = _db(db)
    try:
        key, readings, _ = seed_demo_site(database)
        with ServerThread(database, port=port, tick_s=min(tick, 0.5), notifier=notifier) as srv:
            console.print(f"demo service on {srv.url}/ ({db}); log in as {DEMO_USER} / {DEMO_PASSWORD}")
            replay_demo(database, srv.url, key, readings, echo=console.print)
            console.print(f"replay finished; the service keeps running on {srv.url}/ (Ctrl-C stops)")
            try:
                while True:
                    time.sleep(1)
            except KeyboardInterrupt:
                pass
    finally:
        database.dispose()


#: Prefix of the demo's temporary folders (``rail serve --demo`` without ``--db``); each holds the database and a
#: ``pid`` file naming the process that owns it.
DEMO_FOLDER_PREFIX = "longprofile-demo-"


@contextmanager
def _demo_database(db: str | None):
    """The demo's database URL: ``db`` as given (kept), or a SQLite file in a temporary folder removed when the demo
    stops (Ctrl-C, or SIGTERM: ``kill``, a service manager). A folder left by a demo killed with -9 (nothing runs
    then) is removed by the next demo, once its owner process no longer exists."""
    if db is not None:
        yield db
        return
    import shutil
    import signal
    import tempfile

    _remove_orphan_demo_folders(Path(tempfile.gettempdir()))
    folder = Path(tempfile.mkdtemp(prefix=DEMO_FOLDER_PREFIX))
    (folder / "pid").write_text(str(os.getpid()))
    previous = signal.signal(signal.SIGTERM, _interrupt) if _main_thread() else None
    try:
        yield f"sqlite:///{folder}/site.db"
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        shutil.rmtree(folder, ignore_errors=True)


def _interrupt(signum, frame):
    """SIGTERM during the demo: stop as Ctrl-C does (the ``finally`` blocks run, the temporary folder goes)."""
    raise KeyboardInterrupt


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


def _remove_orphan_demo_folders(tmp: Path) -> None:
    """Remove the demo folders under ``tmp`` whose owner process (their ``pid`` file) is gone; a folder without a
    readable ``pid`` file, or whose owner lives, is left alone."""
    import shutil

    for folder in tmp.glob(f"{DEMO_FOLDER_PREFIX}*"):
        try:
            pid = int((folder / "pid").read_text())
            os.kill(pid, 0)
        except ProcessLookupError:
            shutil.rmtree(folder, ignore_errors=True)
        except (OSError, ValueError):  # no pid file (a folder of another version), another user's process, garbage
            continue


@site_app.command("create")
def site_create(name: str = typer.Argument(..., help="Site name (letters, digits, _ . -)."), db: str = DB_OPT,
                title: str = typer.Option("", "--title"),
                baseline_start: str = typer.Option(None, "--baseline-start", help="Reference start (ISO date/time)."),
                baseline_end: str = typer.Option(None, "--baseline-end",
                                                 help="End of the baseline (days before it are quiet days)."),
                no_data_hours: float = typer.Option(6.0, "--no-data-hours", help="Alarm after this long without data."),
                clock: str = typer.Option("wall", "--clock", help="wall, or data (staleness vs the newest reading)."),
                tz: str = typer.Option("UTC", "--timezone",
                                       help="IANA zone of the loggers' clocks (e.g. Europe/Paris): times sent without "
                                            "a UTC offset are read in it, the hour shown twice in autumn in order."),
                actor: str = ACTOR_OPT):
    """Create a site."""
    from ..rail import service as _service

    _print(_service.create_site(_db(db), _actor(actor), name, title=title, baseline_start=baseline_start,
                             baseline_end=baseline_end, no_data_hours=no_data_hours, clock=clock, timezone=tz))


@site_app.command("update")
def site_update(name: str = typer.Argument(...), db: str = DB_OPT,
                set_: list[str] = typer.Option([], "--set", help="FIELD=VALUE (title, baseline_start, baseline_end, "
                                                                 "no_data_hours, clock, timezone; settings=JSON)."),
                actor: str = ACTOR_OPT):
    """Change site fields (recorded in the audit trail, old -> new)."""
    from ..errors import InputError
    from ..rail import service as _service

    fields = {}
    for item in set_:
        k, sep, v = item.partition("=")
        if not sep:
            raise InputError(f"--set {item!r}: expected FIELD=VALUE.")
        if k == "settings":
            try:
                fields[k] = json.loads(v)
            except json.JSONDecodeError as exc:
                raise InputError(f"--set settings: not a JSON object ({exc.msg} at character {exc.pos + 1}); e.g. "
                                 """settings='{"model": "per-day"}'.""") from None
        else:
            fields[k] = None if v == "" else v
    _print(_service.update_site(_db(db), _actor(actor), name, **fields))


@site_app.command("list")
def site_list(db: str = DB_OPT):
    """List the sites."""
    from ..rail import service as _service

    for n in _service.list_sites(_db(db, existing=True)):
        typer.echo(n)


@site_app.command("show")
def site_show(name: str = typer.Argument(...), db: str = DB_OPT):
    """Print a site: fields, sensors, survey, thresholds (m, rate m/day; threshold_rows: with their units and in mm),
    loggers, channels, declared sensor events (re-installations, replacements)."""
    from ..rail import service as _service

    _print(_service.get_site(_db(db, existing=True), name))


@site_app.command("sensors")
def site_sensors(name: str = typer.Argument(...), file: Path = typer.Option(..., "--file", help="sensors table "
                                                                                               "(sensor_id, x_m [, z_m])."),
                 db: str = DB_OPT, actor: str = ACTOR_OPT):
    """Add or update the sensors of a site from a table."""
    from ..rail import service as _service

    _print(_service.put_sensors(_db(db), _actor(actor), name, _rows(file, "sensors")))


@site_app.command("survey")
def site_survey(name: str = typer.Argument(...), file: Path = typer.Option(..., "--file", help="survey table (x_m, z_m)."),
                db: str = DB_OPT, actor: str = ACTOR_OPT):
    """Replace the initial survey of a site."""
    from ..rail import service as _service

    _print(_service.put_survey(_db(db), _actor(actor), name, _rows(file, "survey")))


@site_app.command("controls")
def site_controls(name: str = typer.Argument(...),
                  file: Path = typer.Option(None, "--file", help="controls table (date, x_m, z_m), as for rail settle; "
                                                                 "each date in it replaces that date's survey."),
                  delete: str = typer.Option(None, "--delete", help="Remove the control survey of this date "
                                                                    "(YYYY-MM-DD) instead."),
                  db: str = DB_OPT, actor: str = ACTOR_OPT):
    """Store control (levelling) surveys of a site, compared with the settlement at the next recompute."""
    from ..errors import InputError
    from ..rail import service as _service

    if (file is None) == (delete is None):
        raise InputError("give either --file controls.csv or --delete YYYY-MM-DD.")
    if delete is not None:
        _print(_service.delete_controls(_db(db), _actor(actor), name, delete))
        return
    _print(_service.put_controls(_db(db), _actor(actor), name, _rows(file, "controls", text=("date",))))


@site_app.command("events")
def site_events(name: str = typer.Argument(...),
                file: Path = typer.Option(None, "--file", help="events table (sensor_id, date, event, new_id), as "
                                                               "rail settle --events reads it; each (sensor, date) in "
                                                               "it is created or replaced."),
                delete: str = typer.Option(None, "--delete", help="Remove the event of this sensor id (with --date) "
                                                                  "instead."),
                date: str = typer.Option(None, "--date", help="The date (YYYY-MM-DD) of the event to --delete."),
                db: str = DB_OPT, actor: str = ACTOR_OPT):
    """Declare re-installed sensors (a new mounting offset after maintenance) and sensors replaced by a new id, used
    by every recompute as rail settle --events uses them; without --file or --delete, list them."""
    from ..errors import InputError
    from ..io import read_rail_events
    from ..rail import service as _service

    if file is not None and delete is not None or (delete is None) != (date is None):
        raise InputError("give --file events.csv, or --delete SENSOR_ID --date YYYY-MM-DD, or neither (to list).")
    if delete is not None:
        _print(_service.delete_event(_db(db, existing=True), _actor(actor), name, delete, date))
    elif file is not None:
        ev = read_rail_events(file)  # as rail settle --events reads it
        rows = ev.assign(date=ev["date"].dt.strftime("%Y-%m-%d")).to_dict("records")
        _print(_service.put_events(_db(db), _actor(actor), name, rows))
    else:
        _print(_service.get_events(_db(db, existing=True), name))


@site_app.command("threshold", context_settings={"ignore_unknown_options": True})  # "-5" is a value, not an option
def site_threshold(name: str = typer.Argument(...),
                   quantity: str = typer.Argument(..., help="settlement, rate or twist."),
                   level: str = typer.Argument(..., help="alert, action or alarm."),
                   value_mm: float = typer.Argument(None, help="|value| in mm (rate: mm/day); omit to remove."),
                   db: str = DB_OPT, actor: str = ACTOR_OPT):
    """Set one of the three levels of a quantity's threshold (printed: value in m, m/day for the rate, and value_mm as
    given)."""
    from ..rail import service as _service

    _print(_service.set_threshold(_db(db), _actor(actor), name, quantity, level,
                               None if value_mm is None else value_mm * 1e-3))


@site_app.command("thresholds")
def site_thresholds(name: str = typer.Argument(...),
                    file: Path = typer.Option(..., "--file", help="thresholds table (quantity, level, value_mm), as "
                                                                 "rail settle --thresholds reads."),
                    db: str = DB_OPT, actor: str = ACTOR_OPT):
    """Replace all thresholds of a site with a table (one transaction; levels may be raised or lowered together).
    Prints each level: value in m (m/day for the rate, as stored and as the API gives it) and value_mm, as in the
    table."""
    from ..io import read_rail_thresholds
    from ..rail import service as _service

    new = _service.replace_thresholds(_db(db), _actor(actor), name, read_rail_thresholds(file))
    _print(_service.threshold_rows(new))


@site_app.command("logger")
def site_logger(name: str = typer.Argument(...), logger: str = typer.Argument(..., help="Logger name."),
                db: str = DB_OPT, actor: str = ACTOR_OPT):
    """Create a logger and print its API key (shown once)."""
    from ..rail import service as _service

    typer.echo(_service.add_logger(_db(db), _actor(actor), name, logger))


@site_app.command("logger-revoke")
def site_logger_revoke(name: str = typer.Argument(...), logger: str = typer.Argument(..., help="Logger name."),
                       db: str = DB_OPT, actor: str = ACTOR_OPT):
    """Revoke a logger's API key (401 from its next request; its stored readings stay)."""
    from ..rail import service as _service

    _print(_service.revoke_logger(_db(db), _actor(actor), name, logger))


@site_app.command("logger-rotate")
def site_logger_rotate(name: str = typer.Argument(...), logger: str = typer.Argument(..., help="Logger name."),
                       db: str = DB_OPT, actor: str = ACTOR_OPT):
    """Give a logger a new API key and print it (shown once); the old key stops working at once."""
    from ..rail import service as _service

    typer.echo(_service.rotate_logger(_db(db), _actor(actor), name, logger))


@site_app.command("channel")
def site_channel(name: str = typer.Argument(...), kind: str = typer.Argument(..., help="webhook or smtp."),
                 target: str = typer.Argument(..., help="URL or e-mail address."), db: str = DB_OPT,
                 actor: str = ACTOR_OPT):
    """Send the site's alarm notifications to a webhook or an e-mail address."""
    from ..rail import service as _service

    _print(_service.add_channel(_db(db), _actor(actor), name, kind, target))


@site_app.command("channel-remove")
def site_channel_remove(name: str = typer.Argument(...), kind: str = typer.Argument(..., help="webhook or smtp."),
                        target: str = typer.Argument(..., help="URL or e-mail address, as added."), db: str = DB_OPT,
                        actor: str = ACTOR_OPT):
    """Remove a notification channel (audited; its undelivered notifications are dropped)."""
    from ..rail import service as _service

    _print(_service.remove_channel(_db(db, existing=True), _actor(actor), name, kind, target))


@site_app.command("channels")
def site_channels(name: str = typer.Argument(...), db: str = DB_OPT):
    """Print the site's channels with their deliveries: sent, waiting, failing and the last error."""
    from ..rail import service as _service

    _print(_service.channel_status(_db(db, existing=True), name))


@site_app.command("user")
def site_user(username: str = typer.Argument(...), role: str = typer.Option("viewer", "--role",
                                                                          help="viewer, engineer or admin."),
              reset_password: bool = typer.Option(False, "--reset-password",
                                                  help="Set a new password for an existing person (asked on the "
                                                       "terminal; from a pipe or a file, the first line of stdin)."),
              db: str = DB_OPT, actor: str = ACTOR_OPT):
    """Create a person, or change an existing person's role (no password; --reset-password to set a new one).
    The password is asked on the terminal without echo; when stdin is not a terminal (echo pw | ..., < file) it is
    the first line of stdin, read without a prompt. Audited, never the password."""
    from ..rail import service as _service

    database = _db(db)
    pw = None
    if reset_password or not _service.user_exists(database, username):
        pw = _read_password()
    _print(_service.add_user(database, _actor(actor), username, pw, role, reset_password=reset_password))


def _read_password() -> str:
    """The new password: asked on the terminal without echo; the first line of stdin (its line end removed) when
    stdin is not a terminal, without getpass (which warns that it cannot turn the echo off and prompts on the
    terminal)."""
    import sys

    from ..errors import InputError

    stdin = sys.stdin
    if stdin is not None and stdin.isatty():
        return typer.prompt("password", hide_input=True, confirmation_prompt=False)
    line = "" if stdin is None else stdin.readline()
    if not line:
        raise InputError("no password: stdin is not a terminal and is empty; give the password as its first line "
                         "(echo \"$PASSWORD\" | longprofile rail site user ...) or run the command in a terminal.")
    return line.rstrip("\r\n")


@site_app.command("audit")
def site_audit(name: str = typer.Argument(None, help="Site name (leave out with --users)."), db: str = DB_OPT,
               limit: int = typer.Option(100, "--limit"),
               users: bool = typer.Option(False, "--users", help="The people's trail instead: creation, role and "
                                                                 "password changes.")):
    """Print the audit trail of a site, or of the people (newest first)."""
    from ..errors import InputError
    from ..rail import service as _service

    if (name is None) != users:
        raise InputError("give a site name, or --users for the people's audit trail.")
    _print(_service.audit_trail(_db(db, existing=True), name, limit, users=users))


@site_app.command("ingest")
def site_ingest(name: str = typer.Argument(...), file: Path = typer.Option(..., "--file", help="readings table."),
                db: str = DB_OPT, angle_unit: str = typer.Option(
                    "deg", "--angle-unit", help="Unit of a plain angle_deg column: deg or rad (a header such as "
                                                "angle_rad declares its own; leave this out then)."),
                actor: str = ACTOR_OPT):
    """Store a readings table directly (same rules as the API: idempotent, revisions, per-row outcomes; audited). The
    table may be wide (a logger's export: one column per sensor of the site, as rail settle --readings reads it)."""
    from ..errors import InputFormatError
    from ..io import read_rail_table
    from ..rail import READING_COLUMNS
    from ..rail import service as _service

    database = _db(db)
    ids = [x["sensor_id"] for x in _service.get_site(database, name)["sensors"]]
    t = read_rail_table(file, "readings", angle_unit=angle_unit, sensor_ids=ids)  # as rail settle reads it
    wrong = sorted(set(map(str, t.columns)) ^ set(READING_COLUMNS))
    if wrong:  # the whole file would be rejected row by row: say it once, store nothing
        raise InputFormatError(f"{file}: the columns are {list(map(str, t.columns))}; a readings table has exactly "
                               f"{list(READING_COLUMNS)} (as for rail settle).")
    t["timestamp"] = t["timestamp"].astype(str)
    res = _service.ingest(database, name, t.to_dict("records"), angle_unit=angle_unit, actor=_actor(actor),
                          source=Path(file).name)
    _print({k: v for k, v in res.as_dict().items() if k != "rows"})
    rejected = [r for r in res.rows if r["outcome"] == "rejected"]
    for r in rejected[:_SHOW_REJECTED]:
        console.print(f"[yellow]row {r['row']} rejected:[/yellow] {r['reason']}", highlight=False)
    if len(rejected) > _SHOW_REJECTED:
        console.print(f"[yellow]... and {len(rejected) - _SHOW_REJECTED} more rejected rows[/yellow]", highlight=False)


#: Rejected rows of ``rail site ingest`` printed one per line; the rest are counted.
_SHOW_REJECTED = 10


@site_app.command("recompute")
def site_recompute(name: str = typer.Argument(...), db: str = DB_OPT,
                   force: bool = typer.Option(False, "--force", help="Even if nothing changed (audited)."),
                   actor: str = ACTOR_OPT):
    """Recompute the settlement of a site now (the server's worker does this when data arrive)."""
    from ..rail.service import recompute

    _print(recompute(_db(db), name, force=force, actor=_actor(actor) if force else None))


def register(app: typer.Typer) -> None:
    """Add ``serve`` and the ``site`` group to the ``rail`` command group."""
    app.command("serve")(serve_command)
    app.add_typer(site_app, name="site")
