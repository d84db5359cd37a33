"""The trial log's writer: the only code that makes a trial's rows.

Everything a live trial leaves in the database is written here: the trial
row and its status changes, snapshots, interruptions and problems, the
participant's commands with their outcomes and idempotency keys, clicks,
probes and their events, decisions, System Message events, request statuses,
and the console's actions on it. The callers (the recorder, the actions, the
rebuild, the runner, the console's control) decide *what* happened, under the
trial's lock and in a transaction that proves the lease
(`leases.trial_transaction`); this module turns it into rows. What a running
trial and the commands on it do arrives as typed facts (`live.facts`,
`write_fact` and `write_facts`); the trial's start, its outages, a rebuild's
problems and replayed outcomes, the probes shown and the commands' keys have
functions of their own. A check in
tests/platform/test_one_writer.py finds any other code that builds, inserts,
updates or deletes such a row (the lease and order tables are the leases' and
orders' own; a withdrawal deletes a participant's rows wholesale).

A trial's decisions, events, probes, probe events, request statuses and
interruptions each have a unique key in the database (migration
i29_unique_trial_rows): a decision is its collective and index, an event its
kind, time and text, a probe its index, a probe event its kind, a status its
request and status, an interruption the moment the trial was last seen before
it. They are written insert-if-absent (``INSERT … ON CONFLICT DO NOTHING``), so
neither a retry after a commit whose answer was lost nor a second writer
racing this one (two transactions that both read "absent") can store one
twice, and neither fails. On PostgreSQL the second of two racing inserts
waits for the first's commit and then skips; SQLite writes one transaction
at a time.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from hcss.platform.db import add_all_if_absent, add_if_absent
from hcss.platform.live.facts import (
    CommandApplied,
    ConsoleActed,
    DecisionMade,
    EventHappened,
    Fact,
    ObservationMade,
    ProbeAnswered,
    ProbeReadyPressed,
    ProbeTimedOut,
    ProjectionScored,
    RequestStatusChanged,
    SnapshotTaken,
    TrialEnded,
)
from hcss.platform.models import (
    Command,
    CommandKey,
    CommandOutcome,
    ConsoleAction,
    DecisionRow,
    Interruption,
    Observation,
    Probe,
    ProbeEvent,
    RequestStatusChange,
    SimEvent,
    Snapshot,
    Trial,
    TrialProblem,
    TrialStatusChange,
)
from hcss.platform.models.vocabularies import RequestStatus, TrialStatus

if TYPE_CHECKING:
    from hcss.simulation.requests import RequestOutcome


@dataclass(frozen=True)
class KeyedCommand:
    """A command's idempotency key as a value: which trial, the key, and what it stands for
    (route and fingerprint); stored as a `CommandKey` row with the command's answer."""

    trial_id: int
    key: str
    endpoint: str
    fingerprint: str


def write_trial(session: Session, trial: Trial) -> Trial:
    """A trial starts: its row and its first status, ``running``."""
    session.add(trial)
    session.flush()
    write_status(session, trial.id, TrialStatus.RUNNING, "started", 0)
    return trial


def new_trial(**columns: Any) -> Trial:
    """The unsaved row of a trial about to start (`write_trial` stores it)."""
    return Trial(**columns)


def write_status(session: Session, trial_id: int, status: str, reason: str, step: int) -> None:
    session.add(TrialStatusChange(trial_id=trial_id, status=status, reason=reason, step=step))
    session.flush()


def write_ended_once(session: Session, trial_id: int, reason: str, step: int) -> None:
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
            TrialStatusChange(trial_id=trial_id, status=TrialStatus.ENDED, reason=reason, step=step)
        )


def write_problem(session: Session, trial_id: int, source: str, record: str, problem: str) -> None:
    """A stored record that could not be used, or a trial that could not be rebuilt."""
    session.add(
        TrialProblem(trial_id=trial_id, source=source, record=record, problem=problem[:300])
    )


def delete_snapshots(session: Session, snapshot_ids: list[int]) -> None:
    """Delete these superseded snapshots (hcss.platform.live.snapshots chooses them; the
    table's trigger refuses any that is a trial's newest)."""
    session.execute(
        delete(Snapshot)
        .where(Snapshot.id.in_(snapshot_ids))
        .execution_options(synchronize_session=False)
    )


