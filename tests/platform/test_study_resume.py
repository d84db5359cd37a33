"""Resume: a refresh or a restart (a new app on the same database) lands in the same place.

Deadlines are stored, so the time left is the same after a restart, and a
deadline that passes while nobody is looking is recorded as a time-out, at
the deadline, when the participant comes back.
"""

from __future__ import annotations

import pytest
from flask import Flask
from sqlalchemy import select

from hcss.platform.bots.participant import BotReport, ParticipantBot
from hcss.platform.models import Participant
from hcss.platform.study import current_position, load_study
from tests.support.study import (
    events,
    make_app,
    new_participant,
    trial_kind,
    visitor,
    walk_to,
)


def _entered(app: Flask, token: str, step: str):
    rows = [e for e in events(app, token) if e.step == step and e.kind == "entered"]
    assert len(rows) == 1
    return rows[0]


def _restart(app: Flask, database_url: str, study: str = "demo") -> Flask:
    now = app.extensions["hcss_runner"].clock.now
    app.extensions["hcss_db"].engine.dispose()
    return make_app(database_url, study, now=now)


def test_mid_mrt_refresh_and_restart_return_to_the_same_item_and_deadline(database_url) -> None:
    app = make_app(database_url, "original")
    token = new_participant(app)
    v = visitor(app, token)
    walk_to(v, "mental_rotation", "part_1")
    for _ in range(3):
        page = v.page()
        assert v.submit({"chosen": ["0", "1"]}, page).status_code == 302
        v.advance(10.0)
    deadline = _entered(app, token, "part_1").deadline
    page = v.page()
    assert page.mrt_item == "mrt_04" and "2:30" in v.html  # 180 s - 30 s
    assert v.page().mrt_item == "mrt_04"  # refresh
    app = _restart(app, database_url, "original")
    v = visitor(app, token)
    page = v.page()
    assert (page.step, page.mrt_item) == ("part_1", "mrt_04") and "2:30" in v.html
    assert _entered(app, token, "part_1").deadline == deadline
    with app.extensions["hcss_db"].session_scope() as session:
        participant = session.scalars(select(Participant).where(Participant.token == token)).one()
        position = current_position(session, participant)
        assert (position.slot.name, position.step) == ("mental_rotation", "part_1")
    # Away past the deadline: the part is timed out at its deadline, the answers kept.
    stale = page
    v.advance(200.0)
    assert v.page().step == "time_up_1" and "You answered 3 of its 12 items" in v.html
    assert v.submit({}).status_code == 302
    assert v.page().step == "break_1" and "you will have <b>3 minutes</b>" in v.html
    timed_out = [e for e in events(app, token) if e.step == "part_1" and e.kind == "timed_out"]
    assert len(timed_out) == 1 and timed_out[0].at == deadline
    assert v.submit({"chosen": ["0"]}, stale).status_code == 409
    assert "time for this part was up" in v.html
    app.extensions["hcss_db"].engine.dispose()


def test_a_part_answered_in_time_ends_on_a_part_done_page_before_the_break(database_url) -> None:
    """Finishing a part early says so; the break follows the participant's Continue."""
    app = make_app(database_url, "original")
    token = new_participant(app)
    v = visitor(app, token)
    walk_to(v, "mental_rotation", "part_1")
    for _ in range(12):
        assert v.submit({"chosen": ["0", "1"]}).status_code == 302
        v.advance(5.0)
    page = v.page()
    assert page.step == "done_1" and "Part 1 done" in v.html
    assert "You answered all 12 items of part 1 of 2 within its 3 minutes" in v.html
    assert "A short break comes next, then part 2." in v.html and "Go to the break" in v.html
    assert v.page().step == "done_1"  # a refresh stays on it; no clock runs here
    assert 'id="timer"' not in v.html
    assert v.submit({}).status_code == 302
    assert v.page().step == "break_1"
    done = [e for e in events(app, token) if e.step == "done_1" and e.kind == "submitted"]
    assert len(done) == 1
    app.extensions["hcss_db"].engine.dispose()


