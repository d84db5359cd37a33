"""A trial's record stays one record: loaded once, rebuilt by identity, committed once.

Two apps on one database stand for two server processes (as in test_leases.py);
the clock is a `ManualClock`, so grace periods and leases pass at once.
"""

from __future__ import annotations

import re
import uuid
from collections.abc import Iterator
from contextlib import suppress

import pytest
from sqlalchemy import func, select
from sqlalchemy.exc import DBAPIError

from hcss.platform.bots.participant import ManualClock
from hcss.platform.live import door
from hcss.platform.live.commands import ProbeAnswer, ProbeReady, SubmitRequest
from hcss.platform.live.leases import UNCLAIMED_GRACE_S
from hcss.platform.live.runner import Runner
from hcss.platform.live.trial_writer import KeyedCommand
from hcss.platform.live.trials import latest_status, start_bot_trial
from hcss.platform.models import (
    Command,
    CommandOutcome,
    ConsoleAction,
    Interruption,
    ProbeEvent,
    SimEvent,
    TrialProblem,
)
from hcss.simulation import OperatorCommand
from tests.support.leases import leased_process


@pytest.fixture
def group(database_url: str) -> Iterator[tuple[Runner, Runner, ManualClock]]:
    clock = ManualClock(1_000_000.0)
    a = leased_process(database_url, "127.0.0.1:5001/a", clock)
    a.extensions["hcss_db"].create_all()
    b = leased_process(database_url, "127.0.0.1:5002/b", clock)
    yield a.extensions["hcss_runner"], b.extensions["hcss_runner"], clock
    for app in (a, b):
        app.extensions["hcss_db"].engine.dispose()


def _start(runner: Runner) -> int:
    with runner.database.session_scope() as session:
        _, trial = start_bot_trial(session, seed=2, duration_s=600.0, time_acceleration=4.0)
        return trial.id


def _hosted_for_20_s(runner: Runner, clock):
    """A new trial hosted by `runner`, ticked through 20 s of its clock: (its id, its live trial)."""
    trial_id = _start(runner)
    live = runner.host(trial_id)
    assert live is not None
    for _ in range(20):
        clock.now += 1.0
        runner.tick()
    return trial_id, live


def _events(runner: Runner, trial_id: int) -> list[tuple[str, float, str]]:
    with runner.database.session_scope() as session:
        rows = session.execute(
            select(SimEvent.kind, SimEvent.sim_time, SimEvent.text).where(
                SimEvent.trial_id == trial_id
            )
        )
        return [tuple(row) for row in rows]


def test_a_trial_claimed_after_the_grace_writes_the_events_of_its_load_once(group) -> None:
    """Nobody opened the trial within the grace: a runner takes it, steps it to the due step
    (events happen on the way) and goes on. Each event is one row, not one per write."""
    _a, b, clock = group
    trial_id = _start(b)
    clock.now += UNCLAIMED_GRACE_S + 5.0
    b.tick()  # the runner loads it: 35 s of wall time, 140 s of trial time to catch up
    assert trial_id in b.loaded_ids()
    for _ in range(3):
        clock.now += 0.5
        b.tick()
    events = _events(b, trial_id)
    assert any(kind == "discovery" for kind, _, _ in events), events
    twice = {event for event in events if events.count(event) > 1}
    assert twice == set()


def _command(runner: Runner, trial_id: int) -> OperatorCommand:
    live = runner.host(trial_id)
    assert live is not None
    target = int(live.display().target_ids[0])
    return OperatorCommand("investigate", 0, target)


def test_the_rebuild_replays_the_commands_after_the_snapshots_last_one_by_identity(
    group,
) -> None:
    """The log holds a command the live trial never applied (its commit's answer was lost,
    the trial rolled back): the snapshots after it name the last command they hold, and a
    rebuild replays what follows that command, not the log's tail by count."""
    a, b, clock = group
    trial_id, live = _hosted_for_20_s(a, clock)
    command = _command(a, trial_id)
    _submit(a, live, command)
    with a.database.session_scope() as session:  # a command in the log, not in memory
        stray = session.scalars(select(Command).where(Command.trial_id == trial_id)).one()
        session.add(
            Command(
                trial_id=trial_id,
                kind=stray.kind,
                collective=1,
                target=stray.target,
                step_applied=live.sim.step_count,
                sim_time=float(live.sim.time),
                selections=[],
            )
        )
    clock.now += 1.0
    a.tick()
    _submit(a, live, OperatorCommand("investigate", 2, command.target))
    for _ in range(2):
        clock.now += 1.0
        a.tick()  # a snapshot holding the two commands applied
    clock.now += 7.0  # A dies; B takes the trial over
    rebuilt = b.host(trial_id)
    with b.database.session_scope() as session:
        problems = session.scalars(select(TrialProblem.problem)).all()
        status = latest_status(session, trial_id)
        interruptions = session.scalar(select(func.count()).select_from(Interruption))
    assert problems == [] and status == "running", problems
    assert rebuilt is not None and interruptions == 1
    assert rebuilt.sim.state_digest() != ""


