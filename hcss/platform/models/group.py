"""Which study files the processes of a group serve: one digest per study, heartbeat-dated.

Every process of a group (`hcss serve --cluster`) must serve the same study
files, since `/join` goes to any of them and each enrolment keeps its file's
digest. A process records the digest of each study it can load at start and
says it is alive every few seconds (`seen_epoch`); a process starting with a
different file for a study that a live member serves refuses to serve
(`hcss.platform.serving.workers.require_same_studies`). Like the lease, a mutable
record of the group, not of the study: not append-only, not exported.
"""

from __future__ import annotations

from sqlalchemy import Double, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base


class GroupStudy(Base):
    __tablename__ = "group_study"

    study: Mapped[str] = mapped_column(String(64), primary_key=True)
    digest: Mapped[str] = mapped_column(String(64))  # sha256 of the study file
    #: The process that last recorded this digest ("host:port/start").
    process: Mapped[str] = mapped_column(String(128))
    #: When a process serving this digest last said it is alive (epoch seconds).
    seen_epoch: Mapped[float] = mapped_column(Double)
