"""A server that dies mid-trial: the next one rebuilds the trial exactly and records the gap."""

from __future__ import annotations

import pytest
from sqlalchemy import select

from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.models import CommandOutcome, Interruption, Snapshot
from tests.support.replays import replay_trial


def test_rebuild_after_a_crash_equals_an_uninterrupted_run(app, make_trial, database_url) -> None:
    """The outage stops the trial clock (hcss.platform.live.outages): the rebuilt trial
    resumes at the step the dead server reached, exactly as that server had it."""
    trial = make_trial(seed=5)
    trial.run_to(60)
    view = trial.state()["view"]
    targets = [t["id"] for t in view["targets"] if 0 in t["in_range_of"]]
    trial.post("/requests", {"kind": "investigate", "collective": 0, "target": targets[0]})
    trial.run_to(97)
    # Commands after the last snapshot are only in the command log.
    trial.post("/requests", {"kind": "investigate", "collective": 0, "target": targets[-1]})
    trial.post("/requests", {"kind": "decide", "collective": 1, "target": targets[0]})
    crashed = trial.live()
    with app.extensions["hcss_db"].session_scope() as session:
        last_snapshot = session.scalars(select(Snapshot).order_by(Snapshot.id.desc())).first()
    assert last_snapshot.step < 97 or last_snapshot.last_command_id < 3

    # The process dies: no end, no final snapshot. A new server starts on the same database.
    restarted = create_app(
        {"DATABASE_URL": database_url, "SECRET_KEY": "test-secret", "LIVE_RUNNER": False}
    )
    restarted.extensions["hcss_runner"].clock = ManualClock(trial.started_epoch + 150)
    try:
        runner = restarted.extensions["hcss_runner"]
        rebuilt = runner.host(trial.trial_id)
        reached = crashed.sim.step_count  # 97: the dead server's last rows are at step 97
        assert rebuilt is not crashed and rebuilt.sim.step_count == reached
        assert rebuilt.sim.state_digest() == crashed.sim.state_digest()
        with restarted.extensions["hcss_db"].session_scope() as session:
            (interruption,) = session.scalars(select(Interruption)).all()
            assert interruption.resumed_step == reached
            assert interruption.outage_s == pytest.approx(150 - reached)  # dt 1 s, real time
            assert interruption.snapshot_step == last_snapshot.step
            assert interruption.replayed_commands >= 1
            assert interruption.state_digest == rebuilt.sim.state_digest()
            independent = replay_trial(session, trial.trial_id, reached)
            assert independent.state_digest() == interruption.state_digest
            assert len(session.scalars(select(CommandOutcome)).all()) == 3
        # The clock runs again from there: ten wall seconds later, ten steps on.
        runner.clock.now += 10
        runner.tick()
        assert rebuilt.sim.step_count == reached + 10
        # The page's history survives: earlier messages are still there, in order.
        before = [m["text"] for m in crashed.messages]
        assert [m["text"] for m in rebuilt.messages][: len(before)] == before
    finally:
        restarted.extensions["hcss_db"].engine.dispose()


def test_a_rebuilt_trial_shows_the_system_messages_in_the_live_order(
    app, make_trial, database_url
) -> None:
    """Messages of one step: the step's events first (the runner records them when it
    reaches the step), then the commands applied at that step, as the live page had them.

    Before the fix the rebuild ordered same-time messages by row id, comparing
    `SimEvent` ids with `Command` ids, so a command sent right after a discovery
    came back above it.
    """
    trial = make_trial(seed=5)
    live = trial.live()
    shared = 0  # steps at which a command landed after that step's own events
    for second in range(1, 120):
        trial.run_to(second)
        if live.messages and live.messages[-1]["time"] == second:  # the step had events
            targets = [t["id"] for t in trial.state()["view"]["targets"]]
            trial.post("/requests", {"kind": "investigate", "collective": 0, "target": targets[0]})
            trial.post("/requests", {"kind": "cancel", "request_id": 1})  # not an abandon
            shared += 1
        if shared == 3:
            break
    assert shared == 3
    kinds = [m["kind"] for m in live.messages]
    assert "accepted" in kinds and "refusal" in kinds and "discovery" in kinds
    before = [(m["time"], m["kind"], m["text"]) for m in live.messages]

    # The process dies; a new server rebuilds the trial at the very instant it died.
    restarted = create_app(
        {"DATABASE_URL": database_url, "SECRET_KEY": "test-secret", "LIVE_RUNNER": False}
    )
    restarted.extensions["hcss_runner"].clock = ManualClock(trial.runner.clock())
    try:
        rebuilt = restarted.extensions["hcss_runner"].host(trial.trial_id)
        assert rebuilt is not live and rebuilt.sim.step_count == live.sim.step_count
        assert [(m["time"], m["kind"], m["text"]) for m in rebuilt.messages] == before
        assert [m["seq"] for m in rebuilt.messages] == [m["seq"] for m in live.messages]
    finally:
        restarted.extensions["hcss_db"].engine.dispose()
