"""The console's participant table: each one's study, cell, stage, clocks, presence and actions.

Read straight from the database on each poll, so the table is right
whichever server process runs the trials. The table is paged and filtered in
the database (`progress_page`): a page costs its own rows, whether the study
has 50 participants or 5,000. The
trial clock is computed the way the runner computes it: running wall time,
pauses excluded, times the trial's acceleration. Presence comes from the
heartbeats of the participant's page (hcss.platform.console.presence).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from sqlalchemy import ColumnElement, and_, false, func, or_, select, true
from sqlalchemy.orm import Session

from hcss.platform.console.interventions import available_actions
from hcss.platform.console.presence import CONNECTED_WITHIN_S, presence_by_participant
from hcss.platform.db import session_now
from hcss.platform.live.clock import paused_intervals, trial_time_s
from hcss.platform.live.trials import latest_change
from hcss.platform.models import (
    Participant,
    ParticipantPresence,
    Recruitment,
    ReturnVisit,
    StageEvent,
    StudyEnrolment,
    Trial,
)
from hcss.platform.models.latest import latest_per_key
from hcss.platform.models.participant_state import participant_states
from hcss.platform.models.pilots import pilot_flags, pilot_marks
from hcss.platform.models.vocabularies import TrialStatus
from hcss.platform.study.enrolment import default_study_name
from hcss.platform.study.flow import Flow, Position, participant_statuses
from hcss.platform.study.versions import StudyHeld, enrolled_study


@dataclass(frozen=True)
class ProgressRow:
    code: str
    state: str  # active, paused, aborted (the experimenter's hold)
    status: str  # not_enrolled, in_progress, completed, declined (the study engine's)
    study: str
    cell: int | None  # None until the participant's first visit (or a cell override)
    stage: str
    stage_number: int | None  # 1-based; None before enrolment
    stage_count: int | None
    time_in_stage_s: float | None  # None before the participant's first visit
    trial_clock_s: float | None  # None outside a running trial
    trial_duration_s: float | None
    last_seen_s: float | None  # seconds since the page's last heartbeat; None: never
    connected: bool
    page_hidden: bool  # the page is open in a background tab
    is_pilot: bool
    is_bot: bool
    is_demo: bool
    actions: list[str]  # what the console offers for this row now
    recruitment: str | None = None  # "prolific 5f8a…": the recruitment site and its id


def trial_clock_s(session: Session, trial: Trial, now: float) -> float:
    paused, open_since = paused_intervals(session, trial.id)
    return trial_time_s(
        trial.started_at.timestamp(),
        paused,
        open_since,
        now,
        acceleration=trial.time_acceleration,
        duration_s=trial.duration_s,
    )


def _stage_label(position: Position) -> str:
    """``mental_rotation part_1``, ``post_trial M2``; the status once the study is over."""
    if position.slot is None:
        return "not started" if position.status == "not_enrolled" else position.status
    parts = (position.slot.name, position.slot.model, position.step)
    return " ".join(part for part in parts if part and part != "form")


@dataclass(frozen=True)
class _Place:
    """Where a participant is in their study, as the study engine says."""

    position: Position
    study: str
    cell: int | None
    stage_number: int | None
    stage_count: int | None
    entered: StageEvent | None  # when the current step was entered, if it was
    held: str = ""  # why the participant is held (their study file is missing or changed)


def _place(session: Session, participant: Participant, enrolment: StudyEnrolment | None) -> _Place:
    """The study engine's own answer to "which stage now?" (read only, like `current_position`)."""
    if enrolment is None:
        study = participant.study or default_study_name()
        return _Place(Position(None, status="not_enrolled"), study, None, None, None, None)
    try:
        enrolled_study(enrolment)
    except StudyHeld as held:
        return _Place(
            Position(None), enrolment.study, enrolment.cell, None, None, None, held.reason
        )
    flow = Flow(session, participant, enrolment, session_now(session))
    position = flow.locate()
    count = len(flow.slots)
    number = count if position.slot is None else position.slot.index + 1
    entered = None if position.slot is None else flow.event(number - 1, position.step, "entered")
    return _Place(position, enrolment.study, enrolment.cell, number, count, entered)


def _presence(row: ParticipantPresence | None, now: float) -> tuple[float | None, bool, bool]:
    if row is None:
        return None, False, False
    ago = max(0.0, now - row.last_seen_epoch)
    return ago, ago <= CONNECTED_WITHIN_S, bool(row.hidden)


#: Rows per page of the live table.
PER_PAGE = 25
#: What the table can hide, by the flag's name in the page's filter boxes.
FLAGS = ("pilot", "bot", "demo")


