"""The Collective Interface's map and probes in Chromium, at the sizes participants use.

The map's text and glyphs are measured as rendered (font size times the
screen transform, and bounding boxes) at 1366x768 and 1024x768; a probe's
question cannot be answered by a second press of the key that said Ready;
a trial the experimenter aborts says so.
"""

from __future__ import annotations

import re

import pytest
from sqlalchemy import select

from hcss.platform.console.interventions import change_participant_state
from hcss.platform.models import Participant, ProbeEvent
from tests.support.pages import contrast, live_trial, open_live_trial, wait_for
from tests.support.study_server import StudyServer

pytestmark = pytest.mark.browser

#: The smallest rendered text (px) and clickable glyph (px) the map may show.
MIN_TEXT_PX = 12.0
MIN_GLYPH_PX = 24.0

#: Rendered sizes on the map: the font size on screen of each kind of text,
#: the smaller side of each target and hub, and how much of the panel the map fills.
MEASURE = """() => {
  const text = (selector) => Array.from(document.querySelectorAll(selector)).map(
    (n) => parseFloat(getComputedStyle(n).fontSize) * n.getScreenCTM().a);
  const side = (selector) => Array.from(document.querySelectorAll(selector)).map((n) => {
    const r = n.getBoundingClientRect(); return Math.min(r.width, r.height); });
  const map = document.getElementById("map").getBoundingClientRect();
  const panel = document.querySelector(".map-area").getBoundingClientRect();
  const arena = document.querySelector("#map .arena").getBoundingClientRect();
  return {
    target_ids: text(".target-id"), quad_labels: text(".quad-label"),
    hub_names: text(".hub-name"), info_box: text(".flag text"),
    targets: side(".target-frame"), hubs: side(".hub-box"),
    map_fills_panel: map.width / panel.width * (map.height / panel.height),
    arena_fills_shorter_side: Math.max(arena.height / map.height, arena.width / map.width),
  };
}"""


def _measure(page) -> dict[str, object]:
    sizes = page.evaluate(MEASURE)
    for kind in ("target_ids", "quad_labels", "hub_names", "info_box"):
        assert sizes[kind], f"no {kind} on the map"
        assert min(sizes[kind]) >= MIN_TEXT_PX, (kind, sizes[kind])
    for kind in ("targets", "hubs"):
        assert min(sizes[kind]) >= MIN_GLYPH_PX, (kind, sizes[kind])
    assert sizes["map_fills_panel"] > 0.99, sizes  # no letterbox bands
    assert sizes["arena_fills_shorter_side"] > 0.99, sizes  # the arena is as large as fits
    return sizes


def test_the_map_reads_at_1366_and_1024_and_a_double_enter_answers_no_probe(
    browser, demo_server: StudyServer, capsys
) -> None:
    from playwright.sync_api import expect

    token, page = open_live_trial(browser, demo_server)
    target = wait_for(
        demo_server,
        lambda lv: next((t for t in lv.view()["targets"] if t["drawn"]), None),
        90,
    )
    assert target, "no target reported within 90 s"
    glyph = page.locator(f'g.target[data-target="{target["id"]}"]')
    glyph.click(button="right")  # the info box, measured with the rest
    expect(page.locator("#layer-flags .flag")).to_have_count(1)
    figures = {"1366x768": _measure(page)}
    page.set_viewport_size({"width": 1024, "height": 768})
    page.wait_for_function(
        "() => Math.abs(document.getElementById('map').viewBox.baseVal.width"
        " / document.getElementById('map').viewBox.baseVal.height"
        " - document.getElementById('map').clientWidth / document.getElementById('map').clientHeight) < 0.01"
    )
    figures["1024x768"] = _measure(page)
    # Tab (every map glyph has tabindex 0: document order) meets the hubs, then the targets by number.
    order = page.evaluate(
        """() => Array.from(document.querySelectorAll('#map [tabindex="0"]'), (n) =>
            n.dataset.collective !== undefined ? 'hub ' + n.dataset.collective : Number(n.dataset.target))"""
    )
    hubs = [f"hub {i}" for i in range(4)]
    assert order[:4] == hubs and order[4:] == sorted(order[4:]), order
    with capsys.disabled():
        for size, sizes in figures.items():
            summary = {
                k: round(min(v), 1) if isinstance(v, list) else round(v, 2)
                for k, v in sizes.items()
            }
            print(f"\nmap at {size}: smallest {summary}")

    # A probe: Ready by Enter, then Enter again as the question shows. Nothing is answered.
    live = live_trial(demo_server)
    assert wait_for(demo_server, lambda lv: lv.probes.current, 150), "no probe within 150 s"
    expect(page.locator("#probe-ready")).to_be_focused()
    page.keyboard.press("Enter")
    expect(page.locator("#probe-choices button").first).to_be_visible()
    page.keyboard.press("Enter")
    page.wait_for_timeout(300)
    page.keyboard.press("Enter")
    page.wait_for_timeout(300)  # past the guard: Enter still finds no choice focused
    page.keyboard.press("Enter")
    expect(page.locator("#probe-text")).to_be_focused()
    expect(page.locator("#probe-choices button:focus")).to_have_count(0)
    probe = live.probes.current
    assert probe is not None and probe.ready, "the probe was answered by the second Enter"
    with demo_server.database.session_scope() as session:
        answers = session.scalars(
            select(ProbeEvent).where(ProbeEvent.probe_id == probe.id, ProbeEvent.kind == "answer")
        ).all()
    assert answers == []
    page.locator("#probe-choices button").last.click()  # read, then chosen with the mouse
    expect(page.locator("#probe")).to_be_hidden()
    with demo_server.database.session_scope() as session:
        (answer,) = session.scalars(
            select(ProbeEvent).where(ProbeEvent.probe_id == probe.id, ProbeEvent.kind == "answer")
        ).all()
    assert answer.answer == probe.choices[-1]

    # The experimenter aborts: the page says so, not "Time is up".
    with demo_server.app.app_context(), demo_server.database.session_scope() as session:
        participant = session.scalars(select(Participant).where(Participant.token == token)).one()
        session.expunge(participant)
    with demo_server.app.app_context():
        change_participant_state(
            demo_server.database,
            demo_server.app.extensions["hcss_live"],
            participant,
            None,
            "abort",
        )
    expect(page.locator("#ended")).to_be_visible()
    expect(page.locator("#ended-title")).to_have_text("Ended by the experimenter")
    page.reload()  # the ended trial's page, opened again, says the same
    expect(page.locator("#ended-title")).to_have_text("Ended by the experimenter")
    page.close()


