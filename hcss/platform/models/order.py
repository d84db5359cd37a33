"""A console action on a live trial that another server process hosts.

With several processes, the experimenter's console may be served by one
process while the trial runs in another. The console writes a `TrialOrder`;
the host's runner polls for orders of the trials it holds, carries each out
exactly as a local console action (a `ConsoleAction` row, then the clock),
and marks it done. The order is the durable request, so one whose host dies
first is carried out by the process that takes the trial over.
"""

from __future__ import annotations

from sqlalchemy import Double, ForeignKey, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt


class TrialOrder(CreatedAt, Base):
    __tablename__ = "trial_order"

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    experimenter_id: Mapped[int | None] = mapped_column(ForeignKey("experimenter.id"))
    #: pause, resume or abort (hcss.platform.models.participant_state.STATE_ACTIONS).
    action: Mapped[str] = mapped_column(String(16))
    #: The process that wrote it (`host:port`), for the log.
    issued_by: Mapped[str] = mapped_column(String(128))
    #: When its host carried it out (its clock); None while pending.
    done_epoch: Mapped[float | None] = mapped_column(Double, index=True)
    #: "done", or "ended" when the trial had ended before the order arrived.
    outcome: Mapped[str] = mapped_column(String(16), default="")
