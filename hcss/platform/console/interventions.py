"""Pause, resume and abort a participant's session; mark or unmark a pilot.

Every action is a new `ConsoleAction` row written before the live trial in
memory changes, inside the trial's lock, so the runner, the participant's
commands and the console never see a half-done pause. The session's state is
the latest pause/resume/abort row (the rule and its query are in
hcss.platform.models.participant_state, which the study flow asks too).
"""

from __future__ import annotations

from sqlalchemy import select, text
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live.service import LiveTrials, OrderUnconfirmed, running_trial_id
from hcss.platform.models import AuditRecord, ConsoleAction, Experimenter, Participant
from hcss.platform.models.participant_state import ENDED_STATES, STATE_ACTIONS, participant_state
from hcss.platform.models.pilots import is_pilot
from hcss.platform.study.flow import current_position, trial_states
from hcss.platform.study.timeouts import REINSTATED


class ConsoleError(ValueError):
    """An action that does not fit the session's state; nothing was changed."""


#: Statuses of a participant the study is over for: nothing left to pause or abort.
FINISHED = ("completed", "declined")


def available_actions(
    state: str, status: str, is_pilot: bool, *, in_flow: bool = True
) -> list[str]:
    """The actions that apply now, in the order the console offers them.

    `state` is `participant_state`; `status` the study engine's (``in_progress``,
    ``not_enrolled``, ``completed``, ``declined``). A finished or aborted
    session can only have its pilot flag changed; a paused one can be resumed
    or aborted, an active one paused or aborted.
    """
    actions: list[str] = []
    if state not in ENDED_STATES and status not in FINISHED:
        if status != "not_enrolled":  # nothing runs yet that a pause could hold
            actions += ["resume"] if state == "paused" else ["pause"]
        actions.append("abort")  # for a link not yet opened: it will not open
        if status == "in_progress" and in_flow:  # a demo trial has no stages to skip
            actions.append("skip_stage")  # hcss.platform.console.skipping
    if state == "timed_out" and status not in FINISHED:
        actions.append("reinstate")  # a power cut, a lost connection: let them go on
    actions.append("unmark_pilot" if is_pilot else "mark_pilot")
    return actions


def study_status(session: Session, participant: Participant) -> str:
    """The study engine's status of the participant (see `available_actions`); one outside
    the study flow (`hcss demo-trial`) is in progress while their trial runs, then completed."""
    status = current_position(session, participant).status
    if status == "not_enrolled":
        return trial_states(session, [participant.id]).get(participant.id, status)
    return status


def one_at_a_time(session: Session, participant_id: int) -> None:
    """Hold the participant's console actions one at a time until this transaction ends.

    Two experimenters acting at once must not both read the session as it was and
    both write: the state is checked, and the row written, after this. On PostgreSQL
    it takes the participant row's lock (`FOR UPDATE`); on SQLite, which has no row
    locks, it takes the database's write lock, by an UPDATE that matches no row (SQLite
    locks for any write statement, as `Database.write_refusal`'s probe relies on).
    Participant rows are append-only, so none is changed by either.
    """
    if session.get_bind().dialect.name == "postgresql":
        session.execute(
            select(Participant.id).where(Participant.id == participant_id).with_for_update()
        )
    else:
        session.execute(text("UPDATE participant SET id = id WHERE 1 = 0"))


def _checked_state(session: Session, participant: Participant, action: str) -> None:
    """Refuse (ConsoleError) an action the session's state does not allow now."""
    state = participant_state(session, participant.id)
    if state in ENDED_STATES:
        ended = state.replace("_", " ")
        raise ConsoleError(f"{participant.code}'s session was {ended}; it cannot change now")
    if action == "pause" and state == "paused":
        raise ConsoleError(f"{participant.code}'s session is already paused")
    if action == "resume" and state != "paused":
        raise ConsoleError(f"{participant.code}'s session is not paused")
    row = session.get(Participant, participant.id)
    if row is None:
        raise ConsoleError("no such participant")
    status = study_status(session, row)
    if status in FINISHED:
        raise ConsoleError(
            f"{participant.code} has {status} the study; there is nothing to {action}"
        )


