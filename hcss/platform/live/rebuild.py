"""Bring a trial into memory: a fresh start, or a rebuild after a restart.

Deterministic replay makes the rebuild exact: restore the latest snapshot,
apply each logged command at the step it was applied live (the simulation's own
`replay`, the one the analysis and the tests use too), and step on to the
step the wall clock says is due, not counting the outage itself
(hcss.platform.live.outages: the trial clock stands still while the server is down). A trial that had been running in some server
before (it has a snapshot) gets an `Interruption` row with the rebuilt
state's digest. A snapshot written by a newer version in a format this one
does not read (a rolling upgrade) is not used: the trial is replayed from its
start with the whole command log.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from hcss.platform.live import trial_writer
from hcss.platform.live.clock import paused_intervals
from hcss.platform.live.outages import (
    earlier_outages_s,
    last_reached_step,
    last_seen,
    stop_clock_for_outage,
)
from hcss.platform.live.probes import counts_of, probe_plan
from hcss.platform.live.progress import CurrentProbe, Projection
from hcss.platform.live.recorder import record_progress, write_snapshot
from hcss.platform.live.running_trial import RunningTrial
from hcss.platform.live.trial_log import (
    build_simulation,
    new_simulation,
    newest_snapshot,
    shown_messages,
)
from hcss.platform.live.unit_of_work import kept_until_written
from hcss.platform.models import (
    Command,
    DecisionRow,
    Probe,
    ProbeEvent,
    RequestStatusChange,
    SimEvent,
    Snapshot,
    Trial,
)
from hcss.platform.models.stored_names import Uninterpretable

if TYPE_CHECKING:
    from hcss.simulation import Simulation
    from hcss.simulation.requests import RequestOutcome


def load_trial(
    session: Session, trial: Trial, now: float, *, host_died: bool = False
) -> RunningTrial:
    """The trial in memory; `host_died`: another process hosted it and its lease ran out.

    A trial that ran in a server that died (it has a snapshot, or its host's
    lease ran out before the host wrote one) gets its clock stopped for the
    outage and an `Interruption` (`snapshot_step` -1 when it was rebuilt from
    the start: no snapshot, or none this version reads).
    """
    newest = newest_snapshot(session, trial.id)
    restored = None if newest is None else _restored(session, newest)
    snapshot = None if restored is None else newest  # the one the rebuild starts from
    sim = new_simulation(trial) if restored is None else restored
    live = RunningTrial(
        trial_id=trial.id,
        participant_id=trial.participant_id,
        participant_code=trial.participant.code,
        participant_token=trial.participant.token,
        kind=trial.kind,
        model=trial.model,
        seed=trial.seed,
        scenario_id=trial.scenario_id,
        first_section=trial.first_section,
        sim=sim,
        started_epoch=trial.started_at.timestamp(),
        acceleration=trial.time_acceleration,
        duration_s=trial.duration_s,
        dt=float(sim.params.dt_s),
        probe_plan=probe_plan(trial.seed, trial.duration_s, counts_of(trial.probe_counts)),
        last_command_id=None if snapshot is None else snapshot.last_command_id,
    )
    seen = last_seen(session, trial.id)  # before this rebuild writes anything
    # The experimenter's pauses stop the trial clock, and so did earlier outages.
    live.pauses_restored(*paused_intervals(session, trial.id))
    live.stood_still(earlier_outages_s(session, trial.id))
    replayed = _replay_commands(session, trial, live)
    outage_s = 0.0
    ran_before = newest is not None or host_died
    if ran_before:  # it ran in a server that died: the outage stops its clock
        reached = max(last_reached_step(session, trial.id), sim.step_count)
        outage_s = stop_clock_for_outage(live, seen, reached, now)
    due = live.due_step(now)
    if sim.step_count < due:
        sim.step(due - sim.step_count)
    _restore_bookkeeping(session, live)
    # A unit of work of the recorder like any other: what it hands over counts as written
    # with this transaction, so the first `advance` does not write the load's events again.
    with kept_until_written(live):
        record_progress(live, session)
    if ran_before:  # stored once, even if two rebuilds of this outage race (its key)
        trial_writer.write_interruption(
            session,
            trial.id,
            snapshot_step=-1 if snapshot is None else snapshot.step,
            resumed_step=sim.step_count,
            replayed_commands=replayed,
            state_digest=sim.state_digest(),
            last_seen_at=seen,
            outage_s=outage_s,
        )
    write_snapshot(live, session, now)
    return live


def _restored(session: Session, snapshot: Snapshot) -> Simulation | None:
    """The snapshot's simulation; None for a newer version's format (a rolling upgrade).

    A newer format is never guessed at: the trial is rebuilt from its start
    with the whole command log instead, exact by deterministic replay as long
    as the two versions step alike, which each release proves on the previous
    one's fixtures (docs/operations.md, "Rolling upgrade"); a trial problem
    row says so. Any other snapshot that cannot be restored (an older format
    no longer read, bytes that are no snapshot) raises SimulationError, and
    the trial ends `rebuild_failed` with the reason.
    """
    from hcss.simulation import NewerSnapshotFormat, Simulation

    try:
        return Simulation.restore(snapshot.blob)
    except NewerSnapshotFormat as newer:
        trial_writer.write_problem(
            session,
            snapshot.trial_id,
            "rebuild",
            f"snapshot {snapshot.id}",
            f"{newer}: rebuilt from the trial's start with its whole command log",
        )
        return None


def _replay_commands(session: Session, trial: Trial, live: RunningTrial) -> int:
    """Apply the commands the snapshot does not contain (the trial log's `build_simulation`).

    The snapshot names the last logged command it holds (`last_command_id`):
    the commands after it are replayed, by identity, not by how many the
    snapshot counts, so a row the live trial never applied cannot shift every
    later rebuild. An outcome the server logged no row for (it died in
    between) is written now. Returns the commands replayed.
    """
    replayed = 0

    def record(command: Command, outcome: RequestOutcome) -> None:
        nonlocal replayed
        replayed += 1
        trial_writer.write_command_outcome(session, command.id, outcome)  # one per command
        live.command_applied(command.id)

    build_simulation(
        session, trial, start=live.sim, after_command=live.last_command_id or 0, on_outcome=record
    )
    return replayed


def _restore_bookkeeping(session: Session, live: RunningTrial) -> None:
    """What was already written, so the recorder writes only what is new."""
    tid = live.trial_id
    last_event_time = session.execute(
        select(func.coalesce(func.max(SimEvent.sim_time), -1.0)).where(SimEvent.trial_id == tid)
    ).scalar_one()
    decisions = session.execute(
        select(func.count()).select_from(DecisionRow).where(DecisionRow.trial_id == tid)
    ).scalar_one()
    written = session.execute(
        select(RequestStatusChange.request_id, RequestStatusChange.status).where(
            RequestStatusChange.trial_id == tid
        )
    )
    statuses = {(request_id, status) for request_id, status in written}
    live.log_queue.restored(last_event_time, decisions, statuses)
    _restore_messages(session, live)
    _restore_probes(session, live)


def _restore_messages(session: Session, live: RunningTrial) -> None:
    """The System Messages in the order the live page had them; a command that
    cannot be worded is recorded as a trial problem instead."""

    def unworded(command: Command, error: Uninterpretable) -> None:
        trial_writer.write_problem(
            session,
            live.trial_id,
            "rebuild",
            f"command {command.id}",
            f"not shown in System Messages: {error}",
        )

    n = live.sim.scenario.n_collectives
    for time, kind, text in shown_messages(session, live.trial_id, n, unworded):
        live.add_message(time, kind, text)


def _restore_probes(session: Session, live: RunningTrial) -> None:
    probes = list(
        session.scalars(select(Probe).where(Probe.trial_id == live.trial_id).order_by(Probe.id))
    )
    events: dict[int, list[ProbeEvent]] = {p.id: [] for p in probes}
    for event in session.scalars(
        select(ProbeEvent).where(ProbeEvent.probe_id.in_(list(events))).order_by(ProbeEvent.id)
    ):
        events[event.probe_id].append(event)
    projections: list[Projection] = []
    current = None
    for probe in probes:
        kinds = {e.kind: e for e in events[probe.id]}
        if probe.level == 3 and "scored" not in kinds:
            answer = kinds["answer"].answer if "answer" in kinds else None
            projections.append((probe.id, probe.shown_sim_time, answer))
        if "answer" not in kinds and "timeout" not in kinds:
            current = CurrentProbe.of(probe, ready="ready" in kinds)
    live.probes_restored(len(probes), current, projections)
