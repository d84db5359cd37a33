"""How each visitor of a study link ended, counted for the console's summary.

A recruitment site settles each submission by its outcome, and each outcome
has its own code and URL in the study file (hcss.platform.study.screenout):
completed; screened out (a device short of `[requirements]`); returned (the
study was full, consent declined, or the experimenter ended the session);
timed out. The counts here are the experimenter's check against the site's
own: of the participants who came through the link (`recruitment` rows), the
export's status; of the visitors who never became participants, the
`screen_out` and `turned_away` rows.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from hcss.platform.models import ConsentRecord, Participant, Recruitment, ScreenOut, TurnedAway
from hcss.platform.models.participant_state import aborted_participants, timed_out_participants
from hcss.platform.study.flow import current_position
from hcss.platform.study.online import Recruit


@dataclass(frozen=True)
class Outcomes:
    """One study link's visitors by outcome."""

    study: str
    completed: int
    in_progress: int
    screened_out: int
    full: int  # returned: came while the study was full
    declined: int  # returned: declined consent
    ended: int  # returned: the experimenter ended the session
    timed_out: int

    @property
    def returned(self) -> int:
        return self.full + self.declined + self.ended


def outcomes(session: Session, study: str) -> Outcomes:
    """The counts for one study's link (pilots, bots and demos included: they came by it too)."""
    participants = session.scalars(
        select(Participant)
        .join(Recruitment, Recruitment.participant_id == Participant.id)
        .where(Recruitment.study == study)
    ).all()
    # participant_status's answer, with the ended sets read once rather than per participant.
    declined = set(
        session.scalars(
            select(ConsentRecord.participant_id).where(ConsentRecord.decision == "decline")
        )
    )
    timed_out, aborted = timed_out_participants(session), aborted_participants(session)
    statuses: Counter[str] = Counter()
    for participant in participants:
        if participant.id in declined:
            statuses["declined"] += 1
        elif participant.id in timed_out:
            statuses["timed_out"] += 1
        elif participant.id in aborted:
            statuses["aborted"] += 1
        else:
            status = current_position(session, participant).status
            statuses["in_progress" if status == "not_enrolled" else status] += 1

    def rows(model: type[ScreenOut] | type[TurnedAway]) -> int:
        count = select(func.count()).select_from(model).where(model.study == study)
        return int(session.scalar(count) or 0)

    return Outcomes(
        study=study,
        completed=statuses["completed"],
        in_progress=statuses["in_progress"],
        screened_out=rows(ScreenOut),
        full=rows(TurnedAway),
        declined=statuses["declined"],
        ended=statuses["aborted"],
        timed_out=statuses["timed_out"],
    )


def record_turned_away(session: Session, study: str, recruit: Recruit) -> None:
    """Note a visitor with a recruitment id who found the study full, once per id.

    An anonymous visit is not noted: a link preview or a crawler would count.
    The caller commits.
    """
    if recruit.recruitment_id is None:
        return
    seen = session.scalar(
        select(TurnedAway.id).where(
            TurnedAway.study == study,
            TurnedAway.source == recruit.source,
            TurnedAway.recruitment_id == recruit.recruitment_id,
        )
    )
    if seen is None:
        session.add(
            TurnedAway(study=study, source=recruit.source, recruitment_id=recruit.recruitment_id)
        )
