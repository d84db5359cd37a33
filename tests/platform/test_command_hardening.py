"""Issue 13 §1: no command a client sends, and no row in the database, breaks a trial or the export.

The issue's POST (`collective: 16`) used to be committed, then its refusal
text raised IndexError: from then on the export failed for everyone and the
trial could not be rebuilt after a restart. Now every field is checked
against the trial's ranges before anything is written, and the export and
the rebuild are total: a stored row they cannot read (here: one written
straight into the database) is reported and skipped.
"""

from __future__ import annotations

import csv

import pytest
from click.testing import CliRunner
from sqlalchemy import func, select

from hcss.cli import main
from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.models import (
    Command,
    CommandOutcome,
    Observation,
    Snapshot,
    TrialProblem,
    TrialStatusChange,
)
from tests.support.counting import count_rows

ISSUE_POST = {"kind": "investigate", "collective": 16, "target": 1}

BAD_COMMANDS = [
    ISSUE_POST,
    {"kind": "investigate", "collective": 4, "target": 1},  # four collectives: 0..3
    {"kind": "investigate", "collective": 2**31, "target": 1},
    {"kind": "investigate", "collective": 2**63, "target": 1},
    {"kind": "investigate", "collective": 2**64 + 1, "target": 1},
    {"kind": "investigate", "collective": 0, "target": 0},  # target ids start at 1
    {"kind": "investigate", "collective": 0, "target": 99},
    {"kind": "investigate", "collective": 0, "target": 2**63},
    {"kind": "decide", "collective": 0, "target": -(2**63) - 1},
    {"kind": "abandon", "collective": 1.0, "target": 1},
    {"kind": "abandon", "collective": "1", "target": 1},
    {"kind": "abandon", "collective": None, "target": 1},
    {"kind": ["investigate"], "collective": 0, "target": 1},
    {"kind": "cancel", "request_id": 1},  # no assignment made yet
    {"kind": "cancel", "request_id": 2**63},
    {"kind": "investigate", "collective": 0, "target": 1, "selections": [2**63]},
    {"kind": "investigate", "collective": 0, "target": 1, "selections": [0]},
    {"kind": "investigate", "collective": 0, "target": 1, "selections": list(range(1, 100))},
    {"kind": "investigate", "collective": 0, "target": 1, "selections": [[1]]},
]


def _export(database_url: str, outdir) -> tuple[int, str, list[dict[str, str]]]:
    result = CliRunner().invoke(main, ["export", str(outdir), "--database-url", database_url])
    problems = outdir / "export_problems.csv"
    rows = list(csv.DictReader(problems.open(encoding="utf-8"))) if problems.exists() else []
    return result.exit_code, result.output, rows


def _restart(database_url: str, now: float):
    """A new server process on the same database (the old one died)."""
    app = create_app(
        {"DATABASE_URL": database_url, "SECRET_KEY": "test-secret", "LIVE_RUNNER": False}
    )
    app.extensions["hcss_runner"].clock = ManualClock(now)
    return app


@pytest.mark.parametrize("body", BAD_COMMANDS, ids=range(len(BAD_COMMANDS)))
def test_a_command_out_of_the_trials_range_is_refused_and_not_stored(make_trial, body) -> None:
    trial = make_trial()
    trial.run_to(30)
    before = trial.state()

    response = trial.post("/requests", body)

    assert response.status_code == 400, response.get_data(as_text=True)
    assert response.get_json()["message"]
    assert count_rows(trial.app, Command) == 0 and count_rows(trial.app, CommandOutcome) == 0
    after = trial.state()
    assert after["messages"] == before["messages"]


def test_an_observation_out_of_range_is_refused(make_trial) -> None:
    trial = make_trial()
    trial.run_to(30)
    for body in (
        {"kind": "collective", "collective": 16, "button": "left"},
        {"kind": "collective", "collective": 2**63, "button": "left"},
        {"kind": "target", "target": 2**64, "button": "right"},
        {"kind": "target", "target": 1, "collective": 2**63, "button": "right"},
    ):
        response = trial.post("/observations", body)
        assert response.status_code == 400, body
    assert count_rows(trial.app, Observation) == 0


def test_after_the_issues_post_export_and_restart_still_work(
    app, make_trial, database_url, tmp_path
) -> None:
    trial = make_trial(seed=2)
    trial.run_to(60)
    assert trial.post("/requests", ISSUE_POST).status_code == 400
    target = next(t for t in trial.state()["view"]["targets"] if 0 in t["in_range_of"])
    ok = trial.post("/requests", {"kind": "investigate", "collective": 0, "target": target["id"]})
    assert ok.status_code == 200 and ok.get_json()["accepted"]

    code, output, problems = _export(database_url, tmp_path / "export")
    assert code == 0, output
    assert problems == []

    restarted = _restart(database_url, trial.started_epoch + 90)
    try:
        rebuilt = restarted.extensions["hcss_runner"].host(trial.trial_id)
        assert rebuilt is not None and rebuilt.sim.step_count == 60  # the outage stops the clock
        client = restarted.test_client()
        assert client.get(f"{trial.api}/state").status_code == 200
    finally:
        restarted.extensions["hcss_db"].engine.dispose()


