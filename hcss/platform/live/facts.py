"""What happened in a running trial, as typed values, each with the rows it leaves.

`RunningTrial`'s methods that move the trial's log on (events handed over, a
decision made, a request's status changed, a probe timed out or scored, a
snapshot taken, the trial ended) return these small frozen values and do no
I/O; so do the participant's commands (hcss.platform.live.commands: a
request applied, a click on the map, a probe's Ready press or answer) and
the console's pause, resume or abort (`ConsoleActed`, made by
hcss.platform.live.control).

Each fact declares its own rows: `write` (and `write_all`, for a run of
facts of one kind in one statement) and, for a command's fact, `stored`
(whether its row is in the database, asked after a commit whose answer was
lost). The trial log's writer (`trial_writer.write_fact`, `write_facts`)
writes a fact by that declaration, in the unit of work that proves the lease
(hcss.platform.live.unit_of_work); no code dispatches on a fact's type, so a
new command's fact is one class here. This module and the writer are the
trial log's only writers (tests/platform/test_one_writer.py).

A fact names no trial: the writer is told which trial it writes for, so one
value cannot be written under another trial's id by mistake of its maker.
A trial's decisions, events, probe events and request statuses are written
insert-if-absent (their unique keys: trial_writer's docstring says why).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.db import add_all_if_absent, add_if_absent
from hcss.platform.models import (
    Command,
    CommandOutcome,
    ConsoleAction,
    DecisionRow,
    Observation,
    ProbeEvent,
    RequestStatusChange,
    SimEvent,
    Snapshot,
    TrialStatusChange,
)
from hcss.platform.models.vocabularies import RequestStatus, TrialStatus

if TYPE_CHECKING:
    from hcss.simulation import OperatorCommand
    from hcss.simulation.requests import RequestOutcome


class Fact:
    """Something that happened in a trial, and the rows it leaves in the trial log."""

    __slots__ = ()

    def write(self, session: Session, trial_id: int) -> int | None:
        """Its rows; the id of the row a command's answer names (None: none, or a row stored
        before, by a commit whose answer was lost)."""
        raise NotImplementedError

    @classmethod
    def write_all(cls, session: Session, trial_id: int, facts: Sequence[Fact]) -> None:
        """The rows of a run of facts of this kind, in order (one statement where it can)."""
        for fact in facts:
            fact.write(session, trial_id)

    def stored(self, session: Session, row_id: int | None) -> bool:
        """Whether its row is in the database: asked after its transaction's commit failed,
        when the commit may have landed and its answer been lost (a command's fact)."""
        raise TypeError(f"{type(self).__name__} is not a command's fact")


class _RowById(Fact):
    """A command's fact whose row is looked up by its id (`row_id`: what `write` answered)."""

    __slots__ = ()
    model: ClassVar[type[Any]]

    def stored(self, session: Session, row_id: int | None) -> bool:
        return row_id is not None and session.get(self.model, row_id) is not None


class _InOneStatement(Fact):
    """A fact whose kind is written a run at a time (`write_all`, one statement): one alone
    is a run of one."""

    __slots__ = ()

    def write(self, session: Session, trial_id: int) -> int | None:
        type(self).write_all(session, trial_id, [self])
        return None


def _probe_event(session: Session, probe_id: int, kind: str, **fields: Any) -> int | None:
    """A probe's ready press, answer, time-out or score, once per kind; its id (None: stored
    before, by a commit whose answer was lost)."""
    row = ProbeEvent(probe_id=probe_id, kind=kind, **fields)
    return row.id if add_if_absent(session, row) else None


def _probe_event_stored(session: Session, probe_id: int, kind: str) -> bool:
    found = session.scalar(
        select(ProbeEvent.id).where(ProbeEvent.probe_id == probe_id, ProbeEvent.kind == kind)
    )
    return found is not None


@dataclass(frozen=True)
class EventHappened(_InOneStatement):
    """A System Message event the simulation handed over (its text as the page shows it)."""

    kind: str
    collective: int | None
    target: int | None
    text: str
    sim_time: float

    @classmethod
    def write_all(cls, session: Session, trial_id: int, facts: Sequence[Fact]) -> None:
        """In one statement; each once (kind, time and text are its key)."""
        add_all_if_absent(
            session,
            [
                SimEvent(
                    trial_id=trial_id,
                    kind=e.kind,
                    collective=e.collective,
                    target=e.target,
                    text=e.text[:300],
                    sim_time=e.sim_time,
                )
                for e in facts
                if isinstance(e, EventHappened)
            ],
        )


@dataclass(frozen=True)
class DecisionMade(Fact):
    """A collective's decision; `record` is the row checked against the decisions contract."""

    collective: int
    decision_index: int
    step: int
    correct: bool | None
    record: dict[str, Any]

    @property
    def collective_name(self) -> str:
        return str(self.record["collective"])

    @property
    def end_s(self) -> float:
        return float(self.record["end_s"])

    def write(self, session: Session, trial_id: int) -> int | None:
        """Once per collective and index (skipped if a commit whose answer was lost wrote it)."""
        add_if_absent(
            session,
            DecisionRow(
                trial_id=trial_id,
                collective=self.collective,
                decision_index=self.decision_index,
                step=self.step,
                correct=self.correct,
                record=self.record,
            ),
        )
        return None


@dataclass(frozen=True)
class RequestStatusChanged(_InOneStatement):
    """A request's status changed (accepted, in progress, completed, removed) at `step`."""

    request_id: int
    status: str
    step: int
    sim_time: float

    @classmethod
    def write_all(cls, session: Session, trial_id: int, facts: Sequence[Fact]) -> None:
        """In one statement; each once (request and status are its key)."""
        add_all_if_absent(
            session,
            [
                RequestStatusChange(
                    trial_id=trial_id,
                    request_id=c.request_id,
                    status=RequestStatus(c.status),
                    step=c.step,
                    sim_time=c.sim_time,
                )
                for c in facts
                if isinstance(c, RequestStatusChanged)
            ],
        )


@dataclass(frozen=True)
class ProbeTimedOut(Fact):
    """The probe on screen was taken off unanswered (its time ran out, or the trial ended)."""

    probe_id: int
    step: int
    sim_time: float

    def write(self, session: Session, trial_id: int) -> int | None:
        _probe_event(session, self.probe_id, "timeout", step=self.step, sim_time=self.sim_time)
        return None


@dataclass(frozen=True)
class ProjectionScored(Fact):
    """A level-3 probe, asked before a decision ended, scored by that decision."""

    probe_id: int
    answer: str | None
    truth: str
    step: int
    sim_time: float

    @property
    def correct(self) -> bool | None:
        return None if self.answer is None else self.answer == self.truth

    def write(self, session: Session, trial_id: int) -> int | None:
        _probe_event(
            session,
            self.probe_id,
            "scored",
            answer=self.answer,
            truth=self.truth,
            correct=self.correct,
            step=self.step,
            sim_time=self.sim_time,
        )
        return None


@dataclass(frozen=True)
class SnapshotTaken(Fact):
    """The simulation's state at `step`, with the newest logged command it holds."""

    step: int
    sim_time: float
    last_command_id: int | None
    blob: bytes

    def write(self, session: Session, trial_id: int) -> int | None:
        session.add(
            Snapshot(
                trial_id=trial_id,
                step=self.step,
                sim_time=self.sim_time,
                last_command_id=self.last_command_id,
                blob=self.blob,
            )
        )
        return None


@dataclass(frozen=True)
class TrialEnded(Fact):
    """The trial is over for `reason` (``time_limit``, ``aborted``, ...) at `step`."""

    reason: str
    step: int

    def write(self, session: Session, trial_id: int) -> int | None:
        """The trial's end, unless a commit whose answer was lost ended it already."""
        ended = session.scalar(
            select(TrialStatusChange.id)
            .where(
                TrialStatusChange.trial_id == trial_id,
                TrialStatusChange.status == TrialStatus.ENDED,
            )
            .limit(1)
        )
        if ended is None:
            session.add(
                TrialStatusChange(
                    trial_id=trial_id, status=TrialStatus.ENDED, reason=self.reason, step=self.step
                )
            )
        return None


@dataclass(frozen=True)
class CommandApplied(_RowById):
    """The participant's request, applied at `step` with its outcome (every value the rows
    say is the simulation's `RequestOutcome`); `selections`: the clicks it names."""

    model: ClassVar[type[Any]] = Command
    command: OperatorCommand
    outcome: RequestOutcome
    step: int
    sim_time: float
    selections: tuple[int, ...]

    # What its row says (`models.Command.applied`): a cancel names the abandon it lifted.
    @property
    def kind(self) -> str:
        return self.command.kind

    @property
    def collective(self) -> int | None:
        cancel = self.command.kind == "cancel"
        return self.outcome.collective if cancel else self.command.collective

    @property
    def target(self) -> int | None:
        return self.outcome.target if self.command.kind == "cancel" else self.command.target

    @property
    def cancel_request_id(self) -> int | None:
        return self.command.request_id if self.command.kind == "cancel" else None

    def write(self, session: Session, trial_id: int) -> int:
        """The command's row and its outcome's; the command's id."""
        row = Command.applied(
            trial_id,
            self.command,
            self.outcome,
            step=self.step,
            sim_time=self.sim_time,
            selections=self.selections,
        )
        session.add(row)
        session.flush()
        session.add(CommandOutcome.of(row.id, self.outcome))
        return row.id


@dataclass(frozen=True)
class ObservationMade(_RowById):
    """A click on the map, on a collective or a target the participant sees."""

    model: ClassVar[type[Any]] = Observation
    kind: str
    collective: int | None
    target: int | None
    button: str
    step: int
    sim_time: float

    def write(self, session: Session, trial_id: int) -> int:
        row = Observation(
            trial_id=trial_id,
            kind=self.kind,
            collective=self.collective,
            target=self.target,
            button=self.button,
            step=self.step,
            sim_time=self.sim_time,
        )
        session.add(row)
        session.flush()
        return row.id


@dataclass(frozen=True)
class ProbeReadyPressed(Fact):
    """The participant pressed Ready on the open probe; `latency_ms` from its prompt's delivery."""

    probe_id: int
    latency_ms: float | None
    step: int
    sim_time: float

    def write(self, session: Session, trial_id: int) -> int | None:
        return _probe_event(
            session,
            self.probe_id,
            "ready",
            latency_ms=self.latency_ms,
            step=self.step,
            sim_time=self.sim_time,
        )

    def stored(self, session: Session, row_id: int | None) -> bool:
        return _probe_event_stored(session, self.probe_id, "ready")


@dataclass(frozen=True)
class ProbeAnswered(Fact):
    """The open probe's answer; one with a `truth` is scored at once (a level-3 one, asked
    about a decision to come, is scored by that decision: `ProjectionScored`)."""

    probe_id: int
    answer: str
    truth: str | None
    latency_ms: float | None
    step: int
    sim_time: float

    @property
    def correct(self) -> bool | None:
        return None if self.truth is None else self.answer == self.truth

    def write(self, session: Session, trial_id: int) -> int | None:
        """The answer's event, and its score when the probe's truth is known now."""
        when = {"step": self.step, "sim_time": self.sim_time}
        answered = _probe_event(
            session,
            self.probe_id,
            "answer",
            answer=self.answer,
            latency_ms=self.latency_ms,
            **when,
        )
        if self.truth is not None:
            _probe_event(
                session,
                self.probe_id,
                "scored",
                answer=self.answer,
                truth=self.truth,
                correct=self.correct,
                **when,
            )
        return answered

    def stored(self, session: Session, row_id: int | None) -> bool:
        return _probe_event_stored(session, self.probe_id, "answer")


@dataclass(frozen=True)
class ConsoleActed(_RowById):
    """The experimenter paused, resumed or aborted the session at `at_epoch`; `on_trial`: the
    trial was running then (False: it had just reached its end, and only the session's state
    changes), `detail`: the trial clock it happened at."""

    model: ClassVar[type[Any]] = ConsoleAction
    participant_id: int
    experimenter_id: int | None
    action: str
    at_epoch: float
    on_trial: bool
    detail: str | None = None

    def write(self, session: Session, trial_id: int) -> int:
        row = ConsoleAction(
            participant_id=self.participant_id,
            experimenter_id=self.experimenter_id,
            action=self.action,
            trial_id=trial_id if self.on_trial else None,
            at_epoch=self.at_epoch,
            detail=self.detail,
        )
        session.add(row)
        session.flush()
        return row.id
