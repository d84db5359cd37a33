"""Where the SA probe box sits on the map, measured in Chromium.

The box overlays the map while the trial runs (SPAM), so it must not hide
the collective or target its question asks about, and it should hide no hub
at all, nor the map's zoom buttons. Measured as rendered at 1366x768 and 1024x768, with a question about
collective I (whose hub is the map's top-left one) and one about a target.
"""

from __future__ import annotations

import math

import pytest

from hcss.platform.live.progress import CurrentProbe
from hcss.platform.models import Probe
from hcss.questionnaires.probes import PROBE_TIMEOUT_S, TEMPLATES, ProbeLevel
from hcss.simulation import ROMAN
from tests.support.pages import live_trial, open_live_trial, wait_for
from tests.support.study_server import StudyServer

pytestmark = pytest.mark.browser

#: Pixels of overlap, in both directions, above which the box hides a glyph.
OVERLAP_PX = 1.0

#: The probe box's rectangle and every hub's and target's (each with its label).
RECTS = """() => {
  const rect = (n) => { const r = n.getBoundingClientRect();
    return [r.left, r.top, r.right, r.bottom]; };
  const hubs = {}, targets = {};
  for (const g of document.querySelectorAll("#layer-collectives g.collective")) hubs[g.dataset.collective] = rect(g);
  for (const g of document.querySelectorAll("#layer-targets g.target")) targets[g.dataset.target] = rect(g);
  return { box: rect(document.getElementById("probe")), hubs, targets,
           zoom: rect(document.getElementById("map-zoom")) };
}"""


def _overlaps(box: list[float], glyph: list[float]) -> bool:
    x = min(box[2], glyph[2]) - max(box[0], glyph[0])
    y = min(box[3], glyph[3]) - max(box[1], glyph[1])
    return x > OVERLAP_PX and y > OVERLAP_PX


def _ask(server: StudyServer, level: ProbeLevel, subject: str | int, choices: list[str]) -> None:
    """Put a probe with this question on screen, as the recorder does when one is due."""
    live = live_trial(server)
    question = TEMPLATES[level].fill(subject)
    with server.app.app_context(), server.database.session_scope() as session, live.lock:
        live.probe_postponed(math.inf)  # no scheduled probe interferes
        now = float(live.sim.time)
        row = Probe(
            trial_id=live.trial_id,
            probe_index=live.probes.shown + 1,
            level=int(level),
            question=question,
            choices=choices,
            truth=None,
            shown_step=live.sim.step_count,
            shown_sim_time=now,
            timeout_sim_time=now + PROBE_TIMEOUT_S,
        )
        session.add(row)
        session.flush()
        live.probe_shown(
            CurrentProbe(
                id=row.id,
                probe_index=row.probe_index,
                level=int(level),
                question=question,
                choices=choices,
                truth=None,
                shown_sim_time=now,
                timeout_sim_time=now + PROBE_TIMEOUT_S,
            )
        )
        live.touch()


def _covered(page) -> dict[str, list[str]]:
    rects = page.evaluate(RECTS)
    return {
        "hubs": [h for h, r in rects["hubs"].items() if _overlaps(rects["box"], r)],
        "targets": [t for t, r in rects["targets"].items() if _overlaps(rects["box"], r)],
        "controls": ["zoom"] if _overlaps(rects["box"], rects["zoom"]) else [],
    }


