"""A participant's state in the study: ``active``, ``paused``, ``aborted`` or ``timed_out``.

The rule, in one place: the state is given by the participant's latest
pause/resume/abort/time_out `ConsoleAction` row (none: active). The console writes those
rows; the study flow holds a paused or aborted participant in place; enrolment
does not count an aborted participant in a cell. All three ask this module.
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from hcss.platform.models import ConsoleAction
from hcss.platform.models.latest import latest_per_key, latest_row

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


def participant_state(session: Session, participant_id: int) -> str:
    """``active``, ``paused`` or ``aborted``, from the latest pause/resume/abort row."""
    latest = latest_row(
        session,
        ConsoleAction,
        ConsoleAction.participant_id,
        participant_id,
        ConsoleAction.action.in_(STATE_ACTIONS),
    )
    return "active" if latest is None else _STATE_OF_ACTION[latest.action]


def participant_states(session: Session) -> dict[int, str]:
    """`participant_state` of every participant with a pause/resume/abort row, in one query."""
    rows = latest_per_key(
        session,
        ConsoleAction,
        ConsoleAction.participant_id,
        ConsoleAction.action.in_(STATE_ACTIONS),
    )
    return {pid: _STATE_OF_ACTION[row.action] for pid, row in rows.items()}


def aborted_participants(session: Session) -> set[int]:
    """Ids of every participant whose session is ``aborted``."""
    return {pid for pid, state in participant_states(session).items() if state == "aborted"}


def timed_out_participants(session: Session) -> set[int]:
    """Ids of every participant the server timed out (inactive, or over the study's limit)."""
    return {pid for pid, state in participant_states(session).items() if state == "timed_out"}
