"""The newest row per key: how the platform asks which row of an append-only table is current.

Statuses, enrolments, stage events, consent records and console actions are
never updated: a change is a new row, and the current one for a key (a trial,
a participant) is the row with the highest id. Every reader asks through
these two functions, so "current" means the same everywhere.
"""

from __future__ import annotations

from typing import Any, TypeVar, cast

from sqlalchemy import ColumnElement, Select, func, select
from sqlalchemy.orm import InstrumentedAttribute, Session

Row = TypeVar("Row")


def newest_ids(
    model: type[Any], key: InstrumentedAttribute[Any], *where: ColumnElement[bool]
) -> Select[tuple[int]]:
    """The id of each key's newest row among those `where` admits (a subquery for `id IN`)."""
    return select(func.max(cast(Any, model).id)).where(*where).group_by(key)


def latest_per_key(
    session: Session,
    model: type[Row],
    key: InstrumentedAttribute[Any],
    *where: ColumnElement[bool],
) -> dict[Any, Row]:
    """Each key's newest row among those `where` admits, by key, in one query."""
    rows = session.scalars(
        select(model).where(cast(Any, model).id.in_(newest_ids(model, key, *where)))
    )
    return {getattr(row, key.key): row for row in rows}


def latest_row(
    session: Session,
    model: type[Row],
    key: InstrumentedAttribute[Any],
    value: Any,
    *where: ColumnElement[bool],
) -> Row | None:
    """The newest row whose `key` is `value` among those `where` admits; None if there is none."""
    return session.scalars(
        select(model).where(key == value, *where).order_by(cast(Any, model).id.desc()).limit(1)
    ).first()
