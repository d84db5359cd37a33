"""Failed console sign-ins: a limit per (account, client), then a short back-off, audited.

A sign-in is counted as a failure *before* its password is checked, in one
serialised unit of work: guesses sent at once queue on that count, so a burst
of any size gets at most `CLIENT_FAILURES` password checks per window; the
rest answer 429 with Retry-After and cost no argon2 time. A correct password
then deletes its (account, client) rows, so it was never a failure.

The key is the account *and* the client's address, never one of them alone:
a guesser who types an experimenter's name locks out only their own address,
and one address guessing many names locks none of the real accounts there.
The address is the proxy-corrected one (``PROXY_HOPS``, werkzeug's ProxyFix),
so behind the reverse proxy every visitor is still their own client.

Recovery that does not wait for the guesser to stop: the back-off is short
(`LOCKOUT_S`), another client signs in as usual, addresses in
``CONSOLE_ALLOW`` are never throttled, and ``hcss admin unlock`` clears an
account's rows. The rows live in the database, so a restart or a second
server process keeps the counts.
"""

from __future__ import annotations

import hashlib
import ipaddress
import threading
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from sqlalchemy import ColumnElement, and_, delete, func, or_, select, text
from sqlalchemy.orm import Session

from hcss.platform.db import Database, hand_back_connection
from hcss.platform.models import AuditRecord, LoginFailure

WINDOW_S = 15 * 60.0
LOCKOUT_S = 5 * 60.0
CLIENT_FAILURES = 5
#: Seconds a sign-in waits for the one before it of the same (account, client).
TURN_WAIT_S = 10.0
SCOPE = "client"
_NAME_CHARS = 47  # key = 16 hex digits of the address's hash, ":", the name: 64 at most


def client_key(username: str, address: str | None) -> str:
    """The (account, client) key: the address hashed (no address at rest), the name kept
    so `unlock` can find every client's rows of one account."""
    digest = hashlib.sha256((address or "?").encode()).hexdigest()[:16]
    return f"{digest}:{_name(username)}"


def account_key(username: str) -> str:
    """The account part of a key (the name as typed, folded), for per-account counts."""
    return _name(username)


def _name(username: str) -> str:
    return username.strip().lower()[:_NAME_CHARS]


def _of(key: str) -> ColumnElement[bool]:
    return and_(LoginFailure.scope == SCOPE, LoginFailure.key == key)


def allowed(address: str | None, networks: Iterable[str]) -> bool:
    """Whether the address lies in one of the allow-listed networks (CIDR strings)."""
    if not address:
        return False
    try:
        ip = ipaddress.ip_address(address)
    except ValueError:
        return False
    return any(ip in ipaddress.ip_network(network, strict=False) for network in networks)


@dataclass(frozen=True)
class Attempt:
    """One sign-in, already counted as a failure; `wait_s` > 0 when it was refused."""

    key: str
    wait_s: float = 0.0
    failures: int = 0
    locks: bool = False
    row_id: int | None = None  # its failure row, taken back if the password was right


