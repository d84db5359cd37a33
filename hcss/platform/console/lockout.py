"""Failed console sign-ins: a limit per account and per address, then a lockout, audited.

400 wrong passwords used to get 400 plain 401s at 4-5 a second. Now, within
`WINDOW_S`, `ACCOUNT_FAILURES` failures for one username or
`ADDRESS_FAILURES` from one address lock that username or address for
`LOCKOUT_S`: every sign-in from it answers 429 with Retry-After, without
checking the password (so guessing gains nothing and costs no argon2 time).
Each lockout writes an `AuditRecord` (action ``login_lockout``). The counts
live in the server process (as Flask-Limiter's default memory storage does):
a restart forgets them, which costs a guesser a restart they cannot cause.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable

WINDOW_S = 15 * 60.0
LOCKOUT_S = 15 * 60.0
ACCOUNT_FAILURES = 5
# Higher: several experimenters may share a lab's address.
ADDRESS_FAILURES = 20

Key = tuple[str, str]  # ("account", username) or ("address", remote address)


class LoginThrottle:
    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self._lock = threading.Lock()
        self._failures: dict[Key, deque[float]] = {}
        self._locked_until: dict[Key, float] = {}

    @staticmethod
    def keys(username: str, address: str | None) -> tuple[Key, Key]:
        return ("account", username.strip().lower()[:64]), ("address", address or "?")

    def retry_after(self, keys: tuple[Key, ...]) -> float:
        """Seconds until every key may sign in again; 0 when none is locked."""
        now = self.clock()
        with self._lock:
            return max((self._locked_until.get(k, 0.0) - now for k in keys), default=0.0)

    def failed(self, keys: tuple[Key, ...]) -> list[tuple[Key, int]]:
        """Count a failure; returns the keys this failure locked, with their failure counts."""
        now = self.clock()
        locked = []
        with self._lock:
            for key in keys:
                recent = self._failures.setdefault(key, deque())
                recent.append(now)
                while recent and recent[0] < now - WINDOW_S:
                    recent.popleft()
                limit = ACCOUNT_FAILURES if key[0] == "account" else ADDRESS_FAILURES
                if len(recent) >= limit and self._locked_until.get(key, 0.0) <= now:
                    self._locked_until[key] = now + LOCKOUT_S
                    locked.append((key, len(recent)))
                    recent.clear()
        return locked

    def succeeded(self, keys: tuple[Key, ...]) -> None:
        """A correct password clears the account's failures (not the address's)."""
        with self._lock:
            for key in keys:
                if key[0] == "account":
                    self._failures.pop(key, None)


def audit_lockouts(database, locked: list[tuple[Key, int]], username: str) -> None:  # type: ignore[no-untyped-def]
    """One audit row per lockout, written in its own unit of work (the 401 rolls back)."""
    from hcss.platform.models import AuditRecord

    if not locked:
        return
    with database.session_scope() as session:
        for (scope, value), failures in locked:
            session.add(
                AuditRecord(
                    action="login_lockout",
                    experimenter=username.strip()[:64] or "?",
                    participant_code=None,
                    row_counts={
                        "scope": scope,
                        "key": value,
                        "failures": failures,
                        "locked_s": LOCKOUT_S,
                    },
                )
            )
