"""Idempotency keys of the participant's commands: one row per command the page sent.

The Collective Interface sends a fresh key with every command (a request, a
click, a probe's Ready or answer). The first POST with a key is carried out
and its answer stored here; a repeat with the same key (a double click, a
retry after a dropped connection) gets that answer back and changes nothing.
The unique constraint on (trial, key) is what makes a second execution
impossible to store.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import ForeignKey, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt


class CommandKey(CreatedAt, Base):
    __tablename__ = "command_key"
    __table_args__ = (UniqueConstraint("trial_id", "key", name="uq_command_key_trial_id_key"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    key: Mapped[str] = mapped_column(String(64))
    # The route and a digest of the JSON body, so a key reused for another command is refused.
    endpoint: Mapped[str] = mapped_column(String(64))
    fingerprint: Mapped[str] = mapped_column(String(64))
    status: Mapped[int]  # the first answer's HTTP status
    response: Mapped[dict[str, Any]]  # and its JSON body
