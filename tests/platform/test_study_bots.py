"""`hcss bots` and the experimenter's holds on the study flow."""

from __future__ import annotations

import pytest
from click.testing import CliRunner
from sqlalchemy import select

from hcss.cli import main
from hcss.platform.bots.participant import BotError, ManualClock, run_bots
from hcss.platform.db import Database
from hcss.platform.models import (
    Command,
    CommandKey,
    ConsoleAction,
    Observation,
    Participant,
    ProbeEvent,
    StageEvent,
    StudyEnrolment,
)
from hcss.platform.study import participant_status
from hcss.platform.study.stage_protocol import Submission, SubmissionMustFail
from hcss.platform.study.stages import STAGES
from tests.support.study import new_participant, visitor


@pytest.mark.slow
def test_hcss_bots_fills_a_database_with_flagged_completed_bots(tmp_path) -> None:
    url = f"sqlite:///{tmp_path / 'bots.sqlite3'}"
    result = CliRunner().invoke(
        main, ["bots", "--n", "2", "--study", "demo", "--database-url", url]
    )
    assert result.exit_code == 0, result.output
    # 40: the MRT part ends on "part done"; the instruction check is answered at its first try
    assert result.output.count("40 pages, 6 trials") == 2
    database = Database(url)
    with database.session_scope() as session:
        participants = list(session.scalars(select(Participant)))
        assert len(participants) == 2 and all(p.is_bot for p in participants)
        assert {participant_status(session, p) for p in participants} == {"completed"}
        cells = {e.cell for e in session.scalars(select(StudyEnrolment))}
        assert len(cells) == 2 and {e.pool for e in session.scalars(select(StudyEnrolment))} == {
            "bot"
        }
    database.engine.dispose()
    bad = CliRunner().invoke(main, ["bots", "--study", "nope", "--database-url", url])
    assert bad.exit_code != 0 and "no study file nope.toml" in bad.output


def test_every_command_of_an_in_process_bot_carries_its_key(demo_app) -> None:
    """The in-process bot (`hcss bots`) sends an Idempotency-Key with every command, as the
    page does: one key row per request, click, Ready press and answer it recorded.

    Before issue 41 it sent none (one `hcss bots --n 1` run: 180 commands, 0 key rows), so
    the study tests walked a door branch no page takes.
    """
    demo_app.extensions["hcss_runner"].clock = ManualClock()
    (report,) = run_bots(demo_app, 1)
    assert report.requests > 0
    with demo_app.extensions["hcss_db"].session_scope() as session:
        commands = (
            len(session.scalars(select(Command.id)).all())
            + len(session.scalars(select(Observation.id)).all())
            + len(
                session.scalars(
                    select(ProbeEvent.id).where(ProbeEvent.kind.in_(("ready", "answer")))
                ).all()
            )
        )
        keys = len(session.scalars(select(CommandKey.id)).all())
    assert commands >= report.requests
    assert keys == commands


def test_a_paused_or_aborted_session_holds_the_participant(demo_app) -> None:
    token = new_participant(demo_app)
    v = visitor(demo_app, token)
    page = v.page()
    with demo_app.extensions["hcss_db"].session_scope() as session:
        participant = session.scalars(select(Participant).where(Participant.token == token)).one()
        session.add(ConsoleAction(participant_id=participant.id, action="pause", at_epoch=0.0))
    assert v.page().stage == "held" and "paused your session" in v.html
    assert v.submit({"decision": "agree"}, page).status_code == 409
    with demo_app.extensions["hcss_db"].session_scope() as session:
        session.add(ConsoleAction(participant_id=participant.id, action="resume", at_epoch=1.0))
    assert v.page().stage == "consent"
    with demo_app.extensions["hcss_db"].session_scope() as session:
        session.add(ConsoleAction(participant_id=participant.id, action="abort", at_epoch=2.0))
        assert participant_status(session, session.get(Participant, participant.id)) == "aborted"
    assert v.page().stage == "held" and "has ended this session" in v.html


@pytest.mark.parametrize(
    ("stage", "accepted"),
    [
        ("consent", {"decision": "agree"}),
        ("screen_check", {"width": "1280", "height": "800"}),
    ],
)
def test_a_bot_stops_where_a_stage_takes_answers_it_must_refuse(
    demo_app,
    monkeypatch: pytest.MonkeyPatch,
    stage: str,
    accepted: dict[str, str],
) -> None:
    """The bots post each stage's `SubmissionMustFail` before its `Submission`: declared
    answers the platform takes are a failed walk, not a pilot participant with wrong data."""
    planted = (SubmissionMustFail(accepted), Submission(accepted))
    monkeypatch.setattr(type(STAGES[stage]), "bot_submissions", lambda self, shown: planted)
    with pytest.raises(BotError, match=rf"{stage}/form took .*: must refuse"):
        run_bots(demo_app, 1)
    with demo_app.extensions["hcss_db"].session_scope() as session:
        submitted = session.scalars(select(StageEvent.stage).where(StageEvent.kind == "submitted"))
        assert stage in set(submitted)  # it was the stage that took them
