"""What a `RunningTrial` knows of its probes and of its trial log, each changed only by its methods.

Both are cursors of the recorder (hcss.platform.live.recorder): they say how
far the trial's rows are written, so they move only with the commit that
wrote them; the log's (`LogQueue`) also hold what was handed over and waits
to be written. A `RunningTrial` copies them (`saved`) before a unit of work and
takes the copy back when its commit fails; nothing else writes them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from hcss.platform.live.facts import (
    DecisionMade,
    EventHappened,
    RequestStatusChanged,
    SnapshotTaken,
)
from hcss.platform.live.probes import probe_subject
from hcss.platform.models import Probe
from hcss.questionnaires.probes import ScheduledProbe
from hcss.simulation import Simulation
from hcss.simulation.messages import event_text
from hcss.simulation.requests import StatusChange
from hcss.tablespec.decisions import stored_decision

#: A level-3 probe waiting for the next decision: (probe id, shown sim time, answer or None).
Projection = tuple[int, float, str | None]


@dataclass
class CurrentProbe:
    """The probe on screen now (its `Probe` row id and what the page needs)."""

    id: int
    probe_index: int
    level: int
    question: str
    choices: list[str]
    truth: str | None
    shown_sim_time: float
    timeout_sim_time: float
    ready: bool = False
    # Running wall seconds (RunningTrial.running_wall_s) when the prompt, then the
    # question, was first sent to the page, and when Ready was pressed: the
    # latencies are measured from these. Lost in a restart: the first frame
    # after it delivers again.
    delivered_s: float | None = None
    question_delivered_s: float | None = None
    ready_s: float | None = None

    @classmethod
    def of(cls, row: Probe, *, ready: bool = False) -> CurrentProbe:
        """The probe on screen as its stored row says (shown now, or found again in a rebuild)."""
        return cls(
            id=row.id,
            probe_index=row.probe_index,
            level=row.level,
            question=row.question,
            choices=list(row.choices),
            truth=row.truth,
            shown_sim_time=row.shown_sim_time,
            timeout_sim_time=row.timeout_sim_time,
            ready=ready,
        )

    def delivered(self, running_s: float) -> None:
        """A frame carrying this probe is being sent."""
        if self.delivered_s is None:
            self.delivered_s = running_s
        if self.ready and self.question_delivered_s is None:
            self.question_delivered_s = running_s

    def ready_pressed(self, running_s: float | None) -> None:
        """The participant pressed Ready: the question shows from the next frame on."""
        self.ready, self.ready_s = True, running_s

    def public(self) -> dict[str, Any]:
        """What the browser sees: never the truth."""
        return {
            "id": self.id,
            "index": self.probe_index,
            "level": self.level,
            "phase": "question" if self.ready else "ready",
            "question": self.question if self.ready else None,
            "choices": self.choices if self.ready else None,
            "subject": probe_subject(self.level, self.question) if self.ready else None,
            "timeout_s": self.timeout_sim_time,
        }


@dataclass
class ProbeSchedule:
    """The trial's planned probes, how many were shown, the one on screen and the
    level-3 answers still to be scored by the next decision."""

    plan: list[ScheduledProbe]
    _shown: int = field(default=0, init=False)
    _postponed_until: float = field(default=0.0, init=False)
    _current: CurrentProbe | None = field(default=None, init=False)
    _projections: list[Projection] = field(default_factory=list, init=False)

    @property
    def shown(self) -> int:
        return self._shown

    @property
    def current(self) -> CurrentProbe | None:
        return self._current

    def due(self, time: float) -> tuple[int, ScheduledProbe] | None:
        """The next planned probe (1-based index) if it is due at sim `time` and none is on screen."""
        if self._current is not None or self._shown >= len(self.plan):
            return None
        planned = self.plan[self._shown]
        if time < planned.at_s or time < self._postponed_until:
            return None
        return self._shown + 1, planned

    def postponed(self, until: float) -> None:
        self._postponed_until = until

    def put_on_screen(self, probe: CurrentProbe) -> None:
        self._shown, self._current = probe.probe_index, probe
        if probe.level == 3:
            self._projections.append((probe.id, probe.shown_sim_time, None))

    def taken_off_screen(self) -> CurrentProbe | None:
        probe, self._current = self._current, None
        return probe

    def answered(self, answer: str) -> None:
        """The probe on screen is answered; a projection keeps the answer until it is scored."""
        probe = self._current
        assert probe is not None
        if probe.level == 3:
            self._projections = [
                (pid, shown, answer if pid == probe.id else previous)
                for pid, shown, previous in self._projections
            ]
        self._current = None

    def projections_ended_by(self, end_s: float) -> list[Projection]:
        """The projections asked before a decision that ended at `end_s`: they are scored now."""
        scored = [p for p in self._projections if p[1] < end_s]
        self._projections = [p for p in self._projections if p[1] >= end_s]
        return scored

    def restored(
        self, shown: int, current: CurrentProbe | None, projections: list[Projection]
    ) -> None:
        self._shown, self._current, self._projections = shown, current, list(projections)

    def saved(self) -> ProbeSchedule:
        """A copy the later changes leave as it is (the probe on screen is shared)."""
        kept = ProbeSchedule(self.plan)
        kept.restored(self._shown, self._current, self._projections)
        kept.postponed(self._postponed_until)
        return kept


@dataclass
class LogCursors:
    """How far the trial log is written: events, decisions, request statuses, snapshots."""

    _last_event_time: float = field(default=-math.inf, init=False)
    _decisions: int = field(default=0, init=False)
    # (request id, status) pairs already written as RequestStatusChange rows.
    _request_statuses: set[tuple[int, str]] = field(default_factory=set, init=False)
    _last_snapshot_epoch: float = field(default=0.0, init=False)

    @property
    def decisions(self) -> int:
        return self._decisions

    @property
    def last_snapshot_epoch(self) -> float:
        return self._last_snapshot_epoch

    def unwritten_event(self, time: float) -> bool:
        """Whether an event at `time` is new: one written before an interruption comes again
        when the rebuild replays its step."""
        return time > self._last_event_time

    def events_written_up_to(self, time: float) -> None:
        self._last_event_time = max(self._last_event_time, time)

    def decisions_written(self, count: int) -> None:
        self._decisions = count

    def statuses_to_write(self, changes: list[StatusChange]) -> list[StatusChange]:
        """The changes whose (request, status) has no row yet; they count as written now."""
        fresh = []
        for change in changes:
            key = (change.request_id, change.status)
            if key not in self._request_statuses:
                self._request_statuses.add(key)
                fresh.append(change)
        return fresh

    def snapshot_written(self, now: float) -> None:
        self._last_snapshot_epoch = now

    def restored(
        self, last_event_time: float, decisions: int, request_statuses: set[tuple[int, str]]
    ) -> None:
        self._last_event_time, self._decisions = last_event_time, decisions
        self._request_statuses = set(request_statuses)

    def saved(self) -> LogCursors:
        kept = LogCursors()
        kept.restored(self._last_event_time, self._decisions, self._request_statuses)
        kept.snapshot_written(self._last_snapshot_epoch)
        return kept


@dataclass(frozen=True)
class SavedLog:
    """A copy of a `LogQueue`'s cursors, and how many handed-over rows were waiting."""

    cursors: LogCursors
    events: int
    status_changes: int


