"""The experimenter's side: accounts, what they did to a session, and deletions.

`ConsoleAction` rows are the append-only record of every pause, resume,
abort and pilot marking; a participant's state in the console is read from
the latest of them, never from a flag overwritten in place. `AuditRecord`
survives a withdrawal on purpose: it names the deleted participant only by
code and keeps the row counts, so the deletion itself can be proven later
without keeping anything personal.
"""

from __future__ import annotations

from typing import Any

from flask_login import UserMixin
from sqlalchemy import Double, ForeignKey, Index, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt

#: What an experimenter can do to a participant's session.
CONSOLE_ACTIONS = (
    "create",
    "pause",
    "resume",
    "abort",
    "mark_pilot",
    "unmark_pilot",
    "cell_override",
    "skip_stage",
    "time_out",  # written by the server (hcss.platform.study.timeouts), no experimenter
)


class Experimenter(UserMixin, CreatedAt, Base):
    """A console account; the password is stored only as an argon2 hash."""

    __tablename__ = "experimenter"

    id: Mapped[int] = mapped_column(primary_key=True)
    username: Mapped[str] = mapped_column(String(64), unique=True)
    password_hash: Mapped[str] = mapped_column(String(256))
    # Moves on at every sign-out; cookies of older generations stop working
    # (hcss.platform.console.login_sessions).
    login_generation: Mapped[int] = mapped_column(default=0)
    # The second factor (hcss.platform.console.second_factor), None until enrolled: the
    # TOTP secret (base32), the last time step a code was taken for (a code is used
    # once), and the argon2 hashes of the recovery codes not yet used.
    totp_secret: Mapped[str | None] = mapped_column(String(64), default=None)
    totp_last_step: Mapped[int | None] = mapped_column(default=None)
    recovery_hashes: Mapped[list[Any] | None] = mapped_column(default=None)

    def get_id(self) -> str:
        """What Flask-Login puts in the session cookie: the account and its generation."""
        return f"{self.id}.{self.login_generation}"

    def __repr__(self) -> str:
        return f"Experimenter({self.username!r})"


class ConsoleAction(CreatedAt, Base):
    """One thing an experimenter did to a participant's session.

    ``at_epoch`` is the live runner's clock when the action took effect (the
    wall clock in a server, a fake one in tests): a trial rebuilt after a
    restart subtracts its paused intervals from exactly these instants.
    ``trial_id`` names the trial a pause, resume or abort stopped or freed.
    """

    __tablename__ = "console_action"

    id: Mapped[int] = mapped_column(primary_key=True)
    participant_id: Mapped[int] = mapped_column(ForeignKey("participant.id"), index=True)
    experimenter_id: Mapped[int | None] = mapped_column(ForeignKey("experimenter.id"))
    action: Mapped[str] = mapped_column(String(16))
    trial_id: Mapped[int | None] = mapped_column(ForeignKey("trial.id"), index=True)
    at_epoch: Mapped[float]
    detail: Mapped[str] = mapped_column(String(200), default="")


class ConsoleForm(CreatedAt, Base):
    """A Create form of the console, once carried out: its key and the batch it made.

    The page sends a fresh random key with each Create (a hidden field); the first POST
    with a key makes the batch and this row, and a repeat (a double click that got past
    the page, a resend, a proxy's retry) is answered with that batch and makes nothing.
    The unique key is what makes a second batch impossible to store, even when the two
    requests arrive together. ``batch`` names the batch as its create actions do (its
    first participant's code).
    """

    __tablename__ = "console_form"

    id: Mapped[int] = mapped_column(primary_key=True)
    key: Mapped[str] = mapped_column(String(64), unique=True)
    experimenter_id: Mapped[int | None] = mapped_column(ForeignKey("experimenter.id"))
    batch: Mapped[str] = mapped_column(String(32))


class AuditRecord(CreatedAt, Base):
    """A withdrawal or an export: who, when, which participant code, how many rows.

    Deliberately no foreign key to the participant (the row must outlive
    them) and no personal data: the code is the study's pseudonym.
    """

    __tablename__ = "audit_record"

    id: Mapped[int] = mapped_column(primary_key=True)
    action: Mapped[str] = mapped_column(String(16))  # "withdrawal" or "export"
    experimenter: Mapped[str] = mapped_column(String(64))  # username, or "cli"
    participant_code: Mapped[str | None] = mapped_column(String(32))
    row_counts: Mapped[dict[str, Any]]


class LoginFailure(CreatedAt, Base):
    """A console sign-in counted as failed, against one (username, client) pair.

    ``scope`` is "client" and ``key`` the pair (the address hashed, then the
    name; hcss.platform.console.lockout). The failure that reaches the limit
    carries ``locked_until``: while it lies ahead, that name may not sign in
    from that client. The rows are in the database, not in a process, so a
    restart or a second server process keeps the count and the lockout. Not
    append-only: a correct password deletes its pair's rows, ``hcss admin
    unlock`` an account's, and rows past the window and any lockout are pruned.
    """

    __tablename__ = "login_failure"
    __table_args__ = (Index("ix_login_failure_scope_key_at", "scope", "key", "at_epoch"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    scope: Mapped[str] = mapped_column(String(8))  # "client"
    key: Mapped[str] = mapped_column(String(64))  # address hash ":" username (lower case)
    at_epoch: Mapped[float] = mapped_column(Double)  # the throttle's clock, seconds since 1970
    locked_until: Mapped[float | None] = mapped_column(Double)
