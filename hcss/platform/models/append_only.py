"""Append-only, enforced by the database: UPDATE and DELETE refused by triggers.

Every table of what happened (participants, trials, commands, answers,
events, audits) only ever gains rows; a correction is a newer row. The
triggers make that a property of the database rather than a habit of the
code: an UPDATE is always refused, and a DELETE is refused unless the same
transaction holds a `DeletionPermit` row, which only the console's audited
withdrawal writes (and removes before it commits). Other transactions never
see an uncommitted permit, on SQLite (one writer at a time) or PostgreSQL.

One exception, for room, not for the record: a `snapshot` row may be deleted
once a newer snapshot of the same trial exists (a later step, or the same
step written later). A rebuild needs only the newest, and the command log
(append-only without exception) is what a trial is rebuilt and replayed from;
so older snapshots are thinned as a trial ages (hcss.platform.live.snapshots),
and the trigger makes sure no deletion ever leaves a trial without its newest.

`experimenter` is not append-only (accounts change), nor are `deletion_permit`
and `login_failure` (sign-in counters, cleared by a correct password and pruned;
each lockout is also an `audit_record` row).
The triggers are created by migration 0004_h13_hardening and by
`Database.create_all` (tests).
"""

from __future__ import annotations

from sqlalchemy import Connection, String, text
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt

APPEND_ONLY_TABLES = (
    "audit_record",
    "participant",
    "consent_record",
    "questionnaire_item",
    "score",
    "stage_event",
    "study_enrolment",
    "trial",
    "command",
    "console_action",
    "decision",
    "interruption",
    "observation",
    "probe",
    "request_status_change",
    "sim_event",
    "snapshot",
    "trial_problem",
    "trial_status_change",
    "command_outcome",
    "probe_event",
    "recruitment",  # 0004_o14_online: ids written once, at the first visit
    "command_key",  # 0004_p8_idempotency: a command's first answer
    "screen_out",  # 0007_screen_out: a visitor turned away before consent
    "return_visit",  # 0010_return_visit: a later visit through the study link
    "turned_away",  # i31a_mturk_submit_to: a visitor the full study turned away
    "console_form",  # i42_console_form: a Create form once carried out
)


class DeletionPermit(CreatedAt, Base):
    """Present only inside a withdrawal's transaction: the one path that may delete."""

    __tablename__ = "deletion_permit"

    id: Mapped[int] = mapped_column(primary_key=True)
    reason: Mapped[str] = mapped_column(String(32))  # "withdrawal"


_PG_FUNCTION = """
CREATE OR REPLACE FUNCTION hcss_append_only() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
    IF TG_OP = 'DELETE' AND EXISTS (SELECT 1 FROM deletion_permit) THEN
        RETURN OLD;
    END IF;
    RAISE EXCEPTION 'append-only table %: % refused', TG_TABLE_NAME, TG_OP
        USING ERRCODE = 'restrict_violation';
END
$$
"""


#: Tables whose rows may be deleted once superseded: the condition, on the deleted row OLD.
SUPERSEDED = {
    "snapshot": (
        "EXISTS (SELECT 1 FROM snapshot newer WHERE newer.trial_id = OLD.trial_id "
        "AND (newer.step > OLD.step OR (newer.step = OLD.step AND newer.id > OLD.id)))"
    ),
}

_PG_SUPERSEDED = """
CREATE OR REPLACE FUNCTION hcss_{table}_superseded() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
    IF TG_OP = 'DELETE' AND (EXISTS (SELECT 1 FROM deletion_permit) OR {condition}) THEN
        RETURN OLD;
    END IF;
    RAISE EXCEPTION 'append-only table %: % refused', TG_TABLE_NAME, TG_OP
        USING ERRCODE = 'restrict_violation';
END
$$
"""


def trigger_statements(dialect: str, tables: tuple[str, ...] = APPEND_ONLY_TABLES) -> list[str]:
    """The DDL that makes `tables` append-only on this dialect ("sqlite" or "postgresql").

    Idempotent, so a second `create_all` on the same database (a test's restart) is harmless.
    """
    if dialect == "postgresql":
        statements = [_PG_FUNCTION]
        for table in tables:
            function = "hcss_append_only"
            if table in SUPERSEDED:
                function = f"hcss_{table}_superseded"
                statements.append(_PG_SUPERSEDED.format(table=table, condition=SUPERSEDED[table]))
            statements.append(f"DROP TRIGGER IF EXISTS append_only_{table} ON {table}")
            statements.append(
                f"CREATE TRIGGER append_only_{table} BEFORE UPDATE OR DELETE ON {table} "
                f"FOR EACH ROW EXECUTE FUNCTION {function}()"
            )
        return statements
    if dialect == "sqlite":
        statements = []
        for table in tables:
            statements.append(
                f"CREATE TRIGGER IF NOT EXISTS append_only_{table}_update BEFORE UPDATE ON {table} "
                f"BEGIN SELECT RAISE(ABORT, 'append-only table {table}: UPDATE refused'); END"
            )
            superseded = f"AND NOT {SUPERSEDED[table]} " if table in SUPERSEDED else ""
            statements.append(
                f"CREATE TRIGGER IF NOT EXISTS append_only_{table}_delete BEFORE DELETE ON {table} "
                f"WHEN NOT EXISTS (SELECT 1 FROM deletion_permit) {superseded}"
                f"BEGIN SELECT RAISE(ABORT, 'append-only table {table}: DELETE refused'); END"
            )
        return statements
    raise ValueError(f"no append-only triggers for {dialect!r}")


def drop_statements(dialect: str, tables: tuple[str, ...] = APPEND_ONLY_TABLES) -> list[str]:
    if dialect == "postgresql":
        return (
            [f"DROP TRIGGER IF EXISTS append_only_{t} ON {t}" for t in tables]
            + [f"DROP FUNCTION IF EXISTS hcss_{t}_superseded()" for t in tables if t in SUPERSEDED]
            + ["DROP FUNCTION IF EXISTS hcss_append_only()"]
        )
    return [
        f"DROP TRIGGER IF EXISTS append_only_{t}_{op}"
        for t in tables
        for op in ("update", "delete")
    ]


def install_triggers(connection: Connection) -> None:
    for statement in trigger_statements(connection.dialect.name):
        connection.execute(text(statement))
