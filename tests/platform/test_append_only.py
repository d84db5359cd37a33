"""Issue 13 §6: "append-only" is enforced by the database, on SQLite and PostgreSQL.

UPDATE and DELETE on the append-only tables are refused by triggers, whoever
sends them (here: raw SQL, as a careless script would). Marking a pilot is an
action row, not an update of the participant; withdrawal is the one path
that deletes, and it is audited.
"""

from __future__ import annotations

import pytest
from sqlalchemy import func, select, text
from sqlalchemy.exc import DBAPIError

from hcss.cli import main  # noqa: F401 - the CLI wires the platform's commands
from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.models import (
    APPEND_ONLY_TABLES,
    AuditRecord,
    Command,
    ConsoleAction,
    ConsoleForm,
    Participant,
)
from hcss.platform.models.pilots import is_pilot
from tests.support.console import code_of


def _refused(database: Database, statement: str) -> str:
    with pytest.raises(DBAPIError) as refusal, database.engine.begin() as connection:
        connection.execute(text(statement))
    return str(refusal.value)


def test_updates_and_deletes_are_refused_by_the_database(app, make_trial) -> None:
    trial = make_trial()
    trial.run_to(30)
    target = next(t for t in trial.state()["view"]["targets"] if 0 in t["in_range_of"])
    trial.post("/requests", {"kind": "investigate", "collective": 0, "target": target["id"]})
    database = app.extensions["hcss_db"]

    assert "append-only" in _refused(database, "UPDATE command SET collective = 3")
    assert "append-only" in _refused(database, "DELETE FROM command_outcome")
    assert "append-only" in _refused(database, "UPDATE participant SET is_pilot = NOT is_pilot")
    assert "append-only" in _refused(database, "DELETE FROM snapshot")
    with database.session_scope() as session:
        assert session.scalar(select(func.count()).select_from(Command)) == 1


def test_every_append_only_table_has_its_triggers(app) -> None:
    """Read from the database's catalogue (an UPDATE of an empty table fires no trigger)."""
    database = app.extensions["hcss_db"]
    with database.engine.connect() as connection:
        if connection.dialect.name == "sqlite":
            rows = connection.execute(
                text("SELECT tbl_name, name FROM sqlite_master WHERE type = 'trigger'")
            )
            guarded = {
                (table, name.rsplit("_", 1)[-1].upper())
                for table, name in rows
                if name.startswith("append_only_")
            }
        else:
            rows = connection.execute(
                text(
                    "SELECT event_object_table, event_manipulation "
                    "FROM information_schema.triggers "
                    "WHERE trigger_schema = current_schema() AND trigger_name LIKE 'append_only_%'"
                )
            )
            guarded = set(rows)
    assert guarded == {(t, op) for t in APPEND_ONLY_TABLES for op in ("UPDATE", "DELETE")}
    assert "experimenter" not in APPEND_ONLY_TABLES  # accounts may change


def test_the_migrated_database_has_the_triggers(database_url) -> None:
    upgrade_database(database_url)
    database = Database(database_url)
    try:
        with database.session_scope() as session:
            session.add(Participant(is_bot=True))
        assert "append-only" in _refused(database, "UPDATE participant SET is_bot = false")
        assert "append-only" in _refused(database, "DELETE FROM participant")
        # the newest append-only table's triggers come from its own migration
        with database.session_scope() as session:
            session.add(ConsoleForm(key="k" * 22, batch="P00000000"))
        assert "append-only" in _refused(database, "UPDATE console_form SET batch = 'x'")
        assert "append-only" in _refused(database, "DELETE FROM console_form")
    finally:
        database.engine.dispose()


def test_marking_a_pilot_is_an_action_not_an_update(app, make_trial, console) -> None:
    trial = make_trial()
    code = code_of(app, trial.token)
    assert console.act(code, "mark_pilot").status_code == 303
    assert console.act(code, "mark_pilot").status_code == 303  # refused: already a pilot
    assert console.act(code, "unmark_pilot").status_code == 303
    assert console.act(code, "mark_pilot").status_code == 303
    database = app.extensions["hcss_db"]
    with database.session_scope() as session:
        participant = session.scalars(select(Participant).where(Participant.code == code)).one()
        assert participant.is_pilot is False  # the creation flag, never rewritten
        assert is_pilot(session, participant) is True
        actions = session.scalars(
            select(ConsoleAction.action)
            .where(ConsoleAction.participant_id == participant.id)
            .order_by(ConsoleAction.id)
        ).all()
    assert actions == ["mark_pilot", "unmark_pilot", "mark_pilot"]
    assert console.progress()[code]["is_pilot"] is True
    assert "Unmark pilot" in console.get(f"/console/participants/{code}").get_data(as_text=True)


def test_withdrawal_is_the_one_path_that_deletes_and_it_is_audited(
    app, make_trial, console
) -> None:
    trial = make_trial()
    trial.run_to(20)
    code = code_of(app, trial.token)
    response = console.post(f"/console/participants/{code}/withdraw", {"confirm_code": code})
    assert response.status_code == 303
    database = app.extensions["hcss_db"]
    with database.session_scope() as session:
        assert session.scalar(select(func.count()).select_from(Participant)) == 0
        (audit,) = session.scalars(select(AuditRecord).where(AuditRecord.action == "withdrawal"))
        assert audit.participant_code == code and audit.row_counts["participant"] == 1
        assert session.execute(text("SELECT count(*) FROM deletion_permit")).scalar() == 0
    assert "append-only" in _refused(database, "DELETE FROM audit_record")
