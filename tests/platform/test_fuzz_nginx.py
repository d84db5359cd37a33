"""The fuzzer's requests through a real nginx (`hcss deploy nginx`) in front of a real `hcss serve`.

test_fuzz.py sends its requests to the app in-process; here the same route
groups (live API, study pages, console, hostile Host headers and multipart
names) go over TCP through nginx to waitress, as a deployment receives them, on
SQLite and (with HCSS_TEST_DATABASE_URL) on PostgreSQL,
CSRF on (each client sends its page's token, so the fuzz reaches the code
behind it). No answer may be a 5xx, nginx's own 502/504 included (a server
that broke a connection), and the server's log must hold no traceback.

The suite sends `EXAMPLES` per group (a few, for time); `make fuzz` sets
HCSS_FUZZ_NGINX_EXAMPLES for the long run and adds the tally to its own.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

import h11
import httpx
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hcss.platform.cli import upgrade_database
from hcss.platform.console.accounts import create_experimenter
from hcss.platform.db import Database
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.serving.localserver import LocalNginx, LocalServer, postgres_schema
from tests.support.databases import PG_ENV
from tests.support.fuzz import (
    FUZZ_SETTINGS,
    TALLY_FILE,
    console_requests,
    envelopes,
    live_requests,
    study_requests,
)
from tests.support.trials import STUDY_TRIAL_S, csrf_token_of

pytestmark = pytest.mark.slow

EXAMPLES = int(os.environ.get("HCSS_FUZZ_NGINX_EXAMPLES", "25"))
USERNAME, PASSWORD = "alice", "correct horse battery"


@dataclass
class Proxied:
    """The names the strategies fill in, and the two browsers that send them."""

    token: str
    code: str
    trial_id: int
    participant: httpx.Client
    console: httpx.Client
    server: LocalServer
    tally: Counter[str] = field(default_factory=Counter)


@pytest.fixture(scope="module", params=["sqlite", "postgresql"])
def proxied(request, tmp_path_factory) -> Iterator[Proxied]:
    """The server behind nginx on SQLite, and on PostgreSQL when the suite has one."""
    if not LocalNginx.available():
        pytest.skip(f"needs nginx at {LocalNginx.BINARY} (scripts/ensure-nginx installs it)")
    folder = tmp_path_factory.mktemp("fuzz-nginx")
    with ExitStack() as stack:
        if request.param == "sqlite":
            url = f"sqlite:///{folder / 'fuzz.sqlite3'}"
        elif os.environ.get(PG_ENV):
            url = stack.enter_context(postgres_schema(os.environ[PG_ENV], "fuzz_nginx"))
        else:
            pytest.skip(f"PostgreSQL's run needs {PG_ENV}")
        yield from _proxied(url, folder, f"nginx+{request.param}")


def _proxied(url: str, folder: Path, label: str) -> Iterator[Proxied]:
    upgrade_database(url)
    database = Database(url)
    with database.session_scope() as session:
        create_experimenter(session, USERNAME, PASSWORD)
        participant, trial = start_bot_trial(session, seed=2, duration_s=STUDY_TRIAL_S)
        token, code, trial_id = participant.token, participant.code, trial.id
    database.engine.dispose()
    server = LocalServer(url, folder / "instance", extra_env={"HCSS_PROXY_HOPS": "1"})
    with server, LocalNginx([f"127.0.0.1:{server.port}"], folder / "nginx") as nginx:
        participant_client = httpx.Client(base_url=nginx.url, timeout=30.0)
        console = httpx.Client(base_url=nginx.url, timeout=30.0)
        page = participant_client.get(f"/live/{token}")
        participant_client.headers["X-CSRFToken"] = csrf_token_of(page.text)
        login = console.get("/console/login")
        fields = {"csrf_token": csrf_token_of(login.text), "username": USERNAME}
        signed_in = console.post("/console/login", data=fields | {"password": PASSWORD})
        assert signed_in.status_code == 302, signed_in.text
        console.headers["X-CSRFToken"] = csrf_token_of(console.get("/console/").text)
        fuzzed = Proxied(token, code, trial_id, participant_client, console, server)
        try:
            yield fuzzed
        finally:
            participant_client.close()
            console.close()
            if TALLY_FILE:
                with open(TALLY_FILE, "a", encoding="utf-8") as handle:
                    for status, count in sorted(fuzzed.tally.items()):
                        handle.write(f"{status} {count} (through-nginx) {label}\n")
    log = server.log_path.read_text(errors="replace")
    assert "Traceback" not in log, log[log.index("Traceback") - 2000 :][:6000]


def _send(proxied: Proxied, client: httpx.Client, request: tuple[str, str, dict[str, Any]]) -> None:
    """One of the fuzzer's requests (Flask test-client options) sent over HTTP through nginx."""
    method, path, options = request
    headers = {
        name: value.encode("latin-1", "replace")
        for name, value in options.get("headers", {}).items()
    }
    content: bytes | None = None
    form: dict[str, str] | None = None
    files: dict[str, tuple[str, bytes]] | None = None
    if "json" in options:
        content = json.dumps(options["json"]).encode()
        headers["Content-Type"] = b"application/json"
    elif isinstance(options.get("data"), dict):
        fields = options["data"]
        form = {k: v for k, v in fields.items() if not isinstance(v, tuple)}
        files = {k: (v[1], v[0].getvalue()) for k, v in fields.items() if isinstance(v, tuple)}
    elif "data" in options:
        data = options["data"]
        content = data if isinstance(data, bytes) else data.encode("utf-8", "surrogatepass")
        headers["Content-Type"] = str(options.get("content_type", "")).encode("latin-1", "replace")
    try:
        with client.stream(
            method, path, headers=headers, content=content, data=form, files=files or None
        ) as answer:
            if not answer.headers.get("content-type", "").startswith("text/event-stream"):
                answer.read()  # a live stream's status is enough; its frames never end
    except (h11.LocalProtocolError, httpx.LocalProtocolError, UnicodeEncodeError):
        proxied.tally["unsendable"] += 1  # a header no HTTP client can send (a NUL, a break)
        return
    proxied.tally[str(answer.status_code)] += 1
    assert answer.status_code < 500, (method, path[:200], answer.status_code, answer.text[:300])


