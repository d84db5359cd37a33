"""A per-client rate limit on enrolment through the public study link.

Anyone with the link can press Start, and each Start of a new visitor makes a
participant: one client made 4,500 in 73 s, and each counted in its cell.
`JOIN_PER_CLIENT` (count, seconds; ``HCSS_JOIN_PER_CLIENT=30/600``) bounds the
Starts one client may send in a sliding window; more answer 429 with
Retry-After and write nothing. The client is the proxy-corrected address
(``PROXY_HOPS``) counted by its prefix (`request_client`: an IPv6 /64, an IPv4
address or its /24 as ``HCSS_CLIENT_PREFIX_V4`` says). A lab whose
participants share one address raises the count.

The Starts are rows of the database (`JoinStart`, the prefix hashed with
the server's secret, kept for one window), counted in turn per client, so
the limit holds across `hcss serve --processes N`, several hosts and
restarts (before, each process kept its own windows in memory and N
processes let a client start N times the count). The row is written in the
request's transaction: a Start that fails writes no row, and a refused one
(429) rolls back, so it counts nothing either.

The limit composes with a study's recruitment cap (its file's `target`):
the view checks the cap first, so a Start on a full study gets the "study
full" page (no wait would help) and, like a returning participant's Start,
uses none of the allowance, since it creates no one.
"""

from __future__ import annotations

import hashlib
import hmac

from flask import Response, current_app
from flask.typing import ResponseReturnValue
from sqlalchemy import delete, func, select, text
from sqlalchemy.orm import Session

from hcss.platform.errors import error_page
from hcss.platform.guards.clients import request_client
from hcss.platform.models import JoinStart

#: Rows past the window deleted by one Start (bounded, so no Start pays for a backlog).
PRUNE = 100


def enrolment_refusal(session: Session) -> ResponseReturnValue | None:
    """Count one Start that would create a participant; the 429 answer past the limit, else None.

    The study link's view asks only once it knows the Start would create
    someone: a returning participant or a full study creates no one, so it
    uses none of the address's allowance and is never told to wait. The row
    counted is `session`'s, so it commits or rolls back with the Start.
    """
    limit = current_app.config.get("JOIN_PER_CLIENT")
    if not limit:
        return None
    wait_s = take_start(session, _client_key(), int(limit[0]), float(limit[1]))
    if wait_s <= 0:
        return None
    headers = {"Retry-After": str(max(1, round(wait_s)))}
    page = error_page(429)
    if isinstance(page, Response):  # plain text: the request named no host of ours
        page.headers.update(headers)
        return page
    return page[0], page[1], headers


def take_start(session: Session, client: str, count: int, seconds: float) -> float:
    """Count one Start of `client` in `session`; 0 when allowed, else the seconds until one is.

    The client's Starts are counted in turn on every process (`_one_client_at_a_time`),
    until the request's transaction ends. Up to `PRUNE` rows (any client's) a whole
    window old are deleted first, so no prefix's hash stays longer than it counts.
    """
    now = session.info["database"].clock()
    _one_client_at_a_time(session, client)
    aged = (
        select(JoinStart.id)
        .where(JoinStart.at_epoch <= now - seconds)
        .limit(PRUNE)
        .with_for_update(skip_locked=True)  # another Start's pruning: never wait for it
    )
    session.execute(delete(JoinStart).where(JoinStart.id.in_(aged)))
    recent = (
        select(JoinStart.at_epoch).where(JoinStart.client == client).order_by(JoinStart.at_epoch)
    )
    taken = int(session.scalar(select(func.count()).select_from(recent.subquery())) or 0)
    if taken >= count:
        # One place frees when the Start `taken - count` places from the oldest ages out.
        frees = session.scalars(recent.offset(taken - count).limit(1)).first()
        return max((frees if frees is not None else now) + seconds - now, 0.001)
    session.add(JoinStart(client=client, at_epoch=now))
    session.flush()
    return 0.0


def _one_client_at_a_time(session: Session, client: str) -> None:
    """PostgreSQL: a transaction-scoped advisory lock on the client. SQLite: a write that
    changes nothing takes the database's write lock before the count is read."""
    if session.get_bind().dialect.name == "postgresql":
        lock = int.from_bytes(hashlib.sha256(client.encode()).digest()[:8], "big", signed=True)
        session.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": lock})
    else:
        session.execute(text("UPDATE join_start SET client = client WHERE 0 = 1"))


def _client_key() -> str:
    """The client's prefix hashed with the server's secret: counted, never kept as an address."""
    secret = str(current_app.config["SECRET_KEY"]).encode()
    return hmac.new(secret, b"join:" + request_client().encode(), hashlib.sha256).hexdigest()
