"""Issue 30 §4: limits that one address obeys hold for many addresses too.

- every per-client limit counts an address by its prefix: an IPv6 /64 is one
  client (its holder has 2^64 addresses), an IPv4 address its /32 or, as
  configured, its /24;
- 30 addresses holding 60 idle sockets each, reopened as they are closed, no
  longer fill the server's connections: a bystander's page p95 < 500 ms (the
  issue measured p50 9.5 s and 8 of 17 loads failed).
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time

import pytest

from hcss.platform.cli import upgrade_database
from hcss.platform.serving.connections import PER_CLIENT
from hcss.platform.serving.localserver import LocalServer
from tests.support.bystander import sample_bystander_ms
from tests.support.recruitment import join


def _visitor(app, address: str):
    client = app.test_client()
    client.environ_base["REMOTE_ADDR"] = address
    return client


def test_the_addresses_of_one_ipv6_64_share_one_allowance_of_starts(app) -> None:
    app.config["JOIN_PER_CLIENT"] = (2, 600.0)
    same_64 = [join(_visitor(app, f"2001:db8:7:1::{n:x}")).status_code for n in range(1, 5)]
    other_64 = join(_visitor(app, "2001:db8:7:2::1")).status_code
    assert same_64 == [302, 302, 429, 429]
    assert other_64 == 302


def test_an_ipv4_24_is_one_client_when_so_configured(app) -> None:
    app.config["JOIN_PER_CLIENT"] = (2, 600.0)
    each_address = [join(_visitor(app, f"198.51.100.{n}")).status_code for n in range(1, 4)]
    app.config["CLIENT_PREFIX_V4"] = 24
    same_24 = [join(_visitor(app, f"203.0.113.{n}")).status_code for n in range(1, 4)]
    assert each_address == [302, 302, 302]
    assert same_24 == [302, 302, 429]


PREFIXES, SOCKETS = 30, 60
WINDOW_S = 10.0


def _hold(port: int, address: str, stop: threading.Event) -> None:
    """`SOCKETS` idle connections from `address`, each reopened when the server closes it."""
    held: list[socket.socket] = []
    while not stop.is_set():
        for sock in list(held):
            with contextlib.suppress(OSError):
                sock.setblocking(False)
                if sock.recv(1) == b"":
                    held.remove(sock)
                    sock.close()
        while len(held) < SOCKETS and not stop.is_set():
            try:
                held.append(
                    socket.create_connection(("127.0.0.1", port), 2, source_address=(address, 0))
                )
            except OSError:
                break
        stop.wait(0.5)
    for sock in held:
        sock.close()


@pytest.mark.slow
def test_thirty_addresses_of_sixty_idle_sockets_leave_a_bystander_p95_under_500_ms(
    tmp_path,
) -> None:
    url = f"sqlite:///{tmp_path / 'hcss.sqlite3'}"
    upgrade_database(url)
    server = LocalServer(  # 32 threads: room for 2 x 32 + 1024 = 1088 connections, < 30 x 60
        url, tmp_path / "instance", threads=32, lift_client_limits=False
    ).start(timeout_s=120)
    assert PER_CLIENT >= SOCKETS  # each address stays under its own cap
    stop = threading.Event()
    holders = [
        threading.Thread(target=_hold, args=(server.port, f"127.0.9.{10 + n}", stop))
        for n in range(PREFIXES)
    ]
    try:
        for holder in holders:
            holder.start()
        time.sleep(3.0)  # the sockets are open
        latencies: list[float] = []
        watch = threading.Event()
        bystander = threading.Thread(
            target=sample_bystander_ms, args=(server.port, watch, latencies)
        )
        bystander.start()
        time.sleep(WINDOW_S)
        watch.set()
        bystander.join(timeout=10)
    finally:
        stop.set()
        for holder in holders:
            holder.join(timeout=10)
        server.stop()
    latencies.sort()
    p95 = latencies[int(0.95 * (len(latencies) - 1))]
    print(
        f"bystander: {len(latencies)} loads, p50 {latencies[len(latencies) // 2]:.0f} ms, "
        f"p95 {p95:.0f} ms"
    )
    assert len(latencies) >= 15
    assert p95 < 500, latencies
