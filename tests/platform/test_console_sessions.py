"""Pause, resume, abort and pilot marking: recorded as rows, obeyed by the trial clock, shown live."""

from __future__ import annotations

from sqlalchemy import select

from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.live.trials import latest_status
from hcss.platform.models import ConsoleAction, Participant
from tests.support.console import code_of

# Fixtures of this part's own module (conftest.py belongs to the live trial tests).


def _actions(app, code: str) -> list[tuple[str, int | None, str]]:
    with app.extensions["hcss_db"].session_scope() as session:
        return [
            (a.action, a.trial_id, a.detail)
            for a in session.scalars(
                select(ConsoleAction)
                .join(Participant, Participant.id == ConsoleAction.participant_id)
                .where(Participant.code == code)
                .order_by(ConsoleAction.id)
            )
        ]


def test_pause_stops_the_trial_clock_and_resume_continues_it(app, make_trial, console) -> None:
    trial = make_trial(duration_s=600.0)
    code = code_of(app, trial.token)
    trial.run_to(60.0)
    assert console.act(code, "pause").status_code == 303
    paused_step = trial.live().sim.step_count
    row = console.progress()[code]
    assert row["state"] == "paused" and row["trial_clock_s"] == 60.0

    trial.run_to(200.0)  # 140 s of wall time pass during the pause
    assert trial.live().sim.step_count == paused_step
    assert trial.state()["trial"]["status"] == "paused"
    assert trial.state()["trial"]["clock_s"] == 60.0
    assert console.progress()[code]["trial_clock_s"] == 60.0
    refused = trial.post("/observations", {"kind": "collective", "collective": 0, "button": "left"})
    assert refused.status_code == 409 and refused.get_json()["error"] == "paused"

    assert console.act(code, "resume").status_code == 303
    trial.run_to(230.0)  # 30 s more wall time: the clock runs again from 60 s
    assert trial.state()["trial"]["clock_s"] == 90.0
    assert console.progress()[code]["state"] == "active"
    assert console.progress()[code]["trial_clock_s"] == 90.0
    assert [a for a, _, _ in _actions(app, code)] == ["pause", "resume"]
    assert all(trial_id == trial.trial_id for _, trial_id, _ in _actions(app, code))
    page = console.get(f"/console/participants/{code}").get_data(as_text=True)
    assert "pause" in page and "trial clock 60.0 s" in page


def test_a_restart_during_a_pause_keeps_the_trial_paused(
    app,
    make_trial,
    console,
    database_url,
) -> None:
    trial = make_trial(duration_s=600.0)
    code = code_of(app, trial.token)
    trial.run_to(30.0)
    console.act(code, "pause")
    paused_step = trial.live().sim.step_count
    restarted = create_app(
        {"DATABASE_URL": database_url, "SECRET_KEY": "test-secret", "LIVE_RUNNER": False}
    )
    # The new server comes up 300 wall seconds later, still inside the pause.
    restarted.extensions["hcss_runner"].clock = ManualClock(trial.started_epoch + 300.0)
    try:
        rebuilt = restarted.extensions["hcss_runner"].host(trial.trial_id)
        assert rebuilt.sim.step_count == paused_step
        assert rebuilt.trial_clock.paused_since == trial.started_epoch + 30.0
    finally:
        restarted.extensions["hcss_db"].engine.dispose()


def test_abort_ends_the_trial_and_the_session(app, make_trial, console) -> None:
    trial = make_trial(duration_s=600.0)
    code = code_of(app, trial.token)
    trial.run_to(45.0)
    console.act(code, "pause")
    assert console.act(code, "abort").status_code == 303
    with app.extensions["hcss_db"].session_scope() as session:
        assert latest_status(session, trial.trial_id) == "ended"
    row = console.progress()[code]
    assert row["state"] == "aborted" and "aborted" in row["stage"] and row["trial_clock_s"] is None
    trial.run_to(100.0)
    assert trial.client.get(trial.api + "/state").status_code == 409
    # An aborted session cannot be paused or resumed again; the refusal writes nothing.
    before = _actions(app, code)
    for action in ("pause", "resume", "abort"):
        response = console.act(code, action)
        assert response.status_code == 303
        assert "was aborted" in console.get(f"/console/participants/{code}").get_data(as_text=True)
    assert _actions(app, code) == before
    assert [a for a, _, _ in before] == ["pause", "abort"]


def test_pause_and_resume_without_a_trial_and_refusals(app, console) -> None:
    console.post("/console/participants", {"count": "1"})
    (code,) = console.progress()
    assert console.act(code, "resume").status_code == 303  # not paused: refused
    assert _actions(app, code) == [("create", None, f"batch {code} of 1")]
    console.act(code, "pause")
    console.act(code, "pause")  # already paused: refused
    assert console.progress()[code]["state"] == "paused"
    console.act(code, "resume")
    assert console.progress()[code]["state"] == "active"
    assert [a for a, _, _ in _actions(app, code)] == ["create", "pause", "resume"]
    assert console.act(code, "delete_everything").status_code == 404


def test_pilot_marking_is_recorded_and_shown(app, console) -> None:
    response = console.post("/console/participants", {"count": "2"})
    assert response.status_code == 303
    codes = sorted(console.progress())
    assert len(codes) == 2 and all(not row["is_pilot"] for row in console.progress().values())
    console.act(codes[0], "mark_pilot")
    console.act(codes[0], "mark_pilot")  # already a pilot: refused, nothing written
    progress = console.progress()
    assert progress[codes[0]]["is_pilot"] and not progress[codes[1]]["is_pilot"]
    console.act(codes[0], "unmark_pilot")
    console.act(codes[0], "mark_pilot")
    assert [a for a, _, _ in _actions(app, codes[0])] == [
        "create",
        "mark_pilot",
        "unmark_pilot",
        "mark_pilot",
    ]
    index = console.get("/console/").get_data(as_text=True)
    assert codes[0] in index and "pilot" in index


def test_created_participants_get_unguessable_links(app, console) -> None:
    response = console.post("/console/participants", {"count": "1", "pilot": "y"})
    assert response.status_code == 303
    code = response.headers["Location"].rsplit("/", 1)[-1]
    with app.extensions["hcss_db"].session_scope() as session:
        participant = session.scalars(select(Participant).where(Participant.code == code)).one()
        token, is_pilot = participant.token, participant.is_pilot
    assert is_pilot and len(token) >= 32
    page = console.get(f"/console/participants/{code}").get_data(as_text=True)
    assert f"/{token}" in page
