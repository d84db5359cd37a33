"""Which server process hosts a live trial, and until when.

With several processes on one PostgreSQL database a trial must live in
exactly one of them: the one holding its lease. The row is the one mutable
record of the live wing (ownership changes hands, it is not a fact of the
study), so it is not append-only and not exported. Times are epoch seconds
of PostgreSQL's clock (`clock_timestamp()`) in a server, so the hosts'
clocks never meet; on SQLite and under a test's `ManualClock`, of the
process clock (`Database.clock`).
"""

from __future__ import annotations

from sqlalchemy import Double, Integer, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base


class TrialLease(Base):
    __tablename__ = "trial_lease"

    #: No foreign key: a withdrawal deletes the trial, and a leftover lease of a
    #: trial that is not running is never read.
    trial_id: Mapped[int] = mapped_column(primary_key=True, autoincrement=False)
    #: The process ("host:port/start"), unique per start, see `hcss.platform.live.leases`.
    owner: Mapped[str] = mapped_column(String(128))
    #: Raised by every claim: the fencing token a holder proves in each transaction that
    #: writes for the trial, so a holder that lost the lease (a stall, a partition) and
    #: took it back later still cannot write with what it held before.
    epoch: Mapped[int] = mapped_column(Integer, default=1, server_default="1")
    expires_epoch: Mapped[float] = mapped_column(Double)
    taken_epoch: Mapped[float] = mapped_column(Double)
    #: Unused since placement (hcss.platform.live.placement) decides where a trial goes
    #: home: the hand-back request of i29, kept so an older version running beside this
    #: one during a rolling upgrade still finds its columns.
    wanted_by: Mapped[str | None] = mapped_column(String(128), nullable=True)
    #: When `wanted_by` last asked (the database's clock): an ask older than a lease is void.
    wanted_epoch: Mapped[float | None] = mapped_column(Double, nullable=True)


class GroupMember(Base):
    """A process of the group, by the address nginx knows it under: who serves there now,
    since when, and when it last said it is alive (with its lease renewals).

    Placement (hcss.platform.live.placement) reads it: a trial's home is the first live
    member in nginx's order for the participant's token, and a trial goes home from
    another process only once, after its home (re)started. Not append-only (a heartbeat).
    """

    __tablename__ = "group_member"

    #: "host:port", as in nginx's upstream (`hcss deploy nginx`, HCSS_GROUP).
    address: Mapped[str] = mapped_column(String(128), primary_key=True)
    #: The process serving there now (`process_name`, new at every start).
    process: Mapped[str] = mapped_column(String(128))
    #: When that process first said it is alive (the database's clock).
    started_epoch: Mapped[float] = mapped_column(Double)
    #: When it last did; a member unseen for a lease is gone.
    seen_epoch: Mapped[float] = mapped_column(Double)
