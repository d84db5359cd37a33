"""How each visitor of a study link ended, counted for the console's summary.

A recruitment site settles each submission by its outcome, and each outcome
has its own code and URL in the study file (hcss.platform.study.screenout):
completed; declined consent; screened out (a device short of `[requirements]`);
study full; ended by the experimenter (paid or returned, as the file says); timed
out. The counts here are the experimenter's check against the site's own, so each
recruitment id counts once, under one outcome: a participant's (of the `recruitment`
rows, the export's status), else the study full's (`turned_away`), else the
screen-out's (`screen_out`: a phone opening the link twice is one visitor). A visit
without an id (an anonymous study) counts each time: there is nothing to join it by.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.models import ConsentRecord, Participant, Recruitment, ScreenOut, TurnedAway
from hcss.platform.models.participant_state import aborted_participants, timed_out_participants
from hcss.platform.study.flow import current_position
from hcss.platform.study.online import Recruit
from hcss.platform.study.screenout import Outcome, outcome_link
from hcss.platform.study.studyfile import Study

#: The outcomes in the console's order, with their labels.
OUTCOME_LABELS = {
    "completed": "completed",
    "in_progress": "in progress",
    "declined": "declined consent",
    "screened_out": "screened out (device)",
    "full": "study full",
    "ended": "ended by the experimenter",
    "timed_out": "timed out",
}


@dataclass(frozen=True)
class OutcomeRow:
    """One outcome of a study link: the code and URL the study file gives it, and how
    many visitors ended so, per recruitment site (``prolific``, ``sona``, ``mturk``,
    ``link``)."""

    outcome: str
    label: str
    code: str
    url: str
    paid: bool  # the visitor submits (a code to enter), not returns
    by_source: dict[str, int] = field(default_factory=dict)

    @property
    def count(self) -> int:
        return sum(self.by_source.values())


@dataclass(frozen=True)
class Outcomes:
    """One study link's visitors by outcome."""

    study: str
    rows: tuple[OutcomeRow, ...]

    def count(self, outcome: str) -> int:
        return next(row.count for row in self.rows if row.outcome == outcome)

    @property
    def total(self) -> int:
        return sum(row.count for row in self.rows)

    @property
    def sources(self) -> list[str]:
        return sorted({source for row in self.rows for source in row.by_source})


def _codes(study: Study) -> dict[str, tuple[str, str, bool]]:
    """Each outcome's (code, URL, paid) as the study file gives it, fallbacks applied;
    URLs with their placeholders unfilled (they differ per visitor)."""
    online = study.online
    codes = {
        "completed": (online.completion_code, online.completion_url, True),
        "in_progress": ("", "", False),
    }
    leaving: tuple[Outcome, ...] = ("declined", "screened_out", "full", "ended", "timed_out")
    for outcome in leaving:
        leave = outcome_link(study, None, outcome)
        codes[outcome] = (
            ("", "", False)
            if leave is None
            else (leave.code, leave.url, not leave.return_submission)
        )
    return codes


def outcomes(session: Session, study: Study) -> Outcomes:
    """The counts for one study's link (pilots, bots and demos included: they came by it too)."""
    name = study.name
    joined = session.execute(
        select(Participant, Recruitment.source, Recruitment.recruitment_id)
        .join(Recruitment, Recruitment.participant_id == Participant.id)
        .where(Recruitment.study == name)
    ).all()
    # participant_status's answer, with the ended sets read once rather than per participant.
    declined = set(
        session.scalars(
            select(ConsentRecord.participant_id).where(ConsentRecord.decision == "decline")
        )
    )
    timed_out, aborted = timed_out_participants(session), aborted_participants(session)
    counts: dict[str, Counter[str]] = {outcome: Counter() for outcome in OUTCOME_LABELS}
    seen: set[tuple[str, str]] = set()
    for participant, source, recruitment_id in joined:
        if recruitment_id is not None:
            seen.add((source, recruitment_id))
        if participant.id in declined:
            outcome = "declined"
        elif participant.id in timed_out:
            outcome = "timed_out"
        elif participant.id in aborted:
            outcome = "ended"
        else:
            status = current_position(session, participant).status
            outcome = "in_progress" if status not in ("completed", "declined") else status
        counts[outcome][source] += 1
    for outcome, model in (("full", TurnedAway), ("screened_out", ScreenOut)):
        rows = session.execute(
            select(model.source, model.recruitment_id).where(model.study == name).order_by(model.id)
        ).all()
        for source, recruitment_id in rows:
            if recruitment_id is not None:
                if (source, recruitment_id) in seen:
                    continue  # counted already, under a later or stronger outcome
                seen.add((source, recruitment_id))
            counts[outcome][source] += 1
    codes = _codes(study)
    return Outcomes(
        study=name,
        rows=tuple(
            OutcomeRow(outcome, label, *codes[outcome], by_source=dict(counts[outcome]))
            for outcome, label in OUTCOME_LABELS.items()
        ),
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
