"""The participant's path through the `demo` study in Chromium, on a clock the test moves.

Each test clicks as a participant does, against waitress in this process
(tests/support/study_server.py), then reads what the database stored.
"""

from __future__ import annotations

import re

import pytest
from sqlalchemy import func, select

from hcss.platform.models import QuestionnaireItem, Score
from hcss.platform.study.studyfile import load_study
from hcss.questionnaires import mrt, ranking
from hcss.questionnaires.demographics import ITEM_KEYS
from tests.support.pages import contrast, live_trial, open_live_trial, start_live_trial, wait_for
from tests.support.screenshots import screenshot
from tests.support.study_server import StudyServer

pytestmark = pytest.mark.browser

VIEWPORT = {"width": 1280, "height": 900}
#: The README's walk of the demo study is taken on a common laptop's window.
LAPTOP = {"width": 1366, "height": 768}
#: A maximised browser's window on a 1366 x 768 laptop: the README's walk is taken at it.
MAXIMISED = {"width": 1366, "height": 657}

#: How far the MRT item's figures reach past the page's column, the footer's (px; 0 or less:
#: inside it), on either side.
MRT_OVERHANG = """() => {
  const column = document.querySelector('.page-footer').getBoundingClientRect();
  const parts = Array.from(document.querySelectorAll('.mrt-item, .mrt-target, .mrt-alternative'),
    (n) => n.getBoundingClientRect());
  return Math.max(column.left - Math.min(...parts.map((r) => r.left)),
                  Math.max(...parts.map((r) => r.right)) - column.right);
}"""


def expect_stage(page, stage: str, step: str | None = None) -> None:
    from playwright.sync_api import expect

    expect(page.locator("main.study")).to_have_attribute("data-stage", stage)
    if step is not None:
        expect(page.locator("main.study")).to_have_attribute("data-step", step)


def consent_and_demographics(page) -> None:
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


def start_mrt_part_1(page) -> None:
    """From the MRT's instructions through the practice item to part 1's first item."""
    page.get_by_role("button", name="Begin").click()
    page.locator('input[name="chosen"][value="0"]').check()
    page.get_by_role("button", name="Check").click()
    page.get_by_role("button", name="Continue").click()
    page.get_by_role("button", name="Start part 1").click()
    expect_stage(page, "mental_rotation", "part_1")


def chosen_for(item: mrt.MrtItem, how: str) -> list[int]:
    right = sorted(item.correct)
    wrong = sorted(set(range(4)) - item.correct)
    return {
        "correct": right,
        "one_right_one_wrong": [right[0], wrong[0]],
        "all_four": [0, 1, 2, 3],
    }[how]


def answer_mrt(page, server: StudyServer, walk: bool = False) -> dict[str, str]:
    """Instructions, the practice item, then the timed part with PATTERN; the answers given."""
    from playwright.sync_api import expect

    expect_stage(page, "mental_rotation", "instructions")
    page.get_by_role("button", name="Begin").click()
    expect_stage(page, "mental_rotation", "practice_1")
    page.locator('input[name="chosen"][value="0"]').check()
    # Measured once each page has loaded its stylesheet, as a participant sees it:
    # under load the feedback can be in the DOM before study.css is applied.
    page.wait_for_load_state("load")
    before = page.locator(".mrt-alternative").first.bounding_box()
    page.get_by_role("button", name="Check").click()
    expect(page.locator(".feedback")).to_be_visible()
    page.wait_for_load_state("load")
    after = page.locator(".mrt-alternative").first.bounding_box()
    # The feedback appears below the alternatives; they stay where they were.
    assert (round(after["x"]), round(after["y"])) == (round(before["x"]), round(before["y"]))
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
        if walk and number == 1:  # the README's walk shows an answered item
            overhang = page.evaluate(MRT_OVERHANG)
            assert overhang <= 0, f"the MRT item reaches {overhang:.0f} px past the page column"
            screenshot(page, "walk-mrt.png", docs_name="walk-3-mrt.png")
        page.get_by_role("button", name="Next").click()
    # Every item answered in time: a page says the part is done before the test moves on.
    expect_stage(page, "mental_rotation", "done_1")
    expect(page.locator("h2#part-done")).to_have_text("Part 1 done")
    expect(page.locator("main")).to_contain_text("That was the last part of the test.")
    page.get_by_role("button", name="Continue").click()
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
    start_mrt_part_1(page)
    page.locator('input[name="chosen"][value="1"]').check()
    page.get_by_role("button", name="Next").click()
    expect(page.locator("p.muted", has_text="item 2 of 4")).to_be_visible()
    expect(page.get_by_role("timer")).to_contain_text("1:00")
    # The server renders 1:00 itself; the countdown starts when study.js has run (by
    # the load event). Moving the clock before that moved nothing (a fresh clone's run).
    page.wait_for_load_state("load")
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


