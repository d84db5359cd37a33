"""Creating participants, and the links (and CSV of links) they open the study with."""

from __future__ import annotations

import io
from collections.abc import Iterable

from flask import url_for
from sqlalchemy import select
from sqlalchemy.orm import Session
from werkzeug.routing import BuildError

from hcss.platform.console.sessions import ConsoleError
from hcss.platform.models import ConsoleAction, Experimenter, Participant
from hcss.platform.study.enrolment import assign_cell, current_enrolment
from hcss.platform.study.studyfile import StudyFileError, load_study
from hcss.tidy_csv import TableWriter


def create_participants(
    session: Session,
    *,
    count: int,
    pilot: bool,
    cell: int | None,
    experimenter: Experimenter | None,
    now: float,
    study: str | None = None,
) -> list[Participant]:
    """New participants with unguessable tokens, each with a `create` action row.

    `study` is the study file they are invited to (None: the server's default);
    it is checked now, so a typo never reaches a participant. Without a cell
    override the study engine assigns the cell when the participant first
    opens their link, so people who never come do not fill cells; an override
    is enrolled now, through the engine, and recorded as an action.
    """
    if study is not None:
        try:
            load_study(study)
        except StudyFileError as error:
            raise ConsoleError(str(error)) from error
    made = []
    for _ in range(count):
        participant = Participant(is_pilot=pilot, study=study)
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
                assign_cell(session, participant, override=cell, study=study)
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


def participants_by_code(session: Session, codes: Iterable[str]) -> list[Participant]:
    """The participants named, in the order named; ConsoleError names any unknown code."""
    wanted = list(dict.fromkeys(codes))
    found = {
        p.code: p for p in session.scalars(select(Participant).where(Participant.code.in_(wanted)))
    }
    missing = [code for code in wanted if code not in found]
    if missing:
        raise ConsoleError(f"no participant with code {', '.join(missing[:5])}")
    return [found[code] for code in wanted]


LINK_COLUMNS = ("code", "study", "cell", "pilot", "link")


def link_rows(session: Session, participants: list[Participant]) -> list[dict[str, str]]:
    """What an experimenter hands out: code, study, cell (empty until the first visit), link."""
    rows = []
    for participant in participants:
        enrolment = current_enrolment(session, participant.id)
        rows.append(
            {
                "code": participant.code,
                "study": enrolment.study if enrolment else (participant.study or ""),
                "cell": str(enrolment.cell) if enrolment else "",
                "pilot": "yes" if participant.is_pilot else "no",
                "link": participant_link(participant),
            }
        )
    return rows


def links_csv(rows: list[dict[str, str]]) -> str:
    buffer = io.StringIO()
    writer = TableWriter(buffer, LINK_COLUMNS)
    for row in rows:
        writer.write(row)
    return buffer.getvalue()
