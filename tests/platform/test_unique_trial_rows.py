"""A trial's decisions, events, probes, probe events, request statuses and interruptions
are each stored once: the database's unique keys (i29_unique_trial_rows) decide, and the
live code writes them insert-if-absent, so a second writer is skipped, not failed.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from datetime import UTC, datetime

import pytest
from alembic import command
from sqlalchemy import func, select, text
from sqlalchemy.exc import DBAPIError, IntegrityError

from hcss.platform.bots.participant import ManualClock
from hcss.platform.cli import alembic_config
from hcss.platform.db import Database
from hcss.platform.live.rebuild import load_trial
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.models import (
    DecisionRow,
    Interruption,
    Probe,
    ProbeEvent,
    RequestStatusChange,
    SimEvent,
    Trial,
    TrialProblem,
)
from tests.support.synthetic import stored_record

T0 = 1_000_000.0


def _trial_rows(trial_id: int, seen: datetime) -> list:
    """One of each row with a key, as a writer would store them."""
    return [
        DecisionRow(
            trial_id=trial_id, collective=0, decision_index=1, step=9, record=stored_record()
        ),
        SimEvent(trial_id=trial_id, kind="discovery", text="Target 3 discovered.", sim_time=4.5),
        RequestStatusChange(trial_id=trial_id, request_id=1, status="removed", step=9, sim_time=5),
        Interruption(
            trial_id=trial_id,
            snapshot_step=3,
            resumed_step=9,
            replayed_commands=0,
            state_digest="d",
            last_seen_at=seen,
        ),
    ]


def _probe(trial_id: int) -> Probe:
    return Probe(
        trial_id=trial_id,
        probe_index=1,
        level=1,
        question="Which collective?",
        choices=["I", "II"],
        truth="I",
        shown_step=3,
        shown_sim_time=1.5,
        timeout_sim_time=31.5,
    )


def _event(probe_id: int, kind: str) -> ProbeEvent:
    return ProbeEvent(probe_id=probe_id, kind=kind, step=4, sim_time=2.0)


def test_the_migration_keeps_the_first_of_each_double_and_says_what_it_removed(
    database_url: str, caplog
) -> None:
    """An old database (before the keys) holds doubles, as issue 29's stall wrote them: the
    upgrade keeps the first of each, moves a doubled probe's events to the kept probe, writes
    a trial_problem row per removal, logs the count, and from then on a double is refused."""
    config = alembic_config(database_url)
    command.upgrade(config, "i29_lease_epoch")
    database = Database(database_url, clock=ManualClock(T0))
    seen = datetime.fromtimestamp(T0 - 60, UTC)
    try:
        with database.session_scope() as session:
            _, trial = start_bot_trial(session, seed=2, duration_s=600.0)
            trial_id = trial.id
            first, second = _probe(trial_id), _probe(trial_id)
            session.add_all([first, second, *_trial_rows(trial_id, seen)])
            session.add_all([*_trial_rows(trial_id, seen), *_trial_rows(trial_id, seen)])
            session.flush()
            session.add_all(
                [_event(first.id, "ready"), _event(second.id, "ready"), _event(second.id, "answer")]
            )
            session.flush()
            first_id, second_id = first.id, second.id
            first_of = {
                model: session.scalar(select(func.min(model.id)).where(model.trial_id == trial_id))
                for model in (DecisionRow, SimEvent, RequestStatusChange, Interruption)
            }

        with caplog.at_level(logging.WARNING, logger="hcss.migrations"):
            command.upgrade(config, "head")

        with database.session_scope() as session:
            for model, kept in first_of.items():
                ids = session.scalars(select(model.id).where(model.trial_id == trial_id)).all()
                assert ids == [kept], model.__tablename__
            assert session.scalars(select(Probe.id).where(Probe.trial_id == trial_id)).all() == [
                first_id
            ]
            events = session.execute(select(ProbeEvent.probe_id, ProbeEvent.kind)).all()
            assert sorted(events) == [(first_id, "answer"), (first_id, "ready")]
            problems = session.scalars(
                select(TrialProblem.record).where(
                    TrialProblem.trial_id == trial_id, TrialProblem.source == "migration"
                )
            ).all()
        removed = Counter(record.split()[0] for record in problems)
        assert removed == {
            "decision": 2,
            "sim_event": 2,
            "request_status_change": 2,
            "interruption": 2,
            "probe": 1,
            "probe_event": 1,  # the second probe's "ready"; its "answer" moved to the first
        }
        assert f"probe {second_id}" in problems
        said = caplog.text
        assert "removed 2 decision row(s)" in said and "removed 1 probe row(s)" in said
        for row in [*_trial_rows(trial_id, seen), _probe(trial_id), _event(first_id, "ready")]:
            with pytest.raises(IntegrityError), database.session_scope() as session:
                session.add(row)
        with pytest.raises(DBAPIError), database.session_scope() as session:  # still append-only
            session.execute(text("UPDATE probe_event SET kind = 'timeout'"))
    finally:
        database.engine.dispose()


def _load(
    database: Database,
    trial_id: int,
    now: float,
    host_died: bool,
    flushed: threading.Event,
    go: threading.Event,
) -> None:
    with database.session_scope() as session:
        load_trial(session, session.get_one(Trial, trial_id), now, host_died=host_died)
        session.flush()
        flushed.set()
        go.wait(30)


def _lock_waits(database: Database) -> int:
    with database.engine.connect() as connection:
        return int(
            connection.scalar(
                text("SELECT count(*) FROM pg_stat_activity WHERE wait_event_type = 'Lock'")
            )
            or 0
        )


def _race(database: Database, trial_id: int, now: float, *, host_died: bool) -> None:
    """Two processes load the trial at `now` in two transactions: the second writes while
    the first has written and not committed (or waits, when a key it writes is taken)."""
    flushed = [threading.Event(), threading.Event()]
    go = threading.Event()
    loads = [
        threading.Thread(target=_load, args=(database, trial_id, now, host_died, done, go))
        for done in flushed
    ]
    loads[0].start()
    assert flushed[0].wait(60)
    loads[1].start()
    deadline = time.monotonic() + 30
    while not flushed[1].is_set() and _lock_waits(database) == 0:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    go.set()
    for load in loads:
        load.join(60)


def test_two_processes_loading_one_trial_at_once_store_each_row_once(database_url: str) -> None:
    """Two processes load one trial at once (a stalled host woke, or fencing failed): both
    read "nothing stored" and write the same events, decisions, statuses and, for a
    rebuild after its host died, interruption. Before the unique keys each was stored
    twice; now the second transaction's inserts wait for the first's commit and skip."""
    if not database_url.startswith("postgresql"):
        pytest.skip("two concurrent writers: PostgreSQL (SQLite writes one at a time)")
    clock = ManualClock(T0)
    database = Database(database_url, clock=clock)
    database.create_all()
    try:
        with database.session_scope() as session:
            _, trial = start_bot_trial(session, seed=2, duration_s=600.0, time_acceleration=4.0)
            trial_id = trial.id
        clock.now += 100.0  # 400 s of trial time to step to: events on the way
        _race(database, trial_id, clock.now, host_died=False)
        clock.now += 30.0  # both hosts died: a rebuild stops the clock for the outage
        _race(database, trial_id, clock.now, host_died=True)

        with database.session_scope() as session:
            counts = {
                model.__tablename__: Counter(
                    tuple(row)
                    for row in session.execute(
                        select(*(getattr(model, c) for c in key)).where(model.trial_id == trial_id)
                    )
                )
                for model, key in (
                    (SimEvent, ("kind", "sim_time", "text")),
                    (DecisionRow, ("collective", "decision_index")),
                    (RequestStatusChange, ("request_id", "status")),
                    (Interruption, ("last_seen_at",)),
                )
            }
        assert all(
            sum(counts[table].values()) > 0 for table in ("sim_event", "decision", "interruption")
        )
        twice = {table: [k for k, n in c.items() if n > 1] for table, c in counts.items()}
        assert twice == {table: [] for table in counts}
    finally:
        database.engine.dispose()