def test_the_mrt_timer_stays_in_view_on_a_phone(browser, demo_server: StudyServer) -> None:
    """Scrolled to an item's last alternative on a 375 x 812 phone, the time left still shows."""
    from playwright.sync_api import expect

    token = demo_server.participant()
    page = browser.new_page(viewport={"width": 375, "height": 812}, is_mobile=True)
    page.goto(f"{demo_server.url}/p/{token}")
    consent_and_demographics(page)
    start_mrt_part_1(page)
    page.locator('input[name="chosen"][value="3"]').scroll_into_view_if_needed()
    page.evaluate("() => window.scrollTo(0, document.documentElement.scrollHeight)")
    page.wait_for_timeout(100)
    scrolled = page.evaluate("() => window.scrollY")
    timer = page.evaluate(
        """() => { const r = document.getElementById("timer").getBoundingClientRect();
        return [r.top, r.bottom]; }"""
    )
    assert scrolled > 100, scrolled  # the item is taller than the phone's screen
    assert timer[0] >= 0 and timer[1] <= 80, (scrolled, timer)  # pinned to the top
    expect(page.get_by_role("timer")).to_be_in_viewport()
    # Nothing scrolled under it is painted over it: the time left is what shows there.
    on_top = page.evaluate(
        """() => { const r = document.getElementById("time-left").getBoundingClientRect();
        const hit = document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2);
        return hit !== null && hit.closest("#timer") !== null; }"""
    )
    assert on_top, "the time left is covered by the page scrolled under it"
    page.close()


# --- the whole demo study, link to debrief (issue 8's acceptance walk) ------------------


def answer_every_radio_group(page, choose=lambda values: values[0]) -> None:
    """Check one option of every radio group on the page (questionnaires, TLX, SART)."""
    groups = page.evaluate(
        """() => {
            const groups = {};
            for (const input of document.querySelectorAll('#stage-form input[type=radio]')) {
                (groups[input.name] = groups[input.name] || []).push(input.value);
            }
            return groups;
        }"""
    )
    assert groups, "no questions on this page"
    for name, values in groups.items():
        page.locator(f'input[name="{name}"][value="{choose(values)}"]').check()


def run_to_end(page, server: StudyServer, step_s: float = 4.0) -> None:
    """Advance the clock until the trial has ended (it may have already: the runner then
    holds no unended trial), then continue from the ended page."""
    from playwright.sync_api import expect

    while any(t and not t.ended for t in map(server.runner.loaded, server.runner.loaded_ids())):
        server.advance(step_s)
    expect(page.locator("#ended")).to_be_visible()
    page.locator("#continue").click()


def answer_probe(page, server: StudyServer) -> str:
    """The probe on screen: its countdown runs, Ready has the focus; answered by keyboard."""
    from playwright.sync_api import expect

    expect(page.locator("#probe")).to_be_visible()
    expect(page.locator("#probe-countdown")).to_have_text(re.compile(r"^0:[0-3]\d$"))
    before = page.locator("#probe-countdown").inner_text()
    server.advance(3.0)
    expect(page.locator("#probe-countdown")).not_to_have_text(before)  # it counts down
    expect(page.locator("#probe-ready")).to_be_focused()
    page.keyboard.press("Enter")  # "Ready", from the keyboard
    expect(page.locator("#probe-text")).to_be_focused()  # the question, not a choice
    screenshot(page, "walk-probe.png", docs_name="walk-5-probe.png")
    choice = page.locator("#probe-choices button").first.inner_text()
    page.locator("#probe-choices button").first.click()
    expect(page.locator("#probe")).to_be_hidden()
    return choice


