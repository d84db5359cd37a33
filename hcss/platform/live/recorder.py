"""Turn what the simulation did since the last look into rows and messages.

Called by the runner after each batch of steps, and once after a rebuild, with
the trial's lock held. Everything is derived from the simulation's state, so a
rebuild that replays the same steps writes only what had not been written.

The cursors that say "written up to here" (the last event time, the decisions
recorded, the request statuses, the probes shown) move only with the commit:
`kept_until_written` restores them when the commit fails, and the events and
status changes the simulation handed over wait on the `RunningTrial`
(`unwritten_events`, `unwritten_status_changes`) to be written first, in
order, by the next commit that succeeds. The page's System Messages show an
event once, when the simulation hands it over.
"""

from __future__ import annotations

import copy
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy.orm import Session

from hcss.platform.live.probes import POSTPONE_S, PROBE_TIMEOUT_S, fill_probe
from hcss.platform.live.session import CurrentProbe, RunningTrial
from hcss.platform.models import (
    DecisionRow,
    Probe,
    ProbeEvent,
    RequestStatusChange,
    SimEvent,
    Snapshot,
    TrialStatusChange,
)
from hcss.platform.models.vocabularies import RequestStatus, TrialStatus
from hcss.simulation.messages import event_text

#: Decision-table columns the export fills from the trial and participant, not stored per row.
EXPORT_IDENTITY = ("source", "participant", "trial_id", "run")


@dataclass
class _Cursors:
    """What a `RunningTrial` says is written; put back when the commit that wrote it fails."""

    fields: dict[str, Any]

    NAMES = (
        "last_event_time",
        "decisions_recorded",
        "request_statuses_written",
        "pending_projection",
        "probes_shown",
        "postponed_until",
        "current_probe",
        "last_snapshot_epoch",
    )

    @classmethod
    def of(cls, live: RunningTrial) -> _Cursors:
        values = {name: getattr(live, name) for name in cls.NAMES}
        values["ended"] = live.ended
        return cls({k: copy.copy(v) if isinstance(v, set | list) else v for k, v in values.items()})

    def restore(self, live: RunningTrial) -> None:
        for name, value in self.fields.items():
            if name != "ended":
                setattr(live, name, value)
        ended = self.fields["ended"]
        if live.ended and not ended:
            live.reopen()  # its end was not written: it runs on


@contextmanager
def kept_until_written(live: RunningTrial, *, simulation_restored: bool = False) -> Iterator[None]:
    """Around a unit of work that records progress: its cursors stand if it commits.

    When the block raises (the commit failed, the database is away), the
    cursors go back to what was written and the handed-over events and status
    changes stay queued, so the next attempt writes them all; nothing the
    participant saw is dropped. A caller that puts the simulation back as it
    was before the block (`simulation_restored`: a command that was not
    logged) drops what the block handed over instead: it never happened.
    """
    saved = _Cursors.of(live)
    events, changes = len(live.unwritten_events), len(live.unwritten_status_changes)
    try:
        yield
    except BaseException:
        saved.restore(live)
        if simulation_restored:
            del live.unwritten_events[events:]
            del live.unwritten_status_changes[changes:]
        raise
    live.unwritten_events.clear()
    live.unwritten_status_changes.clear()


def record_progress(live: RunningTrial, session: Session) -> None:
    """Events, decisions, request statuses and probes up to the simulation's now."""
    sim = live.sim
    _record_events(live, session)
    _record_decisions(live, session)
    record_request_statuses(live, session)
    _expire_probe(live, session, sim.time)
    _show_probe(live, session, sim.time)


def _take_events(live: RunningTrial) -> None:
    """The simulation's new events join the unwritten ones and the System Messages, once."""
    for event in live.sim.drain_events():
        time = float(event["time"])
        if time <= live.last_event_time:
            continue  # written before an interruption; the replay produced it again
        live.unwritten_events.append(event)
        live.add_message(time, str(event["kind"]), event_text(event))


def _record_events(live: RunningTrial, session: Session) -> None:
    _take_events(live)
    for event in live.unwritten_events:
        session.add(
            SimEvent(
                trial_id=live.trial_id,
                kind=str(event["kind"]),
                collective=_int_or_none(event.get("collective")),
                target=_int_or_none(event.get("target")),
                text=event_text(event)[:300],
                sim_time=float(event["time"]),
            )
        )
    # Events of one step share its time and are written together, so the
    # newest time marks everything written.
    live.last_event_time = max(live.last_event_time, float(live.sim.time) - 1e-9)


