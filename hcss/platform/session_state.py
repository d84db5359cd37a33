"""A participant's session state: ``active``, ``paused``, ``aborted`` or ``timed_out``.

The rule, in one place: the state is given by the participant's latest
pause/resume/abort/time_out `ConsoleAction` row (none: active). The console writes those
rows; the study flow holds a paused or aborted participant in place; enrolment
does not count an aborted participant in a cell. All three ask this module.
"""

from __future__ import annotations

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from hcss.platform.models import ConsoleAction

#: The console actions that change a session's state.
#: `time_out` is written by the server itself (hcss.platform.study.timeouts), never the console.
STATE_ACTIONS = ("pause", "resume", "abort", "time_out")

_STATE_OF_ACTION = {
    "pause": "paused",
    "resume": "active",
    "abort": "aborted",
    "time_out": "timed_out",
}
#: States after which the session never continues.
ENDED_STATES = ("aborted", "timed_out")


def _latest_state_actions():
    """Subquery: the newest pause/resume/abort row id per participant."""
    return (
        select(func.max(ConsoleAction.id))
        .where(ConsoleAction.action.in_(STATE_ACTIONS))
        .group_by(ConsoleAction.participant_id)
    )


def session_state(session: Session, participant_id: int) -> str:
    """``active``, ``paused`` or ``aborted``, from the latest pause/resume/abort row."""
    latest = session.scalars(
        select(ConsoleAction.action)
        .where(
            ConsoleAction.participant_id == participant_id,
            ConsoleAction.action.in_(STATE_ACTIONS),
        )
        .order_by(ConsoleAction.id.desc())
        .limit(1)
    ).first()
    return _STATE_OF_ACTION.get(latest or "", "active")


def session_states(session: Session) -> dict[int, str]:
    """`session_state` of every participant with a pause/resume/abort row, in one query."""
    rows = session.execute(
        select(ConsoleAction.participant_id, ConsoleAction.action).where(
            ConsoleAction.id.in_(_latest_state_actions())
        )
    )
    return {pid: _STATE_OF_ACTION[action] for pid, action in rows}


def aborted_participants(session: Session) -> set[int]:
    """Ids of every participant whose session is ``aborted``."""
    return {pid for pid, state in session_states(session).items() if state == "aborted"}


def timed_out_participants(session: Session) -> set[int]:
    """Ids of every participant the server timed out (inactive, or over the study's limit)."""
    return {pid for pid, state in session_states(session).items() if state == "timed_out"}
