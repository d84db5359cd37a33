"""A participant outside the study flow (`hcss demo-trial`) shows their real status in the
console: in progress while the trial runs, with Pause; completed after, without Abort."""

from __future__ import annotations

from sqlalchemy import select

from hcss.platform.models import Participant


def test_a_demo_trials_participant_shows_the_trial_and_its_actions(
    app, console, make_trial
) -> None:
    trial = make_trial(duration_s=120.0)
    with app.extensions["hcss_db"].session_scope() as session:
        code = session.scalars(
            select(Participant.code).where(Participant.token == trial.token)
        ).one()
    trial.run_to(30.0)
    row = console.progress()[code]
    assert (row["status"], row["state"]) == ("in_progress", "active")
    assert row["actions"] == ["pause", "abort", "mark_pilot"]  # no stages to skip
    html = console.get("/console/").get_data(as_text=True)
    assert f'data-code="{code}"' in html and "not started" not in html
    assert console.act(code, "pause").status_code == 303
    assert console.progress()[code]["actions"] == ["resume", "abort", "mark_pilot"]
    assert console.act(code, "resume").status_code == 303

    trial.run_to(200.0)  # past its 2 minutes: ended
    row = console.progress()[code]
    assert row["status"] == "completed" and row["stage"].startswith("trial M1 ended")
    assert row["actions"] == ["mark_pilot"]
    assert console.act(code, "abort").status_code == 303  # refused: nothing to abort
    assert console.progress()[code]["state"] == "active"
    assert "completed the study; there is nothing to abort" in console.get("/console/").text
