"""Notification delivery through the outbox: a loopback SMTP server (aiosmtpd) and a local webhook receiver."""

from __future__ import annotations

import json
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest
from sqlalchemy import select

from longprofile.rail.service import _core
from longprofile.rail.service._alarms import Notifier, deliver_outbox, transition
from longprofile.rail.service._db import Outbox, Site
from longprofile.rail.service._serve import free_port


class Receiver:
    """Webhook receiver on 127.0.0.1: records (Idempotency-Key, payload); can be told to fail."""

    def __init__(self):
        self.got, self.fail = [], False
        rec = self

        class H(BaseHTTPRequestHandler):
            def do_POST(self):
                body = self.rfile.read(int(self.headers["Content-Length"]))
                if rec.fail:
                    self.send_response(503)
                    self.end_headers()
                    return
                rec.got.append((self.headers["Idempotency-Key"], json.loads(body)))
                self.send_response(204)
                self.end_headers()

            def log_message(self, *a):
                pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), H)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/hook"
        self.t = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.t.start()

    def close(self):
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.fixture
def smtp():
    aiosmtpd = pytest.importorskip("aiosmtpd.controller")
    from aiosmtpd.handlers import Message

    got = []

    class Keep(Message):
        def handle_message(self, message):
            got.append(message)

    port = free_port()
    ctl = aiosmtpd.Controller(Keep(), hostname="127.0.0.1", port=port)
    ctl.start()
    yield port, got
    ctl.stop()


@pytest.fixture
def hook():
    r = Receiver()
    yield r
    r.close()


def _raise(db, subject="site", level="alarm"):
    with db.write() as s:
        site = s.scalar(select(Site).where(Site.name == "mitt"))
        return transition(s, site, "settlement", subject, level, value=-0.02, threshold=0.01, day="2019-11-25",
                          message="test")


def test_webhook_and_smtp_deliver_each_notification_once(site, smtp, hook):
    db, *_ = site
    port, mails = smtp
    _core.add_channel(db, "t", "mitt", "webhook", hook.url)
    _core.add_channel(db, "t", "mitt", "smtp", "track@example.org")
    assert _raise(db) == "raised"
    n = Notifier(smtp_host="127.0.0.1", smtp_port=port, timeout_s=5)
    assert deliver_outbox(db, n) == {"sent": 2, "failed": 0}
    assert deliver_outbox(db, n) == {"sent": 0, "failed": 0}  # nothing is sent twice
    assert len(hook.got) == 1 and hook.got[0][1]["level"] == "alarm" and hook.got[0][1]["event"] == "raised"
    assert len(mails) == 1 and mails[0]["To"] == "track@example.org" and "alarm" in mails[0]["Subject"]
    assert mails[0]["Message-ID"].startswith("<lp-")
    assert _raise(db, level=None) == "cleared"
    deliver_outbox(db, n)
    assert [g[1]["event"] for g in hook.got] == ["raised", "cleared"] and len(mails) == 2


def test_a_failed_delivery_is_kept_and_retried(site, hook):
    db, *_ = site
    _core.add_channel(db, "t", "mitt", "webhook", hook.url)
    _raise(db)
    hook.fail = True
    assert deliver_outbox(db, Notifier(timeout_s=5)) == {"sent": 0, "failed": 1}
    with db.read() as s:
        row = s.scalar(select(Outbox))
    assert row.sent_ts is None and row.attempts == 1 and "503" in row.last_error
    hook.fail = False
    assert deliver_outbox(db, Notifier(timeout_s=5))["sent"] == 0  # back-off: not yet
    assert deliver_outbox(db, Notifier(timeout_s=5), now=row.next_try_ts)["sent"] == 1
    assert len(hook.got) == 1


def test_a_crash_between_send_and_mark_repeats_with_the_same_key(site, hook):
    db, *_ = site
    _core.add_channel(db, "t", "mitt", "webhook", hook.url)
    _raise(db)

    class Crash(Exception):
        pass

    def crash(row):
        raise Crash

    with pytest.raises(Crash):
        deliver_outbox(db, Notifier(timeout_s=5), _after_send=crash)
    deliver_outbox(db, Notifier(timeout_s=5))  # "after restart"
    keys = [k for k, _ in hook.got]
    # at-least-once: the receiver saw it twice, with one idempotency key, so it keeps one
    assert len(keys) == 2 and len(set(keys)) == 1
    assert deliver_outbox(db, Notifier(timeout_s=5))["sent"] == 0
