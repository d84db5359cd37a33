"""The `recruitment` table: each online participant's recruitment-site ids.

Kept out of the wide participants table on purpose: these ids link a
participant code to an account on Prolific, SONA or MTurk, which is needed
to approve and pay people but must not travel with data that are shared.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.export.rows import iso
from hcss.platform.models import Participant, Recruitment


def recruitment_rows(session: Session) -> list[dict[str, Any]]:
    rows = session.execute(
        select(Recruitment, Participant.code)
        .join(Participant, Participant.id == Recruitment.participant_id)
        .order_by(Recruitment.id)
    )
    return [
        {
            "participant": code,
            "study": recruitment.study,
            "source": recruitment.source,
            "recruitment_id": recruitment.recruitment_id,
            "recruiter_study_id": recruitment.recruiter_study_id,
            "recruiter_session_id": recruitment.recruiter_session_id,
            "enrolled_at": iso(recruitment.created_at),
        }
        for recruitment, code in rows
    ]