@pytest.mark.slow
def test_every_page_of_the_demo_survives_refresh_and_restart(database_url) -> None:
    """At each step of the whole demo study, including mid-trial, the page and deadline hold."""
    study = load_study("demo")
    app = make_app(database_url, "demo")
    token = new_participant(app, is_bot=True)
    v = visitor(app, token)
    seen = []
    while True:
        page = v.page()
        where = "live" if page.interface else (page.stage, page.step)
        deadlines = {
            (e.stage_index, e.step): e.deadline for e in events(app, token) if e.kind == "entered"
        }
        assert v.page().interface == page.interface or (v.page().stage, v.page().step) == where
        app = _restart(app, database_url)
        v = visitor(app, token)
        again = v.page()
        assert ("live" if again.interface else (again.stage, again.step)) == where
        if page.interface:
            assert again.interface["data-stream-url"] == page.interface["data-stream-url"]
        assert {
            (e.stage_index, e.step): e.deadline for e in events(app, token) if e.kind == "entered"
        } == deadlines
        seen.append(where)
        if where == ("debrief", ""):
            break
        bot = ParticipantBot(app, token, seed=len(seen))
        bot.client = v.client
        if page.interface:
            kind = trial_kind(v)
            half = (study.timing.training_s if kind == "training" else study.timing.trial_s) / 2
            v.advance(half / app.config["TIME_ACCELERATION"])  # mid-trial restart
            app = _restart(app, database_url)
            v = visitor(app, token)
            again = v.page()
            assert again.interface["data-stream-url"] == page.interface["data-stream-url"]
            bot = ParticipantBot(app, token, seed=len(seen))
            bot.client = v.client
            bot.supervise(again, kind, BotReport(code=""))
        else:
            bot.act(again, BotReport(code=""))
    assert seen.count("live") == 6 and ("mental_rotation", "part_1") in seen
    app.extensions["hcss_db"].engine.dispose()


def test_a_trial_whose_deadline_passed_while_away_is_run_to_its_end(demo_app) -> None:
    from sqlalchemy import select

    from hcss.platform.models import TrialStatusChange

    token = new_participant(demo_app, is_bot=True)
    v = visitor(demo_app, token)
    walk_to(v, "training", "ready")
    assert v.submit({}).status_code == 302
    assert v.page().interface  # on the Collective Interface
    (run,) = [e for e in events(demo_app, token) if e.step == "run" and e.kind == "entered"]
    # The browser closes; nobody steps the trial; the participant returns long after.
    v.clock.now = run.deadline.timestamp() + 3600
    page = v.page()
    assert (page.stage, page.step) == ("trial", "ready")
    (done,) = [e for e in events(demo_app, token) if e.step == "run" and e.kind == "submitted"]
    assert done.at == run.deadline
    with demo_app.extensions["hcss_db"].session_scope() as session:
        (ended,) = session.scalars(
            select(TrialStatusChange).where(TrialStatusChange.status == "ended")
        )
        assert ended.reason == "time_limit" and ended.step > 0


def test_the_last_mrt_part_timing_out_still_scores_the_answers_given(demo_app) -> None:
    from hcss.platform.models import Score
    from hcss.questionnaires import mrt

    token = new_participant(demo_app)
    v = visitor(demo_app, token)
    walk_to(v, "mental_rotation", "part_1")  # the demo's only part: 4 items, 60 s
    bank = {item.key: item for item in mrt.item_bank()}
    for _ in range(2):
        page = v.page()
        correct = [str(i) for i in sorted(bank[page.mrt_item].correct)]
        assert v.submit({"chosen": correct}, page).status_code == 302
    assert v.page().mrt_item == "mrt_03"
    v.advance(61.0)
    assert (v.page().stage, v.page().step) == ("mental_rotation", "time_up_1")
    assert "Time is up" in v.html and "You answered 2 of its 4 items" in v.html
    assert v.submit({}).status_code == 302
    assert (v.page().stage, v.page().step) == ("introduction", "page_1")
    with demo_app.extensions["hcss_db"].session_scope() as session:
        scores = {
            s.scale: s.score
            for s in session.scalars(select(Score).where(Score.instrument == "mrt"))
        }
    assert scores == {"total": 2.0, "part_1": 2.0}
