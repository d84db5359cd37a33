"""What the study flow records: enrolment, stage events, answers, scores, consent.

Every table is append-only. A participant's position in the study is read
from their `StageEvent` rows, never from a counter updated in place, so the
record of what they saw and when is complete, and a refresh or a restart
resumes exactly where they were. A correction is a new row; the newest row
wins wherever one value is needed (the enrolment, an answer).

Column names follow docs/data-dictionary.md (`questionnaire_items`, `scores`,
`stage_timings`, the `participants` table's study/cell/model_order), so the
export reads them without renaming.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import ForeignKey, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt

#: `skipped`: the experimenter moved the participant past the step (hcss.platform.console.skipping);
#: `late_answer`: answers sent from a page after its step was skipped, kept apart (detail).
STAGE_EVENT_KINDS = ("entered", "submitted", "timed_out", "skipped", "late_answer")
CONSENT_DECISIONS = ("agree", "decline")


class StudyEnrolment(CreatedAt, Base):
    """A participant's study file and counterbalancing cell.

    Written by `assign_cell`; an experimenter's override sets `override`. A
    re-assignment (allowed only before the first model-specific stage) is a
    new row, and the newest row is the participant's enrolment.
    `time_acceleration` is fixed here: 1.0 for real and pilot participants.
    """

    __tablename__ = "study_enrolment"

    id: Mapped[int] = mapped_column(primary_key=True)
    participant_id: Mapped[int] = mapped_column(ForeignKey("participant.id"), index=True)
    study: Mapped[str] = mapped_column(String(64))  # study file name, e.g. "original"
    study_digest: Mapped[str] = mapped_column(String(64))  # sha256 of the file used
    cell: Mapped[int]  # 1-based cell of the study's counterbalancing design
    model_order: Mapped[str] = mapped_column(String(32))  # e.g. "M2,M1,M3"
    first_sections: Mapped[dict[str, Any]]  # model -> "easy" | "difficult"
    override: Mapped[bool] = mapped_column(default=False)  # chosen by an experimenter
    # Which participants this one was balanced against: real, pilot, bot or demo.
    pool: Mapped[str] = mapped_column(String(8))
    time_acceleration: Mapped[float] = mapped_column(default=1.0)

    def models(self) -> tuple[str, ...]:
        return tuple(self.model_order.split(","))


class StageEvent(CreatedAt, Base):
    """One thing that happened to one step of one stage: entered, submitted, timed out.

    `at` is the study clock when it happened (for a time-out: the deadline
    itself, even when it is recorded later, at the participant's return);
    `created_at` is when the row was written. `deadline` (on ``entered``
    rows of timed steps) is absolute and enforced by the server. `detail`
    keeps what must be shown again identically after a refresh, such as the
    NASA-TLX pair order or the trial id. The unique constraint makes a double
    submission impossible even for two requests racing each other.
    """

    __tablename__ = "stage_event"
    __table_args__ = (
        UniqueConstraint("participant_id", "stage_index", "step", "kind", name="uq_stage_event"),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    participant_id: Mapped[int] = mapped_column(ForeignKey("participant.id"), index=True)
    stage_index: Mapped[int]  # position in the study's stage list, 0-based
    stage: Mapped[str] = mapped_column(String(32))  # e.g. "consent", "trial"
    step: Mapped[str] = mapped_column(String(32))  # e.g. "form", "part_1", "page_3"
    model: Mapped[str] = mapped_column(String(4), default="")  # per-model stages only
    kind: Mapped[str] = mapped_column(String(16))  # STAGE_EVENT_KINDS
    at: Mapped[datetime]
    deadline: Mapped[datetime | None]
    detail: Mapped[dict[str, Any] | None]


class QuestionnaireItem(CreatedAt, Base):
    """One raw answer to one item (the export's `questionnaire_items` row).

    `value` is the answer as text, exactly as given. `model` is the model the
    answer is about, empty for per-participant instruments. MRT answers are
    one row per item answered (the chosen alternatives, e.g. "0,2").
    """

    __tablename__ = "questionnaire_item"

    id: Mapped[int] = mapped_column(primary_key=True)
    participant_id: Mapped[int] = mapped_column(ForeignKey("participant.id"), index=True)
    stage_index: Mapped[int]
    instrument: Mapped[str] = mapped_column(String(32))
    model: Mapped[str] = mapped_column(String(4), default="")
    item: Mapped[str] = mapped_column(String(64))
    value: Mapped[str] = mapped_column(String(200))
    at: Mapped[datetime]  # study clock when the answer was submitted


class Score(CreatedAt, Base):
    """One computed score (the export's `scores` row), from hcss.questionnaires scoring."""

    __tablename__ = "score"

    id: Mapped[int] = mapped_column(primary_key=True)
    participant_id: Mapped[int] = mapped_column(ForeignKey("participant.id"), index=True)
    instrument: Mapped[str] = mapped_column(String(32))
    model: Mapped[str] = mapped_column(String(4), default="")
    scale: Mapped[str] = mapped_column(String(64))
    score: Mapped[float]


class ConsentRecord(CreatedAt, Base):
    """The consent decision, with the version of the text the participant read.

    For a participant who declines, this row (and the consent page's own
    stage events) is all that is kept.
    """

    __tablename__ = "consent_record"

    id: Mapped[int] = mapped_column(primary_key=True)
    participant_id: Mapped[int] = mapped_column(ForeignKey("participant.id"), index=True)
    version: Mapped[str] = mapped_column(String(32))
    decision: Mapped[str] = mapped_column(String(8))  # "agree" or "decline"
    at: Mapped[datetime]
