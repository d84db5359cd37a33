"""Issue 13 §3: a page refused a stream (503, server full) waits Retry-After and comes back.

EventSource gives up for good on an answer other than 200, so before the
fix a participant who arrived while the server held as many streams as it
can stayed on "reconnecting…" with a frozen map. The page now asks again
(HEAD), waits as long as Retry-After says, and opens a new stream.
"""

from __future__ import annotations

import http.client
import time
from urllib.parse import urlsplit

import pytest

from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.stream_slots import RETRY_AFTER_S
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.serving.localserver import LocalServer
from tests.support.trials import STUDY_TRIAL_S

pytestmark = pytest.mark.browser


def _participants_with_trials(url: str, n: int) -> list[tuple[str, int]]:
    database = Database(url)
    links = []
    with database.session_scope() as session:
        for seed in range(n):
            participant, trial = start_bot_trial(session, seed=seed + 2, duration_s=STUDY_TRIAL_S)
            links.append((participant.token, trial.id))
    database.engine.dispose()
    return links


def test_a_refused_stream_comes_back_after_retry_after(browser, tmp_path) -> None:
    from playwright.sync_api import expect

    url = f"sqlite:///{tmp_path / 'retry.sqlite3'}"
    upgrade_database(url)
    (holder, holder_trial), (token, _) = _participants_with_trials(url, 2)
    # 17 threads, 16 kept for pages: room for one stream, which another participant holds.
    with LocalServer(url, tmp_path / "instance", threads=17) as server:
        parts = urlsplit(server.url)
        held = http.client.HTTPConnection(parts.hostname, parts.port, timeout=10)
        held.request("GET", f"/api/live/{holder}/trials/{holder_trial}/stream")
        holding = held.getresponse()
        assert holding.status == 200
        assert holding.read1(4096).startswith(b"retry:")  # the stream is open

        page = browser.new_page()
        streams: list[tuple[float, str]] = []
        answers: list[tuple[float, str, int]] = []
        page.on(
            "request",
            lambda r: streams.append((time.monotonic(), r.method)) if "/stream" in r.url else None,
        )
        page.on(
            "response",
            lambda r: (
                answers.append((time.monotonic(), r.request.method, r.status))
                if "/stream" in r.url
                else None
            ),
        )
        page.goto(f"{server.url}/live/{token}")
        expect(page.locator("#connection")).to_have_text("reconnecting…")
        deadline = time.monotonic() + 10
        while not any(method == "HEAD" for _, method, _ in answers):
            assert time.monotonic() < deadline, answers
            page.wait_for_timeout(100)
        refused_at = next(t for t, method, status in answers if method == "HEAD")
        assert [(m, s) for _, m, s in answers] == [("GET", 503), ("HEAD", 503)]

        holding.close()  # the other participant leaves: a stream is free
        held.close()
        expect(page.locator("#connection")).to_have_text("live", timeout=4 * RETRY_AFTER_S * 1000)
        expect(page.locator("#clock")).not_to_have_text("0:00")
        page.close()

    again = [t for t, method in streams if method == "GET"][1]
    assert again - refused_at >= RETRY_AFTER_S * 0.95  # it waited as Retry-After said
