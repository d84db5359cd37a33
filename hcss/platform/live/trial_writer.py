"""The trial log's writer: the only code that makes a trial's rows.

Everything a live trial leaves in the database is written here: the trial
row and its status changes, snapshots, interruptions and problems, the
participant's commands with their outcomes and idempotency keys, clicks,
probes and their events, decisions, System Message events, request statuses,
and the console's actions on it. The callers (the recorder, the actions, the
rebuild, the runner, the console's control) decide *what* happened, under the
trial's lock and in a transaction that proves the lease
(`unit_of_work.trial_transaction`, in a trial unit of work:
hcss.platform.live.unit_of_work); this module turns it into rows. What a
running trial and the commands on it do arrives as typed facts (`live.facts`),
each of which declares its own rows: `write_fact` and `write_facts` write a
fact by that declaration (no dispatch on its type here), and `stored` asks
it whether its row is in the database. The trial's start, its outages, a
rebuild's problems and replayed outcomes, the probes shown and the commands'
keys have functions of their own. A check in tests/platform/test_one_writer.py
finds any other code (than this module and the facts' declarations) that
builds, inserts, updates or deletes such a row (the lease and order tables are
the leases' and orders' own; a withdrawal deletes a participant's rows
wholesale).

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

import itertools
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from hcss.platform.db import add_if_absent
from hcss.platform.models import (
    CommandKey,
    CommandOutcome,
    Interruption,
    Probe,
    Snapshot,
    Trial,
    TrialProblem,
    TrialStatusChange,
)
from hcss.platform.models.vocabularies import TrialStatus

if TYPE_CHECKING:
    from hcss.platform.live.facts import Fact
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


def write_probe(session: Session, trial_id: int, probe_index: int, **fields: Any) -> Probe:
    """The trial's `probe_index`-th probe, shown; the stored one if a lost commit showed it."""
    row = Probe(trial_id=trial_id, probe_index=probe_index, **fields)
    if add_if_absent(session, row):
        return row
    return session.scalars(
        select(Probe).where(Probe.trial_id == trial_id, Probe.probe_index == probe_index)
    ).one()


def write_facts(session: Session, trial_id: int, facts: Iterable[Fact]) -> None:
    """The rows of what happened in the trial (`live.facts`), in order; each once.

    A run of facts of one kind is written by that kind's `write_all` (events
    and request statuses in one statement each: a step hands over many).
    """
    for _kind, run in itertools.groupby(facts, type):
        batch = list(run)
        type(batch[0]).write_all(session, trial_id, batch)


def write_fact(session: Session, trial_id: int, fact: Fact) -> int | None:
    """The row (or rows) of one fact of the trial, by its own declaration (`Fact.write`); the
    id of its row, which a command's answer names (None: a row stored before, by a commit
    whose answer was lost, or one with no id worth naming)."""
    return fact.write(session, trial_id)


def stored(session: Session, fact: Fact, row_id: int | None) -> bool:
    """Whether the row of a command's `fact` is in the database (`Fact.stored`): asked after
    its transaction's commit failed, when the commit may have landed and its answer been
    lost. `row_id`: what `write_fact` answered (None: it never wrote the row, or the row was
    there before)."""
    return fact.stored(session, row_id)