def write_snapshot(
    session: Session,
    trial_id: int,
    *,
    step: int,
    sim_time: float,
    last_command_id: int | None,
    blob: bytes,
) -> None:
    session.add(
        Snapshot(
            trial_id=trial_id,
            step=step,
            sim_time=sim_time,
            last_command_id=last_command_id,
            blob=blob,
        )
    )


def write_interruption(session: Session, trial_id: int, **fields: Any) -> bool:
    """An outage of the trial, once per moment it was last seen before it (its key)."""
    return add_if_absent(session, Interruption(trial_id=trial_id, **fields))


def write_command_outcome(session: Session, command_id: int, outcome: RequestOutcome) -> None:
    """The outcome of a logged command, replayed by a rebuild; one per command."""
    add_if_absent(session, CommandOutcome.of(command_id, outcome))


def write_command_key(session: Session, key: KeyedCommand, status: int, response: Any) -> None:
    """The key with the answer its command got, in the command's transaction."""
    session.add(
        CommandKey(
            trial_id=key.trial_id,
            key=key.key,
            endpoint=key.endpoint,
            fingerprint=key.fingerprint,
            status=status,
            response=response,
        )
    )


def _write_probe_event(session: Session, probe_id: int, kind: str, **fields: Any) -> int | None:
    """A probe's ready press, answer, time-out or score, once per kind; its id (None: stored
    before, by a commit whose answer was lost)."""
    row = ProbeEvent(probe_id=probe_id, kind=kind, **fields)
    return row.id if add_if_absent(session, row) else None


def write_probe(session: Session, trial_id: int, probe_index: int, **fields: Any) -> Probe:
    """The trial's `probe_index`-th probe, shown; the stored one if a lost commit showed it."""
    row = Probe(trial_id=trial_id, probe_index=probe_index, **fields)
    if add_if_absent(session, row):
        return row
    return session.scalars(
        select(Probe).where(Probe.trial_id == trial_id, Probe.probe_index == probe_index)
    ).one()


def write_decision(session: Session, trial_id: int, **fields: Any) -> bool:
    """A collective decision's record; once per collective and index."""
    return add_if_absent(session, DecisionRow(trial_id=trial_id, **fields))


def write_facts(session: Session, trial_id: int, facts: Iterable[Fact]) -> None:
    """The rows of what happened in the trial (`live.facts`), in order; each once.

    Events and request statuses in a row are inserted in one statement each
    (a step hands over many); the others one by one, as they come (`write_fact`).
    """
    events: list[EventHappened] = []
    statuses: list[RequestStatusChanged] = []

    def flush() -> None:
        if events:
            _write_events(session, trial_id, events)
            events.clear()
        if statuses:
            _write_statuses(session, trial_id, statuses)
            statuses.clear()

    for fact in facts:
        if isinstance(fact, EventHappened):
            if statuses:
                flush()
            events.append(fact)
            continue
        if isinstance(fact, RequestStatusChanged):
            if events:
                flush()
            statuses.append(fact)
            continue
        flush()
        write_fact(session, trial_id, fact)
    flush()


def write_fact(session: Session, trial_id: int, fact: Fact) -> int | None:
    """The row (or rows) of one fact of the trial; the id of its row, which a command's answer
    names (None: a row stored before, by a commit whose answer was lost, or one with no id
    worth naming)."""
    if isinstance(fact, EventHappened):
        _write_events(session, trial_id, [fact])
    elif isinstance(fact, RequestStatusChanged):
        _write_statuses(session, trial_id, [fact])
    elif isinstance(fact, CommandApplied | ObservationMade | ConsoleActed):
        return _write_command_row(session, trial_id, fact)
    elif isinstance(fact, ProbeReadyPressed):
        return _write_probe_event(
            session,
            fact.probe_id,
            "ready",
            latency_ms=fact.latency_ms,
            step=fact.step,
            sim_time=fact.sim_time,
        )
    elif isinstance(fact, ProbeAnswered):
        return _write_answer(session, fact)
    else:
        _write_log_fact(session, trial_id, fact)
    return None


