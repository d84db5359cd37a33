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

Placement. nginx sends each participant to one member of the group, and
every process computes the same member (`home`, hcss.platform.live.placement)
from the participant's token and the members alive (hcss.platform.live.placement).
So trials never move while their holder is alive:

- a runner's sync claims a trial nobody holds only if this process is the
  trial's home (`to_take`): a never-opened trial is held where its
  participant's first request arrives;
- a request for a trial another live process holds is not a reason to take
  it: the process forwards the request to the holder (hcss.platform.live.
  forwarding; nginx re-sends it to the holder's address), whether nginx sent
  it here first or passed it on after a busy 503 or a timeout of the holder;
- a trial another process took over while its home was down goes home once,
  when the home (re)started after that takeover: the holder sees it at a
  renewal (`renew_and_look_home`) and hands it over at a safe point
  (hcss.platform.live.hand_back); the home's next sync rebuilds it. With both
  alive and the home not restarted since, nothing moves.

Without a group list (HCSS_GROUP, written by `hcss serve --processes` for its
workers) there is no placement: any process claims a trial nobody has opened
after `UNCLAIMED_GRACE_S`, and a request for a trial held elsewhere is
answered 503 (nginx passes it on).

Only processes started as part of a group (`hcss serve --processes N`, or
`--cluster`) lease; a lone server hosts every trial, as before.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from sqlalchemy import Double, and_, cast, delete, func, literal, or_, select, update
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.orm import Session
from sqlalchemy.sql.elements import ColumnElement
from werkzeug.exceptions import ServiceUnavailable

from hcss.platform.db import Database
from hcss.platform.live.placement import address_of, home, live_members, say_alive
from hcss.platform.models import Participant, Trial, TrialLease

#: Seconds a lease lasts unless renewed; failover takes at most this long plus a sync.
LEASE_S = 6.0
#: Seconds a started trial that no process has claimed yet is left to the process whose
#: participant started it (its first request claims it) before any runner takes it.
UNCLAIMED_GRACE_S = 30.0
#: Renewals per lease length: a renewal may be late twice before the lease is at risk.
RENEWALS_PER_LEASE = 3
#: Renewals a holder has missed in a row when a process that gets a request for its trial stops
#: forwarding to it and waits out its lease instead (`Leases.runs_out_unrenewed`): a crash.
MISSED_RENEWALS = 2
#: Seconds before its lease runs out (by its own monotonic clock) that a holder stops writing:
#: room for a transaction begun just before the deadline and for clock rate differences.
STOP_MARGIN_S = 1.0


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

    def __init__(
        self,
        database: Database,
        owner: str,
        *,
        lease_s: float = LEASE_S,
        members: Sequence[str] = (),
    ) -> None:
        self.database = database
        self.owner = owner
        self.lease_s = lease_s
        #: The group's members in nginx's upstream order (HCSS_GROUP); empty: no placement.
        self.members = list(members)
        #: This process's address among them.
        self.address = address_of(owner)
        #: Whether claims follow the placement (this process is one of the listed members).
        self.placed = self.address in self.members

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
            inserted = session.scalar(
                insert(TrialLease)
                .values(
                    trial_id=trial_id,
                    owner=self.owner,
                    epoch=1,
                    expires_epoch=db_now + self.lease_s,
                    taken_epoch=db_now,
                )
                .on_conflict_do_nothing(index_elements=["trial_id"])
                # The row it inserted, if any: psycopg's rowcount here is not the rows
                # inserted, so a new lease on PostgreSQL began at epoch 2 (a second claim).
                .returning(TrialLease.epoch)
            )
            if inserted is not None:
                return int(inserted)
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
        return self.renew_and_look_home(held, now)[0]

    def renew_and_look_home(
        self, held: dict[int, int], now: float
    ) -> tuple[set[int], dict[int, str]]:
        """`renew`, and in the same transaction: say this process is alive, and find the
        trials held here whose home is back (`_homes_back`): id -> the home's process."""
        with self.database.session_scope() as session:
            db_now = self._db_now(session, now)
            if self.placed:
                say_alive(session, self.address, self.owner, db_now)
            if not held:
                return set(), {}
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
            return kept, self._homes_back(session, kept, db_now)

    def _db_now(self, session: Session, now: float) -> float:
        """`_now` read once, for comparisons made here rather than in a statement."""
        if self._wall_clock and session.get_bind().dialect.name == "postgresql":
            read = session.scalar(select(self._now(session, now)))
            return now if read is None else float(read)
        return now

    def _homes_back(self, session: Session, held: set[int], db_now: float) -> dict[int, str]:
        """Of the trials held here, those whose home is another live member that started
        after this process took the trial (it was down then): id -> the home's process.

        Only a restart sends a trial home, so each takeover is undone at most once, and a
        trial that was claimed here while its home was alive (the home timed out on a
        request, or the console withdrew it) stays.
        """
        if not self.placed or not held:
            return {}
        live = live_members(session, db_now, self.lease_s)
        alive = set(live) | {self.address}
        rows = session.execute(
            select(TrialLease.trial_id, TrialLease.taken_epoch, Participant.token)
            .join(Trial, Trial.id == TrialLease.trial_id)
            .join(Participant, Participant.id == Trial.participant_id)
            .where(TrialLease.trial_id.in_(held))
        )
        back = {}
        for trial_id, taken, token in rows:
            there = home(token, self.members, alive)
            if there is None or there == self.address:
                continue
            if live[there].started_epoch > taken:
                back[trial_id] = live[there].process
        return back

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

    def send_home(self, session: Session, trial_id: int, heir: str, now: float) -> bool:
        """Pass our lease of the trial to its home's process `heir`, in the caller's
        transaction (which proved it); False if it is no longer ours.

        The lease goes to the home itself, not to whoever claims first: the home's next
        sync (or its participant's next request) claims it (a claim of its own lease)
        and rebuilds it. The epoch rises, so nothing this process still holds can write.
        """
        db_now = self._now(session, now)
        handed = session.execute(
            update(TrialLease)
            .where(TrialLease.trial_id == trial_id, TrialLease.owner == self.owner)
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

    def home_elsewhere(self, trial_id: int, now: float) -> str | None:
        """The process of the trial's home when nobody holds the trial and its home is
        another live member (it is to be claimed there, not here); else None."""
        if not self.placed:
            return None
        with self.database.session_scope() as session:
            db_now = self._db_now(session, now)
            row = session.execute(
                select(Participant.token, TrialLease.expires_epoch)
                .select_from(Trial)
                .join(Participant, Participant.id == Trial.participant_id)
                .outerjoin(TrialLease, TrialLease.trial_id == Trial.id)
                .where(Trial.id == trial_id)
            ).first()
            if row is None or (row.expires_epoch is not None and row.expires_epoch >= db_now):
                return None  # held (by us or another): the claim decides
            live = live_members(session, db_now, self.lease_s)
        there = home(row.token, self.members, set(live) | {self.address})
        if there is None or there == self.address:
            return None
        return live[there].process

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
        MISSED_RENEWALS * renew_every_s` left has gone quiet. A process that gets a
        request for the trial (its participant's stream, sent on by the proxy) waits
        out those last seconds and claims it, a takeover after a crash, instead of
        forwarding the request to the silent process once more.
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

    def to_take(self, trial_ids: Iterable[int], now: float) -> list[int]:
        """Of these running trials (not in memory here), those this process is to host now.

        A trial handed to this process (its lease names us) is taken. A trial nobody
        holds (no lease, or it ran out) is taken by its home only (`placed`): the
        member nginx sends its participant to among those alive. Without placement, a
        trial without a lease row is left for `UNCLAIMED_GRACE_S` after its start to the
        process whose participant started it, then taken by any process, so a trial
        nobody opens still ends on time.
        """
        wanted = list(trial_ids)
        if not wanted:
            return []
        with self.database.session_scope() as session:
            db_now = self._db_now(session, now)
            rows = session.execute(
                select(
                    Trial.id,
                    Trial.started_at,
                    Participant.token,
                    TrialLease.owner,
                    TrialLease.expires_epoch,
                )
                .join(Participant, Participant.id == Trial.participant_id)
                .outerjoin(TrialLease, TrialLease.trial_id == Trial.id)
                .where(Trial.id.in_(wanted))
            ).all()
            live = live_members(session, db_now, self.lease_s) if self.placed else {}
        alive = set(live) | {self.address}
        taken = []
        for trial_id, started_at, token, owner, expires in rows:
            if expires is not None and expires >= db_now:
                if owner == self.owner:
                    taken.append(trial_id)  # handed here, not yet rebuilt
                continue
            if self.placed:
                if home(token, self.members, alive) == self.address:
                    taken.append(trial_id)
            elif expires is not None or started_at.timestamp() <= now - UNCLAIMED_GRACE_S:
                taken.append(trial_id)
        return sorted(taken)


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
