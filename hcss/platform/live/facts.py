"""What happened in a running trial, as typed values: the trial in memory says it, the writer
stores it.

`RunningTrial`'s methods that move the trial's log on (events handed over, a
decision made, a request's status changed, a probe timed out or scored, a
snapshot taken, the trial ended) return these small frozen values and do no
I/O; `trial_writer.write_facts` turns them into rows, in the unit of work
that proves the lease. A fact names no trial: the writer is told which trial
it writes for, so one value cannot be written under another trial's id by
mistake of its maker.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


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


Fact = (
    EventHappened
    | DecisionMade
    | RequestStatusChanged
    | ProbeTimedOut
    | ProjectionScored
    | SnapshotTaken
    | TrialEnded
)
