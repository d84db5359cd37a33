"""The platform records what the simulation answered, never its own reading of the view.

The command's context (support, decision index), the intervention flag and
every request status come from the simulation's typed outcome and its status
queue; a command that cannot be written leaves the trial as it was.
"""

from __future__ import annotations

import uuid

import pytest
from sqlalchemy import select
from sqlalchemy.exc import IntegrityError

from hcss.platform.live import door
from hcss.platform.live.commands import SubmitRequest
from hcss.platform.live.trial_writer import KeyedCommand
from hcss.platform.models import Command, CommandOutcome, RequestStatusChange
from hcss.simulation import OperatorCommand
from tests.support.replays import operate, replay_trial


def _submit(trial, command: OperatorCommand) -> dict:
    """The participant's request through the live service's door, with a fresh key."""
    request = SubmitRequest(trial.trial_id, command.to_json())
    runner = trial.runner
    return door.carry_out(runner.database, runner, request, fresh_key(trial.trial_id)).body


def fresh_key(trial_id: int) -> KeyedCommand:
    key = uuid.uuid4().hex
    return KeyedCommand(trial_id=trial_id, key=key, endpoint="test", fingerprint=key)


def _rows(app, model):
    with app.extensions["hcss_db"].session_scope() as session:
        return list(session.scalars(select(model).order_by(model.id)))


def _favoured(trial, collective: int = 0):
    view = trial.state()["view"]
    return max(
        (t for t in view["targets"] if collective in t["in_range_of"]),
        key=lambda t: t["support"][collective],
    )


def test_the_intervention_flag_follows_the_simulations_parameter(make_trial) -> None:
    """Not a constant of the platform's: a trial whose params move the threshold is flagged by them."""
    trial = make_trial()
    trial.run_to(60)
    target = _favoured(trial)
    support = target["support"][0]
    assert support * 200 >= 2
    live = trial.live()
    threshold = 0.0 if support < 0.10 else 1.0  # the opposite of what a fixed 0.10 would say
    with live.lock:
        live.sim.params = live.sim.params.with_changes(intervention_support=threshold)
    answer = trial.post("/requests", {"kind": "abandon", "collective": 0, "target": target["id"]})
    assert answer.get_json()["accepted"]
    (command,) = _rows(trial.app, Command)
    (outcome,) = _rows(trial.app, CommandOutcome)
    assert command.support == support and command.decision_index == 1
    assert outcome.intervention is (support >= threshold)
    assert live.sim.open[0].requests["interventions"] == int(outcome.intervention)


def _stored_and_replayed_statuses(trial):
    """The stored status rows and those of an uninterrupted replay of the stored commands."""
    live = trial.live()
    step, digest = live.sim.step_count, live.sim.state_digest()
    stored = [(r.request_id, r.status, r.step) for r in _rows(trial.app, RequestStatusChange)]
    with trial.app.extensions["hcss_db"].session_scope() as session:
        oracle = replay_trial(session, trial.trial_id, step)
    assert oracle.state_digest() == digest  # the stored commands replay the live trial
    return stored, [(c.request_id, c.status, c.step) for c in oracle.drain_status_changes()]


def test_the_status_history_is_the_simulations_step_for_step(make_trial) -> None:
    """Each status row carries the step it happened at, as an uninterrupted replay has it."""
    trial = make_trial(seed=4)
    operate(trial, 300.0)
    stored, replayed = _stored_and_replayed_statuses(trial)
    assert stored == replayed
    assert {status for _, status, _ in stored} == {"in_progress", "completed", "removed"}
    # The runner steps four seconds at a time here; the rows are not stamped at its looks.
    assert any(s % 4 for _, _, s in stored)


def test_a_rebuild_writes_each_status_once(make_trial) -> None:
    """After a restart the replay queues statuses already written; none is written twice."""
    trial = make_trial(seed=4)
    operate(trial, 60.0)
    trial.runner.snapshot_interval_s = 1e9  # the newest snapshot stays at 60 s
    operate(trial, 150.0, from_s=60.0)
    written = len(_rows(trial.app, RequestStatusChange))
    trial.runner.forget(trial.trial_id)  # the next look rebuilds from the snapshot and the log
    trial.runner.snapshot_interval_s = 5.0
    operate(trial, 300.0, from_s=150.0)
    stored, replayed = _stored_and_replayed_statuses(trial)
    assert written > 2 and len(stored) > written  # some before the restart, some after
    assert len(set(stored)) == len(stored)
    assert sorted(stored) == sorted(replayed)


def test_a_command_that_cannot_be_written_leaves_the_trial_as_it_was(
    make_trial, monkeypatch
) -> None:
    trial = make_trial()
    trial.run_to(60)
    target = _favoured(trial)
    live = trial.live()
    before = live.sim.state_digest()
    good = CommandOutcome.of

    def broken(command_id, outcome):
        row = good(command_id, outcome)
        row.accepted = None  # NOT NULL: the database refuses the transaction
        return row

    monkeypatch.setattr(CommandOutcome, "of", broken)
    command = OperatorCommand("investigate", 0, target["id"])
    with pytest.raises(IntegrityError):
        _submit(trial, command)
    assert live.sim.state_digest() == before
    assert live.sim.requests == [] and live.sim.drain_status_changes() == []
    assert _rows(trial.app, Command) == [] and _rows(trial.app, RequestStatusChange) == []
    monkeypatch.setattr(CommandOutcome, "of", good)
    answer = _submit(trial, command)
    assert answer["accepted"] and answer["request_id"] == 1
    assert [r.status for r in _rows(trial.app, RequestStatusChange)][:1] == ["in_progress"]
