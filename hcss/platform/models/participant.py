"""A participant: a code for the data and an unguessable token for the link."""

from __future__ import annotations

import secrets

from sqlalchemy import String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt


def new_token() -> str:
    """The secret in a participant's personal link (no account, so this is the key)."""
    return secrets.token_urlsafe(24)


def new_code(prefix: str = "P") -> str:
    """A short code that names the participant in exports and never a person.

    48 random bits: a study of 100,000 participants draws a repeat (refused by the unique
    code, failing the request that drew it) with chance 2e-5; 32 bits gave 0.69, and a
    batch of 5,000 links 0.003 (tests/platform/test_participant_codes.py)."""
    return f"{prefix}{secrets.token_hex(6).upper()}"


class Participant(CreatedAt, Base):
    __tablename__ = "participant"

    id: Mapped[int] = mapped_column(primary_key=True)
    code: Mapped[str] = mapped_column(String(32), unique=True, default=new_code)
    token: Mapped[str] = mapped_column(String(64), unique=True, index=True, default=new_token)
    is_demo: Mapped[bool] = mapped_column(default=False)
    is_pilot: Mapped[bool] = mapped_column(default=False)
    is_bot: Mapped[bool] = mapped_column(default=False)
    #: The study file chosen when the experimenter created the participant; None means
    #: the server's default. The enrolment (first visit) uses it; it is never changed.
    study: Mapped[str | None] = mapped_column(String(64), default=None)

    def __repr__(self) -> str:
        return f"Participant({self.code!r})"
