"""Whether a participant is a pilot: the creation flag, then the experimenter's marks.

`Participant.is_pilot` is written once, when the participant is made (the
console's "Pilot participants" box). Marking or unmarking later is a
`ConsoleAction` row (``mark_pilot`` / ``unmark_pilot``), never an update of
the participant (the table is append-only, enforced by the database), so the
history of the flag is kept and the newest mark wins.
"""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.models import ConsoleAction, Participant

PILOT_ACTIONS = ("mark_pilot", "unmark_pilot")


def is_pilot(session: Session, participant: Participant) -> bool:
    latest = session.scalars(
        select(ConsoleAction.action)
        .where(
            ConsoleAction.participant_id == participant.id,
            ConsoleAction.action.in_(PILOT_ACTIONS),
        )
        .order_by(ConsoleAction.id.desc())
        .limit(1)
    ).first()
    return participant.is_pilot if latest is None else latest == "mark_pilot"


def _latest_marks(session: Session) -> dict[int, str]:
    latest: dict[int, str] = {}
    for participant_id, action in session.execute(
        select(ConsoleAction.participant_id, ConsoleAction.action)
        .where(ConsoleAction.action.in_(PILOT_ACTIONS))
        .order_by(ConsoleAction.id)
    ):
        latest[participant_id] = action  # the newest mark wins
    return latest


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
