"""The participant's pages: `/p/<token>` and the current stage.

Every page is reached through the participant's token and shows only the
step `Flow.locate()` says is current. A POST names the stage and step it
answers; one for any other step (a resubmission, a skipped or an old page)
is refused with a message and changes nothing. Deadlines and ended trials
are settled and committed before anything else, so they hold whatever the
rest of the request does.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from flask import Blueprint, Flask, g, redirect, render_template, request, url_for
from sqlalchemy import inspect, select
from sqlalchemy.exc import IntegrityError, SQLAlchemyError
from werkzeug.exceptions import NotFound
from werkzeug.wrappers import Response

from hcss.platform.db import get_session
from hcss.platform.live.service import live_trials
from hcss.platform.models import Participant, StageEvent, StudyEnrolment
from hcss.platform.models.participant_state import participant_state
from hcss.platform.study.enrolment import current_enrolment, first_enrolment
from hcss.platform.study.flow import Flow, Position, study_now
from hcss.platform.study.markdown import render_markdown
from hcss.platform.study.recruitment import completion_for
from hcss.platform.study.screenout import leave_for, screen_out_for
from hcss.platform.study.stage_protocol import Refused
from hcss.platform.study.texts import fill
from hcss.platform.study.timeouts import time_out_abandoned
from hcss.platform.study.versions import enrolled_study
from hcss.questionnaires import pages

bp = Blueprint("study", __name__, url_prefix="/p")


@bp.record_once
def _continue_after_trials(state: Any) -> None:
    """The live trial page's Continue link leads back into the study."""
    app: Flask = state.app
    app.config.setdefault("LIVE_CONTINUE_URL", "/p/{token}")


@bp.context_processor
def _participant_code() -> dict[str, Any]:
    """Every study page shows the participant's code: consent and debrief say to
    quote it to withdraw, so it must be on screen to be noted down."""
    token = (request.view_args or {}).get("token")
    if not isinstance(token, str):
        return {}
    participant = g.get("study_participant")
    if participant is not None:
        # What the view read, without reading it again: after a failed unit of work the
        # participant is expired, and the page saying "the database is away" (503)
        # must not ask the database for its token (that was a 500).
        loaded = inspect(participant).dict
        if loaded.get("token") == token and loaded.get("code"):
            return {"participant_code": loaded["code"]}  # no second query
    try:
        code = get_session().scalar(select(Participant.code).where(Participant.token == token))
    except SQLAlchemyError:  # an error page for a failed database still renders
        return {}
    return {"participant_code": code} if code else {}


def _participant(token: str) -> Participant:
    participant = (
        get_session().scalars(select(Participant).where(Participant.token == token)).first()
    )
    if participant is None:
        raise NotFound(
            "There is no participant with this link. Please check the link you were given."
        )
    g.study_participant = participant
    return participant


def _enrolled(token: str) -> tuple[Participant, StudyEnrolment, datetime]:
    """The participant, enrolled if not yet, and timed out if they come back too late."""
    session = get_session()
    participant = _participant(token)
    enrolment = current_enrolment(session, participant.id)
    if enrolment is None:  # kept whatever the request does next, and the cell lock let go
        enrolment = first_enrolment(session, participant)
        session.commit()
    # A missing or changed study file holds the participant (503).
    study = enrolled_study(enrolment)
    now = study_now()
    # Only the current enrolment's study can time the participant out: without
    # [timeouts] there is nothing to look up on every page load.
    if study.timeouts.active and time_out_abandoned(session, now, participant.id):
        session.commit()
    return participant, enrolment, now


def _flow(token: str) -> Flow:
    flow = Flow(get_session(), *_enrolled(token))
    if _past_deadline(flow):
        # Before the flow writes: the live service ends a trial past its deadline in
        # units of work of its own (see trial_stage), and the flow then reads it ended.
        live_trials().finish_overdue(flow.participant)
    return flow


