"""Whether a participant is a pilot: the creation flag, then the experimenter's marks.

`Participant.is_pilot` is written once, when the participant is made (the
console's "Pilot participants" box). Marking or unmarking later is a
`ConsoleAction` row (``mark_pilot`` / ``unmark_pilot``), never an update of
the participant (the table is append-only, enforced by the database), so the
history of the flag is kept and the newest mark wins.
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from hcss.platform.models.console import ConsoleAction
from hcss.platform.models.latest import latest_per_key, latest_row
from hcss.platform.models.participant import Participant

PILOT_ACTIONS = ("mark_pilot", "unmark_pilot")


def is_pilot(session: Session, participant: Participant) -> bool:
    latest = latest_row(
        session,
        ConsoleAction,
        ConsoleAction.participant_id,
        participant.id,
        ConsoleAction.action.in_(PILOT_ACTIONS),
    )
    return participant.is_pilot if latest is None else latest.action == "mark_pilot"


def _latest_marks(session: Session) -> dict[int, str]:
    rows = latest_per_key(
        session,
        ConsoleAction,
        ConsoleAction.participant_id,
        ConsoleAction.action.in_(PILOT_ACTIONS),
    )
    return {pid: row.action for pid, row in rows.items()}


def pilot_marks(session: Session) -> tuple[set[int], set[int]]:
    """Ids the experimenter marked pilot, and ids unmarked, by each one's newest mark
    (the console filters its table with them in SQL)."""
    latest = _latest_marks(session)
    marked = {pid for pid, action in latest.items() if action == "mark_pilot"}
    return marked, set(latest) - marked


def pilot_flags(session: Session, participants: list[Participant]) -> dict[int, bool]:
    """`is_pilot` for many participants in one query (the console's live table)."""
    latest = _latest_marks(session)
    return {
        p.id: p.is_pilot if p.id not in latest else latest[p.id] == "mark_pilot"
        for p in participants
    }
