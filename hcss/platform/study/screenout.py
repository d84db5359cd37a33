"""Turning a visitor away: what the first page measured, the screen-out row, the way back.

An online participant who cannot take part should not be left on a dead end:
the recruitment site expects a code or a link back, and which one says what
happened (Prolific sorts submissions by the code they end with). The study
file's `[online]` table gives one per outcome besides completion:

- screened out (a device short of `[requirements]`): `screenout_code`, `screenout_url`;
- declined consent: `declined_code`, `declined_url`; else the return code and URL, else
  the screen-out's (as studies did before there was either);
- the study was full: `full_code`, `full_url`; else the return code and URL;
- ended by the experimenter: `ended_code`, `ended_url`; else, as `ended_paid` decides,
  the completion code and URL (paid) or the return code and URL (returned);
- timed out (`[timeouts]`): `timeout_code`, `timeout_url`.

A returned outcome asks the visitor to return the submission. Each URL's
`{placeholders}` are filled with the visitor's recruitment ids.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from sqlalchemy import select
from sqlalchemy.orm import Session
from werkzeug.datastructures import MultiDict

from hcss.platform.models import Participant, Recruitment, ScreenOut
from hcss.platform.study.online import (
    Recruit,
    RecruitmentError,
    fill_placeholders,
    recruitment_parameters,
)
from hcss.platform.study.requirements import FEATURES, MAX_PIXELS, Measurement, shortfalls
from hcss.platform.study.studyfile import Study

__all__ = [
    "Leave",
    "leave_for",
    "outcome_link",
    "measurement_from",
    "recruit_of",
    "record_screen_out",
    "return_link",
    "screen_out_for",
    "screen_out_link",
    "shortfalls",
]

#: Why a visitor leaves without completing; each has its own code and URL.
Outcome = Literal["screened_out", "declined", "full", "ended", "timed_out"]


@dataclass(frozen=True)
class Leave:
    """The code to enter at the recruitment site and its address, for one outcome.

    `return_submission`: the visitor is asked to return the submission (the study
    was full, they declined, their session was ended unpaid) rather than to submit it.
    """

    code: str
    url: str
    outcome: Outcome = "screened_out"
    return_submission: bool = False


def _pixels(form: MultiDict[str, str], name: str) -> int:
    text = form.get(name, "")
    if not text.isascii() or not text.isdigit() or int(text) > MAX_PIXELS:
        raise RecruitmentError(
            "Your browser did not report its window size; please enable JavaScript and reload."
        )
    return int(text)


def measurement_from(form: MultiDict[str, str]) -> Measurement:
    """The first page's measurement from its form; RecruitmentError (a 400) when malformed."""
    mobile = form.get("mobile", "")
    if mobile not in ("0", "1"):
        raise RecruitmentError(
            "Your browser did not report what device it runs on; please enable JavaScript."
        )
    missing = tuple(name for name in form.get("missing", "").split(",") if name)
    if any(name not in FEATURES for name in missing):
        raise RecruitmentError("The page's check of your browser came back garbled; please reload.")
    return Measurement(
        width=_pixels(form, "width"),
        height=_pixels(form, "height"),
        mobile=mobile == "1",
        missing=missing,
    )


def record_screen_out(
    session: Session, study: Study, recruit: Recruit, measured: Measurement, reasons: list[str]
) -> ScreenOut:
    row = ScreenOut(
        study=study.name,
        source=recruit.source,
        recruitment_id=recruit.recruitment_id,
        width=measured.width,
        height=measured.height,
        mobile=measured.mobile,
        missing=",".join(measured.missing),
        reasons=" ".join(reasons)[:1000],
    )
    session.add(row)
    session.flush()
    return row


def _leave(
    code: str, url: str, outcome: Outcome, recruit: Recruit | None, *, returned: bool = False
) -> Leave | None:
    if not (code or url):
        return None
    filled = fill_placeholders(url, recruitment_parameters(recruit)) if url and recruit else url
    return Leave(code, filled, outcome, returned)


def outcome_link(study: Study, recruit: Recruit | None, outcome: Outcome) -> Leave | None:
    """The code and URL of one outcome, after the study file's fallbacks (module docstring);
    a returned outcome always gets a Leave, for the request to return. Without `recruit`
    the URL is the file's, its placeholders unfilled (the console's table shows it)."""
    online = study.online
    if outcome == "screened_out":
        return _leave(online.screenout_code, online.screenout_url, outcome, recruit)
    if outcome == "timed_out":
        return _leave(online.timeout_code, online.timeout_url, outcome, recruit)
    if outcome == "ended" and online.ended_paid:
        own = _leave(online.ended_code, online.ended_url, outcome, recruit)
        return own or _leave(online.completion_code, online.completion_url, outcome, recruit)
    own_code, own_url = {
        "declined": (online.declined_code, online.declined_url),
        "full": (online.full_code, online.full_url),
        "ended": (online.ended_code, online.ended_url),
    }[outcome]
    found = _leave(own_code, own_url, outcome, recruit, returned=True) or _leave(
        online.return_code, online.return_url, outcome, recruit, returned=True
    )
    if found is None and outcome == "declined":
        found = _leave(online.screenout_code, online.screenout_url, outcome, recruit)
    return found or Leave("", "", outcome, return_submission=True)


def screen_out_link(study: Study, recruit: Recruit) -> Leave | None:
    """The study's screen-out code and URL, when its file gives either."""
    return outcome_link(study, recruit, "screened_out")


def return_link(study: Study, recruit: Recruit) -> Leave:
    """The way back for a visitor who found the study full; always a Leave."""
    found = outcome_link(study, recruit, "full")
    assert found is not None
    return found


def recruit_of(session: Session, participant: Participant) -> Recruit | None:
    """The ids a participant came through the study link with (None: made in the console)."""
    row = session.scalars(
        select(Recruitment).where(Recruitment.participant_id == participant.id)
    ).first()
    if row is None:
        return None
    return Recruit(
        row.source,
        row.recruitment_id,
        row.recruiter_study_id,
        row.recruiter_session_id,
        submit_to=row.submit_to,
    )


def leave_for(session: Session, participant: Participant, study: Study, why: str) -> Leave | None:
    """The way back for a participant of the study link who stops: `why` is the session's
    state or status (declined, aborted, timed_out); None for one created in the console."""
    recruit = recruit_of(session, participant)
    if recruit is None:
        return None
    outcome: Outcome = (
        "timed_out" if why == "timed_out" else "declined" if why == "declined" else "ended"
    )
    return outcome_link(study, recruit, outcome)


def screen_out_for(session: Session, participant: Participant, study: Study) -> Leave | None:
    """The way back for a participant of the study link who declined consent."""
    return leave_for(session, participant, study, "declined")
