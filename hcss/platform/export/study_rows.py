"""Per-participant rows: the wide participants table and the study-flow tables.

The study flow's answers, scores and stage events come from the study
engine's models; until they exist in this installation the tables are
written with their headers only, so the analysis still finds every file.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.console.sessions import session_state
from hcss.platform.export.tables import columns
from hcss.platform.models import Participant, Trial

Row = dict[str, Any]


def model_order(session: Session, participant: Participant) -> str:
    """Models in the order the participant met them in trials, e.g. ``M2,M1,M3``."""
    met: list[str] = []
    for model in session.scalars(
        select(Trial.model)
        .where(Trial.participant_id == participant.id, Trial.kind == "trial")
        .order_by(Trial.id)
    ):
        if model not in met:
            met.append(model)
    return ",".join(met)


def participant_row(session: Session, participant: Participant) -> Row:
    row: Row = dict.fromkeys(columns("participants"))
    state = session_state(session, participant.id)
    row.update(
        participant=participant.code,
        model_order=model_order(session, participant) or None,
        is_pilot=participant.is_pilot,
        is_bot=participant.is_bot,
        is_demo=participant.is_demo,
        status="aborted" if state == "aborted" else "in_progress",
    )
    return row


def participant_rows(session: Session, participants: list[Participant]) -> list[Row]:
    return [participant_row(session, p) for p in participants]


def study_flow_rows(session: Session, participants: list[Participant]) -> dict[str, list[Row]]:
    """questionnaire_items, scores and stage_timings rows."""
    return {"questionnaire_items": [], "scores": [], "stage_timings": []}
