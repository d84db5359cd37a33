"""The server's terminal: one line per participant event, only for what was committed."""

from __future__ import annotations

import logging

import pytest
from sqlalchemy import select

from hcss.platform.live.trials import start_trial
from hcss.platform.models import Participant
from hcss.platform.study import views as study_views
from tests.support.trials import STUDY_TRIAL_S


def _lines(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "hcss.events"]


def test_created_enrolled_and_stage_lines_name_the_participant_by_code(
    app, console, caplog
) -> None:
    caplog.set_level(logging.INFO, logger="hcss.events")
    console.post("/console/participants", {"count": "1", "study": "demo", "pilot": "y"})
    (code,) = console.progress()
    assert _lines(caplog) == [f"{code} created (study demo, pilot)"]
    with app.extensions["hcss_db"].session_scope() as session:
        token = session.scalars(select(Participant.token).where(Participant.code == code)).one()

    caplog.clear()
    assert app.test_client().get(f"/p/{token}", follow_redirects=True).status_code == 200
    lines = _lines(caplog)
    assert len(lines) == 2, lines
    assert lines[0].startswith(f"{code} enrolled: study demo, cell ") and "(pilot pool)" in lines[0]
    assert lines[1] == f"{code} stage 1 consent: entered"
    assert all(token not in record.getMessage() for record in caplog.records)

    caplog.clear()
    app.test_client().get(f"/p/{token}/stage")  # the same page again: nothing new happened
    assert _lines(caplog) == []


def test_trial_start_and_end_lines(app, make_trial, caplog) -> None:
    caplog.set_level(logging.INFO, logger="hcss.events")
    trial = make_trial(duration_s=60.0, model="M2")
    with app.extensions["hcss_db"].session_scope() as session:
        code = session.scalars(
            select(Participant.code).where(Participant.token == trial.token)
        ).one()
    trial.run_to(61.0)
    lines = _lines(caplog)
    assert f"{code} created (default study, bot)" in lines
    assert f"{code} trial M2 (#{trial.trial_id}) started" in lines
    assert lines[-1] == f"{code} trial M2 (#{trial.trial_id}) ended (time_limit)"


def test_a_rolled_back_transaction_logs_nothing(app, caplog) -> None:
    caplog.set_level(logging.INFO, logger="hcss.events")
    database = app.extensions["hcss_db"]
    with pytest.raises(RuntimeError), database.session_scope() as session:
        participant = Participant(is_demo=True)
        session.add(participant)
        session.flush()
        start_trial(session, participant, seed=1, duration_s=STUDY_TRIAL_S)
        session.flush()
        raise RuntimeError("the request failed after the rows were flushed")
    assert _lines(caplog) == []


def test_an_error_on_a_participants_page_is_one_error_line(
    app, console, caplog, monkeypatch
) -> None:
    console.post("/console/participants", {"count": "1"})
    (code,) = console.progress()
    with app.extensions["hcss_db"].session_scope() as session:
        token = session.scalars(select(Participant.token).where(Participant.code == code)).one()

    def broken(*_args, **_kwargs):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(study_views, "current_enrolment", broken)
    caplog.set_level(logging.INFO, logger="hcss.events")
    with pytest.raises(RuntimeError):  # TESTING propagates; a server answers 500
        app.test_client().get(f"/p/{token}")
    errors = [r for r in caplog.records if r.name == "hcss.events" and r.levelno == logging.ERROR]
    assert len(errors) == 1
    message = errors[0].getMessage()
    assert message.startswith(f"{code} error on study.enter: ") and "disk on fire" in message
    assert token not in message