def _past_deadline(flow: Flow) -> bool:
    """Whether the current step's deadline has passed, as read from its entry.

    A trial's run step holds its trial's deadline, so only then can a trial be
    overdue: other page loads skip the live service's look (a unit of work of
    its own, after the request's hands its connection back).
    """
    position = flow.locate()
    if position.slot is None:
        return False
    deadline = flow.deadline_of(position.slot, position.step)
    return deadline is not None and flow.now >= deadline


def _settled(flow: Flow) -> Position:
    """Settle, and commit what that recorded so it holds whatever the request does next.

    A settle that recorded nothing (most page loads) leaves nothing to commit:
    the request's own commit ends its transaction.
    """
    recorded = len(flow.events)
    position = flow.settle()
    if len(flow.events) > recorded:
        flow.session.commit()
    return position


@bp.get("/<token>")
def enter(token: str) -> Response:
    """The personal link: straight to wherever the participant is (the next page locates it)."""
    _enrolled(token)
    return redirect(url_for("study.stage", token=token))


#: A page load that lost a race (another tab recorded the same step first) looks again.
RACE_RETRIES = 3


@bp.get("/<token>/stage")
def stage(token: str) -> Response | str | tuple[str, int]:
    """The current step; simultaneous loads (several tabs, a double click) see one step entered.

    `StageEvent`'s unique constraint lets only one of them record the entry;
    the others roll back and read the step it recorded, instead of a 500.
    """
    for _ in range(RACE_RETRIES):
        try:
            return _current_stage(token)
        except IntegrityError:
            get_session().rollback()
    return _refused(token, "This page is being opened elsewhere; please reload it."), 409


def _current_stage(token: str) -> Response | str:
    flow = _flow(token)
    held = _held(flow)
    if held is not None:
        return held
    position = _settled(flow)
    if position.slot is not None:
        flow.enter(position)
        position = _settled(flow)  # a step may end as it is entered (the debrief)
    if position.slot is None:
        return _finished(flow, position)
    here = flow.at(position.slot, position.step)
    target = position.slot.stage.redirect(here)
    if target is not None:
        return redirect(target)
    form = position.slot.stage.form(here, None)
    return _render(flow, position, form)


@bp.post("/<token>/stage/<int:index>/<step>")
def submit(
    token: str, index: int, step: str
) -> Response | tuple[str, int] | tuple[str, int, dict[str, str]] | str:
    flow = _flow(token)
    held = _held(flow)
    if held is not None:
        return held, 409
    position = _settled(flow)
    if flow.event(index, step, "skipped") is not None and (
        position.slot is None or (position.slot.index, position.step) != (index, step)
    ):
        return _moved_on(flow, index, step)
    try:
        _check_current(flow, position, index, step)
        assert position.slot is not None
        stage_ = position.slot.stage
        here = flow.at(position.slot, position.step)
        form = stage_.form(here, request.form)
        if not form.validate():
            return _render(flow, position, form)
        done = stage_.submit(here, form)
        if form.errors or form.form_errors or getattr(form, "dimension_errors", None):
            flow.session.rollback()
            return _render(flow, position, form)
        if done:
            flow.record(position.slot, position.step, "submitted")
    except Refused as refusal:
        if refusal.retry_after_s is not None:
            flow.session.rollback()
            page = _refused(token, refusal.message, retry_after_s=refusal.retry_after_s)
            return page, refusal.status, {"Retry-After": str(refusal.retry_after_s)}
        return _refused(token, refusal.message), refusal.status
    except IntegrityError:
        flow.session.rollback()
        return _refused(token, "This page has already been submitted."), 409
    return redirect(url_for("study.stage", token=token))


@bp.get("/<token>/stage/<int:index>/<step>")
def submit_address(token: str, index: int, step: str) -> Response:
    """A form's POST address opened as a page (a bookmark, a reload): go to the stage."""
    _participant(token)
    return redirect(url_for("study.stage", token=token))


