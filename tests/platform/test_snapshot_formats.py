"""A trial whose newest snapshot this version cannot read (docs/operations.md, "Rolling upgrade").

During a rolling upgrade a trial may be taken over by a process of the
previous version after one of the next version wrote its newest snapshot. A
newer format is never guessed at: the trial is replayed from its start with
the whole command log (deterministic replay makes that exact; the snapshot
fixtures of tests/simulation prove the two versions step alike), and a
trial problem row says why. A retired format ends the trial, saying why.
"""

from __future__ import annotations

from sqlalchemy import func, select

from hcss.platform.models import Command, Interruption, Snapshot, TrialProblem, TrialStatusChange
from hcss.simulation.snapshots import SNAPSHOT_FORMAT
from tests.support.replays import operate, replay_trial
from tests.support.snapshot_formats import newer, restamped


def _plant(trial, blob: bytes) -> int:
    """A snapshot of the trial as it stands, in other bytes, newest of all; its id."""
    live = trial.live()
    with trial.app.extensions["hcss_db"].session_scope() as session:
        last = session.scalar(
            select(func.max(Command.id)).where(Command.trial_id == trial.trial_id)
        )
        planted = Snapshot(
            trial_id=trial.trial_id,
            step=live.sim.step_count,
            sim_time=live.sim.time,
            last_command_id=last,
            blob=blob,
        )
        session.add(planted)
        session.flush()
        return planted.id


def test_a_snapshot_of_a_newer_format_is_replayed_from_the_start_exactly(make_trial) -> None:
    trial = make_trial(seed=4)
    operate(trial, 100.0)
    trial.runner.snapshot_interval_s = 1e9  # the planted snapshot stays the newest
    planted = _plant(trial, newer(trial.live().sim.snapshot()))
    trial.runner.forget(trial.trial_id)  # taken over by this version
    operate(trial, 160.0, from_s=100.0)

    live = trial.live()
    assert live is not None and live.sim.step_count >= 150
    database = trial.app.extensions["hcss_db"]
    with database.session_scope() as session:
        oracle = replay_trial(session, trial.trial_id, live.sim.step_count)
        logged = session.scalar(
            select(func.count()).select_from(Command).where(Command.trial_id == trial.trial_id)
        )
        (interruption,) = session.scalars(select(Interruption)).all()
        (problem,) = session.scalars(select(TrialProblem)).all()
        ended = session.scalars(
            select(TrialStatusChange).where(TrialStatusChange.status == "ended")
        ).all()
    assert live.sim.state_digest() == oracle.state_digest()
    assert not ended
    # Rebuilt from the start: every command logged before the takeover was replayed.
    assert interruption.snapshot_step == -1
    assert 0 < interruption.replayed_commands < logged
    assert (problem.trial_id, problem.source, problem.record) == (
        trial.trial_id,
        "rebuild",
        f"snapshot {planted}",
    )
    assert f"format {SNAPSHOT_FORMAT + 1} is newer" in problem.problem
    assert "whole command log" in problem.problem


def test_a_snapshot_of_a_retired_format_ends_the_trial_saying_why(make_trial) -> None:
    trial = make_trial(seed=4)
    operate(trial, 40.0)
    trial.runner.snapshot_interval_s = 1e9
    _plant(trial, restamped(trial.live().sim.snapshot(), 2))
    trial.runner.forget(trial.trial_id)
    trial.run_to(44.0)

    assert trial.runner.loaded(trial.trial_id) is None
    with trial.app.extensions["hcss_db"].session_scope() as session:
        (problem,) = session.scalars(select(TrialProblem)).all()
        (ended,) = session.scalars(
            select(TrialStatusChange).where(TrialStatusChange.status == "ended")
        ).all()
    assert ended.reason == "rebuild_failed"
    assert "snapshot format 2 is older than this version reads" in problem.problem


def test_the_console_replays_a_trial_whose_newest_snapshot_is_of_a_newer_format(
    make_trial, console
) -> None:
    """The replay reads the snapshot only to compare digests: it has none to compare."""
    trial = make_trial(seed=4)
    operate(trial, 60.0)
    trial.runner.snapshot_interval_s = 1e9
    _plant(trial, newer(trial.live().sim.snapshot()))
    response = console.get(f"/console/trials/{trial.trial_id}/replay/frames?start=0&count=5")
    assert response.status_code == 200, response.get_data(as_text=True)
    body = response.get_json()
    assert body["recorded_digest"] is None and body["replayed_digest"] is None
    assert body["horizon"] >= 56 and len(body["frames"]) == 5
