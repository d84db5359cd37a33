"""A live trial and the rows that let it be resumed after a crash.

A `Trial` row is written once, when the trial starts: scenario, seed, model,
time acceleration and the absolute deadline. Everything that happens later is
a new row: status changes, snapshots, interruptions.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import ForeignKey, Index, LargeBinary, String
from sqlalchemy.orm import Mapped, mapped_column, relationship

from hcss.platform.models.base import Base, CreatedAt
from hcss.platform.models.participant import Participant
from hcss.platform.models.vocabularies import TrialKind, TrialStatus, check_in

TRIAL_KINDS = tuple(TrialKind)
TRIAL_STATUSES = tuple(TrialStatus)


class Trial(CreatedAt, Base):
    __tablename__ = "trial"
    __table_args__ = (check_in("kind", TrialKind, "kind"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    participant_id: Mapped[int] = mapped_column(ForeignKey("participant.id"), index=True)
    kind: Mapped[str] = mapped_column(String(16))  # "training" or "trial"
    model: Mapped[str] = mapped_column(String(4))  # "M1", "M2", "M3"
    scenario: Mapped[dict[str, Any]]  # Scenario.to_dict()
    scenario_id: Mapped[str] = mapped_column(String(64))
    seed: Mapped[int]
    first_section: Mapped[str | None] = mapped_column(String(16))
    params: Mapped[dict[str, Any] | None]  # None: the model's default parameters
    # SA probes per 20-minute trial by level ({"1": 4, ...}) from the study's [probes];
    # None: the original protocol's counts (trials started before 0005_a10_vocabularies).
    probe_counts: Mapped[dict[str, Any] | None]
    # Trial seconds per wall-clock second (1.0 in the study).
    time_acceleration: Mapped[float] = mapped_column(default=1.0)
    duration_s: Mapped[float]  # trial time
    started_at: Mapped[datetime]
    deadline: Mapped[datetime]  # absolute, enforced by the server

    participant: Mapped[Participant] = relationship()


class TrialStatusChange(CreatedAt, Base):
    """The trial's status history; the latest row is its status now."""

    __tablename__ = "trial_status_change"
    __table_args__ = (check_in("status", TrialStatus, "status"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    status: Mapped[str] = mapped_column(String(16))
    reason: Mapped[str] = mapped_column(String(64), default="")
    step: Mapped[int] = mapped_column(default=0)


class Snapshot(CreatedAt, Base):
    """`Simulation.snapshot()` bytes; with the commands after it, a crash loses nothing."""

    __tablename__ = "snapshot"

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    step: Mapped[int]
    sim_time: Mapped[float]
    # The last command applied to the state in `blob`; replay starts after it.
    last_command_id: Mapped[int | None]
    blob: Mapped[bytes] = mapped_column(LargeBinary)


class Interruption(CreatedAt, Base):
    """A server restart that found this trial live and rebuilt it, or a database outage
    the server lived through (the trial stood still; `replayed_commands` 0, and
    `snapshot_step` = `resumed_step`, the step it stood at)."""

    __tablename__ = "interruption"
    # An outage is known by when the trial was last seen before it: two rebuilds of one
    # outage store one row (i29_unique_trial_rows). A database outage's later stretch
    # starts where the stored rows end, so it is another key.
    __table_args__ = (Index("uq_interruption_trial", "trial_id", "last_seen_at", unique=True),)

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    snapshot_step: Mapped[int]  # -1 when rebuilt from the scenario (no snapshot yet)
    resumed_step: Mapped[int]  # the wall-clock-due step the rebuild reached
    replayed_commands: Mapped[int]
    state_digest: Mapped[str] = mapped_column(String(128))  # at resumed_step
    last_seen_at: Mapped[datetime | None]  # newest row written before the interruption
    # Wall seconds the trial clock stood still for the outage (hcss.platform.live.outages).
    outage_s: Mapped[float] = mapped_column(default=0.0)


class TrialProblem(CreatedAt, Base):
    """A stored record a rebuild could not use, or a trial that could not be rebuilt at all.

    The rebuild skips such a record (or, when the trial cannot be loaded,
    ends it with reason ``rebuild_failed``) and writes this row, so one bad
    row costs no other trial anything and the data say what happened.
    """

    __tablename__ = "trial_problem"

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    source: Mapped[str] = mapped_column(String(16))  # "rebuild"
    record: Mapped[str] = mapped_column(String(64))  # e.g. "command 17", "trial 4"
    problem: Mapped[str] = mapped_column(String(300))