def _write_command_row(
    session: Session, trial_id: int, fact: CommandApplied | ObservationMade | ConsoleActed
) -> int:
    """The row of a command carried out (the participant's or the console's); its id."""
    row: Command | Observation | ConsoleAction
    if isinstance(fact, CommandApplied):
        row = Command.applied(
            trial_id,
            fact.command,
            fact.outcome,
            step=fact.step,
            sim_time=fact.sim_time,
            selections=fact.selections,
        )
    elif isinstance(fact, ObservationMade):
        row = Observation(
            trial_id=trial_id,
            kind=fact.kind,
            collective=fact.collective,
            target=fact.target,
            button=fact.button,
            step=fact.step,
            sim_time=fact.sim_time,
        )
    else:
        row = ConsoleAction(
            participant_id=fact.participant_id,
            experimenter_id=fact.experimenter_id,
            action=fact.action,
            trial_id=trial_id if fact.on_trial else None,
            at_epoch=fact.at_epoch,
            detail=fact.detail,
        )
    session.add(row)
    session.flush()
    if isinstance(fact, CommandApplied):
        session.add(CommandOutcome.of(row.id, fact.outcome))
    return row.id


def _write_answer(session: Session, fact: ProbeAnswered) -> int | None:
    """The answer's event, and its score when the probe's truth is known now."""
    when = {"step": fact.step, "sim_time": fact.sim_time}
    answered = _write_probe_event(
        session, fact.probe_id, "answer", answer=fact.answer, latency_ms=fact.latency_ms, **when
    )
    if fact.truth is not None:
        _write_score(session, fact)
    return answered


def _write_score(session: Session, fact: ProbeAnswered | ProjectionScored) -> None:
    """A probe's score: at its answer when the truth is known then, or later for a
    projection, scored by the decision it asked about."""
    _write_probe_event(
        session,
        fact.probe_id,
        "scored",
        answer=fact.answer,
        truth=fact.truth,
        correct=fact.correct,
        step=fact.step,
        sim_time=fact.sim_time,
    )


def stored(session: Session, fact: Fact, row_id: int | None) -> bool:
    """Whether the row of a command's `fact` is in the database: asked after its transaction's
    commit failed, when the commit may have landed and its answer been lost.

    `row_id`: what `write_fact` answered (None: it never wrote the row, or the
    row was there before). A probe's press or answer is looked up by its key,
    a row without one by its id.
    """
    if isinstance(fact, ProbeReadyPressed | ProbeAnswered):
        kind = "ready" if isinstance(fact, ProbeReadyPressed) else "answer"
        found = session.scalar(
            select(ProbeEvent.id).where(
                ProbeEvent.probe_id == fact.probe_id, ProbeEvent.kind == kind
            )
        )
        return found is not None
    if row_id is None:
        return False
    model = {CommandApplied: Command, ObservationMade: Observation, ConsoleActed: ConsoleAction}[
        type(fact)
    ]
    return session.get(model, row_id) is not None


def _write_log_fact(
    session: Session,
    trial_id: int,
    fact: DecisionMade | ProbeTimedOut | ProjectionScored | SnapshotTaken | TrialEnded,
) -> None:
    if isinstance(fact, DecisionMade):
        write_decision(  # skipped if written by a commit whose answer was lost
            session,
            trial_id,
            collective=fact.collective,
            decision_index=fact.decision_index,
            step=fact.step,
            correct=fact.correct,
            record=fact.record,
        )
    elif isinstance(fact, ProbeTimedOut):
        _write_probe_event(
            session, fact.probe_id, "timeout", step=fact.step, sim_time=fact.sim_time
        )
    elif isinstance(fact, ProjectionScored):
        _write_score(session, fact)
    elif isinstance(fact, SnapshotTaken):
        write_snapshot(
            session,
            trial_id,
            step=fact.step,
            sim_time=fact.sim_time,
            last_command_id=fact.last_command_id,
            blob=fact.blob,
        )
    else:
        write_ended_once(session, trial_id, fact.reason, fact.step)


def _write_events(session: Session, trial_id: int, events: list[EventHappened]) -> None:
    """System Message events, in one statement; each once (kind, time and text are its key)."""
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
            for e in events
        ],
    )


def _write_statuses(session: Session, trial_id: int, changes: list[RequestStatusChanged]) -> None:
    """Request status changes, in one statement; each once (request and status are its key)."""
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
            for c in changes
        ],
    )