class LogQueue:
    """The trial log's progress: how far it is written (`LogCursors`), and what the simulation
    handed over (and the page was shown) that no commit has written yet.

    The recorder writes what waits first, in order, when the database takes
    writes again (hcss.platform.live.recorder.kept_until_written). Its methods
    say what happened as typed facts (`live.facts`) and move the cursors; they
    are called by the `RunningTrial` that holds it, with its lock held.
    """

    def __init__(self) -> None:
        self._cursors = LogCursors()
        self._events: list[EventHappened] = []
        self._status_changes: list[StatusChange] = []

    @property
    def decisions(self) -> int:
        return self._cursors.decisions

    @property
    def last_snapshot_epoch(self) -> float:
        return self._cursors.last_snapshot_epoch

    @property
    def unwritten_events(self) -> list[EventHappened]:
        """The events handed over that no commit wrote yet, oldest first; read-only."""
        return self._events

    def events_handed_over(self, events: list[dict[str, Any]]) -> list[EventHappened]:
        """The simulation's new events (`Simulation.drain_events`) wait to be written; returns
        those not written before (a rebuild replays the steps of events written before the
        interruption), worded as the page shows them."""
        fresh = [
            EventHappened(
                kind=str(e["kind"]),
                collective=_int_or_none(e.get("collective")),
                target=_int_or_none(e.get("target")),
                text=event_text(e),
                sim_time=float(e["time"]),
            )
            for e in events
            if self._cursors.unwritten_event(float(e["time"]))
        ]
        self._events.extend(fresh)
        return fresh

    def events_written_up_to(self, time: float) -> None:
        """Every event up to sim `time` is in the unit of work that writes the log."""
        self._cursors.events_written_up_to(time)

    def decisions_made(self, sim: Simulation) -> list[DecisionMade]:
        """The simulation's decisions not yet written, counted written from now on.

        Each record is checked against the decisions table's contract; who and
        where (source, participant, trial, run) the export adds
        (hcss.tablespec.decisions).
        """
        records = sim.decisions
        made = []
        for record in records[self._cursors.decisions :]:
            row = stored_decision(record.as_row())
            made.append(
                DecisionMade(
                    collective=int(record.collective),
                    decision_index=int(row["decision_index"]),
                    step=sim.step_count,
                    correct=None if row.get("correct") is None else bool(row["correct"]),
                    record=row,
                )
            )
        self._cursors.decisions_written(len(records))
        return made

    def status_changes_to_write(
        self, handed_over: list[StatusChange]
    ) -> list[RequestStatusChanged]:
        """The request status changes the simulation handed over wait with the unwritten
        ones; returns those with no row yet, counted written from now on."""
        self._status_changes.extend(handed_over)
        return [
            RequestStatusChanged(c.request_id, str(c.status), c.step, float(c.time))
            for c in self._cursors.statuses_to_write(self._status_changes)
        ]

    def snapshot_taken(
        self, sim: Simulation, now: float, last_command_id: int | None
    ) -> SnapshotTaken:
        """A snapshot for the unit of work; the next is due a snapshot interval after `now`."""
        self._cursors.snapshot_written(now)
        return SnapshotTaken(
            step=sim.step_count,
            sim_time=float(sim.time),
            last_command_id=last_command_id,
            blob=sim.snapshot(),
        )

    def restored(
        self, last_event_time: float, decisions: int, request_statuses: set[tuple[int, str]]
    ) -> None:
        """How far the rows are written, for a trial rebuilt after a restart."""
        self._cursors.restored(last_event_time, decisions, request_statuses)

    def saved(self) -> SavedLog:
        """What is counted written now, to go back to if the unit of work does not commit."""
        return SavedLog(self._cursors.saved(), len(self._events), len(self._status_changes))

    def lost(self, saved: SavedLog, *, handed_over_dropped: bool) -> None:
        """The unit of work begun at `saved` did not commit: the cursors go back to it.

        What the simulation handed over stays queued for the next attempt,
        unless the simulation itself went back (`handed_over_dropped`: a
        command that was not logged), when it never happened.
        """
        self._cursors = saved.cursors
        if handed_over_dropped:
            del self._events[saved.events :]
            del self._status_changes[saved.status_changes :]

    def written(self) -> None:
        """The unit of work committed: nothing it held waits any longer."""
        self._events.clear()
        self._status_changes.clear()


@dataclass(frozen=True)
class ProgressMark:
    """What a `RunningTrial` counted written before a unit of work (`progress_mark`): copies of
    its log's progress and of its probes, and whether it had ended."""

    log: SavedLog
    probes: ProbeSchedule
    ended: bool


def _int_or_none(value: Any) -> int | None:
    """An event's integer field (numpy or Python), or None."""
    return None if value is None else int(value)
