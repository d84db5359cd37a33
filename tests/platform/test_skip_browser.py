"""A skip reaches the open page in a real browser: the participant's page, with an answer
ticked, moves on by itself at its next heartbeat and keeps the answer given."""

from __future__ import annotations

import threading

import pytest
from waitress.server import create_server

from hcss.platform.bots.participant import bot_app
from hcss.platform.cli import upgrade_database
from hcss.platform.console.accounts import create_experimenter
from hcss.platform.models import Participant
from tests.support.console import Console, sign_in
from tests.support.study import events, visitor

pytestmark = [pytest.mark.browser, pytest.mark.slow]  # waits for a 10 s heartbeat


@pytest.fixture
def served(tmp_path):
    url = f"sqlite:///{tmp_path / 'skip-browser.sqlite3'}"
    upgrade_database(url)
    app = bot_app(url, "demo", SECRET_KEY="skip-browser-secret", WTF_CSRF_ENABLED=True)
    with app.extensions["hcss_db"].session_scope() as session:
        create_experimenter(session, "lab", "a long enough password")
    server = create_server(app, host="127.0.0.1", port=0, threads=4)
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    yield app, f"http://127.0.0.1:{server.effective_port}"
    server.close()
    server.task_dispatcher.shutdown()
    thread.join(timeout=5)
    app.extensions["hcss_db"].engine.dispose()


def test_the_open_page_moves_on_by_itself_and_keeps_the_answer(served, browser) -> None:
    from playwright.sync_api import expect

    app, base = served
    with app.extensions["hcss_db"].session_scope() as session:
        participant = Participant(study="demo")
        session.add(participant)
        session.flush()
        token, code = participant.token, participant.code
    visitor(app, token).submit({"decision": "agree"})  # consent given: demographics next
    client = app.test_client()
    assert sign_in(client, "lab", "a long enough password").status_code == 302
    console = Console(app=app, client=client)
    console.get("/console/")

    page = browser.new_page()
    page.goto(f"{base}/p/{token}")
    expect(page.locator("main.study")).to_have_attribute("data-stage", "demographics")
    page.check('input[name="age_band"][value="18-30"]')
    assert console.act(code, "skip_stage").status_code == 303
    # No click: the next heartbeat (every 10 s) learns of the skip.
    expect(page.locator("#moved-on")).to_contain_text(
        "The answers you gave on it were kept", timeout=20_000
    )
    page.click("#continue")
    expect(page.locator("main.study")).to_have_attribute("data-stage", "mental_rotation")
    (late,) = [e for e in events(app, token) if e.kind == "late_answer"]
    assert late.detail["answers"]["age_band"] == ["18-30"]
