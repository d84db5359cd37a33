"""One line on the server's terminal per participant event, for the experimenter watching it.

Enrolled, stage entered (and submitted or timed out), trial started and
ended, and errors: read from the rows as they are committed, not from calls
sprinkled through the study engine and the live runner. A listener on the
app's own session factory (`Database.sessions`, not every SQLAlchemy session
of the process) collects the rows each flush adds and logs them when the
transaction commits; a rolled-back request logs nothing, so the terminal
never shows an event the database does not hold. `create_app` installs it:
the server's log is the app's, not the console's (before issue 41 the
console's blueprint installed it on every session of the process, so every
live write ran console code).

The lines go to the ``hcss.events`` logger (Python logging); `hcss serve`
sends it to stderr. Participants are named by code, never by token.
"""

from __future__ import annotations

import logging
from typing import Any

from flask import Flask, got_request_exception, request
from sqlalchemy import event, select
from sqlalchemy.orm import Session

from hcss.platform.errors import database_away
from hcss.platform.models import Participant, StageEvent, StudyEnrolment, Trial, TrialStatusChange
from hcss.platform.models.vocabularies import TrialStatus

logger = logging.getLogger("hcss.events")
_PENDING = "hcss_event_lines"


def _code(session: Session, participant_id: int) -> str:
    """The participant's code, from the session's identity map or one small query."""
    known = session.identity_map.get(session.identity_key(Participant, participant_id))
    if known is not None:
        return str(known.code)
    code = session.connection().scalar(
        select(Participant.code).where(Participant.id == participant_id)
    )
    return code or f"participant #{participant_id}"


def _trial(session: Session, trial_id: int) -> tuple[str, str]:
    """(participant code, "trial M2") of a trial."""
    trial = session.identity_map.get(session.identity_key(Trial, trial_id))
    if trial is None:
        row = (
            session.connection()
            .execute(
                select(Trial.participant_id, Trial.kind, Trial.model).where(Trial.id == trial_id)
            )
            .first()
        )
        if row is None:
            return f"trial #{trial_id}", "trial"
        participant_id, kind, model = row
    else:
        participant_id, kind, model = trial.participant_id, trial.kind, trial.model
    return _code(session, participant_id), f"{kind} {model} (#{trial_id})"


def describe(session: Session, row: Any) -> str | None:
    """The terminal line for a new row, or None for rows that are not participant events."""
    if isinstance(row, Participant):
        flags = [flag for flag in ("pilot", "bot", "demo") if getattr(row, f"is_{flag}")]
        study = f"study {row.study}" if row.study else "default study"
        return f"{row.code} created ({', '.join([study, *flags])})"
    if isinstance(row, StudyEnrolment):
        how = "cell override" if row.override else f"{row.pool} pool"
        return f"{_code(session, row.participant_id)} enrolled: study {row.study}, cell {row.cell} ({how})"
    if isinstance(row, StageEvent):
        where = " ".join(
            part for part in (row.stage, row.model, row.step) if part and part != "form"
        )
        return f"{_code(session, row.participant_id)} stage {row.stage_index + 1} {where}: {row.kind.replace('_', ' ')}"
    if isinstance(row, TrialStatusChange):
        code, trial = _trial(session, row.trial_id)
        if row.status == TrialStatus.RUNNING:
            return f"{code} {trial} started"
        return f"{code} {trial} {row.status}" + (f" ({row.reason})" if row.reason else "")
    return None


def _collect(session: Session, _context: Any) -> None:
    lines = [line for row in session.new if (line := describe(session, row)) is not None]
    if lines:
        session.info.setdefault(_PENDING, []).extend(lines)


def _emit(session: Session) -> None:
    for line in session.info.pop(_PENDING, []):
        logger.info(line)


def _discard(session: Session, *_args: Any) -> None:
    session.info.pop(_PENDING, None)


def _request_failed(app: Flask, exception: BaseException, **_extra: Any) -> None:
    """A participant's request raised (the answer is a 500): say whose and where. A database
    away is no error of theirs: its 503 is logged as one line (hcss.platform.errors)."""
    token = (request.view_args or {}).get("token")
    if not isinstance(token, str) or database_away(exception):
        return
    try:
        with app.extensions["hcss_db"].session_scope() as session:
            code = session.scalar(select(Participant.code).where(Participant.token == token))
    except Exception:  # noqa: BLE001 - the database itself may be what failed
        code = None
    endpoint = request.endpoint or request.path
    logger.error(f"{code or 'unknown participant'} error on {endpoint}: {exception!r}")


def install(app: Flask) -> None:
    """Listen on the app's sessions, and on its failed requests (both idempotent)."""
    sessions = app.extensions["hcss_db"].sessions
    if not event.contains(sessions, "after_flush", _collect):
        event.listen(sessions, "after_flush", _collect)
        event.listen(sessions, "after_commit", _emit)
        event.listen(sessions, "after_rollback", _discard)
    got_request_exception.connect(_request_failed, app)