def _record_decisions(live: RunningTrial, session: Session) -> None:
    records = live.sim.decisions
    for record in records[live.decisions_recorded :]:
        # The record itself; who and where (source, participant, trial, run) the export adds.
        row = {k: v for k, v in record.as_row().items() if k not in EXPORT_IDENTITY}
        session.add(
            DecisionRow(
                trial_id=live.trial_id,
                collective=int(record.collective),
                decision_index=int(row["decision_index"]),
                step=live.sim.step_count,
                correct=None if row.get("correct") is None else bool(row["correct"]),
                record=row,
            )
        )
        _score_projections(live, session, row["collective"], float(row["end_s"]))
    live.decisions_recorded = len(records)


def _score_projections(live: RunningTrial, session: Session, collective: str, end_s: float) -> None:
    """Level-3 probes asked before this decision ended are scored by it."""
    still_pending = []
    for probe_id, shown_at, answer in live.pending_projection:
        if shown_at >= end_s:
            still_pending.append((probe_id, shown_at, answer))
            continue
        session.add(
            ProbeEvent(
                probe_id=probe_id,
                kind="scored",
                answer=answer,
                truth=collective,
                correct=None if answer is None else answer == collective,
                step=live.sim.step_count,
                sim_time=float(live.sim.time),
            )
        )
    live.pending_projection = still_pending


def record_request_statuses(live: RunningTrial, session: Session) -> None:
    """Each request status change the simulation queued, written once with its own step.

    A rebuild replays changes that were written before the interruption;
    `request_statuses_written` (restored from the rows) skips those.
    """
    live.unwritten_status_changes.extend(live.sim.drain_status_changes())
    for change in live.unwritten_status_changes:
        key = (change.request_id, change.status)
        if key in live.request_statuses_written:
            continue
        session.add(
            RequestStatusChange(
                trial_id=live.trial_id,
                request_id=change.request_id,
                status=RequestStatus(change.status),
                step=change.step,
                sim_time=float(change.time),
            )
        )
        live.request_statuses_written.add(key)


def _expire_probe(live: RunningTrial, session: Session, time: float) -> None:
    probe = live.current_probe
    if probe is None or time < probe.timeout_sim_time:
        return
    session.add(
        ProbeEvent(
            probe_id=probe.id,
            kind="timeout",
            step=live.sim.step_count,
            sim_time=float(time),
        )
    )
    live.current_probe = None


def _show_probe(live: RunningTrial, session: Session, time: float) -> None:
    if live.current_probe is not None or live.probes_shown >= len(live.probe_plan):
        return
    planned = live.probe_plan[live.probes_shown]
    if time < planned.at_s or time < live.postponed_until:
        return
    probe_index = live.probes_shown + 1
    rng = np.random.default_rng([live.seed, 0x5B, probe_index])
    filled = fill_probe(planned.level, live.display(), live.sim.truth(), rng)
    if filled is None:
        live.postponed_until = time + POSTPONE_S
        return
    row = Probe(
        trial_id=live.trial_id,
        probe_index=probe_index,
        level=filled.level,
        question=filled.question,
        choices=filled.choices,
        truth=filled.truth,
        shown_step=live.sim.step_count,
        shown_sim_time=float(time),
        timeout_sim_time=float(time) + PROBE_TIMEOUT_S,
    )
    session.add(row)
    session.flush()
    live.probes_shown = probe_index
    live.current_probe = CurrentProbe(
        id=row.id,
        probe_index=probe_index,
        level=filled.level,
        question=filled.question,
        choices=filled.choices,
        truth=filled.truth,
        shown_sim_time=row.shown_sim_time,
        timeout_sim_time=row.timeout_sim_time,
    )
    if filled.level == 3:
        live.pending_projection.append((row.id, row.shown_sim_time, None))


def write_snapshot(live: RunningTrial, session: Session, now: float) -> None:
    sim = live.sim
    session.add(
        Snapshot(
            trial_id=live.trial_id,
            step=sim.step_count,
            sim_time=float(sim.time),
            last_command_id=live.last_command_id,
            blob=sim.snapshot(),
        )
    )
    live.last_snapshot_epoch = now


def end_trial(live: RunningTrial, session: Session, reason: str, now: float) -> None:
    """The time limit is reached: close the open probe, snapshot, and mark it ended."""
    probe = live.current_probe
    if probe is not None:
        session.add(
            ProbeEvent(
                probe_id=probe.id, kind="timeout", step=live.sim.step_count, sim_time=live.sim.time
            )
        )
        live.current_probe = None
    write_snapshot(live, session, now)
    session.add(
        TrialStatusChange(
            trial_id=live.trial_id,
            status=TrialStatus.ENDED,
            reason=reason,
            step=live.sim.step_count,
        )
    )
    live.mark_ended(reason)


def _int_or_none(value: Any) -> int | None:
    """A record's integer field (numpy or Python), or None."""
    return None if value is None else int(value)
