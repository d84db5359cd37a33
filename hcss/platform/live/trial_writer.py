"""Insert a trial's row unless the row it stands for is stored already.

A trial's decisions, events, probes, probe events, request statuses and
interruptions each have a unique key in the database (migration
i29_unique_trial_rows): a decision is its collective and index, an event its
kind, time and text, a probe its index, a probe event its kind, a status its
request and status, an interruption the moment the trial was last seen before
it. Written through `add_if_absent`, a row whose key is stored is skipped by the
database itself (``INSERT … ON CONFLICT DO NOTHING``), so neither a retry after a
commit whose answer was lost nor a second writer racing this one (two
transactions that both read "absent") can store it twice, and neither fails.
On PostgreSQL the second of two racing inserts waits for the first's commit
and then skips; SQLite writes one transaction at a time.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.orm import Session

from hcss.platform.db import session_now
from hcss.platform.models.base import Base


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
