"""Issue 44: behind the generated nginx, a process lost is "not now" (503, Retry-After), never 502/504.

A 30-minute chaos soak got nginx's own 502 (56) and 504 (16) while a member of the group
was killed -9 or stopped: the one 5xx the soak's invariant allows is a 503 with
Retry-After, which the page (static/live.js), the HTTP bots and a browser's please-wait
page all wait on and send again. Here a real `hcss serve` behind the real nginx is killed
-9 (nginx cannot connect: its 502) and stopped with SIGSTOP (nginx connects and waits past
its read timeout: its 504). The process's own answers, 4xx and all, must pass unchanged.
"""

from __future__ import annotations

import os
import signal
import uuid
from collections.abc import Iterator
from dataclasses import dataclass

import httpx
import pytest

from hcss.platform.cli import DEFAULT_THREADS, upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.idempotency import KEY_HEADER
from hcss.platform.live.trials import start_trial
from hcss.platform.models import Participant
from hcss.platform.serving.localserver import LocalNginx, LocalServer

pytestmark = pytest.mark.slow


@dataclass
class Behind:
    server: LocalServer
    nginx: LocalNginx
    token: str
    trial_id: int

    def client(self, *, direct: bool = False) -> httpx.Client:
        base = self.server.url if direct else self.nginx.url
        return httpx.Client(base_url=base, timeout=60.0)


@pytest.fixture
def behind(tmp_path) -> Iterator[Behind]:
    if not LocalNginx.available():
        pytest.skip(f"needs nginx at {LocalNginx.BINARY}")
    url = f"sqlite:///{tmp_path / 'lost.sqlite3'}"
    upgrade_database(url)
    database = Database(url)
    with database.command_scope() as session:
        participant = Participant(is_demo=True, study="demo")
        session.add(participant)
        session.flush()
        trial = start_trial(session, participant, kind="trial", duration_s=600.0)
        token, trial_id = participant.token, trial.id
    database.engine.dispose()
    server = LocalServer(url, tmp_path / "instance", threads=DEFAULT_THREADS)
    with server, LocalNginx([f"127.0.0.1:{server.port}"], tmp_path / "nginx") as nginx:
        try:
            yield Behind(server, nginx, token, trial_id)
        finally:
            if server.process is not None:
                os.kill(server.process.pid, signal.SIGCONT)


def _not_now(answer: httpx.Response) -> None:
    """A 503 that says when to ask again, as the app's own "database away" does."""
    assert answer.status_code == 503, (answer.status_code, answer.text[:200])
    assert float(answer.headers["Retry-After"]) > 0


def _heading(page: str) -> str:
    return page.split("<h1>", 1)[1].split("</h1>", 1)[0]


def test_a_killed_process_is_a_503_with_retry_after_for_pages_commands_and_forms(
    behind,
) -> None:
    api = f"/api/live/{behind.token}/trials/{behind.trial_id}"
    behind.server.kill()
    with behind.client() as browser:
        page = browser.get(f"/p/{behind.token}/stage")
        _not_now(page)
        assert page.headers["Content-Type"].startswith("text/html")
        assert '<meta http-equiv="refresh"' in page.text  # the please-wait page asks again

        command = browser.post(
            api + "/observations",
            json={"kind": "collective", "collective": 0, "button": "right"},
            headers={KEY_HEADER: uuid.uuid4().hex},
        )
        _not_now(command)
        body = command.json()  # the page's post() reads message and held_by
        assert body["error"] and body["message"] and body["held_by"] == "server"

        form = browser.post(f"/p/{behind.token}/stage/0/form", data={"consent": "y"})
        _not_now(form)

        stream = browser.head(api + "/stream")  # the page's stream asks with HEAD
        _not_now(stream)


def test_a_stopped_process_is_a_503_with_retry_after_not_a_gateway_timeout(behind) -> None:
    assert behind.server.process is not None
    os.kill(behind.server.process.pid, signal.SIGSTOP)
    with behind.client() as browser:
        state = browser.get(f"/api/live/{behind.token}/trials/{behind.trial_id}/state")
    os.kill(behind.server.process.pid, signal.SIGCONT)
    _not_now(state)
    assert state.json()["held_by"] == "server"


def test_the_processes_own_answers_pass_through_unchanged(behind) -> None:
    paths = [
        f"/api/live/{behind.token}/trials/{behind.trial_id + 99}/state",  # no such trial
        "/api/live/not-a-token/trials/1/state",
        "/p/not-a-token/stage",
        f"/api/live/{behind.token}/trials/{behind.trial_id}/state",
    ]
    with behind.client() as proxied, behind.client(direct=True) as direct:
        for path in paths:
            through, straight = proxied.get(path), direct.get(path)
            assert through.status_code == straight.status_code, path
            assert through.headers.get("Content-Type") == straight.headers.get("Content-Type")
            if through.status_code == 200:  # a live state moves on
                continue
            if "json" in through.headers["Content-Type"]:
                assert through.content == straight.content, path
            else:  # a page has a nonce of its own per answer: the same page, the same words
                assert _heading(through.text) == _heading(straight.text), path
            assert "Retry-After" not in through.headers
            assert through.status_code < 500, path
    # A POST the process refuses (no CSRF token): its own 4xx, its own body.
    with behind.client() as proxied, behind.client(direct=True) as direct:
        key = {KEY_HEADER: uuid.uuid4().hex}
        path = f"/api/live/{behind.token}/trials/{behind.trial_id}/observations"
        through = proxied.post(path, json={}, headers=key)
        straight = direct.post(path, json={}, headers={KEY_HEADER: uuid.uuid4().hex})
        assert 400 <= through.status_code < 500
        assert (through.status_code, through.content) == (straight.status_code, straight.content)
