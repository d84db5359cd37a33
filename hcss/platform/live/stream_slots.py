"""Who may hold a stream: one per participant link, a share per client and per study, and a
server ceiling.

Each open Server-Sent Events stream holds one waitress thread for up to
`STREAM_MAX_S`, so one token opening many streams could take every thread and
time the console out. Two rules keep threads free:

- per link (token): the newest stream takes over. The older one gets a
  ``takeover`` event (data ``{"reason": "another_tab"}``) and closes, which is
  also what a second browser tab should see;
- per server: at most `MAX_STREAMS` streams; one more is a 503 with
  Retry-After, so the threads above the ceiling stay free for page loads and
  the console (`hcss serve` sets the ceiling from its thread count);
- per client address: at most `STREAMS_PER_CLIENT` of them (default a
  quarter of the ceiling, at least 4), so participants scripted from one
  address cannot hold every stream and starve real ones. The address is the
  proxy-corrected one (``PROXY_HOPS``);
- per study, while another study wants streams too: at most
  `STREAMS_PER_STUDY` (default three quarters of the ceiling), so the
  participants of one study (real, or scripted from many addresses) leave
  room for another's. A study wants streams while it holds one or has asked
  within `WANTING_S`; a study alone on the server may use the whole ceiling.
  A study that found the server full is thereby counted, so the crowded
  study's next stream (streams reconnect every `STREAM_MAX_S`) is refused
  and the waiting one's retry gets the place.

- when the server is crowded (`CROWDED` of the ceiling open) and the share
  is the default one, a client holding `FEW` streams gets no more: the last
  quarter stays for clients with few, so scripted participants from a few
  addresses (4 x 8 of a 32-stream server) cannot hold every stream before
  the next real participant comes. A lab that sets ``HCSS_STREAMS_PER_CLIENT``
  (its participants share an address) has no reserve.

A takeover replaces the link's own stream, so it is allowed at the ceiling.
The shares are per process, as the threads they protect are.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

TAKEOVER_EVENT = "takeover"
TAKEOVER_DATA = json.dumps({"reason": "another_tab"})
#: Seconds a refused stream is asked to wait before it tries again.
RETRY_AFTER_S = 5
#: Seconds a study that asked for a stream counts as wanting streams (two stream lifetimes).
WANTING_S = 600.0
#: Share of the ceiling past which only clients holding fewer than `FEW` get a stream.
CROWDED, FEW = 0.75, 2


def takeover_frame() -> str:
    return f"event: {TAKEOVER_EVENT}\ndata: {TAKEOVER_DATA}\n\n"


def reserve_for_pages(threads: int) -> int:
    """Threads kept free of streams for page loads and the console: an eighth, at least 16."""
    return max(16, threads // 8)


def client_share(max_streams: int | None) -> int | None:
    """Streams one address may hold by default: a quarter of the ceiling, at least 4."""
    return None if max_streams is None else max(4, max_streams // 4)


def study_share(max_streams: int | None) -> int | None:
    """Streams one study may hold by default while another wants some: three quarters
    of the ceiling, at least 1."""
    return None if max_streams is None else max(1, max_streams - max_streams // 4)


@dataclass(frozen=True)
class StreamTicket:
    token: str
    number: int
    client: str = "?"
    study: str = ""


class StreamSlots:
    """The server's open streams; thread-safe."""

    def __init__(
        self,
        max_streams: int | None,
        per_token: int = 1,
        per_client: int | None = None,
        per_study: int | None = None,
        clock: Callable[[], float] = time.monotonic,
        reserve_for_few: bool = False,
    ) -> None:
        self.max_streams = max_streams
        self.per_token = per_token
        self.per_client = per_client
        self.per_study = per_study
        self.clock = clock
        self.reserve_for_few = reserve_for_few
        self._lock = threading.Lock()
        self._open: dict[str, list[int]] = {}  # token -> ticket numbers, oldest first
        self._clients: dict[str, int] = {}  # address -> open streams
        self._studies: dict[str, int] = {}  # study name ("" for none) -> open streams
        self._asked: dict[str, float] = {}  # study name -> when it last asked for a stream
        self._count = 0
        self._next = 0

    @property
    def count(self) -> int:
        return self._count

    def acquire(self, token: str, client: str = "?", study: str = "") -> StreamTicket | None:
        """A ticket for a new stream of `token` from `client` in `study`, or None when the
        server, the client's share or the study's share is full."""
        with self._lock:
            mine = self._open.setdefault(token, [])
            taking_over = len(mine) >= self.per_token
            full = self.max_streams is not None and self._count >= self.max_streams
            over_share = self.per_client is not None and (
                self._clients.get(client, 0) >= self.per_client
            )
            over_study = self._over_study_share(study)
            crowded = (
                self.reserve_for_few
                and self.max_streams is not None
                and self._count >= CROWDED * self.max_streams
                and self._clients.get(client, 0) >= FEW
            )
            if not taking_over and (full or over_share or over_study or crowded):
                if not mine:
                    del self._open[token]
                return None
            self._next += 1
            mine.append(self._next)
            self._count += 1
            self._clients[client] = self._clients.get(client, 0) + 1
            self._studies[study] = self._studies.get(study, 0) + 1
            return StreamTicket(token, self._next, client, study)

    def _over_study_share(self, study: str) -> bool:
        """Whether `study` holds its share while another study wants streams (lock held)."""
        now = self.clock()
        self._asked = {s: t for s, t in self._asked.items() if t > now - WANTING_S}
        self._asked[study] = now
        if self.per_study is None or self._studies.get(study, 0) < self.per_study:
            return False
        return any(other != study for other in (*self._studies, *self._asked))

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
                _count_down(self._clients, ticket.client)
                _count_down(self._studies, ticket.study)
            if not mine:
                self._open.pop(ticket.token, None)


def _count_down(counts: dict[str, int], key: str) -> None:
    left = counts.get(key, 1) - 1
    if left > 0:
        counts[key] = left
    else:
        counts.pop(key, None)