#: The most fields, and characters per answer, a late answer keeps (a form has far fewer).
LATE_FIELDS, LATE_CHARACTERS = 200, 200


def _moved_on(flow: Flow, index: int, step: str) -> str:
    """A submit of a step the experimenter skipped: the answers given are kept, apart.

    They are a ``late_answer`` stage event of the step (its detail holds them),
    never the step's answers: the step was closed without them, and the
    analysis reads only answers given while a step was open. A second submit of
    the same page keeps nothing more (one late answer per step).
    """
    answers = {
        name: [value[:LATE_CHARACTERS] for value in request.form.getlist(name)]
        for name in list(request.form)[:LATE_FIELDS]
        if name != "csrf_token"
    }
    skipped = flow.event(index, step, "skipped")
    assert skipped is not None
    if answers and flow.event(index, step, "late_answer") is None:
        try:
            flow.session.add(
                StageEvent(
                    participant_id=flow.participant.id,
                    stage_index=index,
                    stage=skipped.stage,
                    step=step,
                    model=skipped.model,
                    kind="late_answer",
                    at=flow.now,
                    detail={"answers": answers},
                )
            )
            flow.session.commit()
        except IntegrityError:  # the same page sent twice at once: one is kept
            flow.session.rollback()
    return render_template("study/moved_on.html", token=flow.participant.token, kept=bool(answers))


def _check_current(flow: Flow, position: Position, index: int, step: str) -> None:
    if position.slot is not None and (position.slot.index, position.step) == (index, step):
        if flow.event(index, step, "entered") is None:
            raise Refused("This page has not been shown yet; please reload it.")
        return
    if flow.event(index, step, "timed_out") is not None:
        raise Refused("The time for this part was up before your answer arrived.")
    if flow.finished(index, step):
        raise Refused("This page has already been submitted; it cannot be answered again.")
    if position.slot is None:
        raise Refused("The study is over; there is nothing more to submit.")
    raise Refused("This is not the page you are on; the study's pages must be done in order.")


def _held(flow: Flow) -> str | None:
    """The page for a session the experimenter paused or ended, else None."""
    state = participant_state(flow.session, flow.participant.id)
    if state == "active":
        return None
    leave = leave_for(flow.session, flow.participant, flow.study, state)
    return render_template(
        "study/held.html", state=state, token=flow.participant.token, leave=leave
    )


def _refused(token: str, message: str, *, retry_after_s: int | None = None) -> str:
    return render_template(
        "study/refused.html", message=message, token=token, retry_after_s=retry_after_s
    )


def _finished(flow: Flow, position: Position) -> str:
    if position.status == "declined":
        leave = screen_out_for(flow.session, flow.participant, flow.study)
        return render_template("study/declined.html", leave=leave)
    return render_template(
        "study/debrief.html",
        text_html=render_markdown(fill(pages.debrief_text().markdown, flow.study)),
        completion=completion_for(flow.session, flow.participant, flow.study),
    )


def _render(flow: Flow, position: Position, form: Any) -> str:
    slot = position.slot
    assert slot is not None
    deadline = flow.deadline_of(slot, position.step)
    remaining_wall = None
    if deadline is not None:
        remaining_wall = max(0.0, (deadline - flow.now).total_seconds())
    return render_template(
        slot.stage.template,
        token=flow.participant.token,
        slot=slot,
        step=position.step,
        form=form,
        title=slot.stage.title,
        action=url_for(
            "study.submit", token=flow.participant.token, index=slot.index, step=position.step
        ),
        deadline=deadline,
        # Study seconds left, from the stored deadline; the page counts down the
        # wall seconds and reloads at zero, and the server decides what happens.
        remaining_s=None
        if remaining_wall is None
        else remaining_wall * flow.enrolment.time_acceleration,
        remaining_wall_s=remaining_wall,
        study_per_wall=flow.enrolment.time_acceleration,
        progress=(slot.index + 1, len(flow.slots)),
        **slot.stage.context(flow.at(slot, position.step), form),
    )
