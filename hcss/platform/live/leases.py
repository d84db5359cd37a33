"""Trial ownership across server processes: a lease row per trial.

Several `hcss serve` processes can share one PostgreSQL database; each live
trial must be stepped, recorded and commanded in exactly one of them. A
process hosts a trial while it holds the trial's `TrialLease` row: its own
name in `owner` and an expiry in the future. The owner's runner renews every
lease it holds in one UPDATE a few times per lease length. When the owner
dies the lease runs out, and the next process that needs the trial (a
participant's request routed to it, or its runner's sync) takes it with one
conditional statement and rebuilds the trial from its newest snapshot and
the command log, as after a restart.

Why a row and not a PostgreSQL advisory lock on a dedicated connection:
the lock is released the instant the owner's connection drops, but so it is
when the connection merely breaks (a database restart, a network blip), and
the owner learns that only on its next query, while another process already
hosts the trial; a lease expires by one clock (the database's), and the
owner stops on its own deadline before anyone else may start. Rows work on
SQLite too (the tests race takeovers there as well), need no connection per
process outside the pool, and are visible to the console. The price is the
failover delay (at most one lease length) and one UPDATE per renewal for
all of a process's trials.

Fencing. A holder that stalled (SIGSTOP, a long GC, a swap storm) or lost
its database link learns of it only later; meanwhile another process may
have taken the trial. So a lease is not only held but proved: every claim
raises the row's `epoch`, the trial in memory carries the epoch it was
claimed with, and every transaction that writes for the trial first runs
`prove` in the same transaction: an UPDATE of the lease row that matches
only while owner, epoch and an unexpired `expires_epoch` all hold. On
PostgreSQL that UPDATE also locks the row until the commit, so a claimant's
UPDATE waits for the writer and then sees the lease as the writer left it:
a write lands either before the takeover (and the new host's rebuild reads
it) or not at all. A failed proof rolls the transaction back (`LeaseLost`,
a 503 the page retries). Times are the database's clock on PostgreSQL
(`clock_timestamp()`), so two hosts' clocks never meet; on SQLite (one
host) and under a test's `ManualClock` they are the process clock.

The holder also stops on its own clock: each trial's `Fence.deadline` is the
monotonic instant of the last renewal that succeeded plus the lease less a
margin; past it, nothing is written for the trial until a renewal confirms
the lease again, whatever the database answers (or does not).

Hand-back. nginx hashes each participant to one process; while another
process holds the trial (it took it over while that one was down), every
request of the participant reaches the hashed process first, is answered
503 and passed on: a detour per request. So a process that answers a
participant's request that way asks for the trial (`ask_back`: its name in
the lease's `wanted_by`), and the holder, at its next renewal, hears it
(`renew_hearing_asks`) and hands the trial over at a safe point (`hand_back`, in a
fenced unit of work that writes what it holds and a snapshot). Against
ping-pong: only a participant's own request asks (the console and the
runners' syncs never do); the first asker keeps the request while it is
fresh (nginx tries the hashed process first, so its ask is written before
any other process sees the request); and a trial is handed over only after
its holder has held it for a lease, so at most once per lease period.

Only processes started as part of a group (`hcss serve --processes N`, or
`--cluster`) lease; a lone server hosts every trial, as before.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING

from sqlalchemy import Double, and_, cast, delete, func, literal, or_, select, update
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.orm import Session
from sqlalchemy.sql.elements import ColumnElement
from werkzeug.exceptions import ServiceUnavailable

from hcss.platform.db import Database
from hcss.platform.models import Trial, TrialLease

if TYPE_CHECKING:
    from hcss.platform.live.running_trial import RunningTrial

#: Seconds a lease lasts unless renewed; failover takes at most this long plus a sync.
LEASE_S = 6.0
#: Seconds a started trial that no process has claimed yet is left to the process whose
#: participant started it (its first request claims it) before any runner takes it.
UNCLAIMED_GRACE_S = 30.0
#: Renewals per lease length: a renewal may be late twice before the lease is at risk.
RENEWALS_PER_LEASE = 3
#: Renewals a holder has missed in a row when a process asked for its trial stops waiting for
#: it to answer and waits out its lease instead (`Leases.runs_out_unrenewed`).
MISSED_RENEWALS = 2
#: Seconds before its lease runs out (by its own monotonic clock) that a holder stops writing:
#: room for a transaction begun just before the deadline and for clock rate differences.
STOP_MARGIN_S = 1.0
#: Seconds between two asks of one process for one trial: the ask stays fresh for a lease,
#: so the participant's requests need not each write it.
ASK_EVERY_S = 1.0


class HostedElsewhere(ServiceUnavailable):
    """The trial is hosted by another live process: try again (a proxy tries the next one)."""

    def __init__(self, trial_id: int, owner: str) -> None:
        super().__init__(f"trial {trial_id} is hosted by another server process", retry_after=1)
        self.trial_id = trial_id
        self.owner = owner


class LeaseLost(HostedElsewhere):
    """This process cannot prove it holds the trial's lease: nothing was written (503)."""

    def __init__(self, trial_id: int) -> None:
        super().__init__(trial_id, "")
        self.description = (
            f"trial {trial_id} is moving to another server process; try again in a moment"
        )


