"""Skipping a stuck participant's current step, from the console.

A participant can be stuck on a page the study cannot move them past (a
broken browser feature, a questionnaire they will not answer, an MRT part
whose page they lost). The experimenter may move them on: the step gets a
`skipped` stage event, which the study flow counts as done like `submitted`
or `timed_out`, and a `skip_stage` console action names who did it, in the
same transaction, so the audit shows it beside pauses and aborts. Nothing the
participant answered is touched.

Consent cannot be skipped (no one takes part without agreeing), and neither
can a running trial: it ends at its own time limit, or when aborted. A skip
to a chosen stage marks every step before it skipped in one action (skipping
the introduction's five pages and the screen check was six confirmed clicks).

A participant's open page learns of the skip from its next heartbeat and
moves on by itself; answers it sends for a skipped step are kept apart
(hcss.platform.study.views, ``late_answer``).
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from hcss.platform.console.interventions import ConsoleError
from hcss.platform.db import Database, session_now
from hcss.platform.live.service import LiveTrials
from hcss.platform.live.trials import latest_status
from hcss.platform.models import ConsoleAction, Experimenter, Participant
from hcss.platform.models.participant_state import ENDED_STATES, participant_state
from hcss.platform.models.vocabularies import TrialStatus
from hcss.platform.study.enrolment import current_enrolment
from hcss.platform.study.flow import Flow, Position
from hcss.platform.study.stage_protocol import Slot

#: Stages no experimenter may move a participant past.
NEVER_SKIPPED = ("consent",)


def skip_step(
    database: Database,
    live: LiveTrials,
    participant: Participant,
    experimenter: Experimenter | None,
    to_stage: int | None = None,
) -> str:
    """Mark the participant's current step skipped, or every step up to stage `to_stage`
    (1-based, as the console numbers stages) in one action; returns what was skipped
    (``stage 4 introduction page_2``, ``stages 2-5 (9 steps) to stage 6 screen_check``).

    A trial past its deadline is ended first, as the participant's own page
    would (`LiveTrials.finish_overdue`), so the step skipped is the one after it.
    Nothing is skipped unless every step on the way may be: consent never, a
    running trial not.
    """
    live.finish_overdue(participant)
    with database.session_scope() as session:
        if participant_state(session, participant.id) in ENDED_STATES:
            raise ConsoleError(f"{participant.code}'s session has ended; nothing to skip")
        enrolment = current_enrolment(session, participant.id)
        if enrolment is None:
            raise ConsoleError(f"{participant.code} has not opened their link yet")
        row = session.get(Participant, participant.id)
        assert row is not None
        flow = Flow(session, row, enrolment, session_now(session))
        position = flow.settle()
        first = position.slot
        if first is None:
            raise ConsoleError(f"{participant.code} has {position.status} the study")
        target = first.index + 1 if to_stage is None else to_stage - 1
        if to_stage is not None and not first.index < target < len(flow.slots):
            raise ConsoleError(
                f"{participant.code} is at stage {first.index + 1}; choose a later stage "
                f"(up to {len(flow.slots)})"
            )
        who = None if experimenter is None else experimenter.username
        first_step, steps = position.step, 0
        while position.slot is not None and (
            steps == 0 if to_stage is None else position.slot.index < target
        ):
            _refuse_unskippable(session, flow, participant, position)
            flow.record(position.slot, position.step, "skipped", detail={"by": who})
            steps += 1
            position = flow.locate()
        where = _where(first, first_step, steps, position, to_stage)
        session.add(
            ConsoleAction(
                participant_id=participant.id,
                experimenter_id=None if experimenter is None else experimenter.id,
                action="skip_stage",
                at_epoch=flow.now.timestamp(),
                detail=where[:200],
            )
        )
    return where


def _refuse_unskippable(
    session: Session, flow: Flow, participant: Participant, position: Position
) -> None:
    slot = position.slot
    assert slot is not None
    if slot.name in NEVER_SKIPPED:
        raise ConsoleError(f"{participant.code} is at {slot.name}, which cannot be skipped")
    entered = flow.event(slot.index, position.step, "entered")
    trial_id = (entered.detail or {}).get("trial_id") if entered is not None else None
    if trial_id is not None and latest_status(session, trial_id) == TrialStatus.RUNNING:
        raise ConsoleError(
            f"{participant.code}'s trial is running; it ends at its time limit, "
            "or pause or abort it"
        )


def _named(slot: Slot, step: str = "") -> str:
    parts = (f"stage {slot.index + 1}", slot.name, slot.model, step)
    return " ".join(str(part) for part in parts if part)


def _where(first: Slot, first_step: str, steps: int, now: Position, to_stage: int | None) -> str:
    """What a skip did, for the flash message and the audit."""
    if to_stage is None:
        return _named(first, first_step)
    last = now.slot.index if now.slot is not None else to_stage - 1
    span = (
        f"stage {first.index + 1}"
        if last == first.index + 1
        else (f"stages {first.index + 1}-{last}")
    )
    there = _named(now.slot) if now.slot is not None else "the end"
    return f"{span} ({steps} step{'' if steps == 1 else 's'}) to {there}"


def skip_targets(session: Session, participant: Participant) -> list[tuple[int, str]]:
    """The stages a skip may move the participant to: (1-based number, label), after the
    current one; empty when there is nothing to skip."""
    enrolment = current_enrolment(session, participant.id)
    if enrolment is None:
        return []
    flow = Flow(session, participant, enrolment, session_now(session))
    position = flow.locate()
    if position.slot is None or position.slot.name in NEVER_SKIPPED:
        return []
    return [(slot.index + 1, _named(slot)) for slot in flow.slots[position.slot.index + 1 :]]
