"""Placement: nginx and every process of the group put a participant on the same member.

nginx runs the configuration `hcss deploy nginx` writes, in front of plain HTTP
servers that say which member they are; `placement.home` must name, for every
token, the member nginx sent the request to, with all members up and with one
down, and the tokens must split evenly (within 5 % of an even share at 2 and
3 members; nginx's `consistent` ring put 54-59 % on one of two). A member that
answers with X-Accel-Redirect to another member's named location has nginx
send the same request there, method and body included, marked as forwarded.

Then two `hcss serve --cluster` processes on PostgreSQL: a participant whose
stream is refused by the trial's holder (its stream ceiling is reached) is
passed on by nginx to the other process, which forwards the request to the
holder and never takes the trial: 0 lease changes, 0 interruptions, while the
trial's page keeps working through nginx.
"""

from __future__ import annotations

import http.server
import json
import random
import string
import threading
import time
from collections import Counter
from collections.abc import Iterator

import httpx
import pytest
from sqlalchemy import func, select

from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.client import TrialClient
from hcss.platform.live.placement import home, nginx_order
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.models import Interruption, TrialLease
from hcss.platform.serving.localserver import LocalNginx, LocalServer, as_group, free_port
from tests.support.leases import LEASE_S, skip_unless_group
from tests.support.trials import STUDY_TRIAL_S

needs_nginx = pytest.mark.skipif(
    not LocalNginx.available(), reason=f"needs nginx at {LocalNginx.BINARY}"
)


def _tokens(count: int, seed: int) -> list[str]:
    """Participant-like tokens (the platform's are URL-safe base64), the same every run."""
    rng = random.Random(seed)
    alphabet = string.ascii_letters + string.digits + "-_"
    return ["".join(rng.choice(alphabet) for _ in range(22)) for _ in range(count)]


@pytest.mark.parametrize("members", [2, 3])
def test_the_placement_splits_tokens_evenly(members: int) -> None:
    addresses = [f"127.0.0.1:{5000 + index}" for index in range(members)]
    split = Counter(home(token, addresses, addresses) for token in _tokens(20_000, members))
    even = 20_000 / members
    assert all(abs(split[a] - even) <= 0.05 * even for a in addresses), split
    # Each member's own tokens are spread evenly over the others when it is down.
    for down in addresses:
        live = [a for a in addresses if a != down]
        theirs = [t for t in _tokens(20_000, members) if nginx_order(t, addresses)[0] == down]
        moved = Counter(home(t, addresses, live) for t in theirs)
        assert set(moved) == set(live)
        assert all(abs(moved[a] - len(theirs) / len(live)) <= 0.1 * len(theirs) for a in live)


class _Member(http.server.BaseHTTPRequestHandler):
    """A stand-in process: says which member it is, and forwards `/p/fwd-*` to `forward_to`."""

    forward_to = ""

    def log_message(self, *_args: object) -> None:
        pass

    def _answer(self) -> None:
        body = self.rfile.read(int(self.headers.get("Content-Length") or 0))
        host, port = self.server.server_address[:2]
        if self.path.startswith("/p/fwd-") and self.headers.get("X-Hcss-Forward") == "1":
            self.send_response(200)
            self.send_header("X-Accel-Redirect", f"@hcss_{self.forward_to}")
            self.send_header("Content-Length", "0")
            self.end_headers()
            return
        answer = json.dumps(
            {
                "member": f"{host}:{port}",
                "method": self.command,
                "body": body.decode(),
                "forward": self.headers.get("X-Hcss-Forward"),
            }
        ).encode()
        self.send_response(200)
        self.send_header("Content-Length", str(len(answer)))
        self.end_headers()
        self.wfile.write(answer)

    do_GET = do_POST = _answer


@pytest.fixture
def members(tmp_path) -> Iterator[tuple[list[str], dict[str, http.server.HTTPServer], LocalNginx]]:
    """Three stand-in members on loopback addresses behind the generated nginx."""
    servers: dict[str, http.server.HTTPServer] = {}
    for host in ("127.0.0.2", "127.0.0.3", "127.0.0.4"):
        server = http.server.ThreadingHTTPServer((host, free_port()), _Member)
        servers[f"{host}:{server.server_address[1]}"] = server
        threading.Thread(target=server.serve_forever, daemon=True).start()
    addresses = list(servers)
    _Member.forward_to = addresses[2]
    nginx = LocalNginx(addresses, tmp_path / "nginx").start()
    try:
        yield addresses, servers, nginx
    finally:
        nginx.stop()
        for server in servers.values():
            server.shutdown()
            server.server_close()


