"""The study link's first page in Chromium: the device is checked before consent.

A phone is turned away at once with the study's screen-out code, and nothing
but a screen-out row is kept; a laptop whose window is too small is asked to
enlarge it; a laptop that declines consent gets the same way back.
"""

from __future__ import annotations

import time
from urllib.parse import urlencode

import pytest
from sqlalchemy import select

from hcss.platform.models import ConsentRecord, Participant, ScreenOut, StageEvent
from tests.support.counting import count_rows
from tests.support.inprocess import serving

pytestmark = pytest.mark.browser

PROLIFIC = {"PROLIFIC_PID": "5f8a1b2c3d4e5f6a7b8c9d01", "STUDY_ID": "S1", "SESSION_ID": "X1"}
SCREEN_OUT_URL = "https://app.prolific.com/submissions/complete?cc=DEMOSCREEN"
RETURN_URL = "https://app.prolific.com/submissions/complete?cc=DEMORETURN"


def test_a_phone_is_screened_out_before_consent_and_a_small_window_is_asked_to_grow(
    browser,
    demo_bot_app,
) -> None:
    from playwright.sync_api import expect

    with serving(demo_bot_app) as url:
        link = f"{url}/join/demo?{urlencode(PROLIFIC)}"
        phone = browser.new_context(
            viewport={"width": 375, "height": 812}, is_mobile=True, has_touch=True
        )
        page = phone.new_page()
        page.goto(link)
        expect(page.locator("main.study")).to_have_attribute("data-stage", "screened_out")
        expect(page.locator("#screen-out-reasons")).to_contain_text("desktop or laptop")
        expect(page.locator("#screen-out-code")).to_have_text("DEMOSCREEN")
        expect(page.locator("#screen-out-link")).to_have_attribute("href", SCREEN_OUT_URL)
        phone.close()
        assert (
            count_rows(demo_bot_app, Participant) == 0 and count_rows(demo_bot_app, StageEvent) == 0
        )
        with demo_bot_app.extensions["hcss_db"].session_scope() as session:
            row = session.scalars(select(ScreenOut)).one()
            assert (row.recruitment_id, row.mobile, row.width) == (
                PROLIFIC["PROLIFIC_PID"],
                True,
                375,
            )

        # A laptop's window too small (a 1280 x 720 screen with a bookmarks bar): asked to
        # maximise, go full screen or zoom out; Start once it is large enough, checked live.
        page = browser.new_page(viewport={"width": 1280, "height": 590})
        page.goto(link)
        expect(page.locator("#window-too-small")).to_be_visible()
        expect(page.locator("#window-too-small")).to_contain_text("1280 x 590")
        expect(page.locator("#window-too-small")).to_contain_text("F11")
        expect(page.locator("#window-too-small")).to_contain_text("zoom out")
        expect(page.locator("#join-start")).to_be_disabled()
        assert count_rows(demo_bot_app, Participant) == 0
        # Maximised on a 1366 x 768 laptop (1366 x 657), or 1280 x 800 (1280 x 690): admitted.
        for width, height in ((1280, 690), (1366, 625), (1366, 657)):
            page.set_viewport_size({"width": width, "height": height})
            expect(page.locator("#device-ok")).to_be_visible()
            expect(page.locator("#window-too-small")).to_be_hidden()
        page.locator("#join-start").click()
        expect(page.locator("main.study")).to_have_attribute("data-stage", "consent")
        assert count_rows(demo_bot_app, Participant) == 1

        # Declining consent: asked to return the submission, with the study's return code.
        page.get_by_label("I do not agree").check()
        page.get_by_role("button", name="Continue").click()
        page.get_by_role("button", name="Confirm").click()
        expect(page.locator("main.study")).to_have_attribute("data-stage", "declined")
        expect(page.locator("#return-submission")).to_contain_text("return your submission")
        expect(page.locator("#return-code")).to_have_text("DEMORETURN")
        expect(page.locator("#return-link")).to_have_attribute("href", RETURN_URL)
        assert count_rows(demo_bot_app, ConsentRecord) == 1
        assert count_rows(demo_bot_app, ScreenOut) == 1  # the phone's; a decline is its own record
        page.close()


def test_a_double_submit_sends_the_form_once(browser, demo_bot_app) -> None:
    from playwright.sync_api import expect

    with serving(demo_bot_app) as url:
        page = browser.new_page(viewport={"width": 1366, "height": 768})
        # The quickest clumsy participant: a double click on Continue the moment the
        # consent form is on screen, while the page's scripts are still on a slow line
        # (each held back 300 ms). The second submit is held back by the page
        # (whether the browser would have sent it or not). A guard that ran only once
        # the page had loaded let both through, now and then, on a loaded machine.
        page.add_init_script(
            """(() => {
                if (sessionStorage.getItem('sent')) return;
                const timer = setInterval(() => {
                    const form = document.getElementById('stage-form');
                    const agree = [...document.querySelectorAll('#stage-form label')]
                        .find((label) => label.textContent.trim() === 'I agree');
                    if (!form || !agree || !document.getElementById('consent-submit')) return;
                    clearInterval(timer);
                    agree.control.checked = true;
                    const sent = [];
                    form.addEventListener('submit', (e) => sent.push(!e.defaultPrevented));
                    form.requestSubmit(); form.requestSubmit();
                    sessionStorage.setItem('sent', JSON.stringify(sent));
                }, 2);
            })();"""
        )
        page.route("**/static/*.js", lambda route: (time.sleep(0.3), route.continue_()))
        page.goto(f"{url}/join/demo")
        page.locator("#join-start").click()
        expect(page.locator("main.study")).to_have_attribute("data-stage", "demographics")
        assert page.evaluate("JSON.parse(sessionStorage.getItem('sent'))") == [True, False]
        expect(page.locator("main")).not_to_contain_text("already been submitted")
        page.close()


def test_a_submit_the_page_cancelled_leaves_the_form_sendable(browser, demo_bot_app) -> None:
    """The guard counts a form as sent only when the submit went ahead: a submit a page's
    own handler cancelled (a confirm declined, a check that failed) leaves Continue working."""
    from playwright.sync_api import expect

    with serving(demo_bot_app) as url:
        page = browser.new_page(viewport={"width": 1366, "height": 768})
        page.goto(f"{url}/join/demo")
        page.locator("#join-start").click()
        expect(page.locator("main.study")).to_have_attribute("data-stage", "consent")
        page.wait_for_load_state()
        page.get_by_label("I agree").check()
        page.evaluate(
            """() => {
                const form = document.getElementById('stage-form');
                let asked = false;
                form.addEventListener('submit', (e) => { if (!asked) { asked = true; e.preventDefault(); } });
            }"""
        )
        page.get_by_role("button", name="Continue").click()  # cancelled by the page
        expect(page.locator("main.study")).to_have_attribute("data-stage", "consent")
        page.get_by_role("button", name="Continue").click()  # and now sent
        expect(page.locator("main.study")).to_have_attribute("data-stage", "demographics")
        page.close()
