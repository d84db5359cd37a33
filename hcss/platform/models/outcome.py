"""What the collectives did: decision records and the system messages."""

from __future__ import annotations

from typing import Any

from sqlalchemy import ForeignKey, Index, String
from sqlalchemy.orm import Mapped, mapped_column, validates

from hcss.platform.models.base import Base, CreatedAt
from hcss.tablespec.decisions import stored_decision


class DecisionRow(CreatedAt, Base):
    """One completed collective decision: `DecisionRecord.as_row()` plus keys to query by.

    `record` is the decisions table's row without the export's who and where
    (hcss.tablespec.decisions.RECORD_COLUMNS), checked against that contract
    when a row is made: an unknown or missing column, or a value of another
    type, raises RowError before anything is added to the session. The
    export reads it back through the same contract (`exported_decision`).

    It stays one JSON column, not 24: the table's contract, not the database
    schema, is the one place its columns are written, so a column added to
    the decisions table needs no migration here; the row is written once and
    read only by the export, never queried by a column of the record (the
    keys to query by, trial, collective, index, step and correct, are real
    columns); and the rows stored by earlier versions, which may carry
    source, participant, trial_id and run too, stay readable as they are.
    """

    __tablename__ = "decision"
    # A decision is stored once, whoever writes it and however often (i29_unique_trial_rows).
    __table_args__ = (
        Index("uq_decision_trial", "trial_id", "collective", "decision_index", unique=True),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    collective: Mapped[int]
    decision_index: Mapped[int]
    step: Mapped[int]  # step at which the record appeared
    correct: Mapped[bool | None]
    # The simulation's decision record as decisions-table columns, without the export's
    # source/participant/trial_id/run (rows written by earlier versions may also carry them).
    record: Mapped[dict[str, Any]]

    @validates("record")
    def _keeps_the_contract(self, _key: str, record: dict[str, Any]) -> dict[str, Any]:
        return stored_decision(record)


class SimEvent(CreatedAt, Base):
    """A system message from `Simulation.drain_events()` (discovery, commitment, ...)."""

    __tablename__ = "sim_event"
    # An event is its kind, time and text within the trial: stored once (i29_unique_trial_rows).
    __table_args__ = (
        Index("uq_sim_event_trial", "trial_id", "kind", "sim_time", "text", unique=True),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    kind: Mapped[str] = mapped_column(String(32))
    collective: Mapped[int | None]
    target: Mapped[int | None]
    text: Mapped[str] = mapped_column(String(300))
    sim_time: Mapped[float]
