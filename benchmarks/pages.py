"""A participant's trial stream as the page drives it (hcss/platform/static/live.js).

The page's EventSource, with its watchdog: an open stream silent for 3 s
(frames come every 0.5 s) is dropped and opened again at once; a stream that
has not opened is given 12 s (the proxy may wait out its read timeout at a
stopped process, then the next process a lease and a rebuild). A new stream
resumes after the newest System Message shown (`?after=`). An answer that is
not a stream is retried as the page's `retryLater` does: 502/504 (the proxy's
own) after 1 s, 503/429 after Retry-After (plus up to half again), other 5xx
after 5 s; a 4xx ends it. A stream that closes cleanly reconnects after the
server's `retry:` (1 s). Every frame is kept with the time it arrived, so a
failover's gaps and jumps are read off afterwards.

Plain `http.client`, one thread per page: the socket's timeout is the
watchdog (12 s until the answer's head, then 3 s per read).
"""

from __future__ import annotations

import http.client
import json
import random
import threading
import time
from dataclasses import dataclass
from urllib.parse import urlsplit

STALLED_S = 3.0  # live.js STALLED_MS
OPENING_S = 12.0  # live.js OPENING_MS
PROXY_RETRY_S = 1.0  # live.js PROXY_RETRY_S: after a 502 or 504
RETRY_DEFAULT_S = 5.0
RETRY_MAX_S = 60.0
RECONNECT_S = 1.0  # the stream's own `retry: 1000`


@dataclass(frozen=True)
class Frame:
    at: float  # time.monotonic() on arrival
    step: int
    clock_s: float


class PageStream(threading.Thread):
    """One participant's page: its stream's frames, as they arrived."""

    def __init__(self, base_url: str, token: str, trial_id: int, stop: threading.Event) -> None:
        super().__init__(daemon=True, name=f"page-{trial_id}")
        parts = urlsplit(base_url)
        self.host, self.port = parts.hostname or "127.0.0.1", parts.port or 80
        self.token, self.trial_id, self.stop = token, trial_id, stop
        self.frames: list[Frame] = []
        #: When a stream was asked for, and what came of it ("open", "stalled", a status...).
        self.attempts: list[tuple[float, str]] = []
        self.last_event_id = ""
        self.ended = False

    def run(self) -> None:
        while not self.stop.is_set() and not self.ended:
            wait_s = self._one_stream()
            if wait_s:
                self.stop.wait(wait_s)

    def _one_stream(self) -> float:
        """Open one stream and read it until it ends or stalls; the wait before the next."""
        path = f"/api/live/{self.token}/trials/{self.trial_id}/stream"
        if self.last_event_id:
            path += f"?after={self.last_event_id}"
        connection = http.client.HTTPConnection(self.host, self.port, timeout=OPENING_S)
        asked = time.monotonic()
        try:
            connection.request("GET", path, headers={"Accept": "text/event-stream"})
            response = connection.getresponse()
            if response.status != 200:
                response.read()
                self.attempts.append((asked, str(response.status)))
                return self._wait_after(response.status, response.getheader("Retry-After"))
            self.attempts.append((asked, "open"))
            if connection.sock is not None:
                connection.sock.settimeout(STALLED_S)
            self._read(response)
            return 0.0 if self.ended else RECONNECT_S
        except TimeoutError:  # socket.timeout: the watchdog drops it and opens a new one
            self.attempts.append((asked, "stalled"))
            return 0.0
        except (OSError, http.client.HTTPException):
            self.attempts.append((asked, "dropped"))
            return RECONNECT_S
        finally:
            connection.close()

    def _wait_after(self, status: int, retry_after: str | None) -> float:
        if status in (502, 504):
            return PROXY_RETRY_S
        if status in (503, 429):
            try:
                seconds = float(retry_after or "")
            except ValueError:
                seconds = RETRY_DEFAULT_S
            seconds = min(seconds, RETRY_MAX_S) if seconds > 0 else RETRY_DEFAULT_S
            return seconds * (1 + random.random() / 2)
        if status < 500:
            self.ended = True  # the link or the trial is gone
            return 0.0
        return RETRY_DEFAULT_S

    def _read(self, response: http.client.HTTPResponse) -> None:
        event, data = "", []
        while not self.stop.is_set():
            line = response.readline()
            if not line:
                return  # closed by the server
            text = line.decode().rstrip("\r\n")
            if text.startswith("id:"):
                self.last_event_id = text[3:].strip()
            elif text.startswith("event:"):
                event = text[6:].strip()
            elif text.startswith("data:"):
                data.append(text[5:].strip())
            elif not text:
                if event == "takeover":
                    self.ended = True
                    return
                if data:
                    self._frame(json.loads("\n".join(data)))
                    if self.ended:
                        return
                event, data = "", []

    def _frame(self, frame: dict) -> None:
        trial = frame.get("trial") or {}
        self.frames.append(
            Frame(time.monotonic(), int(trial.get("step", -1)), float(trial.get("clock_s", 0.0)))
        )
        if trial.get("status") == "ended":
            self.ended = True


def open_pages(
    base_url: str, tokens_and_ids: list[tuple[str, int]]
) -> tuple[list[PageStream], threading.Event]:
    """A running page stream per trial; set the event to close them all."""
    stop = threading.Event()
    pages = [PageStream(base_url, token, trial_id, stop) for token, trial_id in tokens_and_ids]
    for page in pages:
        page.start()
    return pages, stop


def close_pages(pages: list[PageStream], stop: threading.Event) -> None:
    stop.set()
    for page in pages:
        page.join(timeout=OPENING_S + 2)
