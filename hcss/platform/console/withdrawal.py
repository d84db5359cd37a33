"""Withdrawal: delete every row of one participant, and audit the deletion.

Which tables hold a participant's data is read from the schema, not listed by
hand: a table belongs to the withdrawal when one of its foreign keys points
at the participant or at a row that does (trial -> command -> outcome, ...).
A table added later by any part of the platform is therefore covered without
touching this module. Everything happens in one transaction with the
`AuditRecord`, so either all of it is gone and audited, or nothing changed.
"""

from __future__ import annotations

from sqlalchemy import ColumnElement, MetaData, Select, Table, delete, false, or_, select
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live.service import HostedElsewhere, LiveTrials
from hcss.platform.models import AuditRecord, Base, DeletionPermit, Participant, Trial


class WithdrawalError(ValueError):
    """A withdrawal that cannot be done as asked; nothing was deleted."""


def participant_tables(metadata: MetaData = Base.metadata) -> list[Table]:
    """Tables with a foreign-key path to `participant`, children before parents."""
    owned = {"participant"}
    for table in metadata.sorted_tables:  # parents come before children here
        if any(fk.column.table.name in owned for fk in table.foreign_keys):
            owned.add(table.name)
    return [t for t in reversed(metadata.sorted_tables) if t.name in owned]


def _belongs(table: Table, participant_id: int, owned: set[str]) -> ColumnElement[bool]:
    """Rows of `table` that are the participant's through any foreign-key path."""
    if table.name == "participant":
        return table.c.id == participant_id
    paths = [
        fk.parent.in_(_ids_of(fk.column.table, fk.column.name, participant_id, owned))
        for fk in table.foreign_keys
        if fk.column.table.name in owned
    ]
    return or_(false(), *paths)


def _ids_of(table: Table, column: str, participant_id: int, owned: set[str]) -> Select:
    return select(table.c[column]).where(_belongs(table, participant_id, owned))


def participant_row_counts(session: Session, participant_id: int) -> dict[str, int]:
    """How many rows of each table belong to the participant (for the audit and tests)."""
    tables = participant_tables()
    owned = {t.name for t in tables}
    counts = {}
    for table in tables:
        query = select(table.c[next(iter(table.primary_key.columns)).name]).where(
            _belongs(table, participant_id, owned)
        )
        counts[table.name] = len(session.execute(query).all())
    return counts


def withdraw(
    database: Database, live: LiveTrials, participant_code: str, experimenter: str
) -> dict[str, int]:
    """Delete the participant's data and write the audit row; returns the row counts.

    A trial still live in this server is stopped first, under its lock, so the
    runner cannot write a row for a participant who no longer exists.
    """
    with database.session_scope() as session:
        participant = session.scalars(
            select(Participant).where(Participant.code == participant_code)
        ).first()
        if participant is None:
            raise WithdrawalError(f"no participant with code {participant_code!r}")
        participant_id = participant.id
        trial_ids = list(
            session.scalars(select(Trial.id).where(Trial.participant_id == participant_id))
        )
    try:
        with live.withdrawing(trial_ids, "withdrawn"):
            return _delete_all(database, participant_id, participant_code, experimenter)
    except HostedElsewhere as elsewhere:
        raise WithdrawalError(
            f"the server process hosting trial {elsewhere.trial_id} did not hand it over in "
            "time; nothing was deleted, try again"
        ) from elsewhere


def _delete_all(
    database: Database, participant_id: int, participant_code: str, experimenter: str
) -> dict[str, int]:
    tables = participant_tables()
    owned = {t.name for t in tables}
    with database.session_scope() as session:
        counts = participant_row_counts(session, participant_id)
        # The append-only triggers let a DELETE through only while this transaction holds
        # a permit (hcss.platform.models.append_only); it is gone again before the commit.
        permit = DeletionPermit(reason="withdrawal")
        session.add(permit)
        session.flush()
        for table in tables:  # children first, so no foreign key is left dangling
            session.execute(delete(table).where(_belongs(table, participant_id, owned)))
        session.execute(delete(DeletionPermit).where(DeletionPermit.id == permit.id))
        session.add(
            AuditRecord(
                action="withdrawal",
                experimenter=experimenter,
                participant_code=participant_code,
                row_counts={name: count for name, count in counts.items() if count},
            )
        )
    return counts
