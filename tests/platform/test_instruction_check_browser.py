"""The demo's instruction check in Chromium: a wrong try, the page re-read, a right try.

The participant is brought to the check by the bots' answers (the pages
before it have browser tests of their own), then clicks as a participant
does; the export written afterwards holds both tries and the scores.
"""

from __future__ import annotations

import re

import pytest

from hcss.platform.export.writer import write_export
from hcss.platform.study.studyfile import load_study
from tests.support.axe import axe_violations, summary
from tests.support.exports import read_csv
from tests.support.study import visitor, walk_to
from tests.support.study_server import StudyServer

pytestmark = pytest.mark.browser


def test_a_wrong_answer_sends_the_participant_to_reread_then_a_right_one_passes(
    browser, demo_server: StudyServer, tmp_path
) -> None:
    from playwright.sync_api import expect

    check = load_study("demo").instruction_check
    assert check is not None
    token = demo_server.participant()
    walk_to(visitor(demo_server.app, token), "instruction_check", "try_1")

    page = browser.new_page(viewport={"width": 1024, "height": 620})
    page.goto(f"{demo_server.url}/p/{token}")
    study = page.locator("main.study")
    expect(study).to_have_attribute("data-step", "try_1")
    expect(page.locator("h1")).to_have_text("Checking the instructions")
    # Nothing answered: the browser itself asks for an answer (required radios).
    page.get_by_role("button", name="Check my answers").click()
    expect(study).to_have_attribute("data-step", "try_1")

    # Try 1: the blue half taken for the target's value.
    for item in check.items:
        wrong = item.key == "blue_half"
        choice = "How valuable it is" if wrong else item.answer
        page.get_by_role("group", name=item.question).get_by_label(choice, exact=True).check()
    assert axe_violations(page) == [], summary(axe_violations(page))
    page.get_by_role("button", name="Check my answers").click()

    # The page that explains it, to read again; not the answer.
    expect(study).to_have_attribute("data-step", "reread_1")
    expect(page.locator("#check-missed")).to_have_text("1 of your answers was not right:")
    expect(page.locator(".check-missed-list li")).to_have_text(
        ["What does the blue bottom half of a target show?"]
    )
    expect(page.locator("article.reread h1")).to_have_text(["The targets"])
    expect(page.locator("article.reread")).to_contain_text("bottom half is blue")
    assert page.evaluate("() => document.scrollingElement.scrollWidth - innerWidth") <= 0
    assert axe_violations(page) == [], summary(axe_violations(page))
    page.get_by_role("button", name="Back to the questions").click()

    # Try 2: the question missed is marked; every answer right now.
    expect(study).to_have_attribute("data-step", "try_2")
    expect(page.locator("#check-again")).to_contain_text("Try 2 of 2")
    expect(page.locator(".check-missed")).to_have_count(1)
    for item in check.items:
        page.get_by_role("group", name=item.question).get_by_label(item.answer, exact=True).check()
    assert axe_violations(page) == [], summary(axe_violations(page))
    page.get_by_role("button", name="Check my answers").click()
    expect(study).to_have_attribute("data-stage", "screen_check")
    page.close()

    with demo_server.database.session_scope() as session:
        write_export(session, tmp_path / "export")
    _, items = read_csv(tmp_path / "export" / "questionnaire_items.csv")
    tries = {
        r["item"]: r["value"]
        for r in items
        if r["instrument"] == "instruction_check" and re.search(r"_try_\d$", r["item"])
    }
    assert tries["blue_half_try_1"] == "How valuable it is"
    assert tries["blue_half_try_2"] == "How much support it has"
    assert len(tries) == 2 * len(check.items)
    _, scores = read_csv(tmp_path / "export" / "scores.csv")
    assert {r["scale"]: r["score"] for r in scores if r["instrument"] == "instruction_check"} == {
        "passed": "1.0",
        "tries": "2.0",
    }
