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
hosts the trial; a lease expires on the clock both sides read, so the owner
knows when to stop (`lost`) before anyone else may start. Rows work on
SQLite too (the tests race takeovers there as well), need no connection per
process outside the pool, and are visible to the console. The price is the
failover delay (at most one lease length) and one UPDATE per renewal for
all of a process's trials.

Only processes started as part of a group (`hcss serve --processes N`, or
`--cluster`) lease; a lone server hosts every trial, as before.
"""

from __future__ import annotations

from collections.abc import Iterable

from sqlalchemy import delete, or_, select, update
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.orm import Session
from werkzeug.exceptions import ServiceUnavailable

from hcss.platform.db import Database
from hcss.platform.models import Trial, TrialLease

#: Seconds a lease lasts unless renewed; failover takes at most this long plus a sync.
LEASE_S = 6.0
#: Seconds a started trial that no process has claimed yet is left to the process whose
#: participant started it (its first request claims it) before any runner takes it.
UNCLAIMED_GRACE_S = 30.0
#: Renewals per lease length: a renewal may be late twice before the lease is at risk.
RENEWALS_PER_LEASE = 3


class HostedElsewhere(ServiceUnavailable):
    """The trial is hosted by another live process: try again (a proxy tries the next one)."""

    def __init__(self, trial_id: int, owner: str) -> None:
        super().__init__(f"trial {trial_id} is hosted by another server process", retry_after=1)
        self.trial_id = trial_id
        self.owner = owner


class Leases:
    """The leases of one process (`owner`), read and written by the database's clock."""

    def __init__(self, database: Database, owner: str, *, lease_s: float = LEASE_S) -> None:
        self.database = database
        self.owner = owner
        self.lease_s = lease_s

    @property
    def renew_every_s(self) -> float:
        return self.lease_s / RENEWALS_PER_LEASE

    def claim(self, trial_id: int, now: float) -> bool:
        """Take the trial's lease if nobody holds it, it ran out, or it is already ours.

        One transaction with two statements, each atomic on the row: an insert
        that does nothing when a row exists, and an update whose condition is
        checked again on the row as committed by any racing claimant
        (PostgreSQL re-reads a row it waited for; SQLite writes one at a time).
        So of two processes claiming one expired lease, exactly one wins.
        """
        expires = now + self.lease_s
        with self.database.session_scope() as session:
            dialect = session.get_bind().dialect.name
            insert = pg_insert if dialect == "postgresql" else sqlite_insert
            inserted = session.execute(
                insert(TrialLease)
                .values(trial_id=trial_id, owner=self.owner, expires_epoch=expires, taken_epoch=now)
                .on_conflict_do_nothing(index_elements=["trial_id"])
            )
            # An INSERT/UPDATE answers a CursorResult; Session.execute is typed as any Result.
            if inserted.rowcount == 1:  # type: ignore[attr-defined]
                return True
            taken = session.execute(
                update(TrialLease)
                .where(
                    TrialLease.trial_id == trial_id,
                    or_(TrialLease.owner == self.owner, TrialLease.expires_epoch < now),
                )
                .values(owner=self.owner, expires_epoch=expires, taken_epoch=now)
            )
            return taken.rowcount == 1  # type: ignore[attr-defined]  # a CursorResult, as above

    def renew(self, trial_ids: Iterable[int], now: float) -> set[int]:
        """Extend our leases of these trials in one statement; the ids still ours."""
        wanted = list(trial_ids)
        if not wanted:
            return set()
        with self.database.session_scope() as session:
            rows = session.execute(
                update(TrialLease)
                .where(
                    TrialLease.trial_id.in_(wanted),
                    TrialLease.owner == self.owner,
                    TrialLease.expires_epoch >= now,
                )
                .values(expires_epoch=now + self.lease_s)
                .returning(TrialLease.trial_id)
            )
            return {trial_id for (trial_id,) in rows}

    def pass_on(self, session: Session, trial_id: int, heir: str, now: float) -> None:
        """Give our lease of the trial to `heir`, in the caller's transaction."""
        session.execute(
            update(TrialLease)
            .where(TrialLease.trial_id == trial_id, TrialLease.owner == self.owner)
            .values(owner=heir, expires_epoch=now + self.lease_s, taken_epoch=now)
        )

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
                    TrialLease.trial_id == trial_id, TrialLease.expires_epoch >= now
                )
            )

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
                .where(or_(TrialLease.expires_epoch < now, TrialLease.trial_id.is_(None)))
            )
            return sorted(
                trial_id
                for trial_id, started_at, expires in rows
                if expires is not None or started_at.timestamp() <= now - UNCLAIMED_GRACE_S
            )
