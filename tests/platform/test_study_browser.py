"""The study pages in a real browser: Chromium through Playwright, against a live server.

From the personal link through consent and demographics to the first MRT
item, clicking as a participant does; the MRT item's screenshot goes to
test-artifacts/, and to docs/screenshot-mrt.png with HCSS_UPDATE_SCREENSHOTS=1.
"""

from __future__ import annotations

import re

import pytest
from sqlalchemy import select

from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.models import ConsentRecord, Participant, QuestionnaireItem
from hcss.platform.serving.localserver import LocalServer
from hcss.platform.study import assign_cell
from hcss.questionnaires.demographics import ITEM_KEYS
from tests.support.screenshots import screenshot

pytestmark = pytest.mark.browser


@pytest.fixture
def study_server(tmp_path):
    url = f"sqlite:///{tmp_path / 'study-browser.sqlite3'}"
    upgrade_database(url)
    database = Database(url)
    with database.session_scope() as session:
        participant = Participant()
        session.add(participant)
        session.flush()
        assign_cell(session, participant, study="original")
        token = participant.token
    with LocalServer(url, tmp_path / "instance", extra_env={"HCSS_STUDY": "original"}) as server:
        yield server, token, database
    database.engine.dispose()


def test_consent_to_the_first_mrt_item_in_the_browser(browser, study_server) -> None:
    from playwright.sync_api import expect

    server, token, database = study_server
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    page.goto(f"{server.url}/p/{token}")

    expect(page.locator("main.study")).to_have_attribute("data-stage", "consent")
    expect(page.locator("h1").first).to_have_text("Consent to take part")
    page.get_by_label("I agree").check()
    page.get_by_role("button", name="Continue").click()

    expect(page.locator("main.study")).to_have_attribute("data-stage", "demographics")
    page.get_by_role("button", name="Continue").click()  # nothing answered: the browser stops it
    expect(page.locator("main.study")).to_have_attribute("data-stage", "demographics")
    for key in ITEM_KEYS:
        page.locator(f'input[name="{key}"]').first.check()
    page.get_by_role("button", name="Continue").click()

    expect(page.locator("main.study")).to_have_attribute("data-step", "instructions")
    expect(page.locator("article.text")).to_contain_text("target figure")
    page.get_by_role("button", name="Begin").click()

    expect(page.locator("main.study")).to_have_attribute("data-step", "practice_1")
    expect(page.locator(".mrt-alternative svg")).to_have_count(4)
    expect(page.locator(".mrt-target svg")).to_have_count(1)
    screenshot(page, "study-mrt-item.png", docs_name="screenshot-mrt.png", full_page=True)

    page.locator('input[name="chosen"][value="0"]').check()
    page.locator('input[name="chosen"][value="1"]').check()
    page.get_by_role("button", name="Check").click()
    expect(page.locator(".feedback")).to_contain_text(re.compile("^(Correct|Not quite)"))
    screenshot(page, "study-mrt-feedback.png", full_page=True)
    page.close()

    with database.session_scope() as session:
        (consent,) = session.scalars(select(ConsentRecord))
        items = {
            (r.instrument, r.item): r.value for r in session.scalars(select(QuestionnaireItem))
        }
    assert consent.decision == "agree"
    assert {key for (instrument, key) in items if instrument == "demographics"} == set(ITEM_KEYS)
    assert items[("mrt", "mrt_practice_1")] == "0,1"
