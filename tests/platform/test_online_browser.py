"""Online study and replay in Chromium: the acceptance walks of issue 14.

1. A visitor opens the demo study link with Prolific's parameters, is
   enrolled and shown consent; the rest of the study is walked by a
   participant bot (the same answers the bots give, to keep the test short);
   the same link opened again resumes at the debrief, which shows the
   completion code and leads back to Prolific. The export holds the ids.
2. An experimenter signs in, opens a finished trial's replay from the
   participant's page, plays it at 20x and checks the end state's digest.

Screenshots go to test-artifacts/; with HCSS_UPDATE_SCREENSHOTS=1 the replay's
also goes to docs/ for the README (tests/support/screenshots.py).
"""

from __future__ import annotations

import csv
import time
from urllib.parse import urlencode

import pytest
from sqlalchemy import func, select

from hcss.platform.bots.participant import ParticipantBot
from hcss.platform.export.writer import write_export
from hcss.platform.models import Participant, Recruitment, Snapshot
from hcss.platform.study.studyfile import load_study
from hcss.simulation import Simulation
from tests.support.console import code_of, open_replay
from tests.support.inprocess import serving
from tests.support.replays import operate
from tests.support.screenshots import screenshot

pytestmark = pytest.mark.browser

PROLIFIC = {
    "PROLIFIC_PID": "60b7c9d2e4f1a2b3c4d5e6f7",
    "STUDY_ID": "6655aa01",
    "SESSION_ID": "s-01",
}


@pytest.mark.slow
def test_a_prolific_visitor_walks_the_demo_to_its_completion_code(
    browser, demo_bot_app, tmp_path
) -> None:
    from playwright.sync_api import expect

    with serving(demo_bot_app) as url:
        page = browser.new_page(viewport={"width": 1100, "height": 800})
        page.goto(f"{url}/join/demo?{urlencode(PROLIFIC)}")
        expect(page.locator("#device-ok")).to_be_visible()
        page.locator("#join-start").click()
        expect(page.locator("main.study")).to_have_attribute("data-stage", "consent")
        assert "/p/" in page.url and "PROLIFIC_PID" not in page.url

        with demo_bot_app.extensions["hcss_db"].session_scope() as session:
            token = session.scalars(
                select(Participant.token)
                .join(Recruitment, Recruitment.participant_id == Participant.id)
                .where(Recruitment.recruitment_id == PROLIFIC["PROLIFIC_PID"])
            ).one()
        report = ParticipantBot(demo_bot_app, token).run(load_study("demo"))
        assert len(report.trials) == 6  # a training and a trial per model

        # Back through the same study link, with Prolific's new session id: resumed.
        page.goto(f"{url}/join/demo?{urlencode(PROLIFIC | {'SESSION_ID': 's-02'})}")
        expect(page.locator("main.study")).to_have_attribute("data-stage", "debrief")
        expect(page.locator("#completion-code")).to_have_text("DEMO2026")
        screenshot(page, "online-debrief.png")
        # The link back to Prolific (answered here, so no request leaves the machine).
        page.route(
            "https://app.prolific.com/**",
            lambda route: route.fulfill(status=200, content_type="text/html", body="<p>ok</p>"),
        )
        page.locator("#completion-link").click()
        page.wait_for_url("https://app.prolific.com/submissions/complete?cc=DEMO2026")

    with demo_bot_app.extensions["hcss_db"].session_scope() as session:
        assert session.scalar(select(func.count()).select_from(Participant)) == 1
        write_export(session, tmp_path / "export")
    with (tmp_path / "export" / "recruitment.csv").open(encoding="utf-8") as handle:
        (row,) = list(csv.DictReader(handle))
    assert row["participant"] == report.code and row["source"] == "prolific"
    assert (row["recruitment_id"], row["recruiter_study_id"], row["recruiter_session_id"]) == (
        PROLIFIC["PROLIFIC_PID"],
        PROLIFIC["STUDY_ID"],
        "s-01",  # the first visit's session
    )
    with (tmp_path / "export" / "participants.csv").open(encoding="utf-8") as handle:
        (participant,) = list(csv.DictReader(handle))
    assert (participant["participant"], participant["status"]) == (report.code, "completed")


@pytest.mark.slow
def test_a_finished_trial_replays_at_20x_to_the_recorded_digest(
    browser, app, make_trial, experimenter
) -> None:
    from playwright.sync_api import expect

    trial = make_trial(seed=7, duration_s=120.0)
    sent = operate(trial, 120.0)
    with app.extensions["hcss_db"].session_scope() as session:
        final = session.scalars(
            select(Snapshot).where(Snapshot.trial_id == trial.trial_id).order_by(Snapshot.id.desc())
        ).first()
        recorded = Simulation.restore(final.blob).state_digest()
    code = code_of(app, trial.token)

    with serving(app) as url:
        page = open_replay(browser, url, code, trial.trial_id, {"width": 1400, "height": 950})

        replay = page.locator("#replay")
        expect(replay).to_have_attribute("data-state", "ready")
        expect(page.locator("[data-collective]")).to_have_count(4)
        expect(page.locator("#replay-marks .mark:not(.probe-mark)")).to_have_count(sent)
        page.locator("#replay-speed").select_option("20")
        page.locator("#replay-play").click()
        expect(replay).to_have_attribute("data-state", "playing")
        # Midway: pause for the screenshot, then play on to the end.
        # Polled from Python: the page's CSP forbids the eval behind wait_for_function.
        deadline = time.monotonic() + 30
        while int(replay.get_attribute("data-step") or 0) < 60:
            assert time.monotonic() < deadline, "the replay did not reach step 60"
            page.wait_for_timeout(50)
        page.locator("#replay-play").click()
        expect(replay).to_have_attribute("data-state", "paused")
        expect(page.locator("#messages li").first).to_be_visible()
        screenshot(page, "replay.png", docs_name="screenshot-replay.png")
        page.locator("#replay-play").click()
        expect(replay).to_have_attribute("data-state", "ended", timeout=30_000)
        assert replay.get_attribute("data-end-digest") == recorded
        assert replay.get_attribute("data-step") == "120"
        expect(page.locator("#replay-verdict")).to_contain_text("identical to the recording")
        screenshot(page, "replay-end.png")
