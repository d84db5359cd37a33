"""The database engine and the unit of work.

Every HTTP request gets one SQLAlchemy session, committed when the request
succeeds and rolled back when it fails or answers with an error status, so a
refused request changes nothing. Code outside a request (the live runner, the
CLI) uses `session_scope()`, which has the same all-or-nothing contract.

A request holds at most one pooled connection at a time. A unit of work
opened during a request (a console action, the live runner loading a trial,
an export) first ends the request session's read-only transaction, which
hands its connection back; a request session with unsaved writes may not
open one (`RequestHoldsWrites`). Two connections per request let a bounded
pool deadlock: enough requests each held one and waited for a second.

The database also owns the clock that stamps rows (`Database.clock`, epoch
seconds): every `created_at` is set from it when the row is flushed, and the
live runner and the study flow read the same clock, so a trial's rows, its
stage events and its simulation events share one timeline. In a server that
is the wall clock; tests and bots put a `ManualClock` there.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from flask import Flask, before_render_template, current_app, g, has_app_context
from sqlalchemy import Engine, create_engine, event
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import ORMExecuteState, Session, sessionmaker

from hcss.platform import sqlite_recovery
from hcss.platform.models import Base, CreatedAt

#: SQLite errors after which a pooled connection is replaced, not used again.
SQLITE_REOPEN_ON = ("readonly database", "disk i/o error", "unable to open database")


#: The pool, on SQLite and PostgreSQL alike: waitress' threads queue for these.
#: A request holds one connection at a time (see the module docstring), so a
#: full pool makes requests wait for each other's, never deadlock; a request
#: still waiting after `pool_timeout` seconds fails instead of hanging.
POOL = {"pool_size": 20, "max_overflow": 40, "pool_timeout": 30}


#: PostgreSQL connections notice a dead or black-holed link in seconds, not in the kernel's
#: retransmission time (about 15 minutes): a lease renewal or a write that hangs longer than
#: a lease is as good as lost, and the live runner must learn so while it can still stop.
#: connect_timeout: a connection attempt; keepalives: an idle link's silence (probes after
#: 5 s, every 2 s, 3 lost: dead); tcp_user_timeout: unacknowledged data (ms); the statement
#: timeout: one statement (ms), far above any the server runs.
POSTGRESQL_LINK = {
    "connect_timeout": 5,
    "keepalives": 1,
    "keepalives_idle": 5,
    "keepalives_interval": 2,
    "keepalives_count": 3,
    "tcp_user_timeout": 10_000,
}
#: Milliseconds; set on each new connection (a URL's own `options`, the schema, stay).
STATEMENT_TIMEOUT_MS = 15_000
#: Milliseconds a transaction may wait on its client between statements. A process stopped
#: (SIGSTOP, a hung VM) or cut off in the middle of a unit of work keeps every row it
#: locked, the trial's lease row first, until PostgreSQL ends its transaction; the next
#: host's claim would wait on that lock. Less than a lease, so the row is free before the
#: lease runs out, and far above the milliseconds between a unit of work's statements
#: (at 3 s, a healthy process starved of CPU by a loaded machine once met it).
IDLE_IN_TRANSACTION_MS = 5_000


#: SQLSTATEs with which PostgreSQL closes the connection: an idle transaction ended,
#: an administrator's or a crash's shutdown, a server not yet taking connections.
CLOSED_BY_THE_SERVER = frozenset({"25P03", "57P01", "57P02", "57P03"})


class RequestHoldsWrites(RuntimeError):
    """A unit of work was opened while the request's session held unsaved writes."""


