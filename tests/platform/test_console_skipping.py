"""A skip reaches the participant's open page: its heartbeat learns of it and the page moves
on; answers sent from the skipped page are kept apart, never dropped; a skip to a chosen
stage is one action."""

from __future__ import annotations

import re

from sqlalchemy import select

from hcss.platform.bots.participant import parse_page
from hcss.platform.models import ConsoleAction, StageEvent
from tests.support.study import Visitor, events, visitor

LINK = re.compile(r'value="(http://localhost/p/[A-Za-z0-9_-]+)"')


def _guest(app, console) -> tuple[str, Visitor]:
    console.post("/console/participants", {"count": "1", "study": "demo"})
    (code,) = console.progress()
    (link,) = LINK.findall(console.get("/console/links").get_data(as_text=True))
    guest = visitor(app, link.rsplit("/", 1)[-1])
    guest.submit({"decision": "agree"})
    return code, guest


def _beat(guest: Visitor, stage: int, step: str):
    return guest.client.post(
        f"/p/{guest.token}/heartbeat",
        json={"page": "study", "hidden": False, "stage": stage, "step": step},
    )


def test_a_skipped_page_moves_on_and_its_answers_are_kept_apart(app, console) -> None:
    code, guest = _guest(app, console)
    demographics = guest.page()
    assert 'data-stage="demographics"' in guest.html
    index, step = demographics.action.rsplit("/", 2)[-2:]
    assert _beat(guest, int(index), step).status_code == 204  # nothing happened yet

    assert console.act(code, "skip_stage").status_code == 303
    moved = _beat(guest, int(index), step)
    assert moved.status_code == 200 and moved.get_json() == {"moved_on": True}

    # The page was open with answers ticked: its Continue keeps them, apart, and says why.
    answers = {"age_band": "18-30", "gender": "woman"}
    answer = guest.submit(answers, page=demographics)
    assert answer.status_code == 200
    assert "The experimenter moved you on" in guest.html
    assert "The answers you gave on it were kept." in guest.html
    assert "not accepted" not in guest.html
    (late,) = [e for e in events(app, guest.token) if e.kind == "late_answer"]
    assert late.stage == "demographics" and late.step == step
    assert late.detail == {"answers": {"age_band": ["18-30"], "gender": ["woman"]}}
    guest.submit(answers, page=demographics)  # again: the first is kept, nothing more
    assert [e.kind for e in events(app, guest.token)].count("late_answer") == 1
    # They are not the stage's answers: the export's questionnaire items have none.
    with app.extensions["hcss_db"].session_scope() as session:
        from hcss.platform.models import QuestionnaireItem

        assert session.scalars(select(QuestionnaireItem)).all() == []
    guest.page()
    assert 'data-stage="mental_rotation"' in guest.html
    mrt = parse_page(guest.html)
    now_index, now_step = mrt.action.rsplit("/", 2)[-2:]
    assert _beat(guest, int(now_index), now_step).status_code == 204


def test_a_bad_heartbeat_step_is_refused(app, console) -> None:
    _, guest = _guest(app, console)
    for body in (
        {"page": "study", "stage": 1},
        {"page": "study", "stage": "1", "step": "form"},
        {"page": "study", "stage": 1, "step": "../x"},
        {"page": "study", "stage": True, "step": "form"},
        {"page": "study", "stage": 5000, "step": "form"},
    ):
        beat = guest.client.post(f"/p/{guest.token}/heartbeat", json=body)
        assert beat.status_code == 400, body


def test_skip_to_a_chosen_stage_is_one_action(app, console) -> None:
    code, guest = _guest(app, console)
    guest.page()
    page = console.get(f"/console/participants/{code}").get_data(as_text=True)
    options = dict(
        (label, number)
        for number, label in re.findall(r'<option value="(\d+)">([^<]+)</option>', page)
    )
    target = next(label for label in options if "screen_check" in label)
    assert "stage 2 demographics" not in options  # only stages after the current one
    answer = console.post(f"/console/participants/{code}/skip_stage", {"to_stage": options[target]})
    assert answer.status_code == 303
    flashed = console.get("/console/").get_data(as_text=True)
    assert re.search(r"skipped stages 2-\d+ \(\d+ steps\) to " + re.escape(target), flashed)
    assert console.progress()[code]["stage"] == "screen_check"
    guest.page()
    assert 'data-stage="screen_check"' in guest.html
    with app.extensions["hcss_db"].session_scope() as session:
        (action,) = session.scalars(
            select(ConsoleAction).where(ConsoleAction.action == "skip_stage")
        ).all()
        assert action.detail.endswith(f"to {target}")
        skipped = session.scalars(select(StageEvent).where(StageEvent.kind == "skipped")).all()
    assert len(skipped) >= 6 and {e.stage for e in skipped} >= {"demographics", "introduction"}
    # Back, or to where they are, or past the end, or not a number: nothing changes.
    for bad in (options[target], "1", "999"):
        console.post(f"/console/participants/{code}/skip_stage", {"to_stage": bad})
        assert console.progress()[code]["stage"] == "screen_check"
    assert (
        console.post(f"/console/participants/{code}/skip_stage", {"to_stage": "x"}).status_code
        == 400
    )
