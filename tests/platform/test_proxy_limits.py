"""Behind nginx each client is still bounded: by nginx (connections, slow clients) and by
the server itself, counting requests in progress by the forwarded address.

The nginx configuration `hcss deploy nginx` writes, in front of `hcss serve`
(HCSS_PROXY_HOPS=1), real sockets: one address holding `PER_CLIENT` requests
in progress (POST heads whose bodies never come) gets 429 for one more while
another address is served; the bodies that never come are closed after the
body timeout, and a head that never ends after the header timeout.

And the server behind the proxy: its connections all come from nginx, so the
per-client connection cap cannot tell clients apart; requests in progress are
counted by the address nginx forwards instead (`RequestsPerClient`): a
client holding its share of live streams gets 429 for one more, another
client does not.
"""

from __future__ import annotations

import socket
import time

import httpx
import pytest

from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.serving.localserver import LocalNginx, LocalServer
from hcss.platform.serving.nginx import CLIENT_BODY_S, CLIENT_HEADER_S, PER_CLIENT
from tests.support.trials import STUDY_TRIAL_S

pytestmark = pytest.mark.skipif(
    not LocalNginx.available(), reason=f"needs nginx at {LocalNginx.BINARY}"
)


def _answer(sock: socket.socket, timeout_s: float) -> bytes:
    """What the peer sends before it closes or `timeout_s` passes (b"" if closed silently)."""
    sock.settimeout(timeout_s)
    try:
        return sock.recv(4096)
    except TimeoutError:
        return b"<no answer>"
    except OSError:
        return b""


@pytest.mark.slow
def test_nginx_caps_each_client_and_closes_slow_ones(tmp_path) -> None:
    url = f"sqlite:///{tmp_path / 'hcss.sqlite3'}"
    upgrade_database(url)
    server = LocalServer(url, tmp_path / "instance", extra_env={"HCSS_PROXY_HOPS": "1"})
    nginx = LocalNginx([f"{server.host}:{server.port}"], tmp_path / "nginx")
    held: list[socket.socket] = []
    try:
        server.start(timeout_s=120)
        nginx.start()
        post_head = b"POST /p/slow/x HTTP/1.1\r\nHost: lab\r\nContent-Length: 100\r\n\r\n"
        for _ in range(PER_CLIENT):  # requests in progress: nginx waits for their bodies
            sock = socket.create_connection(("127.0.0.1", nginx.port), timeout=5)
            sock.sendall(post_head)
            held.append(sock)
        slow_head = socket.create_connection(("127.0.0.1", nginx.port), timeout=5)
        slow_head.sendall(b"GET / HTTP/1.1\r\nHost: la")  # a head that never ends
        time.sleep(0.5)
        one_more = socket.create_connection(("127.0.0.1", nginx.port), timeout=5)
        one_more.sendall(post_head)
        assert _answer(one_more, 5).startswith(b"HTTP/1.1 429"), "no per-client cap"
        one_more.close()
        other = httpx.Client(transport=httpx.HTTPTransport(local_address="127.0.0.5"))
        assert other.get(nginx.url + "/console/login").status_code == 200  # another client
        other.close()

        started = time.monotonic()
        assert _answer(slow_head, CLIENT_HEADER_S + 5) == b""  # closed without a word
        header_closed_s = time.monotonic() - started
        body_answer = _answer(held[0], CLIENT_BODY_S + 5)  # closed (nginx may say 408 first)
        assert body_answer == b"" or body_answer.startswith(b"HTTP/1.1 408"), body_answer
        body_closed_s = time.monotonic() - started
        slow_head.close()
    finally:
        for sock in held:
            sock.close()
        nginx.stop()
        server.stop()
    assert header_closed_s < CLIENT_HEADER_S + 2
    assert body_closed_s < CLIENT_BODY_S + 2


def test_the_server_behind_the_proxy_caps_each_forwarded_client(tmp_path) -> None:
    url = f"sqlite:///{tmp_path / 'hcss.sqlite3'}"
    upgrade_database(url)
    database = Database(url)
    streams = []
    with database.session_scope() as session:
        for seed in range(4):
            person, trial = start_bot_trial(session, seed=seed, duration_s=STUDY_TRIAL_S)
            streams.append(f"/api/live/{person.token}/trials/{trial.id}/stream")
    database.engine.dispose()
    server = LocalServer(
        url,
        tmp_path / "instance",
        # nginx would connect from 127.0.0.1 (the trusted proxy) and forward the address.
        extra_env={"HCSS_PROXY_HOPS": "1", "HCSS_CONNECTIONS_PER_CLIENT": "3"},
    )
    client = httpx.Client(base_url=f"http://127.0.0.1:{server.port}", timeout=10)
    opened: list[httpx.Response] = []

    def stream(path: str, address: str) -> httpx.Response:
        request = client.build_request("GET", path, headers={"X-Forwarded-For": address})
        response = client.send(request, stream=True)
        opened.append(response)
        return response

    try:
        server.start(timeout_s=120)
        for path in streams[:3]:  # one participant's address holds three live streams
            assert stream(path, "203.0.113.7").status_code == 200
        refused = stream(streams[3], "203.0.113.7")
        assert refused.status_code == 429
        assert refused.headers["Retry-After"] == "1"
        assert stream(streams[3], "198.51.100.9").status_code == 200  # another client
        for response in opened[:3]:
            response.close()  # streams closed: the first client has room again
        deadline = time.monotonic() + 5
        while stream(streams[0], "203.0.113.7").status_code != 200:
            assert time.monotonic() < deadline, "closed streams were never counted out"
            time.sleep(0.2)
    finally:
        for response in opened:
            response.close()
        client.close()
        server.stop()