def _store_bad_command(app, trial_id: int) -> int:
    """What the server stored before this fix: the issue's command and its refusal.

    Logged at the step of the newest snapshot, as a command the live trial
    had just applied when the server died.
    """
    with app.extensions["hcss_db"].session_scope() as session:
        step = session.scalar(select(func.max(Snapshot.step)).where(Snapshot.trial_id == trial_id))
        command = Command(
            trial_id=trial_id,
            kind="investigate",
            collective=16,
            target=1,
            step_applied=step,
            sim_time=float(step),
            selections=[],
        )
        session.add(command)
        session.flush()
        session.add(
            CommandOutcome(
                command_id=command.id, accepted=False, reason="There is no collective 17."
            )
        )
        return command.id


def test_a_bad_row_in_the_database_breaks_neither_export_nor_rebuild(
    app, make_trial, database_url, tmp_path
) -> None:
    bad = make_trial(seed=2)
    good = make_trial(seed=3)
    bad.run_to(30)
    good.run_to(30)
    bad_command = _store_bad_command(app, bad.trial_id)
    target = next(t for t in good.state()["view"]["targets"] if 0 in t["in_range_of"])
    good.post("/requests", {"kind": "investigate", "collective": 0, "target": target["id"]})

    code, output, problems = _export(database_url, tmp_path / "export")

    assert code == 0, output
    assert "1 record(s) could not be read" in output
    assert [(p["trial_id"], p["table"], p["record"]) for p in problems] == [
        (str(bad.trial_id), "requests", f"command {bad_command}")
    ]
    assert "collective 16" in problems[0]["problem"]
    with (tmp_path / "export" / "requests.csv").open(encoding="utf-8") as handle:
        requests = list(csv.DictReader(handle))
    assert [r["trial_id"] for r in requests] == [str(good.trial_id)]  # others kept

    # The server dies; the next one rebuilds both trials and the bad row is reported.
    restarted = _restart(database_url, bad.started_epoch + 45)
    try:
        runner = restarted.extensions["hcss_runner"]
        runner.tick()
        assert runner.loaded_ids() == {bad.trial_id, good.trial_id}
        client = restarted.test_client()
        for handle in (bad, good):
            assert client.get(f"{handle.api}/state").status_code == 200
            stream = client.get(f"{handle.api}/stream?after=0", buffered=False)
            assert stream.status_code == 200
            assert next(stream.response)  # the first frame arrives
            stream.close()
        with restarted.extensions["hcss_db"].session_scope() as session:
            (problem,) = session.scalars(select(TrialProblem)).all()
        assert (problem.trial_id, problem.record) == (bad.trial_id, f"command {bad_command}")
    finally:
        restarted.extensions["hcss_db"].engine.dispose()


def test_a_trial_that_cannot_be_rebuilt_is_ended_with_a_problem_record(
    app, make_trial, database_url
) -> None:
    broken = make_trial(seed=2)
    healthy = make_trial(seed=3)
    broken.run_to(20)
    healthy.run_to(20)
    with app.extensions["hcss_db"].session_scope() as session:
        session.add(
            Snapshot(trial_id=broken.trial_id, step=20, sim_time=20.0, blob=b"not a snapshot")
        )

    restarted = _restart(database_url, broken.started_epoch + 30)
    try:
        runner = restarted.extensions["hcss_runner"]
        runner.tick()
        runner.tick()  # a second tick does not try (and log) again
        assert runner.loaded_ids() == {healthy.trial_id}
        client = restarted.test_client()
        assert client.get(f"{broken.api}/state").status_code == 409  # ended, not 500
        assert client.get(f"{broken.api}/stream").status_code == 200  # the "ended" frame
        with restarted.extensions["hcss_db"].session_scope() as session:
            problems = session.scalars(select(TrialProblem)).all()
            ended = session.scalars(
                select(TrialStatusChange).where(TrialStatusChange.status == "ended")
            ).all()
        assert [(p.trial_id, p.record) for p in problems] == [
            (broken.trial_id, f"trial {broken.trial_id}")
        ]
        assert [(e.trial_id, e.reason) for e in ended] == [(broken.trial_id, "rebuild_failed")]
    finally:
        restarted.extensions["hcss_db"].engine.dispose()
