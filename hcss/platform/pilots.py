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
