"""Data per study in the console, in Chromium: the export's study choice, search, the table's width.

Two batches on two study files and a participant who came through the demo's
study link; the table shows the recruitment id and finds rows by it, fits a
1024 px window, and the console's export downloads one study's participants
only, their study and its file's digest named in participants.csv.
"""

from __future__ import annotations

import csv
import io
import zipfile

import pytest

from hcss.platform.study.studyfile import load_study
from tests.support.console import sign_in_page

pytestmark = pytest.mark.browser


def _create_batch(page, study: str, count: int) -> tuple[list[str], list[str]]:
    from playwright.sync_api import expect

    page.select_option("#study", study)
    page.fill("#count", str(count))
    page.click("#create-form button[type=submit]")
    expect(page.locator("h1")).to_have_text("Participant links")
    rows = page.locator("#links tbody tr")
    expect(rows).to_have_count(count)
    codes = [rows.nth(i).get_attribute("data-code") for i in range(count)]
    links = [rows.nth(i).locator("input.link").input_value() for i in range(count)]
    page.click("text=Back to the participants")
    return codes, links


def test_the_console_exports_one_study(browser, console_app) -> None:
    from playwright.sync_api import expect

    _app, base = console_app
    context = browser.new_context(viewport={"width": 1366, "height": 768}, accept_downloads=True)
    page = context.new_page()
    sign_in_page(page, base)
    demo, links = _create_batch(page, "demo", 2)
    original, _ = _create_batch(page, "original", 2)
    # One demo participant opens their link: enrolled, with the demo file's digest.
    context.new_page().goto(links[0])

    # A participant from Prolific, through the demo's study link.
    visitor = context.new_page()
    visitor.goto(
        f"{base}/join/demo?PROLIFIC_PID=5f8a1b2c3d4e5f6a7b8c9d0e&STUDY_ID=S1&SESSION_ID=X1"
    )
    visitor.locator("#join-start").click()
    expect(visitor.locator("main.study")).to_have_attribute("data-stage", "consent")
    linked = visitor.locator(".participant-code").first.inner_text()
    visitor.close()

    page.reload()
    row = page.locator(f'#progress tr[data-code="{linked}"]')
    expect(row.locator(".recruitment")).to_have_text("prolific 5f8a1b2c3d4e5f6a7b8c9d0e")
    expect(page.locator(f'#progress tr[data-code="{original[0]}"] .session')).to_have_text(
        "not started"
    )
    page.fill("#search", "5F8A1B")  # any case, part of the id: the server searches every page
    expect(page.locator("#progress tbody tr:visible")).to_have_count(1)
    expect(row).to_be_visible()
    expect(row.locator(".recruitment mark")).to_have_text("5f8a1b")  # the match, marked
    expect(page.locator("#page-of")).to_contain_text("1 participants matching “5f8a1b”")
    page.fill("#search", "demo not started")
    expect(page.locator("#progress tbody tr:visible")).to_have_count(1)  # demo[1]; demo[0] opened
    page.fill("#search", "")
    expect(page.locator("#progress tbody tr:visible")).to_have_count(5)
    page.check("#select-all")  # every row of the page, for the bulk actions
    expect(page.locator("#progress tbody input.select:checked")).to_have_count(5)
    expect(page.locator("#bulk-action option")).to_have_text(
        ["Pause", "Resume", "Mark pilot", "Unmark pilot", "Abort"]
    )
    page.uncheck("#select-all")
    page.set_viewport_size({"width": 1024, "height": 768})
    width = page.evaluate("document.documentElement.scrollWidth")
    assert width <= 1024, f"the console is {width} px wide at 1024"
    page.set_viewport_size({"width": 1366, "height": 768})

    expect(page.locator("#export-study option")).to_have_text(["every study", "demo", "original"])
    page.select_option("#export-study", "demo")
    with page.expect_download() as download:
        page.click("#export-download")
    assert download.value.suggested_filename.startswith("hcss-export-demo-")
    with zipfile.ZipFile(download.value.path()) as archive:
        (name,) = [n for n in archive.namelist() if n.endswith("/participants.csv")]
        rows = list(csv.DictReader(io.StringIO(archive.read(name).decode("utf-8"))))
    assert sorted(r["participant"] for r in rows) == sorted([*demo, linked])
    assert {r["study"] for r in rows} == {"demo"}
    digests = {r["participant"]: r["study_digest"] for r in rows}
    assert digests[linked] == load_study("demo").digest
    assert (digests[demo[0]], digests[demo[1]]) == (load_study("demo").digest, "")
    assert not set(original) & {r["participant"] for r in rows}
    context.close()
