"""The group's members as the database knows them: who serves at each address, since when,
and whether it is alive (it said so within a lease).

Each process of a group says it is alive in the transaction that renews its
leases (`Leases.renew_and_look_home`), a few times per lease length, whether
it holds trials or not. So a member stops counting as live at the moment its
leases run out, by the same clock (the database's), and placement
(hcss.platform.live.placement) agrees with the leases about who may claim.
"""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy import select, update
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.orm import Session

from hcss.platform.models import GroupMember


@dataclass(frozen=True)
class Member:
    """A live member: the process serving at its address, and when it started there."""

    process: str
    started_epoch: float


def say_alive(session: Session, address: str, process: str, now: float) -> None:
    """`process` serves at `address` and is alive at `now` (the database's clock); its
    first word there (a start, or a restart on the same address) sets `started_epoch`."""
    seen = session.execute(
        update(GroupMember)
        .where(GroupMember.address == address, GroupMember.process == process)
        .values(seen_epoch=now)
        .returning(GroupMember.address)
        .execution_options(synchronize_session=False)
    ).first()
    if seen is not None:
        return
    insert = pg_insert if session.get_bind().dialect.name == "postgresql" else sqlite_insert
    values = {"address": address, "process": process, "started_epoch": now, "seen_epoch": now}
    session.execute(
        insert(GroupMember)
        .values(**values)
        .on_conflict_do_update(index_elements=["address"], set_=values)
    )


def live_members(session: Session, now: float, lease_s: float) -> dict[str, Member]:
    """The members that said they are alive within a lease of `now`, by address."""
    rows = session.execute(
        select(GroupMember.address, GroupMember.process, GroupMember.started_epoch).where(
            GroupMember.seen_epoch >= now - lease_s
        )
    )
    return {address: Member(process, started) for address, process, started in rows}
