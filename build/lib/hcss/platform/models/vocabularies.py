"""The closed vocabularies of the schema: one `StrEnum` each, enforced by a CHECK constraint.

The values are what the rows store (a `StrEnum` member compares equal to its
string), so the code names `TrialStatus.RUNNING` instead of writing "running",
and the database refuses a row whose value is not in the vocabulary
(migration 0005_a10_vocabularies; `create_all` builds the same constraints).
"""

from __future__ import annotations

from enum import StrEnum

from sqlalchemy import CheckConstraint


class TrialKind(StrEnum):
    TRAINING = "training"
    TRIAL = "trial"


class TrialStatus(StrEnum):
    RUNNING = "running"
    ENDED = "ended"


class RequestStatus(StrEnum):
    """An accepted request in the Collective Assignments list (hcss.simulation.requests)."""

    IN_PROGRESS = "in_progress"
    COMPLETED = "completed"
    REMOVED = "removed"  # left the list: its decision ended or the abandon was cancelled


def check_in(column: str, vocabulary: type[StrEnum], name: str) -> CheckConstraint:
    """CHECK (column IN (...)) over every value of `vocabulary`."""
    values = ", ".join(f"'{member.value}'" for member in vocabulary)
    return CheckConstraint(f"{column} IN ({values})", name=name)
