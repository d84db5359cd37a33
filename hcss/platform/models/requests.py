"""The operator's requests to the collectives, as a log that replays the trial.

A command is the simulation's `OperatorCommand`: validated once from the
participant's JSON, applied, and written with its `CommandOutcome` (accepted,
or refused with the simulation's reason) in one transaction; `step_applied`
is the step boundary where it was applied. A replay rebuilds the same
`OperatorCommand` from the row (`Command.operator_command`). The context
columns (support, decision index) and the intervention flag are the
simulation's `RequestOutcome`, never worked out here.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import ForeignKey, Index, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt
from hcss.platform.models.vocabularies import RequestStatus, check_in
from hcss.simulation.requests import KINDS, OperatorCommand, RequestOutcome

COMMAND_KINDS = KINDS


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
    # Context for analysis, as the simulation found it just before applying.
    support: Mapped[float | None]  # fraction of the collective favouring the target
    decision_index: Mapped[int | None]  # the collective's decision under way (1-based)
    # Observation ids of the clicks that filled the request form: those clicks
    # were part of this request, not observation actions.
    selections: Mapped[list[Any]] = mapped_column(default=list)

    @classmethod
    def applied(
        cls,
        trial_id: int,
        command: OperatorCommand,
        outcome: RequestOutcome,
        *,
        step: int,
        sim_time: float,
        selections: tuple[int, ...] = (),
    ) -> Command:
        """The row of a command the simulation has answered with `outcome`.

        A cancel is stored with the collective and target of the abandon it lifted.
        """
        cancel = command.kind == "cancel"
        return cls(
            trial_id=trial_id,
            kind=command.kind,
            collective=outcome.collective if cancel else command.collective,
            target=outcome.target if cancel else command.target,
            cancel_request_id=command.request_id if cancel else None,
            step_applied=step,
            sim_time=sim_time,
            support=outcome.support,
            decision_index=outcome.decision_index,
            selections=list(selections),
        )

    def operator_command(self) -> OperatorCommand:
        """The command as the simulation took it, for a replay."""
        if self.kind == "cancel":
            assert self.cancel_request_id is not None, "a cancel row names its request"
            return OperatorCommand.cancel(self.cancel_request_id)
        return OperatorCommand(self.kind, self.collective, self.target)


class CommandOutcome(CreatedAt, Base):
    __tablename__ = "command_outcome"

    id: Mapped[int] = mapped_column(primary_key=True)
    command_id: Mapped[int] = mapped_column(ForeignKey("command.id"), unique=True)
    accepted: Mapped[bool]
    request_id: Mapped[int | None]  # the simulation's id; None when refused
    reason: Mapped[str] = mapped_column(String(200), default="")
    intervention: Mapped[bool] = mapped_column(default=False)

    @classmethod
    def of(cls, command_id: int, outcome: RequestOutcome) -> CommandOutcome:
        return cls(
            command_id=command_id,
            accepted=outcome.accepted,
            request_id=outcome.request_id if outcome.accepted else None,
            reason=outcome.reason,
            intervention=outcome.intervention,
        )


class RequestStatusChange(CreatedAt, Base):
    """An accepted request's status over time, as the Collective Assignments list shows it.

    status: ``in_progress`` (accepted), ``completed`` (investigate acknowledged by
    10 agents), ``removed`` (left the list: decision ended or abandon cancelled).
    """

    __tablename__ = "request_status_change"
    __table_args__ = (
        check_in("status", RequestStatus, "status"),
        # A request reaches each status once (i29_unique_trial_rows).
        Index("uq_request_status_change_trial", "trial_id", "request_id", "status", unique=True),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    request_id: Mapped[int]
    status: Mapped[str] = mapped_column(String(16))
    step: Mapped[int]
    sim_time: Mapped[float]
