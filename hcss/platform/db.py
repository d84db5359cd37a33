"""The database engine and the unit of work.

Every HTTP request gets one SQLAlchemy session, committed when the request
succeeds and rolled back when it fails or answers with an error status, so a
refused request changes nothing. Code outside a request (the live runner, the
CLI) uses `session_scope()`, which has the same all-or-nothing contract.

The database also owns the clock that stamps rows (`Database.clock`, epoch
seconds): every `created_at` is set from it when the row is flushed, and the
live runner and the study flow read the same clock, so a trial's rows, its
stage events and its simulation events share one timeline. In a server that
is the wall clock; tests and bots put a `ManualClock` there.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from typing import Any

from flask import Flask, current_app, g
from sqlalchemy import Engine, create_engine, event
from sqlalchemy.orm import Session, sessionmaker

from hcss.platform.models import Base, CreatedAt

#: SQLite errors after which a pooled connection is replaced, not used again.
SQLITE_REOPEN_ON = ("readonly database", "disk i/o error", "unable to open database")


def make_engine(url: str) -> Engine:
    """An engine fit for several threads writing at once."""
    if url.startswith("sqlite"):
        engine = create_engine(
            url,
            connect_args={"check_same_thread": False, "timeout": 30},
            pool_size=20,
            # No ceiling: a request may hold two connections (its own session and
            # a unit of work), and with a bounded pool 60 such requests waited for
            # each other's second connection until the pool timed out (30 s).
            # Waitress' threads bound the count; an SQLite connection is a file handle.
            max_overflow=-1,
        )

        @event.listens_for(engine, "handle_error")
        def _reopen_after(context) -> None:
            # A connection opened while the file or its disk was read-only stays
            # read-only, and one that met an I/O error may be unusable: treat both
            # as lost, so the pool discards its connections and opens new ones,
            # and the server recovers without a restart once the disk does.
            text = str(context.original_exception).lower()
            if any(sign in text for sign in SQLITE_REOPEN_ON):
                context.is_disconnect = True

        @event.listens_for(engine, "connect")
        def _sqlite_pragmas(dbapi_connection, _record) -> None:
            # WAL lets the stream threads read while the runner writes.
            cursor = dbapi_connection.cursor()
            cursor.execute("PRAGMA journal_mode=WAL")
            cursor.execute("PRAGMA synchronous=NORMAL")
            cursor.execute("PRAGMA foreign_keys=ON")
            cursor.close()

        return engine
    return create_engine(url, pool_size=20, max_overflow=40, pool_pre_ping=True)


class Database:
    """The engine, session factory and row clock of one app (no module-level globals)."""

    def __init__(self, url: str, *, clock: Callable[[], float] = time.time) -> None:
        self.url = url
        self.engine = make_engine(url)
        #: Epoch seconds; replaced by a `ManualClock` in tests (the runner reads it too).
        self.clock = clock
        self.sessions = sessionmaker(self.engine, expire_on_commit=False, info={"database": self})
        event.listen(self.sessions, "before_flush", self._stamp_new_rows)

    def now(self) -> datetime:
        """The clock's instant as an aware UTC datetime, for the rows' time columns."""
        return datetime.fromtimestamp(self.clock(), UTC)

    def _stamp_new_rows(self, session: Session, _context: Any, _instances: Any) -> None:
        """Stamp `created_at` of the rows this flush inserts (one instant per flush)."""
        new = [row for row in session.new if isinstance(row, CreatedAt) and row.created_at is None]
        if new:
            now = self.now()
            for row in new:
                row.created_at = now

    @contextmanager
    def session_scope(self) -> Iterator[Session]:
        """One unit of work: commit on success, roll back on any exception."""
        session = self.sessions()
        try:
            yield session
            session.commit()
        except BaseException:
            session.rollback()
            raise
        finally:
            session.close()

    @contextmanager
    def command_scope(self) -> Iterator[Session]:
        """`session_scope` for CLI commands: database errors become a clear message.

        The usual cause is a database that was never migrated, so the message
        says how to fix that instead of showing a SQLAlchemy traceback. The
        engine is disposed afterwards, since a command uses it once.
        """
        import click
        from sqlalchemy.exc import OperationalError, ProgrammingError

        try:
            with self.session_scope() as session:
                yield session
        except (OperationalError, ProgrammingError) as error:
            raise click.ClickException(
                f"cannot use the database ({error.orig}); is it migrated? Run `hcss db upgrade`."
            ) from error
        finally:
            self.engine.dispose()

    def write_refusal(self) -> str | None:
        """Why the database refuses writes now (the driver's words), or None if it takes them.

        `hcss serve` asks at start, so a read-only, full or unreachable database
        is said at once rather than met by the first participant. The probe is
        an UPDATE that matches no row, rolled back: SQLite still takes its write
        lock and PostgreSQL refuses it in a read-only transaction, and nothing
        changes. A database without the platform's tables is not a refusal here:
        the runner says `hcss db upgrade` for that.
        """
        from sqlalchemy import text
        from sqlalchemy.exc import DBAPIError

        try:
            with self.engine.connect() as connection, connection.begin() as transaction:
                connection.execute(text("UPDATE participant SET id = id WHERE 1 = 0"))
                transaction.rollback()
        except DBAPIError as error:  # PostgreSQL's read-only refusal is an InternalError
            words = str(error.orig).strip().splitlines()[0] if error.orig else str(error)
            lowered = words.lower()
            if "no such table" in lowered or (
                "relation" in lowered and "does not exist" in lowered
            ):
                return None
            return words
        return None

    def create_all(self) -> None:
        """Create every table and the append-only triggers; for tests. Deployments migrate."""
        from hcss.platform.models.append_only import install_triggers

        Base.metadata.create_all(self.engine)
        with self.engine.begin() as connection:
            install_triggers(connection)


def init_app(app: Flask) -> Database:
    """Attach a `Database` to the app and close each request's session as a unit."""
    database = Database(app.config["DATABASE_URL"])
    app.extensions["hcss_db"] = database

    @app.after_request
    def _commit(response):
        session: Session | None = g.pop("db_session", None)
        if session is not None:
            try:
                if response.status_code < 400:
                    session.commit()
                else:
                    session.rollback()
            finally:
                session.close()
        return response

    @app.teardown_request
    def _rollback(_exc: BaseException | None) -> None:
        # Reached with a session still open only when the view raised.
        session: Session | None = g.pop("db_session", None)
        if session is not None:
            session.rollback()
            session.close()

    return database


def database() -> Database:
    return current_app.extensions["hcss_db"]


def session_now(session: Session) -> datetime:
    """The clock of the `Database` whose session this is (see the module docstring)."""
    return session.info["database"].now()


def get_session() -> Session:
    """The current request's session, opened on first use."""
    if "db_session" not in g:
        g.db_session = database().sessions()
    return g.db_session
