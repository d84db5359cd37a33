"""The participant's page through nginx shows frames again after its host is killed, without a reload.

Chromium on the trial page, two `--cluster` processes behind nginx on
PostgreSQL. The page's clock is drawn only from stream frames, so a clock
that moves on after the kill is a stream served by the other process.
"""

from __future__ import annotations

import time

import pytest

from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.serving.localserver import LocalNginx, LocalServer
from tests.support.leases import lease_owner, skip_unless_group
from tests.support.trials import STUDY_TRIAL_S

pytestmark = pytest.mark.browser


def _live_page(database, browser, nginx, servers):
    """A new trial's page opened through nginx, live with its clock running: (the page, the
    trial's id, the lease's owner, the server that owner is)."""
    from playwright.sync_api import expect

    with database.session_scope() as session:
        participant, trial = start_bot_trial(
            session, seed=2, duration_s=STUDY_TRIAL_S, time_acceleration=20.0
        )
        token, trial_id = participant.token, trial.id
    page = browser.new_page()
    page.goto(f"{nginx.url}/live/{token}")
    expect(page.locator("#connection")).to_have_text("live", timeout=15_000)
    expect(page.locator("#clock")).not_to_have_text("0:00", timeout=15_000)
    owner = lease_owner(database, trial_id)
    host = next(s for s in servers if (owner or "").startswith(f"127.0.0.1:{s.port}/"))
    return page, trial_id, owner, host


@pytest.fixture
def group_url(database_url: str) -> str:
    """Skips before the browser starts, on SQLite or without nginx."""
    return skip_unless_group(database_url)


def test_the_page_comes_back_by_itself_on_the_other_process(group_url, tmp_path, browser) -> None:
    from playwright.sync_api import expect

    database_url = group_url
    upgrade_database(database_url)
    database = Database(database_url)
    servers = [
        LocalServer(
            database_url,
            tmp_path / name,
            snapshot_interval_s=1.0,
            serve_args=["--cluster"],
            extra_env={"HCSS_PROXY_HOPS": "1"},
        )
        for name in ("a", "b")
    ]
    nginx = LocalNginx([f"127.0.0.1:{s.port}" for s in servers], tmp_path / "nginx")
    try:
        for server in servers:
            server.start(timeout_s=120)
        nginx.start()
        page, trial_id, owner, host = _live_page(database, browser, nginx, servers)

        host.kill()
        killed = time.monotonic()
        expect(page.locator("#connection")).to_have_text("reconnecting…", timeout=10_000)
        at_kill = page.locator("#clock").text_content()
        expect(page.locator("#connection")).to_have_text("live", timeout=20_000)
        expect(page.locator("#clock")).not_to_have_text(at_kill or "", timeout=20_000)
        print(f"page live again {time.monotonic() - killed:.1f} s after the kill")
        assert lease_owner(database, trial_id) != owner
        page.close()
    finally:
        nginx.stop()
        for server in servers:
            server.stop()
        database.engine.dispose()


@pytest.mark.slow
def test_the_page_of_a_stopped_host_shows_frames_again_while_it_stays_stopped(
    group_url, tmp_path, browser
) -> None:
    """SIGSTOP of the page's host: the connection stays open and silent (nginx connects
    fine to a stopped process). The page's watchdog drops the silent stream, nginx's short
    read timeout passes the new one on, and the clock moves again within 10 s while the
    host is still stopped, served by the other process, without a reload; it never goes
    back. (Before the watchdog, no frame came for as long as the host stayed stopped;
    with it, 6.4-24.2 s, and once none in 60 s: the watchdog dropped the new stream at
    the stopped host before nginx could pass it on, and the other process's claim waited
    on the lease row the stopped host had locked mid-transaction. Now 6.9-7.4 s.)"""
    import os
    import signal

    from playwright.sync_api import expect

    database_url = group_url
    upgrade_database(database_url)
    database = Database(database_url)
    servers = [
        LocalServer(
            database_url,
            tmp_path / name,
            snapshot_interval_s=1.0,
            serve_args=["--cluster"],
            extra_env={"HCSS_PROXY_HOPS": "1"},
        )
        for name in ("a", "b")
    ]
    nginx = LocalNginx([f"127.0.0.1:{s.port}" for s in servers], tmp_path / "nginx")
    stopped_pid = None
    try:
        for server in servers:
            server.start(timeout_s=120)
        nginx.start()
        page, trial_id, owner, host = _live_page(database, browser, nginx, servers)
        assert host.process is not None
        stopped_pid = host.process.pid

        answers: list[str] = []  # what the page's stream requests got, for a failure's message
        page.on(
            "response",
            lambda r: (
                answers.append(
                    f"{time.monotonic() - stopped:.1f}s {r.request.method} {r.status}"
                    f" {r.headers.get('retry-after', '')}"
                )
                if "/stream" in r.url
                else None
            ),
        )
        os.kill(stopped_pid, signal.SIGSTOP)
        stopped = time.monotonic()
        at_stop = page.locator("#clock").text_content() or ""
        try:
            expect(page.locator("#clock")).not_to_have_text(at_stop, timeout=60_000)
        except AssertionError as error:
            shown = page.locator("#connection").text_content()
            raise AssertionError(
                f"{error}\nconnection: {shown}\nstream answers: {answers}"
            ) from error
        back_s = time.monotonic() - stopped
        assert back_s <= 10.0, f"frames again only {back_s:.1f} s after SIGSTOP: {answers}"
        assert lease_owner(database, trial_id) != owner
        shown = [page.locator("#clock").text_content() or ""]
        for _ in range(10):  # it runs on and never goes back
            time.sleep(0.3)
            shown.append(page.locator("#clock").text_content() or "")
        as_seconds = [int(m) * 60 + int(s) for m, s in (t.split(":") for t in shown)]
        assert as_seconds == sorted(as_seconds) and as_seconds[-1] > as_seconds[0]
        print(f"page of a stopped host live again {back_s:.1f} s after SIGSTOP; {answers}")
        page.close()
    finally:
        if stopped_pid is not None:
            os.kill(stopped_pid, signal.SIGCONT)
        nginx.stop()
        for server in servers:
            server.stop()
        database.engine.dispose()
