"""The `recruitment`, `return_visits` and `screen_outs` tables: recruitment-site ids of who
came, who came back and who was turned away.

Kept out of the wide participants table on purpose: these ids link a
participant code to an account on Prolific, SONA or MTurk, which is needed
to approve and pay people but must not travel with data that are shared.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.export.rows import iso
from hcss.platform.models import Participant, Recruitment, ReturnVisit, ScreenOut

#: A cell starting with one of these is run as a formula by Excel, LibreOffice and Sheets.
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
#: pandas' default missing-value strings (`read_csv`'s na_values) that an id may spell.
READ_AS_MISSING = frozenset(
    {"#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND", "1.#QNAN"}
    | {"<NA>", "N/A", "NA", "NULL", "NaN", "None", "n/a", "nan", "null"}
)


def exported_id(value: str | None) -> str | None:
    """An id as the export writes it: one leading apostrophe when a spreadsheet would
    run it as a formula or pandas would read it as missing; strip it to get the id back.

    The ids come from the recruitment link's query, chosen by whoever opens it.
    """
    if value is None:
        return None
    if value.startswith(FORMULA_STARTS) or value in READ_AS_MISSING or value.startswith("'"):
        return "'" + value
    return value


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
            "recruitment_id": exported_id(recruitment.recruitment_id),
            "recruiter_study_id": exported_id(recruitment.recruiter_study_id),
            "recruiter_session_id": exported_id(recruitment.recruiter_session_id),
            "enrolled_at": iso(recruitment.created_at),
        }
        for recruitment, code in rows
    ]


def return_visit_rows(session: Session) -> list[dict[str, Any]]:
    """Later visits through the study link, each with the ids it carried (a new SESSION_ID)."""
    rows = session.execute(
        select(ReturnVisit, Recruitment, Participant.code)
        .join(Participant, Participant.id == ReturnVisit.participant_id)
        .join(Recruitment, Recruitment.participant_id == ReturnVisit.participant_id)
        .order_by(ReturnVisit.id)
    )
    return [
        {
            "participant": code,
            "study": recruitment.study,
            "source": recruitment.source,
            "recruitment_id": exported_id(recruitment.recruitment_id),
            "recruiter_study_id": exported_id(visit.recruiter_study_id),
            "recruiter_session_id": exported_id(visit.recruiter_session_id),
            "visited_at": iso(visit.created_at),
        }
        for visit, recruitment, code in rows
    ]


def screen_out_rows(session: Session) -> list[dict[str, Any]]:
    """Visitors the study link turned away before consent (no participant was made)."""
    return [
        {
            "study": row.study,
            "source": row.source,
            "recruitment_id": exported_id(row.recruitment_id),
            "width": row.width,
            "height": row.height,
            "mobile": row.mobile,
            "missing": row.missing,
            "reasons": row.reasons,
            "screened_out_at": iso(row.created_at),
        }
        for row in session.scalars(select(ScreenOut).order_by(ScreenOut.id))
    ]