class Leases:
    """The leases of one process (`owner`), read and written by the database's clock."""

    def __init__(self, database: Database, owner: str, *, lease_s: float = LEASE_S) -> None:
        self.database = database
        self.owner = owner
        self.lease_s = lease_s
        #: When this process last asked for each trial (monotonic), to write an ask once a second.
        self._asked: dict[int, float] = {}

    @property
    def renew_every_s(self) -> float:
        return self.lease_s / RENEWALS_PER_LEASE

    @property
    def monotonic(self) -> Callable[[], float]:
        """The holder's own clock for its deadlines: monotonic in a server; a test's
        `ManualClock` (the database's clock) when one is in place, so tests move it."""
        return time.monotonic if self._wall_clock else self.database.clock

    def deadline_after(self, renewal_started: float) -> float:
        """The monotonic instant a lease renewed (or claimed) at `renewal_started` stops
        counting as held here: its length less `STOP_MARGIN_S`."""
        return renewal_started + self.lease_s - min(STOP_MARGIN_S, self.lease_s / 3)

    @property
    def _wall_clock(self) -> bool:
        return self.database.clock is time.time

    def _now(self, session: Session, now: float) -> ColumnElement[float]:
        """Now by the database's clock on PostgreSQL in a server; else the given clock reading."""
        if self._wall_clock and session.get_bind().dialect.name == "postgresql":
            return cast(func.extract("epoch", func.clock_timestamp()), Double)
        return literal(now, Double)

    def prove(self, session: Session, trial_id: int, epoch: int, now: float) -> None:
        """Prove in `session`'s transaction that this process holds the trial's lease at
        `epoch`, and keep the row locked until the commit; else `LeaseLost`.

        Call it first in every transaction that writes for the trial.
        """
        proved = session.execute(
            update(TrialLease)
            .where(
                TrialLease.trial_id == trial_id,
                TrialLease.owner == self.owner,
                TrialLease.epoch == epoch,
                TrialLease.expires_epoch > self._now(session, now),
            )
            .values(owner=TrialLease.owner)
            .returning(TrialLease.trial_id)
            .execution_options(synchronize_session=False)
        ).first()
        if proved is None:
            raise LeaseLost(trial_id)

    def claim(self, trial_id: int, now: float) -> int | None:
        """Take the trial's lease if nobody holds it, it ran out, or it is already ours;
        the lease's new epoch, or None when another process holds it.

        One transaction with two statements, each atomic on the row: an insert
        that does nothing when a row exists, and an update whose condition is
        checked again on the row as committed by any racing claimant
        (PostgreSQL re-reads a row it waited for; SQLite writes one at a time).
        So of two processes claiming one expired lease, exactly one wins. Each
        claim raises the epoch, even a claim of our own lease: what this
        process held under the old epoch can no longer write.
        """
        with self.database.session_scope() as session:
            dialect = session.get_bind().dialect.name
            insert = pg_insert if dialect == "postgresql" else sqlite_insert
            db_now = self._now(session, now)
            inserted = session.execute(
                insert(TrialLease)
                .values(
                    trial_id=trial_id,
                    owner=self.owner,
                    epoch=1,
                    expires_epoch=db_now + self.lease_s,
                    taken_epoch=db_now,
                )
                .on_conflict_do_nothing(index_elements=["trial_id"])
            )
            # An INSERT/UPDATE answers a CursorResult; Session.execute is typed as any Result.
            if inserted.rowcount == 1:  # type: ignore[attr-defined]
                return 1
            return session.scalar(
                update(TrialLease)
                .where(
                    TrialLease.trial_id == trial_id,
                    or_(TrialLease.owner == self.owner, TrialLease.expires_epoch < db_now),
                )
                .values(
                    owner=self.owner,
                    epoch=TrialLease.epoch + 1,
                    expires_epoch=db_now + self.lease_s,
                    taken_epoch=db_now,
                )
                .returning(TrialLease.epoch)
                .execution_options(synchronize_session=False)
            )

    def renew(self, held: dict[int, int], now: float) -> set[int]:
        """Extend our leases of these trials (id: epoch) in one statement; the ids still ours."""
        return self.renew_hearing_asks(held, now)[0]

    def renew_hearing_asks(
        self, held: dict[int, int], now: float
    ) -> tuple[set[int], dict[int, str]]:
        """`renew`, and in the same transaction the asks for those trials (`_asks`):
        one unit of work per renewal, as without asks."""
        if not held:
            return set(), {}
        with self.database.session_scope() as session:
            db_now = self._now(session, now)
            rows = session.execute(
                update(TrialLease)
                .where(
                    or_(
                        *(
                            and_(TrialLease.trial_id == trial_id, TrialLease.epoch == epoch)
                            for trial_id, epoch in held.items()
                        )
                    ),
                    TrialLease.owner == self.owner,
                    TrialLease.expires_epoch >= db_now,
                )
                .values(expires_epoch=db_now + self.lease_s)
                .returning(TrialLease.trial_id)
                .execution_options(synchronize_session=False)
            )
            kept = {trial_id for (trial_id,) in rows}
            return kept, self._asks(session, kept, db_now)

    def pass_on(self, session: Session, trial_id: int, heir: str, now: float) -> None:
        """Give our lease of the trial to `heir`, in the caller's transaction (which proved
        it); the epoch rises, so nothing this process still holds can write."""
        db_now = self._now(session, now)
        session.execute(
            update(TrialLease)
            .where(TrialLease.trial_id == trial_id, TrialLease.owner == self.owner)
            .values(
                owner=heir,
                epoch=TrialLease.epoch + 1,
                expires_epoch=db_now + self.lease_s,
                taken_epoch=db_now,
            )
            .execution_options(synchronize_session=False)
        )

    def ask_back(self, trial_id: int, now: float) -> str | None:
        """Ask the live holder of the trial to hand it to this process; the holder asked,
        or None (nobody else holds it, or another process asked first and still asks).

        Call it only for a participant's own request, which nginx's hash sent here. At
        most one write per `ASK_EVERY_S` per trial: an ask stays fresh for a lease.
        """
        last = self._asked.get(trial_id)
        if last is not None and time.monotonic() - last < ASK_EVERY_S:
            return None
        if len(self._asked) > 4096:  # forget asks too old to hold back a new one
            self._asked = {
                t: at for t, at in self._asked.items() if at > time.monotonic() - ASK_EVERY_S
            }
        self._asked[trial_id] = time.monotonic()
        with self.database.session_scope() as session:
            db_now = self._now(session, now)
            return session.scalar(
                update(TrialLease)
                .where(
                    TrialLease.trial_id == trial_id,
                    TrialLease.owner != self.owner,
                    TrialLease.expires_epoch >= db_now,
                    or_(
                        TrialLease.wanted_by.is_(None),
                        TrialLease.wanted_by == self.owner,
                        TrialLease.wanted_epoch < db_now - self.lease_s,
                    ),
                )
                .values(wanted_by=self.owner, wanted_epoch=db_now)
                .returning(TrialLease.owner)
                .execution_options(synchronize_session=False)
            )

    def _handable(self, db_now: ColumnElement[float]) -> ColumnElement[bool]:
        """A lease of ours that another process asks for (within a lease) and that we have
        held for a lease at least (so a trial moves back at most once per lease period)."""
        return and_(
            TrialLease.owner == self.owner,
            TrialLease.wanted_by.is_not(None),
            TrialLease.wanted_by != self.owner,
            TrialLease.wanted_epoch >= db_now - self.lease_s,
            TrialLease.taken_epoch <= db_now - self.lease_s,
        )

    def _asks(
        self, session: Session, trial_ids: Iterable[int], db_now: ColumnElement[float]
    ) -> dict[int, str]:
        """Of these trials held here, those another process asks for now: id -> the asker."""
        held = list(trial_ids)
        if not held:
            return {}
        rows = session.execute(
            select(TrialLease.trial_id, TrialLease.wanted_by).where(
                TrialLease.trial_id.in_(held), self._handable(db_now)
            )
        )
        return {trial_id: str(asker) for trial_id, asker in rows}

    def hand_back(self, session: Session, trial_id: int, heir: str, now: float) -> bool:
        """Pass our lease of the trial to `heir`, which asks for it, in the caller's
        transaction (which proved it); False when the ask is gone (void, or another's).

        The lease goes to the asker itself, not to whoever claims first: its next
        request for the trial claims it (a claim of its own lease) and rebuilds it, and
        no runner's sync takes it meanwhile. The epoch rises, so nothing this process
        still holds can write.
        """
        db_now = self._now(session, now)
        handed = session.execute(
            update(TrialLease)
            .where(
                TrialLease.trial_id == trial_id,
                TrialLease.wanted_by == heir,
                self._handable(db_now),
            )
            .values(
                owner=heir,
                epoch=TrialLease.epoch + 1,
                expires_epoch=db_now + self.lease_s,
                taken_epoch=db_now,
                wanted_by=None,
                wanted_epoch=None,
            )
            .returning(TrialLease.trial_id)
            .execution_options(synchronize_session=False)
        ).first()
        return handed is not None

    def release(self, trial_id: int) -> None:
        """Give the trial up now (it ended, or this process stops hosting it)."""
        with self.database.session_scope() as session:
            session.execute(
                delete(TrialLease).where(
                    TrialLease.trial_id == trial_id, TrialLease.owner == self.owner
                )
            )

    def owner_of(self, trial_id: int) -> str | None:
        """The process named in the trial's lease, whether or not it has run out."""
        with self.database.session_scope() as session:
            return session.scalar(select(TrialLease.owner).where(TrialLease.trial_id == trial_id))

    def holder(self, trial_id: int, now: float) -> str | None:
        """The process holding the trial's lease now, if any."""
        with self.database.session_scope() as session:
            return session.scalar(
                select(TrialLease.owner).where(
                    TrialLease.trial_id == trial_id,
                    TrialLease.expires_epoch >= self._now(session, now),
                )
            )

    def runs_out_unrenewed(self, trial_id: int, now: float) -> float | None:
        """Seconds until another process's lease of the trial runs out, when its holder has
        missed `MISSED_RENEWALS` renewals in a row (it is stopped, cut off from the
        database, or dead); None while the holder renews, or without the database's clock.

        A healthy holder renews every `renew_every_s`, so its lease always has more
        than `lease_s - renew_every_s` left; one with less than `lease_s -
        MISSED_RENEWALS * renew_every_s` left has gone quiet. A process asked for
        the trial (its participant's stream, sent on by the proxy) waits out those
        last seconds and claims it, instead of answering 503 and having the page
        come back through the silent process once more.
        """
        if not self._wall_clock:
            return None  # a test's manual clock does not move while this one waits
        with self.database.session_scope() as session:
            left = session.scalar(
                select(TrialLease.expires_epoch - self._now(session, now)).where(
                    TrialLease.trial_id == trial_id, TrialLease.owner != self.owner
                )
            )
        quiet_below = self.lease_s - MISSED_RENEWALS * self.renew_every_s
        return float(left) if left is not None and 0 <= left <= quiet_below else None

    def unhosted(self, trial_ids: Iterable[int], now: float) -> list[int]:
        """Of these running trials, those nobody hosts: their lease ran out, or they have none.

        A trial without a lease row is left alone for `UNCLAIMED_GRACE_S` after
        its start: the process whose participant started it claims it with
        the participant's first request, and a runner elsewhere must not take
        it first (every request of the participant would then take a detour
        through nginx's next upstream). After that it is taken anyway, so a
        trial nobody opens still ends on time.
        """
        wanted = list(trial_ids)
        if not wanted:
            return []
        with self.database.session_scope() as session:
            rows = session.execute(
                select(Trial.id, Trial.started_at, TrialLease.expires_epoch)
                .outerjoin(TrialLease, TrialLease.trial_id == Trial.id)
                .where(Trial.id.in_(wanted))
                .where(
                    or_(
                        TrialLease.expires_epoch < self._now(session, now),
                        TrialLease.trial_id.is_(None),
                    )
                )
            )
            return sorted(
                trial_id
                for trial_id, started_at, expires in rows
                if expires is not None or started_at.timestamp() <= now - UNCLAIMED_GRACE_S
            )


@dataclass
class Fence:
    """The lease a trial in memory was claimed with: what its writes must prove."""

    leases: Leases
    trial_id: int
    epoch: int
    #: The holder's monotonic instant after which it no longer counts the lease as held.
    deadline: float

    def holds(self) -> bool:
        """Whether the lease still counts as held by this process's own clock (no I/O)."""
        return self.leases.monotonic() < self.deadline

    def prove(self, session: Session, now: float) -> None:
        """`Leases.prove` in `session`, unless the holder's own deadline passed already."""
        if not self.holds():
            raise LeaseLost(self.trial_id)
        self.leases.prove(session, self.trial_id, self.epoch, now)


@contextmanager
def trial_transaction(database: Database, live: RunningTrial) -> Iterator[Session]:
    """A unit of work that writes for the trial: with leases it proves the lease first,
    in the same transaction, and rolls back with `LeaseLost` if it cannot."""
    with database.session_scope() as session:
        if live.fence is not None:
            live.fence.prove(session, database.clock())
        yield session
