"""A bystander's view of a server under load: how long its requests take."""

from __future__ import annotations

import http.client
import threading
import time


def sample_bystander_ms(port: int, stop: threading.Event, latencies: list[float]) -> None:
    while not stop.is_set():
        started = time.perf_counter()
        try:
            connection = http.client.HTTPConnection(
                "127.0.0.1", port, timeout=5, source_address=("127.0.0.2", 0)
            )
            connection.request("GET", "/console/login")
            response = connection.getresponse()
            response.read()
            connection.close()
            assert response.status == 200
            latencies.append((time.perf_counter() - started) * 1000)
        except OSError:
            latencies.append(5000.0)  # timed out or refused: the server is taken
        time.sleep(0.2)
