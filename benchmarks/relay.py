"""A loopback TCP relay to PostgreSQL that can go silent: the benchmark's partition.

A server process given the relay's address as its database reaches PostgreSQL
only through it. `stall` makes the line black-holed (nothing closed, every
byte taken in and held, as a partitioned link does: the driver waits, it is
not refused); `heal` passes the held bytes on, in order. The server itself is
untouched, and nobody else's connection to the shared PostgreSQL is.

A measuring instrument, not product code, so it lives here; tests have their
own (tests/support/cut_proxy.py, which can also refuse), and a benchmark does
not import tests. A relayed socket is closed only by the last of its two pump
threads, so no descriptor is freed while a pump may still send on it.
"""

from __future__ import annotations

import contextlib
import socket
import threading


class StallingRelay:
    def __init__(self, upstream_host: str, upstream_port: int) -> None:
        self.upstream = (upstream_host, upstream_port)
        self._passing = threading.Event()
        self._passing.set()
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = int(self._listener.getsockname()[1])
        threading.Thread(target=self._serve, name="stalling-relay", daemon=True).start()

    def stall(self) -> None:
        """The line goes silent: bytes in both directions are held until `heal`."""
        self._passing.clear()

    def heal(self) -> None:
        self._passing.set()

    def close(self) -> None:
        self.heal()
        _shut_down(self._listener)  # wakes `_serve`'s accept, which closes it

    def _serve(self) -> None:
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:
                self._listener.close()
                return
            try:
                upstream = socket.create_connection(self.upstream, timeout=5)
            except OSError:
                _shut_down(client)
                client.close()
                continue
            upstream.settimeout(None)
            pumps_left = [2]
            lock = threading.Lock()
            for source, sink in ((client, upstream), (upstream, client)):
                threading.Thread(
                    target=self._pump, args=(source, sink, pumps_left, lock), daemon=True
                ).start()

    def _pump(
        self,
        source: socket.socket,
        sink: socket.socket,
        pumps_left: list[int],
        lock: threading.Lock,
    ) -> None:
        try:
            while chunk := source.recv(65536):
                self._passing.wait()
                sink.sendall(chunk)
        except OSError:
            pass
        finally:
            _shut_down(source)  # the other direction stops too
            _shut_down(sink)
            with lock:
                pumps_left[0] -= 1
                last = pumps_left[0] == 0
            if last:
                source.close()
                sink.close()


def _shut_down(end: socket.socket) -> None:
    with contextlib.suppress(OSError):
        end.shutdown(socket.SHUT_RDWR)
