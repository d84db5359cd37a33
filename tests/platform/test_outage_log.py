"""Issue 44 §4: the log tells an outage from a bug.

An expected refusal while the database takes no writes (a read-only disk under SQLite, a
read-only PostgreSQL) is one line naming the request and the database's words, at WARNING,
with no traceback; before, each was "Exception on ..." with a full traceback (219 in 30 s).
A bug still logs its traceback.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager

from flask import Flask
from sqlalchemy import event

from hcss.platform.bots.participant import bot_app
from tests.support.console import add_account, sign_in
from tests.support.own_disk import own_disk
from tests.support.study import new_participant
from tests.support.trials import csrf_token_of


@contextmanager
def _read_only(app: Flask, database_url: str, tmp_path) -> Iterator[None]:
    """Make the app's database refuse writes for real: SQLite's disk remounted read-only,
    PostgreSQL's new connections read-only by default (the pool emptied first)."""
    engine = app.extensions["hcss_db"].engine
    if database_url.startswith("sqlite"):
        yield  # the disk is made read-only by the caller (it owns the mount)
        return

    def read_only(dbapi_connection, _record) -> None:
        with dbapi_connection.cursor() as cursor:
            cursor.execute("SET default_transaction_read_only = on")
        dbapi_connection.commit()

    event.listen(engine, "connect", read_only)
    engine.dispose()
    try:
        yield
    finally:
        event.remove(engine, "connect", read_only)
        engine.dispose()


@contextmanager
def _app_on(database_url: str, tmp_path) -> Iterator[tuple[Flask, object]]:
    if not database_url.startswith("sqlite"):
        yield bot_app(database_url, "original", SECRET_KEY="log-secret"), None
        return
    with own_disk(tmp_path) as disk:
        url = f"sqlite:///{disk.path / 'hcss.sqlite3'}"
        yield bot_app(url, "original", SECRET_KEY="log-secret"), disk


def test_refusals_while_the_database_is_read_only_are_one_line_each(
    database_url, tmp_path, caplog
) -> None:
    with _app_on(database_url, tmp_path) as (app, disk):
        app.extensions["hcss_db"].create_all()
        add_account(app)
        token = new_participant(app)
        console = app.test_client()
        assert sign_in(console, "alice", "correct horse battery").status_code == 302
        csrf = csrf_token_of(console.get("/console/").get_data(as_text=True))
        participant = app.test_client()
        caplog.clear()
        with caplog.at_level(logging.INFO), _read_only(app, database_url, tmp_path):
            if disk is not None:
                app.extensions["hcss_db"].engine.dispose()
                disk.read_only()
            answers = [
                console.post("/console/participants", data={"csrf_token": csrf, "count": "1"}),
                participant.get(f"/p/{token}", follow_redirects=True),
                console.post("/console/participants", data={"csrf_token": csrf, "count": "2"}),
            ]
            if disk is not None:
                disk.writable()
        app.extensions["hcss_db"].engine.dispose()
    statuses = [answer.status_code for answer in answers]
    assert 503 in statuses, statuses
    assert set(statuses) <= {200, 503}, statuses
    assert all(a.headers.get("Retry-After") for a in answers if a.status_code == 503)
    logged = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert not [r for r in logged if r.exc_info], [r.getMessage()[:200] for r in logged]
    text = "\n".join(r.getMessage() for r in logged)
    assert "Traceback" not in text and "Exception on" not in text, text[:500]
    away = [r for r in logged if "database away" in r.getMessage()]
    assert len(away) == statuses.count(503), text[:800]
    assert all("\n" not in r.getMessage() for r in away)


def test_a_bug_still_logs_its_traceback(app, caplog) -> None:
    app.config["TESTING"] = False  # the 500 page, as a server answers

    @app.get("/a-bug")
    def a_bug() -> str:
        raise ZeroDivisionError("a bug")

    with caplog.at_level(logging.ERROR):
        assert app.test_client().get("/a-bug").status_code == 500
    (record,) = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert record.exc_info is not None and "Exception on /a-bug" in record.getMessage()
