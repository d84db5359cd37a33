"""Which participants an export holds: all of them, or one study's.

A server runs several study files (the protocol, a demo for walk-throughs),
and their data must not be pooled by accident. A participant belongs to the
study of their newest enrolment; one who never opened their link has none
yet and belongs to the study the experimenter chose when creating them.
"""

from __future__ import annotations

from sqlalchemy import exists, select, union
from sqlalchemy.orm import Session

from hcss.platform.models import Participant, StudyEnrolment
from hcss.platform.models.latest import latest_per_key, newest_ids


class UnknownStudy(ValueError):
    """An export asked for a study no participant belongs to; the message lists those there are."""


def participant_studies(session: Session) -> dict[int, str | None]:
    """Each participant's study: their newest enrolment's, else the one chosen at creation."""
    newest = latest_per_key(session, StudyEnrolment, StudyEnrolment.participant_id)
    enrolled = {pid: enrolment.study for pid, enrolment in newest.items()}
    chosen = session.execute(select(Participant.id, Participant.study))
    return {pid: enrolled.get(pid, study) for pid, study in chosen}


def present_studies(session: Session) -> list[str]:
    """The studies that have participants, as `participant_studies` assigns them, sorted.

    Asked in the database: every console page lists them, and reading each
    participant's study into Python cost over a second at 5,000 participants.
    """
    enrolled = select(StudyEnrolment.study).where(
        StudyEnrolment.id.in_(newest_ids(StudyEnrolment, StudyEnrolment.participant_id))
    )
    chosen = select(Participant.study).where(
        Participant.study.is_not(None),
        ~exists().where(StudyEnrolment.participant_id == Participant.id),
    )
    return sorted(name for name in session.scalars(union(enrolled, chosen)) if name)


def participants_of(session: Session, study: str | None) -> list[Participant]:
    """Every participant (study None) or the study's, in id order; UnknownStudy when it has none."""
    participants = list(session.scalars(select(Participant).order_by(Participant.id)))
    if study is None:
        return participants
    studies = participant_studies(session)
    chosen = [p for p in participants if studies.get(p.id) == study]
    if not chosen:
        present = sorted({name for name in studies.values() if name})
        raise UnknownStudy(
            f"no participant belongs to study {study!r}; studies in this database: "
            + (", ".join(present) or "none")
        )
    return chosen
