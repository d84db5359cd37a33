"""A loopback TCP proxy whose line the test can cut and restore: a database outage of
the test's own, without stopping the PostgreSQL server other people share.

While cut, every relayed connection is closed at once and each new one is
accepted and closed without a byte, as a server that went away mid-answer
does: the client's driver sees its connection lost, never a hang.
"""

from __future__ import annotations

import contextlib
import socket
import threading
from types import TracebackType


class CutProxy:
    def __init__(self, upstream_host: str, upstream_port: int) -> None:
        self.upstream = (upstream_host, upstream_port)
        self.cut_now = False
        self._lock = threading.Lock()
        self._open: set[socket.socket] = set()
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = int(self._listener.getsockname()[1])
        threading.Thread(target=self._serve, name="cut-proxy", daemon=True).start()

    def cut(self) -> None:
        """The database goes away: every open connection drops, new ones are refused."""
        with self._lock:
            self.cut_now = True
            for end in self._open:
                _close(end)
            self._open.clear()

    def restore(self) -> None:
        with self._lock:
            self.cut_now = False

    def close(self) -> None:
        self.cut()
        _close(self._listener)

    def __enter__(self) -> CutProxy:
        return self

    def __exit__(
        self, _type: type[BaseException] | None, _value: object, _tb: TracebackType | None
    ) -> None:
        self.close()

    def _serve(self) -> None:
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:
                return
            with self._lock:
                refused = self.cut_now
            if refused:
                _close(client)
                continue
            try:
                upstream = socket.create_connection(self.upstream, timeout=5)
            except OSError:
                _close(client)
                continue
            upstream.settimeout(None)
            with self._lock:
                self._open.update((client, upstream))
            for source, sink in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pump, args=(source, sink), daemon=True).start()

    def _pump(self, source: socket.socket, sink: socket.socket) -> None:
        try:
            while chunk := source.recv(65536):
                sink.sendall(chunk)
        except OSError:
            pass
        finally:
            with self._lock:
                self._open.discard(source)
                self._open.discard(sink)
            _close(source)
            _close(sink)


def _close(end: socket.socket) -> None:
    with contextlib.suppress(OSError):  # already closed by the other end
        end.shutdown(socket.SHUT_RDWR)
    end.close()
