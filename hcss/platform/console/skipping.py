"""Skipping a stuck participant's current step, from the console.

A participant can be stuck on a page the study cannot move them past (a
broken browser feature, a questionnaire they will not answer, an MRT part
whose page they lost). The experimenter may move them on: the step gets a
`skipped` stage event, which the study flow counts as done like `submitted`
or `timed_out`, and a `skip_stage` console action names who did it, in the
same transaction, so the audit shows it beside pauses and aborts. Nothing the
participant answered is touched.

Consent cannot be skipped (no one takes part without agreeing), and neither
can a running trial: it ends at its own time limit, or when aborted.
"""

from __future__ import annotations

from hcss.platform.console.sessions import ConsoleError
from hcss.platform.db import Database, session_now
from hcss.platform.live.runner import Runner
from hcss.platform.live.service import finish_overdue_trial
from hcss.platform.live.trials import latest_status
from hcss.platform.models import ConsoleAction, Experimenter, Participant
from hcss.platform.models.vocabularies import TrialStatus
from hcss.platform.session_state import ENDED_STATES, session_state
from hcss.platform.study.enrolment import current_enrolment
from hcss.platform.study.flow import Flow

#: Stages no experimenter may move a participant past.
NEVER_SKIPPED = ("consent",)


def skip_step(
    database: Database,
    runner: Runner,
    participant: Participant,
    experimenter: Experimenter | None,
) -> str:
    """Mark the participant's current step skipped; returns it (``stage 4 introduction page_2``).

    A trial past its deadline is ended first, as the participant's own page
    would (`finish_overdue_trial`), so the step skipped is the one after it.
    """
    finish_overdue_trial(runner, participant)
    with database.session_scope() as session:
        if session_state(session, participant.id) in ENDED_STATES:
            raise ConsoleError(f"{participant.code}'s session has ended; nothing to skip")
        enrolment = current_enrolment(session, participant.id)
        if enrolment is None:
            raise ConsoleError(f"{participant.code} has not opened their link yet")
        row = session.get(Participant, participant.id)
        assert row is not None
        flow = Flow(session, row, enrolment, session_now(session))
        position = flow.settle()
        slot = position.slot
        if slot is None:
            raise ConsoleError(f"{participant.code} has {position.status} the study")
        if slot.name in NEVER_SKIPPED:
            raise ConsoleError(f"{participant.code} is at {slot.name}, which cannot be skipped")
        entered = flow.event(slot.index, position.step, "entered")
        trial_id = (entered.detail or {}).get("trial_id") if entered is not None else None
        if trial_id is not None and latest_status(session, trial_id) == TrialStatus.RUNNING:
            raise ConsoleError(
                f"{participant.code}'s trial is running; it ends at its time limit, "
                "or pause or abort it"
            )
        where = " ".join(
            str(part)
            for part in (f"stage {slot.index + 1}", slot.name, slot.model, position.step)
            if part
        )
        who = None if experimenter is None else experimenter.username
        flow.record(slot, position.step, "skipped", detail={"by": who})
        session.add(
            ConsoleAction(
                participant_id=participant.id,
                experimenter_id=None if experimenter is None else experimenter.id,
                action="skip_stage",
                at_epoch=flow.now.timestamp(),
                detail=where,
            )
        )
    return where