def _answer_lost_after_commit(
    database, monkeypatch, times: int = 1, every: int = 1, skip: int = 0
) -> None:
    """Of the next commits after `skip`, every `every`-th (`times` in all) reaches the
    database and commits, and its answer never arrives (the connection drops after the
    server sent it): the driver raises as for a lost line. A command through the door
    commits its key's lookup first (`skip=1` passes it)."""
    dialect = database.engine.dialect
    commit = dialect.do_commit
    left, seen = [times], [-skip]

    def lost(dbapi_connection) -> None:
        commit(dbapi_connection)
        seen[0] += 1
        if left[0] > 0 and seen[0] > 0 and seen[0] % every == 0:
            left[0] -= 1
            raise dialect.loaded_dbapi.OperationalError("server closed the connection")

    monkeypatch.setattr(dialect, "do_commit", lost)


def test_a_command_whose_commit_answer_is_lost_stays_applied_as_logged(group, monkeypatch) -> None:
    """The command's transaction committed but its answer was lost: the service asks the
    database, finds the command logged and keeps it applied in memory, so the trial in
    memory and its log agree (before, it was rolled back while its row stayed logged)."""
    a, b, clock = group
    trial_id, live = _hosted_for_20_s(a, clock)
    command = _command(a, trial_id)
    _answer_lost_after_commit(a.database, monkeypatch, skip=1)
    answer = _submit(a, live, command)
    with a.database.session_scope() as session:
        logged = session.scalars(select(Command.id).where(Command.trial_id == trial_id)).all()
        outcomes = session.scalar(select(func.count()).select_from(CommandOutcome))
    assert logged == [answer["command_id"]] and outcomes == 1
    assert live.last_command_id == logged[0] and live.sim.commands_applied == 1
    for _ in range(2):
        clock.now += 1.0
        a.tick()
    clock.now += 7.0  # A dies; B's rebuild agrees with what A held
    rebuilt = b.host(trial_id)
    assert rebuilt is not None and rebuilt.sim.commands_applied == 1


def test_runner_steps_whose_commit_answers_are_lost_store_every_row_once(
    group, monkeypatch
) -> None:
    """The runner's units of work commit but their answers are lost until a decision is
    made: each is taken for failed and written again by the next, which must find its
    rows. Every event, decision, request status, probe and outage is stored once."""
    from hcss.platform.models import (
        DecisionRow,
        Interruption,
        Probe,
        ProbeEvent,
        RequestStatusChange,
    )

    a, _b, clock = group
    trial_id = _start(a)
    live = a.host(trial_id)
    assert live is not None
    for _ in range(10):
        clock.now += 1.0
        a.tick()
    _submit(a, live, _command(a, trial_id))
    _answer_lost_after_commit(a.database, monkeypatch, times=10_000, every=2)
    for _ in range(600):  # every other answer lost until the first decisions are made
        clock.now += 1.0
        with suppress(DBAPIError):  # a lost answer outside the trial's units: the thread
            a.tick()  # logs it and goes on
        if len(live.sim.decisions) >= 2:
            break
    assert len(live.sim.decisions) >= 2
    monkeypatch.undo()
    clock.now += 1.0
    a.tick()
    assert live.trial_clock.database_away_since is None and live.log.decisions == len(
        live.sim.decisions
    )
    with a.database.session_scope() as session:

        def rows(*columns):
            return [tuple(r) for r in session.execute(select(*columns))]

        decisions = rows(DecisionRow.collective, DecisionRow.decision_index)
        events = rows(SimEvent.kind, SimEvent.sim_time, SimEvent.text)
        statuses = rows(RequestStatusChange.request_id, RequestStatusChange.status)
        probes = rows(Probe.probe_index)
        probe_events = rows(ProbeEvent.probe_id, ProbeEvent.kind)
        outages = rows(Interruption.trial_id, Interruption.last_seen_at)
    assert len(decisions) == len(live.sim.decisions)
    assert outages  # the lost answers were taken for outages, each recorded
    for stored in (decisions, events, statuses, probes, probe_events, outages):
        assert len(stored) == len(set(stored)), stored


