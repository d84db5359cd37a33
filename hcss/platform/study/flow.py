"""One participant's position in the study, read from their stage events.

`Flow.locate()` is the single answer to "which stage now?": the first step of
the participant's stage sequence that has neither a ``submitted`` nor a
``timed_out`` event. Nothing else stores a position, so a refresh, a closed
tab or a server restart cannot lose or change it. `Flow.settle()` first
applies whatever happened while nobody was looking (a deadline passed, a
trial ended) and records it, with the time it took effect.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.db import database, session_now
from hcss.platform.models import (
    ConsentRecord,
    Participant,
    QuestionnaireItem,
    Score,
    StageEvent,
    StudyEnrolment,
    Trial,
    TrialStatusChange,
)
from hcss.platform.models.latest import latest_per_key, latest_row
from hcss.platform.models.participant_state import participant_states
from hcss.platform.models.vocabularies import TrialStatus
from hcss.platform.study.enrolment import current_enrolment, not_counted
from hcss.platform.study.stage_protocol import Slot, StageContext
from hcss.platform.study.stages import sequence
from hcss.platform.study.studyfile import load_study
from hcss.questionnaires.definitions import ScoreRow


def study_now() -> datetime:
    """The study clock: the database's, which the live runner and every row stamp use too.

    In a server that is the wall clock; tests and bots give the app a clock
    they move themselves, which accelerates stage deadlines and trials alike.
    """
    return database().now()


#: Stage event kinds after which a step is done.
DONE_KINDS = ("submitted", "timed_out", "skipped")


@dataclass(frozen=True)
class KnownRecords:
    """A participant's stage events (in id order) and newest consent record, read beforehand."""

    events: list[StageEvent]
    consent: ConsentRecord | None


@dataclass(frozen=True)
class Position:
    slot: Slot | None  # None: the study is over for this participant
    step: str = ""
    status: str = "in_progress"  # "in_progress", "completed" or "declined"


