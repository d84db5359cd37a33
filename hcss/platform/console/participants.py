"""Creating participants and the links they open the study with."""

from __future__ import annotations

from flask import url_for
from sqlalchemy.orm import Session
from werkzeug.routing import BuildError

from hcss.platform.console.sessions import ConsoleError
from hcss.platform.models import ConsoleAction, Experimenter, Participant
from hcss.platform.study.enrolment import assign_cell


def create_participants(
    session: Session,
    *,
    count: int,
    pilot: bool,
    cell: int | None,
    experimenter: Experimenter | None,
    now: float,
) -> list[Participant]:
    """New participants with unguessable tokens, each with a `create` action row.

    Without an override the study engine assigns the cell when the participant
    first opens their link, so people who never come do not fill cells; an
    override is enrolled now, through the engine, and recorded as an action.
    """
    made = []
    for _ in range(count):
        participant = Participant(is_pilot=pilot)
        session.add(participant)
        session.flush()
        session.add(
            ConsoleAction(
                participant_id=participant.id,
                experimenter_id=None if experimenter is None else experimenter.id,
                action="create",
                at_epoch=now,
                detail="pilot" if pilot else "",
            )
        )
        if cell is not None:
            try:
                assign_cell(session, participant, override=cell)
            except ValueError as error:
                raise ConsoleError(str(error)) from error
            session.add(
                ConsoleAction(
                    participant_id=participant.id,
                    experimenter_id=None if experimenter is None else experimenter.id,
                    action="cell_override",
                    at_epoch=now,
                    detail=f"cell {cell}",
                )
            )
        made.append(participant)
    session.flush()
    return made


def participant_link(participant: Participant) -> str:
    """The personal link to hand out: the study's entry page, else the trial page."""
    for endpoint in ("study.enter", "study.stage", "live.trial_page"):
        try:
            return url_for(endpoint, token=participant.token, _external=True)
        except BuildError:
            continue
    raise RuntimeError("no participant page is registered")
