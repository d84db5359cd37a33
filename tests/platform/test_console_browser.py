"""The experimenter's console in a real browser, while a participant bot walks the demo study.

Chromium (Playwright) signs in, creates a batch of three on the `demo` study,
copies links (read back from the clipboard) and downloads their CSV. One link
goes to a bot, which walks the whole study through the same app while the
table is watched moving through the stages to "completed"; another is opened
in a second tab, whose heartbeats make its row "connected"; that participant
is paused and resumed from the table. The table's screenshot goes to
test-artifacts/, and to docs/ only when HCSS_UPDATE_SCREENSHOTS=1.
"""

from __future__ import annotations

import csv
import re
import threading
import time

import pytest
from sqlalchemy import select

from hcss.platform.bots.participant import ParticipantBot
from hcss.platform.models import ConsoleAction, Participant, StudyEnrolment
from hcss.platform.study.studyfile import load_study
from tests.support.console import sign_in_page, writers_held
from tests.support.screenshots import screenshot

pytestmark = pytest.mark.browser

USERNAME, PASSWORD = "lab", "a long enough password"


def _row(page, code: str):
    return page.locator(f'#progress tr[data-code="{code}"]')


def test_console_batch_links_live_table_and_pause_resume(browser, console_app) -> None:
    from playwright.sync_api import expect

    app, base = console_app
    database = app.extensions["hcss_db"]
    context = browser.new_context(viewport={"width": 1500, "height": 800}, accept_downloads=True)
    context.grant_permissions(["clipboard-read", "clipboard-write"], origin=base)
    page = context.new_page()

    # Sign in, then create a batch of three on the demo study (the server's default is original).
    sign_in_page(page, base)
    expect(page.locator("#study")).to_have_value("original")
    page.select_option("#study", "demo")
    page.fill("#count", "3")
    page.click("#create-form button[type=submit]")

    # The batch page: every link, a copy button each, all links at once, and a CSV.
    expect(page.locator("h1")).to_have_text("Participant links")
    rows = page.locator("#links tbody tr")
    expect(rows).to_have_count(3)
    codes = [rows.nth(i).get_attribute("data-code") for i in range(3)]
    links = [rows.nth(i).locator("input.link").input_value() for i in range(3)]
    assert all(re.fullmatch(rf"{base}/p/[A-Za-z0-9_-]{{32}}", link) for link in links)
    rows.nth(1).locator("button.copy").click()
    expect(rows.nth(1).locator("button.copy")).to_have_text("Copied")
    assert page.evaluate("navigator.clipboard.readText()") == links[1]
    page.click("#copy-all")
    expect(page.locator("#copy-all")).to_have_text("Copied")  # the copy has been made
    assert page.evaluate("navigator.clipboard.readText()").split("\n") == links
    with page.expect_download() as download:
        page.click("#links-csv")
    with open(download.value.path(), newline="") as handle:
        table = list(csv.DictReader(handle))
    assert [(r["code"], r["study"], r["link"]) for r in table] == list(
        zip(codes, ["demo"] * 3, links, strict=True)
    )

    # Back to the live table: each row shows its study, no cell before the first visit.
    page.click("text=Back to the participants")
    for code in codes:
        expect(_row(page, code).locator(".study")).to_have_text("demo · cell at first visit")
        expect(_row(page, code).locator(".presence")).to_contain_text("never seen")
    walker, visitor, _idle = codes

    # The second participant opens their link in another tab: their page beats.
    participant_page = context.new_page()
    participant_page.goto(links[1])
    expect(participant_page.locator("main.study")).to_have_attribute("data-stage", "consent")
    expect(_row(page, visitor).locator(".presence")).to_contain_text("connected", timeout=10_000)
    expect(_row(page, visitor).locator(".stage-of")).to_have_text(re.compile(r"stage 1 of \d+"))

    # The first link is handed to a bot; the table follows it through the study.
    with database.session_scope() as session:
        token = session.scalars(select(Participant.token).where(Participant.code == walker)).one()
    failures: list[BaseException] = []

    def walk() -> None:
        try:
            ParticipantBot(app, token, seed=3, tick_s=6.0).run(load_study("demo"))
        except BaseException as error:  # noqa: BLE001 - reported by the test below
            failures.append(error)

    bot = threading.Thread(target=walk, daemon=True)
    bot.start()
    seen: list[str] = []
    deadline = time.monotonic() + 120
    while bot.is_alive() and time.monotonic() < deadline:
        text = _row(page, walker).locator(".stage").inner_text()
        if not seen or seen[-1] != text:
            seen.append(text)
        page.wait_for_timeout(100)
    bot.join(timeout=1)
    assert not failures, failures
    assert not bot.is_alive(), "the bot did not finish the demo study in 120 s"
    numbers = [int(m.group(1)) for s in seen if (m := re.search(r"stage (\d+) of", s))]
    # The table refreshes every 2 s and the bot is fast: at least three stages are seen.
    assert len(set(numbers)) >= 3 and numbers == sorted(numbers), seen
    walker_row = _row(page, walker)
    expect(walker_row.locator(".session")).to_have_text("completed")
    expect(walker_row.locator("button[data-action]")).to_have_count(1)  # only Mark pilot
    expect(walker_row.locator('button[data-action="mark_pilot"]')).to_have_count(1)

    # The experimenter marks the walker as a pilot (an event: participants are append-only);
    # hiding pilots then hides the walker's row, and only it.
    walker_row.locator('button[data-action="mark_pilot"]').click()
    expect(walker_row.locator('button[data-action="unmark_pilot"]')).to_have_count(1)
    page.check("#hide-pilot")
    expect(walker_row).to_be_hidden()
    expect(_row(page, visitor)).to_be_visible()
    expect(page.locator("#shown-count")).to_have_text("showing 2 of 3")
    page.uncheck("#hide-pilot")
    expect(walker_row).to_be_visible()

    # Pause the visitor from the table: Resume replaces Pause, and their page is held.
    visitor_row = _row(page, visitor)
    # Pause, Abort, Skip, Mark pilot
    expect(visitor_row.locator("button[data-action]")).to_have_count(4)
    visitor_row.locator('button[data-action="pause"]').click()
    expect(page.locator(".flashes")).to_contain_text(f"{visitor}: pause done")
    expect(visitor_row.locator(".session")).to_have_text("paused")
    expect(visitor_row.locator('button[data-action="pause"]')).to_have_count(0)
    participant_page.reload()
    expect(participant_page.locator("body")).to_contain_text("paused")
    visitor_row.locator('button[data-action="resume"]').click()
    expect(visitor_row.locator(".session")).to_have_text("active")
    expect(visitor_row.locator('button[data-action="resume"]')).to_have_count(0)
    expect(visitor_row.locator('button[data-action="pause"]')).to_have_count(1)
    participant_page.reload()
    expect(participant_page.locator("main.study")).to_have_attribute("data-stage", "consent")
    expect(visitor_row.locator(".presence")).to_contain_text("connected", timeout=10_000)
    with database.session_scope() as session:
        actions = session.scalars(
            select(ConsoleAction.action)
            .join(Participant, Participant.id == ConsoleAction.participant_id)
            .where(Participant.code == visitor)
            .order_by(ConsoleAction.id)
        ).all()
        enrolled = set(session.scalars(select(StudyEnrolment.study)))
    assert actions == ["create", "pause", "resume"] and enrolled == {"demo"}

    page.wait_for_timeout(500)  # one more poll, so the screenshot shows the table as served
    screenshot(page.locator("#progress"), "console-table.png", docs_name="screenshot-console.png")

    # The participant's own console page copies their link too.
    visitor_row.locator("a").click()
    expect(page.locator("h1")).to_have_text(f"Participant {visitor}")
    page.click("button.copy")
    expect(page.locator("button.copy")).to_have_text("Copied")
    assert page.evaluate("navigator.clipboard.readText()") == links[1]
    context.close()


