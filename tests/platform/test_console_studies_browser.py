"""Data per study in the console, in Chromium: the export's study choice.

Two batches on two study files; the console's export downloads one study's
participants only, their study and its file's digest named in participants.csv.
"""

from __future__ import annotations

import csv
import io
import zipfile

import pytest

from hcss.platform.study.studyfile import load_study
from tests.platform.test_console_browser import PASSWORD, USERNAME, console_app  # noqa: F401 - a fixture

pytestmark = pytest.mark.browser


def _create_batch(page, study: str, count: int) -> tuple[list[str], list[str]]:  # type: ignore[no-untyped-def]
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


def test_the_console_exports_one_study(browser, console_app) -> None:  # type: ignore[no-untyped-def]  # noqa: F811
    from playwright.sync_api import expect

    _app, base = console_app
    context = browser.new_context(viewport={"width": 1366, "height": 768}, accept_downloads=True)
    page = context.new_page()
    page.goto(f"{base}/console/")
    page.fill("#username", USERNAME)
    page.fill("#password", PASSWORD)
    page.click("button[type=submit]")
    expect(page.locator("h1")).to_have_text("Participants")
    demo, links = _create_batch(page, "demo", 2)
    original, _ = _create_batch(page, "original", 2)
    # One demo participant opens their link: enrolled, with the demo file's digest.
    context.new_page().goto(links[0])

    page.reload()
    expect(page.locator("#export-study option")).to_have_text(["every study", "demo", "original"])
    page.select_option("#export-study", "demo")
    with page.expect_download() as download:
        page.click("#export-download")
    assert download.value.suggested_filename.startswith("hcss-export-demo-")
    with zipfile.ZipFile(download.value.path()) as archive:
        (name,) = [n for n in archive.namelist() if n.endswith("/participants.csv")]
        rows = list(csv.DictReader(io.StringIO(archive.read(name).decode("utf-8"))))
    assert sorted(r["participant"] for r in rows) == sorted(demo)
    assert {r["study"] for r in rows} == {"demo"}
    digests = {r["participant"]: r["study_digest"] for r in rows}
    assert (digests[demo[0]], digests[demo[1]]) == (load_study("demo").digest, "")
    assert not set(original) & {r["participant"] for r in rows}
    context.close()
