"""A replayed trial's probes and System Messages, as the experimenter sees them in Chromium.

The replay draws a probe the way the participant's page did: the same box,
"A question is waiting" until Ready, then the question and its choices, here
with the participant's answer and the truth marked. Its System Messages hold
the "Request N accepted" lines the participant saw.
"""

from __future__ import annotations

import re

import pytest

from tests.support.console import code_of, open_replay
from tests.support.inprocess import serving
from tests.support.replays import operate

pytestmark = pytest.mark.browser

#: Trial seconds from the probe showing to Ready, and from Ready to the answer.
READY_AFTER_S, ANSWER_AFTER_S = 3.0, 5.0


def test_a_replayed_probe_is_drawn_in_the_live_box_with_its_answer(
    browser, app, make_trial, experimenter
) -> None:
    from playwright.sync_api import expect

    trial = make_trial(seed=7, duration_s=90.0)
    sent = operate(trial, 30.0)  # requests, some accepted, before the probe is due
    assert sent
    second = 30.0
    while trial.state()["probe"] is None:
        second += 1.0
        assert second < 80, "no probe by 80 s"
        trial.run_to(second)
    probe = trial.state()["probe"]
    trial.run_to(second + READY_AFTER_S)
    assert trial.post(f"/probes/{probe['id']}/ready", {}).status_code == 200
    asked = trial.state()["probe"]
    answer = asked["choices"][-1]
    trial.run_to(second + READY_AFTER_S + ANSWER_AFTER_S)
    assert trial.post(f"/probes/{probe['id']}/answer", {"answer": answer}).status_code == 200
    trial.run_to(90.0)
    code = code_of(app, trial.token)

    with serving(app) as url:
        page = open_replay(browser, url, code, trial.trial_id, {"width": 1366, "height": 768})
        expect(page.locator("#replay")).to_have_attribute("data-state", "ready")

        # The probe's mark on the timeline jumps to its showing: the live page's prompt.
        page.locator("#replay-marks .probe-mark").first.click()
        box = page.locator("#probe")
        expect(box).to_be_visible()
        expect(box.locator(".probe-ready")).to_be_visible()
        expect(page.locator("#probe-ready")).to_be_disabled()  # nothing is sent from a replay
        expect(page.locator("#probe-replay")).to_contain_text(f"Answered {answer}")

        # After Ready: the question and its choices, the participant's answer marked.
        track = page.locator("#replay-track").bounding_box()
        assert track is not None
        when = second + READY_AFTER_S + 1.0
        page.mouse.click(track["x"] + track["width"] * when / 90.0, track["y"] + 5)
        expect(page.locator("#probe-text")).to_have_text(asked["question"])
        expect(page.locator("#probe-choices button")).to_have_count(len(asked["choices"]))
        expect(page.locator("#probe-choices button.chosen")).to_have_text(answer)
        expect(page.locator("#probe-choices button:enabled")).to_have_count(0)
        subject = asked["subject"]
        if subject and "collective" in subject:  # placed as live: off the asked collective
            hub = page.locator(f'g.collective[data-collective="{subject["collective"]}"]')
            a, b = box.bounding_box(), hub.bounding_box()
            assert a is not None and b is not None
            apart = (
                a["x"] + a["width"] <= b["x"]
                or b["x"] + b["width"] <= a["x"]
                or a["y"] + a["height"] <= b["y"]
                or b["y"] + b["height"] <= a["y"]
            )
            assert apart, (a, b)

        # Past its close (and the moment it is held): gone.
        page.mouse.click(track["x"] + track["width"] * 85.0 / 90.0, track["y"] + 5)
        expect(box).to_be_hidden()
        # The System Messages the participant saw, accepted requests included.
        accepted = page.locator("#messages li.accepted")
        expect(accepted.first).to_be_visible()
        assert all(
            re.match(r"\d+:\d\dRequest \d+ accepted \(", text)
            for text in accepted.all_inner_texts()
        ), accepted.all_inner_texts()
