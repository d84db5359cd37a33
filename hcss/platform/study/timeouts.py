"""Timing out abandoned participants, by the study file's `[timeouts]`.

A participant who stops coming back is found whenever someone needs the
answer: the console before it lists participants, the study link before it
counts places, the personal link before it shows a page. Each of those calls
`time_out_abandoned`, which writes a `time_out` console action (no
experimenter) for every active, in-progress participant whose last sign of
life (a page heartbeat, a stage event, the enrolment) is older than
`inactivity_s`, or whose enrolment is older than `overall_s`. The session is
then `timed_out` (hcss.platform.models.participant_state): held like an abort, exported
with that status, and its cell free unless the study says `free_cell = false`.
A running trial is never timed out: it ends at its own limit first.
"""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.live.trials import latest_status
from hcss.platform.models import (
    ConsoleAction,
    Participant,
    ParticipantPresence,
    StageEvent,
    StudyEnrolment,
    Trial,
)
from hcss.platform.models.latest import latest_per_key
from hcss.platform.models.participant_state import participant_states
from hcss.platform.models.vocabularies import TrialStatus
from hcss.platform.study.flow import current_position
from hcss.platform.study.studyfile import Study, StudyFileError, load_study

#: The detail of the console's `resume` that reinstates a timed-out participant
#: (hcss.platform.console.interventions.reinstate).
REINSTATED = "reinstated after a time-out"


def _studies(names: set[str]) -> dict[str, Study]:
    studies = {}
    for name in names:
        try:
            studies[name] = load_study(name)
        except StudyFileError:  # a file since removed: its participants are left alone
            continue
    return studies


def overdue_reason(study: Study, enrolled_at: float, last_sign: float, now: float) -> str | None:
    """Why a participant is timed out now, or None."""
    limits = study.timeouts
    if limits.overall_s and now - enrolled_at >= limits.overall_s:
        return f"over the study's time limit of {limits.overall_s:g} s"
    if limits.inactivity_s and now - last_sign >= limits.inactivity_s:
        return f"no activity for {now - last_sign:.0f} s"
    return None


def time_out_abandoned(
    session: Session, now: datetime, participant_id: int | None = None
) -> list[str]:
    """Time out every abandoned participant (or only this one); their codes. The caller commits."""
    only = (  # a participant's own page: one row, not the table's
        () if participant_id is None else (StudyEnrolment.participant_id == participant_id,)
    )
    # Which studies time participants out, asked first: the console's table calls this every
    # poll, and reading 5,000 enrolments of studies without [timeouts] cost most of a second.
    studies = _studies(set(session.scalars(select(StudyEnrolment.study).where(*only).distinct())))
    if not any(study.timeouts.active for study in studies.values()):
        return []
    enrolments = latest_per_key(session, StudyEnrolment, StudyEnrolment.participant_id, *only)
    limited = {
        pid: e
        for pid, e in enrolments.items()
        if e.study in studies and studies[e.study].timeouts.active and participant_id in (None, pid)
    }
    if not limited:
        return []
    states = participant_states(session)
    presence = select(ParticipantPresence.participant_id, ParticipantPresence.last_seen_epoch)
    seen = {pid: last for pid, last in session.execute(presence)}
    stage_at = {
        pid: event.at
        for pid, event in latest_per_key(session, StageEvent, StageEvent.participant_id).items()
    }
    trials = {
        pid: trial.id for pid, trial in latest_per_key(session, Trial, Trial.participant_id).items()
    }
    # An experimenter who reinstated a timed-out participant (a `resume` after the time-out)
    # gave them a fresh start: both limits count from then.
    resumed = {
        pid: row.at_epoch
        for pid, row in latest_per_key(
            session,
            ConsoleAction,
            ConsoleAction.participant_id,
            ConsoleAction.action == "resume",
            ConsoleAction.detail == REINSTATED,
        ).items()
    }
    epoch = now.timestamp()
    timed_out = []
    for pid, enrolment in limited.items():
        if states.get(pid, "active") != "active":
            continue
        trial_id = trials.get(pid)
        if trial_id is not None and latest_status(session, int(trial_id)) == TrialStatus.RUNNING:
            continue
        started = max(enrolment.created_at.timestamp(), resumed.get(pid, 0.0))
        signs = [started, float(seen.get(pid, 0.0))]
        if pid in stage_at:
            signs.append(stage_at[pid].timestamp())  # type: ignore[attr-defined]
        reason = overdue_reason(studies[enrolment.study], started, max(signs), epoch)
        if reason is None:
            continue
        participant = session.get(Participant, pid)
        assert participant is not None
        if current_position(session, participant).status != "in_progress":
            continue
        session.add(
            ConsoleAction(
                participant_id=pid,
                experimenter_id=None,
                action="time_out",
                at_epoch=epoch,
                detail=reason,
            )
        )
        timed_out.append(participant.code)
    session.flush()
    return timed_out
