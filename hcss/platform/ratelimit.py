"""A per-client rate limit on enrolment through the public study link.

Anyone with the link can press Start, and each Start of a new visitor makes a
participant: one client made 4,500 in 73 s, and each counted in its cell.
`JOIN_PER_CLIENT` (count, seconds; ``HCSS_JOIN_PER_CLIENT=30/600``) bounds the
Starts one client may send in a sliding window; more answer 429 with
Retry-After and write nothing. The client is the proxy-corrected address
(``PROXY_HOPS``) counted by its prefix (`request_client`: an IPv6 /64, an IPv4
address or its /24 as ``HCSS_CLIENT_PREFIX_V4`` says). A lab whose
participants share one address raises the count.

The windows live in the process, not the database: a restart forgets them,
which costs an attacker one window, and checking one costs no query. With
``hcss serve --processes N`` each process keeps its own windows, so a client
may start up to N times the count (docs/operations.md).

The limit composes with a study's recruitment cap (its file's `target`):
the view checks the cap first, so a Start on a full study gets the "study
full" page (no wait would help) and, like a returning participant's Start,
uses none of the allowance, since it creates no one.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable

from flask import Flask, Response, current_app, request
from flask.typing import ResponseReturnValue

from hcss.platform.connections import client_prefix
from hcss.platform.errors import error_page

#: (Starts, seconds) one address may send; None: no limit.
DEFAULT = (30, 600.0)


class SlidingWindows:
    """At most `count` events per key within any `seconds`; thread-safe, pruned as it goes."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self._events: dict[str, deque[float]] = {}
        self._lock = threading.Lock()

    def take(self, key: str, count: int, seconds: float) -> float:
        """Count one event for `key`; 0 when allowed, else the seconds until one is."""
        now = self.clock()
        with self._lock:
            for stale in [k for k, q in self._events.items() if not q or q[-1] <= now - seconds]:
                del self._events[stale]  # keys idle for a whole window: memory stays bounded
            events = self._events.setdefault(key, deque())
            while events and events[0] <= now - seconds:
                events.popleft()
            if len(events) >= count:
                return events[0] + seconds - now
            events.append(now)
            return 0.0


def parse_limit(text: str) -> tuple[int, float] | None:
    """``"30/600"`` -> (30, 600.0); ``"0"`` or ``""`` -> None (no limit)."""
    if not text or text.strip() == "0":
        return None
    count, _, seconds = text.partition("/")
    return int(count), float(seconds or 60)


def enrolment_refusal() -> ResponseReturnValue | None:
    """Count one Start that would create a participant; the 429 answer past the limit, else None.

    The study link's view asks only once it knows the Start would create
    someone: a returning participant or a full study creates no one, so it
    uses none of the address's allowance and is never told to wait.
    """
    limit = current_app.config.get("JOIN_PER_CLIENT")
    if not limit:
        return None
    windows: SlidingWindows = current_app.extensions["hcss_join_windows"]
    wait_s = windows.take(request_client(), int(limit[0]), float(limit[1]))
    if wait_s <= 0:
        return None
    headers = {"Retry-After": str(max(1, round(wait_s)))}
    page = error_page(429)
    if isinstance(page, Response):  # plain text: the request named no host of ours
        page.headers.update(headers)
        return page
    return page[0], page[1], headers


def request_client() -> str:
    """The client every per-client limit counts this request under: its address's prefix."""
    return client_prefix(request.remote_addr, int(current_app.config.get("CLIENT_PREFIX_V4", 32)))


def install(app: Flask) -> None:
    app.extensions["hcss_join_windows"] = SlidingWindows()