class Flow:
    """The study as it stands for one participant, within one unit of work."""

    def __init__(
        self,
        session: Session,
        participant: Participant,
        enrolment: StudyEnrolment,
        now: datetime,
        *,
        known: KnownRecords | None = None,
    ) -> None:
        """`known`: the participant's stage events and newest consent, already read (the
        export reads them for every participant at once instead of two queries each)."""
        self.session = session
        self.participant = participant
        self.enrolment = enrolment
        self.study = load_study(enrolment.study)
        self.now = now
        self.slots = sequence(self.study, enrolment)
        self.events: list[StageEvent] = []
        # (stage index, step, kind) -> the first such event: `locate` asks for every
        # step of every stage, and a scan of the list each time made a page load's
        # work grow with the square of the participant's progress.
        self._first_event: dict[tuple[int, str, str], StageEvent] = {}
        events = (
            known.events
            if known is not None
            else session.scalars(
                select(StageEvent)
                .where(StageEvent.participant_id == participant.id)
                .order_by(StageEvent.id)
            )
        )
        for event in events:
            self._remember(event)
        # The newest consent record: read on first use, kept up to date.
        self._consent: list[ConsentRecord | None] = [] if known is None else [known.consent]
        # (stage index, instrument) -> answers, read on first use and kept up to date by
        # `record_answers`: an MRT answer's page asked for them up to five times.
        self._answers: dict[tuple[int, str], dict[str, str]] = {}

    def _remember(self, event: StageEvent) -> None:
        self.events.append(event)
        self._first_event.setdefault((event.stage_index, event.step, event.kind), event)

    # --- reading ------------------------------------------------------------------

    def event(self, index: int, step: str, kind: str) -> StageEvent | None:
        return self._first_event.get((index, step, kind))

    def finished(self, index: int, step: str) -> bool:
        """Submitted, timed out, or skipped by the experimenter: the flow has moved past it."""
        return any((index, step, kind) in self._first_event for kind in DONE_KINDS)

    def consent(self) -> ConsentRecord | None:
        """The newest consent record, read once per flow (`record_consent` adds one)."""
        if not self._consent:
            self._consent.append(
                latest_row(
                    self.session, ConsentRecord, ConsentRecord.participant_id, self.participant.id
                )
            )
        return self._consent[0]

    def locate(self) -> Position:
        """Which stage and step now: the first step not yet submitted, timed out or skipped."""
        consent = self.consent()
        if consent is not None and consent.decision == "decline":
            return Position(None, status="declined")
        for slot in self.slots:
            for step in slot.stage.steps(self.at(slot)):
                if not self.finished(slot.index, step):
                    return Position(slot, step)
        return Position(None, status="completed")

    def answers(self, index: int, instrument: str) -> dict[str, str]:
        """The answers given at one stage, item -> value (the newest row wins)."""
        if (index, instrument) not in self._answers:
            rows = self.session.scalars(
                select(QuestionnaireItem)
                .where(
                    QuestionnaireItem.participant_id == self.participant.id,
                    QuestionnaireItem.stage_index == index,
                    QuestionnaireItem.instrument == instrument,
                )
                .order_by(QuestionnaireItem.id)
            )
            self._answers[(index, instrument)] = {row.item: row.value for row in rows}
        return dict(self._answers[(index, instrument)])

    def at(self, slot: Slot, step: str = "") -> StageContext:
        """What a stage's hooks are given: this flow (a `stage.Participation`) at one step."""
        return StageContext(self, slot, step)

    def deadline_of(self, slot: Slot, step: str) -> datetime | None:
        entered = self.event(slot.index, step, "entered")
        return None if entered is None else entered.deadline

    # --- writing ------------------------------------------------------------------

    def record(
        self,
        slot: Slot,
        step: str,
        kind: str,
        *,
        at: datetime | None = None,
        deadline: datetime | None = None,
        detail: dict[str, Any] | None = None,
    ) -> StageEvent:
        event = StageEvent(
            participant_id=self.participant.id,
            stage_index=slot.index,
            stage=slot.name,
            step=step,
            model=slot.model,
            kind=kind,
            at=at or self.now,
            deadline=deadline,
            detail=detail,
        )
        self.session.add(event)
        self.session.flush()  # the unique constraint refuses a racing duplicate here
        self._remember(event)
        return event

    def record_consent(self, version: str, decision: str) -> ConsentRecord:
        record = ConsentRecord(
            participant_id=self.participant.id, version=version, decision=decision, at=self.now
        )
        self.session.add(record)
        self._consent[:] = [record]
        return record

    def enter(self, position: Position) -> StageEvent:
        """Record that the current step is shown, once; later calls return the same event."""
        slot, step = position.slot, position.step
        assert slot is not None
        entered = self.event(slot.index, step, "entered")
        if entered is not None:
            return entered
        here = self.at(slot, step)
        limit = slot.stage.timeout_s(here)
        deadline = None
        if limit is not None:
            deadline = self.now + timedelta(seconds=limit / self.enrolment.time_acceleration)
        detail = slot.stage.on_enter(here)
        return self.record(slot, step, "entered", deadline=deadline, detail=detail)

    def record_answers(
        self, slot: Slot, instrument: str, answers: Mapping[str, object], model: str = ""
    ) -> None:
        rows = [
            QuestionnaireItem(
                participant_id=self.participant.id,
                stage_index=slot.index,
                instrument=instrument,
                model=model,
                item=item,
                value="" if value is None else str(value),
                at=self.now,
            )
            for item, value in answers.items()
        ]
        self.session.add_all(rows)
        self.session.flush()
        known = self._answers.get((slot.index, instrument))
        if known is not None:
            known.update((row.item, row.value) for row in rows)

    def record_scores(self, rows: tuple[ScoreRow, ...]) -> None:
        for row in rows:
            self.session.add(
                Score(
                    participant_id=self.participant.id,
                    instrument=row.instrument,
                    model=row.model,
                    scale=row.scale,
                    score=float(row.score),
                )
            )
        self.session.flush()

    def settle(self) -> Position:
        """Record what ended while nobody was looking (deadlines, trials), then locate."""
        for _ in range(len(self.slots) * 64):
            position = self.locate()
            if position.slot is None:
                return position
            entered = self.event(position.slot.index, position.step, "entered")
            if entered is None:
                return position
            ended = position.slot.stage.poll(self.at(position.slot, position.step), entered)
            if ended is None:
                return position
            kind, at = ended
            self.record(position.slot, position.step, kind, at=at)
        raise RuntimeError(f"participant {self.participant.code}: the study flow does not settle")


