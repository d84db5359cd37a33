"""What happened in a running trial, as typed values: the trial in memory says it, the writer
stores it.

`RunningTrial`'s methods that move the trial's log on (events handed over, a
decision made, a request's status changed, a probe timed out or scored, a
snapshot taken, the trial ended) or that carry out a command (a request
applied, a click on the map, a probe's Ready press or answer) return these
small frozen values and do no I/O; so does the console's pause, resume or
abort (`ConsoleActed`, made by hcss.platform.live.control). The trial log's
writer (`trial_writer.write_fact`, `write_facts`) turns them into rows, in
the unit of work that proves the lease. A fact names no trial: the writer is
told which trial it writes for, so one value cannot be written under another
trial's id by mistake of its maker.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from hcss.simulation import OperatorCommand
    from hcss.simulation.requests import RequestOutcome


@dataclass(frozen=True)
class EventHappened:
    """A System Message event the simulation handed over (its text as the page shows it)."""

    kind: str
    collective: int | None
    target: int | None
    text: str
    sim_time: float


@dataclass(frozen=True)
class DecisionMade:
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


@dataclass(frozen=True)
class RequestStatusChanged:
    """A request's status changed (accepted, in progress, completed, removed) at `step`."""

    request_id: int
    status: str
    step: int
    sim_time: float


@dataclass(frozen=True)
class ProbeTimedOut:
    """The probe on screen was taken off unanswered (its time ran out, or the trial ended)."""

    probe_id: int
    step: int
    sim_time: float


@dataclass(frozen=True)
class ProjectionScored:
    """A level-3 probe, asked before a decision ended, scored by that decision."""

    probe_id: int
    answer: str | None
    truth: str
    step: int
    sim_time: float

    @property
    def correct(self) -> bool | None:
        return None if self.answer is None else self.answer == self.truth


@dataclass(frozen=True)
class SnapshotTaken:
    """The simulation's state at `step`, with the newest logged command it holds."""

    step: int
    sim_time: float
    last_command_id: int | None
    blob: bytes


@dataclass(frozen=True)
class TrialEnded:
    """The trial is over for `reason` (``time_limit``, ``aborted``, ...) at `step`."""

    reason: str
    step: int


@dataclass(frozen=True)
class CommandApplied:
    """The participant's request, applied at `step` with its outcome (every value the rows
    say is the simulation's `RequestOutcome`); `selections`: the clicks it names."""

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


@dataclass(frozen=True)
class ObservationMade:
    """A click on the map, on a collective or a target the participant sees."""

    kind: str
    collective: int | None
    target: int | None
    button: str
    step: int
    sim_time: float


@dataclass(frozen=True)
class ProbeReadyPressed:
    """The participant pressed Ready on the open probe; `latency_ms` from its prompt's delivery."""

    probe_id: int
    latency_ms: float | None
    step: int
    sim_time: float


@dataclass(frozen=True)
class ProbeAnswered:
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


@dataclass(frozen=True)
class ConsoleActed:
    """The experimenter paused, resumed or aborted the session at `at_epoch`; `on_trial`: the
    trial was running then (False: it had just reached its end, and only the session's state
    changes), `detail`: the trial clock it happened at."""

    participant_id: int
    experimenter_id: int | None
    action: str
    at_epoch: float
    on_trial: bool
    detail: str | None = None


Fact = (
    EventHappened
    | DecisionMade
    | RequestStatusChanged
    | ProbeTimedOut
    | ProjectionScored
    | SnapshotTaken
    | TrialEnded
    | CommandApplied
    | ObservationMade
    | ProbeReadyPressed
    | ProbeAnswered
    | ConsoleActed
)
