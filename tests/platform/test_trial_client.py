"""The scripted participant (`TrialClient`, used by the benchmarks and the failover tests)
connects from the loopback address it is given, so a benchmark's pages are as many clients
as a study's: the server counts streams per client address."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from hcss.platform.live.client import TrialClient

PAGE = b'<meta name="csrf-token" content="c"><script>new EventSource("/trials/5/stream")</script>'


@pytest.fixture
def peers() -> Iterator[tuple[str, list[str]]]:
    """A bare HTTP server answering every GET with a trial page; the peer address of each."""
    seen: list[str] = []

    class Page(BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            seen.append(self.client_address[0])
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(PAGE)))
            self.end_headers()
            self.wfile.write(PAGE)

        def log_message(self, *args) -> None:
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Page)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}", seen
    server.shutdown()
    server.server_close()


def test_each_participant_connects_from_its_own_loopback_address(peers) -> None:
    base, seen = peers
    for address in ("127.0.1.7", "127.0.2.250", None):
        client = TrialClient(base, "tok", local_address=address)
        try:
            client.open_page()
        finally:
            client.close()
        assert client.trial_id == 5
    assert seen == ["127.0.1.7", "127.0.2.250", "127.0.0.1"]
