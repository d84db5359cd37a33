"""How an online participant arrived: the recruitment site's ids, kept for payment and export.

One row per participant enrolled through a study link, written in the same
transaction as the participant and their enrolment. The unique constraint on
(study, source, recruitment_id) is what makes a returning person resume
instead of enrolling twice, even when two of their visits race each other.
Anonymous visits have no recruitment id (NULLs never collide).
"""

from __future__ import annotations

from sqlalchemy import ForeignKey, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt


class Recruitment(CreatedAt, Base):
    __tablename__ = "recruitment"
    __table_args__ = (
        UniqueConstraint("study", "source", "recruitment_id", name="uq_recruitment_identity"),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    participant_id: Mapped[int] = mapped_column(ForeignKey("participant.id"), unique=True)
    study: Mapped[str] = mapped_column(String(64))  # the study file the link enrols in
    source: Mapped[str] = mapped_column(String(16))  # prolific, sona, mturk or link
    recruitment_id: Mapped[str | None] = mapped_column(String(128))  # e.g. PROLIFIC_PID
    # The site's own study and session (Prolific STUDY_ID, SESSION_ID; MTurk hitId, assignmentId).
    recruiter_study_id: Mapped[str | None] = mapped_column(String(128))
    recruiter_session_id: Mapped[str | None] = mapped_column(String(128))
    # MTurk's turkSubmitTo (an origin the study file accepts): where the debrief posts the HIT.
    submit_to: Mapped[str | None] = mapped_column(String(128))


class ReturnVisit(CreatedAt, Base):
    """A later visit of an enrolled participant through the study link, with what it carried.

    `recruitment` keeps the first visit's ids and is append-only; a recruitment
    site gives a return visit ids of its own (Prolific a new SESSION_ID), which
    are needed to match its submissions, so each return is a row here.
    """

    __tablename__ = "return_visit"

    id: Mapped[int] = mapped_column(primary_key=True)
    participant_id: Mapped[int] = mapped_column(ForeignKey("participant.id"), index=True)
    recruiter_study_id: Mapped[str | None] = mapped_column(String(128))
    recruiter_session_id: Mapped[str | None] = mapped_column(String(128))


class ScreenOut(CreatedAt, Base):
    """A visitor the study link turned away before consent, and why; no participant is made.

    The recruitment site's id is kept so the experimenter can match the
    site's screen-out submissions (and pay them, where the site asks for it).
    """

    __tablename__ = "screen_out"

    id: Mapped[int] = mapped_column(primary_key=True)
    study: Mapped[str] = mapped_column(String(64))
    source: Mapped[str] = mapped_column(String(16))  # prolific, sona, mturk or link
    recruitment_id: Mapped[str | None] = mapped_column(String(128))
    # What the first page measured, and each shortfall in the words the visitor saw.
    width: Mapped[int] = mapped_column()
    height: Mapped[int] = mapped_column()
    mobile: Mapped[bool] = mapped_column()
    missing: Mapped[str] = mapped_column(String(128))  # browser features, comma-separated
    reasons: Mapped[str] = mapped_column(String(1000))


class TurnedAway(CreatedAt, Base):
    """A visitor with a recruitment id whom the study link turned away as full; no one enrolled.

    Kept once per (study, source, recruitment_id), so the console can count the
    visitors asked to return their submission; the page they saw said nothing
    about them was recorded beyond that they came while the study was full.
    """

    __tablename__ = "turned_away"

    id: Mapped[int] = mapped_column(primary_key=True)
    study: Mapped[str] = mapped_column(String(64), index=True)
    source: Mapped[str] = mapped_column(String(16))
    recruitment_id: Mapped[str] = mapped_column(String(128))