def _act_without_trial(
    database: Database,
    participant: Participant,
    experimenter: Experimenter | None,
    action: str,
    at_epoch: float,
    *,
    trial_ended: bool = False,
) -> int | None:
    """Check the action and, if no trial runs (or the one that ran has ended since), write
    its row; the running trial's id otherwise, whose live service checks and writes it."""
    with database.session_scope() as session:
        one_at_a_time(session, participant.id)
        _checked_state(session, participant, action)
        trial_id = None if trial_ended else running_trial_id(session, participant)
        if trial_id is None:
            session.add(
                ConsoleAction(
                    participant_id=participant.id,
                    experimenter_id=None if experimenter is None else experimenter.id,
                    action=action,
                    at_epoch=at_epoch,
                    detail="",
                )
            )
        return trial_id


def change_participant_state(
    database: Database,
    live: LiveTrials,
    participant: Participant,
    experimenter: Experimenter | None,
    action: str,
) -> None:
    """Pause, resume or abort; refuses an action the session's state does not allow.

    Between trials the check and the row are one transaction, one experimenter's at a
    time (`one_at_a_time`). During a trial the trial's live service writes the row under
    the trial's lock, after checking the trial's state again there.
    """
    if action not in STATE_ACTIONS:
        raise ConsoleError(f"unknown session action {action!r}")
    if action == "time_out":
        raise ConsoleError("only the server times a session out")
    trial_id = _act_without_trial(database, participant, experimenter, action, live.now())
    if trial_id is None:
        return
    experimenter_id = None if experimenter is None else experimenter.id
    try:
        controlled = live.control(
            trial_id,
            action,
            participant_id=participant.id,
            experimenter_id=experimenter_id,
        )
    except OrderUnconfirmed as pending:
        raise ConsoleError(str(pending)) from pending
    if not controlled:  # the trial ended meanwhile: the row alone holds the session
        _act_without_trial(
            database, participant, experimenter, action, live.now(), trial_ended=True
        )


def set_pilot(
    database: Database,
    live: LiveTrials,
    participant: Participant,
    experimenter: Experimenter | None,
    pilot: bool,
) -> None:
    """Flag (or unflag) a pilot: an action row, the flag's history (hcss.platform.models.pilots)."""
    with database.session_scope() as session:
        one_at_a_time(session, participant.id)
        row = session.get(Participant, participant.id)
        if row is None:
            raise ConsoleError("no such participant")
        if is_pilot(session, row) == pilot:
            raise ConsoleError(f"{row.code} is {'already' if pilot else 'not'} a pilot")
        session.add(
            ConsoleAction(
                participant_id=row.id,
                experimenter_id=None if experimenter is None else experimenter.id,
                action="mark_pilot" if pilot else "unmark_pilot",
                at_epoch=live.now(),
            )
        )


def reinstate(
    database: Database, live: LiveTrials, participant: Participant, experimenter: Experimenter
) -> None:
    """Let a timed-out participant go on (a power cut, a lost connection): a `resume` row,
    from which the study's time-outs count afresh, and an audit row in the console's log."""
    with database.session_scope() as session:
        one_at_a_time(session, participant.id)
        if participant_state(session, participant.id) != "timed_out":
            raise ConsoleError(f"{participant.code} was not timed out; nothing to reinstate")
        row = session.get(Participant, participant.id)
        assert row is not None
        if study_status(session, row) in FINISHED:
            raise ConsoleError(f"{participant.code} has finished the study")
        session.add(
            ConsoleAction(
                participant_id=participant.id,
                experimenter_id=experimenter.id,
                action="resume",
                at_epoch=live.now(),
                detail=REINSTATED,
            )
        )
        session.add(
            AuditRecord(
                action="reinstate",
                experimenter=experimenter.username,
                participant_code=participant.code,
                row_counts={},
            )
        )