def test_the_probe_box_hides_no_hub_and_not_what_it_asks_about(
    browser, demo_server: StudyServer, capsys
) -> None:
    from playwright.sync_api import expect

    token, page = open_live_trial(browser, demo_server)
    drawn = wait_for(
        demo_server,
        lambda lv: [t for t in lv.view()["targets"] if t["drawn"]],
        90,
    )
    assert drawn, "no target reported within 90 s"
    # The target nearest the map's top-left corner, where a box left in place would sit.
    corner = min(drawn, key=lambda t: t["position"][0] - t["position"][1])["id"]
    names = [ROMAN[i] for i in range(4)]
    figures = {}
    # The study's smallest window (demo.toml's min_width x min_height), then a laptop's.
    for width, height in [(1024, 700), (1366, 768)]:
        page.set_viewport_size({"width": width, "height": height})
        page.wait_for_timeout(200)  # the map refits to the window

        # A question about collective I: the prompt, then the question, hide no hub.
        _ask(demo_server, ProbeLevel.COMPREHENSION, "I", [str(corner)])
        expect(page.locator("#probe-ready")).to_be_visible()
        prompt = _covered(page)
        assert prompt["hubs"] == prompt["controls"] == [], (width, prompt)
        page.locator("#probe-ready").click()
        question = TEMPLATES[ProbeLevel.COMPREHENSION].fill("I")
        expect(page.locator("#probe-text")).to_have_text(question)
        asked_collective = _covered(page)
        assert asked_collective["hubs"] == asked_collective["controls"] == [], (
            width,
            asked_collective,
        )
        page.locator("#probe-choices button").first.click()
        expect(page.locator("#probe")).to_be_hidden()
        # The answer is carried out (its probe closed in the trial) before the next is put:
        # the page hides its box at once, and a probe put before the answer's commit would
        # be closed by it, as a probe of the study never is (they are minutes apart).
        assert wait_for(demo_server, lambda lv: lv.probes.current is None, 30), "answer lost"

        # A question about the corner's target: that target is never hidden, nor any hub.
        _ask(demo_server, ProbeLevel.PERCEPTION, corner, names)
        page.locator("#probe-ready").click()
        expect(page.locator("#probe-text")).to_contain_text(f"target {corner}?")
        asked_target = _covered(page)
        assert str(corner) not in asked_target["targets"], (width, asked_target)
        assert asked_target["hubs"] == asked_target["controls"] == [], (width, asked_target)
        box = page.evaluate(RECTS)["box"]
        figures[f"{width}x{height}"] = (box, asked_target)
        page.locator("#probe-choices button").first.click()
        expect(page.locator("#probe")).to_be_hidden()
    with capsys.disabled():
        for size, (box, covered) in figures.items():
            print(
                f"\nprobe box at {size}: {box[2] - box[0]:.0f}x{box[3] - box[1]:.0f} px"
                f" at ({box[0]:.0f}, {box[1]:.0f}); covers {covered}"
            )


def test_a_probe_drawn_while_the_last_answer_is_in_flight_stays_on_screen(
    browser, demo_server: StudyServer
) -> None:
    """The answer's reply hides the box only if the box still shows the probe it answered.

    The next probe can be on screen before the answer's reply reaches the page (the
    server closes the answered probe when it commits, and a frame carries the next one):
    the reply must not hide that one, which no later frame would show again.
    """
    from playwright.sync_api import expect

    _, page = open_live_trial(browser, demo_server)
    _ask(demo_server, ProbeLevel.PERCEPTION, "I", ["1", "2"])
    page.locator("#probe-ready").click()
    expect(page.locator("#probe-text")).to_be_visible()
    answered = page.locator("#probe").get_attribute("data-probe")

    def reply_after_the_next_probe_shows(route) -> None:
        reply = route.fetch()  # the answer is committed; its reply is held back
        _ask(demo_server, ProbeLevel.COMPREHENSION, "II", ["1", "2"])
        page.wait_for_function(
            "(answered) => { const box = document.getElementById('probe');"
            " return !box.hidden && box.dataset.probe !== answered; }",
            arg=answered,
            timeout=30_000,
        )
        route.fulfill(response=reply)

    page.route("**/probes/*/answer", reply_after_the_next_probe_shows)
    page.locator("#probe-choices button").first.click()
    page.wait_for_timeout(1_000)  # the held reply has reached the page
    expect(page.locator("#probe")).to_be_visible()
    expect(page.locator("#probe-ready")).to_be_visible()
    assert page.locator("#probe").get_attribute("data-probe") != answered
