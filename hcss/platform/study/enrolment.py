"""Counterbalancing: which cell a new participant gets, and the experimenter's override.

Each new participant gets the cell of the study's design with the fewest
participants who are in progress or completed (declined and aborted ones do
not count), ties broken at random. Real, pilot, bot and demo participants are
balanced in separate pools, so rehearsals and bot runs never unbalance the
real data.
"""

from __future__ import annotations

import os
import secrets
from collections import Counter

from flask import current_app, has_app_context
from sqlalchemy import select, text
from sqlalchemy.orm import Session, object_session

from hcss.platform.models import (
    ConsentRecord,
    Participant,
    StageEvent,
    StudyEnrolment,
)
from hcss.platform.models.latest import latest_row, newest_ids
from hcss.platform.models.participant_state import aborted_participants, timed_out_participants
from hcss.platform.models.pilots import is_pilot
from hcss.platform.study.stages import sequence
from hcss.platform.study.studyfile import Study, load_study

POOLS = ("real", "pilot", "bot", "demo")
#: Advisory-lock key of cell assignment on PostgreSQL ("HCSS" in ASCII).
ASSIGNMENT_LOCK = 0x48435353


def pool_of(participant: Participant) -> str:
    """The pool a participant is balanced in; a bot run as a pilot counts as a bot."""
    if participant.is_bot:
        return "bot"
    if participant.is_demo:
        return "demo"
    session = object_session(participant)
    if participant.is_pilot if session is None else is_pilot(session, participant):
        return "pilot"
    return "real"


def default_study_name() -> str:
    """The study new participants are enrolled in: app config STUDY, else HCSS_STUDY, else original."""
    if has_app_context() and current_app.config.get("STUDY"):
        return str(current_app.config["STUDY"])
    return os.environ.get("HCSS_STUDY", "original")


def time_acceleration_for(participant: Participant, study: Study) -> float:
    """Real and pilot participants run in real time; bots and demos as fast as allowed."""
    if pool_of(participant) not in ("bot", "demo"):
        return 1.0
    wanted = float(current_app.config.get("TIME_ACCELERATION", 1.0)) if has_app_context() else 1.0
    return max(1e-9, min(wanted, study.timing.max_time_acceleration))


def current_enrolment(session: Session, participant_id: int) -> StudyEnrolment | None:
    return latest_row(session, StudyEnrolment, StudyEnrolment.participant_id, participant_id)


def not_counted(session: Session, study: Study | None = None) -> set[int]:
    """Participants who declined consent, whose session the experimenter aborted, or who
    were timed out (unless `study` keeps a timed-out participant's cell: `free_cell = false`)."""
    declined = set(
        session.scalars(
            select(ConsentRecord.participant_id).where(ConsentRecord.decision == "decline")
        )
    )
    ended = declined | aborted_participants(session)
    if study is None or study.timeouts.free_cell:
        ended |= timed_out_participants(session)
    return ended


def cell_counts(session: Session, study: Study, pool: str) -> Counter[int]:
    """Participants per cell in one pool who are in progress or completed."""
    rows = session.execute(
        select(StudyEnrolment.participant_id, StudyEnrolment.cell).where(
            StudyEnrolment.id.in_(newest_ids(StudyEnrolment, StudyEnrolment.participant_id)),
            StudyEnrolment.study == study.name,
            StudyEnrolment.pool == pool,
        )
    ).all()
    excluded = not_counted(session, study)
    counts: Counter[int] = Counter({cell.number: 0 for cell in study.cells})
    counts.update(cell for participant_id, cell in rows if participant_id not in excluded)
    return counts


def assign_cell(
    session: Session,
    participant: Participant,
    override: int | None = None,
    *,
    study: str | None = None,
) -> StudyEnrolment:
    """Enrol the participant in a cell: the least-filled one, or `override` (recorded as such).

    Raises ValueError, writing nothing, for a cell the design does not have
    or a participant whose model-specific stages have already begun.
    """
    existing = current_enrolment(session, participant.id)
    first_choice = participant.study or default_study_name()  # chosen at creation, if any
    chosen_study = load_study(study or (existing.study if existing else first_choice))
    if existing is not None:
        _check_reassignable(session, participant, existing, chosen_study)
    pool = pool_of(participant)
    hold_assignment_lock(session)
    if override is not None:
        if isinstance(override, bool) or not isinstance(override, int):
            raise ValueError(f"a cell is a whole number, got {override!r}")
        cell = chosen_study.cell(override)
    else:
        counts = cell_counts(session, chosen_study, pool)
        if existing is not None and existing.study == chosen_study.name and existing.pool == pool:
            counts[existing.cell] -= 1  # a re-draw does not count the participant's own cell
        fewest = min(counts.values())
        candidates = [number for number, n in sorted(counts.items()) if n == fewest]
        cell = chosen_study.cell(candidates[secrets.randbelow(len(candidates))])
    enrolment = StudyEnrolment(
        participant_id=participant.id,
        study=chosen_study.name,
        study_digest=chosen_study.digest,
        cell=cell.number,
        model_order=",".join(cell.model_order),
        first_sections=dict(cell.first_sections),
        override=override is not None,
        pool=pool,
        time_acceleration=time_acceleration_for(participant, chosen_study),
    )
    session.add(enrolment)
    session.flush()
    return enrolment


def first_enrolment(session: Session, participant: Participant) -> StudyEnrolment:
    """The participant's enrolment, made on their first visit; one even for racing first visits.

    Eight tabs opening one link at once all find no enrolment; each then
    queues on the assignment lock and looks again, so only the first enrols
    and the others read its row.
    """
    hold_assignment_lock(session)
    existing = current_enrolment(session, participant.id)
    if existing is not None:
        return existing
    return assign_cell(session, participant)


def hold_assignment_lock(session: Session) -> None:
    """Two participants arriving at once must not both see the same counts.

    PostgreSQL: a transaction-scoped advisory lock queues concurrent
    assignments until the earlier one commits. SQLite: a write statement that
    changes nothing takes the database's write lock now (pysqlite begins the
    transaction before it), instead of at the enrolment's INSERT after the
    counts were read; the next arrival waits for this commit (busy timeout)
    and then reads counts that include it. Without it, 48 simultaneous
    arrivals filled the 8 cells 3/3/13/5/4/13/3/3. Both locks are held until
    the request's transaction ends and may be taken again in it.
    """
    dialect = session.get_bind().dialect.name
    if dialect == "postgresql":
        session.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": ASSIGNMENT_LOCK})
    elif dialect == "sqlite":
        session.execute(text("UPDATE study_enrolment SET cell = cell WHERE 0 = 1"))


def _check_reassignable(
    session: Session, participant: Participant, existing: StudyEnrolment, study: Study
) -> None:
    """A cell may change only before the first stage that depends on it."""
    events = list(
        session.scalars(select(StageEvent).where(StageEvent.participant_id == participant.id))
    )
    if events and study.name != existing.study:
        raise ValueError(
            f"participant {participant.code} has begun study {existing.study!r}; "
            "they cannot move to another study"
        )
    per_model = {slot.index for slot in sequence(study, existing) if slot.model}
    if any(event.stage_index in per_model for event in events):
        raise ValueError(
            f"participant {participant.code} has begun the model stages; the cell cannot change"
        )
