"""Trial ownership by lease: one host per trial, takeover when the host stops renewing.

Two apps on one database stand for two server processes (each its own
engine, connections and runner, named as `hcss serve --processes` names
them); a process "dies" here by no longer ticking, so its leases run out.
The real processes, kill -9 and nginx are in test_failover.py.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest
from sqlalchemy import func, select
from sqlalchemy.exc import DBAPIError

from hcss.platform.bots.participant import ManualClock
from hcss.platform.db import Database
from hcss.platform.live.leases import UNCLAIMED_GRACE_S, HostedElsewhere, LeaseLost, Leases
from hcss.platform.live.runner import Runner
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.models import (
    Command,
    CommandKey,
    DecisionRow,
    Interruption,
    Observation,
    SimEvent,
    Snapshot,
    TrialLease,
)
from tests.support.leases import LEASE_S, leased_process, start_trial_on


@pytest.fixture
def pair(database_url: str) -> Iterator[tuple[Runner, Runner, ManualClock]]:
    clock = ManualClock(1_000_000.0)
    a = leased_process(database_url, "127.0.0.1:5001", clock)
    a.extensions["hcss_db"].create_all()
    b = leased_process(database_url, "127.0.0.1:5002", clock)
    yield a.extensions["hcss_runner"], b.extensions["hcss_runner"], clock
    for app in (a, b):
        app.extensions["hcss_db"].engine.dispose()


def test_a_trial_is_hosted_by_one_process_and_taken_over_when_its_lease_runs_out(pair) -> None:
    a, b, clock = pair
    trial_id = start_trial_on(a)
    live = a.host(trial_id)  # the participant's first request reaches A: A claims it
    assert live is not None
    with pytest.raises(HostedElsewhere):
        b.host(trial_id)
    for _ in range(10):  # A keeps it on time and renews its lease
        clock.now += 1.0
        a.tick()
        b.tick()
    assert trial_id in a.loaded_ids() and trial_id not in b.loaded_ids()
    assert not b.hosts(trial_id)
    step_before = live.sim.step_count
    assert step_before > 0

    clock.now += LEASE_S + 0.5  # A stops (it died): its lease runs out
    taken = b.host(trial_id)
    assert taken is not None and taken is not live
    assert taken.sim.step_count >= step_before - 10  # from the newest snapshot, not from 0
    with b.database.session_scope() as session:
        assert session.scalar(select(TrialLease.owner)) == "127.0.0.1:5002"
        interruptions = session.scalars(select(Interruption)).all()
    assert len(interruptions) == 1 and interruptions[0].outage_s > LEASE_S

    a.tick()  # A comes back: its renewal finds the lease gone, so it stops hosting
    assert trial_id not in a.loaded_ids() and live.moved
    assert live.fence is not None and a.leases is not None
    assert a.leases.renew({trial_id: live.fence.epoch}, clock.now) == set()
    with pytest.raises(HostedElsewhere):
        a.host(trial_id)


def test_a_runner_takes_over_only_trials_nobody_hosts(pair) -> None:
    a, b, clock = pair
    hosted = start_trial_on(a)
    a.host(hosted)
    fresh = start_trial_on(a)  # started by a page on A, not yet opened: no lease yet
    b.tick()
    assert b.loaded_ids() == set()  # neither the hosted nor the just-started one
    clock.now += LEASE_S + 0.5
    b.tick()  # A is silent past a lease: B's runner hosts the one A hosted
    assert b.loaded_ids() == {hosted}
    clock.now += UNCLAIMED_GRACE_S
    b.tick()  # and the one nobody opened, once its starter had time to claim it
    assert b.loaded_ids() == {hosted, fresh}


def test_only_the_host_finishes_an_overdue_trial(pair) -> None:
    a, b, clock = pair
    trial_id = start_trial_on(a, duration_s=18.0)
    live = a.host(trial_id)
    assert live is not None
    for _ in range(3):  # A renews its lease, then stalls: the trial is overdue
        clock.now += 5.0
        a.tick()
    clock.now += 3.5  # 18.5 s: past the deadline, within A's lease
    b.finish_overdue(trial_id)  # the study page on B: not B's to end
    assert trial_id not in b.loaded_ids() and not live.ended
    a.finish_overdue(trial_id)
    assert live.ended
    with a.database.session_scope() as session:
        assert session.scalar(select(func.count()).select_from(TrialLease)) == 0  # released


def test_two_takeovers_racing_for_one_expired_lease_exactly_one_wins(database_url: str) -> None:
    """Each round, two processes claim the same expired lease at once on their own connections."""
    clock = ManualClock(1_000_000.0)
    setup = Database(database_url, clock=clock)
    setup.create_all()
    contenders = [Leases(Database(database_url, clock=clock), f"p{i}") for i in range(2)]
    with setup.session_scope() as session:
        _, trial = start_bot_trial(session, seed=1, duration_s=60.0)
        trial_id = trial.id
    assert Leases(setup, "dead").claim(trial_id, clock.now)
    rounds = 30
    winners: list[list[str]] = []
    for round_ in range(rounds):
        now = clock.now + (round_ + 1) * 2 * LEASE_S  # every earlier lease has run out
        start = threading.Barrier(2)
        won: list[str] = []

        def claim(leases: Leases, now: float = now, start=start, won=won) -> None:
            start.wait()
            if leases.claim(trial_id, now):
                won.append(leases.owner)

        threads = [threading.Thread(target=claim, args=(c,)) for c in contenders]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(timeout=30)
        winners.append(won)
    assert all(len(won) == 1 for won in winners), winners
    for leases in contenders:
        leases.database.engine.dispose()
    setup.engine.dispose()


def test_a_command_caught_by_a_lost_lease_is_held_back_with_held_by_and_retry_after(
    database_url: str,
) -> None:
    """A's renewal finds the lease gone while a click waits for the trial's lock: A records
    nothing and holds the click back (503), saying why (`held_by`, so the page shows "The
    trial is moving to another server") and when to retry, and B carries it out then.

    The click goes through the live service's one door: it meets the moved trial under its
    lock (error "moved")."""
    from tests.support.trials import csrf_token_of

    clock = ManualClock(1_000_000.0)
    a = leased_process(database_url, "127.0.0.1:5001", clock)
    a.extensions["hcss_db"].create_all()
    b = leased_process(database_url, "127.0.0.1:5002", clock)
    runner_a, runner_b = a.extensions["hcss_runner"], b.extensions["hcss_runner"]
    try:
        with runner_a.database.session_scope() as session:
            participant, trial = start_bot_trial(session, seed=2, duration_s=600.0)
            token, trial_id = participant.token, trial.id
        live = runner_a.host(trial_id)
        assert live is not None
        client = a.test_client()
        csrf = csrf_token_of(client.get(f"/live/{token}").get_data(as_text=True))
        headers = {"X-CSRFToken": csrf, "Idempotency-Key": "click-0001"}
        answers = []

        def click() -> None:
            answers.append(
                client.post(
                    f"/api/live/{token}/trials/{trial_id}/observations",
                    json={"kind": "collective", "collective": 0, "button": "left"},
                    headers=headers,
                )
            )

        with live.lock:  # A is busy with the trial (a tick) when the click arrives
            clicking = threading.Thread(target=click)
            clicking.start()
            clicking.join(timeout=1.0)  # it found the trial and waits for the lock
            clock.now += LEASE_S + 0.5  # meanwhile A stalled past its lease
            assert runner_b.host(trial_id) is not None  # B takes the trial over
            runner_a.tick()  # A's renewal finds the lease gone: the trial moved
        clicking.join(timeout=30)
        (answer,) = answers
        assert answer.status_code == 503 and answer.get_json()["error"] == "moved", answer.json
        assert answer.get_json()["held_by"] == "server"
        assert int(answer.headers["Retry-After"]) > 0
        with runner_a.database.session_scope() as session:
            assert session.scalar(select(func.count()).select_from(Observation)) == 0
    finally:
        for app in (a, b):
            app.extensions["hcss_db"].engine.dispose()


def _rows_written(runner: Runner, trial_id: int) -> dict[str, int]:
    """How many rows of each kind the trial has (every table a trial's host writes)."""
    counts = {}
    with runner.database.session_scope() as session:
        for table in (SimEvent, DecisionRow, Snapshot, Observation, Command, Interruption):
            counts[table.__tablename__] = session.scalar(
                select(func.count()).select_from(table).where(table.trial_id == trial_id)
            )
    return counts


def test_a_host_that_stalled_past_its_lease_writes_nothing_when_it_wakes(database_url) -> None:
    """SIGSTOP in one process: A stops longer than a lease, B takes the trial over, then A
    wakes with a participant's click and its own runner step in hand before any renewal
    of its has answered. The click is held back (503, retried by the page) and nothing A
    holds is written: only B, the lease's holder, writes for the trial."""
    from tests.support.trials import csrf_token_of

    clock = ManualClock(1_000_000.0)
    a = leased_process(database_url, "127.0.0.1:5001", clock)
    a.extensions["hcss_db"].create_all()
    b = leased_process(database_url, "127.0.0.1:5002", clock)
    runner_a, runner_b = a.extensions["hcss_runner"], b.extensions["hcss_runner"]
    try:
        with runner_a.database.session_scope() as session:
            participant, trial = start_bot_trial(session, seed=2, duration_s=600.0)
            token, trial_id = participant.token, trial.id
        live = runner_a.host(trial_id)
        assert live is not None
        client = a.test_client()
        csrf = csrf_token_of(client.get(f"/live/{token}").get_data(as_text=True))
        for _ in range(4):
            clock.now += 1.0
            runner_a.tick()
        clock.now += LEASE_S + 1.0  # A is stopped; its lease runs out
        assert runner_b.host(trial_id) is not None  # B takes the trial over
        written = _rows_written(runner_b, trial_id)

        clock.now += 2.0  # A wakes: a click waited in its socket, its runner steps on
        answer = client.post(
            f"/api/live/{token}/trials/{trial_id}/observations",
            json={"kind": "collective", "collective": 0, "button": "left"},
            headers={"X-CSRFToken": csrf, "Idempotency-Key": "click-after-stall"},
        )
        runner_a.advance(live, clock.now)
        assert answer.status_code == 503, answer.get_json()
        assert int(answer.headers["Retry-After"]) > 0
        assert _rows_written(runner_b, trial_id) == written
        with runner_b.database.session_scope() as session:
            assert session.scalar(select(func.count()).select_from(CommandKey)) == 0
    finally:
        for app in (a, b):
            app.extensions["hcss_db"].engine.dispose()


def test_a_holder_stops_writing_on_its_own_deadline_until_a_renewal_answers(pair) -> None:
    """No renewal answered for a lease less its margin (a partition): the holder stops its
    trial by its own clock, without asking the database, and goes on once one answers."""
    a, _b, clock = pair
    trial_id = start_trial_on(a)
    live = a.host(trial_id)
    assert live is not None and live.fence is not None
    clock.now += 1.0
    a.advance(live, clock.now)
    written = _rows_written(a, trial_id)
    step = live.sim.step_count

    clock.now += LEASE_S - 1.5  # the lease is still A's in the database, not by A's own clock
    assert not live.fence.holds()
    a.advance(live, clock.now)
    assert live.sim.step_count == step and live.trial_clock.database_away_since is not None
    assert _rows_written(a, trial_id) == written

    a.tick()  # a renewal answers: the lease was A's all along, and the trial goes on
    clock.now += 1.0
    a.tick()
    assert live.fence.holds() and live.trial_clock.database_away_since is None
    assert live.sim.step_count > step
    assert _rows_written(a, trial_id)["sim_event"] >= written["sim_event"]


def test_every_claim_takes_a_new_epoch_and_an_old_one_proves_nothing(database_url) -> None:
    """A claim of one's own lease raises the epoch too: a transaction fenced with the
    epoch the trial was held under before is refused, so a holder that lost the lease and
    claimed it back cannot write with what it held in between."""
    clock = ManualClock(1_000_000.0)
    database = Database(database_url, clock=clock)
    database.create_all()
    try:
        with database.session_scope() as session:
            _, trial = start_bot_trial(session, seed=2, duration_s=600.0)
        leases = Leases(database, "p1")
        first = leases.claim(trial.id, clock.now)
        second = leases.claim(trial.id, clock.now)
        assert first is not None and second == first + 1
        with database.session_scope() as session:
            leases.prove(session, trial.id, second, clock.now)
        with pytest.raises(LeaseLost), database.session_scope() as session:
            leases.prove(session, trial.id, first, clock.now)
        clock.now += LEASE_S + 0.1
        with pytest.raises(LeaseLost), database.session_scope() as session:
            leases.prove(session, trial.id, second, clock.now)
    finally:
        database.engine.dispose()


def test_a_process_asked_for_the_trial_of_a_quiet_holder_waits_its_lease_out(
    database_url: str,
) -> None:
    """A's lease is not renewed (A is stopped or cut off). While A renews on time, B asked
    for the trial answers at once that A hosts it; once A has missed two renewals, B asked
    for it (the participant's stream, sent on by the proxy) waits out A's last seconds and
    hosts it, instead of a 503 that sends the page back through the silent A. On the
    database's clock, as in a server."""
    import time

    apps = [leased_process(database_url, name, ManualClock(0.0)) for name in ("a:1", "b:1")]
    apps[0].extensions["hcss_db"].create_all()
    a, b = (app.extensions["hcss_runner"] for app in apps)
    try:
        for runner in (a, b):
            runner.clock = time.time
        trial_id = start_trial_on(a)
        # A claims inside host(), somewhere between these two times (its rebuild can take a
        # second or more on a loaded machine; taking the time after it only failed once there).
        before_claim = time.monotonic()
        assert a.host(trial_id) is not None
        claimed = time.monotonic()
        asked = time.monotonic()
        with pytest.raises(HostedElsewhere):
            b.host(trial_id)  # A renews on time as far as B can tell
        assert time.monotonic() - asked < 1.0, "B must not wait for a holder that renews"

        time.sleep(max(0.0, claimed + 2 * LEASE_S / 3 + 0.2 - time.monotonic()))
        asked = time.monotonic()
        taken = b.host(trial_id)  # A has missed two renewals: B waits its lease out
        waited = time.monotonic() - asked
        assert taken is not None
        assert before_claim + LEASE_S - 0.5 < time.monotonic() < claimed + LEASE_S + 1.5
        assert waited < LEASE_S / 3 + 0.5
        with b.database.session_scope() as session:
            assert session.scalar(select(TrialLease.owner)) == "b:1"
    finally:
        for app in apps:
            app.extensions["hcss_db"].engine.dispose()


def test_a_holder_stopped_inside_its_transaction_does_not_keep_the_lease_row_locked(
    database_url: str,
) -> None:
    """SIGSTOP (or a cut line) in the middle of a fenced unit of work: the holder proved its
    lease, so PostgreSQL keeps the lease row locked for it, and then it went silent. The
    database ends the silent transaction, so once the lease has run out another process's
    claim takes the row at once; it used to wait on the lock until its statement timeout
    (15 s) and fail, and the trial's participants waited as long."""
    import time

    if not database_url.startswith("postgresql"):
        pytest.skip("a row lock held by another session is PostgreSQL's (SQLite locks the file)")
    stopped, other = Database(database_url), Database(database_url)
    stopped.create_all()
    try:
        with stopped.session_scope() as session:
            _, trial = start_bot_trial(session, seed=2, duration_s=600.0)
        holder = Leases(stopped, "a:1/stopped")
        epoch = holder.claim(trial.id, time.time())
        assert epoch is not None
        with stopped.sessions() as silent:
            holder.prove(silent, trial.id, epoch, time.time())  # the row is locked; A stops
            time.sleep(LEASE_S + 0.3)

            asked = time.monotonic()
            taken = Leases(other, "b:1/running").claim(trial.id, time.time())
            waited = time.monotonic() - asked
            with pytest.raises(DBAPIError):  # A wakes: what it held is not written
                silent.commit()
        assert taken == epoch + 1
        assert waited < 1.0
    finally:
        for database in (stopped, other):
            database.engine.dispose()