def current_position(session: Session, participant: Participant) -> Position:
    """Which stage now, for anyone who asks (the console, the export): read only.

    It does not settle deadlines that passed unobserved; the participant's
    next request records those. A participant not yet enrolled is before the
    first stage.
    """
    enrolment = current_enrolment(session, participant.id)
    if enrolment is None:
        return Position(None, status="not_enrolled")
    return Flow(session, participant, enrolment, session_now(session)).locate()


def participant_status(session: Session, participant: Participant) -> str:
    """``not_started``, ``in_progress``, ``completed``, ``declined``, ``aborted`` or
    ``timed_out`` (the export's); see `participant_statuses`."""
    return participant_statuses(session, [participant])[participant.id]


#: Up to this many participants, `participant_statuses` asks for their rows by id.
FEW = 500


def participant_statuses(session: Session, participants: list[Participant]) -> dict[int, str]:
    """Each participant's status, by id, in a few queries whatever their number.

    ``not_started``: the link was never opened (no page of the study was
    shown), so the participant ran no study file and is no participant of any
    study yet. A participant outside
    the study flow (`hcss demo-trial`) is ``in_progress`` while a trial runs
    and ``completed`` once their trials ended.
    """
    ids = {participant.id for participant in participants}
    if not ids:
        return {}
    # A few participants (a batch of links, one row): their rows only; many: every row
    # (an IN list of thousands of ids is slower, and SQLite caps its parameters).
    few = len(ids) <= FEW

    def scope(column: Any) -> tuple[Any, ...]:
        return (column.in_(ids),) if few else ()

    ended = not_counted(session)
    states = participant_states(session)
    consents = latest_per_key(
        session, ConsentRecord, ConsentRecord.participant_id, *scope(ConsentRecord.participant_id)
    )
    enrolments = latest_per_key(
        session,
        StudyEnrolment,
        StudyEnrolment.participant_id,
        *scope(StudyEnrolment.participant_id),
    )
    events: dict[int, list[StageEvent]] = {pid: [] for pid in ids}
    for event in session.scalars(
        select(StageEvent).where(*scope(StageEvent.participant_id)).order_by(StageEvent.id)
    ):
        if event.participant_id in events:
            events[event.participant_id].append(event)
    outside = [p.id for p in participants if p.id not in enrolments and p.id not in ended]
    running = trial_states(session, outside)
    now = session_now(session)
    statuses = {}
    for participant in participants:
        pid, consent = participant.id, consents.get(participant.id)
        if pid in ended:
            declined = consent is not None and consent.decision == "decline"
            statuses[pid] = (
                "declined"
                if declined
                else "timed_out"
                if states.get(pid) == "timed_out"
                else "aborted"
            )
        elif pid not in enrolments:
            statuses[pid] = running.get(pid, "not_started")
        elif not events[pid]:  # enrolled when created (a cell override), never shown a page
            statuses[pid] = "not_started"
        else:
            known = KnownRecords(events[pid], consent)
            flow = Flow(session, participant, enrolments[pid], now, known=known)
            statuses[pid] = flow.locate().status
    return statuses


def trial_states(session: Session, participant_ids: list[int]) -> dict[int, str]:
    """Participants with trials outside the study flow (`hcss demo-trial`): ``in_progress``
    while one runs, else ``completed``; participants without trials are left out."""
    wanted = set(participant_ids)
    if not wanted:
        return {}
    trials = [
        (pid, trial_id)
        for pid, trial_id in session.execute(select(Trial.participant_id, Trial.id))
        if pid in wanted
    ]
    if not trials:
        return {}
    changes = latest_per_key(
        session,
        TrialStatusChange,
        TrialStatusChange.trial_id,
        TrialStatusChange.trial_id.in_([trial_id for _, trial_id in trials]),
    )
    states: dict[int, str] = {}
    for pid, trial_id in trials:
        change = changes.get(trial_id)
        if change is None or change.status == TrialStatus.RUNNING:
            states[pid] = "in_progress"
        else:
            states.setdefault(pid, "completed")
    return states
