"""Failed console sign-ins: a limit per account and per address, then a lockout, audited.

400 wrong passwords used to get 400 plain 401s at 4-5 a second. Now, within
`WINDOW_S`, `ACCOUNT_FAILURES` failures for one username or
`ADDRESS_FAILURES` from one address lock that username or address for
`LOCKOUT_S`: every sign-in from it answers 429 with Retry-After, without
checking the password (so guessing gains nothing and costs no argon2 time).
Each lockout writes an `AuditRecord` (action ``login_lockout``).

The failures and lockouts are rows of `login_failure` (`LoginFailure`), not
process memory: a restart used to forget them, so a guesser who could make
the server restart (or who met a second server process) started afresh.
Each failure and each check is its own unit of work, apart from the sign-in
request, whose 401 rolls back.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from sqlalchemy import ColumnElement, and_, delete, func, or_, select

from hcss.platform.db import Database
from hcss.platform.models import LoginFailure

WINDOW_S = 15 * 60.0
LOCKOUT_S = 15 * 60.0
ACCOUNT_FAILURES = 5
# Higher: several experimenters may share a lab's address.
ADDRESS_FAILURES = 20

Key = tuple[str, str]  # ("account", username) or ("address", remote address)


def _of(key: Key) -> ColumnElement[bool]:
    return and_(LoginFailure.scope == key[0], LoginFailure.key == key[1])


class LoginThrottle:
    """The sign-in limits, kept in the database.

    Time is the database's row clock (`Database.clock`, seconds since 1970), so
    the failure rows' stamps and the lockout windows lie on one timeline; a
    test may give its own `clock`.
    """

    def __init__(self, database: Database, clock: Callable[[], float] | None = None) -> None:
        self.database = database
        self._clock = clock
        self._lock = threading.Lock()  # one process counts and locks a key at a time

    def clock(self) -> float:
        return (self._clock or self.database.clock)()

    @staticmethod
    def keys(username: str, address: str | None) -> tuple[Key, Key]:
        return ("account", username.strip().lower()[:64]), ("address", (address or "?")[:64])

    def retry_after(self, keys: tuple[Key, ...]) -> float:
        """Seconds until every key may sign in again; 0 when none is locked."""
        now = self.clock()
        with self.database.session_scope() as session:
            until = session.scalar(
                select(func.max(LoginFailure.locked_until)).where(or_(*(_of(k) for k in keys)))
            )
        return max(0.0, (until or 0.0) - now)

    def failed(self, keys: tuple[Key, ...]) -> list[tuple[Key, int]]:
        """Count a failure; returns the keys this failure locked, with their failure counts.

        A key's count starts again after each lockout: only failures within
        the window and after the key's last lockout count.
        """
        now = self.clock()
        locked = []
        with self._lock, self.database.session_scope() as session:
            for key in keys:
                session.execute(  # what no count or lockout needs any more
                    delete(LoginFailure).where(
                        _of(key),
                        LoginFailure.at_epoch < now - WINDOW_S,
                        or_(LoginFailure.locked_until.is_(None), LoginFailure.locked_until < now),
                    )
                )
                last_lock = session.execute(
                    select(func.max(LoginFailure.id), func.max(LoginFailure.locked_until)).where(
                        _of(key), LoginFailure.locked_until.is_not(None)
                    )
                ).one()
                failure = LoginFailure(scope=key[0], key=key[1], at_epoch=now)
                session.add(failure)
                session.flush()
                recent = session.scalar(
                    select(func.count()).where(
                        _of(key),
                        LoginFailure.at_epoch >= now - WINDOW_S,
                        LoginFailure.id > (last_lock[0] or 0),
                    )
                )
                limit = ACCOUNT_FAILURES if key[0] == "account" else ADDRESS_FAILURES
                if recent >= limit and (last_lock[1] or 0.0) <= now:
                    failure.locked_until = now + LOCKOUT_S
                    locked.append((key, int(recent)))
        return locked

    def succeeded(self, keys: tuple[Key, ...]) -> None:
        """A correct password clears the account's failures (not the address's)."""
        with self.database.session_scope() as session:
            for key in keys:
                if key[0] == "account":
                    session.execute(delete(LoginFailure).where(_of(key)))


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
