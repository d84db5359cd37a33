"""Issue 13 §7: `hcss bots --base-url --concurrency` drives a real server over HTTP.

Before, `hcss bots` only ran in-process through Flask's test client, one bot
at a time, although the README said it worked over HTTP. Here two bots walk
the demo study at once against a waitress server in its own process; every
page and API call is a real HTTP request, and the server enrols them itself.
"""

from __future__ import annotations

import time

import pytest
from click.testing import CliRunner
from sqlalchemy import func, select

from hcss.cli import main
from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.models import Participant, StudyEnrolment, TrialStatusChange
from hcss.platform.serving.localserver import LocalServer


@pytest.mark.slow
def test_two_bots_walk_the_demo_study_over_http_at_once(tmp_path) -> None:
    url = f"sqlite:///{tmp_path / 'load.sqlite3'}"
    upgrade_database(url)
    env = {"HCSS_STUDY": "demo", "HCSS_TIME_ACCELERATION": "30"}
    with LocalServer(url, tmp_path / "instance", threads=32, extra_env=env) as server:
        result = CliRunner().invoke(
            main,
            [
                "bots",
                "--n",
                "2",
                "--concurrency",
                "2",
                "--study",
                "demo",
                "--base-url",
                server.url,
                "--database-url",
                url,
            ],
        )
        log = server.log_path.read_text()
    assert result.exit_code == 0, result.output
    assert "2 completed, 0 failed, 0 answers >= 500" in result.output
    assert "page p50" in result.output and "p95" in result.output
    assert "Traceback" not in log
    database = Database(url)
    try:
        with database.session_scope() as session:
            assert session.scalar(select(func.count()).select_from(Participant)) == 2
            enrolments = session.scalars(select(StudyEnrolment)).all()
            assert {(e.study, e.pool, e.time_acceleration) for e in enrolments} == {
                ("demo", "bot", 30.0)
            }
            ended = session.scalars(
                select(TrialStatusChange.reason).where(TrialStatusChange.status == "ended")
            ).all()
            assert len(ended) == 12 and set(ended) == {"time_limit"}  # 2 bots x 3 x 2
    finally:
        database.engine.dispose()


@pytest.mark.slow
def test_a_bot_whose_mental_rotation_part_times_out_goes_on(tmp_path, monkeypatch) -> None:
    """Under load (or across a restart) the test's part can run out of time over HTTP.

    The server then shows "time is up" (mental_rotation/time_up_1), a page a
    participant reaches only that way; the bot stopped there ("expected
    introduction/page_1"), in every kill -9 round. It now presses Continue.
    """
    from hcss.platform.bots.http_load import run_http_bots
    from hcss.platform.bots.participant import ParticipantBot
    from hcss.questionnaires import mrt

    acceleration = 60.0
    real_choice = ParticipantBot.mrt_choice
    slept: list[float] = []

    practice = {item.key for item in mrt.practice_items()}

    def slow_choice(self, key):
        if not slept and key not in practice:  # the part's first answer, after its 60 s
            slept.append(60.0 / acceleration + 0.5)
            time.sleep(slept[0])
        return real_choice(self, key)

    monkeypatch.setattr(ParticipantBot, "mrt_choice", slow_choice)
    url = f"sqlite:///{tmp_path / 'slow.sqlite3'}"
    upgrade_database(url)
    env = {"HCSS_STUDY": "demo", "HCSS_TIME_ACCELERATION": str(acceleration)}
    with LocalServer(url, tmp_path / "instance", threads=32, extra_env=env) as server:
        figures = run_http_bots(server.url, url, "demo", 1, concurrency=1)
    assert slept and figures.errors == [] and len(figures.reports) == 1
