"""Clicks on the map: the observation actions of the study."""

from __future__ import annotations

from sqlalchemy import ForeignKey, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt


class Observation(CreatedAt, Base):
    """One click on a hub or a target.

    Every click is logged when it happens. A left-click that filled the request
    form and was then committed is named in that `Command.selections`; the
    study's observation actions are the clicks no command names
    (see `hcss.platform.live.trial_log.observation_actions`).
    """

    __tablename__ = "observation"

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    kind: Mapped[str] = mapped_column(String(16))  # "collective" or "target"
    collective: Mapped[int | None]
    target: Mapped[int | None]
    button: Mapped[str] = mapped_column(String(8))  # "left" or "right"
    step: Mapped[int]
    sim_time: Mapped[float]
