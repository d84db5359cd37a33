"""Waitress with the two bounds a server facing the internet needs.

Waitress reads requests on one thread and hands only complete ones to its
workers, so slow clients cost no worker; they cost connections, and waitress
stops accepting any once `connection_limit` are open. Two bounds keep one
client from taking them all:

- a request must arrive whole within `REQUEST_S` of its first byte: a client
  that sends its head a byte at a time (slowloris) is closed; idle
  connections are closed by waitress' own `channel_timeout`;
- one address holds at most `per_client` connections; more are closed as
  they are accepted. Behind a reverse proxy every connection comes from the
  proxy (and carries many clients' requests in turn), so there the cap
  counts requests in progress by the forwarded address instead
  (`RequestsPerClient`, 429 beyond it), and the proxy bounds connections and
  slow clients (`hcss deploy nginx` writes `limit_conn` and the timeouts).

Behind a proxy (``HCSS_PROXY_HOPS``) waitress is told which peer to trust
(`proxy_adjustments`): waitress 3 removes X-Forwarded-* from any peer it was
not told of before the app sees them, so without it every visitor had
nginx's address, every per-client limit counted all of them as one, and the
scheme (Secure cookies) was lost. Headers from an untrusted peer are removed
and said so once in the log (`UntrustedHeadersOnce`).

An open live stream is a request in progress, never idle, so neither bound
touches it.

`close_server` stops a server without writing into anyone's socket: waitress'
task threads wake its loop by writing a byte into the trigger pipe, and
`server.close()` closes that pipe while a stream's task may still run, so the
task's next wake-up went into whatever then held the old descriptor number (a
fresh PostgreSQL connection read it as "invalid frontend message type 120").
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
import time
import types
from collections import Counter
from typing import Any

from waitress import wasyncore
from waitress.channel import HTTPChannel
from waitress.server import create_server
from werkzeug.wsgi import ClosingIterator

from hcss.platform.guards.clients import IPV4_PREFIX, client_prefix

#: Seconds from a request's first byte to its last (head and body).
REQUEST_S = 10.0
#: Seconds a connection may stay open with nothing to do (waitress' channel_timeout).
IDLE_S = 60
#: Connections one address may hold: a participant's page holds its stream and a few more.
PER_CLIENT = 64


#: Share of `connection_limit` past which only clients holding fewer than `FEW` get more.
CROWDED = 0.8
FEW = 4


def _host(addr: Any) -> str:
    return str(addr[0] if isinstance(addr, tuple) else addr)


class BoundedChannel(HTTPChannel):
    """A connection that must send each request whole in time, one of a capped few per client."""

    request_s: float = REQUEST_S
    per_client: int = PER_CLIENT
    ipv4_bits: int = IPV4_PREFIX
    request_started: float | None = None
    client: str = "?"

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


#: The headers nginx (`hcss deploy nginx`) sets and werkzeug's ProxyFix reads.
PROXY_HEADERS = ("x-forwarded-for", "x-forwarded-proto", "x-forwarded-host", "x-forwarded-port")


def proxy_adjustments(hops: int, trusted_proxy: str) -> dict[str, Any]:
    """Waitress settings for `hops` proxies, the nearest connecting from `trusted_proxy`."""
    if hops <= 0:
        return {"log_untrusted_proxy_headers": True}
    return {
        "trusted_proxy": trusted_proxy,
        "trusted_proxy_count": hops,
        "trusted_proxy_headers": set(PROXY_HEADERS),
        "log_untrusted_proxy_headers": True,
    }


class UntrustedHeadersOnce(logging.Filter):
    """Let waitress' warning about removed proxy headers through once per process, with why.

    A visitor forging X-Forwarded-For would otherwise write a line per request;
    a proxy the server was not told of is the same warning, and once is enough.
    """

    def __init__(self) -> None:
        super().__init__()
        self.said = False
        self._lock = threading.Lock()

    def filter(self, record: logging.LogRecord) -> bool:
        if not str(record.msg).startswith("Removed untrusted headers"):
            return True
        with self._lock:
            if self.said:
                return False
            self.said = True
        record.msg = (
            "proxy headers from an untrusted peer were ignored (%s); behind a proxy set "
            "HCSS_PROXY_HOPS and HCSS_TRUSTED_PROXY to its address (said once)"
        )
        return True


def say_untrusted_headers_once() -> UntrustedHeadersOnce:
    logger = logging.getLogger("waitress")
    for existing in logger.filters:
        if isinstance(existing, UntrustedHeadersOnce):
            return existing
    once = UntrustedHeadersOnce()
    logger.addFilter(once)
    return once


class RequestsPerClient:
    """WSGI middleware: at most `per_client` requests in progress per client, counted by
    the address the trusted proxy forwarded (waitress puts it in REMOTE_ADDR), by its
    prefix as every per-client limit counts it; more are answered 429 at once.

    Behind a proxy the connection cap cannot tell clients apart (every connection is
    the proxy's, kept alive for many clients), so this is the app's own per-client
    bound there. A request is in progress until its answer is closed: a live stream
    counts for as long as it is open, as its connection did without the proxy.
    """

    def __init__(self, app: Any, per_client: int, ipv4_bits: int = IPV4_PREFIX) -> None:
        self.app = app
        self.per_client = per_client
        self.ipv4_bits = ipv4_bits
        self._held: Counter[str] = Counter()
        self._lock = threading.Lock()

    def __call__(self, environ: dict[str, Any], start_response: Any) -> Any:
        client = client_prefix(environ.get("REMOTE_ADDR"), self.ipv4_bits)
        with self._lock:
            full = self._held[client] >= self.per_client
            if not full:
                self._held[client] += 1
        if full:
            body = b"Too many requests in progress from your address; try again shortly.\n"
            start_response(
                "429 Too Many Requests",
                [
                    ("Content-Type", "text/plain; charset=utf-8"),
                    ("Content-Length", str(len(body))),
                    ("Retry-After", "1"),
                ],
            )
            return [body]
        try:
            answer = self.app(environ, start_response)
        except BaseException:
            self._release(client)
            raise
        return ClosingIterator(answer, lambda: self._release(client))

    def _release(self, client: str) -> None:
        with self._lock:
            self._held[client] -= 1
            if self._held[client] <= 0:
                del self._held[client]


def bounded_server(
    app: Any,
    *,
    request_s: float = REQUEST_S,
    per_client: int = PER_CLIENT,
    ipv4_bits: int = IPV4_PREFIX,
    **adjustments: Any,
) -> Any:
    """`waitress.create_server` whose connections are `BoundedChannel`s; `per_client` 0: no cap."""
    server = create_server(app, channel_timeout=IDLE_S, **adjustments)
    server.channel_class = type(
        "ConfiguredChannel",
        (BoundedChannel,),
        {"request_s": float(request_s), "per_client": int(per_client), "ipv4_bits": ipv4_bits},
    )
    server.handle_accept = types.MethodType(_accept_waiting, server)
    return server


#: Connections taken from the listen queue in one turn of waitress' loop.
ACCEPTS_PER_TURN = 1024


def _accept_waiting(server: Any) -> None:
    """Waitress' `handle_accept`, taking every waiting connection, not one per loop turn.

    Sockets that reconnect as fast as they are closed queue in the kernel's
    listen backlog; taken one per turn of a loop over a thousand connections,
    a bystander waited behind all of them (seconds). A connection is closed
    here, before it costs a channel, when its client holds its cap, or when
    the server is crowded (past `CROWDED` of its connections) and the client
    holds `FEW` already: the last fifth is kept for clients with few
    connections (a bystander's page), so a few prefixes each under its cap
    (30 x 60 idle sockets) no longer fill the server together; filling the
    fifth takes a fifth of `connection_limit` / `FEW` prefixes (55 at 1,088).
    """
    channel_class = server.channel_class
    counts = Counter(channel.client for channel in _channels(server))
    crowded_at = CROWDED * server.adj.connection_limit
    for _ in range(ACCEPTS_PER_TURN):
        if len(server._map) >= server.adj.connection_limit:
            break
        try:
            pair = server.accept()
        except OSError:
            break
        if pair is None:
            break  # nothing more waiting
        conn, addr = pair
        addr = server.fix_addr(addr)
        client = client_prefix(_host(addr), channel_class.ipv4_bits)
        held = counts[client]
        over_cap = bool(channel_class.per_client) and held >= channel_class.per_client
        if over_cap or (len(server._map) >= crowded_at and held >= FEW):
            conn.close()  # never read
            continue
        try:
            server.set_socket_options(conn)
        except OSError:
            conn.close()  # the remote had gone already
            continue
        counts[client] += 1
        channel = channel_class(server, conn, addr, server.adj, map=server._map)
        channel.client = client


def _channels(server: Any) -> list[Any]:
    return [c for c in list(server.active_channels.values()) if isinstance(c, BoundedChannel)]


def close_server(
    server: Any, loop: threading.Thread | None = None, *, timeout_s: float = 10.0
) -> bool:
    """Stop `server` (a waitress server whose loop runs in `loop`) in the order that is safe.

    1. in the loop's thread: stop accepting, and mark every connection
       disconnected, so a stream's next write ends its task
       (``ClientDisconnected``) and a task's wake-up finds nothing to do;
    2. wait for the task threads to finish, for at most `timeout_s`;
    3. in the loop's thread: close every connection and, only when no task
       thread is left to pull it, the trigger pipe; the loop then ends.

    A task still running after `timeout_s` keeps the trigger's two descriptors
    open for the rest of the process (False is returned), so its late wake-up
    lands in the pipe, never in a descriptor that was given to someone else.
    """
    in_loop = loop is not None and loop.is_alive()
    disconnected = threading.Event()

    def disconnect() -> None:
        server.accepting = False
        wasyncore.dispatcher.close(server)  # the listening socket; not the trigger
        for channel in list(server._map.values()):
            if isinstance(channel, HTTPChannel):
                with channel.outbuf_lock:
                    channel.will_close = True
                    channel.connected = False
                    channel.outbuf_lock.notify_all()
        disconnected.set()

    if in_loop:
        server.trigger.pull_trigger(disconnect)
        disconnected.wait(timeout_s)
    if not disconnected.is_set():
        disconnect()
    dispatcher = server.task_dispatcher
    dispatcher.shutdown(cancel_pending=True, timeout=timeout_s)
    with dispatcher.lock:
        idle = not dispatcher.threads
    closed = threading.Event()

    def close_all() -> None:
        for channel in list(server._map.values()):
            if channel is not server.trigger:
                with contextlib.suppress(OSError):
                    channel.close()
        if idle:
            server.trigger.close()
        else:
            server.trigger.del_channel()  # the loop ends; the pipe stays open
        server._map.clear()
        closed.set()

    if in_loop:
        server.trigger.pull_trigger(close_all)
        closed.wait(timeout_s)
        assert loop is not None
        loop.join(timeout_s)
    if not closed.is_set():
        close_all()
    return idle


def serve_until_stopped(server: Any, *, timeout_s: float = 10.0) -> bool:
    """Run `server` until SIGINT or SIGTERM, then stop it with `close_server`.

    Waitress' own `run()` caught only Ctrl-C and gave the task threads five
    seconds with the trigger already closing; SIGTERM (a service manager, the
    process group of `hcss serve --processes`) ended the process unannounced.
    Returns whether every task finished in `timeout_s`.
    """
    stop = threading.Event()
    stopping = (signal.SIGINT, signal.SIGTERM)
    previous = {number: signal.signal(number, lambda *_: stop.set()) for number in stopping}
    loop = threading.Thread(target=server.run, name="waitress-loop", daemon=True)
    loop.start()
    try:
        while loop.is_alive() and not stop.wait(1.0):
            pass
    finally:
        idle = close_server(server, loop, timeout_s=timeout_s)
        for number, handler in previous.items():
            signal.signal(number, handler)
    return idle
