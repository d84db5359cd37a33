"""The Collective Interface in a real browser: Chromium through Playwright, against waitress."""

from __future__ import annotations

import re

import pytest
from sqlalchemy import select

from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.client import TrialClient
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.models import Observation, ProbeEvent
from hcss.platform.serving.localserver import LocalServer
from hcss.simulation import ROMAN
from tests.support.screenshots import screenshot
from tests.support.trials import STUDY_TRIAL_S

pytestmark = pytest.mark.browser

ACCELERATION = 6.0


@pytest.fixture
def live_trial(tmp_path):
    url = f"sqlite:///{tmp_path / 'browser.sqlite3'}"
    upgrade_database(url)
    database = Database(url)
    with database.session_scope() as session:
        participant, _ = start_bot_trial(
            session, seed=2, duration_s=STUDY_TRIAL_S, time_acceleration=ACCELERATION
        )
        token = participant.token
    with LocalServer(url, tmp_path / "instance") as server:
        yield server, token, database
    database.engine.dispose()


def test_participant_runs_a_trial_in_the_browser(browser, live_trial) -> None:
    from playwright.sync_api import expect

    server, token, database = live_trial
    page = browser.new_page(viewport={"width": 1440, "height": 900})
    page.goto(f"{server.url}/live/{token}")

    # Four collectives, each a white box with its numeral over U, F, C, X.
    expect(page.locator("#layer-collectives g.collective")).to_have_count(4)
    expect(page.locator("#connection")).to_have_text("live")
    for name in ROMAN[:4]:
        expect(
            page.locator("#layer-collectives .hub-name", has_text=re.compile(f"^{name}$"))
        ).to_have_count(1)

    # Wait for a drawn target in range of collective I.
    client = TrialClient(server.url, token)
    client.open_page()
    page.wait_for_selector("#layer-targets g.target:not(.undrawn)", timeout=30_000)
    target = None
    for _ in range(100):
        view = client.state()["view"]
        target = next((t for t in view["targets"] if t["drawn"] and 0 in t["in_range_of"]), None)
        if target:
            break
        page.wait_for_timeout(200)
    assert target, "no drawn target in range of collective I"

    # Left-click the hub and the target: the form fills, the hub's range is outlined.
    page.locator('g.collective[data-collective="0"]').click()
    page.locator(f'g.target[data-target="{target["id"]}"]').click()
    expect(page.locator("#request-collective")).to_have_value("0")
    expect(page.locator("#request-target")).to_have_value(str(target["id"]))
    expect(page.locator("circle.range")).to_have_count(1)
    page.select_option("#request-kind", "investigate")
    page.click("#commit")
    assignment = page.locator(
        "#assignments li", has_text=f"investigate · I → target {target['id']}"
    )
    expect(assignment).to_have_count(1)
    expect(assignment.locator(".dot")).to_have_class(re.compile("in_progress|completed"))
    expect(page.locator("#request-note")).to_contain_text("accepted")
    expect(page.locator("#request-kind")).to_have_value("")  # the form resets after a commit
    screenshot(page, "trial-assignment.png")

    # Right-click a target: its support flag; logged as an observation action.
    page.locator(f'g.target[data-target="{target["id"]}"]').click(button="right")
    expect(page.locator("#layer-flags .flag")).to_contain_text(f"Target {target['id']}")

    # A decide with too little support is refused, and System Messages says why.
    view = client.state()["view"]
    weakest = min(
        (t for t in view["targets"] if 0 in t["in_range_of"]), key=lambda t: t["support"][0]
    )
    page.select_option("#request-kind", "decide")
    page.select_option("#request-collective", "0")
    page.select_option("#request-target", str(weakest["id"]))
    page.click("#commit")
    expect(page.locator("#messages li.refusal").first).to_contain_text("decide needs at least 30%")

    # An SA probe: press ready, read the question, answer it.
    page.wait_for_selector("#probe:not([hidden])", timeout=90_000)
    screenshot(page, "trial-probe.png")
    page.click("#probe-ready")
    page.wait_for_selector("#probe-choices button", timeout=10_000)
    question = page.locator("#probe-text").inner_text()
    assert question.startswith("Which ")
    page.locator("#probe-choices button").first.click()
    expect(page.locator("#probe")).to_be_hidden()
    screenshot(page, "trial-mid.png")

    with database.session_scope() as session:
        kinds = [e.kind for e in session.scalars(select(ProbeEvent).order_by(ProbeEvent.id))]
        clicks = [(o.kind, o.button) for o in session.scalars(select(Observation))]
    assert "ready" in kinds and "answer" in kinds
    assert ("collective", "left") in clicks and ("target", "right") in clicks
    page.close()
