"""What the live page shows around a probe, in Chromium: crowded targets' numbers, swallowed keys.

- Two targets found at almost the same place: each number is drawn clear of the
  other target and of the other number, so a probe asking about either can be
  answered from the map (with a leader line where a number had to move off).
- A key pressed too soon after the question shows does nothing, and the box
  says why; a key on the question itself says how to answer.
"""

from __future__ import annotations

import json
import re

import pytest

from tests.support.pages import live_trial, open_live_trial, start_live_trial, wait_for
from tests.support.screenshots import screenshot
from tests.support.study_server import StudyServer

pytestmark = pytest.mark.browser

#: For each target's number: its box, and whether the point at its centre shows the number
#: itself (nothing of another target drawn over it).
NUMBERS = """() => Array.from(document.querySelectorAll('#layer-targets g.target'), (g) => {
  const label = g.querySelector('.target-id'), r = label.getBoundingClientRect();
  const leader = g.querySelector('.target-leader');
  const hit = document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2);
  return {id: Number(g.dataset.target), box: [r.left, r.top, r.right, r.bottom],
          shown: hit === label, leader: !!leader && leader.getAttribute('display') !== 'none',
          x: Number(label.getAttribute('x'))};
})"""


def overlaps(a: list[float], b: list[float]) -> bool:
    return min(a[2], b[2]) > max(a[0], b[0]) and min(a[3], b[3]) > max(a[1], b[1])


def test_crowded_targets_keep_their_numbers_apart_and_readable(
    browser, demo_server: StudyServer
) -> None:
    from playwright.sync_api import expect

    token = start_live_trial(demo_server)
    demo_server.advance(0.0)  # the runner takes the trial up
    live = live_trial(demo_server)
    assert wait_for(demo_server, lambda lv: len(lv.view()["targets"]) >= 3, 60)
    frame = json.loads(
        demo_server.app.test_client()
        .get(f"/api/live/{token}/trials/{live.trial_id}/state")
        .get_data(as_text=True)
    )
    targets = frame["view"]["targets"]
    first, second = targets[0], targets[1]
    # The second found 4 m from the first: 2 to 3 screen pixels apart at this window.
    second["position"] = [first["position"][0] + 4.0, first["position"][1] - 3.0]
    body = f"retry: 600000\ndata: {json.dumps(frame)}\n\n"

    page = browser.new_page(viewport={"width": 1024, "height": 620})
    page.route(
        re.compile(r".*/stream(\?.*)?$"),
        lambda route: route.fulfill(
            status=200, headers={"Content-Type": "text/event-stream"}, body=body
        ),
    )
    page.goto(f"{demo_server.url}/live/{token}")
    expect(page.locator("#layer-targets g.target")).to_have_count(len(targets))
    screenshot(page, "crowded-target-numbers.png")
    numbers = {n["id"]: n for n in page.evaluate(NUMBERS)}
    a, b = numbers[first["id"]], numbers[second["id"]]
    assert not overlaps(a["box"], b["box"]), (a, b)
    assert a["shown"] and b["shown"], (a, b)
    assert a["x"] == 29 and not a["leader"]  # the first keeps the usual spot
    lone = [n for i, n in numbers.items() if i not in (first["id"], second["id"])]
    assert all(n["x"] == 29 and not n["leader"] for n in lone if n["shown"]), lone
    page.close()


def test_a_key_too_soon_after_the_question_says_why_it_did_nothing(
    browser, demo_server: StudyServer
) -> None:
    from playwright.sync_api import expect

    _, page = open_live_trial(browser, demo_server, {"width": 1024, "height": 620})
    live = live_trial(demo_server)
    assert wait_for(demo_server, lambda lv: lv.probes.current, 150), "no probe within 150 s"
    expect(page.locator("#probe-ready")).to_be_focused()
    expect(page.locator("#probe-hint")).to_have_text("")
    page.keyboard.press("Enter")  # Ready
    expect(page.locator("#probe-choices button").first).to_be_visible()
    page.keyboard.press("Enter")  # at once: swallowed, and the box says so
    expect(page.locator("#probe-hint")).to_have_text(
        "Read the question first, then choose an answer."
    )
    page.wait_for_timeout(600)
    page.keyboard.press("Enter")  # on the question: how to answer
    expect(page.locator("#probe-hint")).to_have_text(
        "Choose an answer: click it, or Tab to it and press Enter."
    )
    probe = live.probes.current
    assert probe is not None and probe.ready
    page.keyboard.press("Tab")
    page.keyboard.press("Enter")
    expect(page.locator("#probe")).to_be_hidden()
    page.close()
