"""A loopback proxy that loses the answer to one request, as a server killed mid-answer does.

Each connection carries one request: the proxy forwards it to the real server
with ``Connection: close`` (whatever the client asked), so the server's answer
ends with the connection and the client opens a new one for the next request.
It waits for the whole answer; for the
first request whose request line starts with `drop`, it then closes the
client's connection without a byte: the server has done the work, the client
never hears of it. Every other answer is passed on unchanged.
"""

from __future__ import annotations

import socket
import threading


def _read_request(connection: socket.socket) -> bytes:
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = connection.recv(65536)
        if not chunk:
            return data
        data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    length = 0
    for line in head.split(b"\r\n")[1:]:
        name, _, value = line.partition(b":")
        if name.strip().lower() == b"content-length":
            length = int(value.strip())
    while len(body) < length:
        chunk = connection.recv(65536)
        if not chunk:
            break
        body += chunk
    return head + b"\r\n\r\n" + body


def _closing(request: bytes) -> bytes:
    """The request with `Connection: close` in place of any keep-alive the client asked."""
    head, _, body = request.partition(b"\r\n\r\n")
    lines = [line for line in head.split(b"\r\n") if not line.lower().startswith(b"connection:")]
    return b"\r\n".join([*lines, b"Connection: close"]) + b"\r\n\r\n" + body


class LossyProxy:
    def __init__(self, upstream_port: int, drop: bytes) -> None:
        self.upstream_port = upstream_port
        self.drop = drop
        self.dropped: list[bytes] = []  # the requests whose answers were lost
        self.requests: list[bytes] = []
        self._lock = threading.Lock()
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.url = f"http://127.0.0.1:{self._listener.getsockname()[1]}"
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:
                return
            threading.Thread(target=self._relay, args=(client,), daemon=True).start()

    def _relay(self, client: socket.socket) -> None:
        with client:
            request = _closing(_read_request(client))
            with socket.create_connection(("127.0.0.1", self.upstream_port)) as upstream:
                upstream.sendall(request)
                answer = b""
                while chunk := upstream.recv(65536):
                    answer += chunk
            with self._lock:
                self.requests.append(request)
                lose = not self.dropped and request.startswith(self.drop)
                if lose:
                    self.dropped.append(request)
            if not lose:
                client.sendall(answer)

    def close(self) -> None:
        self._listener.close()