class LoginThrottle:
    """The sign-in limits, kept in the database.

    Time is the database's row clock (`Database.clock`, seconds since 1970), so
    the failure rows' stamps and the lockout windows lie on one timeline; a
    test may give its own `clock`.
    """

    def __init__(self, database: Database, clock: Callable[[], float] | None = None) -> None:
        self.database = database
        self._clock = clock
        self._lock = threading.Lock()  # this process's half of the serialisation
        self._turns: dict[str, tuple[threading.Lock, list[int]]] = {}
        self._turns_lock = threading.Lock()

    @contextmanager
    def in_turn(self, username: str, address: str | None) -> Iterator[None]:
        """Hold this process's turn of one (account, client)'s sign-ins (from `begin` to
        `succeeded`), so each is counted after the one before it was decided.

        A turn not had in `TURN_WAIT_S` is gone on without: the count still
        bounds the passwords checked, as it did before turns.
        """
        key = client_key(username, address)
        with self._turns_lock:
            lock, waiting = self._turns.setdefault(key, (threading.Lock(), [0]))
            waiting[0] += 1
        had = lock.acquire(timeout=TURN_WAIT_S)
        try:
            yield
        finally:
            if had:
                lock.release()
            with self._turns_lock:
                waiting[0] -= 1
                if not waiting[0]:
                    self._turns.pop(key, None)

    @contextmanager
    def _unit(self) -> Iterator[Session]:
        """One count's unit of work, in this process's turn. The request's own read ends
        first: no transaction idles while this thread waits for the turn."""
        hand_back_connection()
        with self._lock, self.database.session_scope() as session:
            yield session

    def clock(self) -> float:
        return (self._clock or self.database.clock)()

    def begin(self, username: str, address: str | None) -> Attempt:
        """Count this sign-in as a failure now, or refuse it while its key is locked.

        The failure that reaches `CLIENT_FAILURES` within the window carries
        the lockout. A key's count starts again after each lockout.
        """
        key, now = client_key(username, address), self.clock()
        with self._unit() as session:
            _one_count_at_a_time(session, key)
            session.execute(  # rows that no count or lockout needs any more, any key
                delete(LoginFailure).where(
                    LoginFailure.at_epoch < now - WINDOW_S,
                    or_(LoginFailure.locked_until.is_(None), LoginFailure.locked_until < now),
                )
            )
            last_id, locked_until = session.execute(
                select(func.max(LoginFailure.id), func.max(LoginFailure.locked_until)).where(
                    _of(key), LoginFailure.locked_until.is_not(None)
                )
            ).one()
            if locked_until is not None and locked_until > now:
                return Attempt(key, wait_s=locked_until - now)
            recent = session.scalar(
                select(func.count()).where(
                    _of(key),
                    LoginFailure.at_epoch >= now - WINDOW_S,
                    LoginFailure.id > (last_id or 0),
                )
            )
            failures = int(recent or 0) + 1
            locks = failures >= CLIENT_FAILURES
            row = LoginFailure(
                scope=SCOPE, key=key, at_epoch=now, locked_until=now + LOCKOUT_S if locks else None
            )
            session.add(row)
            session.flush()
            row_id = row.id
        return Attempt(key, failures=failures, locks=locks, row_id=row_id)

    def succeeded(self, attempt: Attempt) -> None:
        """The right password was no failure. Alone, it means this (account, client) never
        failed: its count starts again. With other sign-ins of it waiting their turn behind
        it (a burst: a person signs in once at a time), only its own count is taken back, so
        the guesses behind it are still counted from the wrong ones before it."""
        with self._turns_lock:
            turn = self._turns.get(attempt.key)
            burst = turn is not None and turn[1][0] > 1
        with self._unit() as session:
            if not burst:
                session.execute(delete(LoginFailure).where(_of(attempt.key)))
                return
            if attempt.row_id is not None:
                session.execute(delete(LoginFailure).where(LoginFailure.id == attempt.row_id))

    def take(self, scope: str, key: str, count: int, window_s: float) -> bool:
        """Count one event of (`scope`, `key`); False, counting nothing, when `count` of them
        lie within the last `window_s` already.

        For limits that must hold on every process sharing the database (the second
        factor's codes per account): the rows are the `begin` count's, in turn per key.
        """
        now = self.clock()
        with self._unit() as session:
            _one_count_at_a_time(session, f"{scope}:{key}")
            taken = session.scalar(
                select(func.count()).where(
                    LoginFailure.scope == scope,
                    LoginFailure.key == key,
                    LoginFailure.at_epoch >= now - window_s,
                )
            )
            if int(taken or 0) >= count:
                return False
            session.add(LoginFailure(scope=scope, key=key, at_epoch=now, locked_until=None))
        return True

    def wait_s(self, scope: str, key: str, count: int, window_s: float) -> float:
        """Seconds until `take` of (`scope`, `key`) counts again (0: it would now); reads only."""
        now = self.clock()
        with self.database.session_scope() as session:
            stamps = session.scalars(
                select(LoginFailure.at_epoch)
                .where(
                    LoginFailure.scope == scope,
                    LoginFailure.key == key,
                    LoginFailure.at_epoch >= now - window_s,
                )
                .order_by(LoginFailure.at_epoch.desc())
                .limit(count)
            ).all()
        if len(stamps) < count:
            return 0.0
        return max(0.0, stamps[-1] + window_s - now)

    def forget(self, scope: str, key: str) -> None:
        """Drop the events of (`scope`, `key`): the right code was never a wrong one."""
        with self._unit() as session:
            session.execute(
                delete(LoginFailure).where(LoginFailure.scope == scope, LoginFailure.key == key)
            )

    def unlock(self, username: str) -> int:
        """Clear an account's failures and lockouts from every client; returns the rows."""
        with self._unit() as session:
            result = session.execute(
                delete(LoginFailure).where(
                    or_(
                        and_(
                            LoginFailure.scope == SCOPE,
                            LoginFailure.key.endswith(":" + _name(username), autoescape=True),
                        ),
                        # the second factor's counts of the account (second_factor.CODE_SCOPES)
                        and_(
                            LoginFailure.scope.in_(("code", "lockcode")),
                            LoginFailure.key == _name(username),
                        ),
                    )
                )
            )
            # A DELETE answers a CursorResult; Session.execute is typed as any Result.
            return int(result.rowcount or 0)  # type: ignore[attr-defined]


def _one_count_at_a_time(session: Session, key: str) -> None:
    """Server processes sharing the database count one key's attempts in turn.

    PostgreSQL: a transaction-scoped advisory lock on the key. SQLite: a write
    that changes nothing takes the database's write lock before the count is read.
    """
    dialect = session.get_bind().dialect.name
    if dialect == "postgresql":
        lock = int.from_bytes(hashlib.sha256(key.encode()).digest()[:8], "big", signed=True)
        session.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": lock})
    elif dialect == "sqlite":
        session.execute(text("UPDATE login_failure SET key = key WHERE 0 = 1"))


def audit_lockout(database: Database, attempt: Attempt, username: str) -> None:
    """An audit row for a failure that locked its key (its own unit of work: the 401 rolls back).

    The counts are numbers, as every audit row's are; who was locked is the
    row's experimenter field (the name typed).
    """
    if not attempt.locks:
        return
    with database.session_scope() as session:
        session.add(
            AuditRecord(
                action="login_lockout",
                experimenter=username.strip()[:64] or "?",
                participant_code=None,
                row_counts={"failures": attempt.failures, "locked_s": int(LOCKOUT_S)},
            )
        )