def test_two_concurrent_pauses_write_one_console_action(group) -> None:
    """Two experimenters pause one trial at once; both consoles saw it running. The state is
    checked under the trial's lock: the first pauses it, the second finds it paused and
    writes nothing, so the session's history holds one pause."""
    import threading

    from hcss.platform.live.service import LiveTrials
    from hcss.platform.models import ConsoleAction, Trial

    a, _b, clock = group
    trial_id = _start(a)
    live = a.host(trial_id)
    assert live is not None
    with a.database.session_scope() as session:
        participant_id = session.get(Trial, trial_id).participant_id
    clock.now += 1.0
    start = threading.Barrier(2)

    def pause() -> None:
        start.wait()
        LiveTrials(a.database, a).control(
            trial_id,
            "pause",
            participant_id=participant_id,
            experimenter_id=None,
        )

    threads = [threading.Thread(target=pause) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=30)
    with a.database.session_scope() as session:
        pauses = session.scalar(
            select(func.count()).select_from(ConsoleAction).where(ConsoleAction.action == "pause")
        )
    assert pauses == 1 and live.trial_clock.paused_since is not None


def test_a_command_nobody_can_say_was_committed_is_settled_by_a_rebuild(group, monkeypatch) -> None:
    """The command's commit answer is lost and the database cannot be asked at once (the
    line is still down): the trial in memory is not guessed at. The runner drops it and
    the next request rebuilds it from the log, which holds the command."""
    a, _b, clock = group
    trial_id, live = _hosted_for_20_s(a, clock)
    command = _command(a, trial_id)
    _answer_lost_after_commit(a.database, monkeypatch, skip=1)
    dialect = a.database.engine.dialect
    execute = dialect.do_execute
    asked = [0]

    def still_down(cursor, statement, parameters, context=None):
        # the question whether the command's row landed (not its key's lookup, before)
        if statement.lstrip().upper().startswith("SELECT") and re.search(
            r"FROM command\b", statement
        ):
            asked[0] += 1
            if asked[0] == 1:  # the question right after the lost answer
                raise dialect.loaded_dbapi.OperationalError("no route to host")
        return execute(cursor, statement, parameters, context)

    monkeypatch.setattr(dialect, "do_execute", still_down)
    with pytest.raises(DBAPIError):
        _submit(a, live, command)
    monkeypatch.undo()
    clock.now += 1.0
    a.tick()
    rebuilt = a.host(trial_id)
    assert rebuilt is not None and rebuilt is not live
    with a.database.session_scope() as session:
        logged = session.scalars(select(Command.id).where(Command.trial_id == trial_id)).all()
    assert len(logged) == 1
    assert rebuilt.sim.commands_applied == 1 and rebuilt.last_command_id == logged[0]


def _answer_lost_after_writing(database, model, monkeypatch) -> None:
    """The next commit of a transaction that inserted a `model` row reaches the database and
    commits, and its answer never arrives: the driver raises as for a lost line."""
    from sqlalchemy import event

    dialect = database.engine.dialect
    commit = dialect.do_commit
    insert = f"INSERT INTO {model.__tablename__} "
    wrote: set[int] = set()
    left = [1]

    def executed(_conn, cursor, statement, *_args) -> None:
        if statement.lstrip().upper().startswith(insert.upper()):
            wrote.add(id(cursor.connection))

    def lost(dbapi_connection) -> None:
        commit(dbapi_connection)
        raw = id(getattr(dbapi_connection, "dbapi_connection", dbapi_connection))  # a pool's proxy
        if raw in wrote and left[0] > 0:
            left[0] -= 1
            raise dialect.loaded_dbapi.OperationalError("server closed the connection")
        wrote.discard(raw)

    event.listen(database.engine, "before_cursor_execute", executed)  # the fixture's engine
    monkeypatch.setattr(dialect, "do_commit", lost)


def _with_a_probe_open(runner: Runner, clock) -> tuple[int, object]:
    """A new trial hosted by `runner`, ticked until its first probe is on screen."""
    trial_id = _start(runner)
    live = runner.host(trial_id)
    assert live is not None
    for _ in range(400):
        clock.now += 1.0
        runner.tick()
        if live.probes.current is not None:
            return trial_id, live
    raise AssertionError("no probe within 400 s")


def _submit(runner: Runner, live, command: OperatorCommand) -> dict:
    """The participant's request through the live service's door, with a fresh key."""
    request = SubmitRequest(live.trial_id, command.to_json())
    return door.carry_out(runner.database, runner, request, _fresh(live.trial_id)).body


def _fresh(trial_id: int) -> KeyedCommand:
    """A fresh key, as the page sends with every command."""
    key = uuid.uuid4().hex
    return KeyedCommand(trial_id=trial_id, key=key, endpoint="test", fingerprint=key)


def _key(trial_id: int, key: str, endpoint: str) -> KeyedCommand:
    return KeyedCommand(trial_id=trial_id, key=key, endpoint=endpoint, fingerprint=key)