def test_a_double_click_on_create_makes_one_batch(browser, console_app) -> None:
    """An experimenter's double click on Create sends the form once: one batch of three links,
    not two (each counting against the experimenter's link allowance). The server is slow to
    answer the first click (another writer holds the database for a moment), so the second
    click lands on the same page, as on a loaded lab server."""
    from playwright.sync_api import expect

    app, base = console_app
    database = app.extensions["hcss_db"]
    page = browser.new_page(viewport={"width": 1500, "height": 800})
    sign_in_page(page, base)
    page.select_option("#study", "demo")
    page.fill("#count", "3")
    with writers_held(database):  # the create waits for this writer
        page.evaluate(
            """() => {
                const create = document.querySelector('#create-form button[type=submit]');
                create.click();
                setTimeout(() => create.click(), 150);
            }"""
        )
        page.wait_for_timeout(600)  # both clicks made, on the page the first left
    expect(page.locator("h1")).to_have_text("Participant links")
    expect(page.locator("#links tbody tr")).to_have_count(3)
    page.wait_for_timeout(1000)  # a second request, had one gone out, has been answered
    with database.session_scope() as session:
        assert len(session.scalars(select(Participant)).all()) == 3
        creates = session.scalars(select(ConsoleAction).where(ConsoleAction.action == "create"))
        assert len(creates.all()) == 3
    # Back on the table, Create works again: the guard is the page's, not the form's for good
    page.click("text=Back to the participants")
    page.fill("#count", "1")
    page.click("#create-form button[type=submit]")
    expect(page.locator("h1")).not_to_have_text("Participants")  # one: its own page
    with database.session_scope() as session:
        assert len(session.scalars(select(Participant)).all()) == 4
    page.close()