#: Every drawn target's blue half: its fill-opacity, and the colours it is blended from.
SUPPORT_HALVES = """() => {
  const ground = getComputedStyle(document.querySelector("#map .ground")).fill;
  return Array.from(document.querySelectorAll("#layer-targets g.target"), (g) => {
    const blue = g.querySelector(".target-blue");
    return [Number(g.dataset.target), Number(blue.getAttribute("fill-opacity")),
            getComputedStyle(blue).fill, ground];
  });
}"""


def _contrast_over(fill: str, ground: str, opacity: float) -> float:
    """Contrast of `fill` at `opacity` over `ground` against the bare ground (WCAG 2)."""
    top = [int(v) for v in re.findall(r"\d+", fill)[:3]]
    under = [int(v) for v in re.findall(r"\d+", ground)[:3]]
    mixed = [round(opacity * a + (1 - opacity) * b) for a, b in zip(top, under, strict=True)]
    return contrast(f"rgb({mixed[0]}, {mixed[1]}, {mixed[2]})", ground)


def test_low_support_is_visible_in_the_blue_half(browser, demo_server: StudyServer, capsys) -> None:
    """Opacity grows with support (SPEC-study §3) from a floor, so a little support shows."""

    token, page = open_live_trial(browser, demo_server)
    low = wait_for(
        demo_server,
        lambda lv: [t for t in lv.view()["targets"] if t["drawn"] and 0 < t["max_support"] < 0.2],
        90,
    )
    assert low, "no target with a little support within 90 s"
    targets = {t["id"]: t for t in live_trial(demo_server).view()["targets"]}
    page.wait_for_timeout(400)  # the clock stands still: the next frames show this state
    halves = page.evaluate(SUPPORT_HALVES)
    opacity = {target: value for target, value, _, _ in halves}
    for target, t in targets.items():
        support = t["max_support"] if t["drawn"] else 0.0
        assert (opacity[target] > 0) == (support > 0), (target, support, opacity[target])
    supported = sorted((t["max_support"], opacity[i]) for i, t in targets.items() if t["drawn"])
    assert [o for _, o in supported] == sorted(o for _, o in supported)  # more support, more blue
    faintest = min(low, key=lambda t: t["max_support"])
    _, value, fill, ground = next(h for h in halves if h[0] == faintest["id"])
    contrast = _contrast_over(fill, ground, value)
    assert value >= 0.4 and contrast >= 1.7, (faintest["max_support"], value, contrast)
    with capsys.disabled():
        print(
            f"\nsupport {faintest['max_support']:.2f}: blue half opacity {value:.2f},"
            f" contrast {contrast:.2f}:1 over the ground (drawn at its support:"
            f" {_contrast_over(fill, ground, faintest['max_support']):.2f}:1)"
        )
