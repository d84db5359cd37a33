"""Issue 13 §7: the HTTP bot loses no POST when the answer is lost in flight.

In the kill -9 rounds one bot of eight failed: the server had received its
POST when it was killed, and the bot, unlike a browser, did not try again.
Now the load tool's HTTP client sends each JSON command with an
Idempotency-Key and repeats it, with the same key, when the connection breaks;
the server carries the key out once and answers the repeat with the first
outcome. A form POST is repeated too; if the server had taken it ("already
submitted", 409), the client opens the form's address, which leads on to the
participant's current page, as a participant reloading would.

The proxy (tests/support/lossy_proxy.py) lets the server do the work, then
drops the answer.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

from sqlalchemy import func, select
from waitress.server import create_server

from hcss.platform.bots.http_load import HttpClient, LoadFigures
from hcss.platform.bots.participant import PageParser
from hcss.platform.models import Command, StageEvent
from hcss.platform.serving.connections import close_server
from tests.support.lossy_proxy import LossyProxy
from tests.support.study_server import study_server
from tests.support.trials import csrf_token_of


@contextmanager
def _served(app) -> Iterator[int]:
    server = create_server(app, host="127.0.0.1", port=0, threads=4)
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    try:
        yield server.effective_port
    finally:
        close_server(server, thread)


def test_a_command_whose_answer_is_lost_is_repeated_with_its_key_and_stored_once(
    app, make_trial
) -> None:
    trial = make_trial()
    with _served(app) as port:
        proxy = LossyProxy(port, drop=f"POST {trial.api}/requests".encode())
        client = HttpClient(proxy.url, LoadFigures(bots=1, concurrency=1))
        csrf = csrf_token_of(client.get(f"/live/{trial.token}").get_data(as_text=True))
        answer = client.post(
            f"{trial.api}/requests",
            json={"kind": "decide", "collective": 0, "target": 1},
            headers={"X-CSRFToken": csrf},
        )
        proxy.close()

    assert len(proxy.dropped) == 1  # the server carried it out; the bot never heard
    assert answer.status_code == 200 and answer.get_json()["accepted"] is False
    sent = [r for r in proxy.requests if r.startswith(b"POST")]
    keys = {line for r in sent for line in r.split(b"\r\n") if line.startswith(b"Idempotency-Key")}
    assert len(sent) == 2 and len(keys) == 1  # repeated, with the same key
    with app.extensions["hcss_db"].session_scope() as session:
        stored = session.scalar(
            select(func.count()).select_from(Command).where(Command.trial_id == trial.trial_id)
        )
    assert stored == 1  # neither lost nor doubled


def test_a_form_whose_answer_is_lost_leads_on_to_the_next_page_once(tmp_path) -> None:
    with study_server(tmp_path) as server:
        token = server.participant(is_bot=True)
        port = int(server.url.rsplit(":", 1)[1])
        proxy = LossyProxy(port, drop=f"POST /p/{token}/stage/".encode())
        client = HttpClient(proxy.url, LoadFigures(bots=1, concurrency=1))
        page = PageParser()
        page.feed(client.get(f"/p/{token}").get_data(as_text=True))
        assert page.stage == "consent"
        answer = client.post(page.action, data=dict(page.hidden) | {"decision": "agree"})
        proxy.close()
        following = PageParser()
        following.feed(answer.get_data(as_text=True))
        with server.database.session_scope() as session:
            submitted = session.scalar(
                select(func.count()).select_from(StageEvent).where(StageEvent.kind == "submitted")
            )

    assert len(proxy.dropped) == 1
    assert answer.status_code == 200 and following.stage not in ("", "consent")
    assert submitted == 1
