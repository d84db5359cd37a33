"""Whether a participant's page is open: operational state for the console, not study data.

One row per participant, overwritten by every heartbeat of their page (every
few seconds). It is deliberately *not* an append-only record: nothing in the
analysis reads it, the export leaves it out, and keeping every heartbeat
would add thousands of rows per session that say nothing about behaviour.
It lives in the database rather than in process memory so the console is
right whichever server process served the page, and after a restart. A
withdrawal deletes it with the participant's other rows (it has a foreign key
to `participant`).
"""

from __future__ import annotations

from sqlalchemy import ForeignKey, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base


class ParticipantPresence(Base):
    __tablename__ = "participant_presence"

    participant_id: Mapped[int] = mapped_column(ForeignKey("participant.id"), primary_key=True)
    #: The live runner's clock (epoch seconds) at the latest heartbeat.
    last_seen_epoch: Mapped[float]
    #: Which kind of page sent it: "study" (a stage page) or "trial" (the Collective Interface).
    page: Mapped[str] = mapped_column(String(16))
    #: The page was in a background tab or a minimised window.
    hidden: Mapped[bool] = mapped_column(default=False)
