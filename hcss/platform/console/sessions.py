"""Pause, resume and abort a participant's session; mark or unmark a pilot.

Every action is a new `ConsoleAction` row written before the live trial in
memory changes, inside the trial's lock, so the runner, the participant's
commands and the console never see a half-done pause. The session's state is
the latest pause/resume/abort row (the rule and its query are in
hcss.platform.session_state, which the study flow asks too).
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live.control import control_trial
from hcss.platform.live.leases import HostedElsewhere
from hcss.platform.live.orders import send_order
from hcss.platform.live.runner import Runner
from hcss.platform.live.session import RunningTrial
from hcss.platform.live.trials import current_trial, latest_status
from hcss.platform.models import ConsoleAction, Experimenter, Participant
from hcss.platform.models.vocabularies import TrialStatus
from hcss.platform.pilots import is_pilot
from hcss.platform.session_state import ENDED_STATES, STATE_ACTIONS, session_state
from hcss.platform.study.flow import current_position


class ConsoleError(ValueError):
    """An action that does not fit the session's state; nothing was changed."""


#: Statuses of a participant the study is over for: nothing left to pause or abort.
FINISHED = ("completed", "declined")


def available_actions(state: str, status: str, is_pilot: bool) -> list[str]:
    """The actions that apply now, in the order the console offers them.

    `state` is `session_state`; `status` the study engine's (``in_progress``,
    ``not_enrolled``, ``completed``, ``declined``). A finished or aborted
    session can only have its pilot flag changed; a paused one can be resumed
    or aborted, an active one paused or aborted.
    """
    actions: list[str] = []
    if state not in ENDED_STATES and status not in FINISHED:
        if status != "not_enrolled":  # nothing runs yet that a pause could hold
            actions += ["resume"] if state == "paused" else ["pause"]
        actions.append("abort")  # for a link not yet opened: it will not open
        if status == "in_progress":
            actions.append("skip_stage")  # hcss.platform.console.skipping
    actions.append("unmark_pilot" if is_pilot else "mark_pilot")
    return actions


def study_status(session: Session, participant: Participant) -> str:
    """The study engine's status of the participant (see `available_actions`)."""
    return current_position(session, participant).status


def _live_trial(
    session: Session, runner: Runner, participant: Participant
) -> RunningTrial | HostedElsewhere | None:
    """The participant's running trial if hosted here; `HostedElsewhere` if another process hosts it."""
    trial = current_trial(session, participant)
    if trial is None or latest_status(session, trial.id) != TrialStatus.RUNNING:
        return None
    try:
        return runner.get(trial.id)
    except HostedElsewhere as elsewhere:
        return elsewhere


def _record(
    database: Database,
    participant: Participant,
    experimenter: Experimenter | None,
    action: str,
    at_epoch: float,
    trial_id: int | None = None,
    detail: str = "",
) -> None:
    with database.session_scope() as session:
        session.add(
            ConsoleAction(
                participant_id=participant.id,
                experimenter_id=None if experimenter is None else experimenter.id,
                action=action,
                trial_id=trial_id,
                at_epoch=at_epoch,
                detail=detail,
            )
        )


def change_session(
    database: Database,
    runner: Runner,
    participant: Participant,
    experimenter: Experimenter | None,
    action: str,
) -> None:
    """Pause, resume or abort; refuses an action the session's state does not allow."""
    if action not in STATE_ACTIONS:
        raise ConsoleError(f"unknown session action {action!r}")
    with database.session_scope() as session:
        state = session_state(session, participant.id)
        live = _live_trial(session, runner, participant)
    if action == "time_out":
        raise ConsoleError("only the server times a session out")
    if state in ENDED_STATES:
        ended = state.replace("_", " ")
        raise ConsoleError(f"{participant.code}'s session was {ended}; it cannot change now")
    if action == "pause" and state == "paused":
        raise ConsoleError(f"{participant.code}'s session is already paused")
    if action == "resume" and state != "paused":
        raise ConsoleError(f"{participant.code}'s session is not paused")
    with database.session_scope() as session:
        row = session.get(Participant, participant.id)
        if row is None:
            raise ConsoleError("no such participant")
        status = study_status(session, row)
    if status in FINISHED:
        raise ConsoleError(
            f"{participant.code} has {status} the study; there is nothing to {action}"
        )
    experimenter_id = None if experimenter is None else experimenter.id
    if isinstance(live, HostedElsewhere):
        _send_order(database, runner, live.trial_id, action, experimenter_id)
        return
    if live is None:
        _record(database, participant, experimenter, action, runner.clock())
        return
    control_trial(
        runner, live, action, participant_id=participant.id, experimenter_id=experimenter_id
    )


def _send_order(
    database: Database, runner: Runner, trial_id: int, action: str, experimenter_id: int | None
) -> None:
    """Have the process hosting the trial carry the action out; wait for it to confirm."""
    issued_by = "" if runner.leases is None else runner.leases.owner
    outcome = send_order(
        database, trial_id, action, experimenter_id=experimenter_id, issued_by=issued_by
    )
    if outcome is None:
        raise ConsoleError(
            f"the {action} is sent to the server process hosting trial {trial_id}, which has "
            "not confirmed it yet; it is carried out as soon as that process (or the one "
            "taking the trial over) gets to it"
        )


def set_pilot(
    database: Database,
    runner: Runner,
    participant: Participant,
    experimenter: Experimenter | None,
    pilot: bool,
) -> None:
    """Flag (or unflag) a pilot: an action row, the flag's history (hcss.platform.pilots)."""
    with database.session_scope() as session:
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
                at_epoch=runner.clock(),
            )
        )