@needs_nginx
def test_nginx_sends_each_participant_to_the_member_placement_names(members) -> None:
    addresses, servers, nginx = members
    tokens = _tokens(600, 7)
    with httpx.Client(base_url=nginx.url, timeout=5) as client:
        sent = {t: client.get(f"/p/{t}/x").json()["member"] for t in tokens}
        assert sent == {t: home(t, addresses, addresses) for t in tokens}
        split = Counter(sent.values())
        assert all(abs(split[a] - 200) <= 0.15 * 200 for a in addresses), split

        down = addresses[0]
        servers[down].shutdown()
        servers[down].server_close()
        live = addresses[1:]
        sent = {t: client.get(f"/live/{t}").json()["member"] for t in tokens}
        assert sent == {t: home(t, addresses, live) for t in tokens}


@needs_nginx
def test_a_member_forwards_a_request_whole_through_nginx(members) -> None:
    addresses, _, nginx = members
    with httpx.Client(base_url=nginx.url, timeout=5) as client:
        answer = client.post("/p/fwd-abc/x", content=b'{"kind": "collective"}').json()
    assert answer == {
        "member": addresses[2],
        "method": "POST",
        "body": '{"kind": "collective"}',
        "forward": None,  # cleared (nginx sends no empty header): never forwarded again
    }


def _lease(database: Database, trial_id: int) -> tuple[str, int] | None:
    with database.session_scope() as session:
        row = session.get(TrialLease, trial_id)
        return None if row is None else (row.owner, row.epoch)


@pytest.mark.slow
def test_a_stream_refused_by_the_busy_holder_is_forwarded_back_and_never_moves_the_trial(
    database_url: str, tmp_path
) -> None:
    database_url = skip_unless_group(database_url)
    upgrade_database(database_url)
    database = Database(database_url)
    # 20 threads: a stream ceiling of 4 per process (an eighth, at least 16, kept for pages).
    servers = as_group(
        [
            LocalServer(
                database_url,
                tmp_path / name,
                threads=20,
                serve_args=["--cluster"],
                host=address,
                extra_env={"HCSS_PROXY_HOPS": "1"},
            )
            for name, address in (("a", "127.0.0.2"), ("b", "127.0.0.3"))
        ]
    )
    addresses = [f"{s.host}:{s.port}" for s in servers]
    nginx = LocalNginx(addresses, tmp_path / "nginx")
    pages: list[TrialClient] = []
    held_open: list[httpx.Response] = []
    try:
        for server in servers:
            server.start(timeout_s=120)
        nginx.start()
        holder = addresses[0]
        while len(pages) < 5:  # five participants whose home is the first process
            with database.session_scope() as session:
                person, _ = start_bot_trial(session, seed=len(pages), duration_s=STUDY_TRIAL_S)
                token = person.token
            if home(token, addresses, addresses) != holder:
                continue
            page = TrialClient(nginx.url, token)
            page.open_page()
            page.state()  # its first request: held at home
            pages.append(page)
        *busy, last = pages
        for page in busy:  # four streams: the holder's ceiling
            request = page.http.build_request("GET", page.api + "/stream")
            held_open.append(page.http.send(request, stream=True))
            assert held_open[-1].status_code == 200
        assert last.trial_id is not None
        before = _lease(database, last.trial_id)
        assert before is not None and before[0].startswith(holder + "/")

        refused = 0
        until = time.monotonic() + 3 * LEASE_S  # long enough for a hand-back to happen
        while time.monotonic() < until:
            # The holder answers 503 (busy); nginx passes the request to the other process,
            # which forwards it to the holder: busy again, and the trial stays.
            with last.http.stream("GET", last.api + "/stream") as stream:
                refused += stream.status_code == 503
            assert last.state()["trial"]["status"] == "running"
            time.sleep(0.5)
        assert refused > 0
        assert _lease(database, last.trial_id) == before  # 0 lease changes
        with database.session_scope() as session:
            interrupted = session.scalar(select(func.count()).select_from(Interruption))
        assert interrupted == 0  # 0 interruptions, for any of the five
        log = servers[1].log_path.read_text()
        assert "handed back" not in log and "handed back" not in servers[0].log_path.read_text()
    finally:
        for response in held_open:
            response.close()
        for page in pages:
            page.close()
        nginx.stop()
        for server in servers:
            server.stop()
        database.engine.dispose()