@dataclass(frozen=True)
class ProgressPage:
    rows: list[ProgressRow]
    page: int  # 1-based
    pages: int
    total: int  # participants the filters let through
    everyone: int = 0  # participants before the filters ("showing N of everyone")
    search: str = ""  # what the search asked for, as it was read


def _shown(session: Session, hide: frozenset[str]) -> ColumnElement[bool]:
    """The SQL condition for the participants the filters let through."""
    conditions: list[ColumnElement[bool]] = [true()]
    if "bot" in hide:
        conditions.append(Participant.is_bot == false())
    if "demo" in hide:
        conditions.append(Participant.is_demo == false())
    if "pilot" in hide:
        marked, unmarked = pilot_marks(session)
        conditions.append(Participant.id.not_in(marked))
        conditions.append(or_(Participant.is_pilot == false(), Participant.id.in_(unmarked)))
    return and_(*conditions)


#: What a search for a session's status finds: the table's words for it (`table_status`).
STATUS_SEARCH = {
    "not started": {"not started"},
    "active": {"active"},
    "in progress": {"active", "paused"},
    "paused": {"paused"},
    "completed": {"completed"},
    "declined": {"declined"},
    "aborted": {"aborted"},
    "timed out": {"timed_out"},
}
#: The longest search the table takes (a recruitment id is at most 128 characters).
MAX_SEARCH = 200


def table_status(state: str, status: str) -> str:
    """The table's Session column: what the study says once it is over, the hold otherwise.

    `status` is the study engine's (`participant_statuses` or a position's);
    `state` the experimenter's hold (active, paused, aborted, timed_out).
    """
    if status in ("completed", "declined"):
        return status
    if state == "active" and status in ("not_enrolled", "not_started"):
        return "not started"
    return state


def _search_words(search: str) -> str:
    return " ".join(search.lower().replace("_", " ").split())[:MAX_SEARCH]


def _matching(search: str) -> ColumnElement[bool]:
    """Participants whose code, study, recruitment site or id, recruiter study or session id
    holds every word (as the table shows them: ``prolific 5f8a…``)."""
    conditions: list[ColumnElement[bool]] = [true()]
    for word in search.split():
        ids = [
            select(column.table.c.participant_id).where(column.icontains(word, autoescape=True))
            for column in (
                Recruitment.source,
                Recruitment.recruitment_id,
                Recruitment.recruiter_session_id,
                Recruitment.recruiter_study_id,
                ReturnVisit.recruiter_session_id,
            )
        ]
        ids.append(
            select(StudyEnrolment.participant_id).where(
                StudyEnrolment.study.icontains(word, autoescape=True)
            )
        )
        conditions.append(
            or_(
                Participant.code.icontains(word, autoescape=True),
                Participant.study.icontains(word, autoescape=True),
                *(Participant.id.in_(select_ids) for select_ids in ids),
            )
        )
    return and_(*conditions)


