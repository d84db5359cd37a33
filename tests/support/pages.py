"""The browser tests' pages: a demo study server, its live trial, and the page a participant sees.

The browser tests click as a participant does against waitress in this process
(tests/support/study_server.py), on a clock the test moves.
"""

from __future__ import annotations

import re
from collections.abc import Iterator

import pytest

from tests.support.study_server import StudyServer, study_server
from tests.support.trials import STUDY_TRIAL_S

#: A common laptop's window.
LAPTOP = {"width": 1366, "height": 768}


@pytest.fixture
def demo_server(tmp_path) -> Iterator[StudyServer]:
    """The demo study served in this process, on a fresh SQLite file."""
    with study_server(tmp_path, "demo") as server:
        yield server


def live_trial(server: StudyServer):
    """The one trial the runner holds for the test's participant."""
    (live,) = [
        t for t in map(server.runner.loaded, server.runner.loaded_ids()) if t and not t.ended
    ]
    return live


def wait_for(server: StudyServer, condition, limit_s: float):
    """Advance the clock a second at a time until `condition(live)` is truthy."""
    live = live_trial(server)
    for _ in range(int(limit_s)):
        found = condition(live)
        if found:
            return found
        server.advance(1.0)
    return None


def start_live_trial(server: StudyServer, seed: int = 2) -> str:
    from datetime import UTC, datetime

    from hcss.platform.live.trials import start_trial
    from hcss.platform.models import Participant

    with server.app.app_context(), server.database.session_scope() as session:
        participant = Participant(is_demo=True)
        session.add(participant)
        session.flush()
        start_trial(
            session,
            participant,
            seed=seed,
            duration_s=STUDY_TRIAL_S,
            started_at=datetime.fromtimestamp(server.clock.now, UTC),
        )
        return participant.token


def open_live_trial(browser, server: StudyServer, viewport: dict[str, int] = LAPTOP):
    """A demo participant's live trial, started and shown connected: (token, page)."""
    from playwright.sync_api import expect

    token = start_live_trial(server)
    page = browser.new_page(viewport=viewport)
    page.goto(f"{server.url}/live/{token}")
    expect(page.locator("#connection")).to_have_text("live")
    return token, page


def contrast(first: str, second: str) -> float:
    """WCAG 2 contrast ratio of two CSS rgb() colours."""

    def luminance(css: str) -> float:
        channels = [int(v) / 255 for v in re.findall(r"\d+", css)[:3]]
        linear = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in channels]
        return 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]

    high, low = sorted((luminance(first), luminance(second)), reverse=True)
    return (high + 0.05) / (low + 0.05)
