"""Waitress with the two bounds a server facing the internet needs.

Waitress reads requests on one thread and hands only complete ones to its
workers, so slow clients cost no worker; they cost connections, and waitress
stops accepting any once `connection_limit` are open. Two bounds keep one
client from taking them all:

- a request must arrive whole within `REQUEST_S` of its first byte: a client
  that sends its head a byte at a time (slowloris) is closed; idle
  connections are closed by waitress' own `channel_timeout`;
- one address holds at most `per_client` connections; more are closed as
  they are accepted. Behind a reverse proxy every visitor has the proxy's
  address, so the cap is off there and the proxy bounds slow clients
  (docs/operations.md gives its settings).

An open live stream is a request in progress, never idle, so neither bound
touches it.
"""

from __future__ import annotations

import time
from typing import Any

from waitress.channel import HTTPChannel
from waitress.server import create_server

#: Seconds from a request's first byte to its last (head and body).
REQUEST_S = 10.0
#: Seconds a connection may stay open with nothing to do (waitress' channel_timeout).
IDLE_S = 60
#: Connections one address may hold: a participant's page holds its stream and a few more.
PER_CLIENT = 64


class BoundedChannel(HTTPChannel):
    """A connection that must send each request whole in time, one of a capped few per client."""

    request_s: float = REQUEST_S
    per_client: int = PER_CLIENT
    request_started: float | None = None

    def __init__(self, server: Any, sock: Any, addr: Any, adj: Any, map: Any = None) -> None:  # noqa: A002 - waitress' name
        super().__init__(server, sock, addr, adj, map=map)
        if self.per_client and self._connections_from(addr) > self.per_client:
            self.will_close = True  # closed by the next loop turn; never read

    def _connections_from(self, addr: Any) -> int:
        host = addr[0] if isinstance(addr, tuple) else addr
        return sum(
            1
            for channel in list(self.server.active_channels.values())
            if (channel.addr[0] if isinstance(channel.addr, tuple) else channel.addr) == host
        )

    def received(self, data: bytes) -> bool:
        if self.request is None and data:
            self.request_started = time.monotonic()
        result = super().received(data)
        if self.request is None:
            self.request_started = None  # whole (or nothing pending): no deadline
        return bool(result)

    def readable(self) -> bool:
        """Asked on every turn of waitress' loop: close a request that is overdue."""
        if (
            self.request_started is not None
            and time.monotonic() - self.request_started > self.request_s
        ):
            self.will_close = True
        return bool(super().readable())


def bounded_server(
    app: Any, *, request_s: float = REQUEST_S, per_client: int = PER_CLIENT, **adjustments: Any
) -> Any:
    """`waitress.create_server` whose connections are `BoundedChannel`s; `per_client` 0: no cap."""
    server = create_server(app, channel_timeout=IDLE_S, **adjustments)
    server.channel_class = type(
        "ConfiguredChannel",
        (BoundedChannel,),
        {"request_s": float(request_s), "per_client": int(per_client)},
    )
    return server
