"""The demographics page in a maximised laptop's window and in the smallest window the demo
admits: no sideways scroll, every option of every row on screen, and a participant who
picks each row's last option (the education row has 7) gets to the next stage."""

from __future__ import annotations

import pytest

from hcss.questionnaires.demographics import ITEM_KEYS
from tests.support.study_server import StudyServer

pytestmark = pytest.mark.browser

#: A maximised browser on a 1366 x 768 laptop, and the smallest window `[requirements]` admit.
WINDOWS = ({"width": 1366, "height": 657}, {"width": 1024, "height": 620})

#: How far the page reaches past the window sideways, and the options that end past it.
OVERFLOW = """() => {
  const W = document.documentElement.clientWidth;
  const out = Array.from(document.querySelectorAll('form input[type=radio]'))
    .map((n) => n.closest('label') || n)
    .filter((n) => n.getBoundingClientRect().right > W || n.getBoundingClientRect().left < 0)
    .map((n) => n.textContent.trim());
  return {scroll: document.documentElement.scrollWidth - W, out: out};
}"""


@pytest.mark.parametrize("window", WINDOWS, ids=lambda w: f"{w['width']}x{w['height']}")
def test_demographics_fits_the_window_and_its_last_options_can_be_picked(
    browser, demo_server: StudyServer, window: dict[str, int]
) -> None:
    from playwright.sync_api import expect

    page = browser.new_page(viewport=window)
    page.goto(f"{demo_server.url}/p/{demo_server.participant()}")
    page.get_by_label("I agree").check()
    page.get_by_role("button", name="Continue").click()
    expect(page.locator("main.study")).to_have_attribute("data-stage", "demographics")
    page.wait_for_load_state()  # the whole page laid out, not the part parsed so far
    fits = page.evaluate(OVERFLOW)
    assert fits == {"scroll": 0, "out": []}, fits
    for key in ITEM_KEYS:
        options = page.locator(f'input[name="{key}"]')
        options.nth(options.count() - 1).click()  # a real click: it must be reachable
    page.get_by_role("button", name="Continue").click()
    expect(page.locator("main.study")).to_have_attribute("data-stage", "mental_rotation")
    page.close()
