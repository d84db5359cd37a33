"""Whether an enrolment's study file is still there, and still the one it enrolled in.

Each enrolment keeps the sha256 of the study file it was made with
(`StudyEnrolment.study_digest`). A file removed, renamed or edited after
participants enrolled would otherwise make their pages fail (500) or move
them silently onto a different stage sequence. Such participants are held
instead: their pages say so (503, with the reason) and nothing is written,
the console shows them as held, and `hcss serve` lists the studies at start.
Put the file back as it was (the digest in the export names it) to release
them; an edit meant for new participants belongs in a new study file.

Held, not kept on their version, because only the digest is stored: the
file itself is not, so no other version can be rebuilt.
"""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session
from werkzeug.exceptions import ServiceUnavailable

from hcss.platform.models import StudyEnrolment
from hcss.platform.study.files import StudyFileError, study_names
from hcss.platform.study.studyfile import Study, load_study


class StudyHeld(ServiceUnavailable):
    """The participant's study file is missing or changed since they enrolled."""

    def __init__(self, reason: str) -> None:
        super().__init__(
            f"{reason} Your answers so far are saved, and the experimenter can see "
            "this. Please contact them; this page works again once they have put it right."
        )
        self.reason = reason


def enrolled_study(enrolment: StudyEnrolment) -> Study:
    """The enrolment's study, or StudyHeld when its file is missing or not the same file."""
    try:
        study = load_study(enrolment.study)
    except StudyFileError as error:
        raise StudyHeld(f"The study's file ({enrolment.study}) cannot be read.") from error
    if enrolment.study_digest and study.digest != enrolment.study_digest:
        raise StudyHeld(f"The study's file ({enrolment.study}) has changed since you started.")
    return study


def study_problems(session: Session) -> list[str]:
    """One line per study file that cannot be loaded or differs from what participants
    enrolled in (for `hcss serve` at start and the console's page)."""
    problems = []
    for name in study_names():
        try:
            load_study(name)
        except StudyFileError as error:
            problems.append(f"study {name} cannot be loaded: {error}")
    enrolled = session.execute(
        select(StudyEnrolment.study, StudyEnrolment.study_digest).distinct()
    ).all()
    for name, digest in sorted(enrolled):
        try:
            study = load_study(name)
        except StudyFileError:
            problems.append(f"study {name}: its file is missing; its participants are held")
            continue
        if digest and study.digest != digest:
            problems.append(
                f"study {name}: the file changed since some participants enrolled "
                f"(digest {digest[:12]}); they are held"
            )
    return list(dict.fromkeys(problems))
