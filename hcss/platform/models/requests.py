"""The operator's requests to the collectives, as a log that replays the trial.

A `Command` is written and committed before it reaches the simulation; its
`step_applied` is the step boundary where it was applied. The `CommandOutcome`
(accepted, or refused with the simulation's reason) is a second row, so a
crash between the two leaves a command the replay still applies.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import ForeignKey, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt
from hcss.platform.models.vocabularies import RequestStatus, check_in

COMMAND_KINDS = ("investigate", "abandon", "decide", "cancel")


class Command(CreatedAt, Base):
    __tablename__ = "command"

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    kind: Mapped[str] = mapped_column(String(16))
    collective: Mapped[int | None]  # for cancel: the collective of the cancelled abandon
    target: Mapped[int | None]
    cancel_request_id: Mapped[int | None]  # only for cancel
    step_applied: Mapped[int]
    sim_time: Mapped[float]
    # Context for analysis, read from the simulation just before applying.
    support: Mapped[float | None]  # fraction of the collective favouring the target
    decision_index: Mapped[int | None]  # the collective's decision under way (1-based)
    # Observation ids of the clicks that filled the request form: those clicks
    # were part of this request, not observation actions.
    selections: Mapped[list[Any]] = mapped_column(default=list)

    def as_sim_command(self) -> dict[str, Any]:
        """The dict `Simulation.apply` takes, for the live apply and for replay."""
        if self.kind == "cancel":
            return {"kind": "cancel", "request_id": self.cancel_request_id}
        return {"kind": self.kind, "collective": self.collective, "target": self.target}


class CommandOutcome(CreatedAt, Base):
    __tablename__ = "command_outcome"

    id: Mapped[int] = mapped_column(primary_key=True)
    command_id: Mapped[int] = mapped_column(ForeignKey("command.id"), unique=True)
    accepted: Mapped[bool]
    request_id: Mapped[int | None]  # the simulation's id; None when refused
    reason: Mapped[str] = mapped_column(String(200), default="")
    intervention: Mapped[bool] = mapped_column(default=False)


class RequestStatusChange(CreatedAt, Base):
    """An accepted request's status over time, as the Collective Assignments list shows it.

    status: ``in_progress`` (accepted), ``completed`` (investigate acknowledged by
    10 agents), ``removed`` (left the list: decision ended or abandon cancelled).
    """

    __tablename__ = "request_status_change"
    __table_args__ = (check_in("status", RequestStatus, "status"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    request_id: Mapped[int]
    status: Mapped[str] = mapped_column(String(16))
    step: Mapped[int]
    sim_time: Mapped[float]
