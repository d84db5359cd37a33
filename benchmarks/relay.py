"""A loopback TCP proxy whose line a test or a benchmark can cut, stall and restore: a
database outage or partition of its own, without stopping the PostgreSQL server other
people share. The tests (outages, fuzzing, failover) and the failover benchmark's
partition share this one relay.

While cut, every relayed connection is shut down at once and each new one
is accepted and closed without a byte, as a server that went away mid-answer
does: the client's driver sees its connection lost, never a hang.

A relayed socket is closed only by the last of its two pump threads, once
neither can touch it again. Closing it from another thread (as `cut` did)
freed its descriptor number while a pump could still be about to send on it:
the process's next socket, often another PostgreSQL connection of the same
test process, could get that number and receive the relayed bytes, which the
server refused as "invalid frontend message type" in a later test.
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
        #: A partition (`stall`): bytes are taken in and held, not passed on, until `heal`.
        self._passing = threading.Event()
        self._passing.set()
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
                _shut_down(end)  # wakes its pumps, which close it

    def stall(self) -> None:
        """The line goes silent (a partition, not a refusal): nothing is closed, every byte
        is held, so the client's driver waits as on a black-holed link."""
        self._passing.clear()

    def heal(self) -> None:
        """The held bytes pass on, in order, and the line carries on."""
        self._passing.set()

    def restore(self) -> None:
        with self._lock:
            self.cut_now = False

    def close(self) -> None:
        self.cut()
        _shut_down(self._listener)  # wakes `_serve`'s accept, which closes it

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
                self._listener.close()
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
            pumps_left = [2]
            for source, sink in ((client, upstream), (upstream, client)):
                threading.Thread(
                    target=self._pump, args=(source, sink, pumps_left), daemon=True
                ).start()

    def _pump(self, source: socket.socket, sink: socket.socket, pumps_left: list[int]) -> None:
        """Relay one direction; the last of the pair's two pumps to stop closes both ends."""
        try:
            while chunk := source.recv(65536):
                self._passing.wait()
                sink.sendall(chunk)
        except OSError:
            pass
        finally:
            _shut_down(source)  # the other direction stops too
            _shut_down(sink)
            with self._lock:
                pumps_left[0] -= 1
                last = pumps_left[0] == 0
                if last:
                    self._open.discard(source)
                    self._open.discard(sink)
            if last:
                source.close()
                sink.close()


def _shut_down(end: socket.socket) -> None:
    with contextlib.suppress(OSError):  # already shut down, or the other end went first
        end.shutdown(socket.SHUT_RDWR)


def _close(end: socket.socket) -> None:
    """Close a socket no other thread uses (a refused client)."""
    _shut_down(end)
    end.close()
