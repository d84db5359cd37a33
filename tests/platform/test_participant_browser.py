"""The participant's path through the `demo` study in Chromium, on a clock the test moves.

Each test clicks as a participant does, against waitress in this process
(tests/platform/inprocess_server.py), then reads what the database stored.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from sqlalchemy import select

from hcss.platform.models import QuestionnaireItem, Score
from hcss.questionnaires import mrt
from hcss.questionnaires.demographics import ITEM_KEYS
from tests.platform.inprocess_server import StudyServer, study_server

pytestmark = pytest.mark.browser

VIEWPORT = {"width": 1280, "height": 900}


@pytest.fixture
def demo_server(tmp_path) -> Iterator[StudyServer]:  # type: ignore[no-untyped-def]
    with study_server(tmp_path, "demo") as server:
        yield server


def expect_stage(page, stage: str, step: str | None = None) -> None:  # type: ignore[no-untyped-def]
    from playwright.sync_api import expect

    expect(page.locator("main.study")).to_have_attribute("data-stage", stage)
    if step is not None:
        expect(page.locator("main.study")).to_have_attribute("data-step", step)


def consent_and_demographics(page) -> None:  # type: ignore[no-untyped-def]
    expect_stage(page, "consent")
    page.get_by_label("I agree").check()
    page.get_by_role("button", name="Continue").click()
    expect_stage(page, "demographics")
    for key in ITEM_KEYS:
        page.locator(f'input[name="{key}"]').first.check()
    page.get_by_role("button", name="Continue").click()


# A known pattern for the demo's timed part (4 items): right, half right, right,
# everything ticked. By the MRT rule (a point only for exactly the two correct
# alternatives) that is 1 + 0 + 1 + 0 = 2 points.
PATTERN = ("correct", "one_right_one_wrong", "correct", "all_four")
HAND_COUNT = 2


def chosen_for(item: mrt.MrtItem, how: str) -> list[int]:
    right = sorted(item.correct)
    wrong = sorted(set(range(4)) - item.correct)
    return {
        "correct": right,
        "one_right_one_wrong": [right[0], wrong[0]],
        "all_four": [0, 1, 2, 3],
    }[how]


def answer_mrt(page, server: StudyServer) -> dict[str, str]:  # type: ignore[no-untyped-def]
    """Instructions, the practice item, then the timed part with PATTERN; the answers given."""
    from playwright.sync_api import expect

    expect_stage(page, "mental_rotation", "instructions")
    page.get_by_role("button", name="Begin").click()
    expect_stage(page, "mental_rotation", "practice_1")
    page.locator('input[name="chosen"][value="0"]').check()
    page.get_by_role("button", name="Check").click()
    expect(page.locator(".feedback")).to_be_visible()
    page.get_by_role("button", name="Continue").click()
    expect_stage(page, "mental_rotation", "begin_1")
    expect(page.locator("h2#part-begins")).to_have_text("Part 1 begins")
    expect(page.locator(".part-limit")).to_contain_text("you have 1 minute for it")
    page.get_by_role("button", name="Start part 1").click()
    expect_stage(page, "mental_rotation", "part_1")
    expect(page.get_by_role("timer")).to_contain_text("Time left: 1:00")
    bank = {item.key: item for item in mrt.item_bank()}
    given = {}
    for number, how in enumerate(PATTERN, start=1):
        expect(page.locator("p.muted", has_text=f"item {number} of")).to_be_visible()
        item = bank[page.locator(".mrt-item").get_attribute("data-item")]
        chosen = chosen_for(item, how)
        for index in chosen:
            box = page.locator(f'input[name="chosen"][value="{index}"]')
            expect(box).to_be_enabled()
            box.check()
        given[item.key] = mrt.format_selection(chosen)
        page.get_by_role("button", name="Next").click()
    return given


def test_timed_mrt_answers_are_stored_and_scored(browser, demo_server: StudyServer) -> None:
    token = demo_server.participant()
    page = browser.new_page(viewport=VIEWPORT)
    page.goto(f"{demo_server.url}/p/{token}")
    consent_and_demographics(page)
    given = answer_mrt(page, demo_server)
    expect_stage(page, "introduction")
    page.close()

    with demo_server.database.session_scope() as session:
        stored = {
            row.item: row.value
            for row in session.scalars(
                select(QuestionnaireItem).where(QuestionnaireItem.instrument == "mrt")
            )
        }
        scores = {
            row.scale: row.score
            for row in session.scalars(select(Score).where(Score.instrument == "mrt"))
        }
    assert {key: stored[key] for key in given} == given
    assert scores == {"total": HAND_COUNT, "part_1": HAND_COUNT}


def test_mrt_countdown_runs_out_into_a_time_is_up_page(browser, demo_server: StudyServer) -> None:
    from playwright.sync_api import expect

    token = demo_server.participant()
    page = browser.new_page(viewport=VIEWPORT)
    page.clock.install()  # the page's timers, moved by the test with the server's clock
    page.goto(f"{demo_server.url}/p/{token}")
    consent_and_demographics(page)
    page.get_by_role("button", name="Begin").click()
    page.locator('input[name="chosen"][value="0"]').check()
    page.get_by_role("button", name="Check").click()
    page.get_by_role("button", name="Continue").click()
    page.get_by_role("button", name="Start part 1").click()
    expect_stage(page, "mental_rotation", "part_1")
    page.locator('input[name="chosen"][value="1"]').check()
    page.get_by_role("button", name="Next").click()
    expect(page.locator("p.muted", has_text="item 2 of 4")).to_be_visible()
    expect(page.get_by_role("timer")).to_contain_text("1:00")
    page.clock.run_for(20_000)
    expect(page.get_by_role("timer")).to_contain_text("0:40")  # the countdown is visible

    demo_server.advance(61.0)  # the server's deadline passes ...
    page.clock.run_for(41_000)  # ... and the page's countdown reaches zero and reloads
    expect_stage(page, "mental_rotation", "time_up_1")
    expect(page.locator("h2#time-up")).to_have_text("Time is up")
    expect(page.locator("main")).to_contain_text("You answered 1 of its 4 items")
    page.get_by_role("button", name="Continue").click()
    expect_stage(page, "introduction")
    page.close()