def make_engine(url: str) -> Engine:
    """An engine fit for several threads writing at once."""
    if url.startswith("sqlite"):
        engine = create_engine(
            url, connect_args={"check_same_thread": False, "timeout": 30}, **POOL
        )

        @event.listens_for(engine, "handle_error")
        def _reopen_after(context) -> None:
            # A connection opened while the file or its disk was read-only stays
            # read-only, and one that met an I/O error may be unusable: treat both
            # as lost, so the pool discards its connections and opens new ones,
            # and the server recovers without a restart once the disk does (the
            # -shm mapping's part of it is sqlite_recovery's).
            text = str(context.original_exception).lower()
            if any(sign in text for sign in SQLITE_REOPEN_ON):
                context.is_disconnect = True
                # SQLAlchemy leaves a lost connection's cursor open; its statement would keep
                # the closed connection (its files, its read-only -shm mapping) alive for as
                # long as the error's traceback is kept, so the file never took writes again.
                if context.execution_context is not None:
                    context.execution_context.cursor.close()

        @event.listens_for(engine, "connect")
        def _sqlite_pragmas(dbapi_connection, _record) -> None:
            # WAL lets the stream threads read while the runner writes.
            cursor = dbapi_connection.cursor()
            cursor.execute("PRAGMA journal_mode=WAL")
            cursor.execute("PRAGMA synchronous=NORMAL")
            cursor.execute("PRAGMA foreign_keys=ON")
            cursor.close()

        if engine.url.database and engine.url.database != ":memory:":
            # After the pragmas: a connection whose pragmas fail (a read-only disk refuses
            # WAL) is discarded without a close event, so it must never be counted as an
            # open read-only mapping, or every later connection waits for it in vain.
            sqlite_recovery.install(engine, Path(engine.url.database))
        return engine
    engine = create_engine(url, pool_pre_ping=True, connect_args=POSTGRESQL_LINK, **POOL)

    @event.listens_for(engine, "handle_error")
    def _closed_by_the_server(context) -> None:
        # A transaction ended for idling (25P03) or a server shutting down (57P0x) closes the
        # connection: the pool drops it at once instead of meeting it again.
        sqlstate = getattr(context.original_exception, "sqlstate", None) or ""
        if sqlstate in CLOSED_BY_THE_SERVER or sqlstate.startswith("08"):
            context.is_disconnect = True

    @event.listens_for(engine, "connect")
    def _statement_timeout(dbapi_connection, _record) -> None:
        with dbapi_connection.cursor() as cursor:
            cursor.execute(f"SET statement_timeout = {STATEMENT_TIMEOUT_MS}")
            cursor.execute(f"SET idle_in_transaction_session_timeout = {IDLE_IN_TRANSACTION_MS}")
        dbapi_connection.commit()

    return engine


class Database:
    """The engine, session factory and row clock of one app (no module-level globals)."""

    def __init__(self, url: str, *, clock: Callable[[], float] = time.time) -> None:
        self.url = url
        self.engine = make_engine(url)
        #: Epoch seconds; replaced by a `ManualClock` in tests (the runner reads it too).
        self.clock = clock
        self.sessions = sessionmaker(self.engine, expire_on_commit=False, info={"database": self})
        # Module functions, never bound methods: SQLAlchemy keeps a sessionmaker's listeners
        # in a class-level registry keyed weakly by its Session class, and a listener that
        # held this Database would keep that key, and so every Database, alive for good.
        event.listen(self.sessions, "before_flush", _stamp_new_rows)
        event.listen(self.sessions, "after_flush", _note_writes)
        event.listen(self.sessions, "do_orm_execute", _note_statement_writes)
        event.listen(self.sessions, "after_transaction_end", _forget_writes)

    def now(self) -> datetime:
        """The clock's instant as an aware UTC datetime, for the rows' time columns."""
        return datetime.fromtimestamp(self.clock(), UTC)

    @contextmanager
    def session_scope(self) -> Iterator[Session]:
        """One unit of work: commit on success, roll back on any exception.

        In a request, the request's session first gives its connection back
        (`_hand_back_request_connection`), so the request never holds two.
        """
        _hand_back_request_connection()
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
        """Create every table and the append-only triggers; for tests. Deployments migrate.

        On a PostgreSQL schema with no tables yet (each test's own), the same DDL goes as one
        script: one round trip instead of 112 (a check, table, index or trigger each); on a
        loaded machine 0.5 s instead of 0.7 s of each PostgreSQL test's setup.
        """
        from sqlalchemy import inspect

        from hcss.platform.models.append_only import install_triggers

        with self.engine.begin() as connection:
            if (
                connection.dialect.name == "postgresql"
                and not inspect(connection).get_table_names()
            ):
                # The driver's cursor, without parameters: psycopg reads no placeholders then,
                # and sends the script as one query.
                connection.connection.cursor().execute(_create_script(connection.dialect.name))
                return
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

    before_render_template.connect(_end_read_before_page, app)

    @app.teardown_request
    def _rollback(_exc: BaseException | None) -> None:
        # Reached with a session still open only when the view raised.
        session: Session | None = g.pop("db_session", None)
        if session is not None:
            session.rollback()
            session.close()

    return database


def _end_read_before_page(_app: Flask, **_extra: Any) -> None:
    """A page is built with no transaction open: a request that only read ends its read
    before the template runs (a query the template makes opens its own). Under load a
    page took longer to build than PostgreSQL lets a transaction idle, and the request's
    commit met a closed connection. A request that wrote keeps its unit of work whole."""
    session: Session | None = g.get("db_session")
    if session is None or not session.in_transaction():
        return
    if session.info.get("unsaved_writes") or session.new or session.dirty or session.deleted:
        return
    transaction = session.get_transaction()
    if transaction is None or not transaction.is_active:
        return  # a failed request: its error handler rolls back
    try:
        session.commit()
    except SQLAlchemyError:
        # The connection was lost already (a swallowed error left the transaction invalid,
        # PendingRollbackError): the page is built all the same; its own queries say so.
        session.rollback()


