"""Who may hold a stream: one per participant link, and a ceiling for the whole server.

Each open Server-Sent Events stream holds one waitress thread for up to
`STREAM_MAX_S`, so one token opening many streams could take every thread and
time the console out. Two rules keep threads free:

- per link (token): the newest stream takes over. The older one gets a
  ``takeover`` event (data ``{"reason": "another_tab"}``) and closes, which is
  also what a second browser tab should see;
- per server: at most `MAX_STREAMS` streams; one more is a 503 with
  Retry-After, so the threads above the ceiling stay free for page loads and
  the console (`hcss serve` sets the ceiling from its thread count).

A takeover replaces the link's own stream, so it is allowed at the ceiling.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass

TAKEOVER_EVENT = "takeover"
TAKEOVER_DATA = json.dumps({"reason": "another_tab"})
#: Seconds a refused stream is asked to wait before it tries again.
RETRY_AFTER_S = 5


def takeover_frame() -> str:
    return f"event: {TAKEOVER_EVENT}\ndata: {TAKEOVER_DATA}\n\n"


def reserve_for_pages(threads: int) -> int:
    """Threads kept free of streams for page loads and the console: an eighth, at least 16."""
    return max(16, threads // 8)


@dataclass(frozen=True)
class StreamTicket:
    token: str
    number: int


class StreamSlots:
    """The server's open streams; thread-safe."""

    def __init__(self, max_streams: int | None, per_token: int = 1) -> None:
        self.max_streams = max_streams
        self.per_token = per_token
        self._lock = threading.Lock()
        self._open: dict[str, list[int]] = {}  # token -> ticket numbers, oldest first
        self._count = 0
        self._next = 0

    @property
    def count(self) -> int:
        return self._count

    def acquire(self, token: str) -> StreamTicket | None:
        """A ticket for a new stream of `token`, or None when the server is full."""
        with self._lock:
            mine = self._open.setdefault(token, [])
            taking_over = len(mine) >= self.per_token
            if not taking_over and self.max_streams is not None and self._count >= self.max_streams:
                if not mine:
                    del self._open[token]
                return None
            self._next += 1
            mine.append(self._next)
            self._count += 1
            return StreamTicket(token, self._next)

    def superseded(self, ticket: StreamTicket) -> bool:
        """True once newer streams of the same link fill its allowance."""
        with self._lock:
            mine = self._open.get(ticket.token, [])
            return ticket.number not in mine[-self.per_token :]

    def release(self, ticket: StreamTicket) -> None:
        with self._lock:
            mine = self._open.get(ticket.token, [])
            if ticket.number in mine:
                mine.remove(ticket.number)
                self._count -= 1
            if not mine:
                self._open.pop(ticket.token, None)
