"""A command the server answers 503 (the database is away) is sent again, once stored.

The page keeps the command's Idempotency-Key across its retries, waits a
growing pause between them, and says why it waits (the 503's `held_by`).
The server here really fails: the first commits of the command's unit of
work raise as a dropped database connection does, so it answers 503 with
Retry-After, and the retry that finally commits stores exactly one command.
"""

from __future__ import annotations

import pytest
from sqlalchemy import event, select
from sqlalchemy.exc import OperationalError

from hcss.platform.models import Command
from tests.support.pages import open_live_trial, wait_for
from tests.support.study_server import StudyServer

pytestmark = pytest.mark.browser

FAILED_COMMITS = 3


def _request_ready(browser, server: StudyServer):
    """A live trial's page with an investigate request chosen, one click from being sent."""
    _, page = open_live_trial(browser, server, {"width": 1280, "height": 900})
    target = wait_for(
        server,
        lambda lv: next(
            (t for t in lv.view()["targets"] if t["drawn"] and 0 in t["in_range_of"]), None
        ),
        90,
    )
    assert target
    page.locator('g.collective[data-collective="0"]').click()
    page.locator(f'g.target[data-target="{target["id"]}"]').click()
    page.select_option("#request-kind", "investigate")
    return page


def _requests_sent(page) -> list[tuple[str | None, int]]:
    """(Idempotency-Key, status) of every answer to a request command the page gets."""
    sent: list[tuple[str | None, int]] = []
    page.on(
        "response",
        lambda r: (
            sent.append((r.request.headers.get("idempotency-key"), r.status))
            if r.url.endswith("/requests")
            else None
        ),
    )
    return sent


def test_a_command_answered_503_is_retried_with_its_key_and_stored_once(
    browser, demo_server: StudyServer
) -> None:
    from playwright.sync_api import expect

    page = _request_ready(browser, demo_server)

    failed: list[int] = []
    flushed_commands: set[int] = set()  # sessions that flushed a command's row (for its id)

    def note_the_command(session, _context) -> None:
        # Noted at its flush: the writer keeps no reference to the row, so by the commit it
        # may have left the session's (weak) identity map.
        if any(isinstance(o, Command) for o in session.new):
            flushed_commands.add(id(session))

    def drop_the_command(session, *_args) -> None:
        wrote = id(session) in flushed_commands
        flushed_commands.discard(id(session))
        if len(failed) < FAILED_COMMITS and wrote:
            failed.append(1)
            raise OperationalError("COMMIT", {}, Exception("server closed the connection"))

    sent = _requests_sent(page)
    sessions = demo_server.database.sessions
    event.listen(sessions, "after_flush", note_the_command)
    event.listen(sessions, "before_commit", drop_the_command)
    try:
        page.locator("#commit").click()
        expect(page.locator("#request-note")).to_contain_text("database", timeout=5000)
        expect(page.locator("#request-note")).to_contain_text("accepted", timeout=20000)
    finally:
        event.remove(sessions, "before_commit", drop_the_command)
        event.remove(sessions, "after_flush", note_the_command)

    assert len(failed) == FAILED_COMMITS
    assert [status for _, status in sent] == [503] * FAILED_COMMITS + [200]
    keys = {key for key, _ in sent}
    assert len(keys) == 1 and None not in keys  # one key across every attempt
    with demo_server.database.session_scope() as session:
        assert len(session.scalars(select(Command)).all()) == 1
    expect(page.locator("#messages li.accepted")).to_have_count(1)


def test_a_command_whose_answer_the_proxy_lost_is_retried_and_stored_once(
    browser, demo_server: StudyServer
) -> None:
    """nginx answers 502 when the process dies with a request in flight (the cluster
    failover test saw it): the command may have been stored, its answer lost. The
    page sends it again with its key, and the server answers the first answer."""
    from playwright.sync_api import expect

    page = _request_ready(browser, demo_server)
    lost: list[int] = []

    def lose_the_first_answer(route) -> None:
        if lost:
            route.continue_()
            return
        route.fetch()  # the server stores the command ...
        lost.append(1)
        route.fulfill(status=502, body="<html>502 Bad Gateway</html>")  # ... its answer is lost

    sent = _requests_sent(page)
    page.route("**/requests", lose_the_first_answer)
    page.locator("#commit").click()
    expect(page.locator("#request-note")).to_contain_text("accepted", timeout=20000)

    assert [status for _, status in sent] == [502, 200]
    keys = {key for key, _ in sent}
    assert len(keys) == 1 and None not in keys
    with demo_server.database.session_scope() as session:
        assert len(session.scalars(select(Command)).all()) == 1
    expect(page.locator("#messages li.accepted")).to_have_count(1)