def _stamp_new_rows(session: Session, _context: Any, _instances: Any) -> None:
    """Stamp `created_at` of the rows this flush inserts (one instant per flush), on the
    clock of the session's Database."""
    new = [row for row in session.new if isinstance(row, CreatedAt) and row.created_at is None]
    if new:
        now = session.info["database"].now()
        for row in new:
            row.created_at = now


def _note_writes(session: Session, _context: Any) -> None:
    session.info["unsaved_writes"] = True


def _note_statement_writes(state: ORMExecuteState) -> None:
    """An INSERT, UPDATE or DELETE statement (`session.execute`) writes without a flush."""
    if state.is_insert or state.is_update or state.is_delete:
        state.session.info["unsaved_writes"] = True


def _forget_writes(session: Session, transaction: Any) -> None:
    if transaction.parent is None:  # the outermost transaction: committed or rolled back
        session.info.pop("unsaved_writes", None)


def hand_back_connection() -> None:
    """Before slow work (hashing a password, waiting on a lock, building a page): end the
    request session's read-only transaction, so no transaction idles across the work.

    PostgreSQL ends a transaction idle for `IDLE_IN_TRANSACTION_MS` and closes its
    connection (SQLSTATE 25P03); an argon2 check on a loaded machine took longer than
    that inside a sign-in's read, and the request answered 500. Its next query opens a
    transaction of its own. A no-op outside a request or when nothing is open.
    """
    _hand_back_request_connection()


def _hand_back_request_connection() -> None:
    """End the request session's transaction if it only read, so its connection is free.

    Ending it commits nothing: the session wrote nothing, and with
    `expire_on_commit=False` what it loaded (the signed-in experimenter, the
    participant) stays loaded; its next query takes a connection again. A
    session that wrote may not be ended here (that would commit half a
    request) nor kept open beside a unit of work (two connections, and on
    SQLite a unit of work that writes would wait for the request's own
    write lock): the caller must open its unit of work before it writes.
    """
    if not has_app_context():
        return
    session: Session | None = g.get("db_session")
    if session is None or not session.in_transaction():
        return
    if session.info.get("unsaved_writes") or session.new or session.dirty or session.deleted:
        raise RequestHoldsWrites(
            "a unit of work was opened while this request's session holds unsaved "
            "writes; open it before the request writes"
        )
    session.commit()


def database() -> Database:
    return current_app.extensions["hcss_db"]


def session_now(session: Session) -> datetime:
    """The clock of the `Database` whose session this is (see the module docstring)."""
    return session.info["database"].now()


# --- insert if absent: a row whose unique key is stored is skipped, not an error -----------
# (the trial log's writer, hcss.platform.live.trial_writer, stores each row of a trial once
# this way, whether a retry or a second writer races it)


def add_if_absent(session: Session, row: Base) -> bool:
    """Insert `row` now unless its unique key is stored; True (and `row.id` set) if inserted."""
    inserted = _insert(session, [row])
    if not inserted:
        return False
    row.id = inserted[0]  # type: ignore[attr-defined]
    return True


def add_all_if_absent(session: Session, rows: Sequence[Base]) -> int:
    """Insert every row of one model whose key is not stored, in one statement; how many were."""
    return len(_insert(session, rows)) if rows else 0


def _insert(session: Session, rows: Sequence[Base]) -> list[int]:
    model = type(rows[0])
    table = model.__table__
    now = session_now(session)
    values = [_values(row, table, now) for row in rows]
    insert = pg_insert if session.get_bind().dialect.name == "postgresql" else sqlite_insert
    statement = insert(model).values(values).on_conflict_do_nothing().returning(table.c.id)
    return list(session.scalars(statement))


def _values(row: Base, table: Any, now: Any) -> dict[str, Any]:
    """The row's columns as an INSERT's values: unset ones take the column's default."""
    values: dict[str, Any] = {}
    for column in table.columns:
        if column.key == "id":
            continue
        value = getattr(row, column.key)
        if value is None and column.key == "created_at":
            value = now
        elif value is None and column.default is not None and column.default.is_scalar:
            value = column.default.arg
        values[column.key] = value
    return values


def get_session() -> Session:
    """The current request's session, opened on first use."""
    if "db_session" not in g:
        g.db_session = database().sessions()
    return g.db_session


@functools.cache
def _create_script(dialect: str) -> str:
    """What `Base.metadata.create_all` and the append-only triggers run on an empty database,
    as one script (statements the dialect compiles, joined by semicolons)."""
    from sqlalchemy import create_mock_engine
    from sqlalchemy.engine import make_url

    from hcss.platform.models.append_only import trigger_statements

    compiler = make_url(f"{dialect}://").get_dialect()()
    statements: list[str] = []

    def collect(ddl: Any, *_: Any, **__: Any) -> None:
        statements.append(str(ddl.compile(dialect=compiler)))

    Base.metadata.create_all(create_mock_engine(f"{dialect}://", collect), checkfirst=False)
    return ";\n".join([*statements, *trigger_statements(dialect)])
