"""Situation-awareness probes (SPAM): the question asked and what happened to it.

A `Probe` row is written when the probe is shown, with its question, choices
and (for levels 1 and 2) the truth at that moment. Each later event, the
"ready" press, the answer, the time-out and the scoring, is a `ProbeEvent`;
the press and the answer carry their latency in wall-clock milliseconds.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import ForeignKey, Index, String
from sqlalchemy.orm import Mapped, mapped_column

from hcss.platform.models.base import Base, CreatedAt

PROBE_EVENT_KINDS = ("ready", "answer", "timeout", "scored")


class Probe(CreatedAt, Base):
    __tablename__ = "probe"
    # The trial's n-th probe is shown once (i29_unique_trial_rows).
    __table_args__ = (Index("uq_probe_trial", "trial_id", "probe_index", unique=True),)

    id: Mapped[int] = mapped_column(primary_key=True)
    trial_id: Mapped[int] = mapped_column(ForeignKey("trial.id"), index=True)
    probe_index: Mapped[int]  # 1-based within the trial
    level: Mapped[int]  # 1 perception, 2 comprehension, 3 projection
    question: Mapped[str] = mapped_column(String(200))
    choices: Mapped[list[Any]]  # answer strings, e.g. ["I", "II"] or ["3", "7"]
    truth: Mapped[str | None] = mapped_column(String(16))  # None until known (level 3)
    shown_step: Mapped[int]
    shown_sim_time: Mapped[float]
    timeout_sim_time: Mapped[float]  # unanswered by then: timed out


class ProbeEvent(CreatedAt, Base):
    __tablename__ = "probe_event"
    # A probe is readied, answered, timed out and scored at most once each (i29_unique_trial_rows).
    __table_args__ = (Index("uq_probe_event_probe", "probe_id", "kind", unique=True),)

    id: Mapped[int] = mapped_column(primary_key=True)
    probe_id: Mapped[int] = mapped_column(ForeignKey("probe.id"), index=True)
    kind: Mapped[str] = mapped_column(String(16))
    answer: Mapped[str | None] = mapped_column(String(16))
    truth: Mapped[str | None] = mapped_column(String(16))
    correct: Mapped[bool | None]
    step: Mapped[int]
    sim_time: Mapped[float]
    # Wall-clock milliseconds the participant took, measured on the server while the
    # trial clock ran (an experimenter's pause does not count): for "ready", from the
    # first delivery of the prompt to the press; for "answer", from the first delivery
    # of the question to the answer. None for other kinds, or when never delivered.
    latency_ms: Mapped[float | None]
