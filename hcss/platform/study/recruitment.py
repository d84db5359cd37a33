"""The study link: `/join/<study>` enrols each new visitor, and resumes a returning one.

oTree, JATOS and Gorilla all give one public link that a recruitment site
sends everyone to. Here a visit with a recruitment id the study has already
seen goes back to that participant's personal link; any other visit gets a
first page that checks the device against the study's `[requirements]`. Its
Start creates a participant, stores the recruiter's ids and enrols them
through the study engine's own `assign_cell` (least-filled cell, the same
lock), all in one transaction; a device that falls short gets a screen-out
row and a page with the study's screen-out code instead. The completion code and URL for the debrief come from the study
file's `[online]` table, their `{placeholders}` filled with the participant's ids.

MTurk shows the link in an iframe on its own site (an ExternalQuestion). For a
study with `[online] mturk = true` the join page may be framed by MTurk's
origins only; in the frame it offers to open the study in its own window (a
first-party window: a browser sends no cookies to a cross-site frame, so no
form could be posted there, and a HIT's frame is smaller than the trials need),
and that window's debrief posts the assignment to `turkSubmitTo`, checked to be
one of MTurk's servers when the worker starts.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from urllib.parse import urlencode

from flask import Blueprint, redirect, render_template, request, url_for
from flask.typing import ResponseReturnValue
from sqlalchemy import select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session
from werkzeug.wrappers import Response

from hcss.platform.db import get_session, session_now
from hcss.platform.guards.hardening import allow_form_action_to, allow_framing_by
from hcss.platform.guards.ratelimit import enrolment_refusal
from hcss.platform.models import Participant, Recruitment, ReturnVisit
from hcss.platform.study.enrolment import assign_cell, cell_counts, hold_assignment_lock
from hcss.platform.study.files import NoStudyFile
from hcss.platform.study.flow import participant_status
from hcss.platform.study.limits import Timeouts
from hcss.platform.study.online import (
    HitPreview,
    Recruit,
    RecruitmentError,
    check_submit_to,
    fill_placeholders,
    recruit_from,
    recruitment_parameters,
)
from hcss.platform.study.outcomes import record_turned_away
from hcss.platform.study.screenout import (
    measurement_from,
    record_screen_out,
    recruit_of,
    return_link,
    screen_out_link,
    shortfalls,
)
from hcss.platform.study.studyfile import Study, StudyFileError, load_study
from hcss.platform.study.timeouts import time_out_abandoned

bp = Blueprint("join", __name__, url_prefix="/join")
#: The server's terminal (`hcss serve` prints it): a broken study file is named there.
events = logging.getLogger("hcss.events")

MAX_STUDY_NAME = 64


class NoStudyLink(RecruitmentError):
    """No study of that name offers a link (a 404, not a 400)."""


class StudyUnavailable(RecruitmentError):
    """The study's file is there but cannot be read: the experimenter must repair it (503)."""


class StudyFull(RecruitmentError):
    """The study has reached its recruitment target: no one new is enrolled."""


@dataclass(frozen=True)
class Enrolled:
    """How far a study's recruitment is: real participants in progress or completed."""

    study: str
    total: int
    target: int  # 0: none
    cell_target: int  # 0: none
    cells: dict[int, int]
    timeouts: Timeouts = Timeouts()

    @property
    def full(self) -> bool:
        if self.target and self.total >= self.target:
            return True
        return bool(self.cell_target) and all(n >= self.cell_target for n in self.cells.values())


def enrolled(session: Session, study: Study) -> Enrolled:
    """The study's real participants who count against its targets, per cell."""
    counts = cell_counts(session, study, "real")
    return Enrolled(
        study.name,
        sum(counts.values()),
        study.online.target,
        study.online.cell_target,
        dict(sorted(counts.items())),
        study.timeouts,
    )


def _check_room(session: Session, study: Study) -> None:
    """StudyFull when the study is at its target, after timing out the abandoned."""
    if not (study.online.target or study.online.cell_target):
        return
    if enrolled(session, study).full and time_out_abandoned(session, session_now(session)):
        session.commit()  # the places they held are free now
    if enrolled(session, study).full:
        raise StudyFull(
            "This study has all the participants it needs, so it cannot take you. "
            "Thank you for your interest."
        )


@dataclass(frozen=True)
class MTurkSubmission:
    """The form the debrief posts to MTurk: its externalSubmit and the assignment's fields."""

    action: str
    fields: dict[str, str]


@dataclass(frozen=True)
class Completion:
    """What the debrief gives an online participant to prove they finished."""

    code: str
    url: str
    redirect: bool
    mturk: MTurkSubmission | None = None