def supervise_first_trial(page, server: StudyServer, token: str) -> dict[str, int]:
    """A double-clicked Commit, the probe if it comes, and the experimenter's pause."""
    from playwright.sync_api import expect

    from hcss.platform.console.interventions import change_participant_state
    from hcss.platform.models import Participant

    live = live_trial(server)
    target = wait_for(
        server,
        lambda lv: next(
            (t for t in lv.view()["targets"] if t["drawn"] and 0 in t["in_range_of"]), None
        ),
        60,
    )
    assert target, "no drawn target in range of collective I within a minute"
    answered = 0
    if live.probes.current is not None:  # it would cover the hub
        answer_probe(page, server)
        answered += 1
    page.locator('g.collective[data-collective="0"]').click()
    page.locator(f'g.target[data-target="{target["id"]}"]').click()
    page.select_option("#request-kind", "investigate")
    page.locator("#commit").dblclick()
    expect(page.locator("#request-note")).to_contain_text("accepted")
    expect(page.locator("#messages li.accepted").first).to_contain_text(
        f"investigate by collective I on target {target['id']}"
    )
    screenshot(page, "participant-trial.png", docs_name="screenshot-participant-trial.png")

    # The experimenter pauses: an overlay says so and the clock stands still.
    with server.app.app_context(), server.database.session_scope() as session:
        participant = session.scalars(select(Participant).where(Participant.token == token)).one()
        session.expunge(participant)
    with server.app.app_context():
        change_participant_state(
            server.database, server.app.extensions["hcss_live"], participant, None, "pause"
        )
    expect(page.locator("#paused")).to_be_visible()
    expect(page.locator("#paused")).to_contain_text("Paused by the experimenter")
    expect(page.locator("#clock-state")).to_have_text("paused")
    expect(page.locator("#commit")).to_be_disabled()
    shown = page.locator("#clock").inner_text()
    server.advance(10.0)
    page.wait_for_timeout(300)  # frames keep coming; the clock does not move
    expect(page.locator("#clock")).to_have_text(shown)
    with server.app.app_context():
        change_participant_state(
            server.database, server.app.extensions["hcss_live"], participant, None, "resume"
        )
    expect(page.locator("#paused")).to_be_hidden()
    expect(page.locator("#commit")).to_be_enabled()

    coming = live.probes.shown < len(live.probes.plan) or live.probes.current is not None
    if coming and wait_for(server, lambda lv: lv.probes.current is not None, 120):
        answer_probe(page, server)
        answered += 1
    return {"target": target["id"], "probes": answered}


