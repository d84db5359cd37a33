"""How many participant links one experimenter account may create in a window.

A console account, or a session stolen from one, could otherwise make
participants without bound: each is a working link, a row of the live table
and of every export. `LINKS_PER_EXPERIMENTER` (count, seconds;
``HCSS_LINKS_PER_EXPERIMENTER=500/3600``, ``0`` for none) bounds the links
an account creates in any such window; a batch that would pass it is refused
whole (429), creates nothing, and is written to the audit log.

The count is read from the `create` rows of `ConsoleAction`, so it holds
across restarts and server processes without a store of its own. The count
and the batch's inserts are one step per account (`_one_batch_at_a_time`):
20 batches of 50 sent at once against a limit of 500 create exactly 500
(before, every batch counted the same rows and all 1,000 were created).
"""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy import func, select, text
from sqlalchemy.orm import Session

from hcss.platform.models import AuditRecord, ConsoleAction, Experimenter

AUDIT_ACTION = "link_limit"
#: First key of the link limit's PostgreSQL advisory locks ("LINK" in ASCII); the second
#: is the account's id.
LOCK_SPACE = 0x4C494E4B


@dataclass(frozen=True)
class LinkLimitReached(Exception):
    """A batch the account's allowance cannot take; nothing was created."""

    requested: int
    created: int
    limit: tuple[int, float]
    retry_after_s: int

    @property
    def message(self) -> str:
        count, seconds = self.limit
        left = max(0, count - self.created)
        rule = (
            f"Not created: an account may create {count} participant links per {_window(seconds)}"
        )
        if self.requested > count:
            when = f"ask for at most {count} at once"
        else:
            more = f"{left} more" if left else "no more"
            when = (
                f"this one has created {self.created} in that time ({more} now, "
                f"{self.requested} asked); try again in {_wait(self.retry_after_s)}"
            )
        return f"{rule}: {when}, or ask the administrator to raise HCSS_LINKS_PER_EXPERIMENTER."


def require_allowance(
    session: Session,
    experimenter: Experimenter,
    requested: int,
    now: float,
    limit: tuple[int, float] | None,
) -> None:
    """Raise `LinkLimitReached` (after auditing it in `session`) if the batch would pass the limit."""
    if not limit:
        return
    _one_batch_at_a_time(session, experimenter)
    count, seconds = limit
    since = now - seconds
    created = (
        select(ConsoleAction.at_epoch)
        .where(
            ConsoleAction.experimenter_id == experimenter.id,
            ConsoleAction.action == "create",
            ConsoleAction.at_epoch > since,
        )
        .order_by(ConsoleAction.at_epoch)
    )
    made = int(session.scalar(select(func.count()).select_from(created.subquery())) or 0)
    if made + requested <= count:
        return
    # The window frees one link per row as the oldest age out; wait until enough have.
    must_free = made + requested - count
    oldest = session.scalars(created.offset(must_free - 1).limit(1)).first()
    wait_s = max(1, round((oldest if oldest is not None else now) + seconds - now))
    session.add(
        AuditRecord(
            action=AUDIT_ACTION,
            experimenter=experimenter.username,
            participant_code=None,
            row_counts={"requested": requested, "created_in_window": made},
        )
    )
    raise LinkLimitReached(requested, made, (count, seconds), wait_s)


def _one_batch_at_a_time(session: Session, experimenter: Experimenter) -> None:
    """The account's batches are counted and created in turn, until the request commits.

    PostgreSQL: a transaction-scoped advisory lock on the account (the other
    accounts do not wait). SQLite: a write that changes nothing takes the
    database's write lock before the count is read (as sign-in's lockout does).
    """
    dialect = session.get_bind().dialect.name
    if dialect == "postgresql":
        session.execute(
            text("SELECT pg_advisory_xact_lock(:space, :account)"),
            {"space": LOCK_SPACE, "account": experimenter.id},
        )
    elif dialect == "sqlite":
        session.execute(text("UPDATE console_action SET action = action WHERE 0 = 1"))


def _wait(seconds: int) -> str:
    return f"{seconds} s" if seconds < 120 else f"{round(seconds / 60)} min"


def _window(seconds: float) -> str:
    """3600 -> "hour", 60 -> "minute", 90 -> "90 s", 7200 -> "2 hours"."""
    for size, unit in ((86400, "day"), (3600, "hour"), (60, "minute")):
        if seconds == size:
            return unit
        if seconds > size and seconds % size == 0:
            return f"{int(seconds // size)} {unit}s"
    return f"{round(seconds)} s"
