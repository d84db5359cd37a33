"""600 idle and slowloris connections from one client leave the server answering others.

Real sockets against `hcss serve` in its own process: half send nothing, half
send a request head a byte every 2 s. A bystander on another loopback address
(127.0.0.2) loads a page meanwhile.
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

ATTACK_SOCKETS = 600
WINDOW_S = 12.0


@pytest.mark.slow
def test_600_slowloris_sockets_leave_a_bystander_p95_under_500_ms(tmp_path) -> None:
    url = f"sqlite:///{tmp_path / 'hcss.sqlite3'}"
    upgrade_database(url)
    server = LocalServer(
        url,
        tmp_path / "instance",
        threads=32,
        extra_env={"HCSS_CONNECTIONS_PER_CLIENT": str(PER_CLIENT)},
    ).start(timeout_s=120)
    try:
        attackers: list[socket.socket] = []
        for number in range(ATTACK_SOCKETS):
            try:
                attacker = socket.create_connection(("127.0.0.1", server.port), timeout=2)
            except OSError:
                continue
            if number % 2:
                attacker.sendall(b"G")  # a head begun, never finished
            attackers.append(attacker)
        stop, latencies = threading.Event(), []
        bystander = threading.Thread(
            target=sample_bystander_ms, args=(server.port, stop, latencies)
        )
        bystander.start()
        started = time.monotonic()
        head = b"ET / HTTP/1.1\r\nHost: x\r\nX-Slow: " + b"a" * 64
        position = 0
        while time.monotonic() - started < WINDOW_S:
            for attacker in attackers[1::2]:
                with contextlib.suppress(OSError):  # closed by the server
                    attacker.sendall(head[position : position + 1])
            position = min(position + 1, len(head) - 1)
            time.sleep(2.0)
        stop.set()
        bystander.join(timeout=10)
        for attacker in attackers:
            attacker.close()
    finally:
        server.stop()
    latencies.sort()
    p95 = latencies[int(0.95 * (len(latencies) - 1))]
    print(f"bystander: {len(latencies)} loads, p95 {p95:.0f} ms, max {latencies[-1]:.0f} ms")
    assert len(latencies) >= 20
    assert p95 < 500, latencies
