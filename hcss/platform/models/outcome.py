"""What the collectives did: decision records and the system messages."""

from __future__ import annotations

from typing import Any

from sqlalchemy import ForeignKey, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt


class DecisionRow(CreatedAt, Base):
    """One completed collective decision: `DecisionRecord.as_row()` plus keys to query by."""

    __tablename__ = "decision"

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    collective: Mapped[int]
    decision_index: Mapped[int]
    step: Mapped[int]  # step at which the record appeared
    correct: Mapped[bool | None]
    # The simulation's decision record as decisions-table columns, without the export's
    # source/participant/trial_id/run (rows written by earlier versions may also carry them).
    record: Mapped[dict[str, Any]]


class SimEvent(CreatedAt, Base):
    """A system message from `Simulation.drain_events()` (discovery, commitment, ...)."""

    __tablename__ = "sim_event"

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    kind: Mapped[str] = mapped_column(String(32))
    collective: Mapped[int | None]
    target: Mapped[int | None]
    text: Mapped[str] = mapped_column(String(300))
    sim_time: Mapped[float]
