"""Status vocabularies are enforced by the database, on the migrated schema and on create_all."""

from __future__ import annotations

import pytest
from sqlalchemy import text
from sqlalchemy.exc import IntegrityError

from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.models import Participant, TrialStatusChange
from hcss.platform.models.vocabularies import RequestStatus, TrialKind, TrialStatus


def _trial_sql(participant_id: int, kind: str) -> str:
    return (
        "INSERT INTO trial (participant_id, kind, model, scenario, scenario_id, seed, "
        "first_section, params, probe_counts, time_acceleration, duration_s, started_at, "
        f"deadline, created_at) VALUES ({participant_id}, '{kind}', 'M1', '{{}}', 's', 1, NULL, "
        "NULL, NULL, 1.0, 60.0, '2026-01-01 00:00:00', '2026-01-01 00:01:00', "
        "'2026-01-01 00:00:00')"
    )


def _refused(database: Database, statement: str) -> None:
    """Refused by a CHECK constraint (not by a foreign key or anything else)."""
    refusal = pytest.raises(IntegrityError, match="(?i)check constraint")
    with refusal, database.engine.begin() as connection:
        connection.execute(text(statement))


def _check_vocabularies(database: Database) -> None:
    with database.session_scope() as session:
        participant = Participant(is_bot=True)
        session.add(participant)
        session.flush()
        pid = participant.id
    _refused(database, _trial_sql(pid, "rehearsal"))
    with database.engine.begin() as connection:
        connection.execute(text(_trial_sql(pid, TrialKind.TRIAL)))
        tid = connection.execute(text("SELECT max(id) FROM trial")).scalar_one()
    _refused(
        database,
        "INSERT INTO trial_status_change (trial_id, status, reason, step, created_at) "
        f"VALUES ({tid}, 'paused', '', 0, '2026-01-01 00:00:00')",
    )
    _refused(
        database,
        "INSERT INTO request_status_change (trial_id, request_id, status, step, sim_time, "
        f"created_at) VALUES ({tid}, 1, 'done', 0, 0.0, '2026-01-01 00:00:00')",
    )
    with database.session_scope() as session:  # every value of the vocabulary is accepted
        for status in TrialStatus:
            session.add(TrialStatusChange(trial_id=tid, status=status, reason=""))
    with database.engine.begin() as connection:
        for status in RequestStatus:
            connection.execute(
                text(
                    "INSERT INTO request_status_change (trial_id, request_id, status, step, "
                    "sim_time, created_at) VALUES (:t, 1, :s, 0, 0.0, '2026-01-01 00:00:00')"
                ),
                {"t": tid, "s": str(status)},
            )


def test_the_migrated_schema_refuses_a_status_outside_its_vocabulary(database_url) -> None:
    upgrade_database(database_url)
    database = Database(database_url)
    try:
        _check_vocabularies(database)
        # The tables the migration rebuilt on SQLite are still append-only.
        with pytest.raises(Exception, match="append-only"), database.engine.begin() as c:
            c.execute(text("UPDATE trial_status_change SET reason = 'x'"))
    finally:
        database.engine.dispose()


def test_create_all_builds_the_same_constraints(app) -> None:
    _check_vocabularies(app.extensions["hcss_db"])