def _fuzz(proxied: Proxied, group: Any, client_of: Any, wrap: bool = False) -> None:
    @settings(FUZZ_SETTINGS, max_examples=EXAMPLES)
    @given(data=st.data())
    def fuzz(data: st.DataObject) -> None:
        chosen = group if group is not None else data.draw(st.sampled_from(GROUPS))
        request = data.draw(chosen(proxied))
        if wrap:
            request = data.draw(envelopes(request))
        _send(proxied, client_of(chosen, proxied), request)

    fuzz()


GROUPS = [live_requests, study_requests, console_requests]


def _client(group: Any, proxied: Proxied) -> httpx.Client:
    return proxied.console if group is console_requests else proxied.participant


@pytest.mark.parametrize("group", GROUPS, ids=["live", "study", "console"])
def test_fuzz_through_nginx_gives_no_5xx(proxied: Proxied, group: Any) -> None:
    _fuzz(proxied, group, _client)


def test_fuzz_hosts_and_multipart_names_through_nginx_gives_no_5xx(proxied: Proxied) -> None:
    _fuzz(proxied, None, _client, wrap=True)


def test_a_signed_out_console_link_with_a_long_query_signs_in_first_through_nginx(
    proxied: Proxied,
) -> None:
    """Found by this fuzz: the sign-in redirect carried the whole URL in `next`, a Location
    header past nginx's 4 kB for response headers, and nginx answered 502."""
    with httpx.Client(base_url=str(proxied.console.base_url), timeout=30.0) as visitor:
        long_query = "/console/links?codes=" + "9" * 5000
        answer = visitor.get(long_query)
        assert answer.status_code == 302, answer.status_code
        assert answer.headers["location"].startswith("/console/login")
        short = visitor.get("/console/links?codes=ABC")
        asked = parse_qs(urlsplit(short.headers["location"]).query)["next"]
        assert asked == ["/console/links?codes=ABC"]  # a short one still comes back after
