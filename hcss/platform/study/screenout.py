"""Turning a visitor away: what the first page measured, the screen-out row, the way back.

An online participant who cannot take part (a device that falls short of
`[requirements]`, or declining consent) should not be left on a dead end: the
recruitment site expects a screen-out code or a return link, and the study
file's `[online] screenout_code` and `screenout_url` give them.
"""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy import select
from sqlalchemy.orm import Session
from werkzeug.datastructures import MultiDict

from hcss.platform.models import Participant, Recruitment, ScreenOut
from hcss.platform.study.online import Recruit, RecruitmentError
from hcss.platform.study.requirements import FEATURES, MAX_PIXELS, Measurement, shortfalls
from hcss.platform.study.studyfile import Study

__all__ = [
    "Leave",
    "measurement_from",
    "record_screen_out",
    "screen_out_for",
    "screen_out_link",
    "shortfalls",
]


@dataclass(frozen=True)
class Leave:
    """The screen-out code to enter at the recruitment site, and its return address."""

    code: str
    url: str


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


def screen_out_link(study: Study) -> Leave | None:
    """The study's screen-out code and URL, when its file gives either."""
    online = study.online
    if not (online.screenout_code or online.screenout_url):
        return None
    return Leave(online.screenout_code, online.screenout_url)


def screen_out_for(session: Session, participant: Participant, study: Study) -> Leave | None:
    """The screen-out code and URL for a participant who came through the study link."""
    came_online = session.scalar(
        select(Recruitment.id).where(Recruitment.participant_id == participant.id)
    )
    return None if came_online is None else screen_out_link(study)