@pytest.mark.slow  # about 25 s: six live trials on the manual clock, in a browser
def test_the_demo_study_from_the_link_to_the_debrief(browser, demo_server: StudyServer) -> None:
    from playwright.sync_api import expect

    from hcss.platform.models import Command, CommandKey, ProbeEvent

    # From the study link (anonymous in the demo), as an online participant arrives,
    # in a maximised browser on a 1366 x 768 laptop.
    page = browser.new_page(viewport=MAXIMISED)
    page.goto(f"{demo_server.url}/join/demo")
    expect(page.locator("#device-ok")).to_be_visible()
    screenshot(page, "walk-first-page.png", docs_name="walk-1-first-page.png")
    page.locator("#join-start").click()
    expect(page.locator("#code-note")).to_contain_text("Your participant code is")
    token = re.search(r"/p/([A-Za-z0-9_-]+)/", page.url).group(1)
    code = page.locator("#code-note .participant-code").inner_text()
    screenshot(page, "walk-consent.png", docs_name="walk-2-consent.png")
    consent_and_demographics(page)
    given = answer_mrt(page, demo_server, walk=True)

    expect_stage(page, "introduction")
    while page.locator("main.study").get_attribute("data-stage") == "introduction":
        step = page.locator("main.study").get_attribute("data-step")
        page.get_by_role("button", name="Continue").click()
        expect(page.locator("main.study")).not_to_have_attribute("data-step", step)

    # The instruction check, answered rightly at the first try.
    expect_stage(page, "instruction_check", "try_1")
    check = load_study("demo").instruction_check
    assert check is not None
    for item in check.items:
        page.get_by_role("radio", name=item.answer, exact=True).check()
    page.get_by_role("button", name="Check my answers").click()

    # The screen check: too small a window is told so, and it clears when the window grows.
    expect_stage(page, "screen_check")
    page.set_viewport_size({"width": 900, "height": 600})
    expect(page.locator("#screen-too-small")).to_be_visible()
    expect(page.locator("#screen-size")).to_have_text("900 x 600")
    expect(page.locator("#screen-continue")).to_be_disabled()
    page.set_viewport_size(MAXIMISED)
    expect(page.locator("#screen-too-small")).to_be_hidden()
    expect(page.locator("#screen-ok")).to_be_visible()
    page.locator("#screen-continue").click()

    probes_answered, supervised = 0, None
    for round_ in range(3):
        expect_stage(page, "training", "ready")
        expect(page.locator("main")).to_contain_text("You now get 1 minute to try out")
        page.get_by_role("button", name="Start").click()
        expect(page.locator("#connection")).to_have_text("live")
        expect(page.locator("#fullscreen")).to_be_visible()  # trials offer full screen
        if round_ == 0:
            wait_for(demo_server, lambda lv: len(lv.view()["targets"]) >= 3, 40)
            page.locator('g.collective[data-collective="0"]').click(button="right")
            expect(page.locator("#layer-flags .flag")).to_have_count(1)
            screenshot(page, "walk-training.png", docs_name="walk-4-training.png")
        run_to_end(page, demo_server, step_s=6.0)

        expect_stage(page, "trial", "ready")
        expect(page.locator("main")).to_contain_text("The trial lasts 2 minutes")
        page.get_by_role("button", name="Start").click()
        expect(page.locator("#connection")).to_have_text("live")
        if round_ == 0:
            supervised = supervise_first_trial(page, demo_server, token)
            probes_answered += supervised["probes"]
        elif probes_answered == 0 and wait_for(
            demo_server, lambda lv: lv.probes.current is not None, 110
        ):
            answer_probe(page, demo_server)
            probes_answered += 1
        run_to_end(page, demo_server)

        for stage in ("post_trial", "nasa_tlx", "nasa_tlx", "sart"):
            expect_stage(page, stage)
            if stage == "post_trial" and round_ == 0:
                # The 1-7 points line up from question to question (measured with
                # study.css applied: under load the page can be in the DOM before it).
                page.wait_for_load_state("load")
                columns = page.evaluate(
                    """() => Array.from(document.querySelectorAll('fieldset.question'), (q) =>
                        Array.from(q.querySelectorAll('input[type=radio]'),
                                   (r) => Math.round(r.getBoundingClientRect().x)))"""
                )
                assert len(columns) > 1 and all(c == columns[0] for c in columns), columns
            answer_every_radio_group(page)
            page.get_by_role("button", name="Continue").click()

    expect_stage(page, "ranking")
    for dimension in ranking.DIMENSIONS:
        for rank, label in enumerate(ranking.ORDER_LABELS, start=1):
            page.locator(
                f'input[name="{ranking.item_key(dimension.key, label)}"][value="{rank}"]'
            ).check()
    page.get_by_role("button", name="Continue").click()

    expect_stage(page, "debrief")
    expect(page.locator("#code-note")).to_contain_text(code)
    expect(page.locator("article.text")).to_contain_text("always came last")
    expect(page.locator("#completion-code")).to_have_text("DEMO2026")  # came through the link
    screenshot(page, "walk-debrief.png", docs_name="walk-6-debrief.png")
    page.close()

    assert supervised is not None and probes_answered >= 1
    with demo_server.database.session_scope() as session:
        commands = list(session.scalars(select(Command)))
        assert [(c.kind, c.collective, c.target) for c in commands] == [
            ("investigate", 0, supervised["target"])
        ], "the double-clicked Commit must give exactly one request row"
        assert session.scalar(select(func.count()).select_from(CommandKey)) >= 1
        answers = list(session.scalars(select(ProbeEvent).where(ProbeEvent.kind == "answer")))
        assert len(answers) == probes_answered
        assert all(a.latency_ms is not None and a.latency_ms >= 0 for a in answers)
        scores = {
            (row.instrument, row.model, row.scale): row.score
            for row in session.scalars(select(Score))
        }
        stored = {
            row.item: row.value
            for row in session.scalars(
                select(QuestionnaireItem).where(QuestionnaireItem.instrument == "mrt")
            )
        }
    assert {key: stored[key] for key in given} == given
    assert scores[("mrt", "", "total")] == HAND_COUNT
    assert {m for (i, m, _) in scores if i in ("nasa_tlx", "sart")} == {"M1", "M2", "M3"}


# --- the Collective Interface's details ----------------------------------------------