def linked_study(name: str) -> Study:
    """The study whose `[online] link = true`; NoStudyLink for any other name."""
    if len(name) > MAX_STUDY_NAME:
        raise NoStudyLink("There is no study at this link.")
    try:
        study = load_study(name)
    except NoStudyFile as error:
        raise NoStudyLink("There is no study at this link.") from error
    except StudyFileError as error:  # the file is there and broken: say so, on both sides
        events.error("study %s cannot be opened by its link: %s", name, error)
        raise StudyUnavailable(
            "This study cannot be opened at the moment: its settings have a problem the "
            "experimenter has to fix. Please try again later, or write to the experimenter."
        ) from error
    if not study.online.link:
        raise NoStudyLink("This study is not open to online recruitment.")
    return study


def returning_participant(session: Session, study: Study, recruit: Recruit) -> Participant | None:
    if recruit.recruitment_id is None:
        return None
    return session.scalars(
        select(Participant)
        .join(Recruitment, Recruitment.participant_id == Participant.id)
        .where(
            Recruitment.study == study.name,
            Recruitment.source == recruit.source,
            Recruitment.recruitment_id == recruit.recruitment_id,
        )
    ).first()


def record_return(session: Session, participant: Participant, recruit: Recruit) -> None:
    """Keep a return visit's own ids (a new SESSION_ID) beside the first visit's.

    Only ids not yet on record make a row: a reload, or a client replaying the
    link, carries nothing new, and storing it would let one URL grow the table
    without bound.
    """
    ids = (recruit.recruiter_study_id, recruit.recruiter_session_id)
    first = session.scalars(
        select(Recruitment).where(Recruitment.participant_id == participant.id)
    ).first()
    if first is not None and (first.recruiter_study_id, first.recruiter_session_id) == ids:
        return
    seen = session.scalar(
        select(ReturnVisit.id).where(
            ReturnVisit.participant_id == participant.id,
            ReturnVisit.recruiter_study_id.is_not_distinct_from(ids[0]),
            ReturnVisit.recruiter_session_id.is_not_distinct_from(ids[1]),
        )
    )
    if seen is not None:
        return
    session.add(
        ReturnVisit(
            participant_id=participant.id,
            recruiter_study_id=recruit.recruiter_study_id,
            recruiter_session_id=recruit.recruiter_session_id,
        )
    )
    session.commit()


def enrol_or_resume(session: Session, study: Study, recruit: Recruit) -> Participant:
    """The participant this visit belongs to, enrolled and committed.

    Two first visits with one id racing each other both try to insert; the
    unique (study, source, recruitment_id) constraint lets one win, and the
    loser's whole transaction (participant, enrolment) is rolled back before
    it resumes the winner.
    """
    found = returning_participant(session, study, recruit)
    if found is not None:
        record_return(session, found, recruit)
        return found
    _check_anonymous(study, recruit)
    # Counted under the assignment lock, so two last arrivals cannot both take the last place.
    hold_assignment_lock(session)
    _check_room(session, study)
    try:
        participant = Participant()
        session.add(participant)
        session.flush()
        session.add(
            Recruitment(
                participant_id=participant.id,
                study=study.name,
                source=recruit.source,
                recruitment_id=recruit.recruitment_id,
                recruiter_study_id=recruit.recruiter_study_id,
                recruiter_session_id=recruit.recruiter_session_id,
                submit_to=recruit.submit_to,
            )
        )
        session.flush()
        assign_cell(session, participant, study=study.name)
        session.commit()
    except IntegrityError:
        session.rollback()
        found = returning_participant(session, study, recruit)
        if found is None:
            raise
        return found
    return participant


def mturk_submission(study: Study, recruit: Recruit) -> MTurkSubmission | None:
    """The externalSubmit form for an MTurk worker; the answer may post there (form-action),
    and follow MTurk's redirect to another of its hosts.

    `submit_to` was checked when the worker started; it is checked again against
    the study file as it is now, so a file that stops naming a server stops the posts.
    """
    submit_to, assignment = recruit.submit_to, recruit.recruiter_session_id
    if recruit.source != "mturk" or not submit_to or not assignment:
        return None
    if submit_to not in study.online.mturk_submit_origins:
        return None
    allow_form_action_to(dict.fromkeys([submit_to, *study.online.mturk_form_action]))
    fields = {"assignmentId": assignment}
    if study.online.completion_code:
        fields["completionCode"] = study.online.completion_code
    return MTurkSubmission(f"{submit_to}/mturk/externalSubmit", fields)


def completion_for(session: Session, participant: Participant, study: Study) -> Completion | None:
    """The completion code and URL (and MTurk's form) for a participant of the study link."""
    online = study.online
    recruit = recruit_of(session, participant)
    if recruit is None:
        return None
    mturk = mturk_submission(study, recruit)
    if not (online.completion_code or online.completion_url or mturk):
        return None
    url = fill_placeholders(online.completion_url, recruitment_parameters(recruit))
    return Completion(online.completion_code, url, online.redirect and mturk is None, mturk)


