"""MTurk end to end in Chromium, with a stand-in for MTurk playing its side.

MTurk shows an ExternalQuestion in an iframe on its own site and takes the
answer as a form posted to `turkSubmitTo` + `/mturk/externalSubmit`
(docs.aws.amazon.com, "How Mechanical Turk tasks are rendered"). The stand-in
(tests/support/mturk_standin.py) is on another site than the study, named by
the study file's `mturk_origins` as a real study names MTurk by `mturk = true`:

1. the HIT's preview (assignmentId=ASSIGNMENT_ID_NOT_AVAILABLE) shows in the
   frame and records nothing;
2. an origin the study does not name cannot frame the link, and MTurk's own
   origin cannot frame any other page (the console);
3. the accepted HIT shows in the frame, opens the study in its own window; the
   worker walks it (a participant bot, as in test_online_browser) and the
   debrief posts the assignment id and the completion code to the stand-in.
"""

from __future__ import annotations

from urllib.parse import urlencode

import pytest
from sqlalchemy import select

from hcss.platform.bots.participant import ParticipantBot, bot_app
from hcss.platform.models import Participant, Recruitment
from hcss.platform.study.studyfile import load_study
from tests.support.counting import count_rows
from tests.support.inprocess import serving
from tests.support.mturk_standin import mturk_standin
from tests.support.recruitment import demo_variant
from tests.support.screenshots import screenshot

pytestmark = pytest.mark.browser

HIT = {"workerId": "A2WORKER7", "hitId": "3HITXYZ", "assignmentId": "3ASSIGN42"}


def _refused(frame) -> bool:
    """Chromium shows a refused frame as its error page, with none of the study's page."""
    return frame.url.startswith("chrome-error://") or frame.locator("main").count() == 0


@pytest.mark.slow
def test_an_mturk_worker_previews_accepts_walks_and_submits_the_assignment(
    browser, database_url, tmp_path, monkeypatch
) -> None:
    from playwright.sync_api import expect

    with mturk_standin() as mturk, mturk_standin() as stranger:
        name = demo_variant(
            tmp_path / "studies",
            monkeypatch,
            "hitstudy",
            {"mturk": "true", "mturk_origins": f'["{mturk.origin}"]'},
        )
        app = bot_app(database_url, name)
        app.extensions["hcss_db"].create_all()
        with serving(app) as url:
            context = browser.new_context(viewport={"width": 1366, "height": 657})
            worker = context.new_page()

            # 1. The preview: shown in MTurk's frame, nothing recorded.
            preview = HIT | {"assignmentId": "ASSIGNMENT_ID_NOT_AVAILABLE"}
            mturk.hit_url = (
                f"{url}/join/{name}?{urlencode(preview | {'turkSubmitTo': mturk.origin})}"
            )
            worker.goto(mturk.worker_page())
            frame = worker.frame_locator("#hit")
            expect(frame.locator("main")).to_contain_text("accept the HIT")
            assert count_rows(app, Participant) == 0 and count_rows(app, Recruitment) == 0

            # 2. Another site may not frame the link; MTurk may not frame the console.
            accepted = f"{url}/join/{name}?{urlencode(HIT | {'turkSubmitTo': mturk.origin})}"
            stranger.hit_url = accepted
            worker.goto(stranger.worker_page())
            worker.wait_for_load_state("load")
            assert _refused(worker.frames[1])
            mturk.hit_url = f"{url}/console/login"
            worker.goto(mturk.worker_page())
            worker.wait_for_load_state("load")
            assert _refused(worker.frames[1])

            # 3. The accepted HIT: the frame offers the study in its own window.
            mturk.hit_url = accepted
            worker.goto(mturk.worker_page())
            expect(frame.locator("#join-framed")).to_be_visible()
            expect(frame.locator("#join-form")).to_be_hidden()
            screenshot(worker, "mturk-frame.png")
            with context.expect_page() as opened:
                frame.locator("#join-own-window").click()
            study = opened.value
            expect(study.locator("#device-ok")).to_be_visible()
            study.locator("#join-start").click()
            expect(study.locator("main.study")).to_have_attribute("data-stage", "consent")

            with app.extensions["hcss_db"].session_scope() as session:
                row = session.scalars(select(Recruitment)).one()
                assert (row.source, row.recruitment_id, row.recruiter_session_id) == (
                    "mturk",
                    HIT["workerId"],
                    HIT["assignmentId"],
                )
                assert row.submit_to == mturk.origin
                token = session.get(Participant, row.participant_id).token
            ParticipantBot(app, token).run(load_study(name))

            study.reload()
            expect(study.locator("main.study")).to_have_attribute("data-stage", "debrief")
            expect(study.locator("#mturk-submit")).to_have_attribute(
                "action", f"{mturk.origin}/mturk/externalSubmit"
            )
            screenshot(study, "mturk-debrief.png")
            study.locator("#mturk-submit-button").click()
            expect(study.locator("#submitted")).to_have_text("HIT submitted")
            assert mturk.submissions == [
                {"assignmentId": [HIT["assignmentId"]], "completionCode": ["DEMO2026"]}
            ]
            assert stranger.submissions == []
            context.close()
        app.extensions["hcss_db"].engine.dispose()


@pytest.mark.slow
def test_the_submit_follows_mturks_redirect_and_the_hit_frame_then_says_the_study_is_done(
    browser, database_url, tmp_path, monkeypatch
) -> None:
    """MTurk answers externalSubmit with a redirect to another of its hosts: the debrief's
    form-action lets it through (Chromium checks form-action on each redirect of a form's
    navigation), and the HIT's frame stops offering the study once it is done."""
    from playwright.sync_api import expect

    with mturk_standin() as mturk, mturk_standin() as worker_site:
        mturk.redirect_to = worker_site.origin
        name = demo_variant(
            tmp_path / "studies",
            monkeypatch,
            "hitredirect",
            {"mturk": "true", "mturk_origins": f'["{mturk.origin}", "{worker_site.origin}"]'},
        )
        app = bot_app(database_url, name)
        app.extensions["hcss_db"].create_all()
        with serving(app) as url:
            context = browser.new_context(viewport={"width": 1366, "height": 657})
            worker = context.new_page()
            mturk.hit_url = f"{url}/join/{name}?{urlencode(HIT | {'turkSubmitTo': mturk.origin})}"
            worker.goto(mturk.worker_page())
            frame = worker.frame_locator("#hit")
            with context.expect_page() as opened:
                frame.locator("#join-own-window").click()
            study = opened.value
            study.locator("#join-start").click()
            expect(study.locator("main.study")).to_have_attribute("data-stage", "consent")
            with app.extensions["hcss_db"].session_scope() as session:
                row = session.scalars(select(Recruitment)).one()
                token = session.get(Participant, row.participant_id).token
            ParticipantBot(app, token).run(load_study(name))

            study.reload()
            study.locator("#mturk-submit-button").click()
            expect(study.locator("#submitted")).to_have_text("HIT submitted")
            assert study.url == f"{worker_site.origin}/submitted"
            assert len(mturk.submissions) == 1

            # Back on MTurk's page: the frame learns the study is done, without a reload.
            expect(frame.locator("#join-finished")).to_be_visible(timeout=15_000)
            expect(frame.locator("#join-own-window")).to_be_hidden()
            worker.reload()  # and so does the frame shown afresh
            expect(frame.locator("#join-finished")).to_be_visible()
            expect(frame.locator("#join-own-window")).to_be_hidden()
            context.close()
        app.extensions["hcss_db"].engine.dispose()
