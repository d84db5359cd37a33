"""Snapshots that do not fill the database: written when the state changed, thinned with age.

A rebuild reads a trial's newest snapshot and replays the commands logged
after it; the command log is the record (append-only, without exception).
Every hosted trial used to write a 55-69 KB snapshot every 5 s and keep all of
them: 2.2 GB for 61 trials in 47 minutes (issue 41). Now, in the unit of work
that writes a snapshot:

- nothing is written when the trial is where the last snapshot of this
  trial in memory left it (same step, same last command, its clock at the
  same step: paused, or standing still while the database is away);
- older snapshots are deleted once the new one is in the same transaction,
  so a snapshot is gone only when a newer one commits with it. What stays:
  the newest `KEEP_NEWEST`, and of the older ones the oldest in each age
  bucket (ages in steps behind the newest, bucketed by powers of two), so a
  trial of n steps keeps at most `KEEP_NEWEST` + log2(n) + 1 (15 for an
  hour at 5 Hz), however long it runs.

The `snapshot` table's trigger allows exactly this (hcss.platform.models.
append_only.SUPERSEDED): a snapshot may be deleted only while a newer one of
the same trial exists; updates stay refused.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
from weakref import WeakKeyDictionary

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.live import trial_writer
from hcss.platform.models import Snapshot

if TYPE_CHECKING:
    from hcss.platform.live.running_trial import RunningTrial

#: Newest snapshots kept whatever their age: the one a rebuild reads, and the one before.
KEEP_NEWEST = 2

#: The (step, last command, clock's step) each trial in memory last wrote a snapshot at.
_written: WeakKeyDictionary[RunningTrial, tuple[int, int | None, int]] = WeakKeyDictionary()


def write_snapshot(live: RunningTrial, session: Session, now: float) -> bool:
    """Write the trial's snapshot in `session` unless its state is the one last written
    from this process, and prune what it supersedes; whether one was written.

    The state includes the step the trial's clock has reached (`due_step`): a trial
    whose simulation finished early still runs to its deadline, and its newest row's
    time is when its host was last seen alive (hcss.platform.live.outages), so it
    goes on writing (and pruning); a paused trial, or one standing still while the
    database is away, does not.
    """
    state = (live.sim.step_count, live.last_command_id, live.due_step(now))
    if _written.get(live) == state:
        return False
    trial_writer.write_facts(
        session, live.trial_id, [live.log_queue.snapshot_taken(live.sim, now, live.last_command_id)]
    )
    _written[live] = state
    prune(session, live.trial_id)
    return True


def written(live: RunningTrial, now: float) -> None:
    """A snapshot of the trial's present state was written by another path (its end)."""
    _written[live] = (live.sim.step_count, live.last_command_id, live.due_step(now))


def prune(session: Session, trial_id: int) -> int:
    """Delete the trial's snapshots that `kept` leaves out, in `session`; how many."""
    rows = session.execute(
        select(Snapshot.id, Snapshot.step)
        .where(Snapshot.trial_id == trial_id)
        .order_by(Snapshot.step.desc(), Snapshot.id.desc())
    ).all()
    keep = kept([(row.id, row.step) for row in rows])
    dropped = [row.id for row in rows if row.id not in keep]
    if dropped:
        trial_writer.delete_snapshots(session, dropped)
    return len(dropped)


def kept(snapshots: list[tuple[int, int]]) -> set[int]:
    """The ids to keep of a trial's snapshots (id, step), newest first: the newest
    `KEEP_NEWEST`, and of the rest the oldest in each power-of-two age bucket."""
    if not snapshots:
        return set()
    newest_step = snapshots[0][1]
    keep = {snapshot_id for snapshot_id, _ in snapshots[:KEEP_NEWEST]}
    oldest_in_bucket: dict[int, int] = {}
    for snapshot_id, step in snapshots[KEEP_NEWEST:]:  # newest first: the last seen is oldest
        oldest_in_bucket[(newest_step - step).bit_length()] = snapshot_id
    return keep | set(oldest_in_bucket.values())
