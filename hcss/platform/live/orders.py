"""Console actions for trials hosted by another process: the `TrialOrder` mailbox.

Why polling and not PostgreSQL LISTEN/NOTIFY: the host's runner already
wakes every 50 ms, and one indexed query for the pending orders of its
trials every `POLL_S` keeps the delay well inside the console's 2 s without
a dedicated listening connection per process, a reconnect-and-catch-up path
for notifications lost while it was down (the table must be read then
anyway), or a second code path for SQLite. The measured cost is in
docs/operations.md.
"""

from __future__ import annotations

import time as wallclock
from collections.abc import Iterable
from dataclasses import dataclass

from sqlalchemy import select, update
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.models import Trial, TrialOrder

#: Not a console action: "stop hosting the trial and pass its lease to the order's issuer",
#: which a withdrawal asks of the host before it deletes the trial's rows.
HAND_OVER = "hand_over"
#: How often a host looks for orders (wall seconds).
POLL_S = 0.25
#: How long the console waits for the host to confirm an order.
CONFIRM_S = 3.0


@dataclass(frozen=True)
class PendingOrder:
    id: int
    trial_id: int
    participant_id: int
    experimenter_id: int | None
    action: str
    issued_by: str


def send_order(
    database: Database,
    trial_id: int,
    action: str,
    *,
    experimenter_id: int | None,
    issued_by: str,
    confirm_s: float = CONFIRM_S,
) -> str | None:
    """Write the order and wait for its host to carry it out: its outcome, or None if not yet."""
    with database.session_scope() as session:
        order = TrialOrder(
            trial_id=trial_id, experimenter_id=experimenter_id, action=action, issued_by=issued_by
        )
        session.add(order)
        session.flush()
        order_id = order.id
    deadline = wallclock.monotonic() + confirm_s
    while True:
        with database.session_scope() as session:
            done = session.execute(
                select(TrialOrder.done_epoch, TrialOrder.outcome).where(TrialOrder.id == order_id)
            ).one()
        if done.done_epoch is not None:
            return done.outcome
        if wallclock.monotonic() >= deadline:
            return None
        wallclock.sleep(0.05)


def mark_done(session: Session, order_id: int, now: float, outcome: str) -> None:
    """The order is carried out (`outcome`), in the transaction that carried it out."""
    session.execute(
        update(TrialOrder).where(TrialOrder.id == order_id).values(done_epoch=now, outcome=outcome)
    )


def pending_orders(database: Database, trial_ids: Iterable[int]) -> list[PendingOrder]:
    """Orders not yet carried out for these trials, oldest first."""
    wanted = list(trial_ids)
    if not wanted:
        return []
    with database.session_scope() as session:
        rows = session.execute(
            select(
                TrialOrder.id,
                TrialOrder.trial_id,
                Trial.participant_id,
                TrialOrder.experimenter_id,
                TrialOrder.action,
                TrialOrder.issued_by,
            )
            .join(Trial, Trial.id == TrialOrder.trial_id)
            .where(TrialOrder.done_epoch.is_(None), TrialOrder.trial_id.in_(wanted))
            .order_by(TrialOrder.id)
        )
        return [PendingOrder(*row) for row in rows]