def progress_page(
    session: Session,
    now: float,
    *,
    page: int = 1,
    hide: frozenset[str] = frozenset(),
    search: str = "",
) -> ProgressPage:
    """One page of the table, newest first, with the hidden flags filtered out in SQL.

    `search` looks through every participant, not the page shown: a code,
    a study, a recruitment id (PROLIFIC_PID, SONA id, workerId), a recruiter
    session id (in SQL), and a status as the table shows it ("not started",
    "paused", "completed", ...), which the study engine answers for each
    participant: ``demo not started`` finds the demo links nobody opened.
    """
    shown = _shown(session, hide)
    words = _search_words(search)
    status, rest = _status_in(words)
    if rest:
        shown = and_(shown, _matching(rest))
    everyone = int(session.scalar(select(func.count()).select_from(Participant)) or 0)
    if status:
        found = _with_status(session, shown, STATUS_SEARCH[status])
        total = len(found)
        pages = max(1, -(-total // PER_PAGE))
        page = min(max(1, page), pages)
        participants = found[(page - 1) * PER_PAGE : page * PER_PAGE]
    else:
        total = int(session.scalar(select(func.count()).select_from(Participant).where(shown)) or 0)
        pages = max(1, -(-total // PER_PAGE))
        page = min(max(1, page), pages)
        participants = list(
            session.scalars(
                select(Participant)
                .where(shown)
                .order_by(Participant.id.desc())
                .limit(PER_PAGE)
                .offset((page - 1) * PER_PAGE)
            )
        )
    rows = progress_rows(session, now, participants)
    return ProgressPage(rows, page, pages, total, everyone, words)


def _status_in(words: str) -> tuple[str, str]:
    """The status a search names (``demo not started``: ``not started``) and its other words."""
    for status in sorted(STATUS_SEARCH, key=len, reverse=True):
        padded = f" {words} "
        if f" {status} " in padded:
            return status, " ".join(padded.replace(f" {status} ", " ", 1).split())
    return "", words


def _with_status(
    session: Session, shown: ColumnElement[bool], wanted: set[str]
) -> list[Participant]:
    """The participants shown whose table status is one of `wanted`, newest first."""
    candidates = list(
        session.scalars(select(Participant).where(shown).order_by(Participant.id.desc()))
    )
    statuses = participant_statuses(session, candidates)
    states = participant_states(session)
    return [
        p for p in candidates if table_status(states.get(p.id, "active"), statuses[p.id]) in wanted
    ]


def progress_rows(
    session: Session, now: float, participants: list[Participant] | None = None
) -> list[ProgressRow]:
    """One row per participant given (default: all), in the order given (newest first).

    The stage is the study engine's own answer, so the console never
    disagrees with what the participant sees; a running trial adds its
    clock. Time in stage counts from the step's entry, or from the last thing
    that happened when the participant has not opened the next step yet.
    """
    if participants is None:
        participants = list(session.scalars(select(Participant).order_by(Participant.id.desc())))
    ids = [participant.id for participant in participants]
    trials = latest_per_key(session, Trial, Trial.participant_id, Trial.participant_id.in_(ids))
    last_events = latest_per_key(
        session, StageEvent, StageEvent.participant_id, StageEvent.participant_id.in_(ids)
    )
    presence = presence_by_participant(session, ids)
    states = participant_states(session)
    enrolments = latest_per_key(
        session,
        StudyEnrolment,
        StudyEnrolment.participant_id,
        StudyEnrolment.participant_id.in_(ids),
    )
    recruited = {
        r.participant_id: f"{r.source} {r.recruitment_id}" if r.recruitment_id else r.source
        for r in session.scalars(select(Recruitment).where(Recruitment.participant_id.in_(ids)))
    }
    pilots = pilot_flags(session, participants)
    rows = []
    for participant in participants:
        state = states.get(participant.id, "active")
        trial = trials.get(participant.id)
        status_row = None if trial is None else latest_change(session, trial.id)
        place = _place(session, participant, enrolments.get(participant.id))
        position = place.position
        last = last_events.get(participant.id)
        clock = duration = None
        since = participant.created_at.timestamp() if last is None else last.at.timestamp()
        if (
            trial is not None
            and status_row is not None
            and status_row.status == TrialStatus.RUNNING
        ):
            stage, since = f"{trial.kind} {trial.model}", trial.started_at.timestamp()
            clock, duration = trial_clock_s(session, trial, now), trial.duration_s
        elif position.status == "not_enrolled" and trial is not None:
            # A participant outside the study flow (`hcss demo-trial`).
            reason = "" if status_row is None else f" ({status_row.reason})"
            stage = f"{trial.kind} {trial.model} ended{reason}"
            since = (trial.started_at if status_row is None else status_row.created_at).timestamp()
        elif place.held:
            stage = f"held: {place.held}"
        else:
            stage = _stage_label(position)
            if place.entered is not None:
                since = place.entered.at.timestamp()
        last_seen, connected, hidden = _presence(presence.get(participant.id), now)
        status = position.status
        outside = status == "not_enrolled" and trial is not None  # `hcss demo-trial`
        if outside:  # its real status: in progress while the trial runs, then completed
            running = status_row is not None and status_row.status == TrialStatus.RUNNING
            status = "in_progress" if running else "completed"
        rows.append(
            ProgressRow(
                code=participant.code,
                state=state,
                status=status,
                study=place.study,
                cell=place.cell,
                stage=stage,
                stage_number=place.stage_number,
                stage_count=place.stage_count,
                time_in_stage_s=None
                if position.status == "not_enrolled" and trial is None
                else max(0.0, now - since),
                trial_clock_s=clock,
                trial_duration_s=duration,
                last_seen_s=last_seen,
                connected=connected,
                page_hidden=hidden,
                is_pilot=pilots[participant.id],
                is_bot=participant.is_bot,
                is_demo=participant.is_demo,
                actions=available_actions(
                    state, status, pilots[participant.id], in_flow=not outside
                ),
                recruitment=recruited.get(participant.id),
            )
        )
    return rows


def progress_json(page: ProgressPage) -> dict[str, Any]:
    return {
        "participants": [asdict(row) for row in page.rows],
        "page": page.page,
        "pages": page.pages,
        "total": page.total,
        "everyone": page.everyone,
        "search": page.search,
    }
