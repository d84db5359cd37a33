"""A stored decision (`DecisionRow.record`) keeps the decisions table's contract.

The live trial writer's record is checked against hcss.tablespec.DECISIONS
when the row is made: an unknown or missing column, or a value of another
type, is refused with the column named, and nothing of the unit of work is
written. The export reads a record back through the same contract, rows
stored by earlier versions (which may carry the export's own columns) alike.
"""

from __future__ import annotations

from datetime import UTC, datetime

import pytest
from flask import Flask
from sqlalchemy import func, insert, select

from hcss.platform.export.problems import ProblemLog
from hcss.platform.export.rows import decision_rows
from hcss.platform.live import trial_writer
from hcss.platform.live.facts import DecisionMade
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.models import DecisionRow, Trial
from hcss.tablespec import DECISIONS
from hcss.tablespec.decisions import RECORD_COLUMNS, stored_decision
from hcss.tablespec.spec import RowError
from tests.support.synthetic import decision_row, stored_record


@pytest.mark.parametrize(
    ("record", "message"),
    [
        (
            stored_record() | {"planted": 1},
            r"a decisions row has \['planted'\], which its contract does not name",
        ),
        (
            {k: v for k, v in stored_record().items() if k != "seed"},
            r"a decisions row lacks \['seed'\], which its contract needs",
        ),
        (
            stored_record(decision_index="1"),
            "column 'decision_index' of a decisions row holds '1', expected a whole number",
        ),
        (
            stored_record(correct="yes"),
            "column 'correct' of a decisions row holds 'yes', expected true or false",
        ),
        (stored_record(end_s=True), "column 'end_s' of a decisions row holds True, expected"),
        (
            stored_record(collective=None),
            "column 'collective' of a decisions row is empty; the dictionary allows none",
        ),
    ],
    ids=["unknown", "missing", "text-for-int", "text-for-bool", "bool-for-float", "empty"],
)
def test_a_record_that_breaks_the_contract_is_refused_when_the_row_is_made(
    record: dict, message: str
) -> None:
    with pytest.raises(RowError, match=message):
        DecisionRow(trial_id=1, collective=0, decision_index=1, step=1, record=record)


def test_a_record_that_keeps_it_is_stored_in_the_table_order_without_who_and_where() -> None:
    """The export's columns (as DecisionRecord.as_row() fills them) are left out, not refused."""
    row = DecisionRow(
        trial_id=1, collective=0, decision_index=1, step=1, record=decision_row(chosen_target=None)
    )
    assert tuple(row.record) == RECORD_COLUMNS
    assert row.record["chosen_target"] is None
    assert stored_decision(stored_record()) == stored_record()


def _count(app: Flask, trial_id: int) -> int:
    with app.extensions["hcss_db"].session_scope() as session:
        return session.scalar(
            select(func.count()).select_from(DecisionRow).where(DecisionRow.trial_id == trial_id)
        )


def _trial(app: Flask) -> int:
    with app.extensions["hcss_db"].session_scope() as session:
        _, trial = start_bot_trial(session, seed=2, duration_s=600.0)
        return trial.id


def test_the_live_writer_refuses_a_planted_record_and_writes_nothing_of_its_unit(
    app: Flask,
) -> None:
    trial_id = _trial(app)
    database = app.extensions["hcss_db"]
    with pytest.raises(RowError, match=r"has \['planted'\]"), database.session_scope() as session:
        for index, record in enumerate(
            (stored_record(), stored_record(decision_index=2) | {"planted": 1}), start=1
        ):
            trial_writer.write_fact(
                session,
                trial_id,
                DecisionMade(0, index, index, True, record),
            )
    assert _count(app, trial_id) == 0  # the good first decision went with the refused one
    with app.extensions["hcss_db"].session_scope() as session:
        trial_writer.write_fact(
            session,
            trial_id,
            DecisionMade(0, 1, 1, True, stored_record()),
        )
    assert _count(app, trial_id) == 1


def test_a_record_stored_by_an_earlier_version_still_exports_through_the_contract(
    app: Flask,
) -> None:
    """Rows of earlier versions carried source/participant/trial_id/run, and may lack a column
    added since: written here past the check, as they were, and exported with the table's
    columns, the export's own who and where, and the missing column empty."""
    trial_id = _trial(app)
    old = decision_row(participant="P-old", trial_id="99", run=3, source="simulation")
    del old["section_kind"]
    with app.extensions["hcss_db"].session_scope() as session:
        session.execute(
            insert(DecisionRow.__table__).values(
                trial_id=trial_id,
                collective=0,
                decision_index=1,
                step=1,
                correct=True,
                record=old,
                created_at=datetime.now(UTC),
            )
        )
        trial = session.get(Trial, trial_id)
        problems = ProblemLog()
        (row,) = decision_rows(session, trial, "P07", problems)
    assert problems.rows == []
    assert tuple(row) == DECISIONS.names
    assert (row["source"], row["participant"], row["trial_id"], row["run"]) == (
        "study",
        "P07",
        str(trial_id),
        0,
    )
    assert row["section_kind"] is None
    assert row["decision_index"] == 1 and row["correct"] is True