@bp.get("/<study_name>")
def join(study_name: str) -> Response | tuple[str, int] | str:
    """A returning id resumes; anyone else gets the first page, which checks the device.

    Nothing is written for a new visitor: a link preview, a crawler or a bare
    visit enrols no one and takes no cell; enrolment waits for the first page's
    Start. A returning id's visit is recorded, with the ids it carried.
    """
    framed = request.headers.get("Sec-Fetch-Dest") == "iframe"
    try:
        study = linked_study(study_name)
        allow_framing_by(study.online.mturk_frame_origins)
        recruit = recruit_from(request.args)
        check_submit_to(recruit, study.online.mturk_submit_origins)
        found = returning_participant(get_session(), study, recruit)
        if found is not None and not framed:
            record_return(get_session(), found, recruit)
            return redirect(url_for("study.enter", token=found.token))
        finished = found is not None and _finished(get_session(), found)
        _check_anonymous(study, recruit)
        if found is None:
            _check_room(get_session(), study)
    except StudyFull as full:
        return _study_full(study, str(full), recruit)
    except HitPreview as preview:
        return render_template("study/join_preview.html", message=str(preview), study=study)
    except NoStudyLink as refusal:
        return render_template("study/join_refused.html", message=str(refusal)), 404
    except StudyUnavailable as refusal:
        return render_template("study/join_refused.html", message=str(refusal)), 503
    except RecruitmentError as refusal:
        return render_template("study/join_refused.html", message=str(refusal)), 400
    return render_template(
        "study/join.html",
        study=study,
        requirements=study.requirements,
        parameters=recruitment_parameters(recruit),
        action=url_for("join.start", study_name=study.name),
        framed=framed,
        finished=finished,
        own_window=request.full_path,
        status_url=url_for("join.hit_status", study_name=study.name)
        + "?"
        + urlencode(list(request.args.items(multi=True))),
    )


@bp.get("/<study_name>/status")
def hit_status(study_name: str) -> ResponseReturnValue:
    """Whether the visitor of these recruitment ids has finished: MTurk's frame of the link
    asks while the study runs in its own window, to stop offering it once it is done."""
    try:
        study = linked_study(study_name)
        recruit = recruit_from(request.args)
        check_submit_to(recruit, study.online.mturk_submit_origins)
    except RecruitmentError as refusal:
        status = {NoStudyLink: 404, StudyUnavailable: 503}.get(type(refusal), 400)
        return {"error": str(refusal)}, status
    found = returning_participant(get_session(), study, recruit)
    return {"finished": found is not None and _finished(get_session(), found)}


def _finished(session: Session, participant: Participant) -> bool:
    """Done with the study: completed, or ended in any other way (nothing left to open)."""
    return participant_status(session, participant) not in ("in_progress", "not_started")


@bp.post("/<study_name>")
def start(study_name: str) -> ResponseReturnValue:
    """Start on the first page: enrol and go to consent, or record a screen-out and say why."""
    session = get_session()
    try:
        study = linked_study(study_name)
        recruit = recruit_from(request.form)
        check_submit_to(recruit, study.online.mturk_submit_origins)
        _check_anonymous(study, recruit)
        measured = measurement_from(request.form)
    except NoStudyLink as refusal:
        return render_template("study/join_refused.html", message=str(refusal)), 404
    except StudyUnavailable as refusal:
        return render_template("study/join_refused.html", message=str(refusal)), 503
    except RecruitmentError as refusal:
        return render_template("study/join_refused.html", message=str(refusal)), 400
    if returning_participant(session, study, recruit) is None:
        # The cap before the per-client limit: a full study takes no one, however long one waits.
        try:
            _check_room(session, study)
        except StudyFull as full:
            session.rollback()
            return _study_full(study, str(full), recruit)
        refused = enrolment_refusal(session)
        if refused is not None:
            return refused
        reasons = shortfalls(study.requirements, measured)
        if reasons:
            record_screen_out(session, study, recruit, measured, reasons)
            session.commit()
            return render_template(
                "study/screened_out.html", reasons=reasons, leave=screen_out_link(study, recruit)
            )
    try:
        participant = enrol_or_resume(session, study, recruit)
    except StudyFull as full:
        session.rollback()
        return _study_full(study, str(full), recruit)
    return redirect(url_for("study.enter", token=participant.token))


def _study_full(study: Study, message: str, recruit: Recruit) -> str:
    """The page for a new visitor once the study has reached its target; nothing recorded.

    They did nothing wrong and took no place: the recruitment site should give the
    place to someone else, so they are asked to return the submission (Prolific's
    word), with the study's return code and URL; a screen-out would count against them.
    """
    session = get_session()
    record_turned_away(session, study.name, recruit)
    session.commit()
    return render_template(
        "study/join_full.html",
        study=study,
        message=message,
        leave=return_link(study, recruit),
    )


def _check_anonymous(study: Study, recruit: Recruit) -> None:
    if recruit.recruitment_id is None and not study.online.anonymous:
        raise RecruitmentError(
            "This link needs the id your recruitment site adds to it. "
            "Please open the study from the site's page."
        )