def test_the_interface_by_keyboard_info_box_messages_and_contrast(
    browser, demo_server: StudyServer
) -> None:
    from playwright.sync_api import expect

    minimum_window = {"width": 1024, "height": 700}
    token, page = open_live_trial(browser, demo_server, minimum_window)
    live = live_trial(demo_server)
    target = wait_for(
        demo_server,
        lambda lv: next(
            (t for t in lv.view()["targets"] if t["drawn"] and 1 in t["in_range_of"]), None
        ),
        90,
    )
    assert target

    # Keyboard: hubs and targets are labelled buttons; Enter selects, "i" shows the info box.
    hub = page.locator('g.collective[data-collective="1"]')
    expect(hub).to_have_attribute("role", "button")
    expect(hub).to_have_attribute("aria-label", "Collective II hub")
    hub.focus()
    page.keyboard.press("Enter")
    expect(page.locator("#request-collective")).to_have_value("1")
    glyph = page.locator(f'g.target[data-target="{target["id"]}"]')
    expect(glyph).to_have_attribute(
        "aria-label", re.compile(f"^Target {target['id']}, highest support")
    )
    glyph.focus()
    page.keyboard.press("Enter")
    expect(page.locator("#request-target")).to_have_value(str(target["id"]))
    page.keyboard.press("i")
    flag = page.locator("#layer-flags .flag")
    expect(flag).to_contain_text(f"Target {target['id']}: support")
    expect(page.locator("#sr-status")).to_contain_text(f"Target {target['id']}: support")

    # The info box: Escape closes it; its close control closes it; its body takes no click.
    page.keyboard.press("Escape")
    expect(flag).to_have_count(0)
    glyph.click(button="right")
    expect(flag).to_have_count(1)
    box = flag.locator("rect").first.bounding_box()
    beneath = page.evaluate(
        "([x, y]) => !!document.elementFromPoint(x, y).closest('.flag')",
        [box["x"] + 20, box["y"] + box["height"] - 10],
    )
    assert beneath is False, "a click on the info box's body must reach the map"
    flag.locator(".flag-close").click()
    expect(flag).to_have_count(0)

    # A committed request, then its assignment selected with the keyboard.
    page.select_option("#request-kind", "investigate")
    page.locator("#commit").click()
    expect(page.locator("#request-note")).to_contain_text("accepted")
    # Good news in green; amber (255, 210, 122) is for refusals.
    expect(page.locator("#request-note")).to_have_css("color", "rgb(139, 224, 164)")
    row = page.locator("#assignments li").first
    row.focus()
    page.keyboard.press("Enter")
    expect(page.locator("#assignments li").first).to_have_class(re.compile("selected"))
    expect(page.locator("#assignments li").first).to_be_focused()

    # The support half of a target: at least 3:1 against the ground at full support.
    fills = page.evaluate(
        """() => [getComputedStyle(document.querySelector('.target-blue')).fill,
                  getComputedStyle(document.querySelector('.ground')).fill]"""
    )
    assert contrast(*fills) >= 3.0, fills

    # System Messages: the ten newest fit in the panel without scrolling.
    assert wait_for(demo_server, lambda lv: len(lv.messages) >= 10, 110), "fewer than 10 messages"
    expect(page.locator("#messages li")).to_have_count(len(live.messages))
    panel = page.locator("section.messages").bounding_box()
    for index in range(10):
        item = page.locator("#messages li").nth(index).bounding_box()
        assert (
            item["y"] >= panel["y"]
            and item["y"] + item["height"] <= panel["y"] + panel["height"] + 0.5
        ), index
    page.close()


def test_a_takeover_event_stops_the_older_tab(browser, demo_server: StudyServer) -> None:
    """The server's contract (issue 13): a newer stream for the same trial sends the older
    one an SSE event `takeover`, then closes it. Simulated here by answering the stream
    request with that event; without the handler EventSource would reconnect at once."""
    from playwright.sync_api import expect

    token = start_live_trial(demo_server)
    page = browser.new_page(viewport=VIEWPORT)
    opened = []

    def takeover(route) -> None:
        opened.append(route.request.url)
        route.fulfill(
            status=200,
            headers={"Content-Type": "text/event-stream", "Cache-Control": "no-cache"},
            body='retry: 100\nevent: takeover\ndata: {"reason": "another_tab"}\n\n',
        )

    page.route(re.compile(r".*/stream(\?.*)?$"), takeover)
    page.goto(f"{demo_server.url}/live/{token}")
    expect(page.locator("#taken-over")).to_be_visible()
    expect(page.locator("#taken-over")).to_contain_text(
        "This trial was opened in another tab or window"
    )
    expect(page.locator("#commit")).to_be_disabled()
    page.wait_for_timeout(800)  # eight reconnection delays
    assert len(opened) == 1, "the tab that was taken over must not reconnect"
    page.close()


def test_declining_in_the_browser_asks_once(browser, demo_server: StudyServer) -> None:
    from playwright.sync_api import expect

    token = demo_server.participant()
    page = browser.new_page(viewport=VIEWPORT)
    page.goto(f"{demo_server.url}/p/{token}")
    page.get_by_label("I do not agree").check()
    page.get_by_role("button", name="Continue").click()
    expect(page.locator("#confirm-decline")).to_contain_text("If that is right, press Confirm")
    page.get_by_label("I agree", exact=True).check()
    expect(page.locator("#consent-submit")).to_have_text("Continue")
    page.get_by_label("I do not agree").check()
    expect(page.locator("#consent-submit")).to_have_text("Confirm")
    page.get_by_role("button", name="Confirm").click()
    expect_stage(page, "declined")
    expect(page.locator("main")).to_contain_text("You have chosen not to take part")
    page.close()
