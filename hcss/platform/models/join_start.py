"""The study link's Starts of the last window, counted per client by every server process."""

from __future__ import annotations

from sqlalchemy import Double, Index, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base


class JoinStart(Base):
    """One Start of the public study link that created (or screened out) a new visitor.

    ``client`` is the address prefix hashed with the server's secret (no address at
    rest); ``at_epoch`` the wall clock. Kept only for the limit's window: older rows
    are deleted as Starts come (hcss.platform.guards.ratelimit). In the database, not in a
    process, so `hcss serve --processes N` and a restart keep one count per client.
    """

    __tablename__ = "join_start"
    __table_args__ = (Index("ix_join_start_client_at", "client", "at_epoch"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    client: Mapped[str] = mapped_column(String(64))
    at_epoch: Mapped[float] = mapped_column(Double, index=True)
