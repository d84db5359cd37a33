"""One trial unit of work: the one way anything is written for a hosted trial.

Every command (the participant's, hcss.platform.live.commands; the
console's, hcss.platform.live.control, and so the console's orders carried
out for another process), and the runner's steps (hcss.platform.live.stepping),
write through `trial_unit`, which

1. proves the fence: the transaction proves the trial's lease first
   (`trial_transaction`), so a process that lost it writes nothing;
2. marks the cursors: what the trial counts written (its log's cursors,
   its probes, its end) stands only if the unit commits, and goes back when
   it does not (`kept_until_written`);
3. writes the facts through the writer (`TrialUnit.write`, `TrialUnit.command`:
   each fact by its own declaration, `live.facts`), a command's with its
   idempotency key and the answer its client gets;
4. settles an ambiguous commit: a commit that fails may have landed, its
   answer lost (a dropped line, a failover). For a command the database is
   asked whether the command's row is stored (`was_stored`), not guessed
   at: stored, the unit counts as done (`answer_lost`: the caller's trial in
   memory moves on as the log says); not stored, the error is raised and the
   caller puts back what it changed; nobody can say (the database is still
   away), the trial in memory is not trusted any longer: it is marked moved
   (the runner drops it and the next request rebuilds it from the log) and
   the error is raised (503, and the page retries). A failure before the
   commit was sent (the database away at the first statement) wrote nothing,
   and nothing is asked. A unit without a command (the runner's steps) writes
   only rows that are stored once whatever is retried, so its failures are
   raised as they are.

Before issue 41 the last step, a `committing` flag and a `was_stored` call,
was written out three times (twice in the participant's actions, once in the
console's control).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from sqlalchemy.exc import DBAPIError
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live import trial_writer
from hcss.platform.live.trial_writer import KeyedCommand

if TYPE_CHECKING:
    from hcss.platform.live.facts import Fact
    from hcss.platform.live.running_trial import RunningTrial

log = logging.getLogger(__name__)


@contextmanager
def trial_transaction(database: Database, live: RunningTrial) -> Iterator[Session]:
    """A unit of work that writes for the trial: with leases it proves the lease first,
    in the same transaction, and rolls back with `LeaseLost` if it cannot."""
    with database.session_scope() as session:
        if live.fence is not None:
            live.fence.prove(session, database.clock())
        yield session


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
    mark = live.progress_mark()
    try:
        yield
    except BaseException:
        live.progress_lost(mark, handed_over_dropped=simulation_restored)
        raise
    live.progress_written()


class TrialUnit:
    """What one unit of work writes for a trial, in its transaction (`session`)."""

    def __init__(self, live: RunningTrial, session: Session) -> None:
        self.live = live
        self.session = session
        #: The command's fact and its row's id: what settles a commit whose answer was lost.
        self.settled_by: tuple[Fact, int | None] | None = None
        #: The commit failed but the command's row is stored: the unit is done all the same.
        self.answer_lost = False

    def write(self, *facts: Fact) -> None:
        """The rows of what happened in the trial, in order (`trial_writer.write_facts`)."""
        trial_writer.write_facts(self.session, self.live.trial_id, facts)

    def command(
        self,
        fact: Fact,
        key: KeyedCommand | None = None,
        answer_of: Callable[[int | None], Any] | None = None,
        status: int = 200,
    ) -> int | None:
        """The command's fact (its rows' id), with `key` and the answer `answer_of(row id)`
        its client gets; whether this row is stored settles a lost commit."""
        row_id = trial_writer.write_fact(self.session, self.live.trial_id, fact)
        if key is not None:
            assert answer_of is not None
            trial_writer.write_command_key(self.session, key, status, answer_of(row_id))
        self.settled_by = (fact, row_id)
        return row_id


@contextmanager
def trial_unit(
    database: Database, live: RunningTrial, *, simulation_restored: bool = False
) -> Iterator[TrialUnit]:
    """One fenced unit of work for `live` (its lock held by the caller): see the module.

    `simulation_restored`: the caller puts the simulation back when the unit
    fails (a command not logged), so what the unit's simulation handed over
    is dropped, not queued (`kept_until_written`).
    """
    unit: TrialUnit | None = None
    committing = False
    try:
        with (
            kept_until_written(live, simulation_restored=simulation_restored),
            trial_transaction(database, live) as session,
        ):
            unit = TrialUnit(live, session)
            yield unit
            committing = True  # what fails from here on is the commit: it may have landed
    except DBAPIError:
        if not committing or unit is None or unit.settled_by is None:
            raise
        if not was_stored(database, live, *unit.settled_by):
            raise
        unit.answer_lost = True


def was_stored(database: Database, live: RunningTrial, fact: Fact, row_id: int | None) -> bool:
    """Whether the row of `fact`, whose transaction's commit failed, is in the database: asked,
    not guessed. When the database cannot say (it is still away), the trial in memory is not
    trusted any longer: it is marked moved (the runner drops it, the next request rebuilds it
    from the log) and the answer is False, so the caller raises (503, and the page retries)."""
    try:
        with database.session_scope() as session:
            found = fact.stored(session, row_id)
    except DBAPIError:
        log.warning("trial %s: cannot tell whether %s was stored", live.trial_id, fact)
        live.move_away()
        return False
    if found:
        log.warning("trial %s: %s committed, its answer lost", live.trial_id, type(fact).__name__)
    return found