def test_a_ready_press_whose_commit_answer_is_lost_shows_the_question(group, monkeypatch) -> None:
    """The Ready press committed (its event and its key are stored) but its answer was lost.
    The trial in memory must say what the log says: the question is shown, so the answer
    that follows is taken (before, the probe stayed "not ready" in memory while the log
    held the press, and every answer was refused 409 until the probe timed out)."""
    a, _b, clock = group
    trial_id, live = _with_a_probe_open(a, clock)
    probe_id = live.probes.current.id
    ready = ProbeReady(trial_id, probe_id)
    _answer_lost_after_writing(a.database, ProbeEvent, monkeypatch)
    with suppress(DBAPIError):
        door.carry_out(a.database, a, ready, _key(trial_id, "ready-0001", "ready"))
    monkeypatch.undo()
    again = door.carry_out(a.database, a, ready, _key(trial_id, "ready-0001", "ready"))
    assert again.status == 200, again
    clock.now += 0.5
    a.tick()
    host = a.host(trial_id)
    assert host is not None and host.probes.current is not None
    choice = host.probes.current.choices[0]
    answered = door.carry_out(
        a.database, a, ProbeAnswer(trial_id, probe_id, {"answer": choice}), _fresh(trial_id)
    )
    assert answered.status == 200, answered


def test_a_probe_answer_whose_commit_answer_is_lost_is_not_also_timed_out(
    group, monkeypatch
) -> None:
    """The answer committed, its answer lost: the probe leaves the screen as the log says,
    and no time-out is written for an answered probe (before, the probe stayed open in
    memory and its time-out was stored beside the answer)."""
    a, _b, clock = group
    trial_id, live = _with_a_probe_open(a, clock)
    probe_id = live.probes.current.id
    choice = live.probes.current.choices[0]
    door.carry_out(a.database, a, ProbeReady(trial_id, probe_id), _fresh(trial_id))
    answer = ProbeAnswer(trial_id, probe_id, {"answer": choice})
    _answer_lost_after_writing(a.database, ProbeEvent, monkeypatch)
    with suppress(DBAPIError):
        door.carry_out(a.database, a, answer, _key(trial_id, "answer-0001", "answer"))
    monkeypatch.undo()
    for _ in range(40):  # past the probe's time-out
        clock.now += 1.0
        a.tick()
    with a.database.session_scope() as session:
        kinds = session.scalars(
            select(ProbeEvent.kind).where(ProbeEvent.probe_id == probe_id).order_by(ProbeEvent.id)
        ).all()
    assert "answer" in kinds and "timeout" not in kinds, kinds


def test_a_pause_whose_commit_answer_is_lost_holds_the_trial(group, monkeypatch) -> None:
    """The console's pause committed, its answer lost: the action log says paused, so the
    trial must not run on (before, the trial in memory ran on while the log held the pause;
    the experimenter's retry then wrote a second pause, and a rebuild stopped its clock at
    the first)."""
    from hcss.platform.live.service import LiveTrials
    from hcss.platform.models import Trial

    a, _b, clock = group
    trial_id, _live = _hosted_for_20_s(a, clock)
    with a.database.session_scope() as session:
        participant_id = session.get(Trial, trial_id).participant_id

    def pause() -> None:
        LiveTrials(a.database, a).control(
            trial_id, "pause", participant_id=participant_id, experimenter_id=None
        )

    _answer_lost_after_writing(a.database, ConsoleAction, monkeypatch)
    with suppress(DBAPIError):
        pause()
    monkeypatch.undo()
    clock.now += 1.0
    a.tick()
    pause()  # the experimenter's retry
    host = a.host(trial_id)
    with a.database.session_scope() as session:
        pauses = session.scalar(
            select(func.count()).select_from(ConsoleAction).where(ConsoleAction.action == "pause")
        )
    assert pauses == 1
    assert host is not None and host.trial_clock.paused_since is not None


def test_a_command_refused_by_a_database_away_leaves_the_trial_hosted(group, monkeypatch) -> None:
    """The database refuses the command's first statement (it is away): nothing can have been
    committed, so nothing is asked and the trial in memory stays hosted, its probe as it was;
    only a failed commit, which may have landed, is settled by asking."""
    a, _b, clock = group
    trial_id, live = _with_a_probe_open(a, clock)
    probe_id = live.probes.current.id
    dialect = a.database.engine.dialect

    def away(*_args, **_kwargs):
        raise dialect.loaded_dbapi.OperationalError("could not connect to server")

    monkeypatch.setattr(dialect, "do_execute", away)
    with pytest.raises(DBAPIError):
        door.carry_out(a.database, a, ProbeReady(trial_id, probe_id), _fresh(trial_id))
    monkeypatch.undo()
    assert not live.moved and a.loaded(trial_id) is live
    assert live.probes.current is not None and not live.probes.current.ready
    again = door.carry_out(a.database, a, ProbeReady(trial_id, probe_id), _fresh(trial_id))
    assert again.status == 200 and live.probes.current.ready
