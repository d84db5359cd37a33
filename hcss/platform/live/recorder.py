"""Turn what the simulation did since the last look into rows and messages.

Called by the runner after each batch of steps, and once after a rebuild, with
the trial's lock held. Everything is derived from the simulation's state, so a
rebuild that replays the same steps writes only what had not been written.

What happened comes from the trial in memory as typed facts (`live.facts`:
its methods say what happened and move its cursors, with no I/O) and the
rows are made from them by the trial log's writer (`trial_writer.write_facts`): decisions,
events, probes, probe events and statuses if absent (the database's unique
keys decide): a unit of work whose commit reached the database but
whose answer was lost (a dropped line, a failover) is taken for failed and
written again by the next, whose rows (an event by kind, time and text; a
decision by collective and index; a status by request and status; a probe by
its index; a probe event by its kind) are then skipped. Only the lease's
holder writes (`unit_of_work.trial_transaction`); should a second writer race it
anyway, the keys still store each row once.

The cursors that say "written up to here" (the last event time, the decisions
recorded, the request statuses, the probes shown) move only with the commit:
`kept_until_written` puts them back when the commit fails (the trial's
`progress_mark` .. `progress_lost`), and the events and status changes the
simulation handed over wait on the `RunningTrial` to be written first, in
order, by the next commit that succeeds. The page's System Messages show an
event once, when the simulation hands it over.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from sqlalchemy.orm import Session

from hcss.platform.live import snapshots, trial_writer
from hcss.platform.live.probes import POSTPONE_S, PROBE_TIMEOUT_S, fill_probe
from hcss.platform.live.progress import CurrentProbe
from hcss.questionnaires.probes import ProbeLevel

if TYPE_CHECKING:
    from hcss.platform.live.running_trial import RunningTrial


def record_progress(live: RunningTrial, session: Session) -> None:
    """Events, decisions, request statuses and probes up to the simulation's now."""
    sim = live.sim
    _record_events(live, session)
    _record_decisions(live, session)
    record_request_statuses(live, session)
    _expire_probe(live, session, sim.time)
    _show_probe(live, session, sim.time)


def _record_events(live: RunningTrial, session: Session) -> None:
    """The simulation's new events join the unwritten ones and the System Messages (once);
    every unwritten one is written."""
    for event in live.log_queue.events_handed_over(live.sim.drain_events()):
        live.add_message(event.sim_time, event.kind, event.text)
    trial_writer.write_facts(session, live.trial_id, live.log.unwritten_events)
    # Events of one step share its time and are written together, so the
    # newest time marks everything written.
    live.log_queue.events_written_up_to(float(live.sim.time) - 1e-9)


def _record_decisions(live: RunningTrial, session: Session) -> None:
    """Each new decision, and the level-3 probes asked before it ended, which it scores."""
    for decision in live.log_queue.decisions_made(live.sim):
        trial_writer.write_facts(
            session, live.trial_id, [decision, *live.projections_scored_by(decision)]
        )


def record_request_statuses(live: RunningTrial, session: Session) -> None:
    """Each request status change the simulation queued, written once with its own step.

    A rebuild replays changes that were written before the interruption;
    the written ones (restored from the rows) are skipped.
    """
    changes = live.log_queue.status_changes_to_write(live.sim.drain_status_changes())
    trial_writer.write_facts(session, live.trial_id, changes)


def _expire_probe(live: RunningTrial, session: Session, time: float) -> None:
    probe = live.probes.current
    if probe is None or time < probe.timeout_sim_time:
        return
    cleared = live.probe_cleared()
    assert cleared is not None  # the probe above
    trial_writer.write_facts(session, live.trial_id, [cleared])


def _show_probe(live: RunningTrial, session: Session, time: float) -> None:
    due = live.probes.due(time)
    if due is None:
        return
    probe_index, planned = due
    rng = np.random.default_rng([live.seed, 0x5B, probe_index])
    filled = fill_probe(planned.level, live.display(), live.sim.truth(), rng)
    if filled is None and time + POSTPONE_S + PROBE_TIMEOUT_S > live.duration_s:
        # Nothing to ask about at its level yet, and no time to look again: the level
        # that always has a subject (projection) is asked, so no planned probe is lost
        # to the trial's end (a short trial plans only one). The row stores that level.
        filled = fill_probe(ProbeLevel.PROJECTION, live.display(), live.sim.truth(), rng)
    if filled is None:
        live.probe_postponed(time + POSTPONE_S)
        return
    row = trial_writer.write_probe(  # the stored one if a commit whose answer was lost showed it
        session,
        live.trial_id,
        probe_index,
        level=filled.level,
        question=filled.question,
        choices=filled.choices,
        truth=filled.truth,
        shown_step=live.sim.step_count,
        shown_sim_time=float(time),
        timeout_sim_time=float(time) + PROBE_TIMEOUT_S,
    )
    live.probe_shown(CurrentProbe.of(row))


def write_snapshot(live: RunningTrial, session: Session, now: float) -> None:
    """The trial's snapshot, if its state changed, and the older ones it supersedes
    pruned (hcss.platform.live.snapshots)."""
    snapshots.write_snapshot(live, session, now)


def end_trial(live: RunningTrial, session: Session, reason: str, now: float) -> None:
    """The time limit is reached: close the open probe, snapshot, and mark it ended."""
    cleared = live.probe_cleared()
    trial_writer.write_facts(
        session,
        live.trial_id,
        [
            *([] if cleared is None else [cleared]),
            live.log_queue.snapshot_taken(live.sim, now, live.last_command_id),
            live.mark_ended(reason),
        ],
    )
    snapshots.written(live, now)
    snapshots.prune(session, live.trial_id)
