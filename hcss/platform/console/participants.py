"""Creating participants, and the links (and CSV of links) they open the study with."""

from __future__ import annotations

import io
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from flask import url_for
from sqlalchemy import func, select
from sqlalchemy.orm import Session
from werkzeug.routing import BuildError

from hcss.platform.console.interventions import ConsoleError
from hcss.platform.models import (
    ConsoleAction,
    ConsoleForm,
    Experimenter,
    Participant,
    StageEvent,
    StudyEnrolment,
)
from hcss.platform.models.latest import latest_per_key
from hcss.platform.models.pilots import pilot_flags
from hcss.platform.study.enrolment import assign_cell
from hcss.platform.study.flow import participant_statuses
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
    form_key: str | None = None,
) -> list[Participant]:
    """New participants with unguessable tokens, each with a `create` action row.

    `form_key` is the Create form's own key (`ConsoleForm`): stored with the batch, so
    the commit of a second batch from the same form fails on the unique key.

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
    made: list[Participant] = []
    for _ in range(count):
        participant = Participant(is_pilot=pilot, study=study)
        session.add(participant)
        session.flush()
        # The batch is named by its first participant's code: the links page lists batches.
        batch = f"batch {(made[0] if made else participant).code} of {count}"
        session.add(
            ConsoleAction(
                participant_id=participant.id,
                experimenter_id=None if experimenter is None else experimenter.id,
                action="create",
                at_epoch=now,
                detail=f"{batch}, pilot" if pilot else batch,
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
    if form_key is not None and made:
        session.add(
            ConsoleForm(
                key=form_key,
                experimenter_id=None if experimenter is None else experimenter.id,
                batch=made[0].code,
            )
        )
    session.flush()
    return made


def batch_of_form(
    session: Session, form_key: str, experimenter: Experimenter | None
) -> tuple[str, ...] | None:
    """The codes of the batch the Create form with this key made (none left if all were
    withdrawn), or None if that form has not been carried out. ConsoleError for a key
    another account's form carried: a key is one signed-in page's, so from another
    account it is no repeat of that account's own form."""
    form = session.scalars(select(ConsoleForm).where(ConsoleForm.key == form_key)).first()
    if form is None:
        return None
    if form.experimenter_id != (None if experimenter is None else experimenter.id):
        raise ConsoleError("this form was sent from another account; create from your own page")
    codes = session.scalars(
        select(Participant.code)
        .join(ConsoleAction, ConsoleAction.participant_id == Participant.id)
        .where(
            ConsoleAction.action == "create",
            ConsoleAction.detail.startswith(f"batch {form.batch} of "),
        )
        .order_by(ConsoleAction.id)
    )
    return tuple(codes)


def participant_link(participant: Participant) -> str:
    """The personal link to hand out: the study's entry page, else the trial page."""
    return link_maker()(participant.token)


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


LINK_COLUMNS = ("code", "study", "cell", "pilot", "batch", "created", "opened", "status", "link")
#: A `create` action's detail: "batch P1A2B3C4D of 50" (the batch's first participant).
BATCH = re.compile(r"batch (\S+) of \d+")
#: Where the token goes in a link built once (tokens are URL-safe base64: no "~").
TOKEN_SLOT = "~token~"
#: Statuses whose link still leads somewhere: "Copy all links" copies only these.
USABLE = ("not_started", "in_progress")


@dataclass(frozen=True)
class Batch:
    """Links one experimenter created in one go (one Create), numbered in creation order."""

    number: int
    created: datetime
    experimenter: str
    study: str
    codes: tuple[str, ...]
    opened: int

    @property
    def label(self) -> str:
        return f"batch {self.number}"


def _when(moment: datetime | None) -> str:
    return "" if moment is None else moment.strftime("%Y-%m-%d %H:%M")


def link_rows(session: Session, participants: list[Participant]) -> list[dict[str, str]]:
    """What an experimenter hands out: code, study, cell (empty until the first visit),
    the batch it was created in, when it was created and first opened, its status, link.

    Read in a fixed number of queries whatever the number of participants (one
    enrolment query per participant made the page take 17 s at 5,000).
    """
    enrolments = latest_per_key(session, StudyEnrolment, StudyEnrolment.participant_id)
    pilots = pilot_flags(session, participants)
    statuses = participant_statuses(session, participants)
    opened = first_visits(session)
    batch_of = {code: batch for batch in batches(session) for code in batch.codes}
    link = link_maker()
    rows = []
    for participant in participants:
        enrolment = enrolments.get(participant.id)
        batch = batch_of.get(participant.code)
        rows.append(
            {
                "code": participant.code,
                "study": enrolment.study if enrolment else (participant.study or ""),
                "cell": str(enrolment.cell) if enrolment else "",
                "pilot": "yes" if pilots[participant.id] else "no",
                "batch": batch.label if batch else _origin(participant),
                "created": _when(participant.created_at),
                "opened": _when(opened.get(participant.id)),
                "status": statuses[participant.id],
                "link": link(participant.token),
            }
        )
    return rows


def _origin(participant: Participant) -> str:
    """Where a participant not created in a batch came from."""
    if participant.is_demo:
        return "demo trial"
    if participant.is_bot:
        return "bot"
    return "study link"


def first_visits(session: Session) -> dict[int, datetime]:
    """When each participant first opened their link: their first stage event."""
    rows = session.execute(
        select(StageEvent.participant_id, func.min(StageEvent.at)).group_by(
            StageEvent.participant_id
        )
    )
    return {participant_id: at for participant_id, at in rows}


def batches(session: Session) -> list[Batch]:
    """Every batch of links, oldest first: the `create` actions of one request share
    their experimenter and instant."""
    opened = set(first_visits(session))
    rows = session.execute(
        select(
            ConsoleAction.at_epoch,
            ConsoleAction.experimenter_id,
            Participant.id,
            Participant.code,
            Participant.study,
            ConsoleAction.created_at,
            ConsoleAction.detail,
        )
        .join(Participant, Participant.id == ConsoleAction.participant_id)
        .where(ConsoleAction.action == "create")
        .order_by(ConsoleAction.id)
    )
    names = dict(session.execute(select(Experimenter.id, Experimenter.username)).all())
    grouped: dict[object, list[Any]] = {}
    for row in rows:
        named = BATCH.match(row.detail or "")
        # Rows written before batches were named: one request's rows share an instant.
        key = named.group(1) if named else (row.at_epoch, row.experimenter_id)
        grouped.setdefault(key, []).append(row)
    return [
        Batch(
            number=number,
            created=members[0].created_at,
            experimenter=names.get(members[0].experimenter_id, "cli"),
            study=members[0].study or "",
            codes=tuple(member.code for member in members),
            opened=sum(member.id in opened for member in members),
        )
        for number, members in enumerate(grouped.values(), start=1)
    ]


def link_maker() -> Callable[[str], str]:
    """token -> personal link, the endpoint found once (`participant_link` for many)."""
    for endpoint in ("study.enter", "study.stage", "live.trial_page"):
        try:
            # Built once and filled in: url_for per link was a third of the page at 5,000.
            template = url_for(endpoint, token=TOKEN_SLOT, _external=True)
        except BuildError:
            continue
        return lambda token: template.replace(TOKEN_SLOT, token)
    raise RuntimeError("no participant page is registered")


def links_csv(rows: list[dict[str, str]]) -> str:
    buffer = io.StringIO()
    writer = TableWriter(buffer, LINK_COLUMNS)
    for row in rows:
        writer.write(row)
    return buffer.getvalue()
