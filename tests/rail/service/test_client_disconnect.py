"""A logger that disconnects while sending its batch (or the demo's replay stopped by SIGTERM mid-request): the
service stores nothing and logs no traceback (fresh-clone ``make test``, session 40: the demo's SIGTERM test saw
Starlette's ``ClientDisconnect`` reach the catch-all handler, which logs it as "Exception in ASGI application")."""

from __future__ import annotations

import asyncio
import logging

from longprofile.rail.service._web import create_app

from .conftest import count_readings


def _post_then_disconnect(app, key: str) -> list[dict]:
    """Drive the ASGI app directly: POST readings whose body never arrives (the client disconnects)."""
    scope = {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "POST", "scheme": "http",
             "path": "/api/v1/sites/mitt/readings", "raw_path": b"/api/v1/sites/mitt/readings", "query_string": b"",
             "root_path": "", "headers": [(b"content-type", b"text/csv"), (b"x-api-key", key.encode()),
                                          (b"content-length", b"1000")],
             "client": ("127.0.0.1", 50000), "server": ("127.0.0.1", 8000)}
    sent: list[dict] = []

    async def receive():
        return {"type": "http.disconnect"}

    async def send(message):
        sent.append(message)

    async def run():
        await app(scope, receive, send)

    asyncio.run(run())
    return sent


def test_a_client_disconnecting_mid_batch_stores_nothing_and_logs_no_traceback(site, caplog):
    db, key, _ = site
    app = create_app(db, background=False)
    before = count_readings(db)
    with caplog.at_level(logging.ERROR):
        sent = _post_then_disconnect(app, key)
    assert count_readings(db) == before
    assert not [r for r in caplog.records if r.exc_info], [r.getMessage() for r in caplog.records]
    starts = [m for m in sent if m["type"] == "http.response.start"]
    assert starts and starts[0]["status"] == 400
