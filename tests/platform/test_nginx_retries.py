"""Issue 30 §6: the generated nginx never sends a POST without an Idempotency-Key twice.

Two "processes" that read a request and die before answering (as one killed
after its commit does), behind the nginx of `hcss deploy nginx`. A keyed
command is passed to the next process (its key makes the repeat harmless); a
form POST without a key reached one process and is not sent again.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from contextlib import contextmanager

import httpx
import pytest

from hcss.platform.serving.localserver import LocalNginx


class DyingProcess:
    """Accepts, reads one request's head and body, counts it, and closes unanswered."""

    def __init__(self) -> None:
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.requests: list[bytes] = []
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        while True:
            try:
                connection, _ = self.listener.accept()
            except OSError:
                return
            with connection:
                received = b""
                connection.settimeout(5)
                try:
                    while b"\r\n\r\n" not in received:
                        chunk = connection.recv(65536)
                        if not chunk:
                            break
                        received += chunk
                except OSError:
                    pass
                if received:
                    self.requests.append(received.split(b"\r\n", 1)[0])

    def close(self) -> None:
        self.listener.close()


@contextmanager
def dying_pair(tmp_path) -> Iterator[tuple[str, list[DyingProcess]]]:
    if not LocalNginx.available():
        pytest.skip(f"needs nginx at {LocalNginx.BINARY} (scripts/ensure-nginx installs it)")
    processes = [DyingProcess(), DyingProcess()]
    servers = [f"127.0.0.1:{process.port}" for process in processes]
    try:
        with LocalNginx(servers, tmp_path / "nginx") as nginx:
            yield nginx.url, processes
    finally:
        for process in processes:
            process.close()


def _sent(processes: list[DyingProcess]) -> int:
    return sum(len(process.requests) for process in processes)


def test_an_unkeyed_post_is_sent_once_and_a_keyed_command_is_passed_on(tmp_path) -> None:
    with dying_pair(tmp_path) as (url, processes), httpx.Client(base_url=url) as client:
        form = client.post("/p/sometoken", data={"answer": "7"})
        form_sent = _sent(processes)
        command = client.post(
            "/api/live/sometoken/trials/1/requests", json={}, headers={"Idempotency-Key": "k-1"}
        )
        command_sent = _sent(processes) - form_sent
        page = client.get("/console/")
        page_sent = _sent(processes) - form_sent - command_sent
    # No process answered: nginx's "not now" (503 with Retry-After), never its own 502.
    assert all(a.status_code == 503 and a.headers["Retry-After"] for a in (form, command, page))
    assert form_sent == 1  # not applied twice
    assert command_sent == 2  # tried on both processes
    assert page_sent == 2  # a GET, as before
