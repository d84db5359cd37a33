"""Where a trial lives: one placement that nginx and every process of the group compute alike.

nginx sends each participant's requests by `hash $hcss_token` over the
group's members, in the order `hcss deploy nginx` lists them (HCSS_GROUP).
That hash is the one of Cache::Memcached: ``(crc32([REHASH] KEY) >> 16) &
0x7fff`` added to the previous value, modulo the number of members; a
member that refuses the connection (down) or was tried already is passed
over by hashing again with the attempt's number in front of the key. So for
each token there is a fixed order of members (`nginx_order`), and nginx
sends the request to the first one that answers.

`home` is the first *live* member in that order: the member nginx sends the
participant to while the others are up or down as the group's heartbeats
say (`live_members`, below). Every process computes it the same way,
so a runner claims a never-opened trial only where its participant will
arrive, and a trial another process took over while its home was down goes
home once, when its home is back (hcss.platform.live.leases).

Why nginx's plain hash and not its `consistent` ring: the ring's 160 points
per member split tokens 54-59 % onto one of two members (measured, issue
41), so two processes held 1.7 times what one does at best; the plain
hash's remainder splits within a percent (tests/platform/test_placement.py).
It moves more tokens when a member leaves the configuration for good, which
only a new configuration does (nginx reloads with the new list; the
processes with the new HCSS_GROUP).

After 20 passed-over members nginx gives up hashing and goes round-robin;
with the few members of a group it never does in practice (`nginx_order`
then stops, and the members not reached are appended in their own order).

Who is alive: the group's members as the database knows them, who serves at
each address, since when, and whether it said so within a lease. Each process
of a group says it is alive (`say_alive`) in the transaction that renews its
leases (`Leases.renew_and_look_home`), a few times per lease length, whether
it holds trials or not. So a member stops counting as live at the moment its
leases run out, by the same clock (the database's), and the placement agrees
with the leases about who may claim.
"""

from __future__ import annotations

import zlib
from collections.abc import Collection, Sequence
from dataclasses import dataclass

from sqlalchemy import select, update
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.orm import Session

from hcss.platform.models import GroupMember

#: Members nginx passes over before it stops hashing (ngx_http_upstream_hash_module).
NGINX_HASH_TRIES = 20


def nginx_order(key: str, members: Sequence[str]) -> list[str]:
    """The members in the order nginx's `hash $key` tries them for `key`."""
    if len(members) < 2 or not key:
        return list(members)  # nginx does not hash for one member or an empty key
    order: list[str] = []
    total = 0
    rehash = 0
    passed_over = 0
    encoded = key.encode()
    while len(order) < len(members):
        prefix = str(rehash).encode() if rehash > 0 else b""
        total += (zlib.crc32(prefix + encoded) >> 16) & 0x7FFF
        rehash += 1
        member = members[total % len(members)]
        if member in order:
            passed_over += 1
            if passed_over > NGINX_HASH_TRIES:
                break
            continue
        order.append(member)
    return order + [m for m in members if m not in order]


def home(key: str, members: Sequence[str], live: Collection[str]) -> str | None:
    """The first member in nginx's order for `key` that is live; None if none is."""
    for member in nginx_order(key, members):
        if member in live:
            return member
    return None


def address_of(process: str) -> str:
    """The address ("host:port") in a process's lease name ("host:port/start")."""
    return process.split("/", 1)[0]


# --- who is alive ---------------------------------------------------------------------------


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
