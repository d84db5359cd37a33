"""Snapshots do not grow without bound: thinned as a trial ages, the newest always kept.

The database itself keeps the rule (issue 13's triggers, one exception): a
snapshot may be deleted only while a newer snapshot of the same trial exists;
an update is refused, and so is a deletion that would leave a trial without
its newest. The thinning keeps the newest two and one per power-of-two age
bucket. And a real server hosting a trial for an hour of trial time (60x, a
snapshot due every 5 trial seconds: 720; the bot trial's collectives make
their 12 decisions in its first minutes, then its clock runs on to the
deadline, which the snapshots' times record) keeps a bounded number, and
after kill -9 the restarted server rebuilds the trial from its newest
snapshot, to the state a replay of the command log reaches.
"""

from __future__ import annotations

import time

import pytest
from sqlalchemy import func, select, text
from sqlalchemy.exc import DBAPIError

from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.snapshots import KEEP_NEWEST, kept
from hcss.platform.live.trial_log import newest_snapshot
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.models import Interruption, Snapshot
from hcss.platform.serving.localserver import LocalServer
from hcss.simulation import Simulation
from tests.support.replays import replay_trial

ACCELERATION = 60.0  # trial seconds per wall second
HOUR_S = 3600.0


def _bound(steps: int) -> int:
    return KEEP_NEWEST + steps.bit_length() + 1


def test_thinning_keeps_a_number_that_grows_with_the_log_of_a_trials_age() -> None:
    held: list[tuple[int, int]] = []  # (id, step), newest first, as the table holds them
    most = 0
    for number in range(1, 720 * 5 + 1):  # five hours, a snapshot every 25 steps
        held.insert(0, (number, number * 25))
        keep = kept(held)
        held = [row for row in held if row[0] in keep]
        assert held[0][0] == number  # the newest is always kept
        most = max(most, len(held))
        assert len(held) <= _bound(number * 25)
    assert most <= 20
    ages = [held[0][1] - step for _, step in held]
    assert ages[:KEEP_NEWEST] == [0, 25]
    assert ages[-1] > held[0][1] / 4  # something old is kept too, thinned


def _delete(database: Database, where: str) -> None:
    with database.engine.begin() as connection:
        connection.execute(text(f"DELETE FROM snapshot WHERE {where}"))


def test_the_database_refuses_to_delete_a_trials_newest_snapshot(app, make_trial) -> None:
    trial = make_trial()
    database = app.extensions["hcss_db"]
    for second in (2, 4, 6, 8):
        trial.run_to(second)
        database.clock.now += 5.0  # past the snapshot interval
        trial.run_to(second + 0.5)
    with database.session_scope() as session:
        steps = session.execute(
            select(Snapshot.id, Snapshot.step).order_by(Snapshot.step.desc(), Snapshot.id.desc())
        ).all()
    assert len(steps) >= 2
    newest = steps[0].id
    with pytest.raises(DBAPIError, match="append-only"):
        _delete(database, f"id = {newest}")
    with pytest.raises(DBAPIError, match="append-only"):
        _delete(database, "1 = 1")  # all of them: the newest among them
    with pytest.raises(DBAPIError, match="append-only"), database.engine.begin() as connection:
        connection.execute(text(f"UPDATE snapshot SET step = 0 WHERE id = {steps[-1].id}"))
    _delete(database, f"id = {steps[-1].id}")  # an older one: superseded, so it may go
    with database.session_scope() as session:
        assert session.scalar(select(func.count()).select_from(Snapshot)) == len(steps) - 1


@pytest.mark.slow
def test_a_trial_hosted_for_an_hour_keeps_few_snapshots_and_rebuilds_after_kill_9(
    database_url: str, tmp_path
) -> None:
    upgrade_database(database_url)
    database = Database(database_url)
    # A snapshot every 5 trial seconds, as a study's default every 5 wall seconds.
    server = LocalServer(database_url, tmp_path / "instance", snapshot_interval_s=5 / ACCELERATION)
    try:
        server.start(timeout_s=120)
        deadline = time.monotonic() + 120
        while "simulation ready" not in server.log_path.read_text():  # then it steps in time
            assert time.monotonic() < deadline, "the simulation never got ready"
            time.sleep(0.2)
        with database.session_scope() as session:
            _, trial = start_bot_trial(
                session, seed=3, duration_s=2 * HOUR_S, time_acceleration=ACCELERATION
            )
            trial_id = trial.id
        started = time.monotonic()
        most, first = 0, None
        while time.monotonic() - started < HOUR_S / ACCELERATION:
            time.sleep(0.5)
            with database.session_scope() as session:
                count, low, last, newest = session.execute(
                    select(
                        func.count(),
                        func.min(Snapshot.id),
                        func.max(Snapshot.id),
                        func.max(Snapshot.step),
                    ).where(Snapshot.trial_id == trial_id)
                ).one()
            if count:
                first = low if first is None else min(first, low)
                most = max(most, count)
                assert count <= _bound(newest), (count, newest)
        assert first is not None
        written = last - first + 1  # ids of the one trial's snapshots: the newest is kept
        print(f"an hour at {ACCELERATION:.0f}x: {written} snapshots written, at most {most} kept")
        assert written >= 30  # it was snapshotting all along
        assert most <= 20
        server.kill()
        server.start(timeout_s=120)
        deadline = time.monotonic() + 60
        while True:
            with database.session_scope() as session:
                rebuilt = session.scalars(
                    select(Interruption).where(Interruption.trial_id == trial_id)
                ).first()
            if rebuilt is not None:
                break
            assert time.monotonic() < deadline, "the restarted server never rebuilt the trial"
            time.sleep(0.5)
        assert rebuilt.snapshot_step >= 0  # from a snapshot, not from the start
        with database.session_scope() as session:
            replayed = replay_trial(session, trial_id, rebuilt.resumed_step)
            assert rebuilt.state_digest == replayed.state_digest()
            snapshot = newest_snapshot(session, trial_id)
            assert snapshot is not None
            again = replay_trial(session, trial_id, snapshot.step)
            assert Simulation.restore(snapshot.blob).state_digest() == again.state_digest()
    finally:
        server.stop()
        database.engine.dispose()
